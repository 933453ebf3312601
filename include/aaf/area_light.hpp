// SPDX-License-Identifier: MIT
#pragma once
// The planar (parallelogram) area light, its Gaussian-equivalent σ and an exact unshadowed-irradiance helper.

#include <array>
#include <cmath>
#include <numbers>
#include <type_traits>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "config.hpp"

namespace aaf {
inline namespace v0 {

/// How light samples are weighted when they are averaged into a pixel's visibility.
enum class light_weighting {
    /// Every point of the light counts the same: visibility is the visible fraction of the light's area
    /// (the quantity the analytic oracles give). Default.
    uniform,
    /// The authors' choice: weight exp(-|y - c|² / 2σ²), i.e. a truncated Gaussian emitter (FORMULAS.md §1.4).
    gaussian,
    /// Weight by the point-to-area geometry term cosθ_r cosθ_l / r², so that
    /// visibility × unshadowed_irradiance is the exact shadowed irradiance (a ratio estimator).
    irradiance,
};

/// A planar parallelogram light: points `corner + u * edge_u + v * edge_v` for u, v in [0, 1].
/// It emits from the side its normal `normalize(cross(edge_u, edge_v))` points to, unless `two_sided`.
template <class T = float>
struct area_light {
    using vec3 = glm::vec<3, T>;

    vec3 corner{0};          ///< one corner of the parallelogram (world units)
    vec3 edge_u{1, 0, 0};    ///< first edge from `corner` (world units)
    vec3 edge_v{0, 0, 1};    ///< second edge from `corner` (world units)
    bool two_sided = false;  ///< emit from both faces (default: only towards the normal)

    /// Unit normal, `cross(edge_u, edge_v)` normalised; (0,0,0) for a degenerate light.
    [[nodiscard]] vec3 normal() const noexcept {
        const vec3 n = glm::cross(edge_u, edge_v);
        const T len = glm::length(n);
        return len > T(0) ? n / len : vec3(0);
    }
    [[nodiscard]] T area() const noexcept { return glm::length(glm::cross(edge_u, edge_v)); }
    [[nodiscard]] vec3 center() const noexcept { return corner + T(0.5) * (edge_u + edge_v); }
    [[nodiscard]] vec3 point(T u, T v) const noexcept { return corner + u * edge_u + v * edge_v; }

    /// The Gaussian-equivalent standard deviation σ of FORMULAS.md §1.4: σ = √area / 2, so the light's
    /// equal-area square has side 2σ and its bandwidth is Ω_L = 1/σ (the authors' convention, "reading A").
    [[nodiscard]] T sigma() const noexcept { return std::sqrt(area()) * T(0.5); }

    /// Perpendicular distance from `p` to the light's plane (always ≥ 0). This is the theory's d1 (§1.1).
    [[nodiscard]] T plane_distance(const vec3& p) const noexcept { return std::abs(glm::dot(p - corner, normal())); }

    /// True when the light emits towards `p` (p strictly in front of an emitting face).
    [[nodiscard]] bool emits_towards(const vec3& p) const noexcept {
        const T side = glm::dot(p - corner, normal());
        return two_sided ? side != T(0) : side > T(0);
    }

    /// True when the plane through `p` with normal `n` (a receiver's tangent plane) cuts the light: some corner
    /// strictly above it and some strictly below, so part of the light is below the receiver's horizon and its
    /// visibility depends on the normal as well as on the occluders (issue 13, DEVIATIONS.md L2). A corner on
    /// the plane holds no area and counts on neither side; non-finite input or a zero normal gives false.
    [[nodiscard]] bool straddles_horizon(const vec3& p, const vec3& n) const noexcept {
        const vec3 c[4] = {corner, corner + edge_u, corner + edge_v, corner + edge_u + edge_v};
        bool above = false, below = false;
        for (const vec3& q : c) {
            const T h = glm::dot(n, q - p);
            above |= h > T(0), below |= h < T(0);
        }
        return above && below;  // NaN compares false both ways
    }

    /// Weight of light point `y` for a receiver at `p` with unit normal `n`, under `weighting`.
    /// Zero when `y` is below the receiver's horizon or `p` is behind a one-sided light.
    /// (Computes the light's constants each call; light_sample_frame keeps them for many samples.)
    [[nodiscard]] T sample_weight(light_weighting weighting, const vec3& p, const vec3& n, const vec3& y) const noexcept;
};

/// What weighting samples of `light` needs, computed once instead of per sample (the normal alone costs a
/// cross product and a square root): the one definition of the sample weights.
template <class T>
struct light_sample_frame {
    glm::vec<3, T> normal, center;
    T inv_two_sigma2 = 0;
    bool two_sided = false;
    light_weighting weighting = light_weighting::uniform;

    light_sample_frame(const area_light<T>& light, light_weighting w) noexcept
        : normal(light.normal()), center(light.center()), two_sided(light.two_sided), weighting(w) {
        const T s = light.sigma();
        inv_two_sigma2 = s > T(0) ? T(1) / (T(2) * s * s) : T(0);  // a degenerate light weighs every point 1
    }

    /// Weight of light point y seen from a receiver with unit normal n, along the unnormalised
    /// `to_light` = y − receiver. Zero below the horizon or behind a one-sided light.
    [[nodiscard]] T weight(const glm::vec<3, T>& n, const glm::vec<3, T>& to_light, const glm::vec<3, T>& y) const noexcept {
        const T cos_r = glm::dot(n, to_light);
        if (!(cos_r > T(0))) return T(0);
        const T cos_l = -glm::dot(normal, to_light);
        if (two_sided ? cos_l == T(0) : !(cos_l > T(0))) return T(0);
        switch (weighting) {
            case light_weighting::uniform: return T(1);
            case light_weighting::gaussian: {
                const glm::vec<3, T> dc = y - center;
                return std::exp(-glm::dot(dc, dc) * inv_two_sigma2);
            }
            case light_weighting::irradiance: {
                // cosθ_r cosθ_l / r² with both cosines taken from the unnormalised vector: divide by r⁴.
                const T r2 = glm::dot(to_light, to_light);
                return r2 > T(0) ? cos_r * std::abs(cos_l) / (r2 * r2) : T(0);
            }
        }
        return T(0);
    }
};

template <class T>
T area_light<T>::sample_weight(light_weighting weighting, const vec3& p, const vec3& n, const vec3& y) const noexcept {
    return light_sample_frame<T>(*this, weighting).weight(n, y - p, y);
}

/// Exact unshadowed irradiance at `p` (unit normal `n`) from the light with constant `radiance`
/// (W·sr⁻¹·m⁻² per unit of your choice): E = radiance · π · F, with F the point-to-polygon form factor
/// (Lambert's contour formula), after clipping the light to the receiver's upper hemisphere.
/// Returns 0 behind a one-sided light or when the light is wholly below the horizon.
/// Computed in at least double precision: Lambert's sum adds edge terms of the size of the light's angular
/// extent to obtain its far smaller projected solid angle, so in float a light subtending 10^-3 rad would
/// lose about 2 % to cancellation.
template <class T>
[[nodiscard]] T unshadowed_irradiance(const area_light<T>& light, const glm::vec<3, T>& p, const glm::vec<3, T>& n,
                                      T radiance = T(1)) noexcept {
    using D = std::conditional_t<(sizeof(T) < sizeof(double)), double, T>;
    using vec3 = glm::vec<3, D>;
    if (!light.emits_towards(p)) return T(0);
    const vec3 corner(light.corner), edge_u(light.edge_u), edge_v(light.edge_v), pd(p), nd(n);
    // Light polygon relative to p, clipped against the plane dot(n, x) >= 0 (Sutherland–Hodgman, ≤ 5 vertices).
    const std::array<vec3, 4> quad = {corner - pd, corner + edge_u - pd, corner + edge_u + edge_v - pd, corner + edge_v - pd};
    std::array<vec3, 8> poly{};
    std::size_t count = 0;
    for (std::size_t i = 0; i < 4; ++i) {
        const vec3& a = quad[i];
        const vec3& b = quad[(i + 1) % 4];
        const D da = glm::dot(nd, a);
        const D db = glm::dot(nd, b);
        if (da >= D(0)) poly[count++] = a;
        if ((da >= D(0)) != (db >= D(0))) poly[count++] = a + (b - a) * (da / (da - db));
    }
    if (count < 3) return T(0);
    // Lambert: F = 1/(2π) Σ θ_i n·Γ_i with Γ_i the unit normal of the plane through p and edge i.
    D sum = 0;
    for (std::size_t i = 0; i < count; ++i) {
        const vec3 a = glm::normalize(poly[i]);
        const vec3 b = glm::normalize(poly[(i + 1) % count]);
        const vec3 c = glm::cross(a, b);
        const D sin_theta = glm::length(c);
        if (!(sin_theta > D(0))) continue;
        const D theta = std::atan2(sin_theta, glm::dot(a, b));
        sum += theta * glm::dot(nd, c / sin_theta);
    }
    // The sign depends on the polygon's winding as seen from p; irradiance is its magnitude.
    return static_cast<T>(static_cast<D>(radiance) * std::abs(sum) * D(0.5));
}

}  // namespace v0
}  // namespace aaf
