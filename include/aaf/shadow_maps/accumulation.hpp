// SPDX-License-Identifier: MIT
#pragma once
// Heckbert–Herf accumulation (FORMULAS.md §3.1): the soft shadow of an area light as the average of hard
// shadows from M×M points on it, with equal weights. One hard shadow at a time — one depth map, rendered
// through the user's tracer from the light point and tested with the hard lookup, or the tracer's own
// shadow rays — is added into a running accumulation buffer, so memory stays one map whatever M is.
//
// Weights. Every light point counts 1 where it lights the receiver (above its horizon and in front of a
// one-sided light) and 0 elsewhere, and the result is the lit fraction of the counted points: the same
// estimator as aaf::gather_visibility with light_weighting::uniform, so with the tracer source and the
// regular grid this *is* Monte Carlo with the regular-grid pattern, and with depth maps it differs from it
// only where a hard shadow's edge lies within a few texel footprints of the receiver (the tests bound it).

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "../area_light.hpp"
#include "../executor.hpp"
#include "../gather.hpp"
#include "../image.hpp"
#include "../ray_offset.hpp"
#include "../sampler.hpp"
#include "../tracer.hpp"
#include "depth_bias.hpp"
#include "depth_map.hpp"
#include "render_depth_map.hpp"

namespace aaf {
inline namespace v0 {

/// Where each light point's hard shadow comes from.
enum class hard_shadow_source {
    depth_maps,  ///< a perspective depth map from the light point, rendered through the tracer, hard lookup
    tracer,      ///< one shadow ray per receiver and light point (Monte Carlo with the chosen pattern)
};

/// Accumulation settings.
template <class T = float>
struct accumulation_settings {
    std::uint32_t grid = 4;                              ///< M: M×M light points, [1, 256]
    sample_pattern pattern = sample_pattern::regular_grid;  ///< regular_grid (Heckbert–Herf), or the sampler's stratified / low_discrepancy points (one set for all pixels)
    hard_shadow_source source = hard_shadow_source::depth_maps;  ///< see hard_shadow_source
    std::uint32_t map_size = 512;                        ///< texels per side of each depth map, [1, 16384]
    depth_format format = depth_format::unorm24;         ///< precision of each depth map
    bias_settings<T> bias{};                             ///< depth bias of the hard lookups (default automatic)
    T near_fraction = T(1e-3);  ///< each map's near plane as a fraction of its far plane, (0, 1): occluders nearer the light point are missed; smaller costs depth precision
    T max_half_tan = 8;         ///< cap on each map's tan(half field of view), [1e-3, 1e3]: receivers beyond it are lit by that light point
    double origin_offset = -1;  ///< tracer source: shadow-ray origin offset, < 0 automatic (ray_offset.hpp), else world units
    std::uint32_t light_index = 0;  ///< sample-key field of the light points (stratified / low_discrepancy)
    std::uint32_t frame_seed = 0;   ///< sample-key field of the light points
};

/// What an accumulation did.
struct accumulation_stats {
    std::uint64_t rays = 0;         ///< tracer queries: texels of every map, or shadow rays
    std::uint32_t passes = 0;       ///< hard shadows accumulated (M² minus points that light no receiver)
    std::size_t map_bytes = 0;      ///< storage of the one depth map (0 with the tracer source)
    std::size_t buffer_bytes = 0;   ///< the running accumulation buffers
};

namespace detail {
template <class T>
void validate_accumulation(const char* fn, const accumulation_settings<T>& s) {
    validate_bias(fn, s.bias);
    if (s.grid < 1 || s.grid > 256) throw_invalid(fn, "`settings.grid` must be in [1, 256]");
    if (s.map_size < 1 || s.map_size > 16384) throw_invalid(fn, "`settings.map_size` must be in [1, 16384]");
    if (!(s.near_fraction > T(0) && s.near_fraction < T(1))) throw_invalid(fn, "`settings.near_fraction` must be in (0, 1)");
    if (!(s.max_half_tan >= T(1e-3) && s.max_half_tan <= T(1e3))) throw_invalid(fn, "`settings.max_half_tan` must be in [1e-3, 1e3]");
    if (std::isnan(s.origin_offset)) throw_invalid(fn, "`settings.origin_offset` is NaN");
}
}  // namespace detail

/// The perspective view from light point `y` along `forward` that contains every receiver of `gb` in front
/// of it (its field of view capped at max_half_tan, its near plane near_fraction of its far plane). False
/// when no receiver lies in front of `y` (then the point lights nothing).
template <class T, class Ids>
[[nodiscard]] bool fit_perspective_view(const gbuffer<T, Ids>& gb, const glm::vec<3, T>& y, const glm::vec<3, T>& forward,
                                        T near_fraction, T max_half_tan, light_view<T>& out) {
    light_view<T> v;
    v.projection = depth_projection::perspective;
    v.eye = y;
    v.forward = forward;
    v.up = std::abs(forward.y) < T(0.9) ? glm::vec<3, T>(0, 1, 0) : glm::vec<3, T>(1, 0, 0);
    const light_frame<T> frame(v);
    T far_depth = 0, tx = 0, ty = 0;
    for (std::size_t j = 0; j < gb.height(); ++j)
        for (std::size_t i = 0; i < gb.width(); ++i) {
            const glm::vec<3, T> p = gb.positions(i, j);
            if (!detail::finite3(p)) continue;
            const glm::vec<3, T> l = frame.to_light(p);
            if (!(l.z > T(0))) continue;
            far_depth = std::max(far_depth, l.z);
            tx = std::max(tx, std::abs(l.x) / l.z), ty = std::max(ty, std::abs(l.y) / l.z);
        }
    if (!(far_depth > T(0)) || !std::isfinite(far_depth)) return false;
    // A margin so the farthest receivers' own texels lie inside, not on, the frustum's far plane and sides.
    v.far_plane = far_depth * T(1.01);
    v.near_plane = v.far_plane * near_fraction;
    v.half_width = std::clamp(tx * T(1.01), T(1e-3), max_half_tan);
    v.half_height = std::clamp(ty * T(1.01), T(1e-3), max_half_tan);
    out = v;
    return true;
}

/// Accumulates the hard shadows of the M×M light points of `settings` into `visibility` (lit fraction per
/// pixel; sky 1; a receiver no light point lights 0). The tracer answers each map's nearest-hit queries or
/// each shadow ray; rows of every pass run on `exec`. Memory: one depth map (map_size², depth_maps source)
/// plus two accumulation buffers of the frame's size. Throws aaf::invalid_argument (gbuffer, light,
/// settings, visibility) before writing.
template <class T, class Ids, class Tracer, class Exec = sequential_executor>
    requires occlusion_tracer<Tracer, T>
accumulation_stats accumulate_hard_shadows(const gbuffer<T, Ids>& gb, const area_light<T>& light, const Tracer& tracer,
                                           const accumulation_settings<T>& settings, image_view<T> visibility, Exec&& exec = {}) {
    constexpr const char* fn = "accumulate_hard_shadows";
    detail::require_nonempty(fn, "gbuffer.positions", gb.positions);
    const std::size_t w = gb.width(), h = gb.height();
    detail::require_size(fn, "gbuffer.normals", gb.normals, w, h);
    detail::require_size(fn, "visibility", visibility, w, h);
    detail::require_light(fn, light);
    detail::validate_accumulation(fn, settings);

    const std::uint32_t m = settings.grid, count = m * m;
    std::vector<glm::vec<2, T>> points(count);
    generate_samples<T>(settings.pattern, sample_key{0, 0, 0, settings.light_index, settings.frame_seed}, points);
    const light_sample_frame<T> lframe(light, light_weighting::uniform);
    image<T> lit_sum(w, h, T(0)), weight_sum(w, h, T(0));
    accumulation_stats stats;
    stats.buffer_bytes = 2 * w * h * sizeof(T);
    depth_map<T> map;
    for (const glm::vec<2, T>& uv : points) {
        const glm::vec<3, T> y = light.point(uv.x, uv.y);
        if (settings.source == hard_shadow_source::tracer) {
            exec.parallel_for(h, [&](std::size_t y0, std::size_t y1) {
                for (std::size_t j = y0; j < y1; ++j)
                    for (std::size_t i = 0; i < w; ++i) {
                        const glm::vec<3, T> p = gb.positions(i, j), n = gb.normals(i, j);
                        if (!detail::finite3(p) || !detail::finite3(n) || !(lframe.weight(n, y - p, y) > T(0))) continue;
                        // Offset towards the light's centre, as gather_pixel does, so that this *is* gather_visibility's
                        // estimator: a receiver facing away from the centre starts its rays on the far side.
                        const glm::vec<3, T> origin = shadow_ray_origin(p, n, lframe.center, settings.origin_offset);
                        const glm::vec<3, T> to = y - origin;
                        const T len = glm::length(to);
                        if (!(len > T(0)) || !std::isfinite(len)) continue;
                        const shadow_segment<T> seg{origin, to / len, len};
                        occluder_span<T> scratch{};
                        detail::visibility_hit hit{};
                        detail::trace_visibility<T>(tracer, std::span<const shadow_segment<T>>(&seg, 1),
                                                    std::span<occluder_span<T>>(&scratch, 1), std::span<detail::visibility_hit>(&hit, 1));
                        if (hit == detail::visibility_hit::failed) continue;  // dropped, as gather_visibility drops it
                        weight_sum(i, j) += T(1);
                        if (hit == detail::visibility_hit::visible) lit_sum(i, j) += T(1);
                    }
            });
            stats.rays += static_cast<std::uint64_t>(w) * h;  // upper bound: skipped pixels trace nothing
            ++stats.passes;
            continue;
        }
        // The map looks from the light point along the light's emitting side (towards the receivers for a
        // two-sided light: the side their mean lies on).
        glm::vec<3, T> forward = lframe.normal;
        if (light.two_sided) {
            glm::vec<3, T> mean(0);
            for (std::size_t j = 0; j < h; ++j)
                for (std::size_t i = 0; i < w; ++i)
                    if (detail::finite3(gb.positions(i, j))) mean += gb.positions(i, j) - y;
            if (glm::dot(mean, forward) < T(0)) forward = -forward;
        }
        light_view<T> view;
        if (!fit_perspective_view(gb, y, forward, settings.near_fraction, settings.max_half_tan, view)) continue;
        if (map.width() == 0) map = depth_map<T>(settings.map_size, settings.map_size, view, settings.format);
        else map.reset(view);
        stats.rays += render_depth_map(map, tracer, exec).texels;
        ++stats.passes;
        const light_frame<T> frame(view);
        const depth_map_view<T> mv = map.map_view();
        exec.parallel_for(h, [&](std::size_t y0, std::size_t y1) {
            for (std::size_t j = y0; j < y1; ++j)
                for (std::size_t i = 0; i < w; ++i) {
                    const glm::vec<3, T> p = gb.positions(i, j), n = gb.normals(i, j);
                    if (!detail::finite3(p) || !detail::finite3(n) || !(lframe.weight(n, y - p, y) > T(0))) continue;
                    weight_sum(i, j) += T(1);
                    const detail::prepared_receiver<T> r = detail::prepare_receiver(frame, mv.width(), mv.height(), mv.format, settings.bias, p, n);
                    bool shadowed = false;
                    if (r.inside) {
                        const auto ti = std::min(static_cast<std::size_t>(r.u), mv.width() - 1);
                        const auto tj = std::min(static_cast<std::size_t>(r.v), mv.height() - 1);
                        shadowed = r.occluded_by(mv.depth(ti, tj), ti, tj);
                    }
                    if (!shadowed) lit_sum(i, j) += T(1);
                }
        });
    }
    stats.map_bytes = map.storage_bytes();
    for (std::size_t j = 0; j < h; ++j)
        for (std::size_t i = 0; i < w; ++i) {
            const glm::vec<3, T> p = gb.positions(i, j), n = gb.normals(i, j);
            if (!detail::finite3(p) || !detail::finite3(n)) visibility(i, j) = T(1);
            else visibility(i, j) = weight_sum(i, j) > T(0) ? lit_sum(i, j) / weight_sum(i, j) : T(0);
        }
    return stats;
}

}  // namespace v0
}  // namespace aaf
