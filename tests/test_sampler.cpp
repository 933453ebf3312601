// SPDX-License-Identifier: MIT
// sampler.hpp: the per-pixel light-sample point sets. Range, determinism, the equal-area strata of the
// stratified and regular-grid patterns for any n, the (0, m, 2)-net property of the low-discrepancy
// pattern, lower error than independent random points on the analytic scene, and thread independence.

#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <random>
#include <thread>
#include <string_view>
#include <vector>

#include <glm/geometric.hpp>

#include <aaf/region.hpp>
#include <aaf/sampler.hpp>

#include "reference/reference_sampler.hpp"
#include "support/analytic_scene.hpp"

namespace {

constexpr aaf::sample_pattern all_patterns[] = {aaf::sample_pattern::stratified, aaf::sample_pattern::regular_grid,
                                                aaf::sample_pattern::low_discrepancy};

template <class T>
std::vector<glm::vec<2, T>> samples(aaf::sample_pattern p, const aaf::sample_key& key, std::uint32_t n) {
    std::vector<glm::vec<2, T>> out(n);
    aaf::generate_samples<T>(p, key, out);
    return out;
}

template <class T>
bool identical(const std::vector<glm::vec<2, T>>& a, const std::vector<glm::vec<2, T>>& b) {
    if (a.size() != b.size()) return false;
    for (std::size_t i = 0; i < a.size(); ++i)
        if (!(a[i].x == b[i].x && a[i].y == b[i].y)) return false;
    return true;
}

/// The documented strata layout, derived independently of the library: ⌊√n⌋ rows, the first n mod rows
/// of them holding ⌊n/rows⌋ + 1 cells and the rest ⌊n/rows⌋; row heights proportional to their cell counts.
struct layout {
    std::vector<std::uint32_t> cols;   // cells per row
    std::vector<std::uint32_t> start;  // cells before the row (row r spans [start/n, (start + cols)/n))
};

layout documented_layout(std::uint32_t n) {
    std::uint32_t rows = 1;
    while ((rows + 1) * (rows + 1) <= n) ++rows;
    layout l;
    std::uint32_t acc = 0;
    for (std::uint32_t r = 0; r < rows; ++r) {
        const std::uint32_t c = n / rows + (r < n % rows ? 1u : 0u);
        l.start.push_back(acc);
        l.cols.push_back(c);
        acc += c;
    }
    REQUIRE(acc == n);
    return l;
}

/// Index of the stratum containing (u, v), computed exactly (a float times a small integer is exact in double).
std::size_t stratum_of(const layout& l, std::uint32_t n, double u, double v) {
    const double vn = v * n;
    std::size_t r = 0;
    while (r + 1 < l.cols.size() && vn >= static_cast<double>(l.start[r + 1])) ++r;
    const auto c = static_cast<std::size_t>(std::floor(u * l.cols[r]));
    return l.start[r] + std::min<std::size_t>(c, l.cols[r] - 1u);
}

}  // namespace

TEMPLATE_TEST_CASE("every pattern and n from 1 to 150 stays in the unit square", "[sampler]", float, double) {
    using T = TestType;
    for (auto p : all_patterns)
        for (std::uint32_t n = 1; n <= 150; ++n)
            for (std::uint32_t x : {0u, 17u, 4000000000u}) {
                const auto pts = samples<T>(p, aaf::sample_key{x, 3, 1, 0, 7}, n);
                for (const auto& q : pts) {
                    INFO(aaf::to_string(p) << " n=" << n << " point " << q.x << ", " << q.y);
                    const bool inside = q.x >= T(0) && q.x < T(1) && q.y >= T(0) && q.y < T(1);
                    CHECK(inside);
                    if (!inside) return;
                }
            }
    // n = 0 writes nothing and does not crash.
    std::vector<glm::vec<2, T>> none;
    aaf::generate_samples<T>(aaf::sample_pattern::stratified, aaf::sample_key{}, none);
}

