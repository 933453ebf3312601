// SPDX-License-Identifier: MIT
// tracer.hpp: the tracer contract's concepts (positive and negative), the bisecting adapter for
// boolean-only tracers, sanitising of reported hits, and dispatch over every tracer shape.

#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <span>
#include <vector>

#include <glm/geometric.hpp>

#include <aaf/area_light.hpp>
#include <aaf/tracer.hpp>

#include "support/helpers.hpp"
#include "support/analytic_scene.hpp"

// ---------------------------------------------------------------------------------------------------
// Concepts: the analytic scene's tracers, each through one shape of the contract.

namespace concept_checks {

using aaf::shadow_segment;
template <class T>
using span_t = aaf_test::span_tracer<T>;
template <class T>
using nearest_t = aaf_test::nearest_tracer<T>;
template <class T>
using batch_t = aaf_test::batch_tracer<T>;
template <class T>
using boolean_t = aaf_test::boolean_tracer<T>;

static_assert(aaf::span_tracer<span_t<float>, float>);
static_assert(aaf::span_tracer<span_t<double>, double>);
static_assert(aaf::nearest_tracer<nearest_t<float>, float>);
static_assert(aaf::nearest_tracer<nearest_t<double>, double>);
static_assert(aaf::batch_tracer<batch_t<float>, float>);
static_assert(aaf::batch_tracer<batch_t<double>, double>);
static_assert(aaf::boolean_tracer<boolean_t<float>, float>);
static_assert(aaf::boolean_tracer<boolean_t<double>, double>);
static_assert(aaf::occlusion_tracer<span_t<float>, float>);
static_assert(aaf::occlusion_tracer<nearest_t<float>, float>);
static_assert(aaf::occlusion_tracer<batch_t<float>, float>);
static_assert(aaf::occlusion_tracer<span_t<double>, double>);
static_assert(aaf::occlusion_tracer<nearest_t<double>, double>);
static_assert(aaf::occlusion_tracer<batch_t<double>, double>);

// Each shape is only what it is.
static_assert(!aaf::nearest_tracer<span_t<float>, float>);
static_assert(!aaf::batch_tracer<span_t<float>, float>);
static_assert(!aaf::span_tracer<nearest_t<float>, float>);
static_assert(!aaf::span_tracer<batch_t<float>, float>);
static_assert(!aaf::boolean_tracer<span_t<float>, float>);

// A boolean-only tracer is not an occlusion tracer; bisecting_tracer over it is (a span tracer).
static_assert(!aaf::occlusion_tracer<boolean_t<float>, float>);
static_assert(!aaf::occlusion_tracer<boolean_t<double>, double>);
static_assert(aaf::occlusion_tracer<aaf::bisecting_tracer<boolean_t<float>>, float>);
static_assert(aaf::occlusion_tracer<aaf::bisecting_tracer<boolean_t<double>>, double>);
static_assert(aaf::span_tracer<aaf::bisecting_tracer<boolean_t<float>>, float>);
// ... but only for the precision its boolean tracer answers in.
static_assert(!aaf::occlusion_tracer<aaf::bisecting_tracer<boolean_t<float>>, double>);

// A tracer for one precision does not satisfy the other.
static_assert(!aaf::nearest_tracer<nearest_t<double>, float>);
static_assert(!aaf::span_tracer<span_t<double>, float>);

// Negative checks: wrong names, argument types, return types, constness.
struct wrong_name {
    int occluded_by(float) const;
};
struct nearest_wrong_argument {
    float nearest_occluder(int) const;
};
struct nearest_wrong_return {
    struct opaque {};
    opaque nearest_occluder(const shadow_segment<float>&) const;
};
struct nearest_not_const {
    float nearest_occluder(const shadow_segment<float>&);
};
struct span_wrong_return {
    int occluder_span(const shadow_segment<float>&) const;
};
struct span_wrong_argument {
    aaf::occluder_span<float> occluder_span(const glm::vec3&) const;
};
struct batch_wrong_spans {
    void trace_batch(std::span<const float>, std::span<float>) const;
};
struct batch_wrong_arity {
    void trace_batch(std::span<const shadow_segment<float>>) const;
};
struct boolean_wrong_return {
    struct opaque {};
    opaque occluded(const shadow_segment<float>&) const;
};
struct data_member_only {
    float nearest_occluder = 0;
};
struct nothing {};

static_assert(!aaf::occlusion_tracer<wrong_name, float>);
static_assert(!aaf::occlusion_tracer<nearest_wrong_argument, float>);
static_assert(!aaf::occlusion_tracer<nearest_wrong_return, float>);
static_assert(!aaf::occlusion_tracer<nearest_not_const, float>);
static_assert(!aaf::occlusion_tracer<span_wrong_return, float>);
static_assert(!aaf::occlusion_tracer<span_wrong_argument, float>);
static_assert(!aaf::occlusion_tracer<batch_wrong_spans, float>);
static_assert(!aaf::occlusion_tracer<batch_wrong_arity, float>);
static_assert(!aaf::occlusion_tracer<boolean_wrong_return, float>);
static_assert(!aaf::occlusion_tracer<data_member_only, float>);
static_assert(!aaf::occlusion_tracer<nothing, float>);
static_assert(!aaf::occlusion_tracer<int, float>);
static_assert(!aaf::boolean_tracer<boolean_wrong_return, float>);
static_assert(!aaf::boolean_tracer<wrong_name, float>);

// Convertible return types are fine: a nearest distance as double for a float tracer.
struct nearest_returns_double {
    double nearest_occluder(const shadow_segment<float>&) const;
};
static_assert(aaf::nearest_tracer<nearest_returns_double, float>);
static_assert(aaf::occlusion_tracer<nearest_returns_double, float>);

}  // namespace concept_checks

