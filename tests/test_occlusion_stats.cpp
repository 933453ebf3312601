// SPDX-License-Identifier: MIT
// occlusion_stats: the per-pixel accumulation of weighted visibility and occluder distances
// (FORMULAS.md §1.2, §1.3, §1.12, §1.16), merge(), slopes(), and exact distances in the analytic scene.

#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <span>
#include <vector>

#include <glm/geometric.hpp>

#include <aaf/area_light.hpp>
#include <aaf/occlusion_stats.hpp>
#include <aaf/sampler.hpp>
#include <aaf/tracer.hpp>

#include "support/helpers.hpp"
#include "support/analytic_scene.hpp"

namespace {

using aaf_test::span;

template <class T>
bool same(const aaf::occlusion_stats<T>& a, const aaf::occlusion_stats<T>& b) {
    const auto eq = [](T x, T y) { return x == y || (std::isnan(x) && std::isnan(y)); };
    return eq(a.visible_weight, b.visible_weight) && eq(a.total_weight, b.total_weight) && a.samples == b.samples &&
           a.occluded == b.occluded && eq(a.d1, b.d1) && eq(a.d2min, b.d2min) && eq(a.d2max, b.d2max);
}

template <class T>
struct sample {
    T weight, d1, length;
    aaf::occluder_span<T> hit;
};

}  // namespace

TEMPLATE_TEST_CASE("add_sample arithmetic", "[stats]", float, double) {
    using T = TestType;
    aaf::occlusion_stats<T> s;
    CHECK(s.samples == 0u);
    CHECK_FALSE(s.has_light());
    CHECK_FALSE(s.has_occluder());
    // Receiver at d1 = 4 from the light plane, segment of length 8, hits at t = 2 and t = 6:
    // d2 = d1·(L − t)/L → nearest (t = 2) gives d2max = 4·6/8 = 3, farthest (t = 6) gives d2min = 4·2/8 = 1.
    s.add_sample(T(2), T(4), T(8), span<T>(T(2), T(6)));
    CHECK(s.samples == 1u);
    CHECK(s.occluded == 1u);
    CHECK(s.total_weight == T(2));
    CHECK(s.visible_weight == T(0));
    CHECK(s.d1 == T(4));
    CHECK(s.d2max == T(3));
    CHECK(s.d2min == T(1));
    CHECK(s.visibility() == T(0));
    // A miss of weight 1.
    s.add_sample(T(1), T(4), T(8), aaf::occluder_span<T>{});
    CHECK(s.samples == 2u);
    CHECK(s.occluded == 1u);
    CHECK(s.total_weight == T(3));
    CHECK(s.visible_weight == T(1));
    CHECK(s.visibility() == Approx(1.0 / 3.0));
    // A single hit (nearest == farthest) at t = 4 on a segment of length 10: d2 = 4·6/10 = 2.4, inside [1, 3].
    s.add_sample(T(0.5), T(4), T(10), span<T>(T(4), T(4)));
    CHECK(s.d2max == T(3));
    CHECK(s.d2min == T(1));
    CHECK(s.occluded == 2u);
    CHECK(s.total_weight == T(3.5));
    // A hit close to the receiver widens d2max; one close to the light lowers d2min.
    s.add_sample(T(1), T(4), T(8), span<T>(T(1), T(1)));   // d2 = 4·7/8 = 3.5
    s.add_sample(T(1), T(4), T(8), span<T>(T(7), T(7)));   // d2 = 4·1/8 = 0.5
    CHECK(s.d2max == T(3.5));
    CHECK(s.d2min == T(0.5));
    CHECK(s.has_occluder());
    CHECK(s.has_light());
    // slopes: s1 = d1/d2min − 1 = 7, s2 = d1/d2max − 1 = 4/3.5 − 1 = 1/7.
    const auto sl = aaf::slopes(s);
    CHECK(sl.s1 == Approx(7.0));
    CHECK(sl.s2 == Approx(1.0 / 7.0));
    // Each sample's slope is t/(L − t): here the extremes are 7/1 and 1/7.
}