TEMPLATE_TEST_CASE("the chunked loops give the bits of the one-sample-at-a-time definition", "[sampler]", float, double) {
    using T = TestType;
    // n crosses the chunk size (64) and its multiples, and powers of two (whole Sobol' bit planes).
    const std::uint32_t counts[] = {1, 2, 3, 7, 9, 16, 20, 63, 64, 65, 100, 127, 128, 129, 200, 257, 1000};
    for (const aaf::sample_pattern p : all_patterns) {
        for (const std::uint32_t n : counts) {
            for (std::uint32_t k = 0; k < 40; ++k) {
                const aaf::sample_key key{k * 37U, k * 11U + 3U, k % 3U, k % 2U, k * 1000003U};
                std::vector<glm::vec<2, T>> expected(n);
                aaf_ref::generate_samples<T>(p, key, expected);
                INFO(aaf::to_string(p) << " n = " << n << " key " << k);
                REQUIRE(identical(samples<T>(p, key, n), expected));
            }
        }
    }
}

TEMPLATE_TEST_CASE("samples are a pure function of (pattern, key, n)", "[sampler]", float, double) {
    using T = TestType;
    const aaf::sample_key key{12, 34, 1, 2, 99};
    for (auto p : all_patterns)
        for (std::uint32_t n : {1u, 2u, 9u, 17u, 64u, 150u}) {
            INFO(aaf::to_string(p) << " n=" << n);
            CHECK(identical(samples<T>(p, key, n), samples<T>(p, key, n)));
            // Output buffers are overwritten completely, whatever they held before.
            std::vector<glm::vec<2, T>> dirty(n, glm::vec<2, T>(T(-5), T(7)));
            aaf::generate_samples<T>(p, key, dirty);
            CHECK(identical(dirty, samples<T>(p, key, n)));
        }
    // Every field of the key decorrelates the jittered patterns.
    const aaf::sample_key others[] = {{13, 34, 1, 2, 99}, {12, 35, 1, 2, 99}, {12, 34, 2, 2, 99},
                                      {12, 34, 1, 3, 99}, {12, 34, 1, 2, 100}, {34, 12, 1, 2, 99}};
    for (auto p : {aaf::sample_pattern::stratified, aaf::sample_pattern::low_discrepancy})
        for (std::uint32_t n : {1u, 9u, 64u}) {
            const auto base = samples<T>(p, key, n);
            for (const auto& other : others) {
                INFO(aaf::to_string(p) << " n=" << n << " key " << other.x << " " << other.y << " " << other.pass << " " << other.light
                             << " " << other.frame_seed);
                const auto s = samples<T>(p, other, n);
                std::size_t equal = 0;
                for (std::size_t i = 0; i < n; ++i) equal += (s[i].x == base[i].x || s[i].y == base[i].y) ? 1u : 0u;
                CHECK(equal == 0u);
            }
        }
    // The regular grid is the same for every pixel (a Heckbert–Herf style baseline).
    for (std::uint32_t n : {1u, 9u, 10u, 64u})
        for (const auto& other : others)
            CHECK(identical(samples<T>(aaf::sample_pattern::regular_grid, key, n),
                            samples<T>(aaf::sample_pattern::regular_grid, other, n)));
}

