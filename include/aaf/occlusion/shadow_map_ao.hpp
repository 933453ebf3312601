// SPDX-License-Identifier: MIT
#pragma once
// Shadow-map ambient occlusion (the soft-shadow lecture's second AO method): N directional depth maps from
// directions spread evenly over the sphere, looked up one map at a time and accumulated per pixel into the
// cosine-weighted unoccluded fraction and the bent normal. Built on the shadow-map family (depth_map,
// render_depth_map, fit_orthographic_view, the automatic depth bias); nothing of it is copied here.
//
// Estimator. Directions ω_k, k < N, are a spherical Fibonacci set (even over the sphere, deterministic, any
// N). A receiver with normal n uses the directions above its horizon (c_k = n·ω_k > 0):
//   visibility = Σ c_k V_k / Σ c_k,   bent normal = normalize(Σ c_k V_k ω_k)
// (the cosine-weighted fraction and mean unoccluded direction of ao_stats.hpp, by quadrature over the set).
// V_k is the map's hard depth test with the automatic bias (depth_bias.hpp).
//
// Maximum distance. Maps are directional, so they see occluders at any distance. A finite max_distance R
// (the AO reference's convention) is applied per receiver as a depth range: the texel occludes only when the
// surface it stores lies less than R in front of the receiver along ω. Exact when the first surface seen from
// ω is the nearest occluder; when a surface farther than R along ω hides a nearer one (two layers of occluders
// above the receiver), the map stores only the far one and the direction counts as unoccluded: an
// underestimate of occlusion that a single-layer map cannot avoid (DEVIATIONS.md, occlusion section).
//
// Memory: one map (resolution² floats) plus five numbers per pixel of accumulators; time: N map renders of
// resolution² rays each plus N lookups per pixel.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "../config.hpp"
#include "../executor.hpp"
#include "../gather.hpp"
#include "../image.hpp"
#include "../image_view.hpp"
#include "../shadow_maps/depth_bias.hpp"
#include "../shadow_maps/depth_map.hpp"
#include "../shadow_maps/light_view.hpp"
#include "../shadow_maps/render_depth_map.hpp"
#include "ao_stats.hpp"

