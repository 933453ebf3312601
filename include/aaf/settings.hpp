// SPDX-License-Identifier: MIT
#pragma once
// Settings structs with documented defaults and ranges, their validation, and named presets.

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>

#include "area_light.hpp"
#include "config.hpp"
#include "sampler.hpp"

namespace aaf {
inline namespace v0 {

/// Which published form of the filter bandwidth Ω* and sample count n to use (FORMULAS.md §1.7, §1.9).
enum class formula_form {
    /// The paper's equations: Ω* = μ·min(Ω_L/s2, Ω_x^max), β = 1/(kΩ*),
    /// n = 4(1 + μ s1/s2)² (μ (2/s2) √(A_p/A_l) + α/(1+s2))². Default.
    paper,
    /// The authors' code, generalised: μ scales only the light bound, Ω* = min(μ/(σ s2), α/(d(1+s2))), and
    /// n = 4(α/(1+s2) + dΩ*)² (1 + σ·min(s1Ω*, s1/(d(1+s1))))². Identical to `paper` when light-limited;
    /// finite at contact shadows and point lights where the paper's n diverges (and is clamped).
    authors,
};

/// Which light the filter width's light term assumes (FORMULAS.md §1.4, §1.8; DEVIATIONS.md, issue 13).
/// The paper derives β = σ s2/(kμ) for a Gaussian light of standard deviation σ = √A/2, but aaf samples the
/// parallelogram uniformly (light_weighting::uniform): a square of side 2σ whose standard deviation per axis
/// is σ/√3. Its visibility is a ramp with kinks at the penumbra's ends, not an erf, and a Gaussian of width β
/// brightens the umbra's edge and darkens the lit edge by ≈ 0.4 β/P (P the penumbra's width): the structured
/// bias of the scenes' error images. Matching β to the light that is actually sampled shrinks that bias.
enum class light_profile {
    /// The paper's model: β's light term is σ s2/(kμ), σ = √A/2 the Gaussian's standard deviation. Default.
    gaussian,
    /// The uniform parallelogram aaf samples: β's light term uses its per-axis standard deviation σ/√3
    /// (same second moment, hence the same low-frequency spectrum, as the box), so β is √3 narrower where
    /// the filter is light-limited. The sample count n is unchanged (it stays the paper's); still
    /// consistent (β → 0 as μ → ∞).
    box,
};

/// Constants of the formulas (FORMULAS.md §1.8). Units: none unless stated.
template <class T = float>
struct formula_settings {
    formula_form form = formula_form::paper;  ///< paper or authors' form
    T k = 3;                                  ///< filter-width divisor, β = 1/(kΩ*); (0, ∞), paper 3
    T mu = 2;                                 ///< filter shrink / sample increase factor; [1, ∞), paper 2
    T alpha = 1;                              ///< pixel-bandwidth scale; (0, ∞), paper 1
    T max_slope = T(1e6);                     ///< guard: slopes are capped here (d2 ≥ d1/(1+max_slope)); > 0
    light_profile light = light_profile::gaussian;  ///< the light β's light term assumes (n is unaffected)
    /// Multiplies the standard deviation β's light term uses (after `light`): 1 (default) keeps the profile's
    /// own. 0.9 with `gaussian`, between the paper's σ and the box's σ/√3 (0.577), is the compromise measured
    /// to keep ≥ 3× fewer rays than stratified MC on all ten example scenes with per-axis widths and Sobol'
    /// samples (DEVIATIONS.md L1). Only β where light-limited changes; n and pixel-limited widths do not;
    /// still consistent (β → 0 as μ → ∞). Finite, > 0.
    T light_scale = 1;
};

/// What the adaptive pass asks the tracer for each of its samples (the initial pass always asks for distances).
enum class shadow_query {
    /// "Occluded or not": the tracer's `occluded(segment)` when it has one (an any-hit ray, the cheapest
    /// query), else its normal query with the distances ignored. Adaptive samples count in visibility only;
    /// slopes, hence β, come from the initial pass (and spreading) alone, as in the paper (Mehta et al. §5).
    visibility,
    /// Nearest and farthest occluder, as in the initial pass: adaptive samples also feed d2min/d2max, and
    /// pixels with occluders recompute their slopes from all their samples (DEVIATIONS.md row 11).
    distances,
};

/// How many shadow samples each pixel gets and how they are drawn.
struct sampling_settings {
    std::uint32_t initial_samples = 9;     ///< samples per pixel in the first pass; [1, 4096], paper 9
    std::uint32_t max_samples = 100;       ///< cap on a pixel's total (initial + adaptive); ≥ initial_samples
    bool adaptive = true;                  ///< run the adaptive pass (n from the formulas, capped)
    shadow_query adaptive_query = shadow_query::visibility;  ///< what the adaptive pass traces (see shadow_query)
    sample_pattern pattern = sample_pattern::stratified;  ///< point set on the light
    light_weighting weighting = light_weighting::uniform;  ///< how samples are averaged
    std::uint32_t frame_seed = 0;          ///< decorrelates frames; same seed ⇒ same image
    std::uint32_t light_index = 0;         ///< identifies the light in the sample key (several lights)
    /// Shadow-ray origins: < 0 (default) moves each origin off its surface by a few ULPs along the normal
    /// (Wächter–Binder; right at every scene scale, nothing to tune); >= 0 moves it by this fixed distance
    /// in world units instead (0 = not at all). The fixed form exists to compare against hand-set epsilons.
    double origin_offset = -1;
    /// Tracers with a batched query (tracer.hpp) get whole pixels' segments until a batch holds at least
    /// this many (fewer at the end of an executor task); [1, 65536]. 64 fills four 16-wide packets. The
    /// image does not depend on it.
    std::uint32_t batch_rays = 64;
};

/// Where the filter measures the distance between two pixels (FORMULAS.md §1.11).
enum class offset_space {
    image,        ///< pixel offsets, β converted to pixels with the centre's projected pixel size (cheap)
    light_plane,  ///< world offsets projected onto the light plane, as the theory and the authors' code
    /// World offsets projected onto the *centre pixel's* tangent plane (its normal guide), as the authors'
    /// indirect-light / AO code (§1.11 [AUTH-GI]); needs the positions and normals guides.
    tangent_plane,
};

/// Which pixel footprint turns the filter width β (world units) into pixels in image space (footprint.hpp).
enum class pixel_footprint {
    camera,        ///< the G-buffer's pixel_size d, a plane facing the camera (the paper's β/d); the default
    /// √(s_x s_y), the pixel's area on its own surface: at a grazing angle θ a pixel spans d/cos θ along
    /// the tilt, so the kernel narrows by √cos θ there instead of over-blurring (tilt-aware widths)
    surface_area,
    surface_max,   ///< max(s_x, s_y): the footprint's longer side (narrower still; never over-blurs either axis)
    /// s_x for the horizontal pass and s_y for the vertical pass: each pass narrows by its own axis's
    /// stretch (a wall receding along x keeps its full width along y; surface_footprint_axes)
    surface_axes,
    /// surface_axes with each step projected on the light's plane first (surface_footprint_light_axes): the
    /// distance light-plane offsets measure, per axis, never below d
    light_axes,
};

/// The separable Gaussian filter and the slope-spreading pass.
template <class T = float>
struct filter_settings {
    offset_space space = offset_space::image;  ///< image-space or light-parallel world offsets
    T truncation = 3;                          ///< kernel radius in units of β; (0, 10], 3 keeps 99.7 %
    std::uint32_t max_radius = 24;             ///< cap on the kernel radius in pixels; [0, 1024]
    T normal_threshold_degrees = 20;           ///< reject neighbours whose normal differs more; (0, 180], authors 20
    bool spread_slopes = true;                 ///< give unoccluded pixels their occluded neighbours' slopes (§1.12)
    std::uint32_t spread_radius = 10;          ///< radius of that spreading in pixels; [0, 1024], authors 10
    /// Image-space offsets only: the footprint β is divided by (render_frame computes it with
    /// surface_footprint from the G-buffer's positions and normals when it is not `camera`).
    pixel_footprint footprint = pixel_footprint::camera;
    /// With a surface footprint: the stretch (surface footprint / camera d) below which a pixel keeps the
    /// camera's d; [1, ∞), 1 = the surface footprint everywhere. Tilt matters where a surface is seen at a
    /// grazing angle; a mildly tilted pixel gains little from a narrower kernel and pays in noise at high μ.
    T footprint_min_stretch = 1;
    /// render_frame (also progressive_shadow, and render_sheared's aaf pixels): a pixel whose tangent plane
    /// cuts the light (area_light::straddles_horizon: part of the light below its horizon) is not filtered
    /// (β = 0) and keeps its own estimate. The paper's spectrum assumes the whole light above the receiver;
    /// across such pixels visibility follows the normal at a scale the occluder slopes do not bound (a curved
    /// receiver turning away from the light), and the filter blurs it. Off by default (the paper filters
    /// them); DEVIATIONS.md L2.
    bool unfiltered_at_horizon = false;
};

/// Everything one frame needs besides buffers, light and tracer.
template <class T = float>
struct frame_settings {
    sampling_settings sampling{};
    formula_settings<T> formulas{};
    filter_settings<T> filter{};
    T radiance = 1;  ///< light radiance used by the shaded output's exact unshadowed irradiance
};

/// Named points on the speed/accuracy trade-off, measured by `aaf-tradeoff` (docs/RESULTS.md has each
/// preset's rays per pixel, time and error on every scene). Start from one and change what you need.
enum class frame_preset {
    fast,      ///< fewest rays: 4 initial samples, μ = 1.5, at most 36 per pixel
    balanced,  ///< the paper's settings: 9 initial samples, μ = 2, at most 100 per pixel (the defaults)
    accurate,  ///< lowest error: 16 initial samples, μ = 3, at most 256 per pixel
};

/// The settings of a preset (image-space offsets, guides as the caller provides them).
template <class T = float>
[[nodiscard]] constexpr frame_settings<T> preset(frame_preset p) noexcept {
    frame_settings<T> s{};
    switch (p) {
        case frame_preset::fast:
            s.sampling.initial_samples = 4;
            s.sampling.max_samples = 36;
            s.formulas.mu = T(1.5);
            break;
        case frame_preset::balanced: break;
        case frame_preset::accurate:
            s.sampling.initial_samples = 16;
            s.sampling.max_samples = 256;
            s.formulas.mu = T(3);
            break;
    }
    return s;
}

namespace detail {

inline void require(bool ok, const char* function, const char* field, const std::string& what) {
    if (!ok) throw_invalid(function, std::string("`") + field + "` " + what);
}

}  // namespace detail

/// Throws aaf::invalid_argument naming the first invalid field, e.g. "`settings.formulas.k` must be > 0 (got -1)".
template <class T>
void validate(const formula_settings<T>& s, const char* function = "validate") {
    using detail::require;
    require(std::isfinite(s.k) && s.k > T(0), function, "settings.formulas.k", "must be finite and > 0 (got " + std::to_string(s.k) + ")");
    require(std::isfinite(s.mu) && s.mu >= T(1), function, "settings.formulas.mu", "must be finite and >= 1 (got " + std::to_string(s.mu) + ")");
    require(std::isfinite(s.alpha) && s.alpha > T(0), function, "settings.formulas.alpha", "must be finite and > 0 (got " + std::to_string(s.alpha) + ")");
    require(std::isfinite(s.max_slope) && s.max_slope > T(0), function, "settings.formulas.max_slope",
            "must be finite and > 0 (got " + std::to_string(s.max_slope) + ")");
    require(s.light == light_profile::gaussian || s.light == light_profile::box, function, "settings.formulas.light",
            "must be light_profile::gaussian or light_profile::box (got " + std::to_string(static_cast<int>(s.light)) + ")");
    require(std::isfinite(s.light_scale) && s.light_scale > T(0), function, "settings.formulas.light_scale",
            "must be finite and > 0 (got " + std::to_string(s.light_scale) + ")");
}

inline void validate(const sampling_settings& s, const char* function = "validate") {
    using detail::require;
    require(s.initial_samples >= 1 && s.initial_samples <= 4096, function, "settings.sampling.initial_samples",
            "must be in [1, 4096] (got " + std::to_string(s.initial_samples) + ")");
    require(s.max_samples >= s.initial_samples && s.max_samples <= 1u << 20, function, "settings.sampling.max_samples",
            "must be in [initial_samples, 2^20] (got " + std::to_string(s.max_samples) + ")");
    require(s.adaptive_query == shadow_query::visibility || s.adaptive_query == shadow_query::distances, function,
            "settings.sampling.adaptive_query",
            "must be shadow_query::visibility or shadow_query::distances (got " +
                std::to_string(static_cast<int>(s.adaptive_query)) + ")");
    require(std::isfinite(s.origin_offset), function, "settings.sampling.origin_offset",
            "must be finite (got " + std::to_string(s.origin_offset) + ")");
    require(s.batch_rays >= 1 && s.batch_rays <= 65536, function, "settings.sampling.batch_rays",
            "must be in [1, 65536] (got " + std::to_string(s.batch_rays) + ")");
}

template <class T>
void validate(const filter_settings<T>& s, const char* function = "validate") {
    using detail::require;
    // Messages built only on failure: filter_visibility validates on every call and must not allocate then.
    if (!(std::isfinite(s.truncation) && s.truncation > T(0) && s.truncation <= T(10)))
        require(false, function, "settings.filter.truncation", "must be in (0, 10] (got " + std::to_string(s.truncation) + ")");
    if (!(s.max_radius <= 1024))
        require(false, function, "settings.filter.max_radius", "must be <= 1024 (got " + std::to_string(s.max_radius) + ")");
    if (!(s.normal_threshold_degrees > T(0) && s.normal_threshold_degrees <= T(180)))
        require(false, function, "settings.filter.normal_threshold_degrees",
                "must be in (0, 180] (got " + std::to_string(s.normal_threshold_degrees) + ")");
    if (!(s.spread_radius <= 1024))
        require(false, function, "settings.filter.spread_radius", "must be <= 1024 (got " + std::to_string(s.spread_radius) + ")");
    if (!(s.footprint == pixel_footprint::camera || s.footprint == pixel_footprint::surface_area || s.footprint == pixel_footprint::surface_max ||
          s.footprint == pixel_footprint::surface_axes || s.footprint == pixel_footprint::light_axes))
        require(false, function, "settings.filter.footprint", "must be a pixel_footprint (got " + std::to_string(static_cast<int>(s.footprint)) + ")");
    if (!(s.footprint_min_stretch >= T(1) && s.footprint_min_stretch <= std::numeric_limits<T>::max()))
        require(false, function, "settings.filter.footprint_min_stretch",
                "must be finite and >= 1 (got " + std::to_string(s.footprint_min_stretch) + ")");
}

template <class T>
void validate(const frame_settings<T>& s, const char* function = "validate") {
    validate(s.sampling, function);
    validate(s.formulas, function);
    validate(s.filter, function);
    detail::require(std::isfinite(s.radiance) && s.radiance >= T(0), function, "settings.radiance",
                    "must be finite and >= 0 (got " + std::to_string(s.radiance) + ")");
}

}  // namespace v0
}  // namespace aaf