TEMPLATE_TEST_CASE("stratified and regular_grid put one point in each equal-area stratum", "[sampler]", float, double) {
    using T = TestType;
    std::size_t checked = 0;
    for (std::uint32_t n = 1; n <= 150; ++n) {
        const layout l = documented_layout(n);
        // Strata have equal area 1/n: (1/cols)·(cols/n).
        for (std::size_t r = 0; r < l.cols.size(); ++r) CHECK(l.cols[r] >= 1u);
        for (auto p : {aaf::sample_pattern::stratified, aaf::sample_pattern::regular_grid})
            for (std::uint32_t pixel = 0; pixel < 40; ++pixel) {
                const auto pts = samples<T>(p, aaf::sample_key{pixel, pixel * 7u + 1u, pixel % 3u, 0, 5}, n);
                std::vector<int> hits(n, 0);
                for (const auto& q : pts) ++hits[stratum_of(l, n, static_cast<double>(q.x), static_cast<double>(q.y))];
                std::size_t bad = 0;
                for (int h : hits) bad += h == 1 ? 0u : 1u;
                INFO(aaf::to_string(p) << " n=" << n << " pixel " << pixel);
                CHECK(bad == 0u);
                ++checked;
                if (p == aaf::sample_pattern::regular_grid) {
                    // ... exactly at the strata centres.
                    std::size_t i = 0;
                    for (std::size_t r = 0; r < l.cols.size(); ++r)
                        for (std::uint32_t c = 0; c < l.cols[r]; ++c, ++i) {
                            const double u = (c + 0.5) / l.cols[r];
                            const double v = (l.start[r] + 0.5 * l.cols[r]) / n;
                            CHECK(static_cast<double>(pts[i].x) == Approx(u).margin(1e-6));
                            CHECK(static_cast<double>(pts[i].y) == Approx(v).margin(1e-6));
                        }
                    break;  // the grid does not depend on the pixel
                }
            }
    }
    CHECK(checked > 6000u);
}

TEMPLATE_TEST_CASE("jittered points never round onto a neighbouring stratum", "[sampler]", float, double) {
    using T = TestType;
    // Keys found by an exhaustive search over 200000 pixels (x = k, y = k >> 8, frame_seed 1) whose float
    // jitter of 1 − 2^-24 made c + jx, or the accumulated row start, round up onto the next stratum's edge.
    struct known {
        std::uint32_t n, k;
    };
    const known cases[] = {{13, 63976}, {17, 63976}, {31, 63976}, {63, 6707}, {63, 63976},
                           {63, 171302}, {64, 32939}, {64, 39470}, {64, 63976}, {64, 87287}};
    for (const known& c : cases) {
        const layout l = documented_layout(c.n);
        const auto pts = samples<T>(aaf::sample_pattern::stratified, aaf::sample_key{c.k, c.k >> 8, 0, 0, 1}, c.n);
        for (std::size_t i = 0; i < pts.size(); ++i) {
            INFO("n=" << c.n << " k=" << c.k << " point " << i << " = " << pts[i].x << ", " << pts[i].y);
            CHECK(stratum_of(l, c.n, static_cast<double>(pts[i].x), static_cast<double>(pts[i].y)) == i);
        }
    }
    // A broader sweep: every point in the stratum of its index (the documented row-major order).
    std::size_t bad = 0;
    for (std::uint32_t n : {3u, 10u, 64u, 100u})
        for (std::uint32_t k = 0; k < 4000; ++k) {
            const layout l = documented_layout(n);
            const auto pts = samples<T>(aaf::sample_pattern::stratified, aaf::sample_key{k, k >> 8, 0, 0, 1}, n);
            for (std::size_t i = 0; i < pts.size(); ++i)
                bad += stratum_of(l, n, static_cast<double>(pts[i].x), static_cast<double>(pts[i].y)) == i ? 0u : 1u;
        }
    CHECK(bad == 0u);
}

