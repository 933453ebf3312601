// SPDX-License-Identifier: MIT
// Slope spreading (FORMULAS.md §1.12): unoccluded pixels take the max s1 / min s2 of the occluded pixels
// around them. Checked against brute force over the square window (exact without IDs) and against a
// literal horizontal-then-vertical reference with IDs.

#include <catch2/catch.hpp>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <functional>
#include <random>
#include <limits>
#include <string>
#include <vector>

#include <aaf/executor.hpp>
#include <aaf/filter.hpp>
#include <aaf/guides.hpp>
#include <aaf/image.hpp>
#include <aaf/occlusion_stats.hpp>

#include "support/helpers.hpp"
#include "reference/reference_filter.hpp"

namespace {

using aaf_test::what_of;

using sp = aaf::slope_pair<float>;
constexpr float inf_f = std::numeric_limits<float>::infinity();

/// Random sparse occluded pixels (probability `density`) with s1 ≥ s2 ≥ 0; the rest "no occluder".
aaf::image<sp> random_slopes(std::size_t w, std::size_t h, double density, std::uint64_t seed) {
    aaf_ref::rng r(seed);
    aaf::image<sp> img(w, h);
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x)
            if (r.uniform() < density) {
                const auto s2 = static_cast<float>(r.uniform(0.0, 5.0));
                img(x, y) = sp{s2 + static_cast<float>(r.uniform(0.0, 20.0)), s2};
            }
    return img;
}

/// Object IDs in irregular blobs (so ID edges run in every direction).
aaf::image<std::uint32_t> random_ids(std::size_t w, std::size_t h, std::uint64_t seed) {
    aaf_ref::rng r(seed);
    const double a = r.uniform(0.1, 0.4), b = r.uniform(0.1, 0.4), c = r.uniform(0, 6.3);
    aaf::image<std::uint32_t> ids(w, h);
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) {
            const double v = std::sin(a * static_cast<double>(x) + c) + std::cos(b * static_cast<double>(y)) +
                             0.5 * std::sin(0.05 * static_cast<double>(x * y));
            ids(x, y) = static_cast<std::uint32_t>(std::floor(v * 1.5 + 10.0));
        }
    return ids;
}

bool same_bits(const sp& a, const sp& b) { return std::memcmp(&a, &b, sizeof(sp)) == 0; }

std::size_t count_mismatches(const aaf::image<sp>& a, const aaf::image<sp>& b) {
    std::size_t n = 0;
    for (std::size_t y = 0; y < a.height(); ++y)
        for (std::size_t x = 0; x < a.width(); ++x) n += same_bits(a(x, y), b(x, y)) ? 0 : 1;
    return n;
}

aaf::image<sp> copy_of(const aaf::image<sp>& a) {
    aaf::image<sp> c(a.width(), a.height());
    for (std::size_t y = 0; y < a.height(); ++y)
        for (std::size_t x = 0; x < a.width(); ++x) c(x, y) = a(x, y);
    return c;
}

constexpr std::size_t sizes[][2] = {{16, 16}, {37, 23}, {96, 64}, {1, 20}, {20, 1}, {5, 3}};

}  // namespace

TEST_CASE("spread_slopes: without IDs equals brute force over the square window, exactly", "[spread]") {
    std::uint64_t seed = 1;
    for (const auto& sz : sizes)
        for (double density : {0.002, 0.02, 0.3})
            for (std::uint32_t radius : {1u, 3u, 10u, 40u}) {
                CAPTURE(sz[0], sz[1], density, radius);
                const aaf::image<sp> in = random_slopes(sz[0], sz[1], density, seed++);
                aaf::image<sp> slopes = copy_of(in), scratch(sz[0], sz[1]);
                aaf::spread_slopes<float>(slopes.view(), scratch.view(), radius);
                const aaf::image<sp> ref = aaf_ref::spread_square<float>(in.cview(), radius);
                CHECK(count_mismatches(slopes, ref) == 0);
                // Occluded pixels keep their own slopes, bit for bit.
                std::size_t changed_occluded = 0;
                for (std::size_t y = 0; y < sz[1]; ++y)
                    for (std::size_t x = 0; x < sz[0]; ++x)
                        if (in(x, y).has_occluder() && !same_bits(in(x, y), slopes(x, y))) ++changed_occluded;
                CHECK(changed_occluded == 0);
            }
}

