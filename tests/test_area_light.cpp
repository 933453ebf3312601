// SPDX-License-Identifier: MIT
// area_light.hpp: geometry (normal, area, centre, σ = √A/2 of FORMULAS.md §1.4), the emitting side,
// per-sample weights, and unshadowed_irradiance against a brute-force integral of
// cosθ_r cosθ_l / r² over the light, including horizon clipping.

#include <catch2/catch.hpp>

#include <cmath>
#include <random>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <aaf/area_light.hpp>

namespace {

constexpr double pi = 3.14159265358979323846;

template <class T>
aaf::area_light<T> make_light(glm::vec<3, T> corner, glm::vec<3, T> eu, glm::vec<3, T> ev, bool two_sided = false) {
    aaf::area_light<T> l;
    l.corner = corner;
    l.edge_u = eu;
    l.edge_v = ev;
    l.two_sided = two_sided;
    return l;
}

/// Irradiance E = L ∫ max(0, cosθ_r) |cosθ_l| / r² dA by the midpoint rule on a res × res grid, in double.
/// Points behind a one-sided light's emitting face contribute nothing.
double brute_irradiance(const aaf::area_light<double>& light, const glm::dvec3& p, const glm::dvec3& n, double radiance,
                        int res = 400) {
    const glm::dvec3 ln = glm::normalize(glm::cross(light.edge_u, light.edge_v));
    const double dA = glm::length(glm::cross(light.edge_u, light.edge_v)) / (static_cast<double>(res) * res);
    double sum = 0;
    for (int i = 0; i < res; ++i)
        for (int j = 0; j < res; ++j) {
            const glm::dvec3 y = light.point((i + 0.5) / res, (j + 0.5) / res);
            const glm::dvec3 d = y - p;
            const double r2 = glm::dot(d, d);
            const double r = std::sqrt(r2);
            const double cos_r = glm::dot(n, d) / r;
            double cos_l = -glm::dot(ln, d) / r;
            if (light.two_sided) cos_l = std::abs(cos_l);
            if (cos_r <= 0 || cos_l <= 0) continue;
            sum += cos_r * cos_l / r2 * dA;
        }
    return radiance * sum;
}

}  // namespace

TEMPLATE_TEST_CASE("light geometry: normal, area, centre, sigma, point", "[light]", float, double) {
    using T = TestType;
    using v3 = glm::vec<3, T>;
    // A 2 × 0.5 rectangle facing down: cross((2,0,0), (0,0,0.5)) = (0, −1, 0).
    const auto l = make_light<T>(v3(1, 2, 3), v3(2, 0, 0), v3(0, 0, T(0.5)));
    CHECK(l.normal().x == T(0));
    CHECK(l.normal().y == T(-1));
    CHECK(l.normal().z == T(0));
    CHECK(l.area() == Approx(1.0));
    CHECK(l.center().x == Approx(2.0));
    CHECK(l.center().y == Approx(2.0));
    CHECK(l.center().z == Approx(3.25));
    CHECK(l.sigma() == Approx(0.5));  // σ = √A / 2: the equal-area square has side 2σ
    const v3 q = l.point(T(0.25), T(0.5));
    CHECK(q.x == Approx(1.5));
    CHECK(q.y == Approx(2.0));
    CHECK(q.z == Approx(3.25));
    CHECK(l.point(T(0), T(0)) == l.corner);
    // A sheared parallelogram: base 3, height 2 → area 6, σ = √6/2; normal −y.
    const auto p = make_light<T>(v3(0, 5, 0), v3(3, 0, 0), v3(1, 0, 2));
    CHECK(p.area() == Approx(6.0));
    CHECK(p.sigma() == Approx(std::sqrt(6.0) / 2));
    CHECK(p.normal().y == Approx(-1.0));
    CHECK(glm::length(p.normal()) == Approx(1.0));
    CHECK(p.center().x == Approx(2.0));
    CHECK(p.center().z == Approx(1.0));
    // A tilted light: its normal is unit and perpendicular to both edges.
    const auto t = make_light<T>(v3(0, 4, 0), v3(1, T(0.5), 0), v3(0, T(0.3), 2));
    CHECK(glm::length(t.normal()) == Approx(1.0));
    CHECK(glm::dot(t.normal(), t.edge_u) == Approx(0.0).margin(1e-6));
    CHECK(glm::dot(t.normal(), t.edge_v) == Approx(0.0).margin(1e-6));
    CHECK(t.area() == Approx(glm::length(glm::cross(glm::dvec3(1, 0.5, 0), glm::dvec3(0, 0.3, 2)))).epsilon(1e-6));
    // Degenerate light: zero normal, zero area, σ = 0.
    const auto d = make_light<T>(v3(0), v3(1, 0, 0), v3(2, 0, 0));
    CHECK(d.normal() == v3(0));
    CHECK(d.area() == T(0));
    CHECK(d.sigma() == T(0));
}