// ---------------------------------------------------------------------------------------------------

namespace {

using aaf_test::span;

/// Shadow segments from receiver points of the analytic scene to stratified-ish points on its light.
template <class T>
std::vector<aaf::shadow_segment<T>> scene_segments(const aaf_test::analytic_scene<T>& sc, std::size_t count, std::uint32_t seed) {
    const aaf::area_light<T> light = sc.area_light();
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u01(0.0, 1.0);
    std::vector<aaf::shadow_segment<T>> out;
    for (std::size_t i = 0; i < count; ++i) {
        const glm::vec<3, T> p(static_cast<T>(-1.5 + 3 * u01(rng)), T(0), static_cast<T>(-1.5 + 3 * u01(rng)));
        const glm::vec<3, T> y = light.point(static_cast<T>(u01(rng)), static_cast<T>(u01(rng)));
        const glm::vec<3, T> to = y - p;
        const T len = glm::length(to);
        out.push_back({p, to / len, len});
    }
    return out;
}

template <class T>
aaf_test::analytic_scene<T> two_occluders() {
    aaf_test::analytic_scene<T> sc;
    sc.occluders = {{T(-0.6), T(0.6), T(-0.3), T(0.3), T(1)}, {T(-0.2), T(1.0), T(-0.1), T(0.6), T(2)}};
    return sc;
}

/// Counts calls, to check the bisection's ray budget.
template <class T>
struct counting_boolean {
    const aaf_test::analytic_scene<T>* scene;
    mutable std::size_t calls = 0;
    bool occluded(const aaf::shadow_segment<T>& s) const {
        ++calls;
        return scene->span(s).hit();
    }
};

}  // namespace