TEMPLATE_TEST_CASE("no occluder and no light", "[stats]", float, double) {
    using T = TestType;
    aaf::occlusion_stats<T> lit;
    for (int i = 0; i < 9; ++i) lit.add_sample(T(0.25) + T(i), T(3), T(3.5), aaf::occluder_span<T>{});
    CHECK(lit.visibility() == T(1));
    CHECK(lit.has_light());
    CHECK_FALSE(lit.has_occluder());
    CHECK(lit.occluded == 0u);
    CHECK(lit.samples == 9u);
    const auto s = aaf::slopes(lit);
    CHECK(s.s1 == T(0));
    CHECK(s.s2 == std::numeric_limits<T>::infinity());
    CHECK_FALSE(s.has_occluder());

    // Every light point below the horizon: the samples are drawn (weight 0) but nothing counts.
    aaf::occlusion_stats<T> dark;
    for (int i = 0; i < 9; ++i) dark.add_sample(T(0), T(3), T(0), aaf::occluder_span<T>{});
    CHECK(dark.samples == 9u);
    CHECK(std::isnan(dark.visibility()));
    CHECK_FALSE(dark.has_light());
    CHECK_FALSE(dark.has_occluder());
    CHECK_FALSE(aaf::slopes(dark).has_occluder());
}

TEMPLATE_TEST_CASE("failed and invalid samples are counted but contribute nothing", "[stats]", float, double) {
    using T = TestType;
    const T nan = std::numeric_limits<T>::quiet_NaN();
    const T inf = std::numeric_limits<T>::infinity();
    aaf::occlusion_stats<T> base;
    base.add_sample(T(1), T(4), T(8), span<T>(T(2), T(6)));
    base.add_sample(T(1), T(4), T(8), aaf::occluder_span<T>{});
    const std::vector<sample<T>> bad = {
        {T(1), T(4), T(8), span<T>(nan, nan)},   // failed sample (tracer.hpp: NaN = failed)
        {T(1), T(4), T(8), span<T>(nan, T(5))},
        {T(1), T(4), T(8), span<T>(T(5), nan)},  // NaN anywhere in the span
        {T(1), T(4), T(8), span<T>(nan, -inf)},
        {T(0), T(4), T(8), span<T>(T(2), T(6))},     // zero weight
        {T(-1), T(4), T(8), span<T>(T(2), T(6))},    // negative weight
        {T(-1), T(4), T(8), aaf::occluder_span<T>{}},
        {nan, T(4), T(8), aaf::occluder_span<T>{}},  // NaN weight
        {inf, T(4), T(8), aaf::occluder_span<T>{}},  // infinite weight
        {T(1), nan, T(8), span<T>(T(2), T(6))},      // NaN d1
        {T(1), inf, T(8), aaf::occluder_span<T>{}},  // infinite d1
        {T(1), T(4), T(0), aaf::occluder_span<T>{}},  // zero length
        {T(1), T(4), T(-8), span<T>(T(2), T(6))},    // negative length
        {T(1), T(4), nan, span<T>(T(2), T(6))},      // NaN length
        {T(1), T(4), inf, aaf::occluder_span<T>{}},  // infinite length
    };
    for (std::size_t i = 0; i < bad.size(); ++i) {
        INFO("case " << i);
        aaf::occlusion_stats<T> s = base;
        s.add_sample(bad[i].weight, bad[i].d1, bad[i].length, bad[i].hit);
        aaf::occlusion_stats<T> expected = base;
        expected.samples += 1;
        CHECK(same(s, expected));
    }
}