TEST_CASE("spread_slopes: with IDs equals the literal separable rule, and never crosses an ID", "[spread]") {
    std::uint64_t seed = 1000;
    for (const auto& sz : sizes)
        for (double density : {0.01, 0.1})
            for (std::uint32_t radius : {1u, 4u, 10u}) {
                CAPTURE(sz[0], sz[1], density, radius);
                const aaf::image<sp> in = random_slopes(sz[0], sz[1], density, seed++);
                const aaf::image<std::uint32_t> ids = random_ids(sz[0], sz[1], seed++);
                aaf::image<sp> slopes = copy_of(in), scratch(sz[0], sz[1]);
                aaf::spread_slopes<float>(slopes.view(), scratch.view(), radius, aaf::guides{aaf::no_guide{}, ids.cview()});
                CHECK(count_mismatches(slopes, aaf_ref::spread_separable<float>(in.cview(), radius, ids.cview())) == 0);

                // The separable rule only ever uses same-ID sources inside the square: compared with the
                // ideal same-ID square window it can miss sources (weaker slopes), never add any.
                const aaf::image<sp> ideal = aaf_ref::spread_square<float>(in.cview(), radius, ids.cview());
                std::size_t stronger = 0;
                for (std::size_t y = 0; y < sz[1]; ++y)
                    for (std::size_t x = 0; x < sz[0]; ++x)
                        if (slopes(x, y).s1 > ideal(x, y).s1 || slopes(x, y).s2 < ideal(x, y).s2) ++stronger;
                CHECK(stronger == 0);

                // A single ID everywhere is the no-ID case.
                const aaf::image<std::uint32_t> one(sz[0], sz[1], 5u);
                aaf::image<sp> single = copy_of(in);
                aaf::spread_slopes<float>(single.view(), scratch.view(), radius, aaf::guides{aaf::no_guide{}, one.cview()});
                CHECK(count_mismatches(single, aaf_ref::spread_square<float>(in.cview(), radius)) == 0);
            }
}

TEST_CASE("spread_slopes: an ID edge blocks spreading; the separable rule misses L-shaped paths", "[spread]") {
    // Occluder at (2, 2) with ID 1. Pixel (6, 6) has ID 1 too, but (6, 2) — the corner of the
    // horizontal-then-vertical path — has ID 2, so the separable pass cannot reach it, while the ideal
    // square rule would.
    aaf::image<sp> slopes(9, 9), scratch(9, 9);
    aaf::image<std::uint32_t> ids(9, 9, 1u);
    slopes(2, 2) = sp{3.0f, 1.5f};
    ids(6, 2) = 2;
    ids(8, 8) = 3;  // another object inside the window: receives nothing
    const aaf::image<sp> in = copy_of(slopes);
    aaf::spread_slopes<float>(slopes.view(), scratch.view(), 5, aaf::guides{aaf::no_guide{}, ids.cview()});
    CHECK(same_bits(slopes(2, 2), sp{3.0f, 1.5f}));
    CHECK(same_bits(slopes(5, 5), sp{3.0f, 1.5f}));   // path (2,2) → (5,2) → (5,5) all ID 1
    CHECK(same_bits(slopes(6, 6), sp{}));             // corner (6,2) has ID 2
    CHECK(same_bits(slopes(6, 2), sp{}));             // ID 2 itself gets nothing
    CHECK(same_bits(slopes(8, 8), sp{}));
    CHECK(same_bits(aaf_ref::spread_square<float>(in.cview(), 5, ids.cview())(6, 6), sp{3.0f, 1.5f}));
}

