// SPDX-License-Identifier: MIT
// AO shading helpers: the AO-modulated diffuse term and spherical-harmonic irradiance of the sky models,
// against closed forms and numerical integration.

#include <catch2/catch.hpp>

#include <cmath>
#include <numbers>

#include <aaf/occlusion/hemisphere.hpp>
#include <aaf/occlusion/shading.hpp>

namespace {

constexpr double pi = std::numbers::pi;

/// ∫ L(ω) max(0, n·ω) dω over the sphere by a (θ, φ) midpoint rule.
glm::dvec3 irradiance_numeric(const aaf::sky_model<float>& sky, glm::vec3 n) {
    glm::dvec3 e(0);
    const int nt = 400, np = 800;
    for (int i = 0; i < nt; ++i)
        for (int j = 0; j < np; ++j) {
            const double th = (i + 0.5) * pi / nt, ph = (j + 0.5) * 2 * pi / np;
            const glm::vec3 w(static_cast<float>(std::sin(th) * std::cos(ph)), static_cast<float>(std::cos(th)),
                              static_cast<float>(std::sin(th) * std::sin(ph)));
            const double c = std::max(0.0, static_cast<double>(glm::dot(n, w)));
            e += glm::dvec3(sky.radiance(w)) * (c * std::sin(th) * (pi / nt) * (2 * pi / np));
        }
    return e;
}

}  // namespace

TEST_CASE("AO-modulated diffuse: K_d (1 - occlusion) max(0, N.L)", "[occlusion]") {
    const glm::vec3 kd(0.5f, 0.25f, 1.0f), n(0, 1, 0);
    const glm::vec3 l = glm::normalize(glm::vec3(1, 1, 0));
    const glm::vec3 c = aaf::ao_diffuse(kd, 0.4f, n, l);
    CHECK(c.x == Approx(0.5 * 0.6 * std::sqrt(0.5)));
    CHECK(c.z == Approx(1.0 * 0.6 * std::sqrt(0.5)));
    CHECK(aaf::ao_diffuse(kd, 0.4f, n, -l) == glm::vec3(0));                       // light below the horizon
    CHECK(aaf::ao_diffuse(kd, std::nanf(""), n, l) == aaf::ao_diffuse(kd, 0.0f, n, l));  // no estimate: unoccluded
    CHECK(aaf::ao_diffuse(kd, 2.0f, n, l) == glm::vec3(0));                        // clamped
}

TEST_CASE("SH irradiance of the sky models is exact (closed form and quadrature)", "[occlusion]") {
    using kind = aaf::sky_model<float>::kind;
    for (kind k : {kind::constant, kind::gradient, kind::sky_ground}) {
        aaf::sky_model<float> sky;
        sky.shape = k;
        sky.zenith = {1.0f, 0.8f, 0.6f};
        sky.ground = {0.2f, 0.1f, 0.0f};
        sky.up = glm::normalize(glm::vec3(0.2f, 1.0f, -0.3f));
        const aaf::sh9<float> sh = sky.coefficients();
        for (glm::vec3 n : {sky.up, -sky.up, glm::vec3(1, 0, 0), glm::normalize(glm::vec3(1, 1, 1)), glm::normalize(glm::vec3(-1, 0.2f, 0.5f))}) {
            CAPTURE(static_cast<int>(k), n.x, n.y, n.z);
            const glm::vec3 e = aaf::sh_irradiance(sh, n);
            const glm::dvec3 ref = irradiance_numeric(sky, n);
            for (int c = 0; c < 3; ++c) CHECK(static_cast<double>(e[c]) == Approx(ref[c]).margin(2e-3));
        }
    }
    // Closed forms: a constant sky gives π L; a sky over a ground gives π s straight up, π g straight down.
    aaf::sky_model<float> constant{aaf::sky_model<float>::kind::constant, {2, 2, 2}, {}, {0, 1, 0}};
    CHECK(aaf::sh_irradiance(constant.coefficients(), glm::vec3(0.6f, 0, 0.8f)).x == Approx(2 * pi));
    aaf::sky_model<float> sg{aaf::sky_model<float>::kind::sky_ground, {1, 1, 1}, {0.25f, 0.25f, 0.25f}, {0, 1, 0}};
    CHECK(aaf::sh_irradiance(sg.coefficients(), glm::vec3(0, 1, 0)).x == Approx(pi).epsilon(1e-5));
    CHECK(aaf::sh_irradiance(sg.coefficients(), glm::vec3(0, -1, 0)).x == Approx(0.25 * pi).epsilon(1e-5));
}

TEST_CASE("projecting a sky with sh9::add matches its closed-form coefficients", "[occlusion]") {
    aaf::sky_model<float> sky;  // gradient, white over black, +y
    aaf::sh9<float> sh;
    const int nt = 200, np = 400;
    for (int i = 0; i < nt; ++i)
        for (int j = 0; j < np; ++j) {
            const double th = (i + 0.5) * pi / nt, ph = (j + 0.5) * 2 * pi / np;
            const glm::vec3 w(static_cast<float>(std::sin(th) * std::cos(ph)), static_cast<float>(std::cos(th)),
                              static_cast<float>(std::sin(th) * std::sin(ph)));
            sh.add(w, sky.radiance(w), static_cast<float>(std::sin(th) * (pi / nt) * (2 * pi / np)));
        }
    const aaf::sh9<float> closed = sky.coefficients();
    for (int i = 0; i < 9; ++i) CHECK(sh.c[i].x == Approx(closed.c[i].x).margin(1e-3));
    // The bent normal of a half-occluded point lowers the irradiance it looks up against the normal's.
    const glm::vec3 e_normal = aaf::sh_irradiance(closed, glm::vec3(0, 1, 0));
    const glm::vec3 e_bent = aaf::sh_irradiance(closed, glm::normalize(glm::vec3(2.0 / 3.0, pi / 3.0, 0)));
    CHECK(e_bent.x < e_normal.x);
}