TEMPLATE_TEST_CASE("hit distances are clamped into [0, L]", "[stats]", float, double) {
    using T = TestType;
    const T inf = std::numeric_limits<T>::infinity();
    struct clamp_case {
        aaf::occluder_span<T> hit;
        T d2max, d2min;
    };
    // d1 = 4, L = 8.
    const clamp_case cases[] = {
        {span<T>(T(-1), T(2)), T(4), T(3)},    // t < 0 → contact: d2max = d1
        {span<T>(T(2), T(12)), T(3), T(0)},    // t > L → at the light: d2min = 0
        {span<T>(T(-3), T(-1)), T(4), T(4)},   // both behind the origin → contact
        {span<T>(T(10), T(12)), T(0), T(0)},   // both beyond the light → at the light
        {span<T>(-inf, inf), T(4), T(0)},
        {span<T>(T(0), T(8)), T(4), T(0)},
    };
    for (const clamp_case& c : cases) {
        INFO("hit " << c.hit.nearest << " .. " << c.hit.farthest);
        aaf::occlusion_stats<T> s;
        s.add_sample(T(1), T(4), T(8), c.hit);
        CHECK(s.occluded == 1u);
        CHECK(s.d2max == c.d2max);
        CHECK(s.d2min == c.d2min);
        CHECK(s.d2min <= s.d2max);
        CHECK(s.d2max <= s.d1);
        const auto sl = aaf::slopes(s);
        CHECK(std::isfinite(sl.s1));
        CHECK(sl.s1 >= sl.s2);
        CHECK(sl.s2 >= T(0));
    }
}

TEMPLATE_TEST_CASE("merge is associative, commutative and equals one record of all samples", "[stats]", float, double) {
    using T = TestType;
    std::mt19937 rng(20121128u);
    std::uniform_real_distribution<double> u01(0.0, 1.0);
    for (int trial = 0; trial < 50; ++trial) {
        const T d1 = static_cast<T>(1 + 4 * u01(rng));
        std::vector<sample<T>> all;
        const int count = 1 + static_cast<int>(u01(rng) * 40);
        for (int i = 0; i < count; ++i) {
            const T length = static_cast<T>(static_cast<double>(d1) * (1 + u01(rng)));
            const T weight = u01(rng) < 0.1 ? T(0) : static_cast<T>(u01(rng));
            aaf::occluder_span<T> hit{};
            if (u01(rng) < 0.5) {
                const T a = static_cast<T>(u01(rng) * static_cast<double>(length));
                const T b = static_cast<T>(u01(rng) * static_cast<double>(length));
                hit = span<T>(std::min(a, b), std::max(a, b));
            }
            all.push_back({weight, d1, length, hit});
        }
        // Split into three consecutive parts A, B, C (possibly empty).
        const std::size_t i1 = static_cast<std::size_t>(u01(rng) * static_cast<double>(all.size() + 1));
        const std::size_t i2 = i1 + static_cast<std::size_t>(u01(rng) * static_cast<double>(all.size() - i1 + 1));
        aaf::occlusion_stats<T> one, a, b, c;
        for (std::size_t i = 0; i < all.size(); ++i) {
            const sample<T>& x = all[i];
            one.add_sample(x.weight, x.d1, x.length, x.hit);
            (i < i1 ? a : i < i2 ? b : c).add_sample(x.weight, x.d1, x.length, x.hit);
        }
        const auto left = aaf::merge(aaf::merge(a, b), c);
        const auto right = aaf::merge(a, aaf::merge(b, c));
        const auto swapped = aaf::merge(c, aaf::merge(b, a));
        for (const auto* m : {&left, &right, &swapped}) {
            INFO("trial " << trial);
            CHECK(m->samples == one.samples);
            CHECK(m->occluded == one.occluded);
            CHECK(m->d2min == one.d2min);  // min / max are exact
            CHECK(m->d2max == one.d2max);
            CHECK(m->total_weight == Approx(one.total_weight).epsilon(1e-5).margin(1e-6));
            CHECK(m->visible_weight == Approx(one.visible_weight).epsilon(1e-5).margin(1e-6));
            if (one.has_light()) {
                CHECK(m->d1 == one.d1);
                CHECK(m->visibility() == Approx(one.visibility()).epsilon(1e-5).margin(1e-6));
            }
            CHECK(m->has_occluder() == one.has_occluder());
        }
        CHECK(same(aaf::merge(a, b), aaf::merge(b, a)));  // two-record merge: IEEE addition commutes exactly
        // The empty record is the identity.
        CHECK(same(aaf::merge(one, aaf::occlusion_stats<T>{}), one));
        CHECK(same(aaf::merge(aaf::occlusion_stats<T>{}, one), one));
    }
}

