// SPDX-License-Identifier: MIT
#pragma once
// A Monte Carlo reference for the gather that uses no light-space map: the same profile integrated over the
// surface around x_o, with surface points from the caller's sampler and the light's visibility at each point
// traced through the caller's tracer. The gather is judged against the integral it approximates.

#include <cmath>
#include <cstdint>
#include <numbers>
#include <utility>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "../area_light.hpp"
#include "../ray_offset.hpp"
#include "../sampler.hpp"
#include "../tracer.hpp"
#include "dipole.hpp"
#include "directional_dipole.hpp"
#include "gather.hpp"
#include "material.hpp"

namespace aaf {
inline namespace v0 {
namespace subsurface {

/// A point on the translucent surface drawn by the caller's sampler, with its density per unit area
/// (pdf ≤ 0 or non-finite: the sample is dropped).
template <class T = float>
struct surface_sample {
    glm::vec<3, T> position{0};
    glm::vec<3, T> normal{0, 0, 1};  ///< unit, outward
    T pdf = 0;                       ///< per unit area, world units⁻²
};

/// The light as the reference sees it: directional (`direction` = unit vector towards the light, `power` =
/// irradiance perpendicular to it), point (`position`, `power` = intensity) or area (`area`, `power` = its
/// constant radiance; one point of the light per surface sample, from the key's next pass).
template <class T = float>
struct reference_light {
    bool is_point = false;
    bool is_area = false;               ///< an area light (`area`); overrides is_point
    area_light<T> area{};               ///< the area light when is_area
    glm::vec<3, T> direction{0, 1, 0};  ///< directional: unit vector towards the light
    glm::vec<3, T> position{0};         ///< point light position
    glm::vec<3, T> power{1};            ///< irradiance (directional) or intensity (point), ≥ 0
    T far = 1e30f;                      ///< directional: shadow-ray length, world units
};

/// Estimates Σ_k f(x_o, x_k)·E_k·F_t,k / pdf_k / n over `n` surface samples from `sample_surface(u, v)`
/// (u, v ∈ [0, 1), stratified, keyed by `key`), with E_k = power·cos θ_k·V_k (V_k through `tracer`, origins
/// offset with aaf::shadow_ray_origin) and f the same profile as the gather (R_d(r)/π or S_d without T₁₂).
/// The result is the gather's quantity (subsurface radiance before the exit Fresnel factor).
template <class T, class Tracer, class SurfaceSampler>
    requires occlusion_tracer<Tracer, T>
[[nodiscard]] glm::dvec3 reference_subsurface(const glm::vec<3, T>& x_o, const glm::vec<3, T>& n_o, const material<T>& mat,
                                              profile_model model, boundary_term boundary, const reference_light<T>& light,
                                              const Tracer& tracer, SurfaceSampler&& sample_surface, std::uint32_t n,
                                              const sample_key& key) {
    validate(mat, "subsurface::reference_subsurface");
    const rgb_dipole dip(mat, boundary);
    const rgb_directional_dipole ddip(mat);
    std::vector<glm::vec<2, T>> uv(n), uv_light(light.is_area ? n : 0);
    generate_samples<T>(sample_pattern::stratified, key, uv);
    if (light.is_area) {
        sample_key next = key;
        ++next.pass;
        generate_samples<T>(sample_pattern::stratified, next, uv_light);
        // Stratum k of the surface and stratum k of the light must not be paired: both sets run through their
        // strata in the same order, so sample k's radius and angle would choose its light point (+3.4 % on a
        // slab under a square light, measured). A hash-driven Fisher–Yates shuffle decorrelates them.
        const std::uint32_t seed = aaf::detail::key_hash(next);
        for (std::uint32_t k = n; k > 1; --k) {
            const std::uint32_t j = aaf::detail::hash32(seed ^ (k * 0x9e3779b9u)) % k;
            std::swap(uv_light[k - 1], uv_light[j]);
        }
    }
    const glm::vec<3, T> area_normal = light.area.normal();
    glm::dvec3 sum(0);
    for (std::uint32_t k = 0; k < n; ++k) {
        const surface_sample<T> s = sample_surface(uv[k].x, uv[k].y);
        if (!(s.pdf > T(0)) || !std::isfinite(s.pdf)) continue;
        // Area light: a point y of it, and the geometry factor cos θ_y·area/d² turning its radiance into the
        // irradiance it gives (the 1/pdf of a uniform point on the light).
        glm::vec<3, T> y_light(0);
        double area_factor = 1;
        if (light.is_area) {
            y_light = light.area.point(uv_light[k].x, uv_light[k].y);
            const glm::vec<3, T> d = y_light - s.position;
            const double d2 = double(glm::dot(d, d));
            double cos_y = -double(glm::dot(area_normal, d)) / std::sqrt(d2);
            if (light.area.two_sided) cos_y = std::abs(cos_y);
            if (!(cos_y > 0) || !(d2 > 0)) continue;
            area_factor = cos_y * double(light.area.area()) / d2;
        }
        const glm::vec<3, T> to_light = light.is_area    ? glm::normalize(y_light - s.position)
                                        : light.is_point ? glm::normalize(light.position - s.position)
                                                         : light.direction;
        const T c = glm::dot(s.normal, to_light);
        if (!(c > T(0))) continue;
        const glm::vec<3, T> target = light.is_area ? y_light : light.is_point ? light.position : s.position + light.far * to_light;
        const glm::vec<3, T> origin = shadow_ray_origin(s.position, s.normal, target);
        const T len = glm::length(target - origin);
        const occluder_span<T> hit = aaf::detail::trace_one<T>(tracer, shadow_segment<T>{origin, to_light, len});
        if (hit.hit() || std::isnan(hit.nearest)) continue;
        double e = double(c) * double(fresnel_transmittance_in(c, mat.eta)) * area_factor;
        if (light.is_point && !light.is_area) e /= double(glm::dot(light.position - s.position, light.position - s.position));
        glm::dvec3 f;
        if (model == profile_model::dipole) f = dip.profile(double(glm::length(x_o - s.position))) / std::numbers::pi;
        else f = ddip.evaluate(glm::dvec3(s.position), glm::dvec3(s.normal), glm::dvec3(to_light), glm::dvec3(x_o), glm::dvec3(n_o), false);
        sum += glm::dvec3(light.power) * e * f / double(s.pdf);
    }
    return n > 0 ? sum / double(n) : sum;
}

}  // namespace subsurface
}  // namespace v0
}  // namespace aaf