TEMPLATE_TEST_CASE("plane distance and the emitting side", "[light]", float, double) {
    using T = TestType;
    using v3 = glm::vec<3, T>;
    const auto l = make_light<T>(v3(1, 2, 3), v3(2, 0, 0), v3(0, 0, T(0.5)));  // plane y = 2, facing −y
    CHECK(l.plane_distance(v3(5, -1, 7)) == Approx(3.0));
    CHECK(l.plane_distance(v3(-4, 2.5, 0)) == Approx(0.5));  // behind: still ≥ 0
    CHECK(l.plane_distance(v3(9, 2, 9)) == T(0));
    CHECK(l.emits_towards(v3(5, -1, 7)));        // in front (below), even outside the rectangle's footprint
    CHECK_FALSE(l.emits_towards(v3(2, 3, 3)));   // behind
    CHECK_FALSE(l.emits_towards(v3(2, 2, 3)));   // in the plane
    auto two = l;
    two.two_sided = true;
    CHECK(two.emits_towards(v3(5, -1, 7)));
    CHECK(two.emits_towards(v3(2, 3, 3)));
    CHECK_FALSE(two.emits_towards(v3(2, 2, 3)));
}

TEMPLATE_TEST_CASE("sample_weight for each weighting", "[light]", float, double) {
    using T = TestType;
    using v3 = glm::vec<3, T>;
    const auto l = make_light<T>(v3(-1, 3, -1), v3(2, 0, 0), v3(0, 0, 2));  // 2×2 at y = 3 facing −y, σ = 1
    REQUIRE(l.normal().y == T(-1));
    const v3 p(T(0.5), 0, T(-0.25));
    const v3 up(0, 1, 0);
    const v3 y = l.point(T(0.9), T(0.2));  // (0.8, 3, −0.6)
    CHECK(l.sample_weight(aaf::light_weighting::uniform, p, up, y) == T(1));
    // Gaussian: exp(−|y − c|²/(2σ²)) with c = (0, 3, 0), σ = 1: |y − c|² = 0.64 + 0.36 = 1.
    CHECK(l.sample_weight(aaf::light_weighting::gaussian, p, up, y) == Approx(std::exp(-0.5)));
    CHECK(l.sample_weight(aaf::light_weighting::gaussian, p, up, l.center()) == Approx(1.0));
    CHECK(l.sample_weight(aaf::light_weighting::gaussian, p, up, l.corner) == Approx(std::exp(-1.0)));  // §1.4: e^-1 at corners
    // Irradiance: cosθ_r cosθ_l / r², computed here with normalised vectors.
    {
        const glm::dvec3 d = glm::dvec3(y) - glm::dvec3(p);
        const double r = glm::length(d);
        const glm::dvec3 n(0.3, 0.9, 0.1);
        const glm::dvec3 nn = glm::normalize(n);
        const double expected = glm::dot(nn, d / r) * (d.y / r) / (r * r);
        CHECK(static_cast<double>(l.sample_weight(aaf::light_weighting::irradiance, p, v3(nn), y)) == Approx(expected).epsilon(1e-5));
    }
    for (auto w : {aaf::light_weighting::uniform, aaf::light_weighting::gaussian, aaf::light_weighting::irradiance}) {
        // Below the receiver's horizon → 0 (normal pointing away, or grazing exactly).
        CHECK(l.sample_weight(w, p, v3(0, -1, 0), y) == T(0));
        CHECK(l.sample_weight(w, v3(0, 0, 0), v3(1, 0, 0), v3(-0.5, 3, 0)) == T(0));  // cos_r < 0
        CHECK(l.sample_weight(w, v3(0.8f, 0, 0), v3(1, 0, 0), v3(0.8f, 3, 0)) == T(0));  // cos_r = 0 exactly
        // Receiver behind the one-sided light → 0; a two-sided light lights it.
        const v3 behind(0, 5, 0);
        CHECK(l.sample_weight(w, behind, v3(0, -1, 0), y) == T(0));
        auto two = l;
        two.two_sided = true;
        CHECK(two.sample_weight(w, behind, v3(0, -1, 0), y) > T(0));
        CHECK(two.sample_weight(w, p, up, y) == Approx(static_cast<double>(l.sample_weight(w, p, up, y))));
        // In the light's plane → 0.
        CHECK(l.sample_weight(w, v3(5, 3, 0), v3(-1, 0, 0), y) == T(0));
    }
}