TEMPLATE_TEST_CASE("slopes() follows the paper and its guards", "[stats]", float, double) {
    using T = TestType;
    const auto record = [](T d1, T d2min, T d2max) {
        aaf::occlusion_stats<T> s;
        s.samples = s.occluded = 1;
        s.total_weight = T(1);
        s.d1 = d1;
        s.d2min = d2min;
        s.d2max = d2max;
        return s;
    };
    // s1 = d1/d2min − 1, s2 = d1/d2max − 1 (FORMULAS.md §1.2).
    auto s = aaf::slopes(record(T(6), T(2), T(4)));
    CHECK(s.s1 == Approx(2.0));
    CHECK(s.s2 == Approx(0.5));
    CHECK(s.has_occluder());
    // Contact: d2max = d1 → s2 = 0.
    s = aaf::slopes(record(T(6), T(2), T(6)));
    CHECK(s.s2 == T(0));
    // Occluder at the light: capped at max_slope.
    s = aaf::slopes(record(T(6), T(0), T(3)), T(50));
    CHECK(s.s1 == Approx(50.0));
    CHECK(s.s2 == Approx(1.0));
    s = aaf::slopes(record(T(6), T(0), T(0)), T(50));
    CHECK(s.s1 == Approx(50.0));
    CHECK(s.s2 == Approx(50.0));
    // Receiver on the light plane or a non-finite d1: no slopes.
    CHECK_FALSE(aaf::slopes(record(T(0), T(0), T(0))).has_occluder());
    CHECK_FALSE(aaf::slopes(record(std::numeric_limits<T>::infinity(), T(1), T(2))).has_occluder());
    CHECK_FALSE(aaf::slopes(record(std::numeric_limits<T>::quiet_NaN(), T(1), T(2))).has_occluder());
}

// ---------------------------------------------------------------------------------------------------
// The analytic scene: a receiver point on y = 0 under occluders at heights h, light at height H.

namespace {

/// Traces `n` stratified light samples from p (no origin offset: the segment starts exactly at p) and
/// returns one record per occluded sample plus the pixel's record.
template <class T>
struct traced {
    std::vector<aaf::occlusion_stats<T>> occluded_samples;
    aaf::occlusion_stats<T> pixel;
};

template <class T>
traced<T> trace_point(const aaf_test::analytic_scene<T>& sc, const glm::vec<3, T>& p, std::uint32_t n) {
    const aaf::area_light<T> light = sc.area_light();
    std::vector<glm::vec<2, T>> uv(n);
    aaf::generate_samples<T>(aaf::sample_pattern::stratified, aaf::sample_key{3, 5, 0, 0, 0}, uv);
    const aaf_test::span_tracer<T> tracer{&sc};
    traced<T> out;
    const T d1 = light.plane_distance(p);
    for (const auto& q : uv) {
        const glm::vec<3, T> y = light.point(q.x, q.y);
        const glm::vec<3, T> to = y - p;
        const T len = glm::length(to);
        const aaf::shadow_segment<T> seg{p, to / len, len};
        const aaf::occluder_span<T> hit = aaf::detail::trace_one<T>(tracer, seg);
        out.pixel.add_sample(T(1), d1, len, hit);
        if (hit.hit()) {
            aaf::occlusion_stats<T> one;
            one.add_sample(T(1), d1, len, hit);
            out.occluded_samples.push_back(one);
        }
    }
    return out;
}

}  // namespace

