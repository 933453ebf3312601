// SPDX-License-Identifier: MIT
#pragma once
// Depth bias: how much nearer than the receiver a stored depth must be to count as an occluder. The
// seed's constant ε_b, slope-scaled bias (glPolygonOffset, FORMULAS.md §3.4), normal-offset bias,
// receiver-plane depth bias (Isidoro 2006) and the automatic bias, the default, which sets no epsilon by
// hand: it is derived from the texel's world footprint, the receiver's slope to the light and the depth
// quantisation step, as ray_offset.hpp derives ray origins from the hit point's rounding error.
//
// Why the automatic bias is what it is. A texel stores the depth of the surface at the texel's *centre*;
// a receiver read through that texel lies Δ texels away from it (|Δ| ≤ ½ per axis for the hard test, more
// for a PCF tap). On a receiver plane whose depth changes by g_i, g_j world units per texel step (its slope
// to the light times the texel footprint), the two depths differ by g_i·Δ_i + g_j·Δ_j ≤ |g_i||Δ_i| + |g_j||Δ_j|.
// The stored value also carries up to half a quantisation step (plus half a float ulp when a unorm24 code is
// held as a float), and both depths carry the rounding of computing them (a few ulps of the coordinates).
// The automatic bias is the sum of these bounds, times `scale` for curved receivers and the perspective
// depth's curvature across a texel: acne would need an error beyond a bound, so there is none on planar
// receivers at any scene scale; peter-panning is at most that bound, a fixed multiple of the texel's depth
// footprint (docs/SHADOW_MAPS.md has the measurements).

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <string>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "../config.hpp"
#include "depth_map.hpp"
#include "light_view.hpp"

