// SPDX-License-Identifier: MIT
// Ambient occlusion gathering against closed forms: a point under a parallel plane with a maximum distance,
// at the foot of a wall, in a corner, inside a box, under an open sky; both sampling densities; bent
// normals; hit-distance statistics; tiles; per-vertex and per-triangle baking.

#include <catch2/catch.hpp>

#include <cmath>
#include <numbers>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include <aaf/occlusion.hpp>

#include "support/ao_scene.hpp"

using aaf_test::ao_half_plane;
using aaf_test::ao_scene;
using aaf_test::ao_tracer;

namespace {

constexpr double pi = std::numbers::pi;

/// `w`×`h` pixels that all sit at point `p` with normal `n`: independent sample sets of one point.
struct point_frame {
    aaf::image<glm::vec3> positions, normals;
    aaf::image<float> pixel_size;
    point_frame(glm::vec3 p, glm::vec3 n, std::size_t w = 16, std::size_t h = 16)
        : positions(w, h, p), normals(w, h, n), pixel_size(w, h, 0.01f) {}
    [[nodiscard]] aaf::gbuffer<float> gb() const { return {positions.cview(), normals.cview(), pixel_size.cview()}; }
};

/// All samples of all pixels of a point_frame merged: one point, w·h·spp samples.
template <class Tracer>
aaf::ao_stats<float> gather_point(const Tracer& tracer, glm::vec3 p, glm::vec3 n, const aaf::ao_sampling_settings<float>& s,
                                  std::uint32_t spp = 256) {
    const point_frame f(p, n);
    aaf::image<aaf::ao_stats<float>> stats(f.positions.width(), f.positions.height());
    aaf::gather_ambient_occlusion(f.gb(), tracer, s, 0, spp, stats.view());
    aaf::ao_stats<float> all;
    for (std::size_t y = 0; y < stats.height(); ++y)
        for (std::size_t x = 0; x < stats.width(); ++x) all = aaf::merge(all, stats(x, y));
    return all;
}

aaf::ao_sampling_settings<float> settings(aaf::hemisphere_sampling density, float max_distance,
                                          aaf::sample_pattern pattern = aaf::sample_pattern::stratified) {
    aaf::ao_sampling_settings<float> s;
    s.density = density;
    s.max_distance = max_distance;
    s.pattern = pattern;
    return s;
}

double angle_deg(glm::vec3 a, glm::vec3 b) {
    return std::acos(std::clamp(static_cast<double>(glm::dot(glm::normalize(a), glm::normalize(b))), -1.0, 1.0)) * 180.0 / pi;
}

const auto densities = {aaf::hemisphere_sampling::cosine, aaf::hemisphere_sampling::uniform};

}  // namespace

TEST_CASE("hemisphere directions are unit, upper-hemisphere and follow their density", "[occlusion]") {
    for (auto h : densities) {
        std::vector<glm::vec2> uv(4096);
        std::vector<glm::vec3> dirs(4096);
        aaf::generate_hemisphere_samples<float>(aaf::sample_pattern::stratified, h, aaf::sample_key{3, 4, 0, 0, 0}, uv, dirs);
        double mean_z = 0, mean_z2 = 0;
        for (const glm::vec3& d : dirs) {
            REQUIRE(std::abs(glm::length(d) - 1.0f) < 1e-5f);
            REQUIRE(d.z >= 0.0f);
            mean_z += static_cast<double>(d.z) / 4096.0, mean_z2 += static_cast<double>(d.z * d.z) / 4096.0;
        }
        // E[cos θ] is 2/3 under the cosine density and 1/2 under the uniform one; E[cos² θ] 1/2 and 1/3.
        const bool cosine = h == aaf::hemisphere_sampling::cosine;
        CHECK(mean_z == Approx(cosine ? 2.0 / 3.0 : 0.5).margin(2e-3));
        CHECK(mean_z2 == Approx(cosine ? 0.5 : 1.0 / 3.0).margin(2e-3));
    }
    // The frame is orthonormal for normals in every octant and along the axes.
    for (glm::vec3 n : {glm::vec3(0, 0, 1), glm::vec3(0, 0, -1), glm::vec3(1, 0, 0), glm::normalize(glm::vec3(-1, 2, -3)),
                        glm::normalize(glm::vec3(0.3f, -0.2f, 1e-7f))}) {
        const aaf::tangent_frame<float> f(n);
        CHECK(glm::dot(f.t, f.b) == Approx(0).margin(1e-6));
        CHECK(glm::dot(f.t, n) == Approx(0).margin(1e-6));
        CHECK(glm::dot(f.b, n) == Approx(0).margin(1e-6));
        CHECK(glm::length(f.t) == Approx(1).epsilon(1e-6));
        CHECK(glm::length(f.b) == Approx(1).epsilon(1e-6));
    }
}

