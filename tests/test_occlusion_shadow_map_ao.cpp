// SPDX-License-Identifier: MIT
// Shadow-map AO (include/aaf/occlusion/shadow_map_ao.hpp) against the ray-traced AO of the same directions
// and against closed forms, on the analytic scenes of tests/support/ao_scene.hpp; bad input named.
//
// The stated bound. A map answers "occluded within R along ω" with the depth of the texel containing the
// receiver, not of the receiver's own ray; with the automatic bias the answer can differ from the exact one
// only when the exact hit distance lies within δ of R, or within δ of the receiver (contact: an occluder
// inside the receiver's texel neighbourhood is below the bias), δ = k·(texel footprint). So the shadow-map
// estimate over a direction set lies between the exact quadrature over the same set counting hits in
// [0, R + δ) (more occluded) and in [δ, R − δ) (less occluded). Here the occluder is a plane seen at up to 60° from its normal (tan 60° = 1.73)
// and a texel centre is at most half a diagonal (0.71 footprints) from the receiver: 1.23 footprints, plus
// the bias (1.5 × the receiver's slope over that half texel): k = 3 covers both.

#include <catch2/catch.hpp>

#include <array>
#include <cmath>
#include <limits>
#include <vector>

#include <aaf/occlusion.hpp>

#include "support/ao_scene.hpp"
#include "support/helpers.hpp"

using aaf_test::ao_half_plane;
using aaf_test::ao_scene;
using aaf_test::ao_tracer;
using aaf_test::what_of;

namespace {

struct point_frame {
    aaf::image<glm::vec3> positions, normals;
    aaf::image<float> pixel_size;
    point_frame(glm::vec3 p, glm::vec3 n, std::size_t w = 2, std::size_t h = 2)
        : positions(w, h, p), normals(w, h, n), pixel_size(w, h, 0.01f) {}
    [[nodiscard]] aaf::gbuffer<float> gb() const { return {positions.cview(), normals.cview(), pixel_size.cview()}; }
};

/// The exact cosine-weighted visibility at p (normal n) over the Fibonacci set of `count`, counting hits at
/// distances in [near, range).
double exact_quadrature(const ao_scene& scene, glm::vec3 p, glm::vec3 n, std::uint32_t count, double range, double near = 0) {
    double weight = 0, lit = 0;
    for (std::uint32_t k = 0; k < count; ++k) {
        const glm::vec3 w = aaf::fibonacci_direction<float>(k, count);
        const double c = glm::dot(n, w);
        if (!(c > 0)) continue;
        weight += c;
        const double t = scene.nearest({p, w, 1e30f});
        if (!(t < range && t >= near)) lit += c;
    }
    return weight > 0 ? lit / weight : 1.0;
}

/// The largest texel footprint over the maps of a direction set around `points`.
float max_footprint(const std::vector<glm::vec3>& points, std::uint32_t count, std::uint32_t resolution) {
    float fp = 0;
    for (std::uint32_t k = 0; k < count; ++k) {
        const aaf::light_view<float> v = aaf::fit_orthographic_view<float>(-aaf::fibonacci_direction<float>(k, count), points);
        fp = std::max({fp, 2 * v.half_width / static_cast<float>(resolution), 2 * v.half_height / static_cast<float>(resolution)});
    }
    return fp;
}

std::vector<glm::vec3> box_corners(glm::vec3 lo, glm::vec3 hi) {
    std::vector<glm::vec3> c;
    for (int i = 0; i < 8; ++i) c.emplace_back(i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y, i & 4 ? hi.z : lo.z);
    return c;
}

}  // namespace

TEST_CASE("Fibonacci directions are unit and spread evenly over the sphere", "[occlusion]") {
    for (std::uint32_t n : {1u, 4u, 32u, 512u}) {
        glm::dvec3 mean(0);
        for (std::uint32_t k = 0; k < n; ++k) {
            const glm::vec3 w = aaf::fibonacci_direction<float>(k, n);
            CHECK(glm::length(w) == Approx(1.0f).margin(1e-6));
            mean += glm::dvec3(w);
        }
        if (n >= 32) CHECK(glm::length(mean / double(n)) < 0.05);  // no hemisphere favoured
    }
}