TEST_CASE("spread_slopes: occluded pixels keep theirs; far pixels stay {0, +inf}; radius 0 is a no-op", "[spread]") {
    SECTION("one occluder: exactly its Chebyshev neighbourhood receives its slopes") {
        const std::size_t w = 23, h = 17;
        aaf::image<sp> slopes(w, h), scratch(w, h);
        slopes(6, 5) = sp{4.0f, 2.0f};
        slopes(7, 5) = sp{1.0f, 0.5f};  // a neighbouring occluder: keeps its own, although (6,5) is stronger in s1
        aaf::spread_slopes<float>(slopes.view(), scratch.view(), 4u);
        CHECK(same_bits(slopes(6, 5), sp{4.0f, 2.0f}));
        CHECK(same_bits(slopes(7, 5), sp{1.0f, 0.5f}));
        for (std::size_t y = 0; y < h; ++y)
            for (std::size_t x = 0; x < w; ++x) {
                if ((x == 6 || x == 7) && y == 5) continue;
                CAPTURE(x, y);
                const auto dist = [&](std::size_t cx, std::size_t cy) {
                    const std::size_t dx = x > cx ? x - cx : cx - x, dy = y > cy ? y - cy : cy - y;
                    return std::max(dx, dy);
                };
                const bool near_a = dist(6, 5) <= 4, near_b = dist(7, 5) <= 4;
                sp expected{};
                if (near_a) expected = sp{4.0f, 2.0f};
                if (near_b) expected = near_a ? sp{4.0f, 0.5f} : sp{1.0f, 0.5f};
                CHECK(same_bits(slopes(x, y), expected));
                if (!near_a && !near_b) {
                    CHECK(slopes(x, y).s1 == 0.0f);
                    CHECK(slopes(x, y).s2 == inf_f);
                    CHECK_FALSE(slopes(x, y).has_occluder());
                }
            }
    }
    SECTION("radius 0 leaves everything (even unnormalised no-occluder pixels) untouched") {
        aaf::image<sp> slopes = random_slopes(19, 11, 0.1, 77);
        slopes(0, 0) = sp{7.0f, inf_f};  // "no occluder" with a stray s1
        const aaf::image<sp> in = copy_of(slopes);
        aaf::image<sp> scratch(19, 11, sp{-1.0f, -1.0f});
        aaf::spread_slopes<float>(slopes.view(), scratch.view(), 0u);
        CHECK(count_mismatches(slopes, in) == 0);
        CHECK(same_bits(scratch(3, 3), sp{-1.0f, -1.0f}));
    }
    SECTION("no occluder anywhere: everything stays {0, +inf}") {
        aaf::image<sp> slopes(13, 9), scratch(13, 9);
        aaf::spread_slopes<float>(slopes.view(), scratch.view(), 10u);
        CHECK(count_mismatches(slopes, aaf::image<sp>(13, 9)) == 0);
    }
}

TEST_CASE("spread_slopes: thread pools give identical results", "[spread][executor]") {
    const aaf::image<sp> in = random_slopes(96, 64, 0.03, 5);
    const aaf::image<std::uint32_t> ids = random_ids(96, 64, 6);
    aaf::thread_pool pool(3);
    for (std::uint32_t radius : {1u, 10u}) {
        aaf::image<sp> a = copy_of(in), b = copy_of(in), c = copy_of(in), scratch(96, 64);
        const auto g = aaf::guides{aaf::no_guide{}, ids.cview()};
        aaf::spread_slopes<float>(a.view(), scratch.view(), radius, g);
        aaf::spread_slopes<float>(b.view(), scratch.view(), radius, g, pool);
        aaf::spread_slopes<float>(c.view(), scratch.view(), radius, g, aaf::thread_pool(2));
        CHECK(count_mismatches(a, b) == 0);
        CHECK(count_mismatches(a, c) == 0);
    }
}

namespace {
/// Runs the bodies on the calling thread in reverse order of the sub-ranges it cuts, and says a concurrency
/// of its choice: the bands spread_slopes cuts for it must not change a bit.
struct reversed_executor {
    std::size_t threads = 0;
    std::size_t chunk = 1;
    template <class Body>
    void parallel_for(std::size_t count, Body&& body) const {
        for (std::size_t b = (count + chunk - 1) / chunk; b-- > 0;) body(b * chunk, std::min(count, (b + 1) * chunk));
    }
    [[nodiscard]] std::size_t concurrency() const noexcept { return threads; }
};
}  // namespace

