// SPDX-License-Identifier: MIT
#pragma once
// A light-space map for an area light (aaf::area_light, the core's light): an orthographic map looking along
// the light's normal from its plane, each texel holding the first surface that direction meets and the
// irradiance the whole light gives it, integrated over the light's area through the user's tracer:
//
//   E·F_t(p) = L ∫_light F_t(cos θ_p; η) cos θ_p cos θ_y / |y − p|² V(p, y) dA_y
//
// estimated with `light_samples` stratified points y per texel and one shadow ray each (V).
//
// The model, and what it leaves out: the Jensen dipole needs only E·F_t at each entry point (the profile
// depends on distance alone), so wherever the map sees the lit surface the gather integrates the same
// quantity as with a directional light: the light's size enters through E, including its penumbrae. What the
// map cannot hold: (1) entry points lit by the light but hidden along the light's normal (the sides of an
// object under a light much wider than it, a surface facing the light sideways) get no texel, so their light
// is missing from the gather (not measured: the tests use a flat slab, where the map sees every lit point);
// (2) the directional dipole's ω_i is taken as the map's direction (−normal), the light's mean direction
// only for receivers under its centre. A point light's cube map or several maps from points of the light
// would cover (1); not done.

#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "../area_light.hpp"
#include "../executor.hpp"
#include "../ray_offset.hpp"
#include "../region.hpp"
#include "../sampler.hpp"
#include "../tracer.hpp"
#include "dipole.hpp"
#include "light_map.hpp"

namespace aaf {
inline namespace v0 {
namespace subsurface {

/// Settings of `build_area_light_map`.
template <class T = float>
struct area_map_settings {
    std::uint32_t light_samples = 64;  ///< shadow rays per texel towards the light, [1, 65536], stratified over its area
    glm::vec<3, T> radiance{1};        ///< the light's constant RGB radiance, finite, ≥ 0 (irradiance units per sr)
    std::uint32_t light_index = 0;     ///< sample key's light (texel (x, y) is keyed as pixel (x, y), pass 0)
    std::uint32_t frame_seed = 0;      ///< sample key's frame seed
};

/// The orthographic map of `light`: looking along its normal (towards `center` for a two-sided light) over
/// the sphere of `center` and `radius` (the translucent objects' bounds), `resolution`² texels.
template <class T>
[[nodiscard]] orthographic_projection<T> area_light_projection(const area_light<T>& light, const glm::vec<3, T>& center, T radius,
                                                              std::size_t resolution) {
    glm::vec<3, T> n = light.normal();
    if (light.two_sided && glm::dot(center - light.center(), n) < T(0)) n = -n;
    return orthographic_projection<T>::looking_along(n, center, radius, resolution);
}

/// Builds the map of an area light through the user's tracer (tracer.hpp contract): positions and normals as
/// `build_light_map` finds them along `projection`'s rays, then E·F_t per texel integrated over the light
/// (header comment). `projection` would normally come from `area_light_projection`; any orthographic one is
/// accepted (the map holds the light's irradiance wherever it looks from). Texels the light does not reach
/// (behind a one-sided light, back-facing, all shadow rays blocked) get 0.
/// Throws aaf::invalid_argument before building for: an invalid projection, a degenerate light (zero or
/// non-finite area or corner), negative or non-finite radiance, η ≤ 0 or non-finite, light_samples outside
/// [1, 65536]. Rows run on `exec`; the tracer is called concurrently. Cost: one ray per texel plus
/// light_samples shadow rays per covered texel.
template <class T, class Tracer, class NormalFn = reconstruct_normals, class Exec = sequential_executor>
    requires occlusion_tracer<Tracer, T>
[[nodiscard]] light_map<orthographic_projection<T>> build_area_light_map(const orthographic_projection<T>& projection,
                                                                         const area_light<T>& light, const area_map_settings<T>& settings,
                                                                         T eta, const Tracer& tracer, NormalFn normals_of = {},
                                                                         Exec&& exec = {}) {
    using vec3 = glm::vec<3, T>;
    constexpr const char* fn = "subsurface::build_area_light_map";
    detail::require_projection(fn, projection);
    const vec3 nl = light.normal();
    if (!(light.area() > T(0)) || !std::isfinite(light.area()) || !std::isfinite(light.corner.x + light.corner.y + light.corner.z) ||
        nl == vec3(0))
        aaf::detail::throw_invalid(fn, "`light` must have a finite corner and a finite area > 0");
    if (!subsurface::detail::finite_nonnegative(settings.radiance))
        aaf::detail::throw_invalid(fn, "`settings.radiance` must be finite and >= 0");
    if (settings.light_samples < 1 || settings.light_samples > 65536)
        aaf::detail::throw_invalid(fn, "`settings.light_samples` must be in [1, 65536]");
    if (!(eta > T(0)) || !std::isfinite(eta)) aaf::detail::throw_invalid(fn, "`eta` must be finite and > 0");

    // Positions and normals as for a directional light (its E is replaced below).
    light_map<orthographic_projection<T>> map =
        build_light_map(projection, map_light<T>{vec3(1)}, eta, tracer, std::move(normals_of), exec);
    const std::size_t w = projection.width, h = projection.height;
    const std::uint32_t M = settings.light_samples;
    const double area = double(light.area());
    auto& P = map.positions[0];
    auto& N = map.normals[0];
    auto& E = map.irradiance[0];
    exec.parallel_for(h, [&](std::size_t y0, std::size_t y1) {
        std::vector<glm::vec<2, T>> uv(M);
        for (std::size_t y = y0; y < y1; ++y)
            for (std::size_t x = 0; x < w; ++x) {
                E(x, y) = vec3(0);
                const vec3 p = P(x, y), n = N(x, y);
                if (!std::isfinite(p.x + p.y + p.z) || !std::isfinite(n.x + n.y + n.z)) continue;
                generate_samples<T>(sample_pattern::stratified, pixel_key(frame_region{}, x, y, 0, settings.light_index, settings.frame_seed), uv);
                double sum = 0;
                for (std::uint32_t k = 0; k < M; ++k) {
                    const vec3 yl = light.point(uv[k].x, uv[k].y);
                    const vec3 d = yl - p;
                    const double d2 = double(glm::dot(d, d));
                    if (!(d2 > 0) || !std::isfinite(d2)) continue;
                    const vec3 dir = d / T(std::sqrt(d2));
                    const T cos_p = glm::dot(n, dir);
                    T cos_y = -glm::dot(nl, dir);  // the light emits along +nl: a receiver in front sees −dir·nl > 0
                    if (light.two_sided) cos_y = std::abs(cos_y);
                    if (!(cos_p > T(0)) || !(cos_y > T(0))) continue;
                    const vec3 origin = shadow_ray_origin(p, n, yl);
                    const T len = glm::length(yl - origin);
                    const occluder_span<T> hit = aaf::detail::trace_one<T>(tracer, shadow_segment<T>{origin, (yl - origin) / len, len});
                    if (hit.hit() || std::isnan(hit.nearest)) continue;
                    sum += double(cos_p) * double(fresnel_transmittance_in(cos_p, eta)) * double(cos_y) / d2;
                }
                const glm::dvec3 e = glm::dvec3(settings.radiance) * (sum * area / double(M));
                E(x, y) = std::isfinite(e.x + e.y + e.z) ? vec3(e) : vec3(0);
            }
    });
    return map;
}

}  // namespace subsurface
}  // namespace v0
}  // namespace aaf
