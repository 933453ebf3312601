// SPDX-License-Identifier: MIT
// The peers of include/aaf/variants/ (guided à-trous, joint bilateral): against plain references, never
// crossing object IDs, preserving constants, non-finite handling, argument validation.

#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>

#include <aaf/variants.hpp>

#include "reference/reference_variants.hpp"

namespace {

/// A small scene-like G-buffer: two planes (a floor and a tilted wall, IDs 1 and 2) and a sky corner.
struct small_gbuffer {
    std::size_t w = 23, h = 17;
    aaf::image<glm::vec3> normals{w, h}, positions{w, h};
    aaf::image<float> pixel_size{w, h, 0.05f};
    aaf::image<std::uint32_t> ids{w, h, 0u};
    aaf::image<float> value{w, h}, variance{w, h};

    explicit small_gbuffer(std::uint32_t seed) {
        std::mt19937 rng(seed);
        std::uniform_real_distribution<float> u(0, 1);
        const float nan = std::numeric_limits<float>::quiet_NaN();
        const glm::vec3 wall_n = glm::normalize(glm::vec3(0.3f, 0.2f, 1.0f));
        for (std::size_t y = 0; y < h; ++y)
            for (std::size_t x = 0; x < w; ++x) {
                const float fx = float(x) * 0.05f, fy = float(y) * 0.05f;
                if (x + y < 4) {  // sky
                    normals(x, y) = positions(x, y) = glm::vec3(nan);
                    ids(x, y) = 0;
                } else if (x < 12) {
                    normals(x, y) = {0, 1, 0};
                    positions(x, y) = {fx, 0.0f, fy};
                    ids(x, y) = 1;
                } else {
                    normals(x, y) = wall_n;
                    positions(x, y) = glm::vec3(fx, fy, 0.5f) - wall_n * (glm::dot(wall_n, glm::vec3(fx, fy, 0.5f)) - 0.4f);
                    ids(x, y) = 2;
                }
                const float v = float(std::binomial_distribution<int>(4, 0.3 + 0.4 * double(x) / double(w))(rng)) / 4.0f;
                value(x, y) = v;
                variance(x, y) = v * (1 - v) / 4 + 0.01f * u(rng);
            }
    }
    [[nodiscard]] auto all_guides() const { return aaf::guides{normals.cview(), ids.cview(), positions.cview()}; }
    [[nodiscard]] aaf_ref::variant_inputs ref(bool with_variance) const {
        return {&value, with_variance ? &variance : nullptr, &pixel_size, &normals, &positions, &ids, 128, 1};
    }
};

template <class A, class B>
double max_diff(const A& a, const B& b) {
    double m = 0;
    for (std::size_t y = 0; y < a.height(); ++y)
        for (std::size_t x = 0; x < a.width(); ++x) {
            const double da = a(x, y), db = b(x, y);
            if (std::isnan(da) != std::isnan(db)) return std::numeric_limits<double>::infinity();
            if (!std::isnan(da)) m = std::max(m, std::abs(da - db));
        }
    return m;
}

}  // namespace

TEST_CASE("atrous_filter matches the plain reference for every iteration count, with and without the luminance stop", "[variants]") {
    small_gbuffer gb(7);
    aaf::image<float> out(gb.w, gb.h), scratch(gb.w, gb.h);
    aaf::thread_pool pool(2);
    for (unsigned it = 1; it <= 5; ++it)
        for (bool lum : {false, true}) {
            INFO("iterations " << it << ", luminance stop " << lum);
            aaf::atrous_settings<float> s{.iterations = it};
            aaf::atrous_filter<float>(gb.value, lum ? gb.variance.cview() : aaf::const_image_view<float>{}, gb.pixel_size, out.view(),
                                      scratch.view(), gb.all_guides(), s, pool);
            const auto ref = aaf_ref::atrous(gb.ref(lum), it, 4, 1e-4);
            CHECK(max_diff(out, ref) < 2e-5);
        }
    // Guide subsets compile to fewer tests and still match.
    aaf::atrous_filter<float>(gb.value, {}, {}, out.view(), scratch.view(), aaf::guides{aaf::no_guide{}, gb.ids.cview()},
                              aaf::atrous_settings<float>{.iterations = 2});
    aaf_ref::variant_inputs only_ids{&gb.value, nullptr, nullptr, nullptr, nullptr, &gb.ids};
    CHECK(max_diff(out, aaf_ref::atrous(only_ids, 2, 4, 1e-4)) < 2e-5);
}

