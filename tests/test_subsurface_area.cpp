// SPDX-License-Identifier: MIT
// The area light's map (include/aaf/subsurface/area_light_map.hpp): its irradiance against Lambert's exact
// form factor (η = 1, no Fresnel), the gather from it against the map-free Monte Carlo reference that samples
// the light itself, and bad input.

#include <catch2/catch.hpp>

#include <cmath>
#include <numbers>

#include <aaf/subsurface.hpp>

#include "support/box_scene.hpp"

namespace ss = aaf::subsurface;
using ortho = ss::orthographic_projection<float>;

namespace {

/// A 300 mm slab (top at y = 0) under a 60 mm square light 80 mm above it, facing down.
struct area_setup {
    aaf_test::box_scene scene;
    aaf::area_light<float> light;
    ortho proj;
    explicit area_setup(std::size_t res = 256) {
        scene.boxes.push_back({glm::vec3(-150, -100, -150), glm::vec3(150, 0, 150)});
        light.corner = {-30, 80, -30};
        light.edge_u = {60, 0, 0};
        light.edge_v = {0, 0, 60};  // normal −y: towards the slab
        proj = ss::area_light_projection(light, glm::vec3(0, -50, 0), 120.0f, res);
    }
};

}  // namespace

TEST_CASE("an area light's map holds the irradiance of the whole light (Lambert's form factor at eta = 1)", "[subsurface]") {
    const area_setup setup(64);
    CHECK(setup.proj.forward.y == Approx(-1.0f));
    ss::area_map_settings<float> s;
    s.radiance = glm::vec3(2, 1, 0.5f);
    s.light_samples = 256;
    const auto map = ss::build_area_light_map(setup.proj, setup.light, s, 1.0f, setup.scene,
                                              [&](const glm::vec3& p) { return setup.scene.normal_at(p); });
    int checked = 0;
    double worst = 0;
    for (std::size_t y = 2; y < 64; y += 7)
        for (std::size_t x = 2; x < 64; x += 7) {
            const glm::vec3 p = map.positions[0](x, y);
            REQUIRE(std::isfinite(p.x));
            REQUIRE(p.y == Approx(0.0f).margin(1e-3));
            const double exact = double(aaf::unshadowed_irradiance(setup.light, p, glm::vec3(0, 1, 0)));
            const glm::vec3 e = map.irradiance[0](x, y);
            CHECK(e.x / 2 == Approx(e.z / 0.5f).epsilon(1e-5));  // RGB radiance scales the same integral
            worst = std::max(worst, std::abs(double(e.y) - exact) / exact);
            ++checked;
        }
    INFO("worst relative error over " << checked << " texels: " << worst);
    CHECK(checked == 81);
    CHECK(worst < 0.01);  // 256 stratified light samples of a smooth integrand
}

TEST_CASE("the gather from an area light's map matches the map-free Monte Carlo reference", "[subsurface]") {
    const area_setup setup(128);
    const ss::material<float> m = ss::presets::skim_milk();
    ss::area_map_settings<float> s;
    const auto map = ss::build_area_light_map(setup.proj, setup.light, s, m.eta, setup.scene,
                                              [&](const glm::vec3& p) { return setup.scene.normal_at(p); });
    const ss::rgb_dipole d(m);
    const double R = ss::default_gather_radius(d);
    const ss::radius_sampler S(d, R);
    ss::reference_light<float> light;
    light.is_area = true;
    light.area = setup.light;
    light.power = glm::vec3(1);
    // Under the light's centre, under its edge (steepest irradiance gradient) and outside its footprint.
    for (const glm::vec3 p : {glm::vec3(2, 0, -1), glm::vec3(30, 0, 5), glm::vec3(-70, 0, 20)}) {
        const auto sampler = [&, p = p](float u, float v) {
            const double rho = S.radius(int(u * 3) % 3, std::fmod(double(u) * 3.0, 1.0)), phi = 2 * std::numbers::pi * double(v);
            return ss::surface_sample<float>{{p.x + float(rho * std::cos(phi)), 0, p.z + float(rho * std::sin(phi))}, {0, 1, 0},
                                             float(S.pdf_area(rho))};
        };
        const glm::dvec3 ref = ss::reference_subsurface(p, glm::vec3(0, 1, 0), m, ss::profile_model::dipole, ss::boundary_term::classical,
                                                        light, setup.scene, sampler, 40000u, aaf::sample_key{5, 5, 5, 5, 5});
        glm::vec3 out[1];
        const glm::vec3 pts[1] = {p}, nrm[1] = {glm::vec3(0, 1, 0)};
        glm::dvec3 got(0);
        ss::gather_settings<float> g;
        for (std::uint32_t k = 0; k < 8; ++k) {
            g.frame_seed = k;
            ss::gather_subsurface(ss::visible_points<float>{{pts, 1, 1}, {nrm, 1, 1}}, map.view(), m, g, aaf::image_view<glm::vec3>(out, 1, 1));
            got += glm::dvec3(out[0]) / 8.0;
        }
        for (int c = 0; c < 3; ++c) {
            INFO("point " << p.x << " channel " << c << " gather " << got[c] << " reference " << ref[c]);
            CHECK(ref[c] > 0);
            // 3 %: 8 × 150 gather samples, 40000 reference samples (one light point each), the map's 1.9 mm texels.
            CHECK(got[c] == Approx(ref[c]).epsilon(0.03));
        }
    }
}

TEST_CASE("build_area_light_map rejects bad input by name", "[subsurface]") {
    const area_setup setup(32);
    const auto normals = [&](const glm::vec3& p) { return setup.scene.normal_at(p); };
    ss::area_map_settings<float> s;
    aaf::area_light<float> flat = setup.light;
    flat.edge_v = glm::vec3(0);
    CHECK_THROWS_AS(ss::build_area_light_map(setup.proj, flat, s, 1.3f, setup.scene, normals), aaf::invalid_argument);
    aaf::area_light<float> nan_light = setup.light;
    nan_light.corner.x = NAN;
    CHECK_THROWS_AS(ss::build_area_light_map(setup.proj, nan_light, s, 1.3f, setup.scene, normals), aaf::invalid_argument);
    ss::area_map_settings<float> bad = s;
    bad.radiance.y = -1;
    CHECK_THROWS_WITH(ss::build_area_light_map(setup.proj, setup.light, bad, 1.3f, setup.scene, normals), Catch::Contains("settings.radiance"));
    bad = s;
    bad.light_samples = 0;
    CHECK_THROWS_WITH(ss::build_area_light_map(setup.proj, setup.light, bad, 1.3f, setup.scene, normals), Catch::Contains("light_samples"));
    CHECK_THROWS_WITH(ss::build_area_light_map(setup.proj, setup.light, s, 0.0f, setup.scene, normals), Catch::Contains("eta"));
    ortho empty = setup.proj;
    empty.width = 0;
    CHECK_THROWS_AS(ss::build_area_light_map(empty, setup.light, s, 1.3f, setup.scene, normals), aaf::invalid_argument);
    // A light facing away from the slab: a valid map of zeros, not an error.
    aaf::area_light<float> away = setup.light;
    std::swap(away.edge_u, away.edge_v);
    const auto map = ss::build_area_light_map(setup.proj, away, s, 1.3f, setup.scene, normals);
    double total = 0;
    for (std::size_t y = 0; y < 32; ++y)
        for (std::size_t x = 0; x < 32; ++x) total += double(map.irradiance[0](x, y).y);
    CHECK(total == 0);
}