TEST_CASE("a point under a parallel plane at height h sees h^2/R^2 within distance R, 0 beyond", "[occlusion]") {
    const float h = 1.0f;
    const ao_scene scene{{ao_half_plane{{0, h, 0}, {0, 1, 0}}}, {}};
    for (auto density : densities)
        for (float R : {1.5f, 2.0f, 4.0f}) {
            CAPTURE(aaf::to_string(density), R);
            const auto st = gather_point(ao_tracer{&scene}, {0, 0, 0}, {0, 1, 0}, settings(density, R));
            CHECK(st.visibility() == Approx(h * h / (R * R)).margin(0.006));
            // Symmetric about the normal, the bent normal is the normal: the mean of c_i ω_i is
            // (0, ∫₀^{h/R} z·2z dz, 0) = (0, (2/3)(h/R)³, 0). (Its direction alone converges slowly for large R:
            // the free directions are a thin grazing ring whose horizontal parts only cancel on average.)
            const glm::vec3 mean = st.bent_sum / static_cast<float>(st.counted);
            const double c = h / R;
            CHECK(mean.y == Approx(2.0 / 3.0 * c * c * c).epsilon(0.03));
            CHECK(std::abs(mean.x) < 0.0025f);
            CHECK(std::abs(mean.z) < 0.0025f);
            // Nearest hits lie in [h, R): z_min near h (straight up), z_max near R (the grazing edge of the range).
            CHECK(st.z_min >= h * 0.9999f);
            CHECK(st.z_min < h * 1.02f);
            CHECK(st.z_max < R);
            CHECK(st.z_max > R * 0.97f);
        }
    SECTION("R <= h: nothing within range, fully unoccluded") {
        for (auto density : densities) {
            const auto st = gather_point(ao_tracer{&scene}, {0, 0, 0}, {0, 1, 0}, settings(density, 0.99f), 64);
            if (density == aaf::hemisphere_sampling::cosine) CHECK(st.visibility() == 1.0f);
            else CHECK(st.visibility() == Approx(1.0).margin(0.006));
            CHECK(st.hits == 0);
            CHECK_FALSE(st.has_hit());
        }
    }
    SECTION("falloffs: linear 2c - c^2, quadratic c^2 (1 + 2 ln(1/c)), c = h/R") {
        const float R = 2.0f;
        const double c = h / R;
        auto s = settings(aaf::hemisphere_sampling::cosine, R);
        s.falloff = aaf::ao_falloff::linear;
        CHECK(gather_point(ao_tracer{&scene}, {0, 0, 0}, {0, 1, 0}, s).visibility() == Approx(2 * c - c * c).margin(0.006));
        s.falloff = aaf::ao_falloff::quadratic;
        s.query = aaf::ao_query::visibility;  // the falloff needs distances and gets them anyway
        CHECK(gather_point(ao_tracer{&scene}, {0, 0, 0}, {0, 1, 0}, s).visibility() ==
              Approx(c * c * (1 + 2 * std::log(1 / c))).margin(0.006));
    }
}

TEST_CASE("uniform sampling's plain fraction would be the solid-angle one; aaf's estimator is the cosine one", "[occlusion]") {
    // With R = 2h the solid-angle visible fraction is h/R = 0.5, the cosine-weighted one h²/R² = 0.25: both
    // densities must give the second (FORMULAS.md §4.1).
    const ao_scene scene{{ao_half_plane{{0, 1, 0}, {0, 1, 0}}}, {}};
    const auto cosine = gather_point(ao_tracer{&scene}, {0, 0, 0}, {0, 1, 0}, settings(aaf::hemisphere_sampling::cosine, 2));
    const auto uniform = gather_point(ao_tracer{&scene}, {0, 0, 0}, {0, 1, 0}, settings(aaf::hemisphere_sampling::uniform, 2));
    CHECK(cosine.visibility() == Approx(0.25).margin(0.004));
    CHECK(uniform.visibility() == Approx(0.25).margin(0.006));
    CHECK(std::abs(uniform.visibility() - cosine.visibility()) < 0.008f);
}