TEST_CASE("unshadowed irradiance matches a brute-force integral", "[light]") {
    const double L = 2.5;
    struct config {
        const char* what;
        aaf::area_light<double> light;
        glm::dvec3 p, n;
    };
    const auto rect = make_light<double>({-1, 3, -0.5}, {2, 0, 0}, {0, 0, 1});  // 2×1 at y = 3 facing down
    const auto tilted = make_light<double>({-0.5, 2, -0.5}, {1, 0.6, 0}, {0, 0.2, 1.5});
    const auto facing_x = make_light<double>({2, 0.5, -1}, {0, 0, 2}, {0, 1.5, 0});  // plane x = 2, normal −x
    const config configs[] = {
        {"below the centre, facing up", rect, {0, 0, 0}, {0, 1, 0}},
        {"off to the side, tilted normal", rect, {1.7, 0.3, -0.8}, glm::normalize(glm::dvec3(-0.3, 1, 0.2))},
        {"close to the light", rect, {0.2, 2.6, 0.1}, {0, 1, 0}},
        {"tilted light, oblique receiver", tilted, {0.3, -0.5, 0.4}, glm::normalize(glm::dvec3(0.2, 1, -0.4))},
        {"light facing -x", facing_x, {0, 1, 0}, glm::normalize(glm::dvec3(1, 0.2, 0))},
        // The receiver's horizon cuts through the light: only the part above it counts.
        {"horizon clips the light", rect, {0, 2, 0}, glm::normalize(glm::dvec3(1, 0.1, 0))},
        {"horizon clips a corner", rect, {-0.2, 1, 0.3}, glm::normalize(glm::dvec3(1, 1.2, 0.9))},
        {"horizon clips the tilted light", tilted, {0.0, 1.0, 0.0}, glm::normalize(glm::dvec3(0.5, 0.3, 1))},
    };
    for (const config& c : configs) {
        INFO(c.what);
        const double exact = aaf::unshadowed_irradiance(c.light, c.p, c.n, L);
        const double brute = brute_irradiance(c.light, c.p, c.n, L);
        REQUIRE(brute > 0);
        // Midpoint rule on 400² cells: relative error O(h²); the worst case here (the close light and the
        // kink at the horizon in the clipped cases) is about 5e-6.
        CHECK(exact == Approx(brute).epsilon(2e-5));
        CHECK(exact / (pi * L) <= 1.0);  // the form factor is at most 1
        // Float agrees with double.
        const aaf::area_light<float> lf = make_light<float>(glm::vec3(c.light.corner), glm::vec3(c.light.edge_u),
                                                             glm::vec3(c.light.edge_v), c.light.two_sided);
        CHECK(static_cast<double>(aaf::unshadowed_irradiance(lf, glm::vec3(c.p), glm::vec3(c.n), 2.5f)) == Approx(exact).epsilon(1e-5));
    }
    // Wholly below the horizon, or behind a one-sided light → 0.
    CHECK(aaf::unshadowed_irradiance(rect, glm::dvec3(0, 0, 0), glm::dvec3(0, -1, 0), L) == 0.0);
    CHECK(aaf::unshadowed_irradiance(rect, glm::dvec3(0, 2, 0), glm::dvec3(0, 1, 0), L) > 0.0);
    CHECK(aaf::unshadowed_irradiance(rect, glm::dvec3(0, 2, 0), glm::normalize(glm::dvec3(1, -4, 0)), L) == 0.0);
    CHECK(aaf::unshadowed_irradiance(rect, glm::dvec3(0, 4, 0), glm::dvec3(0, -1, 0), L) == 0.0);
    CHECK(aaf::unshadowed_irradiance(rect, glm::dvec3(0, 3, 0), glm::dvec3(0, 1, 0), L) == 0.0);  // in the plane
    // A two-sided light lights the point behind it as its mirror image in front.
    auto two = rect;
    two.two_sided = true;
    const double behind = aaf::unshadowed_irradiance(two, glm::dvec3(0.3, 4, 0.1), glm::dvec3(0, -1, 0), L);
    const double front = aaf::unshadowed_irradiance(two, glm::dvec3(0.3, 2, 0.1), glm::dvec3(0, 1, 0), L);
    CHECK(behind == Approx(front).epsilon(1e-12));
    CHECK(behind == Approx(brute_irradiance(two, glm::dvec3(0.3, 4, 0.1), glm::dvec3(0, -1, 0), L)).epsilon(2e-5));
    // Linear in the radiance.
    CHECK(aaf::unshadowed_irradiance(rect, glm::dvec3(0.1, 0, 0), glm::dvec3(0, 1, 0), 1.0) * L ==
          Approx(aaf::unshadowed_irradiance(rect, glm::dvec3(0.1, 0, 0), glm::dvec3(0, 1, 0), L)).epsilon(1e-14));
}

