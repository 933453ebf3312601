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
#include <bit>
#include <cmath>
#include <cstddef>
#include <limits>
#include <string>
#include <type_traits>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "../config.hpp"
#include "../simd.hpp"
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

/// One receiver in the shape of simd<T> (a "vector" of one lane, the mask a bool): prepare_lanes's
/// arithmetic instantiated for compilers without vector extensions.
template <class T>
struct one_lane {
    static constexpr std::size_t lanes = 1;
    using vec = T;
    using mask = bool;
    [[nodiscard]] static T splat(T x) noexcept { return x; }
    [[nodiscard]] static T select(bool m, T a, T b) noexcept { return m ? a : b; }
};

/// The lanes aaf prepares receivers in: simd<T>'s where the compiler has vector extensions, else one.
#if AAF_SIMD_BYTES > 0
template <class T>
using receiver_lanes = simd<T>;
#else
template <class T>
using receiver_lanes = one_lane<T>;
#endif

/// S::lanes receivers prepared at once, one lane per receiver: prepared_receiver's fields, a vector each.
template <class T, class S = receiver_lanes<T>>
struct prepared_receivers {
    typename S::vec u{}, v{}, z{}, depth{}, c0{}, su{}, sv{}, au{}, av{};
    typename S::mask inside{};  ///< set in the lanes inside the map's frustum

    /// Lane `l` as a prepared_receiver.
    [[nodiscard]] prepared_receiver<T> lane(std::size_t l) const noexcept {
        const auto at = [=](const auto& x) {
            if constexpr (S::lanes == 1) return x;
            else return x[l];
        };
        prepared_receiver<T> r;
        r.u = at(u), r.v = at(v), r.z = at(z), r.depth = at(depth);
        r.c0 = at(c0), r.su = at(su), r.sv = at(sv), r.au = at(au), r.av = at(av);
        r.inside = static_cast<bool>(at(inside));
        return r;
    }
};

/// |x| per lane (std::abs: clears the sign bit, also of −0).
template <class T, class V>
[[nodiscard]] V abs_lanes(V x) noexcept {
#if AAF_SIMD_BYTES > 0
    if constexpr (!std::is_same_v<V, T>) {
        using I = typename simd<T>::mask;
        using B = typename simd<T>::mask_int;
        constexpr auto magnitude = static_cast<B>(~(std::make_unsigned_t<B>(1) << (8 * sizeof(T) - 1)));
        return std::bit_cast<V>(std::bit_cast<I>(x) & magnitude);
    } else
#endif
    {
        return std::abs(x);
    }
}