TEST_CASE("spread_slopes: one band per thread (executors that say their concurrency) gives the same bits", "[spread][executor]") {
    // Tall enough that the bands are not the fixed 64 rows: 2 threads cut 301 rows into 151 + 150, 3 into
    // 101-row bands, 4 into 76-row ones; a concurrency of 9 keeps the 64-row minimum.
    const aaf::image<sp> in = random_slopes(72, 301, 0.03, 17);
    const aaf::image<std::uint32_t> ids = random_ids(72, 301, 18);
    const auto g = aaf::guides{aaf::no_guide{}, ids.cview()};
    CHECK(aaf::concurrency_of(aaf::sequential_executor{}) == 1);
    CHECK(aaf::concurrency_of(reversed_executor{5}) == 5);
    for (std::uint32_t radius : {1u, 10u, 70u}) {
        aaf::image<sp> expected = copy_of(in), scratch(72, 301);
        aaf::spread_slopes<float>(expected.view(), scratch.view(), radius, g);
        for (const std::size_t threads : {0u, 2u, 3u, 4u, 9u}) {
            aaf::image<sp> got = copy_of(in);
            aaf::spread_slopes<float>(got.view(), scratch.view(), radius, g, reversed_executor{threads});
            INFO("radius " << radius << ", concurrency " << threads);
            CHECK(count_mismatches(expected, got) == 0);
        }
        for (const std::size_t threads : {2u, 3u}) {
            aaf::thread_pool pool(threads);
            CHECK(aaf::concurrency_of(pool) == threads);
            aaf::image<sp> got = copy_of(in);
            aaf::spread_slopes<float>(got.view(), scratch.view(), radius, g, pool);
            CHECK(count_mismatches(expected, got) == 0);
        }
    }
}

TEST_CASE("spread_slopes: invalid arguments throw naming the argument, slopes untouched", "[spread]") {
    const aaf::image<sp> in = random_slopes(12, 8, 0.2, 9);
    aaf::image<sp> slopes = copy_of(in), scratch(12, 8), small(11, 8);
    aaf::image<std::uint32_t> ids_small(12, 7);
    const auto expect = [&](const std::string& needle, const std::function<void()>& f) {
        const std::string msg = what_of(f);
        INFO("expected a message containing " << needle << ", got: " << msg);
        CHECK(msg.find(needle) != std::string::npos);
        CHECK(msg.find("spread_slopes") != std::string::npos);
        CHECK(count_mismatches(slopes, in) == 0);
    };
    expect("scratch", [&] { aaf::spread_slopes<float>(slopes.view(), small.view(), 3u); });
    expect("scratch", [&] { aaf::spread_slopes<float>(slopes.view(), slopes.view(), 3u); });  // aliasing
    expect("guides.ids", [&] { aaf::spread_slopes<float>(slopes.view(), scratch.view(), 3u, aaf::guides{aaf::no_guide{}, ids_small.cview()}); });
    expect("radius", [&] { aaf::spread_slopes<float>(slopes.view(), scratch.view(), 1025u); });
    expect("slopes", [&] { aaf::spread_slopes<float>(aaf::image_view<sp>{}, scratch.view(), 3u); });
    expect("scratch", [&] { aaf::spread_slopes<float>(slopes.view(), aaf::image_view<sp>(nullptr, 12, 8), 3u); });
}