TEMPLATE_TEST_CASE("analytic scene: one occluder gives d2 = H - h exactly", "[stats][analytic]", float, double) {
    using T = TestType;
    const T eps = std::numeric_limits<T>::epsilon();
    for (T h : {T(0.5), T(1), T(2.25)}) {
        INFO("occluder height " << h);
        aaf_test::analytic_scene<T> sc;  // light at H = 3
        sc.occluders = {{T(-0.6), T(0.6), T(-0.3), T(0.3), h}};
        const T H = sc.light.y;
        // Points under the occluder and in its penumbra.
        for (const glm::vec<3, T>& p : {glm::vec<3, T>(0, 0, 0), glm::vec<3, T>(T(0.1), 0, T(0.5)),
                                         glm::vec<3, T>(T(-0.7), 0, T(0.2)), glm::vec<3, T>(T(0.3), 0, T(-0.4))}) {
            const traced<T> t = trace_point(sc, p, 64);
            REQUIRE_FALSE(t.occluded_samples.empty());
            CHECK(t.pixel.d1 == H);
            // Exact up to the rounding of a few float operations (the measured worst case is 2 ulp).
            for (const auto& one : t.occluded_samples) {
                CHECK(one.d1 == H);
                CHECK(std::abs(static_cast<double>(one.d2max) - static_cast<double>(H - h)) <=
                      4 * static_cast<double>(eps) * static_cast<double>(H - h));
                CHECK(std::abs(static_cast<double>(one.d2min) - static_cast<double>(H - h)) <=
                      4 * static_cast<double>(eps) * static_cast<double>(H - h));
            }
            const auto sl = aaf::slopes(t.pixel);
            const double expected = static_cast<double>(H) / static_cast<double>(H - h) - 1;
            CHECK(static_cast<double>(sl.s1) == Approx(expected).epsilon(32 * static_cast<double>(eps)));
            CHECK(static_cast<double>(sl.s2) == Approx(expected).epsilon(32 * static_cast<double>(eps)));
            // The visible fraction is estimated (stratified, 64 samples) close to the exact one.
            CHECK(static_cast<double>(t.pixel.visibility()) == Approx(sc.exact_visibility(p)).margin(0.05));
        }
    }
}

TEMPLATE_TEST_CASE("analytic scene: two occluders give d2min and d2max of the two depths", "[stats][analytic]", float, double) {
    using T = TestType;
    const T eps = std::numeric_limits<T>::epsilon();
    aaf_test::analytic_scene<T> sc;  // light at H = 3
    sc.occluders = {{T(-0.6), T(0.6), T(-0.3), T(0.3), T(1)}, {T(-0.2), T(1.0), T(-0.1), T(0.6), T(2)}};
    const glm::vec<3, T> p(T(0.2), 0, T(0.1));
    const traced<T> t = trace_point(sc, p, 100);
    // d2max from the low occluder (H − 1 = 2), d2min from the high one (H − 2 = 1).
    CHECK(std::abs(static_cast<double>(t.pixel.d2max) - 2.0) <= 4 * static_cast<double>(eps) * 2);
    CHECK(std::abs(static_cast<double>(t.pixel.d2min) - 1.0) <= 4 * static_cast<double>(eps) * 1);
    const auto sl = aaf::slopes(t.pixel);
    CHECK(static_cast<double>(sl.s1) == Approx(3.0 / 1.0 - 1).epsilon(32 * static_cast<double>(eps)));
    CHECK(static_cast<double>(sl.s2) == Approx(3.0 / 2.0 - 1).epsilon(32 * static_cast<double>(eps)));
    CHECK(static_cast<double>(t.pixel.visibility()) == Approx(sc.exact_visibility(p)).margin(0.05));
}

TEST_CASE("a record with NaN occluder distances gives no slopes rather than a contact", "[stats][limits]") {
    aaf::occlusion_stats<float> s;
    s.add_sample(1.0f, 2.0f, 2.0f, {1.0f, 1.0f});
    REQUIRE(aaf::slopes(s).has_occluder());
    s.d2min = std::numeric_limits<float>::quiet_NaN();
    CHECK_FALSE(aaf::slopes(s).has_occluder());
}

