// SPDX-License-Identifier: MIT
#pragma once
// The directional dipole S_d(x_i, ω_i; x_o) of Frisvad, Hachisuka and Kjeldsen 2014 (FORMULAS.md §5.2), one
// colour channel at a time.

#include <algorithm>
#include <cmath>
#include <numbers>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "dipole.hpp"

namespace aaf {
inline namespace v0 {
namespace subsurface {

/// One channel's directional dipole. Lengths in the material's unit; S_d in 1/(length²·sr).
///
/// DEPARTURES from the sample code as FORMULAS.md §5.2 transcribes it (docs/DEVIATIONS.md, "subsurface"):
/// * The Fresnel moments C₁, C₂ come from quadrature (`fresnel_moment`), not the polynomial fits; the two agree
///   to 0.001 at η = 1.3 (tests/test_subsurface_profiles.cpp) and the quadrature has no range limits.
/// * The real-source distance for μ₀ ≤ 0 uses 1/(3σ_t′) where the code has 1/(3σ_t): aaf's materials carry
///   σ_s′ only (Jensen's table gives no g), so σ_t is unknown.
/// * d_r is floored at D/10: for μ₀ → 0⁺ at r = 0 the formula's d_r = Dμ₀ goes to 0 and S′_d to infinity
///   (the test "finite at r → 0" would otherwise fail); the floor only acts within D/10 of the entry point.
///
/// NOT energy-bounded near the lossless limit, as published: the planar albedo reaches 1.22 at σ_a = 0, η = 1.3
/// (the real source's d_r is shorter than the displacement its first-order term implies, and d_e = 2.131D puts
/// the image farther than the boundary condition's 2D); the authors' sample code gives the same values
/// (docs/DEVIATIONS.md S4). For energy-bounded output use the Jensen dipole.
struct directional_dipole {
    double sigma_tr = 0, D = 0, d_e = 0, A = 1, sigma_t_prime = 0;
    double C_phi = 0, C_E = 0, C_phi_inv = 0;  ///< C_φ(η), C_E(η), C_φ(1/η)
    double eta = 1.3;
    bool scatters = false;  ///< false when σ_s′ = 0 (no diffusion: S_d = 0)

    directional_dipole() = default;
    directional_dipole(double sigma_a, double sigma_s_prime, double eta_) noexcept : eta(eta_) {
        sigma_t_prime = sigma_a + sigma_s_prime;
        scatters = sigma_s_prime > 0 && sigma_t_prime > 0;
        if (!scatters) return;
        const double alpha = sigma_s_prime / sigma_t_prime;
        D = 1 / (3 * sigma_t_prime);
        sigma_tr = std::sqrt(sigma_a / D);
        d_e = 2.131 * D / std::sqrt(alpha);
        C_phi = 0.25 * (1 - 2 * fresnel_moment(eta, 1));
        C_E = 0.5 * (1 - 3 * fresnel_moment(eta, 2));
        C_phi_inv = 0.25 * (1 - 2 * fresnel_moment(1 / eta, 1));
        A = (1 - C_E) / (2 * C_phi);
    }

    /// S′_d(x, ω, r) of FORMULAS.md §5.2.
    [[nodiscard]] double s_prime(const glm::dvec3& x, const glm::dvec3& w, double r, const glm::dvec3& n_o) const noexcept {
        const double sr = sigma_tr * r, one = 1 + sr;
        const double xw = glm::dot(x, w), xn = glm::dot(x, n_o), wn = glm::dot(w, n_o);
        const double r2 = r * r;
        const double bracket = C_phi * (r2 / D + 3 * one * xw) -
                               C_E * (3 * D * one * wn - (one + 3 * D * (3 * one + sr * sr) / r2 * xw) * xn);
        return 1 / (4 * C_phi_inv) / (4 * std::numbers::pi * std::numbers::pi) * std::exp(-sr) / (r2 * r) * bracket;
    }

    /// S_d for light arriving at x_i (normal n_i) from direction `to_light` (unit, pointing away from the
    /// surface) and leaving at x_o (normal n_o), clamped at 0. Includes the entry transmittance T₁₂ when
    /// `entry_fresnel`; never the exit one T₂₁ (it depends on the view direction). Normals must be unit.
    /// Non-finite input gives 0; light from below n_i gives 0.
    [[nodiscard]] double evaluate(const glm::dvec3& x_i, const glm::dvec3& n_i, const glm::dvec3& to_light, const glm::dvec3& x_o,
                                  const glm::dvec3& n_o, bool entry_fresnel = true) const noexcept {
        if (!scatters) return 0;
        const double cos_i = glm::dot(to_light, n_i);
        if (!(cos_i > 0)) return 0;
        // ω₁₂: the light's travel direction −ω refracted into the medium (relative index 1/η on the way in).
        const double er = 1 / eta;
        const double cos_t = std::sqrt(std::max(0.0, 1 - er * er * (1 - cos_i * cos_i)));
        const glm::dvec3 w12 = -er * to_light + (er * cos_i - cos_t) * n_i;
        const glm::dvec3 x = x_o - x_i;
        const double r2 = glm::dot(x, x), r = std::sqrt(r2);
        // Modified normal n_i* (the plane containing x and n_i, tilted so that x lies in it).
        glm::dvec3 ni_star = n_i;
        const glm::dvec3 nxx = glm::cross(n_i, x);
        const double nxx_len = glm::length(nxx);
        if (r > 1e-12 * D && nxx_len > 1e-9 * r) ni_star = glm::cross(x / r, nxx / nxx_len);
        const glm::dvec3 w_v = w12 - 2 * glm::dot(w12, ni_star) * ni_star;
        const glm::dvec3 x_v = x_i + 2 * A * d_e * ni_star;
        const glm::dvec3 xo_xv = x_o - x_v;
        const double d_v = glm::length(xo_xv);
        const double mu0 = -glm::dot(n_o, w12);
        double dr2;
        if (mu0 > 0) {
            const double xw = glm::dot(x, w12);
            const double cos_beta = -std::sqrt(std::max(0.0, (r2 - xw * xw) / (r2 + d_e * d_e)));
            dr2 = r2 + D * mu0 * (D * mu0 - 2 * d_e * cos_beta);
        } else {
            dr2 = r2 + 1 / (9 * sigma_t_prime * sigma_t_prime);
        }
        const double d_r = std::max(std::sqrt(std::max(dr2, 0.0)), D / 10);
        const double s = s_prime(x, w12, d_r, n_o) - s_prime(xo_xv, w_v, d_v, n_o);
        double out = std::isfinite(s) ? std::max(s, 0.0) : 0.0;
        if (entry_fresnel) out *= fresnel_transmittance_in(cos_i, eta);
        return out;
    }
};

/// Directional dipoles for the three channels of a material.
struct rgb_directional_dipole {
    directional_dipole channel[3];
    rgb_directional_dipole() = default;
    template <class T>
    explicit rgb_directional_dipole(const material<T>& m) {
        for (int c = 0; c < 3; ++c) channel[c] = directional_dipole(double(m.sigma_a[c]), double(m.sigma_s_prime[c]), double(m.eta));
    }
    [[nodiscard]] glm::dvec3 evaluate(const glm::dvec3& x_i, const glm::dvec3& n_i, const glm::dvec3& to_light, const glm::dvec3& x_o,
                                      const glm::dvec3& n_o, bool entry_fresnel = true) const noexcept {
        return {channel[0].evaluate(x_i, n_i, to_light, x_o, n_o, entry_fresnel),
                channel[1].evaluate(x_i, n_i, to_light, x_o, n_o, entry_fresnel),
                channel[2].evaluate(x_i, n_i, to_light, x_o, n_o, entry_fresnel)};
    }
};

}  // namespace subsurface
}  // namespace v0
}  // namespace aaf
