// SPDX-License-Identifier: MIT
#pragma once
// The paper's formulas: bandwidths, filter bandwidth Ω*, filter width β and sample count n
// (FORMULAS.md §1.4–§1.10), each defined and finite-or-+∞-by-design at every limit.
//
// Symbols: σ light std-dev (world units, area_light::sigma), d projected pixel size (world units),
// s1 ≥ s2 ≥ 0 the slopes (occlusion_stats.hpp), k, μ, α the paper's constants (formula_settings).
//
// Limits, and what each function returns there (tested in tests/test_formulas.cpp):
// * no occluder (s2 = +∞)  → Ω* = +∞, β = 0 (nothing to filter), n = 0 (no adaptive samples wanted);
// * contact, s2 → 0         → light bound +∞, Ω* pixel-limited, β = d(1+s2)/(kμα) (paper form) or
//                             d(1+s2)/(kα) (authors' form): well under a pixel, a near no-op filter;
//                             paper n → +∞ (callers clamp it, as the paper says); authors' n finite
//                             for d > 0 (+∞ when d = 0 and s1 > 0, which clamps the same way);
// * occluder at the light   → slopes capped at max_slope by slopes(), everything finite;
// * point light, σ = 0      → Ω* pixel-limited (β as at contact); n = 1 (no penumbra: one sample is exact);
// * zero pixel size, d = 0  → pixel bound +∞, Ω* light-limited; n uses d·Ω* → 0;
// * NaN inputs              → treated as "no occluder" (NaN s1, s2, σ or d, and a NaN Ω* given to filter_width);
// * indeterminate n         → 0, as for "no occluder" (∞/∞ or ∞·0 inside n: σ = d = +∞ together, or s1 = +∞
//                             with the bandwidth terms underflowed to 0); target_samples gives the minimum.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#include "occlusion_stats.hpp"
#include "settings.hpp"