TEMPLATE_TEST_CASE("bisecting_tracer brackets the nearest occluder to length / 2^(steps+1)", "[tracer]", float, double) {
    using T = TestType;
    const aaf_test::analytic_scene<T> sc = two_occluders<T>();
    const auto segments = scene_segments(sc, 2000, 5u);
    std::size_t occluded = 0;
    for (unsigned steps : {0u, 1u, 3u, 5u, 10u, 20u}) {
        counting_boolean<T> inner{&sc};
        const aaf::bisecting_tracer<counting_boolean<T>> tracer{&inner, steps};
        occluded = 0;
        std::size_t expected_calls = 0;
        for (const auto& s : segments) {
            const aaf::occluder_span<T> truth = sc.span(s);
            const aaf::occluder_span<T> got = tracer.occluder_span(s);
            INFO("steps " << steps << " length " << s.length << " true nearest " << truth.nearest);
            REQUIRE(got.hit() == truth.hit());
            expected_calls += truth.hit() ? 1 + steps : 1;
            if (!truth.hit()) continue;
            ++occluded;
            CHECK(got.nearest == got.farthest);  // first-hit statistics
            const double bound = static_cast<double>(s.length) / std::ldexp(1.0, static_cast<int>(steps) + 1);
            // Plus the rounding of the bracket's arithmetic in T (a few ulps of the length).
            const double rounding = 4 * static_cast<double>(std::numeric_limits<T>::epsilon()) * static_cast<double>(s.length);
            CHECK(std::abs(static_cast<double>(got.nearest) - static_cast<double>(truth.nearest)) <= bound + rounding);
            CHECK(got.nearest > T(0));
            CHECK(got.nearest < s.length);
        }
        CHECK(inner.calls == expected_calls);  // 1 ray per miss, 1 + steps per hit
    }
    CHECK(occluded > 200u);
    CHECK(occluded < segments.size());
    // Through the dispatch: trace_one uses it as a span tracer.
    const aaf_test::boolean_tracer<T> boolean{&sc};
    const aaf::bisecting_tracer<aaf_test::boolean_tracer<T>> bisect{&boolean, 12};
    for (const auto& s : segments) {
        const auto got = aaf::detail::trace_one<T>(bisect, s);
        const auto truth = sc.span(s);
        CHECK(got.hit() == truth.hit());
        if (truth.hit())
            CHECK(std::abs(static_cast<double>(got.nearest) - static_cast<double>(truth.nearest)) <=
                  static_cast<double>(s.length) / 8192.0 + 4 * static_cast<double>(std::numeric_limits<T>::epsilon()) * static_cast<double>(s.length));
    }
}

TEMPLATE_TEST_CASE("sanitize keeps only hits inside (0, length) and marks NaN as failed", "[tracer]", float, double) {
    using T = TestType;
    const T L = T(10);
    const T inf = std::numeric_limits<T>::infinity();
    const T nan = std::numeric_limits<T>::quiet_NaN();
    using aaf::detail::sanitize;
    // Inside: unchanged.
    {
        const auto s = sanitize<T>(span<T>(T(2), T(7)), L);
        CHECK(s.nearest == T(2));
        CHECK(s.farthest == T(7));
    }
    {
        const auto s = sanitize<T>(span<T>(T(4), T(4)), L);
        CHECK(s.hit());
        CHECK(s.nearest == T(4));
        CHECK(s.farthest == T(4));
    }
    // A miss stays a miss.
    CHECK_FALSE(sanitize<T>(aaf::occluder_span<T>{}, L).hit());
    // Entirely outside (0, L): dropped.
    for (const auto& outside : {span<T>(T(-1), T(-0.5)), span<T>(T(-3), T(0)), span<T>(T(0), T(0)), span<T>(L, L),
                                span<T>(T(12), T(15)), span<T>(L, inf), span<T>(-inf, T(0)), span<T>(-inf, inf),
                                span<T>(T(-1), T(12))}) {
        INFO("span " << outside.nearest << " .. " << outside.farthest);
        CHECK_FALSE(sanitize<T>(outside, L).hit());
        CHECK_FALSE(std::isnan(sanitize<T>(outside, L).nearest));
    }
    // One end outside: that hit is dropped; the span keeps the hit that is inside, never reporting one at
    // t <= 0 or t >= L (e.g. the light's own geometry at t = L, which must not become an occluder at the light).
    for (const auto& partly : {span<T>(T(3), L), span<T>(T(3), T(12)), span<T>(T(3), inf)}) {
        INFO("span " << partly.nearest << " .. " << partly.farthest);
        const auto s = sanitize<T>(partly, L);
        CHECK(s.hit());
        CHECK(s.nearest == T(3));
        CHECK(s.farthest == T(3));
    }
    for (const auto& partly : {span<T>(T(0), T(6)), span<T>(T(-2), T(6)), span<T>(-inf, T(6))}) {
        INFO("span " << partly.nearest << " .. " << partly.farthest);
        const auto s = sanitize<T>(partly, L);
        CHECK(s.hit());
        CHECK(s.nearest == T(6));
        CHECK(s.farthest == T(6));
    }
    // NaN anywhere: a failed sample (nearest = NaN).
    for (const auto& bad : {span<T>(nan, T(3)), span<T>(T(3), nan), span<T>(nan, nan), span<T>(nan, -inf)}) {
        CHECK(std::isnan(sanitize<T>(bad, L).nearest));
    }
}