namespace {
/// Slopes with every kind of value the max/min rule must treat exactly as the scalar loop: occluded pixels,
/// "no occluder" ones, NaN and ±Inf slopes, −0, denormals; in a buffer of `Slot`s (one slope pair each,
/// plus padding when Slot is larger) so that the same pixels can be seen through a packed view (the
/// vector path) or through one with a pixel stride (the scalar rule).
template <class T>
struct odd_pair {
    aaf::slope_pair<T> p;
    T pad;
};

template <class T>
void fill_odd_slopes(std::vector<aaf::slope_pair<T>>& v, aaf_ref::rng& r) {
    constexpr T inf = std::numeric_limits<T>::infinity(), nan = std::numeric_limits<T>::quiet_NaN();
    for (aaf::slope_pair<T>& s : v) {
        s = {};
        const double z = r.uniform();
        if (z < 0.4) s = {T(r.uniform(0.0, 20.0)), T(r.uniform(0.0, 5.0))};
        else if (z < 0.45) s = {nan, T(1)};
        else if (z < 0.5) s = {T(2), nan};
        else if (z < 0.55) s = {inf, T(0.5)};
        else if (z < 0.6) s = {T(-0.0), T(-0.0)};
        else if (z < 0.62) s = {std::numeric_limits<T>::denorm_min(), T(0)};
        else if (z < 0.64) s = {T(3), -inf};
    }
}

template <class T>
void check_vector_path_equals_scalar_rule(std::uint64_t seed) {
    aaf_ref::rng r(seed);
    const std::size_t w = 1 + r.below(220), h = 1 + r.below(40);
    const auto radius = static_cast<std::uint32_t>(r.below(3) == 0 ? 1 + r.below(60) : 1 + r.below(12));
    CAPTURE(seed, w, h, radius);
    std::vector<aaf::slope_pair<T>> packed(w * h), packed_scratch(w * h);
    std::vector<odd_pair<T>> strided(w * h), strided_scratch(w * h);
    fill_odd_slopes<T>(packed, r);
    for (std::size_t i = 0; i < w * h; ++i) strided[i].p = packed[i];
    const aaf::image<std::uint32_t> ids = random_ids(w, h, seed + 99);
    const bool with_ids = r.below(2) == 0;
    using view = aaf::image_view<aaf::slope_pair<T>>;
    const view pv(packed.data(), w, h), ps(packed_scratch.data(), w, h);
    const view sv(&strided[0].p, w, h, sizeof(odd_pair<T>)), ss(&strided_scratch[0].p, w, h, sizeof(odd_pair<T>));
    REQUIRE(pv.packed_rows());
    REQUIRE_FALSE(sv.packed_rows());
    if (with_ids) {
        const aaf::guides g{aaf::no_guide{}, ids.cview()};
        aaf::spread_slopes<T>(pv, ps, radius, g, aaf::thread_pool(2));
        aaf::spread_slopes<T>(sv, ss, radius, g);
    } else {
        aaf::spread_slopes<T>(pv, ps, radius);
        aaf::spread_slopes<T>(sv, ss, radius);
    }
    std::size_t mismatches = 0;
    for (std::size_t i = 0; i < w * h; ++i) mismatches += std::memcmp(&packed[i], &strided[i].p, sizeof(packed[i])) != 0;
    CHECK(mismatches == 0);
}
}  // namespace

TEMPLATE_TEST_CASE("spread_slopes: the vector passes equal the scalar rule bit for bit (NaN, ±Inf, −0, IDs, borders)",
                   "[spread]", float, double) {
    for (std::uint64_t seed = 1; seed <= 40; ++seed) check_vector_path_equals_scalar_rule<TestType>(seed);
}

TEST_CASE("spread_slopes: rows padded by a part of an element spread as packed rows do", "[spread]") {
    // A view may pad its rows by any byte count its alignment allows: slope_pair<double> is 16 bytes, its rows
    // here start 8 bytes apart from a whole element. The vertical vector pass counts its taps' steps in
    // elements, so it must leave such views to the scalar rule (fuzz_filter found it reading between rows).
    using P = aaf::slope_pair<double>;
    const std::size_t w = 37, h = 9, stride = w * sizeof(P) + 8;
    std::vector<double> storage((stride * h) / sizeof(double) + 2), scratch_storage(storage.size());
    aaf::image_view<P> padded(reinterpret_cast<P*>(storage.data()), w, h, 0, stride);
    // The scratch is what the vertical pass reads with its steps: padded too.
    aaf::image_view<P> scratch_padded(reinterpret_cast<P*>(scratch_storage.data()), w, h, 0, stride);
    aaf::image<P> packed(w, h), scratch_packed(w, h);
    std::mt19937 rng(5);
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) {
            const bool occluded = rng() % 7 == 0;
            const P p = occluded ? P{double(rng() % 100) * 0.1, double(rng() % 50) * 0.01} : P{};
            packed(x, y) = p;
            padded(x, y) = p;
        }
    aaf::spread_slopes<double>(packed.view(), scratch_packed.view(), 3);
    aaf::spread_slopes<double>(padded, scratch_padded, 3);
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) {
            INFO("pixel " << x << ", " << y);
            REQUIRE(std::memcmp(&packed(x, y), &padded(x, y), sizeof(P)) == 0);
        }
}