TEST_CASE("a point at the foot of an infinite wall: half occluded, bent normal tilted by atan(2/pi)", "[occlusion]") {
    // Floor y = 0 (normal +y), wall x = 0 standing on it; the point 1e-4 in front of the wall. Every direction
    // with d.x < 0 hits the wall. Cosine-weighted: A = 1/2; ∫ω cos θ over the free half ∝ (2/3, π/3, 0), so
    // the bent normal leans away from the wall by atan(2/π) = 32.48°.
    const ao_scene scene{{ao_half_plane{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}}, {}};
    const glm::vec3 expected = glm::normalize(glm::vec3(2.0 / 3.0, pi / 3.0, 0));
    for (auto density : densities)
        for (auto pattern : {aaf::sample_pattern::stratified, aaf::sample_pattern::low_discrepancy}) {
            CAPTURE(aaf::to_string(density), aaf::to_string(pattern));
            const auto st = gather_point(ao_tracer{&scene}, {1e-4f, 0, 0}, {0, 1, 0},
                                         settings(density, std::numeric_limits<float>::infinity(), pattern));
            CHECK(st.visibility() == Approx(0.5).margin(0.006));
            CHECK(angle_deg(st.bent_normal({0, 1, 0}), expected) < 0.5);
        }
    SECTION("the same in a rotated world (arbitrary normals)") {
        const glm::mat3 r = glm::mat3(glm::rotate(glm::mat4(1), 1.1f, glm::normalize(glm::vec3(0.3f, -0.5f, 0.8f))));
        const ao_scene turned = aaf_test::rotated(scene, r);
        const auto st = gather_point(ao_tracer{&turned}, r * glm::vec3(1e-4f, 0, 0), r * glm::vec3(0, 1, 0),
                                     settings(aaf::hemisphere_sampling::cosine, std::numeric_limits<float>::infinity()));
        CHECK(st.visibility() == Approx(0.5).margin(0.006));
        CHECK(angle_deg(st.bent_normal(r * glm::vec3(0, 1, 0)), r * expected) < 0.5);
    }
}

