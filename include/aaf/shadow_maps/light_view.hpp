// SPDX-License-Identifier: MIT
#pragma once
// A light's view for a depth map: where it looks from, its projection (orthographic for a directional light
// or the area light's plane, perspective for a spot view from a point on the light), its near/far planes and
// extents, and the depth encoding each projection uses (FORMULAS.md §3.5), with its exact inverse.
//
// Conventions. The view has an orthonormal basis (right, up, forward) built from `forward` and the `up` hint.
// A point's light-space coordinates are x = dot(p − eye, right), y = dot(p − eye, up) and its *depth*
// z = dot(p − eye, forward): the distance in front of the light along `forward` (positive), which is the
// eye-space −z of OpenGL. Normalised device coordinates are ndc = (x, y) / half-extent (orthographic) or
// (x, y) / (z · tan-half-extent) (perspective), in [−1, 1] inside the frustum. Texel (i, j) of a W×H map
// covers ndc x ∈ [−1 + 2i/W, −1 + 2(i+1)/W] and ndc y ∈ [−1 + 2j/H, −1 + 2(j+1)/H]: row 0 is at ndc y = −1
// (OpenGL's bottom row), so a GL depth buffer read with glReadPixels is laid out as aaf expects.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <string>

#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "../config.hpp"
#include "../tracer.hpp"