TEST_CASE("through gather_occlusion d2 is the occluder's true distance to the light plane", "[stats][gather]") {
    // d1 is measured from the offset ray origin, like t and L, so d2 = d1·(L − t)/L has no offset error.
    aaf_test::analytic_scene<float> sc;
    sc.width = sc.height = 8;
    sc.occluders = {{-5.0f, 5.0f, -5.0f, 5.0f, 1.0f}};  // covers everything: every sample occluded at height 1
    const aaf_test::analytic_gbuffer<float> gb(sc);
    aaf::image<aaf::occlusion_stats<float>> stats(8, 8);
    aaf::gather_occlusion(gb.view(), sc.area_light(), aaf_test::span_tracer<float>{&sc}, {}, 0, 9, stats.view());
    for (std::size_t i = 0; i < stats.size(); ++i) {
        const auto& s = stats.data()[i];
        REQUIRE(s.occluded == 9);
        CHECK(s.d2min == Approx(2.0f).epsilon(4e-7));  // light at 3, occluder at 1
        CHECK(s.d2max == Approx(2.0f).epsilon(4e-7));
    }
}

// Visibility-only samples (shadow_query::visibility, the adaptive pass's default).
#include <atomic>

#include <aaf/gather.hpp>

TEMPLATE_TEST_CASE("add_visibility_sample counts visibility and weight but leaves the distances alone", "[stats]", float, double) {
    using T = TestType;
    aaf::occlusion_stats<T> s;
    s.add_sample(T(2), T(3), T(4), span<T>(T(1), T(2)));  // one distance sample: d2 in [1.5, 2.25]
    const aaf::occlusion_stats<T> before = s;
    s.add_visibility_sample(T(0.5), false);
    s.add_visibility_sample(T(1.5), true);
    s.add_visibility_sample(T(0), false);                                   // zero weight: counted only
    s.add_visibility_sample(std::numeric_limits<T>::quiet_NaN(), true);     // invalid weight: counted only
    CHECK(s.samples == before.samples + 4);
    CHECK(s.total_weight == T(4));
    CHECK(s.visible_weight == T(0.5));
    CHECK(s.occluded == before.occluded);
    CHECK(s.d1 == before.d1);
    CHECK(s.d2min == before.d2min);
    CHECK(s.d2max == before.d2max);
    CHECK(aaf::slopes(s).s1 == aaf::slopes(before).s1);
    CHECK(aaf::slopes(s).s2 == aaf::slopes(before).s2);
    // Alone, blocked visibility samples give visibility 0 and still no slopes (no distances were seen).
    aaf::occlusion_stats<T> only;
    only.add_visibility_sample(T(1), true);
    CHECK(only.visibility() == T(0));
    CHECK_FALSE(only.has_occluder());
    CHECK_FALSE(aaf::slopes(only).has_occluder());
}

namespace {

/// Span and boolean queries over the analytic scene, counting the calls of each (thread-safe).
struct counting_scene_tracer {
    const aaf_test::analytic_scene<float>* scene;
    mutable std::atomic<std::uint64_t> spans{0}, booleans{0};
    aaf::occluder_span<float> occluder_span(const aaf::shadow_segment<float>& s) const { return ++spans, scene->span(s); }
    bool occluded(const aaf::shadow_segment<float>& s) const { return ++booleans, scene->span(s).hit(); }
};

}  // namespace

