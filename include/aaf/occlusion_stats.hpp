// SPDX-License-Identifier: MIT
#pragma once
// Per-pixel occlusion-distance statistics: weighted visibility, sample counts, d1, d2min, d2max.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#include "tracer.hpp"

namespace aaf {
inline namespace v0 {

/// The two slopes bounding a pixel's occlusion spectrum (FORMULAS.md §1.2), s1 ≥ s2 ≥ 0.
/// "No occluder" is s1 = 0, s2 = +∞: the identity of the max/min used to spread slopes (§1.12).
template <class T = float>
struct slope_pair {
    T s1 = 0;                                       ///< steepest slope d1/d2min − 1 (maximum over samples)
    T s2 = std::numeric_limits<T>::infinity();      ///< flattest slope d1/d2max − 1 (minimum over samples)
    [[nodiscard]] constexpr bool has_occluder() const noexcept { return s2 < std::numeric_limits<T>::infinity(); }
};

/// Statistics of the shadow samples of one pixel.
///
/// Distances follow the theory's convention (FORMULAS.md §1.1): d1 is the receiver's perpendicular
/// distance to the light's plane, d2 an occluder's perpendicular distance to it. aaf derives d2 from the
/// hit distance t along a segment of length L as d2 = d1·(L − t)/L, which is exact for any sample
/// direction (similar triangles) and makes each sample's slope s = d1/d2 − 1 = t/(L − t).
template <class T = float>
struct occlusion_stats {
    T visible_weight = 0;                            ///< Σ weight of samples that reached the light
    T total_weight = 0;                              ///< Σ weight of all counted samples
    std::uint32_t samples = 0;                       ///< samples drawn (including zero-weight ones)
    std::uint32_t occluded = 0;                      ///< samples that hit an occluder and gave its distances
    T d1 = 0;                                        ///< receiver-to-light-plane distance (world units)
    T d2min = std::numeric_limits<T>::infinity();    ///< smallest occluder-to-light distance seen
    T d2max = 0;                                     ///< largest occluder-to-light distance seen

    /// Records one sample of weight `weight` (see light_weighting) for a receiver at distance `d1` from the
    /// light plane, traced along a segment of length `length`, with occluders `hit`. A sample whose
    /// weight, d1 or length is not finite, or whose hit has a NaN distance (a failed sample, tracer.hpp),
    /// is counted in `samples` but contributes nothing else.
    constexpr void add_sample(T weight, T receiver_d1, T length, const occluder_span<T>& hit) noexcept {
        ++samples;
        if (!(weight > T(0)) || !std::isfinite(weight) || !std::isfinite(receiver_d1) || !(length > T(0)) ||
            !std::isfinite(length) || std::isnan(hit.nearest) || std::isnan(hit.farthest))
            return;
        d1 = receiver_d1;
        total_weight += weight;
        if (!hit.hit()) {
            visible_weight += weight;
            return;
        }
        ++occluded;
        // Clamp into [0, L]: the tracer contract promises it, noise may not.
        const T near_t = std::clamp(hit.nearest, T(0), length);
        const T far_t = std::clamp(hit.farthest, near_t, length);
        d2max = std::max(d2max, receiver_d1 * (length - near_t) / length);
        d2min = std::min(d2min, receiver_d1 * (length - far_t) / length);
    }

    /// Records one visibility-only sample (shadow_query::visibility): it counts in `samples`, `total_weight`
    /// and, when not `blocked`, `visible_weight`, but leaves d1, d2min, d2max and `occluded` alone, so the
    /// slopes stay those of the distance samples. A weight that is not finite and positive counts in
    /// `samples` only, as in add_sample.
    constexpr void add_visibility_sample(T weight, bool blocked) noexcept {
        ++samples;
        if (!(weight > T(0)) || !std::isfinite(weight)) return;
        total_weight += weight;
        if (!blocked) visible_weight += weight;
    }

    /// Visibility in [0, 1]: Σ weight of unoccluded samples / Σ weight. NaN when no sample counted
    /// (every light point below the horizon or behind the light) — the caller decides what that means.
    [[nodiscard]] constexpr T visibility() const noexcept {
        return total_weight > T(0) ? visible_weight / total_weight : std::numeric_limits<T>::quiet_NaN();
    }
    [[nodiscard]] constexpr bool has_occluder() const noexcept { return occluded > 0; }
    [[nodiscard]] constexpr bool has_light() const noexcept { return total_weight > T(0); }
};

/// Combines two records of the same pixel (e.g. initial and adaptive passes, or two tiles of samples).
/// Associative and commutative up to floating-point rounding.
template <class T>
[[nodiscard]] constexpr occlusion_stats<T> merge(const occlusion_stats<T>& a, const occlusion_stats<T>& b) noexcept {
    occlusion_stats<T> m;
    m.visible_weight = a.visible_weight + b.visible_weight;
    m.total_weight = a.total_weight + b.total_weight;
    m.samples = a.samples + b.samples;
    m.occluded = a.occluded + b.occluded;
    m.d1 = a.total_weight > T(0) ? a.d1 : b.d1;
    m.d2min = std::min(a.d2min, b.d2min);
    m.d2max = std::max(a.d2max, b.d2max);
    return m;
}

/// Slopes of FORMULAS.md §1.2 from a record, guarded at every limit:
/// * no occluder → {0, +∞} (the "no slopes" identity);
/// * noise with d2 > d1 → d2 clamped to d1 (s = 0, a contact shadow);
/// * d2 → 0 (occluder at the light) → d2 clamped to d1 / (1 + max_slope), so s ≤ max_slope;
/// * non-finite d1 or NaN d2 (a corrupted record) → treated as no occluder.
template <class T>
[[nodiscard]] constexpr slope_pair<T> slopes(const occlusion_stats<T>& s, T max_slope = T(1e6)) noexcept {
    if (!s.has_occluder() || !(s.d1 > T(0)) || !std::isfinite(s.d1) || std::isnan(s.d2min) || std::isnan(s.d2max))
        return {};
    const T floor_d2 = s.d1 / (T(1) + max_slope);
    const T d2min = std::clamp(s.d2min, floor_d2, s.d1);
    const T d2max = std::clamp(s.d2max, d2min, s.d1);
    // The floor underflows to 0 for a denormal d1 (d1 < max_slope · denorm_min), and −0 passes a clamp to +0:
    // a d2 that is still not positive is at the light, the cap.
    const T s1 = d2min > T(0) ? std::min(s.d1 / d2min - T(1), max_slope) : max_slope;
    return {s1, d2max > T(0) ? std::min(s.d1 / d2max - T(1), s1) : s1};
}

}  // namespace v0
}  // namespace aaf