namespace aaf {
inline namespace v0 {

/// Which depth bias a lookup applies. Costs in docs/SHADOW_MAPS.md.
enum class bias_mode {
    none,            ///< stored < receiver: acne on every lit surface not facing the light exactly
    constant,        ///< the seed's ε_b (`constant`, world units): right at one scene scale only
    slope_scaled,    ///< constant + slope_factor·(depth slope per texel) + units·(quantisation step), as glPolygonOffset
    normal_offset,   ///< receiver moved `normal_offset` texel footprints along its normal, then `constant`
    receiver_plane,  ///< each texel compared with the receiver plane's depth extrapolated to it, + quantisation
    automatic,       ///< from texel footprint, receiver slope and quantisation step; no hand-set epsilon. Default.
};

[[nodiscard]] constexpr const char* to_string(bias_mode m) noexcept {
    switch (m) {
        case bias_mode::none: return "none";
        case bias_mode::constant: return "constant";
        case bias_mode::slope_scaled: return "slope_scaled";
        case bias_mode::normal_offset: return "normal_offset";
        case bias_mode::receiver_plane: return "receiver_plane";
        case bias_mode::automatic: return "automatic";
    }
    return "?";
}

/// Depth-bias settings. Only the fields of the chosen mode are read.
template <class T = float>
struct bias_settings {
    bias_mode mode = bias_mode::automatic;  ///< see bias_mode
    T constant = 0;        ///< world units added to the bias in constant, slope_scaled, normal_offset, receiver_plane modes, [0, ∞)
    T slope_factor = 1;    ///< slope_scaled: multiple of the receiver's depth change per texel (glPolygonOffset factor), [0, ∞)
    T units = 1;           ///< slope_scaled: multiple of the depth quantisation step (glPolygonOffset units), [0, ∞)
    T normal_offset = 1;   ///< normal_offset: texel footprints the receiver moves along its normal, [0, ∞)
    T max_slope = 16;      ///< cap on the receiver's slope tan θ to the light in every slope term (grazing receivers), [0, ∞)
    T scale = T(1.5);      ///< automatic: multiple of the derived bound (margin for curvature), [1, ∞)
};

namespace detail {

template <class T>
void validate_bias(const char* fn, const bias_settings<T>& b) {
    const auto check = [&](T v, const char* name, T lo) {
        if (!(v >= lo) || !std::isfinite(v))
            throw_invalid(fn, std::string("`settings.bias.") + name + "` must be finite and >= " + std::to_string(static_cast<double>(lo)));
    };
    check(b.constant, "constant", T(0));
    check(b.slope_factor, "slope_factor", T(0));
    check(b.units, "units", T(0));
    check(b.normal_offset, "normal_offset", T(0));
    check(b.max_slope, "max_slope", T(0));
    check(b.scale, "scale", T(1));
}

/// A receiver prepared for depth tests against one map: its texel position and z_tex, and its bias as
/// threshold(i, j) = z − c0 + su·Δi + sv·Δj − au·|Δi| − av·|Δj| in z_tex units, where Δ = texel centre − (u, v).
/// Every mode is one set of coefficients of this one expression, so a tap costs the same in every mode.
/// Comparing in z_tex units means the bias (world units) is converted with the derivative of z_tex at the
/// receiver's depth: exact for orthographic maps; for perspective ones the error is relative (bias/depth)².
template <class T>
struct prepared_receiver {
    T u = 0, v = 0;  ///< continuous texel coordinates
    T z = 0;         ///< z_tex of the receiver (not clamped)
    T depth = 0;     ///< depth in front of the light (world units)
    T c0 = 0, su = 0, sv = 0, au = 0, av = 0;
    bool inside = false;  ///< inside the map's frustum (else lit by definition)

    [[nodiscard]] T threshold(T ci, T cj) const noexcept {
        const T du = ci - u, dv = cj - v;
        return z - c0 + su * du + sv * dv - au * std::abs(du) - av * std::abs(dv);
    }
    /// True when the stored z_tex `stored` at texel (i, j) occludes the receiver. NaN never occludes.
    [[nodiscard]] bool occluded_by(float stored, std::size_t i, std::size_t j) const noexcept {
        return static_cast<T>(stored) < threshold(static_cast<T>(i) + T(0.5), static_cast<T>(j) + T(0.5));
    }
};

template <class T>
[[nodiscard]] T max_abs(const glm::vec<3, T>& v) noexcept {
    return std::max({std::abs(v.x), std::abs(v.y), std::abs(v.z)});
}

/// Prepares receiver point `p` with unit normal `n` (either orientation) for tests against a width×height
/// map of `format` seen through `frame`, under bias `b`.
template <class T>
[[nodiscard]] prepared_receiver<T> prepare_receiver(const light_frame<T>& frame, std::size_t width, std::size_t height,
                                                    depth_format format, const bias_settings<T>& b, glm::vec<3, T> p,
                                                    glm::vec<3, T> n) noexcept {
    prepared_receiver<T> r;
    const light_view<T>& view = frame.view;
    const bool persp = frame.perspective();
    glm::vec<3, T> l = frame.to_light(p);
    if (b.mode == bias_mode::normal_offset) {
        const glm::vec<3, T> to_light = persp ? view.eye - p : -frame.forward;
        if (glm::dot(n, to_light) < T(0)) n = -n;
        const glm::vec<2, T> fp = frame.texel_footprint(std::max(l.z, view.near_plane), width, height);
        p += n * (b.normal_offset * std::max(fp.x, fp.y));
        l = frame.to_light(p);
    }
    r.depth = l.z;
    if (persp && !(l.z > T(0))) return r;  // behind the light: outside
    const glm::vec<2, T> uv = frame.texel_coords(l, width, height);
    r.u = uv.x, r.v = uv.y;
    r.inside = uv.x >= T(0) && uv.x <= static_cast<T>(width) && uv.y >= T(0) && uv.y <= static_cast<T>(height) &&
               l.z >= view.near_plane && l.z <= view.far_plane;
    if (!r.inside) return r;
    const T nf = view.near_plane, ff = view.far_plane;
    r.z = z_tex_from_depth(view.projection, l.z, nf, ff);
    const T dz_dd = T(1) / depth_per_z_tex(view.projection, l.z, nf, ff);
    const T q = static_cast<T>(z_tex_step(format, static_cast<double>(r.z)));
    // Rounding of the receiver's depth and of the stored depth: a few ulps of the largest coordinates involved.
    const T rounding = T(32) * std::numeric_limits<T>::epsilon() *
                       (max_abs(p) + max_abs(view.eye) + std::abs(nf) + std::abs(ff));
    if (b.mode == bias_mode::none) return r;
    if (b.mode == bias_mode::constant || b.mode == bias_mode::normal_offset) {
        r.c0 = b.constant * dz_dd;
        return r;
    }
    // The receiver plane's depth change per texel step: g = −n_lateral·footprint / n_depth, where n_depth is
    // the normal's component along the ray through the receiver (forward for orthographic maps, l/depth for
    // perspective ones). Capped at max_slope·footprint: a grazing (or degenerate) normal is not an infinite bias.
    const glm::vec<3, T> nl(glm::dot(n, frame.right), glm::dot(n, frame.up), glm::dot(n, frame.forward));
    const T n_depth = persp ? glm::dot(nl, l) / l.z : nl.z;
    const glm::vec<2, T> fp = frame.texel_footprint(l.z, width, height);
    const auto slope = [&](T n_lateral, T footprint) {
        const T cap = b.max_slope * footprint;
        const T g = -n_lateral * footprint / n_depth;
        if (std::isnan(g)) return T(0);
        return std::clamp(g, -cap, cap);
    };
    const T gi = slope(nl.x, fp.x), gj = slope(nl.y, fp.y);
    switch (b.mode) {
        case bias_mode::slope_scaled: r.c0 = (b.constant + b.slope_factor * std::sqrt(gi * gi + gj * gj)) * dz_dd + b.units * q; break;
        case bias_mode::receiver_plane:
            r.c0 = (b.constant + rounding) * dz_dd + q;
            r.su = gi * dz_dd, r.sv = gj * dz_dd;
            break;
        case bias_mode::automatic:
            r.c0 = b.scale * (rounding * dz_dd + q);
            r.au = b.scale * std::abs(gi) * dz_dd, r.av = b.scale * std::abs(gj) * dz_dd;
            break;
        default: break;
    }
    return r;
}

}  // namespace detail

}  // namespace v0
}  // namespace aaf