TEST_CASE("Shadow-map AO under a parallel plane converges to the ray-traced AO within the texel bound", "[occlusion]") {
    // Floor y = 0, ceiling y = h; receiver on the floor; maximum distance R: unoccluded fraction h²/R².
    constexpr float h = 1, R = 2;
    ao_scene scene;
    scene.planes.push_back({glm::vec3(0), glm::vec3(0, 1, 0), glm::vec3(0)});
    scene.planes.push_back({glm::vec3(0, h, 0), glm::vec3(0, -1, 0), glm::vec3(0)});
    const ao_tracer tracer{&scene};
    // Occluded directions (cos θ > h/R) hit the ceiling within √(R² − h²) = 1.73 of the receiver: the box
    // around ±2 holds every hit that counts.
    const std::vector<glm::vec3> bounds = box_corners({-2, 0, -2}, {2, h, 2});
    const glm::vec3 p(0.1f, 0, -0.05f), n(0, 1, 0);
    const point_frame f(p, n);
    const double analytic = double(h * h) / double(R * R);
    constexpr std::uint32_t resolution = 128;
    std::array<double, 3> errors{};
    const std::array<std::uint32_t, 3> counts{4, 32, 512};
    for (std::size_t c = 0; c < counts.size(); ++c) {
        const std::uint32_t count = counts[c];
        aaf::shadow_map_ao_settings<float> s;
        s.directions = count;
        s.resolution = resolution;
        s.max_distance = R;
        aaf::image<float> vis(2, 2, -1.0f);
        aaf::image<glm::vec3> bent(2, 2);
        const aaf::shadow_map_ao_stats st = aaf::shadow_map_ao(f.gb(), tracer, bounds, s, vis.view(), bent.view());
        CHECK(st.map_rays == std::uint64_t{count} * resolution * resolution);
        CHECK(st.map_bytes == std::size_t{resolution} * resolution * sizeof(float));
        const double delta = 3.0 * double(max_footprint(bounds, count, resolution));
        const double v = vis(0, 0);
        const double more_occluded = exact_quadrature(scene, p, n, count, double(R) + delta);
        const double less_occluded = exact_quadrature(scene, p, n, count, double(R) - delta, delta);
        INFO("N = " << count << ", delta = " << delta << ", shadow-map " << vis(0, 0) << ", exact at R+delta " << more_occluded
                    << ", at R-delta " << less_occluded);
        CHECK(v >= more_occluded - 1e-6);
        CHECK(v <= less_occluded + 1e-6);
        CHECK(vis(1, 1) == vis(0, 0));
        // By symmetry the bent normal is the normal, up to the set's quadrature error.
        if (count >= 512) CHECK(glm::dot(bent(0, 0), n) > 0.99f);
        errors[c] = std::abs(v - analytic);
    }
    INFO("errors against h^2/R^2 at N = 4, 32, 512: " << errors[0] << ", " << errors[1] << ", " << errors[2]);
    CHECK(errors[2] < 0.03);
}

TEST_CASE("Shadow-map AO at the foot of a wall: occlusion and bent-normal tilt", "[occlusion]") {
    // A wall x = 0 (standing on y >= 0) next to a floor point at its foot, R = 1: about half the hemisphere
    // is blocked and the bent normal tilts away from the wall. Checked against the exact quadrature over the
    // same directions with the texel bound (the receiver is within a texel of the wall: the contact term of
    // the bound matters here), and for its sign.
    ao_scene scene;
    scene.planes.push_back({glm::vec3(0), glm::vec3(0, 1, 0), glm::vec3(0)});
    scene.planes.push_back({glm::vec3(0), glm::vec3(1, 0, 0), glm::vec3(0, 1, 0)});
    const ao_tracer tracer{&scene};
    const float R = 1;  // finite so that the bounded box holds every counted hit
    const std::vector<glm::vec3> bounds = box_corners({-1.5f, 0, -1.5f}, {1.5f, 1.5f, 1.5f});
    const glm::vec3 p(0.02f, 0, 0), n(0, 1, 0);
    const point_frame f(p, n);
    aaf::shadow_map_ao_settings<float> s;
    s.directions = 512;
    s.resolution = 128;
    s.max_distance = R;
    aaf::image<float> vis(2, 2);
    aaf::image<glm::vec3> bent(2, 2);
    aaf::shadow_map_ao(f.gb(), tracer, bounds, s, vis.view(), bent.view());
    const double delta = 3.0 * double(max_footprint(bounds, s.directions, s.resolution));
    const double v = vis(0, 0);
    CHECK(v >= exact_quadrature(scene, p, n, s.directions, double(R) + delta) - 1e-6);
    CHECK(v <= exact_quadrature(scene, p, n, s.directions, double(R) - delta, delta) + 1e-6);
    CHECK(vis(0, 0) > 0.45f);  // half blocked, minus the sliver of directions between wall and receiver
    CHECK(vis(0, 0) < 0.6f);
    CHECK(bent(0, 0).x > 0.3f);  // tilted away from the wall, towards +x
}