namespace aaf {
inline namespace v0 {

namespace detail {
template <class T>
inline constexpr T inf = std::numeric_limits<T>::infinity();

/// a / b with the limits the formulas need: x/0 = +∞ for x > 0, 0/0 = 0, x/∞ = 0.
template <class T>
[[nodiscard]] constexpr T safe_div(T a, T b) noexcept {
    if (b > T(0)) return a / b;
    return a > T(0) ? inf<T> : T(0);
}

/// The "NaN inputs → no occluder" rule of the header comment: slopes, σ and d must all be non-NaN.
template <class T>
[[nodiscard]] constexpr bool formula_inputs_valid(const slope_pair<T>& s, T sigma, T pixel_size) noexcept {
    return s.has_occluder() && !std::isnan(s.s1) && !std::isnan(s.s2) && !std::isnan(sigma) && !std::isnan(pixel_size);
}
}  // namespace detail

/// Light bandwidth Ω_L^max = 1/σ (FORMULAS.md §1.4, reading A). +∞ for a point light.
template <class T>
[[nodiscard]] constexpr T light_bandwidth(T sigma) noexcept {
    return detail::safe_div(T(1), sigma);
}

/// Pixel bandwidth Ω_pix^max = 1/d (§1.5). +∞ for a zero footprint.
template <class T>
[[nodiscard]] constexpr T pixel_bandwidth(T pixel_size) noexcept {
    return detail::safe_div(T(1), pixel_size);
}

/// Projected pixel size of a pinhole camera (§1.5): d = 2·t·tan(fov_y/2)/H, with t the primary-ray hit
/// distance and H the image height in pixels.
template <class T>
[[nodiscard]] constexpr T pinhole_pixel_size(T hit_distance, T tan_half_fov_y, std::uint32_t image_height) noexcept {
    return image_height > 0 ? T(2) * hit_distance * tan_half_fov_y / static_cast<T>(image_height) : T(0);
}

/// Receiver-space bandlimit Ω_x^max = α Ω_pix^max / (1 + s2) = α/(d(1 + s2)) (§1.6).
template <class T>
[[nodiscard]] constexpr T receiver_bandlimit(T pixel_size, T s2, T alpha) noexcept {
    return detail::safe_div(alpha, pixel_size * (T(1) + s2));
}

/// The light-limited bound Ω_L^max / s2 = 1/(σ s2) (§1.7). +∞ when σ s2 = 0.
template <class T>
[[nodiscard]] constexpr T light_limited_bandwidth(T sigma, T s2) noexcept {
    return detail::safe_div(T(1), sigma * s2);
}

/// The light's standard deviation the filter width assumes: σ for the paper's Gaussian light, σ/√3 for the
/// uniform parallelogram (light_profile::box, the per-axis standard deviation of a square of side 2σ).
template <class T>
[[nodiscard]] constexpr T filter_light_sigma(T sigma, light_profile profile) noexcept {
    return profile == light_profile::box ? sigma * T(0.57735026918962576451) : sigma;  // 1/√3
}

/// Filter bandwidth Ω* in world units⁻¹ (§1.7): paper μ·min(1/(σ s2), Ω_x^max); authors min(μ/(σ s2), Ω_x^max).
/// With formula_settings::light = light_profile::box the light term uses σ/√3 (filter_light_sigma; a
/// deviation from the paper, DEVIATIONS.md), times formula_settings::light_scale (DEVIATIONS.md L1): Ω* and β
/// only, sample_count keeps the paper's σ.
template <class T>
[[nodiscard]] constexpr T filter_bandwidth(const slope_pair<T>& s, T sigma, T pixel_size,
                                           const formula_settings<T>& f) noexcept {
    if (!detail::formula_inputs_valid(s, sigma, pixel_size)) return detail::inf<T>;
    const T light = light_limited_bandwidth(filter_light_sigma(sigma, f.light) * f.light_scale, s.s2);
    const T pixel = receiver_bandlimit(pixel_size, s.s2, f.alpha);
    return f.form == formula_form::paper ? f.mu * std::min(light, pixel) : std::min(f.mu * light, pixel);
}

/// Filter width β = 1/(kΩ*) in world units (§1.8): the standard deviation of the Gaussian in the plane
/// parallel to the light. 0 for Ω* = +∞ (do not filter).
template <class T>
[[nodiscard]] constexpr T filter_width(T omega, T k) noexcept {
    if (std::isnan(k * omega)) return T(0);  // a NaN input means "no occluder": do not filter
    return detail::safe_div(T(1), k * omega);
}

/// Convenience: β straight from the slopes.
template <class T>
[[nodiscard]] constexpr T filter_width(const slope_pair<T>& s, T sigma, T pixel_size, const formula_settings<T>& f) noexcept {
    return filter_width(filter_bandwidth(s, sigma, pixel_size, f), f.k);
}

/// Samples per pixel n (§1.9), real-valued and unclamped (may be +∞ in the paper form at contact;
/// clamp with target_samples). 0 when there is no occluder; 1 for a point light (σ = 0).
template <class T>
[[nodiscard]] constexpr T sample_count(const slope_pair<T>& s, T sigma, T pixel_size, const formula_settings<T>& f) noexcept {
    using detail::safe_div;
    if (!detail::formula_inputs_valid(s, sigma, pixel_size)) return T(0);
    if (!(sigma > T(0))) return T(1);
    const T pixel_term = f.alpha / (T(1) + s.s2);  // α (1 + s2)^-1 = d Ω_x^max
    // s1/s2 → 1 along s1 = s2 → 0: a single contact depth has a one-line spectrum.
    const T ratio = (s.s1 == T(0) && s.s2 == T(0)) ? T(1) : safe_div(s.s1, s.s2);
    if (f.form == formula_form::paper) {
        // μ (2/s2) √(A_p/A_l) with A_p = d², A_l = 4σ²  =  μ d/(σ s2).
        const T light_term = pixel_size > T(0) ? safe_div(f.mu * pixel_size, sigma * s.s2) : T(0);
        const T a = T(1) + f.mu * ratio;
        const T b = light_term + pixel_term;
        const T n = T(4) * a * a * b * b;
        return std::isnan(n) ? T(0) : n;
    }
    // Authors: 4 (α/(1+s2) + dΩ*)² (1 + σ min(s1Ω*, s1/(d(1+s1))))², with dΩ* and σ s1Ω* expanded so that
    // d = 0 and s2 = 0 stay defined.
    const T d_omega = std::min(pixel_size > T(0) ? safe_div(f.mu * pixel_size, sigma * s.s2) : T(0), pixel_term);
    const T sigma_s1_omega = std::min(f.mu * ratio, safe_div(sigma * s.s1 * f.alpha, pixel_size * (T(1) + s.s2)));
    const T wedge = std::min(sigma_s1_omega, safe_div(sigma * s.s1, pixel_size * (T(1) + s.s1)));
    const T a = pixel_term + d_omega;
    const T b = T(1) + wedge;
    const T n = T(4) * a * a * b * b;
    return std::isnan(n) ? T(0) : n;
}

/// Rounds n up and clamps it to [minimum, maximum]; NaN gives `minimum`.
template <class T>
[[nodiscard]] constexpr std::uint32_t target_samples(T n, std::uint32_t minimum, std::uint32_t maximum) noexcept {
    if (!(n > static_cast<T>(minimum))) return minimum;
    if (!(n < static_cast<T>(maximum))) return maximum;
    return static_cast<std::uint32_t>(std::ceil(n));
}

}  // namespace v0
}  // namespace aaf
