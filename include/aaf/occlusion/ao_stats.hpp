// SPDX-License-Identifier: MIT
#pragma once
// Per-pixel ambient-occlusion record: the estimator's sums, the bent-normal sum and the hit-distance
// statistics z_min, z_max (FORMULAS.md §4.1, §4.2), the AO counterpart of occlusion_stats.hpp.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "hemisphere.hpp"

namespace aaf {
inline namespace v0 {

/// How an occluder's distance t (world units, from the ray origin) lowers a sample's visibility, with R the
/// maximum distance. A hit beyond R is no hit whatever the falloff.
enum class ao_falloff {
    none,       ///< any hit within R occludes fully: V = 0 (the lecture's binary AO). Default.
    linear,     ///< V = t / R: near hits occlude fully, hits near R hardly at all
    quadratic,  ///< V = (t / R)², occlusion 1 − (t/R)², softer towards R
};

/// The visibility of a sample whose nearest hit is at `t` (a miss is +∞): 1 for a miss or a hit at or beyond
/// `max_distance`; else per `f`. With R = +∞ every falloff is `none` (t / ∞ = 0): defined, documented.
template <class T>
[[nodiscard]] constexpr T falloff_visibility(ao_falloff f, T t, T max_distance) noexcept {
    if (!(t < max_distance)) return T(1);
    if (f == ao_falloff::none || !(max_distance < std::numeric_limits<T>::infinity())) return T(0);
    const T x = std::clamp(t / max_distance, T(0), T(1));
    return f == ao_falloff::linear ? x : x * x;
}

/// The ambient-occlusion samples of one pixel (or vertex).
///
/// Both sampling densities estimate the same quantity, the cosine-weighted ambient visibility
/// A = (1/π) ∫ V(ω) cos θ dω, as (1/N) Σ c_i with c_i = V_i (cosine sampling) or c_i = 2 cos θ_i V_i
/// (uniform sampling); the bent normal is the cosine-weighted mean unoccluded direction
/// normalize(∫ V ω cos θ dω), estimated as normalize(Σ c_i ω_i) with the same c_i under either density.
/// (FORMULAS.md §4.1 calls the uniform-sampled bent normal "the unweighted mean"; aaf weights it, so the
/// two densities converge to one bent normal: DEVIATIONS.md, occlusion row 1.)
namespace detail {

/// The unit vector along n (a G-buffer or mesh normal, a bent-normal sum), or a zero vector when it has none:
/// n is zero or has a non-finite component (docs/EXTREMES.md). Any other n, however short or long, has a
/// direction: it is divided by its largest component first, so that its length neither under- nor overflows.
/// (Dividing by |n| directly failed twice under fuzz_occlusion: for components near 1e-23 in float the squares
/// are denormal and |n| was 20 % off, so a fully occluded pixel's bent normal, its normal, had length 0.85;
/// and a bent-normal sum of falloff weights near 1e-24 gave bent normals of length 0.96–1.03, or below 1e-23
/// |n| = 0 lost the direction altogether.)
template <class T>
[[nodiscard]] glm::vec<3, T> ao_unit_or_zero(const glm::vec<3, T>& n) noexcept {
    if (!std::isfinite(n.x) || !std::isfinite(n.y) || !std::isfinite(n.z)) return glm::vec<3, T>(0);
    const T largest = std::max({std::abs(n.x), std::abs(n.y), std::abs(n.z)});
    if (!(largest > T(0))) return glm::vec<3, T>(0);
    const glm::vec<3, T> scaled = n / largest;  // largest component ±1: its length is in [1, √3]
    return scaled / glm::length(scaled);
}

}  // namespace detail

template <class T = float>
struct ao_stats {
    T visible_sum = 0;                              ///< Σ c_i (see above)
    glm::vec<3, T> bent_sum{0};                     ///< Σ c_i ω_i, world space
    std::uint32_t samples = 0;                      ///< samples drawn, N (including failed ones)
    std::uint32_t counted = 0;                      ///< samples that count in the estimate (not failed)
    std::uint32_t hits = 0;                         ///< counted samples whose ray found a distance within R
    T z_min = std::numeric_limits<T>::infinity();   ///< nearest hit distance over the distance samples
    T z_max = 0;                                    ///< farthest of the samples' nearest hits (0 = no hit)

    /// Records one sample along the world direction `direction` with cos θ = `cos_theta` (in (0, 1]), drawn
    /// with density `h`, whose visibility is `visibility` ∈ [0, 1] (falloff_visibility). A non-finite
    /// visibility or cosine (a failed sample) counts in `samples` only.
    constexpr void add(hemisphere_sampling h, T cos_theta, const glm::vec<3, T>& direction, T visibility) noexcept {
        ++samples;
        if (!std::isfinite(visibility) || !std::isfinite(cos_theta)) return;
        ++counted;
        const T c = (h == hemisphere_sampling::uniform ? T(2) * std::max(cos_theta, T(0)) : T(1)) * visibility;
        visible_sum += c;
        bent_sum += c * direction;
    }

    /// Records the hit distance of a distance sample (a nearest hit at `t` within the maximum distance).
    constexpr void add_hit_distance(T t) noexcept {
        if (!(t >= T(0)) || !std::isfinite(t)) return;
        ++hits;
        z_min = std::min(z_min, t);
        z_max = std::max(z_max, t);
    }

    /// Cosine-weighted ambient visibility Â = Σ c_i / N over the counted samples, in [0, 1] under cosine
    /// sampling (uniform sampling's unbiased estimate can exceed 1 by noise at small N; it is not clamped, so
    /// averages of it converge). NaN when no sample counted (no surface, or every sample failed).
    [[nodiscard]] constexpr T visibility() const noexcept {
        return counted > 0 ? visible_sum / static_cast<T>(counted) : std::numeric_limits<T>::quiet_NaN();
    }
    /// 1 − visibility().
    [[nodiscard]] constexpr T occlusion() const noexcept { return T(1) - visibility(); }
    /// The unit bent normal; `normal` when no unoccluded direction was seen (fully occluded, or no sample),
    /// so a lookup with it is always defined.
    [[nodiscard]] glm::vec<3, T> bent_normal(const glm::vec<3, T>& normal) const noexcept {
        const glm::vec<3, T> b = detail::ao_unit_or_zero(bent_sum);
        return b == glm::vec<3, T>(0) ? normal : b;
    }
    [[nodiscard]] constexpr bool has_hit() const noexcept { return hits > 0; }
};

/// Combines two records of the same pixel (e.g. the initial and the adaptive pass).
template <class T>
[[nodiscard]] constexpr ao_stats<T> merge(const ao_stats<T>& a, const ao_stats<T>& b) noexcept {
    ao_stats<T> m;
    m.visible_sum = a.visible_sum + b.visible_sum;
    m.bent_sum = a.bent_sum + b.bent_sum;
    m.samples = a.samples + b.samples;
    m.counted = a.counted + b.counted;
    m.hits = a.hits + b.hits;
    m.z_min = std::min(a.z_min, b.z_min);
    m.z_max = std::max(a.z_max, b.z_max);
    return m;
}

}  // namespace v0
}  // namespace aaf
