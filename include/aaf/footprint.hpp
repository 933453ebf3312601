// SPDX-License-Identifier: MIT
#pragma once
// A pixel's footprint on its receiver surface, for tilt-aware image-space filter widths: the camera's
// pixel size d (pinhole_pixel_size) is the footprint on a plane facing the camera, but a surface seen at a
// grazing angle θ spans d/cos θ per pixel along its tilt, so β/d pixels over-blur it by 1/cos θ there.
// Measured from the G-buffer's own positions: the distance between a pixel's neighbours on the same surface.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <type_traits>
#include <utility>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "config.hpp"
#include "executor.hpp"
#include "image_view.hpp"
#include "settings.hpp"

namespace aaf {
inline namespace v0 {

namespace detail {

/// World distance per pixel step along one axis at pixel (x, y): half the distance between the two
/// neighbours on the same surface (finite position, normal within the cosine threshold), or the one-sided
/// distance when only one qualifies; 0 when neither does. `nearer` (surface_axes): with both neighbours,
/// the shorter one-sided distance instead of the central one. A depth jump to a parallel surface (a blind's
/// next slat, a box's top over the floor) passes the normal test and sits on one side only: the central
/// distance takes half the jump as the step, and a per-axis footprint, which unlike √(s_x s_y) does not
/// soften it with the other axis, would switch that axis's kernel off along the edge. On a smooth surface
/// the two one-sided distances differ by the foreshortening's change over one pixel (second order).
/// `plane` (light_axes; else null): the distances are projected on the plane of that unit normal first.
template <class T>
[[nodiscard]] T surface_step(const_image_view<glm::vec<3, T>> positions, const_image_view<glm::vec<3, T>> normals, std::size_t x,
                             std::size_t y, bool horizontal, T cos_threshold, bool nearer = false,
                             const glm::vec<3, T>* plane = nullptr) noexcept {
    const std::size_t pos = horizontal ? x : y, extent = horizontal ? positions.width() : positions.height();
    const glm::vec<3, T> n = normals(x, y);
    const auto at = [&](std::size_t j) { return horizontal ? std::pair{j, y} : std::pair{x, j}; };
    const auto same_surface = [&](std::size_t j) {
        const auto [nx, ny] = at(j);
        const glm::vec<3, T> q = positions(nx, ny);
        return std::isfinite(q.x + q.y + q.z) && glm::dot(n, normals(nx, ny)) >= cos_threshold;  // NaN normal: false
    };
    const bool lo = pos > 0 && same_surface(pos - 1), hi = pos + 1 < extent && same_surface(pos + 1);
    const auto p = [&](std::size_t j) {
        const auto [nx, ny] = at(j);
        return positions(nx, ny);
    };
    const auto length = [plane](glm::vec<3, T> v) {
        if (plane) v -= glm::dot(v, *plane) * *plane;
        return glm::length(v);
    };
    if (lo && hi && nearer) return std::min(length(p(pos) - p(pos - 1)), length(p(pos + 1) - p(pos)));
    if (lo && hi) return length(p(pos + 1) - p(pos - 1)) / T(2);
    if (lo) return length(p(pos) - p(pos - 1));
    if (hi) return length(p(pos + 1) - p(pos));
    return T(0);
}

}  // namespace detail

namespace detail {

/// surface_footprint's work, compiled once per pixel type whatever the caller's executor.
/// `vertical` (surface_axes, light_axes; else empty): s_y, while `output` gets s_x. `light_normal`
/// (light_axes only): the plane the steps are projected on.
template <class T>
void surface_footprint_impl(const_image_view<glm::vec<3, T>> positions, const_image_view<glm::vec<3, T>> normals,
                            const_image_view<T> pixel_size, image_view<T> output, image_view<T> vertical, pixel_footprint mode,
                            T normal_threshold_degrees, glm::vec<3, T> light_normal, executor_ref exec) {
    const bool on_light = mode == pixel_footprint::light_axes, axes = mode == pixel_footprint::surface_axes || on_light;
    const char* fn = on_light ? "surface_footprint_light_axes" : axes ? "surface_footprint_axes" : "surface_footprint";
    require_nonempty(fn, "positions", positions);
    const std::size_t w = positions.width(), h = positions.height();
    require_size(fn, "normals", normals, w, h);
    require_size(fn, "pixel_size", pixel_size, w, h);
    require_size(fn, axes ? "horizontal" : "output", output, w, h);
    if (axes) require_size(fn, "vertical", vertical, w, h);
    if (!(normal_threshold_degrees > T(0) && normal_threshold_degrees <= T(180)))
        throw_invalid(fn, "`normal_threshold_degrees` must be in (0, 180] (got " + std::to_string(normal_threshold_degrees) + ")");
    if (on_light) {
        const T len = glm::length(light_normal);
        if (!(len > T(0)) || !std::isfinite(len)) throw_invalid(fn, "`light_normal` must be a finite non-zero vector");
        light_normal /= len;
    }
    if (axes) {
        if (output.bytes() == pixel_size.bytes() || vertical.bytes() == pixel_size.bytes() || output.bytes() == vertical.bytes())
            throw_invalid(fn, "`horizontal`, `vertical` and `pixel_size` must be distinct buffers");
    } else {
        if (mode != pixel_footprint::camera && mode != pixel_footprint::surface_area && mode != pixel_footprint::surface_max)
            throw_invalid(fn, "`mode` is not a pixel_footprint");
        if (output.bytes() == pixel_size.bytes()) throw_invalid(fn, "`output` must not alias `pixel_size`");
    }
    const T cos_threshold = std::cos(normal_threshold_degrees * T(3.14159265358979323846) / T(180));
    exec.parallel_for(h, [&](std::size_t y0, std::size_t y1) {
        for (std::size_t y = y0; y < y1; ++y)
            for (std::size_t x = 0; x < w; ++x) {
                const T d = pixel_size(x, y);
                const glm::vec<3, T> p = positions(x, y), n = normals(x, y);
                if (mode == pixel_footprint::camera || !(d > T(0)) || !std::isfinite(d) || !std::isfinite(p.x + p.y + p.z + n.x + n.y + n.z)) {
                    output(x, y) = d;
                    if (axes) vertical(x, y) = d;
                    continue;
                }
                const glm::vec<3, T>* plane = on_light ? &light_normal : nullptr;
                const T sx = std::max(surface_step(positions, normals, x, y, true, cos_threshold, axes, plane), d);
                const T sy = std::max(surface_step(positions, normals, x, y, false, cos_threshold, axes, plane), d);
                if (axes) {  // each pass its own axis's step (finite: a length of finite positions, or d)
                    output(x, y) = std::isfinite(sx) ? sx : d;
                    vertical(x, y) = std::isfinite(sy) ? sy : d;
                    continue;
                }
                const T f = mode == pixel_footprint::surface_area ? std::sqrt(sx * sy) : std::max(sx, sy);
                output(x, y) = std::isfinite(f) ? f : d;
            }
    });
}

}  // namespace detail

/// Writes each pixel's footprint for the filter's β/d (filter_settings::footprint): `camera` copies
/// `pixel_size`; `surface_area` is √(s_x s_y) and `surface_max` is max(s_x, s_y), with s_x, s_y the world
/// distances per pixel step along the image axes on the pixel's own surface (neighbours with a finite
/// position and a normal within `normal_threshold_degrees`), each at least `pixel_size` (a surface is
/// never seen more than face-on) and `pixel_size` itself where no neighbour qualifies. Pixels with a
/// non-finite position or normal, or a pixel size that is not finite and positive, are copied.
/// `surface_axes` has two footprints per pixel: surface_footprint_axes (this function rejects it).
template <class T, class Exec = sequential_executor>
void surface_footprint(std::type_identity_t<const_image_view<glm::vec<3, T>>> positions,
                       std::type_identity_t<const_image_view<glm::vec<3, T>>> normals, std::type_identity_t<const_image_view<T>> pixel_size,
                       image_view<T> output, pixel_footprint mode, T normal_threshold_degrees = T(20), Exec&& exec = {}) {
    if (mode == pixel_footprint::surface_axes || mode == pixel_footprint::light_axes)  // one footprint per pixel here
        detail::throw_invalid("surface_footprint",
                              "`mode` surface_axes or light_axes has a footprint per axis: call surface_footprint_axes or surface_footprint_light_axes");
    detail::surface_footprint_impl<T>(positions, normals, pixel_size, output, image_view<T>{}, mode, normal_threshold_degrees,
                                      glm::vec<3, T>(0), detail::executor_ref(exec));
}

/// The per-axis footprint of `pixel_footprint::surface_axes`: `horizontal` gets s_x and `vertical` s_y
/// (the rules of surface_footprint: each at least `pixel_size`, `pixel_size` where no neighbour along that
/// axis qualifies or the pixel's own data is not usable), for filter_visibility_axes, whose horizontal pass
/// divides β by s_x and vertical pass by s_y. On a plane seen at a grazing angle θ along x, s_x = d/cos θ
/// and s_y = d: the kernel narrows only along the tilt. On a curved surface the step is the chord to the
/// neighbours (central difference), at a silhouette or an edge the one-sided step to the neighbour on the
/// same surface. Between two neighbours on the surface the step is the shorter one-sided distance (not the
/// scalar modes' central one), so that a depth jump to a parallel surface on one side (normals within the
/// threshold) does not read as a long step; where both sides jump (a one-pixel strip) it still does, which
/// narrows that axis's kernel there: less blur, never more.
template <class T, class Exec = sequential_executor>
void surface_footprint_axes(std::type_identity_t<const_image_view<glm::vec<3, T>>> positions,
                            std::type_identity_t<const_image_view<glm::vec<3, T>>> normals,
                            std::type_identity_t<const_image_view<T>> pixel_size, image_view<T> horizontal,
                            std::type_identity_t<image_view<T>> vertical, T normal_threshold_degrees = T(20), Exec&& exec = {}) {
    detail::surface_footprint_impl<T>(positions, normals, pixel_size, horizontal, vertical, pixel_footprint::surface_axes,
                                      normal_threshold_degrees, glm::vec<3, T>(0), detail::executor_ref(exec));
}

/// The per-axis footprint of `pixel_footprint::light_axes`: surface_footprint_axes with each step projected
/// on the plane of `light_normal` (any finite non-zero length) first, the distance the light-plane offsets
/// measure (§1.11) and the plane in which the paper's β is a width; each still at least `pixel_size`. On a
/// receiver parallel to the light it equals surface_footprint_axes; where the surface turns towards the
/// light's direction its steps shorten (down to the clamp d), so the kernel narrows less than by the tilt
/// to the camera alone.
template <class T, class Exec = sequential_executor>
void surface_footprint_light_axes(std::type_identity_t<const_image_view<glm::vec<3, T>>> positions,
                                  std::type_identity_t<const_image_view<glm::vec<3, T>>> normals,
                                  std::type_identity_t<const_image_view<T>> pixel_size,
                                  const std::type_identity_t<glm::vec<3, T>>& light_normal, image_view<T> horizontal,
                                  std::type_identity_t<image_view<T>> vertical, T normal_threshold_degrees = T(20), Exec&& exec = {}) {
    detail::surface_footprint_impl<T>(positions, normals, pixel_size, horizontal, vertical, pixel_footprint::light_axes,
                                      normal_threshold_degrees, light_normal, detail::executor_ref(exec));
}

// The compiled mode's instantiations (config.hpp: AAF_EXTERN_TEMPLATES).
#define AAF_DETAIL_FOOTPRINT_INSTANTIATIONS(KEYWORD, T) AAF_DETAIL_INSTANTIATE(KEYWORD, detail::surface_footprint_impl<T>)
#ifdef AAF_EXTERN_TEMPLATES
AAF_DETAIL_FOOTPRINT_INSTANTIATIONS(extern, float)
AAF_DETAIL_FOOTPRINT_INSTANTIATIONS(extern, double)
#endif

}  // namespace v0
}  // namespace aaf