TEST_CASE("gather_visibility: same visibility as gather_occlusion under every weighting, distances untouched",
          "[stats][gather]") {
    aaf_test::analytic_scene<float> sc;
    sc.width = sc.height = 24;
    sc.occluders = {{-0.6f, 0.6f, -0.3f, 0.3f, 1.0f}, {0.2f, 1.4f, 0.1f, 0.5f, 1.8f}};
    const aaf_test::analytic_gbuffer<float> gb(sc);
    for (const auto weighting : {aaf::light_weighting::uniform, aaf::light_weighting::gaussian, aaf::light_weighting::irradiance}) {
        CAPTURE(static_cast<int>(weighting));
        aaf::sampling_settings ss;
        ss.weighting = weighting;
        // A first pass with distances, then the same second pass three ways.
        aaf::image<aaf::occlusion_stats<float>> first(sc.width, sc.height);
        aaf::gather_occlusion(gb.view(), sc.area_light(), aaf_test::span_tracer<float>{&sc}, ss, 0, 9, first.view());
        aaf::image<aaf::occlusion_stats<float>> dist = first, vis_bool = first, vis_span = first;
        const std::uint64_t r0 = aaf::gather_occlusion(gb.view(), sc.area_light(), aaf_test::span_tracer<float>{&sc}, ss, 1, 16, dist.view());
        counting_scene_tracer counting{&sc};
        const std::uint64_t r1 = aaf::gather_visibility(gb.view(), sc.area_light(), counting, ss, 1, 16, vis_bool.view());
        const std::uint64_t r2 = aaf::gather_visibility(gb.view(), sc.area_light(), aaf_test::span_tracer<float>{&sc}, ss, 1, 16, vis_span.view());
        CHECK(r0 == r1);
        CHECK(r0 == r2);
        CHECK(counting.booleans.load() == r1);  // the boolean query when there is one
        CHECK(counting.spans.load() == 0);
        std::size_t changed = 0;
        for (std::size_t i = 0; i < first.size(); ++i) {
            const auto &f = first.data()[i], &d = dist.data()[i], &b = vis_bool.data()[i], &s = vis_span.data()[i];
            for (const auto* v : {&b, &s}) {
                CHECK(v->visible_weight == d.visible_weight);  // same samples, same weights, same order
                CHECK(v->total_weight == d.total_weight);
                CHECK(v->samples == d.samples);
                CHECK(v->occluded == f.occluded);              // distances: the first pass's only
                CHECK(v->d1 == f.d1);
                CHECK(v->d2min == f.d2min);
                CHECK(v->d2max == f.d2max);
            }
            if (b.visible_weight != f.visible_weight || b.total_weight != f.total_weight) ++changed;
        }
        CHECK(changed > 0);
    }
}

namespace {

/// A tracer whose answer depends on a bit of the segment's direction (so a lane that computed a different
/// direction would change the statistics) and whose hits lie inside the segment.
template <class T>
struct direction_bit_tracer {
    [[nodiscard]] aaf::occluder_span<T> occluder_span(const aaf::shadow_segment<T>& s) const noexcept {
        std::uint64_t bits = 0;
        std::memcpy(&bits, &s.direction.y, sizeof(T));
        return (bits >> 5) & 1 ? aaf::occluder_span<T>{T(0.25) * s.length, T(0.75) * s.length} : aaf::occluder_span<T>{};
    }
};

/// The same answers through the batched form (gather_occlusion then collects several pixels' segments).
template <class T>
struct direction_bit_batch_tracer {
    void trace_batch(std::span<const aaf::shadow_segment<T>> segments, std::span<aaf::occluder_span<T>> out) const noexcept {
        for (std::size_t i = 0; i < segments.size(); ++i) out[i] = direction_bit_tracer<T>{}.occluder_span(segments[i]);
    }
};

}  // namespace

