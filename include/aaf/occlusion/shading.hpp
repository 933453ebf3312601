// SPDX-License-Identifier: MIT
#pragma once
// Shading with ambient occlusion: the lecture's AO-modulated diffuse term (FORMULAS.md §4.1), the irradiance
// of an environment given by 9 spherical-harmonic coefficients (Ramamoorthi & Hanrahan 2001, "An efficient
// representation for irradiance environment maps"), looked up with the bent normal or the normal, and a small
// sky model to make such coefficients from.

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "ao_stats.hpp"

namespace aaf {
inline namespace v0 {

/// K_d · (1 − occlusion) · max(0, N·L) (the lecture's AO-modulated diffuse), per colour channel. `n` and
/// `to_light` unit vectors. A NaN occlusion (no estimate) is taken as 0 (unoccluded), so a pixel without
/// AO still shades; occlusion is clamped to [0, 1].
template <class T>
[[nodiscard]] glm::vec<3, T> ao_diffuse(const glm::vec<3, T>& k_d, T occlusion, const glm::vec<3, T>& n,
                                        const glm::vec<3, T>& to_light) noexcept {
    const T o = std::isnan(occlusion) ? T(0) : std::clamp(occlusion, T(0), T(1));
    return k_d * ((T(1) - o) * std::max(T(0), glm::dot(n, to_light)));
}

/// Nine spherical-harmonic coefficients (bands 0–2) of an RGB radiance environment, in the real basis and
/// order of Ramamoorthi & Hanrahan 2001: L00, L1−1, L10, L11, L2−2, L2−1, L20, L21, L22 (y, z, x for band 1).
template <class T = float>
struct sh9 {
    std::array<glm::vec<3, T>, 9> c{};

    /// The 9 basis functions Y_lm at unit direction d (R&H 2001, eq. 3).
    [[nodiscard]] static std::array<T, 9> basis(const glm::vec<3, T>& d) noexcept {
        const T x = d.x, y = d.y, z = d.z;
        return {T(0.282095), T(0.488603) * y, T(0.488603) * z, T(0.488603) * x, T(1.092548) * x * y,
                T(1.092548) * y * z, T(0.315392) * (T(3) * z * z - T(1)), T(1.092548) * x * z,
                T(0.546274) * (x * x - y * y)};
    }

    /// Adds radiance `l` from unit direction `d` with quadrature weight `weight` (solid angle, e.g. 4π/N for
    /// N uniform sphere samples): projects an environment map or a sampled sky.
    void add(const glm::vec<3, T>& d, const glm::vec<3, T>& l, T weight) noexcept {
        const auto y = basis(d);
        for (int i = 0; i < 9; ++i) c[i] += l * (y[i] * weight);
    }
};

/// Irradiance E(n) = ∫ L(ω) max(0, n·ω) dω of the environment `sh` at unit direction `n` (the normal, or
/// the bent normal for AO), by R&H 2001, eq. 13 (c1 = 0.429043, c2 = 0.511664, c3 = 0.743125,
/// c4 = 0.886227, c5 = 0.247708). Exact for environments whose radiance has no band above 2 (constant,
/// linear gradients, a sky over a ground of another colour); within ≈ 3 % (R&H's bound on average) else.
/// Divide by π for the radiance of a white Lambertian surface.
template <class T>
[[nodiscard]] glm::vec<3, T> sh_irradiance(const sh9<T>& sh, const glm::vec<3, T>& n) noexcept {
    constexpr T c1 = T(0.429043), c2 = T(0.511664), c3 = T(0.743125), c4 = T(0.886227), c5 = T(0.247708);
    const T x = n.x, y = n.y, z = n.z;
    const auto& L = sh.c;
    return c1 * L[8] * (x * x - y * y) + c3 * L[6] * z * z + c4 * L[0] - c5 * L[6] +
           T(2) * c1 * (L[4] * x * y + L[7] * x * z + L[5] * y * z) + T(2) * c2 * (L[3] * x + L[1] * y + L[2] * z);
}

/// A small sky: radiance `zenith` straight up (along `up`), `ground` straight down, and between them
/// * `constant`: `zenith` everywhere (ground ignored);
/// * `gradient`: linear in cos θ = ω·up, L(ω) = ground + (zenith − ground)(1 + ω·up)/2;
/// * `sky_ground`: `zenith` over the whole upper hemisphere, `ground` under the horizon.
/// All three have no band above 1 that irradiance sees, so sh_irradiance of their coefficients is exact.
template <class T = float>
struct sky_model {
    enum class kind { constant, gradient, sky_ground };
    kind shape = kind::gradient;        ///< how radiance varies with elevation
    glm::vec<3, T> zenith{1, 1, 1};     ///< radiance straight up (W·m⁻²·sr⁻¹ or any consistent unit), ≥ 0
    glm::vec<3, T> ground{0, 0, 0};     ///< radiance straight down (gradient, sky_ground), ≥ 0
    glm::vec<3, T> up{0, 1, 0};         ///< the zenith direction; normalised on use (zero: +y)

    /// The radiance from unit direction `d`.
    [[nodiscard]] glm::vec<3, T> radiance(const glm::vec<3, T>& d) const noexcept {
        const T c = glm::dot(d, axis());
        switch (shape) {
            case kind::constant: return zenith;
            case kind::gradient: return ground + (zenith - ground) * ((T(1) + c) * T(0.5));
            case kind::sky_ground: return c > T(0) ? zenith : ground;
        }
        return zenith;
    }

    /// The unit zenith direction (+y for a zero or non-finite `up`).
    [[nodiscard]] glm::vec<3, T> axis() const noexcept {
        const glm::vec<3, T> u = detail::ao_unit_or_zero(up);
        return u != glm::vec<3, T>(0) ? u : glm::vec<3, T>(0, 1, 0);
    }

    /// The sky's 9 coefficients in closed form: a constant a projects to L00 = 2√π a; a term b (ω·up) to
    /// L1m = 2√(π/3) b up_m (m in y, z, x order); the sky/ground step a + b·sign(ω·up) projects like
    /// a + (3/2) b (ω·up) on bands 0 and 1, its even bands ≥ 2 vanish, and its odd bands ≥ 3 do not reach
    /// irradiance (R&H's Â_l = 0 there), so band 2 stays zero for all three shapes.
    [[nodiscard]] sh9<T> coefficients() const noexcept {
        constexpr T pi = std::numbers::pi_v<T>;
        const glm::vec<3, T> u = axis();
        glm::vec<3, T> a{0}, b{0};  // L(ω) ≈ a + b·(ω·up) as far as irradiance sees
        T b_scale = T(1);           // ∫ (ω·up)·Y1 over the sphere for the lobe, or over the step for sky_ground
        switch (shape) {
            case kind::constant: a = zenith; break;
            case kind::gradient:
                a = (zenith + ground) * T(0.5);
                b = (zenith - ground) * T(0.5);
                break;
            case kind::sky_ground:
                // sign(ω·up) projects on Y1 like 3/2 (ω·up) does: ∫ sign(c)·c dω = 2π, ∫ c·c dω = 4π/3.
                a = (zenith + ground) * T(0.5);
                b = (zenith - ground) * T(0.5);
                b_scale = T(1.5);
                break;
        }
        sh9<T> sh;
        sh.c[0] = a * (T(2) * std::sqrt(pi));
        const T k = T(2) * std::sqrt(pi / T(3)) * b_scale;
        sh.c[1] = b * (k * u.y);
        sh.c[2] = b * (k * u.z);
        sh.c[3] = b * (k * u.x);
        return sh;
    }
};

}  // namespace v0
}  // namespace aaf