TEST_CASE("Shadow-map AO of an open plane is 1 and its bent normal the normal", "[occlusion]") {
    ao_scene scene;
    scene.planes.push_back({glm::vec3(0), glm::vec3(0, 1, 0), glm::vec3(0)});
    const ao_tracer tracer{&scene};
    const std::vector<glm::vec3> bounds = box_corners({-1, 0, -1}, {1, 0, 1});  // flat: the fit gives it volume
    point_frame f(glm::vec3(0.3f, 0, 0.2f), glm::vec3(0, 1, 0));
    f.positions(1, 1) = glm::vec3(std::numeric_limits<float>::quiet_NaN());  // a background pixel
    aaf::shadow_map_ao_settings<float> s;
    s.directions = 64;
    s.resolution = 64;  // infinite max distance: every map sees only the plane itself
    aaf::image<float> vis(2, 2, -1.0f);
    aaf::image<glm::vec3> bent(2, 2);
    aaf::shadow_map_ao(f.gb(), tracer, bounds, s, vis.view(), bent.view());
    CHECK(vis(0, 0) == 1.0f);  // the automatic bias keeps the receiver from shadowing itself
    CHECK(glm::dot(bent(0, 0), glm::vec3(0, 1, 0)) > 0.99f);
    CHECK(vis(1, 1) == 1.0f);  // non-finite position: defined, unoccluded, bent = normal
    CHECK(bent(1, 1) == glm::vec3(0, 1, 0));
    // One direction: a receiver whose hemisphere holds none of the set is defined as unoccluded.
    s.directions = 1;  // the single direction is (almost) straight up: flip the normal to face away from it
    point_frame down(glm::vec3(0.3f, 0, 0.2f), glm::vec3(0, -1, 0));
    aaf::shadow_map_ao(down.gb(), tracer, bounds, s, vis.view(), bent.view());
    CHECK(vis(0, 0) == 1.0f);
    CHECK(bent(0, 0) == glm::vec3(0, -1, 0));
}

TEST_CASE("Shadow-map AO: bad input is a named error before any output", "[occlusion]") {
    ao_scene scene;
    const ao_tracer tracer{&scene};
    const std::vector<glm::vec3> bounds = box_corners({-1, 0, -1}, {1, 1, 1});
    const point_frame f(glm::vec3(0), glm::vec3(0, 1, 0), 3, 2);
    aaf::image<float> vis(3, 2, -7.0f), wrong(2, 2);
    aaf::image<glm::vec3> bent_wrong(1, 1);
    const auto run = [&](aaf::shadow_map_ao_settings<float> s) {
        return what_of([&] { aaf::shadow_map_ao(f.gb(), tracer, bounds, s, vis.view()); });
    };
    aaf::shadow_map_ao_settings<float> s;
    s.resolution = 8;
    s.directions = 0;
    CHECK_THAT(run(s), Catch::Contains("shadow_map_ao") && Catch::Contains("settings.directions"));
    s.directions = 4;
    s.resolution = 0;
    CHECK_THAT(run(s), Catch::Contains("settings.resolution"));
    s.resolution = 8;
    for (float bad : {0.0f, -1.0f, std::numeric_limits<float>::quiet_NaN()}) {
        s.max_distance = bad;
        CHECK_THAT(run(s), Catch::Contains("settings.max_distance"));
    }
    s.max_distance = std::numeric_limits<float>::infinity();
    s.bias.scale = 0.5f;
    CHECK_THAT(run(s), Catch::Contains("settings.bias.scale"));
    s.bias = {};
    CHECK_THAT(what_of([&] { aaf::shadow_map_ao(f.gb(), tracer, bounds, s, wrong.view()); }), Catch::Contains("visibility"));
    CHECK_THAT(what_of([&] { aaf::shadow_map_ao(f.gb(), tracer, bounds, s, vis.view(), bent_wrong.view()); }),
               Catch::Contains("bent"));
    const std::vector<glm::vec3> none;
    const std::vector<glm::vec3> nan_only{glm::vec3(std::numeric_limits<float>::quiet_NaN())};
    CHECK_THAT(what_of([&] { aaf::shadow_map_ao(f.gb(), tracer, none, s, vis.view()); }), Catch::Contains("scene_points"));
    CHECK_THAT(what_of([&] { aaf::shadow_map_ao(f.gb(), tracer, nan_only, s, vis.view()); }), Catch::Contains("scene_points"));
    aaf::image<glm::vec3> normals(2, 2, glm::vec3(0, 1, 0));
    const aaf::gbuffer<float> mismatched{f.positions.cview(), normals.cview(), f.pixel_size.cview()};
    CHECK_THAT(what_of([&] { aaf::shadow_map_ao(mismatched, tracer, bounds, s, vis.view()); }), Catch::Contains("gbuffer.normals"));
    CHECK(vis(0, 0) == -7.0f);  // nothing written by any failing call
    CHECK(run(s) == "<no aaf::invalid_argument thrown>");
}