TEMPLATE_TEST_CASE("a sample plan's groups give generate_samples' bits for every pixel of the group", "[sampler]", float, double) {
    // gather_occlusion draws a group of pixels at once, one per vector lane (sample_plan::generate_group): every
    // pattern and count, and the keys whose jitter rounds onto a stratum's edge (the test above), each in a
    // different lane of its group, so that the edge rule runs on one lane of a group and not the others.
    using T = TestType;
    constexpr std::uint32_t L = aaf::detail::sample_lanes<T>;
    const std::uint32_t counts[] = {9, 1, 2, 3, 7, 13, 16, 17, 31, 37, 63, 64, 65, 100, 9};
    const std::uint32_t edge_keys[] = {63976, 6707, 171302, 32939, 39470, 87287};
    aaf::detail::sample_plan<T> plan;
    std::vector<T> u, v;
    for (const std::uint32_t n : counts) {
        for (const aaf::sample_pattern p : all_patterns) {
            plan.prepare(p, n);
            u.assign(std::size_t{n} * L, T(-1)), v.assign(std::size_t{n} * L, T(-1));
            for (std::uint32_t group = 0; group < 8; ++group) {
                std::vector<aaf::sample_key> keys;
                std::uint32_t seeds[L];
                for (std::uint32_t k = 0; k < L; ++k) {
                    const std::uint32_t x = k == group % L ? edge_keys[group % std::size(edge_keys)] : group * 97U + k * 5U;
                    keys.push_back({x, x >> 8, 0, 0, 1});
                    seeds[k] = aaf::detail::key_hash(keys.back());
                }
                plan.generate_group(seeds, u.data(), v.data());
                for (std::uint32_t k = 0; k < L; ++k) {
                    const auto expected = samples<T>(p, keys[k], n);
                    std::vector<glm::vec<2, T>> got(n);
                    for (std::uint32_t i = 0; i < n; ++i) got[i] = {u[i * L + k], v[i * L + k]};
                    INFO(aaf::to_string(p) << " n = " << n << " group " << group << " lane " << k);
                    REQUIRE(identical(got, expected));
                }
            }
        }
    }
}

TEMPLATE_TEST_CASE("low_discrepancy power-of-two prefixes are (0,m,2)-nets in base 2", "[sampler]", float, double) {
    using T = TestType;
    for (std::uint32_t m = 0; m <= 8; ++m) {
        const std::uint32_t n = 1u << m;
        for (std::uint32_t pixel = 0; pixel < 24; ++pixel) {
            const aaf::sample_key key{pixel * 13u, pixel, pixel % 2u, pixel % 4u, 11};
            const auto pts = samples<T>(aaf::sample_pattern::low_discrepancy, key, n);
            // Every elementary interval of area 2^-m: [i 2^-a, (i+1) 2^-a) × [j 2^-(m-a), (j+1) 2^-(m-a)).
            std::size_t bad = 0;
            for (std::uint32_t a = 0; a <= m; ++a) {
                std::vector<int> hits(n, 0);
                for (const auto& q : pts) {
                    const auto i = static_cast<std::uint32_t>(std::floor(static_cast<double>(q.x) * (1u << a)));
                    const auto j = static_cast<std::uint32_t>(std::floor(static_cast<double>(q.y) * (1u << (m - a))));
                    ++hits[(i << (m - a)) | j];
                }
                for (int h : hits) bad += h == 1 ? 0u : 1u;
            }
            INFO("m=" << m << " pixel " << pixel);
            CHECK(bad == 0u);
        }
    }
    // Any n is allowed, and a longer sequence starts with the shorter one: the 128- and 64-point prefixes of a
    // 150-point set are nets too.
    const aaf::sample_key key{5, 6, 0, 0, 0};
    const auto long_set = samples<T>(aaf::sample_pattern::low_discrepancy, key, 150);
    for (std::uint32_t m : {6u, 7u}) {
        const std::uint32_t n = 1u << m;
        const std::vector<glm::vec<2, T>> prefix(long_set.begin(), long_set.begin() + n);
        CHECK(identical(prefix, samples<T>(aaf::sample_pattern::low_discrepancy, key, n)));
        std::vector<int> hits(n, 0);
        for (const auto& q : prefix)
            ++hits[static_cast<std::size_t>(std::floor(static_cast<double>(q.x) * n))];
        for (int h : hits) CHECK(h == 1);
    }
}