/// Prepares S::lanes receivers at once (S: simd<T>, or one_lane<T> for one receiver): lane l is point
/// (px, py, pz)[l] with unit normal (nx, ny, nz)[l] (either orientation), for tests against a width×height
/// map of `format` seen through `frame`, under bias `b`. Lanes with non-finite input come out as anything:
/// callers mask them.
///
/// The one implementation of the setup: prepare_receiver is its one-lane instance, and the lookup pass runs
/// it on a vector's lanes of pixels at once (the setup of one receiver at a time was a sixth of the pass's
/// time). The same operations in the same order in every instance; whether a compiler contracts a·b + c
/// into an fma can still differ between instances (and between inlined copies), so bit-equal results
/// are only promised between callers of the same instance through one non-inlined function
/// (shadow_map_sampler::visibility_lanes).
template <class T, class S = receiver_lanes<T>>
[[nodiscard]] prepared_receivers<T, S> prepare_lanes(const light_frame<T>& frame, std::size_t width, std::size_t height, depth_format format,
                                                     const bias_settings<T>& b, typename S::vec px, typename S::vec py, typename S::vec pz,
                                                     typename S::vec nx, typename S::vec ny, typename S::vec nz) noexcept {
    using V = typename S::vec;
    using M = typename S::mask;
    const auto splat = [](T x) { return S::splat(x); };
    const auto vmax = [](V x, V y) { return S::select(x < y, y, x); };  // std::max's (x < y ? y : x)
    const auto dot3 = [](V ax, V ay, V az, V bx, V by, V bz) { return ax * bx + ay * by + az * bz; };
    const auto both = [](M x, M y) -> M {  // per-lane "and" (&& for one lane's bool)
        if constexpr (S::lanes == 1) return x && y;
        else return x & y;
    };
    prepared_receivers<T, S> r;
    const light_view<T>& view = frame.view;
    const bool persp = frame.perspective();
    const T W = static_cast<T>(width), H = static_cast<T>(height), nf = view.near_plane, ff = view.far_plane;
    // Light-space coordinates (light_frame::to_light).
    V lx, ly, lz;
    const auto to_light = [&] {
        const V dx = px - view.eye.x, dy = py - view.eye.y, dz = pz - view.eye.z;
        lx = dot3(dx, dy, dz, splat(frame.right.x), splat(frame.right.y), splat(frame.right.z));
        ly = dot3(dx, dy, dz, splat(frame.up.x), splat(frame.up.y), splat(frame.up.z));
        lz = dot3(dx, dy, dz, splat(frame.forward.x), splat(frame.forward.y), splat(frame.forward.z));
    };
    // World size of a texel at depth d (light_frame::texel_footprint).
    const auto footprint = [&](V d, V& fx, V& fy) {
        const V s = persp ? d : splat(T(1));
        fx = T(2) * view.half_width * s / W, fy = T(2) * view.half_height * s / H;
    };
    to_light();
    if (b.mode == bias_mode::normal_offset) {  // the receiver moves along its normal, turned towards the light
        const V tx = persp ? view.eye.x - px : splat(-frame.forward.x), ty = persp ? view.eye.y - py : splat(-frame.forward.y),
                tz = persp ? view.eye.z - pz : splat(-frame.forward.z);
        const M away = dot3(nx, ny, nz, tx, ty, tz) < splat(T(0));
        nx = S::select(away, -nx, nx), ny = S::select(away, -ny, ny), nz = S::select(away, -nz, nz);
        V fx, fy;
        footprint(S::select(lz < splat(nf), splat(nf), lz), fx, fy);  // std::max(l.z, near)
        const V k = b.normal_offset * vmax(fx, fy);
        px = px + nx * k, py = py + ny * k, pz = pz + nz * k;
        to_light();
    }
    r.depth = lz;
    // Texel coordinates (light_frame::texel_coords); inside the frustum, and in front of a perspective light.
    const V s = persp ? lz : splat(T(1));
    const V ndx = lx / (s * view.half_width), ndy = ly / (s * view.half_height);
    r.u = (ndx + T(1)) * T(0.5) * W, r.v = (ndy + T(1)) * T(0.5) * H;
    M inside = both(both(both(r.u >= splat(0), r.u <= splat(W)), both(r.v >= splat(0), r.v <= splat(H))), both(lz >= splat(nf), lz <= splat(ff)));
    if (persp) inside = both(inside, lz > splat(0));
    r.inside = inside;
    // z_tex, its derivative by depth, and the format's quantisation step there.
    V dz_dd;
    if (persp) {
        r.z = ff * (lz - nf) / ((ff - nf) * lz);
        dz_dd = T(1) / (lz * lz * (ff - nf) / (ff * nf));
    } else {
        r.z = (lz - nf) / (ff - nf);
        dz_dd = splat(T(1) / (ff - nf));
    }
    if (b.mode == bias_mode::none) return r;
    V q;
    if constexpr (S::lanes == 1) {
        q = static_cast<T>(z_tex_step(format, static_cast<double>(r.z)));
    } else if constexpr (std::is_same_v<T, float>) {
        if (format != depth_format::float32) {
            q = splat(static_cast<T>(z_tex_step(format, 0.0)));
        } else {  // z_tex_step's nextafter(max(|z|, FLT_MIN), 2.0f) − that: the next float up below 2, down above
            const V a = abs_lanes<T>(r.z);
            const V m = S::select(a < splat(std::numeric_limits<T>::min()), splat(std::numeric_limits<T>::min()), a);
            q = std::bit_cast<V>(std::bit_cast<M>(m) - (m < splat(T(2))) + (m > splat(T(2)))) - m;  // true is −1
        }
    } else {
        for (std::size_t l = 0; l < S::lanes; ++l) q[l] = static_cast<T>(z_tex_step(format, static_cast<double>(r.z[l])));
    }
    // Rounding of the receiver's depth and of the stored depth: a few ulps of the largest coordinates involved.
    const V rounding = T(32) * std::numeric_limits<T>::epsilon() *
                       (vmax(vmax(abs_lanes<T>(px), abs_lanes<T>(py)), abs_lanes<T>(pz)) + max_abs(view.eye) + std::abs(nf) + std::abs(ff));
    if (b.mode == bias_mode::constant || b.mode == bias_mode::normal_offset) {
        r.c0 = b.constant * dz_dd;
        return r;
    }
    // The receiver plane's depth change per texel step: g = −n_lateral·footprint / n_depth, where n_depth is
    // the normal's component along the ray through the receiver (forward for orthographic maps, l/depth for
    // perspective ones). Capped at max_slope·footprint: a grazing (or degenerate) normal is not an infinite bias.
    const V nlx = dot3(nx, ny, nz, splat(frame.right.x), splat(frame.right.y), splat(frame.right.z));
    const V nly = dot3(nx, ny, nz, splat(frame.up.x), splat(frame.up.y), splat(frame.up.z));
    const V nlz = dot3(nx, ny, nz, splat(frame.forward.x), splat(frame.forward.y), splat(frame.forward.z));
    const V n_depth = persp ? dot3(nlx, nly, nlz, lx, ly, lz) / lz : nlz;
    V fx, fy;
    footprint(lz, fx, fy);
    const auto slope = [&](V n_lateral, V fp) {
        const V cap = b.max_slope * fp;
        V g = -n_lateral * fp / n_depth;
        g = S::select(g != g, splat(T(0)), g);                          // NaN: no slope
        return S::select(g < -cap, -cap, S::select(cap < g, cap, g));  // std::clamp(g, −cap, cap)
    };
    const V gi = slope(nlx, fx), gj = slope(nly, fy);
    switch (b.mode) {
        case bias_mode::slope_scaled: {
            V len = gi * gi + gj * gj;
            if constexpr (S::lanes == 1) len = std::sqrt(len);
            else for (std::size_t l = 0; l < S::lanes; ++l) len[l] = std::sqrt(len[l]);
            r.c0 = (b.constant + b.slope_factor * len) * dz_dd + b.units * q;
            break;
        }
        case bias_mode::receiver_plane:
            r.c0 = (b.constant + rounding) * dz_dd + q;
            r.su = gi * dz_dd, r.sv = gj * dz_dd;
            break;
        case bias_mode::automatic:
            r.c0 = b.scale * (rounding * dz_dd + q);
            r.au = b.scale * abs_lanes<T>(gi) * dz_dd, r.av = b.scale * abs_lanes<T>(gj) * dz_dd;
            break;
        default: break;
    }
    return r;
}

/// Prepares receiver point `p` with unit normal `n` (either orientation) for tests against a width×height
/// map of `format` seen through `frame`, under bias `b`: prepare_lanes for one receiver.
template <class T>
[[nodiscard]] prepared_receiver<T> prepare_receiver(const light_frame<T>& frame, std::size_t width, std::size_t height,
                                                    depth_format format, const bias_settings<T>& b, glm::vec<3, T> p,
                                                    glm::vec<3, T> n) noexcept {
    return prepare_lanes<T, one_lane<T>>(frame, width, height, format, b, p.x, p.y, p.z, n.x, n.y, n.z).lane(0);
}

}  // namespace detail

}  // namespace v0
}  // namespace aaf