TEST_CASE("form factor: at most 1, approaching 1 under a huge close light", "[light]") {
    std::mt19937 rng(7u);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    for (int i = 0; i < 300; ++i) {
        const auto light = make_light<double>({u(rng) * 3, 1 + std::abs(u(rng)) * 2, u(rng) * 3}, {1 + 3 * std::abs(u(rng)), 0, u(rng)},
                                              {u(rng), 0, 1 + 3 * std::abs(u(rng))});
        const glm::dvec3 n = glm::normalize(glm::dvec3(u(rng), 1.2, u(rng)));
        const double e = aaf::unshadowed_irradiance(light, glm::dvec3(u(rng), u(rng) * 0.5, u(rng)), n, 1.0);
        CHECK(e >= 0.0);
        CHECK(e / pi <= 1.0);
    }
    // A 2000 × 2000 light 0.01 above the receiver fills its hemisphere: F → 1.
    const auto huge = make_light<double>({-1000, 0.01, -1000}, {2000, 0, 0}, {0, 0, 2000});
    const double f = aaf::unshadowed_irradiance(huge, glm::dvec3(0, 0, 0), glm::dvec3(0, 1, 0), 1.0) / pi;
    CHECK(f <= 1.0);
    CHECK(f > 0.9999);
    // Horizon clipping keeps F ≤ 1 even with a tilted receiver: exactly the half of the hemisphere above the light's plane.
    const double half = aaf::unshadowed_irradiance(huge, glm::dvec3(0, 0, 0), glm::dvec3(1, 0, 0), 1.0) / pi;
    CHECK(half <= 1.0);
    CHECK(half == Approx(0.5).epsilon(1e-3));
}

TEST_CASE("a tiny far light is a point source", "[light]") {
    // E ≈ L · A · cosθ_r cosθ_l / r² for a light much smaller than its distance.
    const double L = 3.0, s = 0.01;
    const auto tiny = make_light<double>({2 - s / 2, 10, 1 - s / 2}, {s, 0, 0}, {0, 0, s});  // facing −y
    for (const glm::dvec3& n : {glm::dvec3(0, 1, 0), glm::normalize(glm::dvec3(0.4, 1, -0.3)), glm::normalize(glm::dvec3(1, 0.2, 0))}) {
        const glm::dvec3 p(-1, 0.5, 3);
        const glm::dvec3 d = tiny.center() - p;
        const double r = glm::length(d);
        const double cos_r = glm::dot(n, d) / r, cos_l = d.y / r;
        const double point = L * s * s * cos_r * cos_l / (r * r);
        CHECK(aaf::unshadowed_irradiance(tiny, p, n, L) == Approx(point).epsilon(1e-5));
        CHECK(static_cast<double>(aaf::unshadowed_irradiance(aaf::area_light<float>{glm::vec3(tiny.corner), glm::vec3(tiny.edge_u),
                                                                                   glm::vec3(tiny.edge_v), false},
                                                             glm::vec3(p), glm::vec3(n), 3.0f)) == Approx(point).epsilon(1e-5));
    }
}