namespace aaf {
inline namespace v0 {

/// Settings of shadow-map AO.
template <class T = float>
struct shadow_map_ao_settings {
    std::uint32_t directions = 32;  ///< depth maps (directions over the sphere); [1, 65536], lecture 4, 32, 512
    std::uint32_t resolution = 512; ///< each map is resolution × resolution texels; [1, 16384]
    /// Occluders count within this distance of the surface along each direction (world units); (0, +∞].
    T max_distance = std::numeric_limits<T>::infinity();
    depth_format format = depth_format::unorm24;  ///< precision of the maps (the automatic bias uses its step)
    bias_settings<T> bias{};                      ///< depth bias of the lookups (default automatic)
    T margin = T(0.01);                           ///< relative margin of the maps' frusta around the scene; [0, 1]
};

/// The i-th of n directions of the spherical Fibonacci set: unit, evenly spread over the sphere (z_i evenly
/// spaced in (−1, 1), azimuths advancing by the golden angle). n >= 1, i < n.
template <class T = float>
[[nodiscard]] glm::vec<3, T> fibonacci_direction(std::uint32_t i, std::uint32_t n) noexcept {
    const double z = 1.0 - (2.0 * i + 1.0) / static_cast<double>(n);
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double phi = static_cast<double>(i) * std::numbers::pi * (3.0 - std::sqrt(5.0));
    return glm::vec<3, T>(static_cast<T>(r * std::cos(phi)), static_cast<T>(z), static_cast<T>(r * std::sin(phi)));
}

/// What shadow_map_ao returns.
struct shadow_map_ao_stats {
    std::uint64_t map_rays = 0;     ///< texel rays traced to render the maps (directions × resolution²)
    std::uint64_t failed_rays = 0;  ///< texel rays the tracer answered with NaN (stored as "nothing")
    std::size_t map_bytes = 0;      ///< storage of the one map that is live at a time
};

namespace detail {
template <class T>
void validate(const shadow_map_ao_settings<T>& s, const char* fn) {
    if (s.directions < 1 || s.directions > 65536) throw_invalid(fn, "`settings.directions` must be in [1, 65536]");
    if (s.resolution < 1 || s.resolution > 16384) throw_invalid(fn, "`settings.resolution` must be in [1, 16384]");
    if (!(s.max_distance > T(0))) throw_invalid(fn, "`settings.max_distance` must be > 0 world units, +inf for no limit");
    if (!(s.margin >= T(0) && s.margin <= T(1))) throw_invalid(fn, "`settings.margin` must be in [0, 1]");
    validate_bias(fn, s.bias);
}
}  // namespace detail

/// Shadow-map AO over the G-buffer `gb` (positions and normals read; pixel_size and ids not): writes each
/// pixel's cosine-weighted unoccluded fraction into `visibility` and, when not empty, its unit bent normal
/// into `bent`. `scene_points` (any range of glm::vec<3, T>, e.g. the scene's vertices or bounding-box
/// corners) bounds the geometry: every map's frustum is fitted around it. The maps are rendered through
/// `tracer` one direction at a time and discarded after their lookups. Pixels whose position or normal is not
/// finite, or whose hemisphere holds no direction of the set (N tiny), get visibility 1 and bent = normal
/// (zero vector for a non-finite normal). Throws aaf::invalid_argument naming gbuffer.*, visibility, bent,
/// settings.* or scene_points before writing anything.
template <class T, class Ids, class Tracer, class Points, class Exec = sequential_executor>
    requires occlusion_tracer<Tracer, T>
shadow_map_ao_stats shadow_map_ao(const gbuffer<T, Ids>& gb, const Tracer& tracer, const Points& scene_points,
                                  const shadow_map_ao_settings<T>& settings, image_view<T> visibility,
                                  image_view<glm::vec<3, T>> bent = {}, Exec&& exec = {}) {
    constexpr const char* fn = "shadow_map_ao";
    detail::validate(settings, fn);
    detail::require_nonempty(fn, "gbuffer.positions", gb.positions);
    const std::size_t w = gb.width(), h = gb.height();
    detail::require_size(fn, "gbuffer.normals", gb.normals, w, h);
    detail::require_size(fn, "visibility", visibility, w, h);
    detail::require_size_or_empty(fn, "bent", bent, w, h);
    bool any_point = false;
    for (const auto& p : scene_points) any_point = any_point || detail::finite3(glm::vec<3, T>(p));
    if (!any_point) detail::throw_invalid(fn, "`scene_points` has no finite point (the maps need the scene's extent)");

    // Accumulators: Σ c_k, Σ c_k V_k, Σ c_k V_k ω_k.
    image<T> weight(w, h, T(0)), lit(w, h, T(0));
    image<glm::vec<3, T>> bent_sum(w, h, glm::vec<3, T>(0));
    const std::size_t res = settings.resolution;
    const T range = settings.max_distance;
    const bool limited = range < std::numeric_limits<T>::infinity();
    shadow_map_ao_stats stats;
    depth_map<T> map;
    for (std::uint32_t k = 0; k < settings.directions; ++k) {
        const glm::vec<3, T> omega = fibonacci_direction<T>(k, settings.directions);
        // The map looks from ω towards the scene.
        const light_view<T> view = fit_orthographic_view<T>(-omega, scene_points, settings.margin);
        if (k == 0) map = depth_map<T>(res, res, view, settings.format);
        else map.reset(view);
        const depth_render_stats rs = render_depth_map(map, tracer, exec);
        stats.map_rays += rs.texels;
        stats.failed_rays += rs.failed;
        const light_frame<T> frame(view);
        exec.parallel_for(h, [&](std::size_t y0, std::size_t y1) {
            for (std::size_t y = y0; y < y1; ++y)
                for (std::size_t x = 0; x < w; ++x) {
                    const glm::vec<3, T> p = gb.positions(x, y), n = gb.normals(x, y);
                    if (!detail::finite3(p) || !detail::finite3(n)) continue;
                    const T c = glm::dot(n, omega);
                    if (!(c > T(0))) continue;
                    const detail::prepared_receiver<T> r =
                        detail::prepare_receiver(frame, res, res, settings.format, settings.bias, p, n);
                    bool occluded = false;
                    if (r.inside) {
                        // u == res (the frustum's closed edge) reads the last texel.
                        const auto i = std::min(static_cast<std::size_t>(r.u), res - 1);
                        const auto j = std::min(static_cast<std::size_t>(r.v), res - 1);
                        const float stored = map.z_tex(i, j);
                        occluded = r.occluded_by(stored, i, j) && (!limited || map.depth(i, j) > r.depth - range);
                    }
                    weight(x, y) += c;
                    if (!occluded) lit(x, y) += c, bent_sum(x, y) += c * omega;
                }
        });
    }
    stats.map_bytes = map.storage_bytes();
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) {
            const T wsum = weight(x, y);
            visibility(x, y) = wsum > T(0) ? lit(x, y) / wsum : T(1);
            if (bent.empty()) continue;
            const glm::vec<3, T> b = bent_sum(x, y), n = gb.normals(x, y);
            const glm::vec<3, T> u = detail::ao_unit_or_zero(b);
            bent(x, y) = u != glm::vec<3, T>(0) ? u : (detail::finite3(n) ? n : glm::vec<3, T>(0));
        }
    return stats;
}

}  // namespace v0
}  // namespace aaf
