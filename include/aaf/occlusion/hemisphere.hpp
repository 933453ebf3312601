// SPDX-License-Identifier: MIT
#pragma once
// Hemisphere directions for ambient occlusion: the sampler's per-pixel point sets (sampler.hpp) mapped onto
// the hemisphere around a normal, cosine-weighted or uniform (FORMULAS.md §4.1).

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <span>

#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "../sampler.hpp"
#include "../tangent_frame.hpp"

namespace aaf {
inline namespace v0 {

/// The density hemisphere directions are drawn with. Each has its own estimator (ao_stats.hpp), so both
/// estimate the same cosine-weighted ambient visibility (FORMULAS.md §4.1).
enum class hemisphere_sampling {
    /// pdf cos θ / π (Malley: the sample's disc point lifted to the hemisphere). Â = the plain fraction of
    /// unoccluded rays. The lower-variance choice for cosine-weighted AO. Default.
    cosine,
    /// pdf 1 / (2π). Â = (2/N) Σ V_i cos θ_i.
    uniform,
};

/// The enumerator's name ("cosine", "uniform"), for logs and result files.
[[nodiscard]] constexpr const char* to_string(hemisphere_sampling h) noexcept {
    switch (h) {
        case hemisphere_sampling::cosine: return "cosine";
        case hemisphere_sampling::uniform: return "uniform";
    }
    return "?";
}

/// Maps a point of [0, 1)² to a direction of the hemisphere z ≥ 0 (local frame, z = cos θ).
/// * cosine: Shirley–Chiu concentric disc (it keeps the strata's shapes compact, so stratification and the
///   Sobol' nets carry over), then lifted to z = √(1 − r²);
/// * uniform: z = 1 − u (so z ∈ (0, 1]), azimuth 2πv.
/// Every returned direction is a unit vector with z > 0 up to rounding; z = 0 exactly cannot occur for u < 1.
template <class T>
[[nodiscard]] glm::vec<3, T> hemisphere_direction(hemisphere_sampling h, T u, T v) noexcept {
    constexpr T pi = std::numbers::pi_v<T>;
    if (h == hemisphere_sampling::uniform) {
        const T z = T(1) - u;
        const T r = std::sqrt(std::max(T(0), T(1) - z * z));
        const T phi = T(2) * pi * v;
        return {r * std::cos(phi), r * std::sin(phi), z};
    }
    const T a = T(2) * u - T(1), b = T(2) * v - T(1);
    T r = 0, phi = 0;
    if (a != T(0) || b != T(0)) {
        if (std::abs(a) > std::abs(b)) r = a, phi = (pi / T(4)) * (b / a);
        else r = b, phi = pi / T(2) - (pi / T(4)) * (a / b);
    }
    const T x = r * std::cos(phi), y = r * std::sin(phi);
    return {x, y, std::sqrt(std::max(T(0), T(1) - x * x - y * y))};
}

/// The density of `hemisphere_direction(h, ·)` at a direction with cos θ = `cos_theta` (per steradian).
template <class T>
[[nodiscard]] constexpr T hemisphere_pdf(hemisphere_sampling h, T cos_theta) noexcept {
    constexpr T pi = std::numbers::pi_v<T>;
    return h == hemisphere_sampling::uniform ? T(1) / (T(2) * pi) : std::max(cos_theta, T(0)) / pi;
}

/// Fills `out` with one pixel's hemisphere directions in the local frame (z = cos θ): the point set of
/// `pattern` for `key` (sampler.hpp: stratified, regular grid or low-discrepancy, any count) mapped by
/// hemisphere_direction. A pure function of (pattern, h, key, size): thread-safe, no allocation beyond
/// `uv`, which must be as large as `out` (scratch for the unit-square points).
template <class T>
void generate_hemisphere_samples(sample_pattern pattern, hemisphere_sampling h, const sample_key& key,
                                 std::span<glm::vec<2, T>> uv, std::span<glm::vec<3, T>> out) noexcept {
    const std::size_t n = std::min(uv.size(), out.size());
    generate_samples<T>(pattern, key, uv.first(n));
    for (std::size_t i = 0; i < n; ++i) out[i] = hemisphere_direction<T>(h, uv[i].x, uv[i].y);
}

}  // namespace v0
}  // namespace aaf
