// SPDX-License-Identifier: MIT
#pragma once
// Gathering ambient occlusion: hemisphere samples → rays → the user's tracer → ao_stats, per pixel of a
// G-buffer (with its frame region) or per vertex / triangle of a mesh (baking).
//
// THE AO TRACER CONTRACT is the shadow one (tracer.hpp) with the segment read as an AO ray: `origin` is the
// surface point (already offset by aaf), `direction` a unit vector in the normal's hemisphere, `length` the
// maximum distance R (may be +∞: a tracer must treat t < +∞ as "any distance"). Visibility-only passes call
// `occluded(segment)` when the tracer has it (an any-hit ray); distance passes call `nearest_occluder` (or
// the span's nearest end, or `trace_batch`). Calls are concurrent.

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "../executor.hpp"
#include "../gather.hpp"
#include "../image_view.hpp"
#include "../ray_offset.hpp"
#include "../region.hpp"
#include "../tracer.hpp"
#include "ao_settings.hpp"
#include "ao_stats.hpp"
#include "hemisphere.hpp"

namespace aaf {
inline namespace v0 {

namespace detail {

/// The key row of mesh element i: vertices (kind 0) and triangles (kind 1) never share a key, at any count.
[[nodiscard]] constexpr std::uint32_t ao_mesh_key_row(std::size_t i, std::uint32_t kind) noexcept {
    return static_cast<std::uint32_t>((static_cast<std::uint64_t>(i) >> 32) * 2 + kind);
}

/// Reusable per-thread buffers for one point's AO samples.
template <class T>
struct ao_scratch {
    std::vector<glm::vec<2, T>> uv;
    std::vector<glm::vec<3, T>> local;
    std::vector<shadow_segment<T>> segments;
    std::vector<occluder_span<T>> hits;
    std::vector<visibility_hit> visible;

    void resize(std::uint32_t n) {
        if (uv.size() >= n) return;
        uv.resize(n), local.resize(n), segments.resize(n), hits.resize(n), visible.resize(n);
    }
};


/// Draws `count` samples of pass `key.pass` at point `p` with unit normal `n` and adds them to `stats`.
/// `distances`: ask for the nearest hit (z statistics, falloff); else any-hit visibility. Returns rays traced.
template <class T, class Tracer>
std::uint64_t ao_point(const glm::vec<3, T>& p, const glm::vec<3, T>& n, const Tracer& tracer,
                       const ao_sampling_settings<T>& s, bool distances, const sample_key& key, std::uint32_t count,
                       ao_stats<T>& stats, ao_scratch<T>& scratch) {
    scratch.resize(count);
    generate_hemisphere_samples<T>(s.pattern, s.density, key, std::span(scratch.uv.data(), count),
                                   std::span(scratch.local.data(), count));
    const tangent_frame<T> frame(n);
    const glm::vec<3, T> origin = s.origin_offset < 0 ? offset_ray_origin(p, n) : p + static_cast<T>(s.origin_offset) * n;
    for (std::uint32_t i = 0; i < count; ++i) scratch.segments[i] = {origin, frame.to_world(scratch.local[i]), s.max_distance};
    const std::span<const shadow_segment<T>> segments(scratch.segments.data(), count);
    const std::span<occluder_span<T>> hits(scratch.hits.data(), count);
    if (distances) {
        std::fill_n(scratch.hits.begin(), count, occluder_span<T>{});
        trace_all<T>(tracer, segments, hits);
        for (std::uint32_t i = 0; i < count; ++i) {
            const occluder_span<T>& h = scratch.hits[i];
            const T cos_theta = scratch.local[i].z;
            if (std::isnan(h.nearest) || std::isnan(h.farthest)) {  // a failed sample (tracer.hpp)
                stats.add(s.density, cos_theta, segments[i].direction, std::numeric_limits<T>::quiet_NaN());
                continue;
            }
            const T t = h.hit() ? h.nearest : std::numeric_limits<T>::infinity();
            stats.add(s.density, cos_theta, segments[i].direction, falloff_visibility(s.falloff, t, s.max_distance));
            if (h.hit()) stats.add_hit_distance(t);
        }
    } else {
        trace_visibility<T>(tracer, segments, hits, std::span<visibility_hit>(scratch.visible.data(), count));
        for (std::uint32_t i = 0; i < count; ++i) {
            const visibility_hit v = scratch.visible[i];
            const T vis = v == visibility_hit::failed ? std::numeric_limits<T>::quiet_NaN()
                                                      : (v == visibility_hit::blocked ? T(0) : T(1));
            stats.add(s.density, scratch.local[i].z, segments[i].direction, vis);
        }
    }
    return count;
}

}  // namespace detail

/// Adds `samples_per_pixel` hemisphere samples of pass `pass` to every pixel of `gb` with a surface,
/// accumulating into `stats` (which the caller initialises, e.g. to `ao_stats<T>{}`). When `sample_counts` is
/// non-empty it gives each pixel's count instead (0 = skip; capped at settings.max_samples). Pass 0 asks the
/// tracer what `settings.query` says; later passes (adaptive) ask visibility only, unless the falloff needs
/// distances. Samples are keyed by aaf::pixel_key(region, x, y, pass, settings.stream, settings.frame_seed),
/// so a tile (its buffers and its `region`) gets exactly the samples of the same pixels of a full frame.
///
/// * `gb.positions` non-finite = no surface (skipped, the record stays empty: visibility() is NaN).
/// * `gb.normals` give the hemisphere (the side AO is wanted on, e.g. facing the camera); they are
///   normalised here; a zero or non-finite normal = no surface (skipped). `gb.pixel_size` is not read.
/// Rows run on `exec`; the tracer is called concurrently. Returns the number of rays traced.
/// Throws aaf::invalid_argument (before writing) on mismatched buffers or invalid settings.
template <class T, class Ids, class Tracer, class Exec = sequential_executor>
std::uint64_t gather_ambient_occlusion(const gbuffer<T, Ids>& gb, const Tracer& tracer, const ao_sampling_settings<T>& s,
                                       std::uint32_t pass, std::uint32_t samples_per_pixel, image_view<ao_stats<T>> stats,
                                       const_image_view<std::uint32_t> sample_counts = {}, const frame_region& region = {},
                                       Exec&& exec = {}) {
    static_assert(occlusion_tracer<Tracer, T>,
                  "aaf::gather_ambient_occlusion: the tracer needs nearest_occluder(const aaf::shadow_segment<T>&), "
                  "occluder_span(...) or trace_batch(...) (tracer.hpp); occluded(...) alone: wrap it in aaf::bisecting_tracer");
    constexpr const char* fn = "gather_ambient_occlusion";
    detail::require_gbuffer(fn, gb);
    validate(s, fn);
    const std::size_t w = gb.width(), h = gb.height();
    detail::require_size(fn, "stats", stats, w, h);
    detail::require_size_or_empty(fn, "sample_counts", sample_counts, w, h);
    if (sample_counts.empty() && (samples_per_pixel == 0 || samples_per_pixel > s.max_samples))
        detail::throw_invalid(fn, "`samples_per_pixel` must be in [1, settings.max_samples] (got " +
                                      std::to_string(samples_per_pixel) + ")");
    const bool distances = s.falloff != ao_falloff::none || (pass == 0 && s.query == ao_query::distances);
    std::atomic<std::uint64_t> rays{0};
    exec.parallel_for(h, [&](std::size_t y0, std::size_t y1) {
        detail::ao_scratch<T> scratch;
        std::uint64_t local = 0;
        for (std::size_t y = y0; y < y1; ++y)
            for (std::size_t x = 0; x < w; ++x) {
                const std::uint32_t count = std::min(sample_counts.empty() ? samples_per_pixel : sample_counts(x, y), s.max_samples);
                if (count == 0) continue;
                const glm::vec<3, T> p = gb.positions(x, y);
                const glm::vec<3, T> n = detail::ao_unit_or_zero(gb.normals(x, y));
                if (!std::isfinite(p.x + p.y + p.z) || n == glm::vec<3, T>(0)) continue;
                local += detail::ao_point(p, n, tracer, s, distances, pixel_key(region, x, y, pass, s.stream, s.frame_seed),
                                          count, stats(x, y), scratch);
            }
        rays += local;
    });
    return rays.load();
}

/// Ambient occlusion per vertex of a mesh, for baking (the lecture's loop: for each point, rays over its
/// hemisphere, ++occlusion or accumulate the direction). Vertex i at `positions[i]` with normal `normals[i]`
/// gets `settings.initial_samples` samples, keyed like pixel (i, 0) of pass 0; `stats[i]` is overwritten.
/// Non-finite positions and zero / non-finite normals give an empty record (visibility() NaN, bent normal =
/// the given normal). The tracer must not report the vertex's own surface at t = 0 (origins are offset).
/// Returns the number of rays. Throws aaf::invalid_argument on mismatched spans or invalid settings.
template <class T, class Tracer, class Exec = sequential_executor>
std::uint64_t bake_vertex_occlusion(std::span<const glm::vec<3, T>> positions, std::span<const glm::vec<3, T>> normals,
                                    const Tracer& tracer, const ao_sampling_settings<T>& s, std::span<ao_stats<T>> stats,
                                    Exec&& exec = {}) {
    static_assert(occlusion_tracer<Tracer, T>,
                  "aaf::bake_vertex_occlusion: the tracer needs nearest_occluder, occluder_span or trace_batch (tracer.hpp)");
    constexpr const char* fn = "bake_vertex_occlusion";
    validate(s, fn);
    if (normals.size() != positions.size())
        detail::throw_invalid(fn, "`normals` has " + std::to_string(normals.size()) + " entries but `positions` has " +
                                      std::to_string(positions.size()));
    if (stats.size() != positions.size())
        detail::throw_invalid(fn, "`stats` has " + std::to_string(stats.size()) + " entries but `positions` has " +
                                      std::to_string(positions.size()));
    std::atomic<std::uint64_t> rays{0};
    const bool distances = s.falloff != ao_falloff::none || s.query == ao_query::distances;
    exec.parallel_for(positions.size(), [&](std::size_t b, std::size_t e) {
        detail::ao_scratch<T> scratch;
        std::uint64_t local = 0;
        for (std::size_t i = b; i < e; ++i) {
            stats[i] = {};
            const glm::vec<3, T> p = positions[i];
            const glm::vec<3, T> n = detail::ao_unit_or_zero(normals[i]);
            if (!std::isfinite(p.x + p.y + p.z) || n == glm::vec<3, T>(0)) continue;
            const sample_key key{static_cast<std::uint32_t>(i), detail::ao_mesh_key_row(i, 0), 0, s.stream, s.frame_seed};
            local += detail::ao_point(p, n, tracer, s, distances, key, s.initial_samples, stats[i], scratch);
        }
        rays += local;
    });
    return rays.load();
}

/// Ambient occlusion per triangle: at each triangle's centroid, around its geometric normal
/// cross(b − a, c − a) (counter-clockwise front faces; pass `flip` to use the other side). Degenerate
/// triangles (zero area) or non-finite vertices give an empty record; an index past `positions` throws
/// aaf::invalid_argument. Otherwise as bake_vertex_occlusion, triangle i keyed apart from vertex i.
template <class T, class Tracer, class Exec = sequential_executor>
std::uint64_t bake_triangle_occlusion(std::span<const glm::vec<3, T>> positions, std::span<const glm::vec<3, std::uint32_t>> triangles,
                                      const Tracer& tracer, const ao_sampling_settings<T>& s, std::span<ao_stats<T>> stats,
                                      bool flip = false, Exec&& exec = {}) {
    static_assert(occlusion_tracer<Tracer, T>,
                  "aaf::bake_triangle_occlusion: the tracer needs nearest_occluder, occluder_span or trace_batch (tracer.hpp)");
    constexpr const char* fn = "bake_triangle_occlusion";
    validate(s, fn);
    if (stats.size() != triangles.size())
        detail::throw_invalid(fn, "`stats` has " + std::to_string(stats.size()) + " entries but `triangles` has " +
                                      std::to_string(triangles.size()));
    for (std::size_t i = 0; i < triangles.size(); ++i)
        for (int c = 0; c < 3; ++c)
            if (triangles[i][c] >= positions.size())
                detail::throw_invalid(fn, "`triangles[" + std::to_string(i) + "]` indexes vertex " +
                                              std::to_string(triangles[i][c]) + " of " + std::to_string(positions.size()));
    std::atomic<std::uint64_t> rays{0};
    const bool distances = s.falloff != ao_falloff::none || s.query == ao_query::distances;
    exec.parallel_for(triangles.size(), [&](std::size_t b, std::size_t e) {
        detail::ao_scratch<T> scratch;
        std::uint64_t local = 0;
        for (std::size_t i = b; i < e; ++i) {
            stats[i] = {};
            const glm::vec<3, T> a = positions[triangles[i].x], bb = positions[triangles[i].y], c = positions[triangles[i].z];
            const glm::vec<3, T> p = (a + bb + c) / T(3);
            glm::vec<3, T> n = detail::ao_unit_or_zero(glm::cross(bb - a, c - a));
            if (flip) n = -n;
            if (!std::isfinite(p.x + p.y + p.z) || n == glm::vec<3, T>(0)) continue;
            const sample_key key{static_cast<std::uint32_t>(i), detail::ao_mesh_key_row(i, 1), 0, s.stream, s.frame_seed};
            local += detail::ao_point(p, n, tracer, s, distances, key, s.initial_samples, stats[i], scratch);
        }
        rays += local;
    });
    return rays.load();
}

}  // namespace v0
}  // namespace aaf
