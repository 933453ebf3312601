// SPDX-License-Identifier: MIT
#pragma once
// Settings of the ambient-occlusion family (sampling, the filter's formulas), with validation.

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>

#include "../settings.hpp"
#include "ao_stats.hpp"
#include "hemisphere.hpp"

namespace aaf {
inline namespace v0 {

/// What an AO pass asks the tracer for each sample.
enum class ao_query {
    /// Only "occluded within the maximum distance or not": the tracer's `occluded` (an any-hit ray) when it
    /// has one. No hit distances are recorded (z_min, z_max unchanged). Used automatically as `distances`
    /// when the falloff needs the distance.
    visibility,
    /// The nearest hit (`nearest_occluder`, or the span's nearest end): visibility with falloff, and z_min,
    /// z_max for the filter. Default.
    distances,
};

/// How a pixel's (or vertex's) hemisphere samples are drawn and traced.
template <class T = float>
struct ao_sampling_settings {
    hemisphere_sampling density = hemisphere_sampling::cosine;  ///< cosine (default) or uniform directions
    sample_pattern pattern = sample_pattern::stratified;        ///< point set mapped to the hemisphere
    std::uint32_t initial_samples = 16;  ///< samples in the first pass; [1, 4096], authors 16 (4×4)
    std::uint32_t max_samples = 256;     ///< cap on a pixel's total; [initial_samples, 2^20]
    /// Occluders count within this distance of the surface (world units); (0, +∞], +∞ = the whole scene.
    T max_distance = std::numeric_limits<T>::infinity();
    ao_falloff falloff = ao_falloff::none;  ///< how an occluder's distance lowers its occlusion
    ao_query query = ao_query::distances;   ///< what the first pass asks the tracer (adaptive passes: visibility)
    std::uint32_t frame_seed = 0;           ///< decorrelates frames; same seed ⇒ same result
    /// The sample key's `light` field (region.hpp): a stream tag so that AO samples are independent of the
    /// same pixel's shadow samples (light 0, 1, …). Any value; change it to draw a second independent set.
    std::uint32_t stream = 0x414F0000u;
    /// Ray origins: < 0 (default) moves each origin a few ULPs off its surface along the normal
    /// (ray_offset.hpp, Wächter–Binder); >= 0 moves it by this many world units instead (0 = not at all).
    double origin_offset = -1;
};

/// How the AO filter's Gaussian is evaluated.
enum class ao_filter_kernel {
    /// The core's guided separable Gaussian (filter.hpp), a horizontal then a vertical pass over the AO and
    /// each bent-normal component; the normal threshold is a hard test. Fast. Default.
    separable,
    /// A direct 2D Gaussian over each pixel's whole window, as in the authors' code: (2r + 1)² taps per
    /// pixel instead of 2(2r + 1), cut where the exponent exceeds truncation²/2 (the authors' μ²Ω*²r² ≤ 2 at
    /// the default truncation). The only kernel that applies `normal_angle_term` and `reject_beyond_z_min`,
    /// whose weights depend on the centre and the neighbour together and so do not separate.
    direct,
};

/// Constants of the axis-aligned AO filter (FORMULAS.md §4.2, §8.3: Mehta et al. 2013 and the authors' code).
template <class T = float>
struct ao_filter_settings {
    T omega_h = T(2.8);  ///< the diffuse BRDF's angular bandlimit Ω_h; (0, ∞), authors 2.8 (Phong m: 3.5 + 0.2m)
    T mu = 2;            ///< filter shrink / sample increase; [1, ∞), authors 2. β = z_min / (2 μ Ω_h)
    T alpha = 1;         ///< pixel-sampling term of n; (0, ∞), authors 1
    /// c_imp, the importance-sampling scale of n (FORMULAS.md §4.2). Its value in the authors' code could not
    /// be read; aaf's default is its own choice (DEVIATIONS.md occlusion row 4). [0, ∞)
    T importance_scale = T(0.25);
    /// z_min is clamped to at least this (world units) before β and n are computed; [0, ∞). The authors clamp
    /// at a scene constant (0.1 or 15); aaf's 0 keeps the contact limit (β → 0: unfiltered; n → the cap).
    T min_distance = 0;
    /// Reject neighbours whose normal differs more (degrees); (0, 180], authors 5 (in place of their 50·θ term).
    T normal_threshold_degrees = 5;
    T truncation = T(2.8284271);   ///< kernel radius in units of β; (0, 10], authors' cut μ²Ω*²r² ≤ 2, i.e. 2√2·β
    std::uint32_t max_radius = 50;  ///< cap on the kernel radius in pixels; [0, 1024], authors 50
    /// Where distances between pixels are measured: image space (β/d pixels) or world offsets projected on
    /// the centre pixel's tangent plane (the authors' choice; needs positions and normals).
    offset_space space = offset_space::tangent_plane;
    /// A pixel whose initial samples hit nothing within range takes the smallest z_min and largest z_max of the
    /// pixels with hits within this many pixels (same object ID), so it is filtered and sampled adaptively
    /// like its neighbours (the AO counterpart of the shadows' slope spreading, FORMULAS.md §1.12, run by the
    /// core's aaf::spread_slopes); [0, 1024], 0 = off (such pixels stay unfiltered with their initial samples).
    std::uint32_t spread_radius = 10;
    /// Separable (default) or direct 2D evaluation of the Gaussian (ao_filter_kernel).
    ao_filter_kernel kernel = ao_filter_kernel::separable;
    /// The authors' per-neighbour bandwidth Ω_h(1 + c·θ)/z_min, θ the angle between the centre's and the
    /// neighbour's normals in radians: a neighbour on a curved surface gets a narrower weight (the Gaussian's
    /// exponent times (1 + cθ)²; the hard `normal_threshold_degrees` test still applies). c: [0, 1e6], authors
    /// 50, aaf 0 (off; DEVIATIONS.md occlusion row 2, measured there). c > 0 needs kernel = direct.
    T normal_angle_term = 0;
    /// The authors' rejection of neighbours whose world distance from the centre is ≥ the centre's z_min
    /// (clamped by min_distance). Default off (DEVIATIONS.md occlusion row 3, measured there); needs kernel = direct.
    bool reject_beyond_z_min = false;
    /// The authors' pre-filter rejection boost (FORMULAS.md §8.3): a pixel's adaptive n is divided by
    /// (1 − f), f the fraction of the pixels in its filter window that the filter's guides reject (other ID,
    /// normal beyond the threshold, no surface), so pixels at discontinuities, whose filter has little
    /// support, get more samples (f = 1: the cap). Default off (DEVIATIONS.md occlusion row 7, measured there).
    bool rejection_boost = false;
};

template <class T>
void validate(const ao_sampling_settings<T>& s, const char* function = "validate") {
    using detail::require;
    require(s.density == hemisphere_sampling::cosine || s.density == hemisphere_sampling::uniform, function,
            "settings.density", "must be hemisphere_sampling::cosine or ::uniform");
    require(s.initial_samples >= 1 && s.initial_samples <= 4096, function, "settings.initial_samples",
            "must be in [1, 4096] (got " + std::to_string(s.initial_samples) + ")");
    require(s.max_samples >= s.initial_samples && s.max_samples <= 1u << 20, function, "settings.max_samples",
            "must be in [initial_samples, 2^20] (got " + std::to_string(s.max_samples) + ")");
    require(s.max_distance > T(0), function, "settings.max_distance",
            "must be > 0 world units, +inf for no limit (got " + std::to_string(s.max_distance) + ")");
    require(s.falloff == ao_falloff::none || s.falloff == ao_falloff::linear || s.falloff == ao_falloff::quadratic,
            function, "settings.falloff", "must be ao_falloff::none, ::linear or ::quadratic");
    require(s.query == ao_query::visibility || s.query == ao_query::distances, function, "settings.query",
            "must be ao_query::visibility or ::distances");
    require(std::isfinite(s.origin_offset), function, "settings.origin_offset",
            "must be finite (got " + std::to_string(s.origin_offset) + ")");
}

template <class T>
void validate(const ao_filter_settings<T>& s, const char* function = "validate") {
    using detail::require;
    require(std::isfinite(s.omega_h) && s.omega_h > T(0), function, "settings.omega_h",
            "must be finite and > 0 (got " + std::to_string(s.omega_h) + ")");
    require(std::isfinite(s.mu) && s.mu >= T(1), function, "settings.mu", "must be finite and >= 1 (got " + std::to_string(s.mu) + ")");
    require(std::isfinite(s.alpha) && s.alpha > T(0), function, "settings.alpha",
            "must be finite and > 0 (got " + std::to_string(s.alpha) + ")");
    require(std::isfinite(s.importance_scale) && s.importance_scale >= T(0), function, "settings.importance_scale",
            "must be finite and >= 0 (got " + std::to_string(s.importance_scale) + ")");
    require(std::isfinite(s.min_distance) && s.min_distance >= T(0), function, "settings.min_distance",
            "must be finite and >= 0 (got " + std::to_string(s.min_distance) + ")");
    require(s.normal_threshold_degrees > T(0) && s.normal_threshold_degrees <= T(180), function,
            "settings.normal_threshold_degrees", "must be in (0, 180] (got " + std::to_string(s.normal_threshold_degrees) + ")");
    require(std::isfinite(s.truncation) && s.truncation > T(0) && s.truncation <= T(10), function, "settings.truncation",
            "must be in (0, 10] (got " + std::to_string(s.truncation) + ")");
    require(s.max_radius <= 1024, function, "settings.max_radius", "must be <= 1024 (got " + std::to_string(s.max_radius) + ")");
    require(s.spread_radius <= 1024, function, "settings.spread_radius",
            "must be <= 1024 (got " + std::to_string(s.spread_radius) + ")");
    require(s.space == offset_space::image || s.space == offset_space::tangent_plane, function, "settings.space",
            "must be offset_space::image or ::tangent_plane");
    require(s.kernel == ao_filter_kernel::separable || s.kernel == ao_filter_kernel::direct, function, "settings.kernel",
            "must be ao_filter_kernel::separable or ::direct");
    require(std::isfinite(s.normal_angle_term) && s.normal_angle_term >= T(0) && s.normal_angle_term <= T(1e6), function,
            "settings.normal_angle_term", "must be in [0, 1e6] (got " + std::to_string(s.normal_angle_term) + ")");
    require(s.kernel == ao_filter_kernel::direct || (s.normal_angle_term == T(0) && !s.reject_beyond_z_min), function,
            "settings.kernel",
            "must be ao_filter_kernel::direct when normal_angle_term > 0 or reject_beyond_z_min is set (the separable "
            "filter cannot weight a neighbour by its centre and itself together)");
}

}  // namespace v0
}  // namespace aaf
