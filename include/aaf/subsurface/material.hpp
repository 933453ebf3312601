// SPDX-License-Identifier: MIT
#pragma once
// Scattering coefficients of a translucent material per colour channel, and Jensen et al. 2001's measured
// table as named presets (FORMULAS.md §5.1).

#include <cmath>
#include <string>

#include <glm/vec3.hpp>

#include "../config.hpp"

namespace aaf {
inline namespace v0 {
namespace subsurface {

/// A homogeneous translucent medium, one value per colour channel (R, G, B).
/// Coefficients are per unit of length of the scene they are used in (the presets are in mm⁻¹: convert with
/// `in_units`). `eta` is the medium's index of refraction relative to the outside (n_medium / n_outside).
template <class T = float>
struct material {
    glm::vec<3, T> sigma_a{T(0)};      ///< absorption coefficient σ_a, per unit length, [0, ∞), finite
    glm::vec<3, T> sigma_s_prime{T(1)};  ///< reduced scattering σ_s′ = σ_s(1 − g), per unit length, [0, ∞), finite
    T eta = T(1.3);                    ///< relative index of refraction, (0, ∞); 1.3 in Jensen's table

    /// The same material in a scene whose length unit is `unit_in_preset_units` preset units long, e.g.
    /// `marble().in_units(1000)` for a scene modelled in metres (1 m = 1000 mm): coefficients are per length,
    /// so they scale by the unit's length.
    [[nodiscard]] constexpr material in_units(T unit_in_preset_units) const noexcept {
        return {sigma_a * unit_in_preset_units, sigma_s_prime * unit_in_preset_units, eta};
    }
};

namespace detail {
template <class T>
[[nodiscard]] bool finite_nonnegative(const glm::vec<3, T>& v) noexcept {
    return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z) && v.x >= T(0) && v.y >= T(0) && v.z >= T(0);
}
}  // namespace detail

/// Throws aaf::invalid_argument (naming `function` and the field) unless the coefficients are finite and
/// non-negative, some extinction is present in every channel (σ_a + σ_s′ > 0: otherwise the medium is
/// vacuum and the dipole's z_r = 1/σ_t′ is infinite), and 0 < η < ∞.
template <class T>
void validate(const material<T>& m, const char* function) {
    using aaf::detail::throw_invalid;
    if (!detail::finite_nonnegative(m.sigma_a)) throw_invalid(function, "`material.sigma_a` must be finite and >= 0 in every channel");
    if (!detail::finite_nonnegative(m.sigma_s_prime))
        throw_invalid(function, "`material.sigma_s_prime` must be finite and >= 0 in every channel");
    for (int c = 0; c < 3; ++c)
        if (!(m.sigma_a[c] + m.sigma_s_prime[c] > T(0)))
            throw_invalid(function, "`material` has zero extinction (sigma_a + sigma_s_prime = 0) in channel " + std::to_string(c));
    if (!(m.eta > T(0)) || !std::isfinite(m.eta)) throw_invalid(function, "`material.eta` must be finite and > 0");
}

/// Jensen, Marschner, Levoy, Hanrahan 2001, Table "measured scattering parameters", in mm⁻¹, η = 1.3.
///
/// Which values we trust (FORMULAS.md §5.1 lists disagreements between copies): we use the values that
/// pbrt's and yocto's tables agree on, because they are two independent transcriptions that match each
/// other digit for digit; the one port that disagrees is alone and its variants look like transcription
/// slips. Concretely:
/// * Chicken1 σ_a(R) = 0.015 and Chicken2 σ_a(R) = 0.018 (not 0.0015 / 0.0018): with 0.0015 chicken would
///   absorb red ten times less than green (0.077) and be the least red-absorbing entry after cream, which
///   contradicts its measured colour; the 0.015/0.018 values keep the R < G < B ordering of every meat entry.
/// * Marble η = 1.3 (not 1.5): Jensen's table gives one η for all materials; 1.5 is calcite's refractive
///   index, which one port substituted. Use `marble_eta15()` if you want that variant; the tests check
///   FORMULAS.md §8.4's totals for both.
/// None of these was checked against the original paper's table (not readable to us), so they carry the
/// STD (two-source) confidence of FORMULAS.md, not EXACT.
namespace presets {
template <class T = float>
[[nodiscard]] constexpr material<T> apple() { return {{T(0.0030), T(0.0034), T(0.046)}, {T(2.29), T(2.39), T(1.97)}, T(1.3)}; }
template <class T = float>
[[nodiscard]] constexpr material<T> chicken1() { return {{T(0.015), T(0.077), T(0.19)}, {T(0.15), T(0.21), T(0.38)}, T(1.3)}; }
template <class T = float>
[[nodiscard]] constexpr material<T> chicken2() { return {{T(0.018), T(0.088), T(0.20)}, {T(0.19), T(0.25), T(0.32)}, T(1.3)}; }
template <class T = float>
[[nodiscard]] constexpr material<T> cream() { return {{T(0.0002), T(0.0028), T(0.0163)}, {T(7.38), T(5.47), T(3.15)}, T(1.3)}; }
template <class T = float>
[[nodiscard]] constexpr material<T> ketchup() { return {{T(0.061), T(0.97), T(1.45)}, {T(0.18), T(0.07), T(0.03)}, T(1.3)}; }
template <class T = float>
[[nodiscard]] constexpr material<T> marble() { return {{T(0.0021), T(0.0041), T(0.0071)}, {T(2.19), T(2.62), T(3.00)}, T(1.3)}; }
/// Marble with η = 1.5, the variant one port lists (see above).
template <class T = float>
[[nodiscard]] constexpr material<T> marble_eta15() { return {{T(0.0021), T(0.0041), T(0.0071)}, {T(2.19), T(2.62), T(3.00)}, T(1.5)}; }
template <class T = float>
[[nodiscard]] constexpr material<T> potato() { return {{T(0.0024), T(0.0090), T(0.12)}, {T(0.68), T(0.70), T(0.55)}, T(1.3)}; }
template <class T = float>
[[nodiscard]] constexpr material<T> skim_milk() { return {{T(0.0014), T(0.0025), T(0.0142)}, {T(0.70), T(1.22), T(1.90)}, T(1.3)}; }
template <class T = float>
[[nodiscard]] constexpr material<T> skin1() { return {{T(0.032), T(0.17), T(0.48)}, {T(0.74), T(0.88), T(1.01)}, T(1.3)}; }
template <class T = float>
[[nodiscard]] constexpr material<T> skin2() { return {{T(0.013), T(0.070), T(0.145)}, {T(1.09), T(1.59), T(1.79)}, T(1.3)}; }
/// Spectralon has σ_a = 0: the dipole is then lossless (α′ = 1, σ_tr = 0) and R_d's total is 1 for any A.
template <class T = float>
[[nodiscard]] constexpr material<T> spectralon() { return {{T(0), T(0), T(0)}, {T(11.6), T(20.4), T(14.9)}, T(1.3)}; }
template <class T = float>
[[nodiscard]] constexpr material<T> whole_milk() { return {{T(0.0011), T(0.0024), T(0.014)}, {T(2.55), T(3.21), T(3.77)}, T(1.3)}; }
}  // namespace presets

}  // namespace subsurface
}  // namespace v0
}  // namespace aaf