TEMPLATE_TEST_CASE("gather_occlusion's vector loops give the bits of the one-sample-at-a-time definition", "[stats][gather]",
                   float, double) {
    // draw_pixel computes every sample's light point, weight and segment in arrays (from a sample_plan shared
    // by the pixels of one count) and drops the untraceable ones afterwards; the plain definition does one
    // sample at a time with generate_samples and light_sample_frame::weight. Every pattern; one count for all
    // pixels (more than one vector of lanes, not a multiple of any width), the initial pass's 9, and counts
    // that change from pixel to pixel (an adaptive pass: the plan is set up again); a region off the origin.
    // With one count for all pixels and the uniform weighting, pixels are drawn in groups, one per vector lane
    // (23 columns: whole groups and a remainder drawn one at a time); some pixels are sky, inside the groups.
    using T = TestType;
    using vec3 = glm::vec<3, T>;
    const std::size_t w = 23, h = 11;
    aaf::image<vec3> positions(w, h), normals(w, h);
    aaf::image<T> pixel_size(w, h, T(0.01));
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) {
            positions(x, y) = vec3(T(0.1) * T(x), T(0.2 * u(rng)), T(0.1) * T(y));
            glm::dvec3 n(0.6 * u(rng), 1.0, 0.6 * u(rng));
            if (x % 7 == 2) n = -n;  // some receivers face away from the light
            normals(x, y) = x % 11 == 4 ? vec3(0) : vec3(glm::normalize(n));  // and some have no orientation
            if ((x + 2 * y) % 9 == 5) positions(x, y) = vec3(std::numeric_limits<T>::quiet_NaN());  // and some are sky
        }
    aaf::image<std::uint32_t> varying(w, h);
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) varying(x, y) = static_cast<std::uint32_t>((x * 7 + y * 3) % 41);  // 0 = skipped
    aaf::gbuffer<T> gb{positions.cview(), normals.cview(), pixel_size.cview()};
    gb.region = {5, 1000, 0, 0};
    for (const bool two_sided : {false, true}) {
        aaf::area_light<T> light{{T(0.4), T(1.5), T(0.2)}, {T(1), T(0), T(0)}, {T(0), T(0.3), T(1)}};
        light.two_sided = two_sided;
        for (const auto weighting : {aaf::light_weighting::uniform, aaf::light_weighting::gaussian, aaf::light_weighting::irradiance}) {
            for (const auto pattern : {aaf::sample_pattern::stratified, aaf::sample_pattern::regular_grid,
                                       aaf::sample_pattern::low_discrepancy}) {
                for (const std::uint32_t fixed : {37u, 9u, 0u}) {  // 0: the per-pixel counts of `varying`
                    aaf::sampling_settings s;
                    s.weighting = weighting;
                    s.pattern = pattern;
                    s.frame_seed = 3;
                    aaf::image<aaf::occlusion_stats<T>> stats(w, h, aaf::occlusion_stats<T>{}), batched(stats);
                    const auto counts = fixed ? aaf::const_image_view<std::uint32_t>{} : varying.cview();
                    aaf::gather_occlusion(gb, light, direction_bit_tracer<T>{}, s, 2, fixed, stats.view(), counts);
                    aaf::gather_occlusion(gb, light, direction_bit_batch_tracer<T>{}, s, 2, fixed, batched.view(), counts);
                    const aaf::light_sample_frame<T> frame(light, weighting);
                    for (std::size_t y = 0; y < h; ++y)
                        for (std::size_t x = 0; x < w; ++x) {
                            const std::uint32_t count = fixed ? fixed : varying(x, y);
                            if (!std::isfinite(positions(x, y).x)) {  // sky: no sample, the record untouched
                                REQUIRE(same(stats(x, y), aaf::occlusion_stats<T>{}));
                                REQUIRE(same(batched(x, y), aaf::occlusion_stats<T>{}));
                                continue;
                            }
                            std::vector<glm::vec<2, T>> uv(count);
                            const vec3 p = positions(x, y), n = aaf::detail::receiver_normal(normals(x, y), p, frame.center);
                            aaf::generate_samples<T>(pattern, aaf::pixel_key(gb.region, x, y, 2, s.light_index, s.frame_seed), uv);
                            const vec3 origin = aaf::shadow_ray_origin(p, n, frame.center, s.origin_offset);
                            const T d1 = std::abs(glm::dot(origin - light.corner, frame.normal));
                            aaf::occlusion_stats<T> expected{};
                            std::uint32_t skipped = 0;
                            for (const auto& xi : uv) {
                                const vec3 yl = light.point(xi.x, xi.y);
                                const T wgt = frame.weight(n, yl - p, yl);
                                const vec3 to = yl - origin;
                                const T len = glm::length(to);
                                if (!(wgt > T(0)) || !std::isfinite(wgt) || !(len > T(0)) || !std::isfinite(len)) {
                                    ++skipped;
                                    continue;
                                }
                                const aaf::shadow_segment<T> seg{origin, to * (T(1) / len), len};
                                expected.add_sample(wgt, d1, len, aaf::detail::trace_one<T>(direction_bit_tracer<T>{}, seg));
                            }
                            expected.samples += skipped;
                            INFO("two_sided " << two_sided << " weighting " << static_cast<int>(weighting) << " pattern "
                                              << aaf::to_string(pattern) << " count " << count << " pixel " << x << ", " << y);
                            REQUIRE(same(stats(x, y), expected));
                            REQUIRE(same(batched(x, y), expected));
                        }
                }
            }
        }
    }
}