namespace {

/// Mean squared error, over the penumbra pixels of the analytic scene, of the visible fraction estimated
/// with `n` points per pixel from `points(pixel_index)`.
template <class Points>
double penumbra_mse(const aaf_test::analytic_scene<float>& sc, std::uint32_t n, Points&& points, std::size_t& pixels) {
    const aaf::area_light<float> light = sc.area_light();
    double sum = 0;
    pixels = 0;
    for (std::size_t y = 0; y < sc.height; ++y)
        for (std::size_t x = 0; x < sc.width; ++x) {
            const glm::vec3 p = sc.position(x, y);
            const double exact = sc.exact_visibility(p);
            if (!(exact > 0.0 && exact < 1.0)) continue;
            const std::vector<glm::vec2> pts = points(static_cast<std::uint32_t>(x), static_cast<std::uint32_t>(y), n);
            std::uint32_t visible = 0;
            for (const glm::vec2& q : pts) {
                const glm::vec3 to = light.point(q.x, q.y) - p;
                const float len = glm::length(to);
                if (!sc.span(aaf::shadow_segment<float>{p, to / len, len}).hit()) ++visible;
            }
            const double e = static_cast<double>(visible) / n - exact;
            sum += e * e;
            ++pixels;
        }
    return sum / static_cast<double>(pixels);
}

}  // namespace

TEST_CASE("stratified and low-discrepancy points beat independent random points on the analytic scene", "[sampler][statistical]") {
    aaf_test::analytic_scene<float> sc;
    sc.width = sc.height = 48;
    sc.occluders = {{-0.6f, 0.6f, -0.3f, 0.3f, 1.0f}, {0.2f, 1.4f, 0.1f, 0.5f, 1.8f}};
    const std::uint32_t n = 64;
    std::mt19937 rng(1234567u);  // fixed seed: the test is deterministic
    std::uniform_real_distribution<float> u01(0.0f, 1.0f);
    std::size_t pixels = 0;
    const double random = penumbra_mse(sc, n, [&](std::uint32_t, std::uint32_t, std::uint32_t count) {
        std::vector<glm::vec2> pts(count);
        for (auto& q : pts) q = {u01(rng), u01(rng)};
        return pts;
    }, pixels);
    REQUIRE(pixels > 500u);
    const auto with = [&](aaf::sample_pattern p) {
        std::size_t px = 0;
        const double mse = penumbra_mse(sc, n, [&](std::uint32_t x, std::uint32_t y, std::uint32_t count) {
            return samples<float>(p, aaf::sample_key{x, y, 0, 0, 42}, count);
        }, px);
        CHECK(px == pixels);
        return mse;
    };
    const double stratified = with(aaf::sample_pattern::stratified);
    const double low_discrepancy = with(aaf::sample_pattern::low_discrepancy);
    INFO("MSE random " << random << ", stratified " << stratified << ", low discrepancy " << low_discrepancy << " over "
                       << pixels << " penumbra pixels");
    // Independent points: MSE ≈ E[v(1 − v)]/n. Stratification removes most of it; demand at least a factor 3.
    CHECK(random > 1e-3);
    CHECK(stratified < random / 3);
    CHECK(low_discrepancy < random / 3);
}

TEMPLATE_TEST_CASE("samples do not depend on the thread that computes them", "[sampler][threads]", float, double) {
    using T = TestType;
    const auto compute = [] {
        std::vector<std::vector<glm::vec<2, T>>> all;
        for (auto p : all_patterns)
            for (std::uint32_t n : {1u, 7u, 9u, 64u, 100u, 150u})
                for (std::uint32_t x = 0; x < 16; ++x) all.push_back(samples<T>(p, aaf::sample_key{x, 2 * x, 1, 0, 3}, n));
        return all;
    };
    std::vector<std::vector<glm::vec<2, T>>> a, b;
    std::thread ta([&] { a = compute(); });
    std::thread tb([&] { b = compute(); });
    ta.join();
    tb.join();
    const auto here = compute();
    REQUIRE(a.size() == here.size());
    REQUIRE(b.size() == here.size());
    std::size_t differ = 0;
    for (std::size_t i = 0; i < here.size(); ++i) differ += (identical(a[i], here[i]) && identical(b[i], here[i])) ? 0u : 1u;
    CHECK(differ == 0u);
}

