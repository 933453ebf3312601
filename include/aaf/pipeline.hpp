// SPDX-License-Identifier: MIT
#pragma once
// One call for a whole frame: initial samples → statistics → slope spreading → β and n → adaptive
// samples (visibility only by default, sampling_settings::adaptive_query) → filter → filtered visibility
// (and the shaded result). Every stage is also public on its own: gather_occlusion / gather_visibility
// (gather.hpp), slopes (occlusion_stats.hpp), spread_slopes and filter_visibility (filter.hpp),
// filter_width / sample_count (formulas.hpp).

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <type_traits>

#include "area_light.hpp"
#include "config.hpp"
#include "executor.hpp"
#include "filter.hpp"
#include "footprint.hpp"
#include "formulas.hpp"
#include "gather.hpp"
#include "guides.hpp"
#include "image.hpp"
#include "occlusion_stats.hpp"
#include "region.hpp"
#include "settings.hpp"
#include "tracer.hpp"

namespace aaf {
inline namespace v0 {

/// Where the frame's results go. `visibility` is required; the others are optional (empty = not wanted).
template <class T = float>
struct frame_outputs {
    image_view<T> visibility;            ///< filtered visibility in [0, 1]
    image_view<T> shaded{};              ///< filtered visibility × unshadowed irradiance
    const_image_view<T> unshadowed{};    ///< the caller's unshadowed irradiance; if empty aaf computes it exactly
};

/// Buffers a frame needs, kept between frames so nothing is allocated per frame. After `render_frame`
/// they hold every intermediate result, which is what the debug views (debug.hpp) display.
template <class T = float>
struct frame_workspace {
    image<occlusion_stats<T>> stats;         ///< merged statistics of all passes
    image<slope_pair<T>> slopes;             ///< slopes after spreading (and the adaptive pass, shadow_query::distances)
    image<slope_pair<T>> slope_scratch;
    image<T> filter_width;                   ///< β in world units (0 = not filtered)
    image<std::uint32_t> adaptive_samples;   ///< samples added by the adaptive pass
    image<T> raw_visibility;                 ///< unfiltered visibility (NaN where undefined)
    image<T> filtered;
    image<T> scratch;
    image<T> footprint;                      ///< the filter's pixel footprint (filter_settings::footprint other than camera)
    image<T> footprint_vertical;             ///< the vertical pass's footprint (pixel_footprint::surface_axes only)
    filter_workspace<T> filter;              ///< the filter's working memory (internal)

    void resize(std::size_t w, std::size_t h) {
        if (stats.width() == w && stats.height() == h) return;
        stats.reset(w, h);
        slopes.reset(w, h);
        slope_scratch.reset(w, h);
        filter_width.reset(w, h);
        adaptive_samples.reset(w, h);
        raw_visibility.reset(w, h);
        filtered.reset(w, h);
        scratch.reset(w, h);
        footprint = {};
        footprint_vertical = {};
    }
};

/// What a frame cost, and what it found in its inputs: counts that make a misconfigured frame visible
/// (a frame that is all black for a reason aaf can see is reported by `diagnose()`).
struct frame_report {
    std::uint64_t initial_rays = 0;   ///< shadow rays of the first pass
    std::uint64_t adaptive_rays = 0;  ///< shadow rays of the adaptive pass
    double initial_ms = 0, adaptive_ms = 0, formulas_ms = 0, filter_ms = 0, total_ms = 0;
    bool cancelled = false;           ///< the progress callback asked to stop; outputs were not written
    std::uint64_t pixels = 0;                  ///< pixels of the buffers (the counts below are among them)
    std::uint64_t pixels_without_surface = 0;  ///< non-finite position or normal: visibility 1
    std::uint64_t pixels_behind_light = 0;     ///< surface on the back side of a one-sided light: visibility 0
    std::uint64_t pixels_below_horizon = 0;    ///< in front of the light but every sample below the horizon: 0
    std::uint64_t pixels_zero_normal = 0;      ///< surface with a zero normal: taken to face the light's centre
    std::uint64_t pixels_bad_pixel_size = 0;   ///< surface whose pixel size is not a positive finite length
    [[nodiscard]] std::uint64_t rays() const noexcept { return initial_rays + adaptive_rays; }
    [[nodiscard]] std::uint64_t surface_pixels() const noexcept { return pixels - pixels_without_surface; }

    /// One sentence per suspicious count, naming the likely cause; empty when nothing looks wrong.
    [[nodiscard]] std::string diagnose() const {
        std::string out;
        const auto line = [&](std::uint64_t n, const char* what) {
            if (n == 0) return;
            out += std::to_string(n) + " of " + std::to_string(surface_pixels()) + " surface pixels " + what + "\n";
        };
        const std::uint64_t surface = surface_pixels();
        if (pixels != 0 && surface == 0)
            out += "no pixel has a surface: every position or normal is non-finite (gbuffer.positions, gbuffer.normals)\n";
        if (surface != 0 && pixels_behind_light == surface)
            out += "every surface pixel is behind the one-sided light: it emits towards cross(edge_u, edge_v); swap "
                   "light.edge_u and light.edge_v, or set light.two_sided\n";
        else
            line(pixels_behind_light, "are behind the one-sided light (visibility 0)");
        if (surface != 0 && pixels_below_horizon == surface - pixels_behind_light && pixels_below_horizon != 0)
            out += "every surface pixel in front of the light has it below its horizon: do gbuffer.normals face away "
                   "from the camera? (e.g. Embree's geometric normal follows the winding; face it forward)\n";
        else
            line(pixels_below_horizon, "have the light below their horizon (visibility 0)");
        line(pixels_zero_normal, "have a zero normal (taken to face the light's centre)");
        line(pixels_bad_pixel_size,
             "have a gbuffer.pixel_size that is not a positive finite world length (max_samples, not filtered)");
        return out;
    }
};

/// The default progress callback: never cancels.
struct no_progress {
    constexpr bool operator()(double) const noexcept { return true; }
};

namespace detail {
inline double ms_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace detail

namespace detail {

/// One gathering pass of render_frame over the caller's tracer (gather_occlusion for
/// shadow_query::distances, gather_visibility for shadow_query::visibility) into `stats`, `sample_counts`
/// as theirs; returns the rays traced.
template <class T>
using frame_gather = function_ref<std::uint64_t(shadow_query query, std::uint32_t pass, std::uint32_t samples_per_pixel,
                                                image_view<occlusion_stats<T>> stats,
                                                const_image_view<std::uint32_t> sample_counts)>;

/// Step 5 of render_frame, also progressive_shadow's filter: ws.raw_visibility (widths ws.filter_width)
/// filtered into ws.filtered with normals always and IDs when the G-buffer has them, in light-plane offsets
/// or image-space widths over the camera's d or the pixels' surface footprints (fs.footprint, one for both
/// passes or one per pass, kept only where stretched by fs.footprint_min_stretch).
template <class T, class Ids>
void filter_frame_visibility(const gbuffer<T, Ids>& gb, const area_light<T>& light, frame_workspace<T>& ws,
                             const filter_settings<T>& fs, executor_ref exec) {
    const std::size_t w = gb.width(), h = gb.height();
    if (fs.space == offset_space::light_plane) {
        guides<const_image_view<glm::vec<3, T>>, Ids, const_image_view<glm::vec<3, T>>> g{gb.normals, gb.ids, gb.positions};
        filter_visibility<T>(ws.raw_visibility.cview(), ws.filter_width.cview(), gb.pixel_size, ws.filtered.view(),
                             ws.scratch.view(), ws.filter, g, fs, light.normal(), exec);
    } else {
        // Tilt-aware widths: β over the pixel's footprint on its own surface instead of the camera's d.
        const_image_view<T> footprint = gb.pixel_size;
        const bool axes = fs.footprint == pixel_footprint::surface_axes || fs.footprint == pixel_footprint::light_axes;  // a footprint per pass
        if (fs.footprint != pixel_footprint::camera) {
            if (ws.footprint.width() != w || ws.footprint.height() != h) ws.footprint.reset(w, h);
            if (axes) {
                if (ws.footprint_vertical.width() != w || ws.footprint_vertical.height() != h) ws.footprint_vertical.reset(w, h);
                if (fs.footprint == pixel_footprint::light_axes)
                    surface_footprint_light_axes<T>(gb.positions, gb.normals, gb.pixel_size, light.normal(), ws.footprint.view(),
                                                    ws.footprint_vertical.view(), fs.normal_threshold_degrees, exec);
                else
                    surface_footprint_axes<T>(gb.positions, gb.normals, gb.pixel_size, ws.footprint.view(), ws.footprint_vertical.view(),
                                              fs.normal_threshold_degrees, exec);
            } else {
                surface_footprint<T>(gb.positions, gb.normals, gb.pixel_size, ws.footprint.view(), fs.footprint,
                                     fs.normal_threshold_degrees, exec);
            }
            // Only pixels stretched by at least footprint_min_stretch keep their surface footprint (issue 13);
            // per axis, each axis by its own stretch.
            if (const T t = fs.footprint_min_stretch; t > T(1))
                exec.parallel_for(h, [&](std::size_t y0, std::size_t y1) {
                    for (std::size_t y = y0; y < y1; ++y)
                        for (std::size_t x = 0; x < w; ++x) {
                            if (!(ws.footprint(x, y) >= t * gb.pixel_size(x, y))) ws.footprint(x, y) = gb.pixel_size(x, y);
                            if (axes && !(ws.footprint_vertical(x, y) >= t * gb.pixel_size(x, y)))
                                ws.footprint_vertical(x, y) = gb.pixel_size(x, y);
                        }
                });
            footprint = ws.footprint.cview();
        }
        guides<const_image_view<glm::vec<3, T>>, Ids, no_guide> g{gb.normals, gb.ids, {}};
        if (axes)
            filter_visibility_axes<T>(ws.raw_visibility.cview(), ws.filter_width.cview(), footprint, ws.footprint_vertical.cview(),
                                      ws.filtered.view(), ws.scratch.view(), ws.filter, g, fs, light.normal(), exec);
        else
            filter_visibility<T>(ws.raw_visibility.cview(), ws.filter_width.cview(), footprint, ws.filtered.view(),
                                 ws.scratch.view(), ws.filter, g, fs, light.normal(), exec);
    }
}

/// filter_settings::unfiltered_at_horizon's test of pixel (x, y), shared by render_frame, progressive_shadow
/// and render_sheared: its tangent plane, with the normal its samples are drawn with (receiver_normal), cuts
/// the light. `light_center` = light.center().
template <class T, class Ids>
[[nodiscard]] bool straddles_horizon_at(const gbuffer<T, Ids>& gb, const area_light<T>& light, const glm::vec<3, T>& light_center,
                                        std::size_t x, std::size_t y) noexcept {
    const glm::vec<3, T> p = gb.positions(x, y);
    return light.straddles_horizon(p, receiver_normal(gb.normals(x, y), p, light_center));
}

/// Step 6 of render_frame, also progressive_shadow's and render_sheared's, so that every whole-frame entry
/// point gives misconfigured pixels the same meaning and reports them alike: a pixel without a surface
/// (non-finite position or normal) gets visibility 1; a surface pixel without light in `stats` (every sample
/// below its horizon or behind a one-sided light), or whose `filtered` value is not finite, gets 0; then
/// clamped to [0, 1]. out.shaded = visibility × (out.unshadowed, or the exact unshadowed irradiance with the
/// receiver_normal a zero normal stands for). Fills report.pixels and the pixels_* counts.
template <class T, class Ids>
void write_frame_outputs(const gbuffer<T, Ids>& gb, const area_light<T>& light, const_image_view<occlusion_stats<T>> stats,
                         const_image_view<T> filtered, const frame_outputs<T>& out, T radiance, executor_ref exec,
                         frame_report& report) {
    const std::size_t w = gb.width(), h = gb.height();
    const glm::vec<3, T> light_center = light.center();
    std::atomic<std::uint64_t> no_surface{0}, behind{0}, below{0}, zero_normal{0}, bad_size{0};
    exec.parallel_for(h, [&](std::size_t y0, std::size_t y1) {
        std::uint64_t c_no_surface = 0, c_behind = 0, c_below = 0, c_zero = 0, c_bad = 0;
        for (std::size_t y = y0; y < y1; ++y)
            for (std::size_t x = 0; x < w; ++x) {
                const glm::vec<3, T> p = gb.positions(x, y);
                const glm::vec<3, T> n = gb.normals(x, y);
                const bool surface = std::isfinite(p.x + p.y + p.z) && std::isfinite(n.x + n.y + n.z);
                T v = filtered(x, y);
                if (!surface) {
                    v = T(1);
                    ++c_no_surface;
                } else {
                    const bool lit = stats(x, y).has_light();
                    if (!lit || !std::isfinite(v)) v = T(0);
                    if (!lit) ++(light.emits_towards(p) ? c_below : c_behind);
                    c_zero += glm::dot(n, n) == T(0);
                    const T d = gb.pixel_size(x, y);
                    c_bad += !(d > T(0) && d <= std::numeric_limits<T>::max());
                }
                v = std::clamp(v, T(0), T(1));
                out.visibility(x, y) = v;
                if (!out.shaded.empty()) {
                    T e = T(0);
                    if (!out.unshadowed.empty()) e = out.unshadowed(x, y);
                    else if (surface) e = unshadowed_irradiance(light, p, receiver_normal(n, p, light_center), radiance);
                    out.shaded(x, y) = v * e;
                }
            }
        no_surface += c_no_surface, behind += c_behind, below += c_below, zero_normal += c_zero, bad_size += c_bad;
    });
    report.pixels = static_cast<std::uint64_t>(w) * h;
    report.pixels_without_surface = no_surface.load();
    report.pixels_behind_light = behind.load();
    report.pixels_below_horizon = below.load();
    report.pixels_zero_normal = zero_normal.load();
    report.pixels_bad_pixel_size = bad_size.load();
}

/// render_frame's stages. Only `gather` calls the tracer, so all of this is compiled once per pixel type and
/// G-buffer type, whatever the tracer, executor and progress callback (the compiled mode, aaf::compiled,
/// holds it for float and double, with and without IDs).
template <class T, class Ids>
frame_report render_frame_stages(const gbuffer<T, Ids>& gb, const area_light<T>& light, frame_gather<T> gather,
                                 const frame_outputs<T>& out, frame_workspace<T>& ws, const frame_settings<T>& settings,
                                 executor_ref exec, function_ref<bool(double)> progress) {
    constexpr const char* fn = "render_frame";
    using clock = std::chrono::steady_clock;
    require_gbuffer(fn, gb);
    require_light(fn, light);
    validate(settings, fn);
    const std::size_t w = gb.width(), h = gb.height();
    require_size(fn, "outputs.visibility", out.visibility, w, h);
    require_size_or_empty(fn, "outputs.shaded", out.shaded, w, h);
    require_size_or_empty(fn, "outputs.unshadowed", out.unshadowed, w, h);

    frame_report report;
    const auto t_frame = clock::now();
    ws.resize(w, h);
    ws.stats.fill(occlusion_stats<T>{});
    ws.adaptive_samples.fill(0);
    const sampling_settings& ss = settings.sampling;
    const formula_settings<T>& fs = settings.formulas;
    const T sigma = light.sigma();

    // 1. Initial samples.
    auto t0 = clock::now();
    report.initial_rays = gather(shadow_query::distances, 0, ss.initial_samples, ws.stats.view(), {});
    report.initial_ms = ms_since(t0);
    if (!progress(0.4)) return report.cancelled = true, report;

    // 2. Slopes, spread to unoccluded neighbours (same object when IDs are given).
    t0 = clock::now();
    exec.parallel_for(h, [&](std::size_t y0, std::size_t y1) {
        for (std::size_t y = y0; y < y1; ++y)
            for (std::size_t x = 0; x < w; ++x) ws.slopes(x, y) = slopes(ws.stats(x, y), fs.max_slope);
    });
    const auto id_guides = [&] {
        if constexpr (gbuffer<T, Ids>::has_ids) return guides<no_guide, Ids, no_guide>{{}, gb.ids, {}};
        else return guides<>{};
    }();
    if (settings.filter.spread_slopes)
        spread_slopes<T>(ws.slopes.view(), ws.slope_scratch.view(), settings.filter.spread_radius, id_guides, exec);
    report.formulas_ms = ms_since(t0);

    // 3. Adaptive pass: n from the formulas, capped at max_samples in total.
    if (ss.adaptive && ss.max_samples > ss.initial_samples) {
        t0 = clock::now();
        // In a tile's buffers (gbuffer.region with the frame's size), pixels nearer than the spreading's reach
        // to a halo edge feed only the spreading of their neighbours, which reads the first pass alone: no
        // pixel of the tile reads their visibility (the filter reaches max_radius, and stops there), so they
        // get no adaptive samples. Their outputs are not the frame's anyway.
        const frame_region& r = gb.region;
        const std::size_t halo = region_halo_extent(settings).spread;
        const bool tile = r.knows_frame();
        const std::size_t left = tile && r.origin_x > 0 ? halo : 0, top = tile && r.origin_y > 0 ? halo : 0;
        const std::size_t right = tile && r.origin_x + w < r.frame_width ? halo : 0;
        const std::size_t bottom = tile && r.origin_y + h < r.frame_height ? halo : 0;
        exec.parallel_for(h, [&](std::size_t y0, std::size_t y1) {
            for (std::size_t y = y0; y < y1; ++y)
                for (std::size_t x = 0; x < w; ++x) {
                    if (x < left || y < top || x + right >= w || y + bottom >= h) {
                        ws.adaptive_samples(x, y) = 0;
                        continue;
                    }
                    const T d = gb.pixel_size(x, y);
                    // A pixel the formulas cannot size (d not a positive finite length) gets the most samples.
                    const T n = d > T(0) && d <= std::numeric_limits<T>::max() ? sample_count(ws.slopes(x, y), sigma, d, fs)
                                                                              : std::numeric_limits<T>::infinity();
                    const std::uint32_t target = target_samples(n, ss.initial_samples, ss.max_samples);
                    ws.adaptive_samples(x, y) = target - ss.initial_samples;
                }
        });
        if (ss.adaptive_query == shadow_query::visibility) {
            // The paper's pass: visibility only (any-hit rays when the tracer has them); β keeps the first pass's slopes.
            report.adaptive_rays = gather(shadow_query::visibility, 1, 0, ws.stats.view(), ws.adaptive_samples.cview());
        } else {
            report.adaptive_rays = gather(shadow_query::distances, 1, 0, ws.stats.view(), ws.adaptive_samples.cview());
            // Pixels that now have occluders of their own use their own slopes; the others keep the spread ones.
            exec.parallel_for(h, [&](std::size_t y0, std::size_t y1) {
                for (std::size_t y = y0; y < y1; ++y)
                    for (std::size_t x = 0; x < w; ++x)
                        if (ws.stats(x, y).has_occluder()) ws.slopes(x, y) = slopes(ws.stats(x, y), fs.max_slope);
            });
        }
        report.adaptive_ms = ms_since(t0);
    }
    if (!progress(0.8)) return report.cancelled = true, report;

    // 4. β per pixel and the unfiltered visibility.
    t0 = clock::now();
    const bool horizon_rule = settings.filter.unfiltered_at_horizon;
    const glm::vec<3, T> centre = light.center();
    exec.parallel_for(h, [&](std::size_t y0, std::size_t y1) {
        for (std::size_t y = y0; y < y1; ++y)
            for (std::size_t x = 0; x < w; ++x) {
                const T d = gb.pixel_size(x, y);  // not a positive finite length: not filtered (β = 0)
                ws.filter_width(x, y) =
                    d > T(0) && d <= std::numeric_limits<T>::max() ? filter_width(ws.slopes(x, y), sigma, d, fs) : T(0);
                // Part of the light below the pixel's horizon (the normal the samples were drawn with): its own
                // estimate, not filtered (filter_settings::unfiltered_at_horizon).
                if (horizon_rule && straddles_horizon_at(gb, light, centre, x, y)) ws.filter_width(x, y) = T(0);
                ws.raw_visibility(x, y) = ws.stats(x, y).visibility();
            }
    });
    report.formulas_ms += ms_since(t0);

    // 5. Filter, with normals always and IDs when the G-buffer has them.
    t0 = clock::now();
    filter_frame_visibility<T, Ids>(gb, light, ws, settings.filter, exec);
    report.filter_ms = ms_since(t0);
    if (!progress(0.95)) return report.cancelled = true, report;

    // 6. Outputs, and the counts of the report.
    write_frame_outputs<T, Ids>(gb, light, ws.stats.cview(), ws.filtered.cview(), out, settings.radiance, exec, report);
    report.total_ms = ms_since(t_frame);
    progress(1.0);
    return report;
}

}  // namespace detail

/// Renders one frame's shadow from `light` over the G-buffer `gb` with `tracer`.
///
/// * Pixels without a surface (non-finite position or normal) get visibility 1; pixels whose whole light
///   is below their horizon or behind a one-sided light get 0. No such pixel feeds its neighbours. The
///   report counts each kind, and report.diagnose() names the likely mistake when a whole frame is dark
///   (light edges swapped, normals facing away from the camera).
/// * A zero normal is an orientation-less receiver (hair, particles): it faces the light's centre.
/// * A surface pixel whose pixel size is not a positive finite world length (0, negative, NaN, ±∞) cannot
///   be sized by the formulas: it gets max_samples and is not filtered (its own Monte Carlo estimate), and
///   is counted (report.pixels_bad_pixel_size). A size in pixels instead of world units is not detectable:
///   formulas.hpp's pinhole_pixel_size gives world units.
/// * `progress(fraction)` is called between stages; returning false cancels the frame before any output
///   is written (report.cancelled).
/// * Deterministic: the same inputs and `settings.sampling.frame_seed` give the same image on any executor.
/// * Tiles: with `gb.region` placing the buffers in the frame, and buffers that cover a tile plus
///   region_halo(settings) pixels on every side that is not a frame edge (plan_region), the tile's pixels
///   are bit-identical to the same pixels of a full-frame render. The halo's own outputs are not.
/// Throws aaf::invalid_argument, before writing anything, for mismatched buffers or invalid settings.
template <class T, class Ids, class Tracer, class Exec = sequential_executor, class Progress = no_progress>
frame_report render_frame(const gbuffer<T, Ids>& gb, const area_light<T>& light, const Tracer& tracer,
                          const frame_outputs<T>& out, frame_workspace<T>& ws, const frame_settings<T>& settings = {},
                          Exec&& exec = {}, Progress&& progress = {}) {
    static_assert(check_tracer<Tracer, T>());  // a message naming the member and the reason (tracer.hpp)
    const detail::executor_ref ex(exec);
    const sampling_settings& ss = settings.sampling;
    // The one tracer-dependent part: the gathering passes (gather_occlusion / gather_visibility).
    const auto gather = [&](shadow_query query, std::uint32_t pass, std::uint32_t samples_per_pixel,
                            image_view<occlusion_stats<T>> stats, const_image_view<std::uint32_t> sample_counts) -> std::uint64_t {
        if constexpr (occlusion_tracer<Tracer, T>) {
            if (query == shadow_query::visibility)
                return detail::gather_rows<shadow_query::visibility>("gather_visibility", gb, light, tracer, ss, pass,
                                                                     samples_per_pixel, stats, sample_counts, ex);
            return detail::gather_rows<shadow_query::distances>("gather_occlusion", gb, light, tracer, ss, pass,
                                                                samples_per_pixel, stats, sample_counts, ex);
        } else {
            return 0;
        }
    };
    return detail::render_frame_stages<T, Ids>(gb, light, gather, out, ws, settings, ex, progress);
}

// The compiled mode's instantiations (config.hpp: AAF_EXTERN_TEMPLATES): every stage of render_frame but
// the gathering, for G-buffers with and without IDs.
#define AAF_DETAIL_PIPELINE_INSTANTIATIONS(KEYWORD, T)                                                          \
    AAF_DETAIL_INSTANTIATE(KEYWORD, detail::render_frame_stages<T, no_guide>)                                   \
    AAF_DETAIL_INSTANTIATE(KEYWORD, detail::render_frame_stages<T, const_image_view<std::uint32_t>>)
#ifdef AAF_EXTERN_TEMPLATES
AAF_DETAIL_PIPELINE_INSTANTIATIONS(extern, float)
AAF_DETAIL_PIPELINE_INSTANTIATIONS(extern, double)
#endif

}  // namespace v0
}  // namespace aaf
