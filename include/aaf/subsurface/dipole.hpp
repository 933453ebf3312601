// SPDX-License-Identifier: MIT
#pragma once
// The Jensen et al. 2001 dipole diffusion profile R_d(r) (FORMULAS.md §5.1): Fresnel terms, the boundary
// term A in its two forms, the profile, its integral over a disc in closed form (which gives the total
// diffuse reflectance, exact per-texel weights and the CDF for sampling radii), and radius sampling.

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include <glm/vec3.hpp>

#include "material.hpp"

namespace aaf {
inline namespace v0 {
namespace subsurface {

/// Unpolarised Fresnel reflectance at a smooth interface for light travelling inside a medium of relative
/// index `eta` (n_inside / n_outside) towards the outside, at cos θ = `cos_theta` ∈ [0, 1] from the normal.
/// Total internal reflection gives 1. For light arriving from the outside use `eta` = 1/η.
template <class T>
[[nodiscard]] T fresnel_reflectance(T cos_theta, T eta) noexcept {
    cos_theta = std::clamp(cos_theta, T(0), T(1));
    const T sin2_t = eta * eta * (T(1) - cos_theta * cos_theta);  // Snell: sin θ_t = η sin θ_i
    if (sin2_t >= T(1)) return T(1);
    const T cos_t = std::sqrt(T(1) - sin2_t);
    // r_s, r_p for n_i = η, n_t = 1.
    const T rs = (eta * cos_theta - cos_t) / (eta * cos_theta + cos_t);
    const T rp = (cos_theta - eta * cos_t) / (cos_theta + eta * cos_t);
    const T r = T(0.5) * (rs * rs + rp * rp);
    return std::isfinite(r) ? std::clamp(r, T(0), T(1)) : T(1);
}

/// The Fresnel transmittance F_t = 1 − R for light entering a medium of relative index `eta` from outside at
/// cos θ = `cos_theta` (FORMULAS.md §5.1's F_t(η, ω)).
template <class T>
[[nodiscard]] T fresnel_transmittance_in(T cos_theta, T eta) noexcept {
    return T(1) - fresnel_reflectance(cos_theta, T(1) / eta);
}

/// The n-th Fresnel moment C_n(η) = ∫₀¹ R(μ; η) μⁿ dμ of the internal reflectance (light inside the medium),
/// computed by quadrature rather than fitted (FORMULAS.md §5.2 gives polynomial fits; §8.4 notes they are off
/// in the third digit: 2C₁(1.3) fit 0.4453 vs 0.4444). R = 1 below the critical cosine μ_c, so that part is
/// exact; above it the substitution μ = μ_c + (1 − μ_c)t² removes R's square-root kink at μ_c and a 64-point
/// composite Gauss–Legendre rule is exact to ~1e-9.
inline double fresnel_moment(double eta, int n) noexcept {
    const double mu_c = eta > 1 ? std::sqrt(1 - 1 / (eta * eta)) : 0.0;
    double sum = std::pow(mu_c, n + 1) / (n + 1);  // ∫₀^μc μⁿ dμ with R = 1
    // 4-point Gauss–Legendre on 16 panels of t ∈ [0, 1].
    constexpr double x[4] = {-0.8611363115940526, -0.3399810435848563, 0.3399810435848563, 0.8611363115940526};
    constexpr double w[4] = {0.3478548451374538, 0.6521451548625461, 0.6521451548625461, 0.3478548451374538};
    constexpr int panels = 16;
    for (int p = 0; p < panels; ++p) {
        const double a = double(p) / panels, b = double(p + 1) / panels;
        for (int k = 0; k < 4; ++k) {
            const double t = 0.5 * (a + b) + 0.5 * (b - a) * x[k];
            const double mu = mu_c + (1 - mu_c) * t * t;
            const double jac = 2 * (1 - mu_c) * t;
            sum += 0.5 * (b - a) * w[k] * jac * fresnel_reflectance(mu, eta) * std::pow(mu, n);
        }
    }
    return sum;
}

/// The classical diffuse Fresnel reflectance fit F_dr(η) (Egan & Hilgeman, as in Jensen 2001; FORMULAS.md
/// §5.1), valid for η > 1. For η < 1 it is evaluated at 1/η, as the ports FORMULAS.md read do (there is no
/// agreed form there; pick `boundary_term::fresnel_moments` for media less dense than their surroundings).
template <class T>
[[nodiscard]] T diffuse_fresnel_reflectance(T eta) noexcept {
    const T e = eta < T(1) ? T(1) / eta : eta;
    return T(-1.440) / (e * e) + T(0.710) / e + T(0.668) + T(0.0636) * e;
}

/// Which boundary term A the dipole uses.
enum class boundary_term {
    classical,        ///< A = (1 + F_dr)/(1 − F_dr) with the Egan–Hilgeman fit (Jensen 2001)
    fresnel_moments,  ///< A = (1 + 3C₂)/(1 − 2C₁) with the moments by quadrature (d'Eon; FHK 2014 via C_φ, C_E)
};

/// The boundary term A(η) (FORMULAS.md §5.1, §8.4): 2.602 (classical) and 2.340 (moments) at η = 1.3.
inline double boundary_A(double eta, boundary_term form) noexcept {
    // The fit leaves [0, 1) far from η ≈ 1 (F_dr(10) > 1 gives A < 0: a virtual source inside the medium and a
    // negative profile), so it is clamped there; the moments form stays in range by construction, but at
    // extreme η its denominator 1 − 2C₁ underflows, hence the same cap on A.
    constexpr double f_max = 1 - 1e-9;
    if (form == boundary_term::classical) {
        const double f = std::clamp(diffuse_fresnel_reflectance(eta), 0.0, f_max);
        return (1 + f) / (1 - f);
    }
    const double two_c1 = std::clamp(2 * fresnel_moment(eta, 1), 0.0, f_max);
    return std::min((1 + 3 * fresnel_moment(eta, 2)) / (1 - two_c1), 2 / (1 - f_max));
}

/// The dipole of one colour channel. Lengths in the material's unit; R_d in 1/length².
/// Computed in double: the profile spans many orders of magnitude near r = 0 and its integrals cancel.
struct dipole {
    double alpha_prime = 0;  ///< reduced albedo α′ = σ_s′/σ_t′, [0, 1]
    double sigma_tr = 0;     ///< effective transport coefficient √(3σ_a σ_t′), 1/length
    double z_r = 0;          ///< real source depth 1/σ_t′
    double z_v = 0;          ///< virtual source height z_r(1 + 4A/3)
    double A = 1;            ///< boundary term

    dipole() = default;
    /// Requires σ_a, σ_s′ ≥ 0 finite with σ_a + σ_s′ > 0 (use `validate(material)` at API boundaries).
    dipole(double sigma_a, double sigma_s_prime, double boundary_A_value) noexcept {
        const double st = sigma_a + sigma_s_prime;
        alpha_prime = sigma_s_prime / st;
        sigma_tr = std::sqrt(3 * sigma_a * st);
        z_r = 1 / st;
        A = boundary_A_value;
        z_v = z_r * (1 + 4 * A / 3);
    }

    /// R_d(r) (FORMULAS.md §5.1), in 1/length². Finite at r = 0 (d_r = z_r there) and for σ_a = 0.
    [[nodiscard]] double profile(double r) const noexcept {
        const double r2 = r * r;
        const double dr = std::sqrt(r2 + z_r * z_r), dv = std::sqrt(r2 + z_v * z_v);
        // A source at infinite distance (r² overflowing) contributes 0, not (1 + ∞)·e^{−∞} = NaN (fuzz finding).
        const double a = std::isinf(dr) ? 0.0 : z_r * (1 + sigma_tr * dr) * std::exp(-sigma_tr * dr) / (dr * dr * dr);
        const double b = std::isinf(dv) ? 0.0 : z_v * (1 + sigma_tr * dv) * std::exp(-sigma_tr * dv) / (dv * dv * dv);
        return alpha_prime / (4 * std::numbers::pi) * (a + b);
    }

    /// 2π∫₀^ρ R_d(r) r dr in closed form: with d = √(r² + z²), z(1 + σd)e^{−σd}/d³ · r dr = z(1 + σd)e^{−σd}/d² dd,
    /// whose antiderivative is −z e^{−σd}/d. So each source contributes (α′/2)[e^{−σz} − z e^{−σd(ρ)}/d(ρ)],
    /// written with expm1/log1p so small discs do not cancel. ρ = ∞ gives `total()`.
    [[nodiscard]] double disc_integral(double rho) const noexcept {
        if (!(rho > 0)) return 0;
        if (std::isinf(rho * rho)) return total();  // ρ² overflowing: the whole plane (ρ/z_v ≥ 1e150 … in practice)
        const auto source = [&](double z) {
            const double d = std::sqrt(rho * rho + z * z);
            const double delta = rho * rho / (d + z);  // d − z without cancellation
            // e^{−σz}[1 − (z/d)e^{−σΔ}] = −e^{−σz}·expm1(−log1p(Δ/z) − σΔ)
            return -std::exp(-sigma_tr * z) * std::expm1(-std::log1p(delta / z) - sigma_tr * delta);
        };
        return alpha_prime / 2 * (source(z_r) + source(z_v));
    }

    /// ∫ R_d(√(r² + Δ²)) dA over a disc of radius ρ whose plane lies Δ ≥ 0 away from the point (FORMULAS.md
    /// §5.3's per-texel weight with a depth difference Δz): the same antiderivative between d(0) = √(Δ² + z²)
    /// and d(ρ) = √(ρ² + Δ² + z²), i.e. (α′/2) Σ (z/d₀)·e^{−σd₀}·[1 − (d₀/d)e^{−σ(d−d₀)}]. Δ = 0 is disc_integral(ρ).
    [[nodiscard]] double disc_integral(double rho, double depth) const noexcept {
        if (!(rho > 0)) return 0;
        if (!(depth > 0)) return disc_integral(rho);
        if (std::isinf(depth)) return 0;  // infinitely far below: nothing (σ_tr = 0 would give 0·∞ = NaN below)
        const auto source = [&](double z) {
            const double d0 = std::sqrt(depth * depth + z * z);
            const double ez = z / d0 * std::exp(-sigma_tr * d0);
            if (std::isinf(rho * rho + d0 * d0)) return ez;
            const double d = std::sqrt(rho * rho + d0 * d0);
            const double delta = rho * rho / (d + d0);
            return -ez * std::expm1(-std::log1p(delta / d0) - sigma_tr * delta);
        };
        return alpha_prime / 2 * (source(z_r) + source(z_v));
    }

    /// Total diffuse reflectance R_d^tot = (α′/2)(1 + e^{−(4/3)A√(3(1−α′))})e^{−√(3(1−α′))} (FORMULAS.md §5.1),
    /// evaluated as (α′/2)(e^{−σ_tr z_r} + e^{−σ_tr z_v}): the same value, since √(3(1−α′)) = σ_tr z_r and
    /// z_v = z_r(1 + 4A/3), but without forming 1 − α′, which rounds to 0 when σ_a/σ_s′ < 1e-16 while σ_tr z_v is
    /// still of order 1 (σ_a = 0.004, σ_s′ = 2e16 mm⁻¹, A = 2e9: the textbook form gave 1, the disc integral's
    /// limit 0.57, and radius_of_fraction never reached 99 % of it — a fuzz finding).
    [[nodiscard]] double total() const noexcept {
        return alpha_prime / 2 * (std::exp(-sigma_tr * z_r) + std::exp(-sigma_tr * z_v));
    }

    /// The radius below which a fraction `fraction` ∈ (0, 1) of the total lies (bisection on the closed form).
    [[nodiscard]] double radius_of_fraction(double fraction) const noexcept {
        const double target = std::clamp(fraction, 0.0, 1.0) * total();
        double lo = 0, hi = std::max({z_v, z_r, 1e-300});
        while (disc_integral(hi) < target && hi < 1e150) hi *= 2;
        for (int i = 0; i < 200 && hi - lo > 1e-15 * hi; ++i) {
            const double mid = 0.5 * (lo + hi);
            (disc_integral(mid) < target ? lo : hi) = mid;
        }
        return 0.5 * (lo + hi);
    }
};

/// One dipole per colour channel of a material.
struct rgb_dipole {
    dipole channel[3];

    rgb_dipole() = default;
    template <class T>
    explicit rgb_dipole(const material<T>& m, boundary_term form = boundary_term::classical) {
        const double A = boundary_A(double(m.eta), form);
        for (int c = 0; c < 3; ++c) channel[c] = dipole(double(m.sigma_a[c]), double(m.sigma_s_prime[c]), A);
    }
    [[nodiscard]] glm::dvec3 profile(double r) const noexcept {
        return {channel[0].profile(r), channel[1].profile(r), channel[2].profile(r)};
    }
    [[nodiscard]] glm::dvec3 disc_integral(double rho) const noexcept {
        return {channel[0].disc_integral(rho), channel[1].disc_integral(rho), channel[2].disc_integral(rho)};
    }
    [[nodiscard]] glm::dvec3 disc_integral(double rho, double depth) const noexcept {
        return {channel[0].disc_integral(rho, depth), channel[1].disc_integral(rho, depth), channel[2].disc_integral(rho, depth)};
    }
    [[nodiscard]] glm::dvec3 total() const noexcept { return {channel[0].total(), channel[1].total(), channel[2].total()}; }
    /// The smallest σ_tr over channels: 1/σ_tr_min is the longest diffusion length, which sets gather radii.
    [[nodiscard]] double min_sigma_tr() const noexcept {
        return std::min({channel[0].sigma_tr, channel[1].sigma_tr, channel[2].sigma_tr});
    }
    /// The largest σ_tr over channels: 1/σ_tr_max is the shortest diffusion length, which bounds epsilons.
    [[nodiscard]] double max_sigma_tr() const noexcept {
        return std::max({channel[0].sigma_tr, channel[1].sigma_tr, channel[2].sigma_tr});
    }
};

/// Radii drawn from R_d: a tabulated inverse of the closed-form CDF F(ρ) = disc_integral(ρ)/disc_integral(R)
/// on [0, R], one table per channel. Built once per material and radius (exact bisection at `table_size`
/// points, linear in between), so drawing a radius costs one table lookup instead of a root search.
/// With three channels, a sample uses one channel's table and the balance-heuristic pdf of all three
/// (`pdf_area`), so every channel's estimator stays unbiased.
class radius_sampler {
public:
    radius_sampler() = default;
    /// `radius` > 0 (may be +∞: then the table ends at the 1 − 1e-6 quantile of each channel).
    radius_sampler(const rgb_dipole& d, double radius, std::size_t table_size = 1024) : dipole_(d), radius_(radius) {
        for (int c = 0; c < 3; ++c) {
            const dipole& ch = d.channel[c];
            const double rmax = std::isinf(radius) ? ch.radius_of_fraction(1 - 1e-6) : radius;
            norm_[c] = ch.disc_integral(rmax);
            table_[c].resize(table_size + 1);
            if (!(norm_[c] > 0) || !std::isfinite(norm_[c]) || !(rmax > 0) || !std::isfinite(rmax)) {
                // No profile to follow (σ_s′ = 0, or an underflowing one): uniform over the disc's area, which the
                // s = √u table gives with ρ = R·s; pdf_area counts it as 1/(πR²).
                uniform_[c] = true;
                const double r_uniform = std::isfinite(radius) && radius > 0 ? radius : 1.0;
                for (std::size_t i = 0; i <= table_size; ++i) table_[c][i] = r_uniform * double(i) / double(table_size);
                continue;
            }
            // Invert the closed-form CDF on a fine forward grid ρ_k = rmax·(k/K)² (dense where R_d peaks), then
            // interpolate: 8·table_size evaluations instead of a root search per entry.
            const std::size_t K = 8 * table_size;
            std::size_t k = 0;
            double rho_prev = 0, cdf_prev = 0;
            for (std::size_t i = 0; i <= table_size; ++i) {
                // Tabulated over s = √u: near ρ = 0 the CDF grows like ρ², so ρ(s) is close to linear there.
                const double su = double(i) / double(table_size);
                const double target = su * su;
                double rho_next = rho_prev, cdf_next = cdf_prev;
                while (k < K) {
                    const double q = double(k + 1) / double(K);
                    rho_next = rmax * q * q;
                    cdf_next = ch.disc_integral(rho_next) / norm_[c];
                    if (cdf_next >= target) break;
                    rho_prev = rho_next, cdf_prev = cdf_next;
                    ++k;
                }
                const double f = cdf_next > cdf_prev ? std::clamp((target - cdf_prev) / (cdf_next - cdf_prev), 0.0, 1.0) : 0.0;
                table_[c][i] = rho_prev + f * (rho_next - rho_prev);
            }
            table_[c][0] = 0;
            table_[c][table_size] = rmax;
        }
    }

    /// A radius for channel `c` from u ∈ [0, 1).
    [[nodiscard]] double radius(int c, double u) const noexcept {
        const std::vector<double>& t = table_[c];
        const double x = std::sqrt(std::clamp(u, 0.0, 1.0)) * double(t.size() - 1);
        const auto i = std::min(static_cast<std::size_t>(x), t.size() - 2);
        const double f = x - double(i);
        return t[i] + f * (t[i + 1] - t[i]);
    }

    /// The area density (per unit of disc area) of a point at distance ρ from the centre, averaged over the
    /// three channels' tables (balance heuristic). Exact for the continuous CDF; the tables' linear pieces
    /// make the drawn density deviate by O(1/table_size²) within a piece.
    [[nodiscard]] double pdf_area(double rho) const noexcept {
        double p = 0;
        for (int c = 0; c < 3; ++c) {
            if (uniform_[c]) {
                const double r_uniform = table_[c].back();
                p += rho <= r_uniform ? 1 / (std::numbers::pi * r_uniform * r_uniform) : 0.0;
            } else {
                p += dipole_.channel[c].profile(rho) / norm_[c];
            }
        }
        return p / 3;
    }
    [[nodiscard]] double max_radius() const noexcept { return radius_; }
    [[nodiscard]] const rgb_dipole& profile() const noexcept { return dipole_; }

private:
    rgb_dipole dipole_;
    double radius_ = 0;
    double norm_[3] = {1, 1, 1};
    bool uniform_[3] = {false, false, false};
    std::vector<double> table_[3];
};

}  // namespace subsurface
}  // namespace v0
}  // namespace aaf