namespace aaf {
inline namespace v0 {

/// How a depth map projects the scene.
enum class depth_projection {
    orthographic,  ///< parallel rays along `forward`: a directional light, or an area light's plane
    perspective,   ///< rays from `eye`: a spot view from a point on the light
};

/// [[nodiscard]] name of a projection ("orthographic", "perspective"), for logs and result files.
[[nodiscard]] constexpr const char* to_string(depth_projection p) noexcept {
    return p == depth_projection::orthographic ? "orthographic" : "perspective";
}

/// The view a depth map is rendered from. See the conventions at the top of this header.
template <class T = float>
struct light_view {
    glm::vec<3, T> eye{0};             ///< the view's origin (world units); perspective: the light point
    glm::vec<3, T> forward{0, -1, 0};  ///< viewing direction (any length > 0; normalised internally)
    glm::vec<3, T> up{0, 0, 1};        ///< a hint for the map's vertical axis, not parallel to `forward`
    depth_projection projection = depth_projection::orthographic;
    T near_plane = 0;   ///< depth of the near plane (world units); perspective: > 0; orthographic: any < far
    T far_plane = 1;    ///< depth of the far plane (world units), > near_plane
    T half_width = 1;   ///< orthographic: half the frustum's width (world units); perspective: tan of half the horizontal field of view; > 0
    T half_height = 1;  ///< orthographic: half the frustum's height (world units); perspective: tan of half the vertical field of view; > 0
};

/// z_tex ∈ [0, 1] of a point at depth `depth` in front of the light (FORMULAS.md §3.5, OpenGL's projection
/// matrices with glDepthRange(0, 1)): orthographic z_tex = (depth − n)/(f − n); perspective
/// z_tex = f·(depth − n)/((f − n)·depth), which is (z_ndc + 1)/2 of glFrustum's z row. Not clamped.
template <class T>
[[nodiscard]] constexpr T z_tex_from_depth(depth_projection p, T depth, T near_plane, T far_plane) noexcept {
    if (p == depth_projection::orthographic) return (depth - near_plane) / (far_plane - near_plane);
    return far_plane * (depth - near_plane) / ((far_plane - near_plane) * depth);
}

/// The exact inverse of z_tex_from_depth: the depth in front of the light of a stored z_tex. Orthographic
/// n + z_tex·(f − n) (the seed's formula, see seed_orthographic_world_z); perspective
/// f·n / (f − z_tex·(f − n)) (the same inversion of glFrustum's z row), evaluated as
/// f·n / (z_tex·n + (1 − z_tex)·f): a sum of two positive terms, so z_tex = 1 gives exactly f even when
/// f/n is 10⁹ (the textbook form cancels there). z_tex = 0 gives n.
template <class T>
[[nodiscard]] constexpr T depth_from_z_tex(depth_projection p, T z_tex, T near_plane, T far_plane) noexcept {
    if (p == depth_projection::orthographic) return near_plane + z_tex * (far_plane - near_plane);
    return far_plane * near_plane / (z_tex * near_plane + (T(1) - z_tex) * far_plane);
}

/// d depth / d z_tex at `depth`: how many world units one unit of z_tex spans there. Orthographic f − n;
/// perspective depth²·(f − n)/(f·n) (precision is lost quadratically with distance).
template <class T>
[[nodiscard]] constexpr T depth_per_z_tex(depth_projection p, T depth, T near_plane, T far_plane) noexcept {
    if (p == depth_projection::orthographic) return far_plane - near_plane;
    return depth * depth * (far_plane - near_plane) / (far_plane * near_plane);
}

/// The formula of the translucency write-up (FORMULAS.md §3.5), kept verbatim: the world z of a texel of an
/// orthographic map whose light at world height `z_camera` looks down the world −Z axis:
/// z_world = z_camera − (f − n)/2 · (2 z_tex − 1 + (f + n)/(f − n)). It equals z_camera − depth_from_z_tex
/// (the tests check it); for any other orientation use light_frame::world_point.
template <class T>
[[nodiscard]] constexpr T seed_orthographic_world_z(T z_camera, T z_tex, T near_plane, T far_plane) noexcept {
    return z_camera - (far_plane - near_plane) / T(2) * (T(2) * z_tex - T(1) + (far_plane + near_plane) / (far_plane - near_plane));
}

namespace detail {

template <class T>
[[nodiscard]] bool finite3(const glm::vec<3, T>& v) noexcept {
    return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

/// Throws aaf::invalid_argument naming `name`.field unless the view is usable.
template <class T>
void require_light_view(const char* fn, const char* name, const light_view<T>& v) {
    const std::string n = name;
    if (!finite3(v.eye) || !finite3(v.forward) || !finite3(v.up)) throw_invalid(fn, "`" + n + "` has a non-finite eye, forward or up");
    if (!(glm::length(v.forward) > T(0))) throw_invalid(fn, "`" + n + ".forward` is zero");
    const glm::vec<3, T> f = glm::normalize(v.forward);
    const glm::vec<3, T> r = glm::cross(f, v.up);
    if (!(glm::length(r) > std::numeric_limits<T>::epsilon() * glm::length(v.up)))
        throw_invalid(fn, "`" + n + ".up` is zero or parallel to `" + n + ".forward`");
    if (!std::isfinite(v.near_plane) || !std::isfinite(v.far_plane))
        throw_invalid(fn, "`" + n + "` has a non-finite near_plane or far_plane");
    if (!(v.near_plane < v.far_plane)) throw_invalid(fn, "`" + n + ".near_plane` is not less than `" + n + ".far_plane`");
    if (v.projection == depth_projection::perspective && !(v.near_plane > T(0)))
        throw_invalid(fn, "`" + n + ".near_plane` must be > 0 for a perspective view");
    if (!(v.half_width > T(0)) || !(v.half_height > T(0)) || !std::isfinite(v.half_width) || !std::isfinite(v.half_height))
        throw_invalid(fn, "`" + n + ".half_width` and `" + n + ".half_height` must be finite and > 0");
    // A frustum so thin that the planes are the same float is as degenerate as near == far.
    if (!(z_tex_from_depth(v.projection, v.far_plane, v.near_plane, v.far_plane) > T(0)))
        throw_invalid(fn, "`" + n + "` has near and far planes too close to tell apart");
}

}  // namespace detail

/// A light_view with its basis computed once: what the map renderer and the lookups use per point.
/// Construct only from a validated view (the entry points validate; so does make_light_frame).
template <class T = float>
struct light_frame {
    light_view<T> view;
    glm::vec<3, T> right{1, 0, 0}, up{0, 1, 0}, forward{0, 0, 1};

    light_frame() = default;
    explicit light_frame(const light_view<T>& v) noexcept : view(v) {
        forward = glm::normalize(v.forward);
        right = glm::normalize(glm::cross(forward, v.up));
        up = glm::cross(right, forward);
    }

    [[nodiscard]] bool perspective() const noexcept { return view.projection == depth_projection::perspective; }

    /// Light-space (x, y, depth) of world point p.
    [[nodiscard]] glm::vec<3, T> to_light(const glm::vec<3, T>& p) const noexcept {
        const glm::vec<3, T> d = p - view.eye;
        return {glm::dot(d, right), glm::dot(d, up), glm::dot(d, forward)};
    }

    /// World lateral size of one texel of a `width`×`height` map at `depth` (x: along right, y: along up).
    [[nodiscard]] glm::vec<2, T> texel_footprint(T depth, std::size_t width, std::size_t height) const noexcept {
        const T s = perspective() ? depth : T(1);
        return {T(2) * view.half_width * s / static_cast<T>(width), T(2) * view.half_height * s / static_cast<T>(height)};
    }

    /// Continuous texel coordinates (texel i spans [i, i+1)) of light-space point `l` in a width×height map.
    [[nodiscard]] glm::vec<2, T> texel_coords(const glm::vec<3, T>& l, std::size_t width, std::size_t height) const noexcept {
        const T s = perspective() ? l.z : T(1);
        const T nx = l.x / (s * view.half_width), ny = l.y / (s * view.half_height);
        return {(nx + T(1)) * T(0.5) * static_cast<T>(width), (ny + T(1)) * T(0.5) * static_cast<T>(height)};
    }

    /// The world point at continuous texel coordinates (u, v) and depth `depth`: the inverse of texel_coords
    /// and to_light (reconstruction of a texel's surface point, FORMULAS.md §3.5 caveat 1).
    [[nodiscard]] glm::vec<3, T> world_point(T u, T v, T depth, std::size_t width, std::size_t height) const noexcept {
        const T s = perspective() ? depth : T(1);
        const T x = (T(2) * u / static_cast<T>(width) - T(1)) * view.half_width * s;
        const T y = (T(2) * v / static_cast<T>(height) - T(1)) * view.half_height * s;
        return view.eye + x * right + y * up + depth * forward;
    }

    /// The ray through the centre of texel (i, j) from the near to the far plane, as a tracer segment, and
    /// `depth_per_t`: a hit at distance t along it has depth near_plane + t·depth_per_t.
    [[nodiscard]] shadow_segment<T> texel_ray(std::size_t i, std::size_t j, std::size_t width, std::size_t height,
                                              T& depth_per_t) const noexcept {
        const T u = static_cast<T>(i) + T(0.5), v = static_cast<T>(j) + T(0.5);
        if (!perspective()) {
            depth_per_t = T(1);
            return {world_point(u, v, view.near_plane, width, height), forward, view.far_plane - view.near_plane};
        }
        // The direction through the texel at depth 1, built from the frame's axes alone. Not as
        // world_point(u, v, 1) − eye: far from the origin (a scene at scale 1e5) the eye's coordinates are so
        // large that adding a texel's lateral offset at depth 1 to them rounds it away, and neighbouring
        // texels got the same ray (found by tests/examples/test_shadow_maps_bias_scenes.cpp).
        const T x = (T(2) * u / static_cast<T>(width) - T(1)) * view.half_width;
        const T y = (T(2) * v / static_cast<T>(height) - T(1)) * view.half_height;
        const glm::vec<3, T> through = x * right + y * up + forward;  // depth 1 along forward
        const T len1 = glm::length(through);
        depth_per_t = T(1) / len1;  // cosine of the ray's angle to forward
        const glm::vec<3, T> dir = through * depth_per_t;
        return {view.eye + dir * (view.near_plane * len1), dir, (view.far_plane - view.near_plane) * len1};
    }
};

/// Validates `v` (aaf::invalid_argument naming `view`) and returns its frame.
template <class T>
[[nodiscard]] light_frame<T> make_light_frame(const light_view<T>& v) {
    detail::require_light_view("make_light_frame", "view", v);
    return light_frame<T>(v);
}

/// An orthographic view along `direction` that contains every point of `points` (e.g. the scene's bounding
/// box corners): its near and far planes and extents are fitted to them with a margin of `margin` (relative,
/// default 1 %), and `eye` is the points' centre moved back to the near plane. `Points` is any range of
/// glm::vec<3, T>. Throws aaf::invalid_argument when `direction` is zero or non-finite, or `points` holds
/// no finite point. A set of points with no extent gets a frustum of unit size around them.
template <class T, class Points>
[[nodiscard]] light_view<T> fit_orthographic_view(const glm::vec<3, T>& direction, const Points& points, T margin = T(0.01)) {
    if (!detail::finite3(direction) || !(glm::length(direction) > T(0)))
        detail::throw_invalid("fit_orthographic_view", "`direction` is zero or non-finite");
    light_view<T> v;
    v.forward = glm::normalize(direction);
    v.up = std::abs(v.forward.y) < T(0.9) ? glm::vec<3, T>(0, 1, 0) : glm::vec<3, T>(1, 0, 0);
    v.eye = glm::vec<3, T>(0);
    const light_frame<T> frame(v);
    glm::vec<3, T> lo(std::numeric_limits<T>::infinity()), hi(-std::numeric_limits<T>::infinity());
    bool any = false;
    for (const auto& p : points) {
        if (!detail::finite3(glm::vec<3, T>(p))) continue;
        const glm::vec<3, T> l = frame.to_light(glm::vec<3, T>(p));
        lo = glm::min(lo, l), hi = glm::max(hi, l), any = true;
    }
    if (!any) detail::throw_invalid("fit_orthographic_view", "`points` has no finite point");
    const glm::vec<3, T> centre = (lo + hi) * T(0.5);
    glm::vec<3, T> half = (hi - lo) * (T(0.5) * (T(1) + margin));
    const T size = std::max({half.x, half.y, half.z});
    const T floor = size > T(0) ? size * T(1e-3) : T(0.5);  // a flat set still gets a frustum with volume
    half = glm::max(half, glm::vec<3, T>(floor));
    v.eye = centre.x * frame.right + centre.y * frame.up + (centre.z - half.z) * frame.forward;
    v.near_plane = 0;
    v.far_plane = T(2) * half.z;
    v.half_width = half.x;
    v.half_height = half.y;
    return v;
}

}  // namespace v0
}  // namespace aaf