TEST_CASE("a point in a right-angled corner of two walls: a quarter visible, bent normal (1/3, pi/6, 1/3)", "[occlusion]") {
    const ao_scene scene{{ao_half_plane{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, ao_half_plane{{0, 0, 0}, {0, 0, 1}, {0, 1, 0}}}, {}};
    const glm::vec3 expected = glm::normalize(glm::vec3(1.0 / 3.0, pi / 6.0, 1.0 / 3.0));
    for (auto density : densities) {
        CAPTURE(aaf::to_string(density));
        const auto st = gather_point(ao_tracer{&scene}, {1e-4f, 0, 1e-4f}, {0, 1, 0},
                                     settings(density, std::numeric_limits<float>::infinity()));
        CHECK(st.visibility() == Approx(0.25).margin(0.006));
        CHECK(angle_deg(st.bent_normal({0, 1, 0}), expected) < 0.7);
    }
}

TEST_CASE("inside a closed box every ray is occluded, unless the box is beyond the maximum distance", "[occlusion]") {
    const ao_scene scene{{}, {aaf_test::ao_box{{-1, -1, -1}, {1, 1, 1}}}};
    const auto inside = gather_point(ao_tracer{&scene}, {0.2f, -0.3f, 0.1f}, glm::normalize(glm::vec3(1, 2, 3)),
                                     settings(aaf::hemisphere_sampling::cosine, std::numeric_limits<float>::infinity()), 32);
    CHECK(inside.visibility() == 0.0f);
    CHECK(inside.hits == inside.counted);
    CHECK(inside.bent_normal(glm::normalize(glm::vec3(1, 2, 3))) == glm::normalize(glm::vec3(1, 2, 3)));  // documented
    // The nearest face is 0.7 away: with R = 0.5 nothing is in range.
    const auto short_range = gather_point(ao_tracer{&scene}, {0.2f, -0.3f, 0.1f}, {0, 1, 0},
                                          settings(aaf::hemisphere_sampling::cosine, 0.5f), 32);
    CHECK(short_range.visibility() == 1.0f);
}

TEST_CASE("an open plane: no occlusion and the bent normal converges to the normal", "[occlusion]") {
    const glm::vec3 n = glm::normalize(glm::vec3(-0.4f, 0.2f, 0.9f));
    for (auto density : densities) {
        const auto st = gather_point(aaf_test::empty_tracer{}, {3, 4, 5}, n,
                                     settings(density, std::numeric_limits<float>::infinity()));
        if (density == aaf::hemisphere_sampling::cosine) CHECK(st.visibility() == 1.0f);
        else CHECK(st.visibility() == Approx(1.0).margin(0.006));
        CHECK(angle_deg(st.bent_normal(n), n) < 0.3);
        CHECK(st.hits == 0);
        CHECK(st.z_min == std::numeric_limits<float>::infinity());
    }
}

TEST_CASE("cosine and uniform sampling converge to the same AO as samples grow", "[occlusion]") {
    const ao_scene scene{{ao_half_plane{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}}, {}};
    double last_gap = 1;
    for (std::uint32_t spp : {4u, 64u, 1024u}) {
        CAPTURE(spp);
        auto sc = settings(aaf::hemisphere_sampling::cosine, 1), su = settings(aaf::hemisphere_sampling::uniform, 1);
        sc.max_samples = su.max_samples = spp;
        sc.initial_samples = su.initial_samples = std::min(spp, 16u);
        const auto c = gather_point(ao_tracer{&scene}, {0.3f, 0, 0}, {0, 1, 0}, sc, spp);
        const auto u = gather_point(ao_tracer{&scene}, {0.3f, 0, 0}, {0, 1, 0}, su, spp);
        last_gap = std::abs(static_cast<double>(c.visibility() - u.visibility()));
        CAPTURE(spp, c.visibility(), u.visibility());
        if (spp == 1024u) {
            CHECK(last_gap < 0.002);
            CHECK(angle_deg(c.bent_normal({0, 1, 0}), u.bent_normal({0, 1, 0})) < 0.3);
        }
    }
}

TEST_CASE("visibility-only passes use the any-hit query and agree with distance passes", "[occlusion]") {
    const ao_scene scene{{ao_half_plane{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}}, {}};
    const point_frame f({0.1f, 0, 0}, {0, 1, 0}, 8, 8);
    auto s = settings(aaf::hemisphere_sampling::cosine, 1.0f);
    aaf::image<aaf::ao_stats<float>> a(8, 8), b(8, 8);
    aaf_test::counting_ao_tracer ta{&scene}, tb{&scene};
    s.query = aaf::ao_query::distances;
    aaf::gather_ambient_occlusion(f.gb(), ta, s, 0, 16, a.view());
    s.query = aaf::ao_query::visibility;
    aaf::gather_ambient_occlusion(f.gb(), tb, s, 0, 16, b.view());
    CHECK(ta.occluded_calls == 0);
    CHECK(ta.nearest_calls == 64 * 16);
    CHECK(tb.occluded_calls == 64 * 16);
    CHECK(tb.nearest_calls == 0);
    for (std::size_t y = 0; y < 8; ++y)
        for (std::size_t x = 0; x < 8; ++x) {
            CHECK(a(x, y).visibility() == b(x, y).visibility());
            CHECK(a(x, y).bent_sum == b(x, y).bent_sum);
            CHECK(b(x, y).hits == 0);  // no distances asked
        }
    // A later pass (adaptive) asks visibility only even when pass 0 asks distances.
    aaf_test::counting_ao_tracer tc{&scene};
    s.query = aaf::ao_query::distances;
    aaf::gather_ambient_occlusion(f.gb(), tc, s, 1, 4, a.view());
    CHECK(tc.nearest_calls == 0);
    CHECK(tc.occluded_calls == 64 * 4);
}

TEST_CASE("AO samples are keyed by the full-frame pixel: a tile equals the same pixels of the frame", "[occlusion]") {
    const ao_scene scene{{ao_half_plane{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}}, {}};
    aaf::image<glm::vec3> p(12, 10), n(12, 10, glm::vec3(0, 1, 0));
    aaf::image<float> d(12, 10, 0.01f);
    for (std::size_t y = 0; y < 10; ++y)
        for (std::size_t x = 0; x < 12; ++x) p(x, y) = {0.05f * static_cast<float>(x) + 0.01f, 0, 0.05f * static_cast<float>(y)};
    const aaf::gbuffer<float> full{p.cview(), n.cview(), d.cview()};
    const auto s = settings(aaf::hemisphere_sampling::cosine, 1.0f, aaf::sample_pattern::low_discrepancy);
    aaf::image<aaf::ao_stats<float>> whole(12, 10), tile(5, 4);
    aaf::gather_ambient_occlusion(full, ao_tracer{&scene}, s, 0, 9, whole.view());
    const aaf::gbuffer<float> sub{p.cview().subview(6, 3, 5, 4), n.cview().subview(6, 3, 5, 4), d.cview().subview(6, 3, 5, 4)};
    aaf::gather_ambient_occlusion(sub, ao_tracer{&scene}, s, 0, 9, tile.view(), {}, aaf::frame_region{6, 3});
    for (std::size_t y = 0; y < 4; ++y)
        for (std::size_t x = 0; x < 5; ++x) {
            CHECK(tile(x, y).visible_sum == whole(x + 6, y + 3).visible_sum);
            CHECK(tile(x, y).bent_sum == whole(x + 6, y + 3).bent_sum);
            CHECK(tile(x, y).z_min == whole(x + 6, y + 3).z_min);
        }
}

TEST_CASE("per-vertex and per-triangle baking under a plane", "[occlusion]") {
    const ao_scene scene{{ao_half_plane{{0, 1, 0}, {0, 1, 0}}}, {}};
    auto s = settings(aaf::hemisphere_sampling::cosine, 2.0f);
    s.initial_samples = 1024;
    s.max_samples = 1024;
    const std::vector<glm::vec3> positions{{0, 0, 0}, {1, 0, 0}, {0, 0, 1}, {5, 0.5f, 5}};
    const std::vector<glm::vec3> normals{{0, 1, 0}, {0, 2, 0}, {0, 1, 0}, {0, 1, 0}};
    std::vector<aaf::ao_stats<float>> v(4);
    const auto rays = aaf::bake_vertex_occlusion<float>(positions, normals, ao_tracer{&scene}, s, v);
    CHECK(rays == 4 * 1024);
    for (int i = 0; i < 3; ++i) CHECK(v[i].visibility() == Approx(0.25).margin(0.01));
    CHECK(v[3].visibility() == Approx(0.0625).margin(0.01));  // h = 0.5 below the plane: (0.5/2)²
    // One triangle, counter-clockwise seen from +y: normal +y. Flipped: normal −y, away from the plane.
    const std::vector<glm::vec<3, std::uint32_t>> tris{{0, 2, 1}};
    std::vector<aaf::ao_stats<float>> t(1);
    aaf::bake_triangle_occlusion<float>(positions, tris, ao_tracer{&scene}, s, t);
    CHECK(t[0].visibility() == Approx(0.25).margin(0.01));
    aaf::bake_triangle_occlusion<float>(positions, tris, ao_tracer{&scene}, s, t, true);
    CHECK(t[0].visibility() == 1.0f);
    // Vertices and triangles draw independent samples (different keys).
    CHECK(v[0].visible_sum != Approx(t[0].visible_sum).epsilon(0));
}

TEST_CASE("a point at distance a from a wall with maximum distance R: 1 - (acos c - c sqrt(1 - c^2))/pi, c = a/R", "[occlusion]") {
    // Cosine-distributed directions have disc coordinates uniform on the unit disc; the wall is hit within R
    // iff d.x < −a/R: the occluded part is the disc segment beyond c.
    const ao_scene scene{{ao_half_plane{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}}, {}};
    for (auto density : densities)
        for (float a : {0.1f, 0.3f, 0.6f, 1.2f}) {
            CAPTURE(aaf::to_string(density), a);
            const double c = std::min(static_cast<double>(a), 1.0);
            const auto st = gather_point(ao_tracer{&scene}, {a, 0, 0}, {0, 1, 0}, settings(density, 1.0f));
            CHECK(st.visibility() == Approx(1 - (std::acos(c) - c * std::sqrt(1 - c * c)) / pi).margin(0.006));
        }
}