TEST_CASE("bilateral_filter matches the plain reference", "[variants]") {
    small_gbuffer gb(11);
    aaf::image<float> out(gb.w, gb.h);
    for (float sigma : {0.5f, 1.5f, 3.0f}) {
        INFO("sigma " << sigma);
        aaf::bilateral_filter<float>(gb.value, gb.pixel_size, out.view(), gb.all_guides(), {.sigma_pixels = sigma}, aaf::thread_pool(2));
        CHECK(max_diff(out, aaf_ref::bilateral(gb.ref(false), sigma, 2.5)) < 2e-5);
    }
    // Normals only, the normal stop off: a plain Gaussian within finite normals.
    aaf::bilateral_settings<float> s{.sigma_pixels = 2, .edges = {.normal_power = 0}};
    aaf::bilateral_filter<float>(gb.value, {}, out.view(), aaf::guides{gb.normals.cview()}, s);
    aaf_ref::variant_inputs normals_only{&gb.value, nullptr, nullptr, &gb.normals, nullptr, nullptr, 0, 1};
    CHECK(max_diff(out, aaf_ref::bilateral(normals_only, 2, 2.5)) < 2e-5);
}

TEST_CASE("variant filters never mix object IDs and leave sky pixels alone", "[variants]") {
    small_gbuffer gb(3);
    // Object 1 is exactly 0.25, object 2 noisy: any leak across the ID edge would move object 1.
    for (std::size_t y = 0; y < gb.h; ++y)
        for (std::size_t x = 0; x < gb.w; ++x) {
            if (gb.ids(x, y) == 1) gb.value(x, y) = 0.25f;
            if (gb.ids(x, y) == 0) gb.value(x, y) = 0.75f;
        }
    // Normals alike everywhere, so only the ID stop separates the objects.
    aaf::image<glm::vec3> flat(gb.w, gb.h, glm::vec3(0, 1, 0));
    aaf::image<float> a(gb.w, gb.h), scratch(gb.w, gb.h), b(gb.w, gb.h);
    const aaf::guides g{flat.cview(), gb.ids.cview()};
    aaf::atrous_filter<float>(gb.value, gb.variance, {}, a.view(), scratch.view(), g, aaf::atrous_settings<float>{.iterations = 5});
    aaf::bilateral_filter<float>(gb.value, {}, b.view(), g, {.sigma_pixels = 6});
    for (std::size_t y = 0; y < gb.h; ++y)
        for (std::size_t x = 0; x < gb.w; ++x)
            if (gb.ids(x, y) != 2) {
                INFO(x << ", " << y);
                // Averages of one constant: equal up to float rounding of the normalised sum.
                CHECK(a(x, y) == Approx(gb.value(x, y)).margin(1e-6));
                CHECK(b(x, y) == Approx(gb.value(x, y)).margin(1e-6));
            }
    // With the real G-buffer the sky (NaN normals and positions) is copied, whatever its ID.
    aaf::atrous_filter<float>(gb.value, gb.variance, gb.pixel_size, a.view(), scratch.view(), gb.all_guides());
    for (std::size_t y = 0; y < gb.h; ++y)
        for (std::size_t x = 0; x < gb.w; ++x)
            if (gb.ids(x, y) == 0) CHECK(a(x, y) == 0.75f);
}

TEST_CASE("variant filters preserve a constant image", "[variants]") {
    small_gbuffer gb(5);
    gb.value.fill(0.625f);
    aaf::image<float> a(gb.w, gb.h), scratch(gb.w, gb.h), b(gb.w, gb.h);
    aaf::atrous_filter<float>(gb.value, gb.variance, gb.pixel_size, a.view(), scratch.view(), gb.all_guides(),
                              aaf::atrous_settings<float>{.iterations = 5});
    aaf::bilateral_filter<float>(gb.value, gb.pixel_size, b.view(), gb.all_guides(), {.sigma_pixels = 4});
    for (std::size_t i = 0; i < a.size(); ++i) {
        CHECK(a.data()[i] == Approx(0.625f).margin(1e-6));
        CHECK(b.data()[i] == Approx(0.625f).margin(1e-6));
    }
}

