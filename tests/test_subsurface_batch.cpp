// SPDX-License-Identifier: MIT
// The vectorised profile evaluation (include/aaf/subsurface/profile_batch.hpp) against the scalar dipole::profile
// it replaces in the gather: the weighted sum over radii from 0 to far tails for real and extreme materials
// (its exponential, simd_exp.hpp's subnormal range, is tested in test_simd_exp.cpp), and the gather with and
// without it.

#include <catch2/catch.hpp>

#include <cmath>
#include <random>
#include <vector>

#include <aaf/subsurface.hpp>

#include "support/box_scene.hpp"

namespace ss = aaf::subsurface;

TEST_CASE("weighted_profile_sum agrees with summing dipole::profile one radius at a time", "[subsurface]") {
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    ss::material<double> extreme_small{{1e-30, 1e-30, 1e-30}, {1e-30, 2e-30, 3e-30}, 1.3};
    ss::material<double> extreme_large{{1e30, 1e29, 1e28}, {1e30, 1e30, 1e30}, 1.3};
    ss::material<double> lossless{{0, 0, 0}, {11.6, 20.4, 14.9}, 1.3};
    ss::material<double> no_scatter{{1, 1, 1}, {0, 0, 0}, 1.3};
    for (const auto& m : {ss::presets::marble<double>(), ss::presets::skim_milk<double>(), ss::presets::ketchup<double>(), lossless,
                          no_scatter, extreme_small, extreme_large}) {
        const ss::rgb_dipole d(m);
        for (const std::size_t n : {0u, 1u, 7u, 8u, 9u, 150u, 1001u}) {
            std::vector<double> r(n), w0(n), w1(n), w2(n);
            const double len = 1 / std::max(d.channel[0].z_r > 0 ? 1 / d.channel[0].z_r : 1.0, 1e-300);
            for (std::size_t i = 0; i < n; ++i) {
                r[i] = i % 17 == 0 ? 0.0 : len * std::exp(std::log(1e-6) + (std::log(1e4) - std::log(1e-6)) * u(rng));
                w0[i] = u(rng), w1[i] = u(rng) * 1e3, w2[i] = u(rng) * 1e-3;
            }
            glm::dvec3 scalar(0), magnitude(0);
            for (std::size_t i = 0; i < n; ++i) {
                const glm::dvec3 p = d.profile(r[i]);
                scalar += glm::dvec3(w0[i], w1[i], w2[i]) * p;
                magnitude += glm::abs(glm::dvec3(w0[i], w1[i], w2[i]) * p);
            }
            const glm::dvec3 vec = ss::weighted_profile_sum(d, r.data(), w0.data(), w1.data(), w2.data(), n);
            for (int c = 0; c < 3; ++c) {
                INFO("sigma_a " << m.sigma_a[c] << " n " << n << " channel " << c << " scalar " << scalar[c] << " vector " << vec[c]);
                REQUIRE(std::isfinite(vec[c]));
                CHECK(std::abs(vec[c] - scalar[c]) <= 1e-13 * magnitude[c]);
            }
        }
    }
}

TEST_CASE("weighted_profile_sum keeps its precision where the terms are tiny but normal", "[subsurface]") {
    // fuzz_subsurface's finding: σ_t′ ≈ 1e-29 and radii ≈ 1e33, where R_d ≈ 1e-293. Dividing by d³ before
    // multiplying by z made a subnormal quotient and a sum 0.15 % off the scalar one.
    ss::dipole ch;
    ch.alpha_prime = 0x1.feca87579467bp-1;
    ch.sigma_tr = 0x1.03284e8765aa9p-100;
    ch.z_r = 0x1.548704e50d9a7p+96;
    ch.z_v = 0x1.a6dac109354dfp+127;
    ss::rgb_dipole d;
    d.channel[0] = d.channel[1] = d.channel[2] = ch;
    // Enough radii for a full vector at every width, all with σd ≈ 519…551 (e^{−σd} normal, e^{−σd}/d³ not).
    std::vector<double> r, w;
    for (int i = 0; i < 40; ++i) {
        r.push_back(6.5e32 + 1e30 * i);
        w.push_back(0.5);
    }
    double scalar = 0;
    for (std::size_t i = 0; i < r.size(); ++i) scalar += w[i] * ch.profile(r[i]);
    const glm::dvec3 vec = ss::weighted_profile_sum(d, r.data(), w.data(), w.data(), w.data(), r.size());
    INFO("scalar " << scalar << " vector " << vec[0]);
    REQUIRE(scalar > 0x1p-1022);
    CHECK(std::abs(vec[0] - scalar) <= 1e-13 * scalar);
}

TEST_CASE("the gather gives the same image with the vectorised and the scalar profile", "[subsurface]") {
    using ortho = ss::orthographic_projection<float>;
    aaf_test::box_scene scene;
    scene.boxes.push_back({glm::vec3(-150, -100, -150), glm::vec3(150, 0, 150)});
    scene.boxes.push_back({glm::vec3(-20, 0, -20), glm::vec3(20, 30, 20)});  // edges and a step
    const ortho proj = ortho::looking_along(glm::normalize(glm::vec3(0.5f, -1, 0.2f)), glm::vec3(0, -30, 0), 200.f, 128);
    const auto map = ss::build_light_map(proj, ss::map_light<float>{glm::vec3(1)}, 1.3f, scene,
                                         [&](const glm::vec3& p) { return scene.normal_at(p); });
    const std::size_t w = 24, h = 16;
    std::vector<glm::vec3> P(w * h), N(w * h, glm::vec3(0, 1, 0)), a(w * h), b(w * h);
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) {
            const glm::vec3 p(-40.0f + 80.0f * float(x) / float(w), 0, -30.0f + 60.0f * float(y) / float(h));
            const bool top = std::abs(p.x) < 20 && std::abs(p.z) < 20;
            P[y * w + x] = top ? glm::vec3(p.x, 30, p.z) : p;
        }
    const ss::visible_points<float> vp{{P.data(), w, h}, {N.data(), w, h}};
    for (const auto sampling : {ss::disc_sampling::profile, ss::disc_sampling::centre_first}) {
        ss::gather_settings<float> s;
        s.sampling = sampling;
        s.samples = 64;
        s.vector_profile = true;
        ss::gather_subsurface(vp, map.view(), ss::presets::skim_milk<float>(), s, aaf::image_view<glm::vec3>(a.data(), w, h));
        s.vector_profile = false;
        ss::gather_subsurface(vp, map.view(), ss::presets::skim_milk<float>(), s, aaf::image_view<glm::vec3>(b.data(), w, h));
        double worst = 0, peak = 0;
        for (std::size_t i = 0; i < w * h; ++i)
            for (int c = 0; c < 3; ++c) {
                worst = std::max(worst, double(std::abs(a[i][c] - b[i][c])));
                peak = std::max(peak, double(b[i][c]));
            }
        INFO("sampling " << int(sampling) << " worst " << worst << " peak " << peak);
        CHECK(peak > 0);
        CHECK(worst <= 1e-6 * peak);  // float output: the sums agree to ~1e-13, their rounding to float to 1 ulp
    }
}