TEST_CASE("to_string names every sample pattern as its enumerator", "[sampler]") {
    static_assert(std::string_view(aaf::to_string(aaf::sample_pattern::stratified)) == "stratified");
    CHECK(std::string_view(aaf::to_string(aaf::sample_pattern::regular_grid)) == "regular_grid");
    CHECK(std::string_view(aaf::to_string(aaf::sample_pattern::low_discrepancy)) == "low_discrepancy");
    CHECK(std::string_view(aaf::to_string(static_cast<aaf::sample_pattern>(99))) == "?");
}

TEST_CASE("a region's pixel key is the frame pixel's key", "[sampler][region]") {
    const aaf::frame_region tile{.origin_x = 160, .origin_y = 120};
    const aaf::sample_key k = aaf::pixel_key(tile, 3, 5, 2, 1, 77);
    CHECK(k.x == 163);
    CHECK(k.y == 125);
    CHECK(k.pass == 2);
    CHECK(k.light == 1);
    CHECK(k.frame_seed == 77);
    // The same frame pixel seen from the full frame and from the tile draws the same samples.
    const auto full = samples<float>(aaf::sample_pattern::stratified, aaf::pixel_key(aaf::frame_region{}, 163, 125, 2, 1, 77), 9);
    const auto from_tile = samples<float>(aaf::sample_pattern::stratified, k, 9);
    CHECK(full == from_tile);
    const auto other = samples<float>(aaf::sample_pattern::stratified, aaf::pixel_key(aaf::frame_region{}, 3, 5, 2, 1, 77), 9);
    CHECK(other != from_tile);
}

TEMPLATE_TEST_CASE("a sample plan gives generate_samples' bits for every pixel, and points in the unit square in its padding",
                   "[sampler]", float, double) {
    // gather_occlusion draws a pass's samples through detail::sample_plan: the per-(pattern, n) constants once,
    // the per-pixel hashes in lanes. The plan is set up again whenever n or the pattern changes (an adaptive
    // pass's counts differ from pixel to pixel), so the counts are visited in an order that switches back and forth.
    using T = TestType;
    const std::uint32_t counts[] = {9, 1, 2, 9, 3, 7, 16, 20, 37, 63, 64, 65, 100, 129, 9, 257};
    aaf::detail::sample_plan<T> plan;
    std::vector<T> u, v;
    for (const std::uint32_t n : counts) {
        for (const aaf::sample_pattern p : all_patterns) {
            plan.prepare(p, n);
            REQUIRE(plan.size() == n);
            REQUIRE(plan.padded() >= n);
            REQUIRE(plan.padded() % aaf::detail::sample_lanes<T> == 0);
            u.assign(plan.padded(), T(-1)), v.assign(plan.padded(), T(-1));
            for (std::uint32_t k = 0; k < 40; ++k) {
                const aaf::sample_key key{k * 37U, k * 11U + 3U, k % 3U, k % 2U, k * 1000003U};
                const auto [pu, pv] = plan.generate(aaf::detail::key_hash(key), u.data(), v.data());
                const auto expected = samples<T>(p, key, n);
                std::vector<glm::vec<2, T>> got(n);
                for (std::uint32_t i = 0; i < n; ++i) got[i] = {pu[i], pv[i]};
                INFO(aaf::to_string(p) << " n = " << n << " key " << k);
                REQUIRE(identical(got, expected));
                for (std::uint32_t i = n; i < plan.padded(); ++i) {
                    const bool inside = pu[i] >= T(0) && pu[i] < T(1) && pv[i] >= T(0) && pv[i] < T(1);
                    REQUIRE(inside);
                }
            }
        }
    }
}