TEST_CASE("variant filters: non-finite values never spread; a non-finite centre takes its neighbours' mean", "[variants]") {
    small_gbuffer gb(9);
    const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
    gb.value(8, 8) = nan;
    gb.value(15, 10) = inf;
    gb.value(16, 10) = -inf;
    gb.variance(5, 9) = nan;
    aaf::image<float> a(gb.w, gb.h), scratch(gb.w, gb.h), b(gb.w, gb.h);
    aaf::atrous_filter<float>(gb.value, gb.variance, gb.pixel_size, a.view(), scratch.view(), gb.all_guides(),
                              aaf::atrous_settings<float>{.iterations = 3});
    aaf::bilateral_filter<float>(gb.value, gb.pixel_size, b.view(), gb.all_guides());
    for (std::size_t y = 0; y < gb.h; ++y)
        for (std::size_t x = 0; x < gb.w; ++x) {
            INFO(x << ", " << y);
            CHECK(std::isfinite(a(x, y)));
            CHECK(std::isfinite(b(x, y)));
            CHECK(a(x, y) >= 0.0f);
            CHECK(a(x, y) <= 1.0f);
        }
    CHECK(max_diff(a, aaf_ref::atrous(gb.ref(true), 3, 4, 1e-4)) < 2e-5);
    CHECK(max_diff(b, aaf_ref::bilateral(gb.ref(false), 2, 2.5)) < 2e-5);
    // An isolated non-finite pixel (no accepted neighbour) keeps its value.
    aaf::image<float> one(1, 1, nan), o1(1, 1), s1(1, 1);
    aaf::atrous_filter<float>(one, {}, {}, o1.view(), s1.view());
    CHECK(std::isnan(o1(0, 0)));
}

TEST_CASE("estimate_mean_variance is the Bernoulli variance of the 3x3 mean", "[variants]") {
    aaf::image<float> v(3, 3, 0.0f), out(3, 3);
    v(0, 0) = 1;
    v(2, 2) = std::numeric_limits<float>::quiet_NaN();
    aaf::estimate_mean_variance<float>(v, 4.0f, out.view());
    CHECK(out(1, 1) == Approx((1.0 / 8) * (7.0 / 8) / 4));  // 8 finite values, one 1
    CHECK(out(0, 0) == Approx(0.25 * 0.75 / 4));            // corner: 4 values, one 1
    CHECK(std::isnan(out(2, 2)));
    CHECK_THROWS_AS(aaf::estimate_mean_variance<float>(v, 0.5f, out.view()), aaf::invalid_argument);
}

TEST_CASE("variant filters reject bad arguments before writing", "[variants]") {
    aaf::image<float> v(4, 4, 0.5f), out(4, 4, -1.0f), scratch(4, 4), small(3, 4);
    aaf::image<glm::vec3> n(4, 4, glm::vec3(0, 1, 0));
    CHECK_THROWS_WITH(aaf::atrous_filter<float>(v, {}, {}, out.view(), scratch.view(), aaf::guides<>{}, aaf::atrous_settings<float>{.iterations = 6}),
                      Catch::Contains("aaf::atrous_filter") && Catch::Contains("settings.iterations"));
    CHECK_THROWS_WITH(aaf::atrous_filter<float>(v, small, {}, out.view(), scratch.view()), Catch::Contains("`variance`"));
    CHECK_THROWS_WITH(aaf::atrous_filter<float>(v, {}, {}, out.view(), out.view()), Catch::Contains("distinct"));
    // Positions need a pixel size.
    CHECK_THROWS_WITH(aaf::atrous_filter<float>(v, {}, {}, out.view(), scratch.view(), aaf::guides{n.cview(), aaf::no_guide{}, n.cview()}),
                      Catch::Contains("`pixel_size`"));
    CHECK_THROWS_WITH(aaf::bilateral_filter<float>(v, {}, out.view(), aaf::guides<>{}, {.sigma_pixels = 0}), Catch::Contains("sigma_pixels"));
    CHECK_THROWS_WITH(aaf::bilateral_filter<float>(v, {}, out.view(), aaf::guides<>{}, {.edges = {.plane_sigma = -1}}),
                      Catch::Contains("settings.edges.plane_sigma"));
    CHECK_THROWS_WITH(aaf::bilateral_filter<float>(v, {}, v.view()), Catch::Contains("alias"));
    for (std::size_t i = 0; i < out.size(); ++i) CHECK(out.data()[i] == -1.0f);
}