namespace {

/// A nearest tracer that reports a fixed distance, to drive trace_one's edge cases.
template <class T>
struct fixed_nearest {
    T t;
    T nearest_occluder(const aaf::shadow_segment<T>&) const { return t; }
};

/// A span tracer that reports the light's own quad at t = length (a scene that contains its light).
template <class T>
struct sees_the_light {
    const aaf_test::analytic_scene<T>* scene;
    aaf::occluder_span<T> occluder_span(const aaf::shadow_segment<T>& s) const {
        aaf::occluder_span<T> out = scene->span(s);
        out.nearest = std::min(out.nearest, s.length);
        out.farthest = std::max(out.farthest, s.length);
        return out;
    }
};

}  // namespace

TEMPLATE_TEST_CASE("every tracer shape gives the same sanitised hits", "[tracer]", float, double) {
    using T = TestType;
    const aaf_test::analytic_scene<T> sc = two_occluders<T>();
    const auto segments = scene_segments(sc, 1500, 9u);
    const aaf_test::span_tracer<T> spans{&sc};
    const aaf_test::nearest_tracer<T> nearest{&sc};
    const aaf_test::batch_tracer<T> batch{&sc};
    const sees_the_light<T> with_light{&sc};
    std::vector<aaf::occluder_span<T>> batched(segments.size());
    aaf::detail::trace_all<T>(batch, std::span<const aaf::shadow_segment<T>>(segments), std::span<aaf::occluder_span<T>>(batched));
    CHECK(batch.batches == 1u);  // one call for the whole pixel
    std::vector<aaf::occluder_span<T>> via_spans(segments.size());
    aaf::detail::trace_all<T>(spans, std::span<const aaf::shadow_segment<T>>(segments), std::span<aaf::occluder_span<T>>(via_spans));
    std::size_t hits = 0, two_depths = 0;
    for (std::size_t i = 0; i < segments.size(); ++i) {
        const auto& s = segments[i];
        const auto truth = sc.span(s);
        const auto a = aaf::detail::trace_one<T>(spans, s);
        const auto b = aaf::detail::trace_one<T>(nearest, s);
        const auto c = aaf::detail::trace_one<T>(batch, s);
        const auto d = aaf::detail::trace_one<T>(with_light, s);
        REQUIRE(a.hit() == truth.hit());
        CHECK(b.hit() == truth.hit());
        CHECK(c.hit() == truth.hit());
        CHECK(d.hit() == truth.hit());  // the light's own geometry is not an occluder
        CHECK(batched[i].hit() == truth.hit());
        CHECK(via_spans[i].hit() == truth.hit());
        if (!truth.hit()) continue;
        ++hits;
        two_depths += truth.nearest < truth.farthest ? 1u : 0u;
        CHECK(a.nearest == truth.nearest);
        CHECK(a.farthest == truth.farthest);
        CHECK(b.nearest == truth.nearest);
        CHECK(b.farthest == truth.nearest);  // first hit only
        CHECK(c.nearest == truth.nearest);
        CHECK(c.farthest == truth.farthest);
        CHECK(batched[i].nearest == truth.nearest);
        CHECK(batched[i].farthest == truth.farthest);
        CHECK(d.nearest == truth.nearest);
        CHECK(d.farthest < s.length);
    }
    CHECK(hits > 100u);
    CHECK(two_depths > 10u);
    // nearest_occluder edge cases: miss, behind, at/after the end, NaN.
    const aaf::shadow_segment<T> seg{glm::vec<3, T>(0), glm::vec<3, T>(0, 1, 0), T(5)};
    CHECK_FALSE(aaf::detail::trace_one<T>(fixed_nearest<T>{aaf::no_occluder<T>}, seg).hit());
    CHECK_FALSE(aaf::detail::trace_one<T>(fixed_nearest<T>{T(-1)}, seg).hit());
    CHECK_FALSE(aaf::detail::trace_one<T>(fixed_nearest<T>{T(0)}, seg).hit());
    CHECK_FALSE(aaf::detail::trace_one<T>(fixed_nearest<T>{T(5)}, seg).hit());
    CHECK_FALSE(aaf::detail::trace_one<T>(fixed_nearest<T>{T(6)}, seg).hit());
    CHECK(aaf::detail::trace_one<T>(fixed_nearest<T>{T(2.5)}, seg).nearest == T(2.5));
    CHECK(std::isnan(aaf::detail::trace_one<T>(fixed_nearest<T>{std::numeric_limits<T>::quiet_NaN()}, seg).nearest));
}
