// SPDX-License-Identifier: MIT
#pragma once
// The directional dipole of Frisvad, Hachisuka and Kjeldsen 2014 written straight from FORMULAS.md §5.2 (its
// transcription of the authors' sample code, as ported to Mitsuba): the polynomial Fresnel-moment fits, σ_t in
// the μ₀ ≤ 0 branch, no floor on d_r, no guards. The oracle for include/aaf/subsurface/directional_dipole.hpp
// at interior points (r > 0, μ₀ not near 0); it differs from the library only where docs/DEVIATIONS.md says.

#include <cmath>
#include <numbers>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

namespace aaf_ref {

/// 2C₁(η) and 3C₂(η) by the fits of FORMULAS.md §5.2 (η ≥ 1 rows; the η < 1 row for 2C₁).
inline double two_c1_fit(double n) {
    if (n >= 1) return -9.23372 + 22.2272 * n - 20.9292 * n * n + 10.2291 * n * n * n - 2.54396 * n * n * n * n + 0.254913 * n * n * n * n * n;
    return 0.919317 - 3.4793 * n + 6.75335 * n * n - 7.80989 * n * n * n + 4.98554 * n * n * n * n - 1.36881 * n * n * n * n * n;
}
inline double three_c2_fit(double n) {
    return -1641.1 + 135.926 / (n * n * n) - 656.175 / (n * n) + 1376.53 / n + 1213.67 * n - 568.556 * n * n + 164.798 * n * n * n -
           27.0181 * n * n * n * n + 1.91826 * n * n * n * n * n;
}

/// S_d(x_i, ω_i; x_o) for one channel, without Fresnel transmittances, clamped at 0 (FORMULAS.md §5.2).
/// `to_light` is the unit direction from x_i towards the light; σ_t = σ_s + σ_a (here g = 0: σ_s = σ_s′).
inline double directional_dipole(double sigma_a, double sigma_s, double g, double eta, const glm::dvec3& x_i, const glm::dvec3& n_i,
                                 const glm::dvec3& to_light, const glm::dvec3& x_o, const glm::dvec3& n_o) {
    const double sigma_t = sigma_s + sigma_a;
    const double sigma_sp = sigma_s * (1 - g), sigma_tp = sigma_sp + sigma_a, alpha_p = sigma_sp / sigma_tp;
    const double D = 1 / (3 * sigma_tp);
    const double sigma_tr = std::sqrt(sigma_a / D);
    const double d_e = 2.131 * D / std::sqrt(alpha_p);
    const double C_phi = 0.25 * (1 - two_c1_fit(eta)), C_E = 0.5 * (1 - three_c2_fit(eta));
    const double C_phi_inv = 0.25 * (1 - two_c1_fit(1 / eta));
    const double A = (1 - C_E) / (2 * C_phi);
    const auto S_prime = [&](const glm::dvec3& x, const glm::dvec3& w, double r) {
        const double sr = sigma_tr * r;
        return 1 / (4 * C_phi_inv) / (4 * std::numbers::pi * std::numbers::pi) * std::exp(-sr) / (r * r * r) *
               (C_phi * (r * r / D + 3 * (1 + sr) * glm::dot(x, w)) -
                C_E * (3 * D * (1 + sr) * glm::dot(w, n_o) -
                       ((1 + sr) + 3 * D * (3 * (1 + sr) + sr * sr) / (r * r) * glm::dot(x, w)) * glm::dot(x, n_o)));
    };
    // ω₁₂: the light's travel direction refracted into the medium (Snell's law, relative index 1/η).
    const glm::dvec3 d = -to_light;
    const double cos_i = glm::dot(to_light, n_i), k = 1 / eta;
    const glm::dvec3 w12 = glm::normalize(k * d + (k * cos_i - std::sqrt(1 - k * k * (1 - cos_i * cos_i))) * n_i);
    const glm::dvec3 x = x_o - x_i;
    const double r = glm::length(x);
    const glm::dvec3 ni_star = glm::cross(x / r, glm::normalize(glm::cross(n_i, x)));
    const glm::dvec3 w_v = w12 - 2 * glm::dot(w12, ni_star) * ni_star;
    const glm::dvec3 x_v = x_i + 2 * A * d_e * ni_star;
    const double mu0 = -glm::dot(n_o, w12);
    double d_r;
    if (mu0 > 0) {
        const double cos_beta = -std::sqrt((r * r - glm::dot(x, w12) * glm::dot(x, w12)) / (r * r + d_e * d_e));
        d_r = std::sqrt(r * r + D * mu0 * (D * mu0 - 2 * d_e * cos_beta));
    } else {
        d_r = std::sqrt(r * r + 1 / ((3 * sigma_t) * (3 * sigma_t)));
    }
    const double s = S_prime(x, w12, d_r) - S_prime(x_o - x_v, w_v, glm::length(x_o - x_v));
    return s > 0 ? s : 0;
}

}  // namespace aaf_ref
