// SPDX-License-Identifier: MIT
#pragma once
// The light-space map of a translucent scene (FORMULAS.md §5.3): per texel the surface point the light reaches
// first, its normal and the irradiance transmitted into the medium, E·F_t. An orthographic map serves a
// directional light, a cube map (six 90° faces) a point light. The map is read through views, so a renderer
// can fill it from its own rasterised buffers; `build_orthographic_map` / `build_cube_map` render it through
// the user's tracer (tracer.hpp contract).
//
// Sharing with shadow maps: the projections below (orthographic_projection, cube_projection) are plain
// value types holding only the light's frame, with project()/texel_ray() as the whole interface, so the
// shadow-map family's depth maps can adopt (or replace) them without touching the gather.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <string>
#include <type_traits>

#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "../executor.hpp"
#include "../image.hpp"
#include "../image_view.hpp"
#include "../tracer.hpp"
#include "dipole.hpp"

namespace aaf {
inline namespace v0 {
namespace subsurface {

/// Where a point falls in a map: continuous texel coordinates (texel (i, j) covers [i, i+1) × [j, j+1)),
/// depth along the light's rays (distance from the map's origin plane, or from the point light), and face.
template <class T>
struct map_point {
    glm::vec<2, T> texel{0};  ///< continuous texel coordinates
    T depth = 0;              ///< world units along the light's ray
    int face = 0;             ///< cube face 0..5 (+x, −x, +y, −y, +z, −z); 0 for orthographic maps
};

/// An orthographic light frustum: rays travel along `forward` from the rectangle centred at `origin`
/// spanned by ±half_width·right and ±half_height·up. Texel (0, 0) is at −right, +up (image rows go down).
template <class T = float>
struct orthographic_projection {
    using vec3 = glm::vec<3, T>;
    vec3 origin{0};              ///< centre of the map's near rectangle (world units)
    vec3 right{1, 0, 0};         ///< unit vector, map's +x
    vec3 up{0, 0, -1};           ///< unit vector, map's −y (rows go down)
    vec3 forward{0, -1, 0};      ///< unit vector, the direction the light travels (= −ω_l)
    T half_width = 1;            ///< world units, > 0
    T half_height = 1;           ///< world units, > 0
    T far = 10;                  ///< world units along `forward` from `origin` covered by the map, > 0
    std::size_t width = 512;     ///< texels, ≥ 1
    std::size_t height = 512;    ///< texels, ≥ 1

    /// An orthographic map looking along `direction` (the light's travel direction) over a box of centre
    /// `center` and radius `radius` (a bounding sphere of the translucent objects).
    [[nodiscard]] static orthographic_projection looking_along(const vec3& direction, const vec3& center, T radius,
                                                               std::size_t resolution) {
        orthographic_projection p;
        p.forward = glm::normalize(direction);
        const vec3 helper = std::abs(p.forward.y) < T(0.9) ? vec3(0, 1, 0) : vec3(1, 0, 0);
        p.right = glm::normalize(glm::cross(helper, p.forward));
        p.up = glm::cross(p.forward, p.right);
        p.origin = center - radius * T(1.01) * p.forward;
        p.half_width = p.half_height = radius * T(1.01);
        p.far = T(2.02) * radius;
        p.width = p.height = resolution;
        return p;
    }

    [[nodiscard]] T texel_width() const noexcept { return T(2) * half_width / T(width); }
    [[nodiscard]] T texel_height() const noexcept { return T(2) * half_height / T(height); }
    /// The world-space side of a texel at `p` (constant for an orthographic map): max of both sides.
    [[nodiscard]] T footprint(const vec3&) const noexcept { return std::max(texel_width(), texel_height()); }
    /// The area of one texel perpendicular to the rays at `p`.
    [[nodiscard]] T texel_area(const vec3&) const noexcept { return texel_width() * texel_height(); }
    /// Unit direction from `p` towards the light, ω_l.
    [[nodiscard]] vec3 to_light(const vec3&) const noexcept { return -forward; }

    [[nodiscard]] map_point<T> project(const vec3& p) const noexcept {
        const vec3 d = p - origin;
        map_point<T> m;
        m.texel = {(glm::dot(d, right) / half_width + T(1)) * T(0.5) * T(width),
                   (T(1) - glm::dot(d, up) / half_height) * T(0.5) * T(height)};
        m.depth = glm::dot(d, forward);
        return m;
    }
    /// The ray through texel coordinates `t` (continuous): its origin on the near rectangle and direction.
    [[nodiscard]] shadow_segment<T> texel_ray(int, const glm::vec<2, T>& t) const noexcept {
        const T sx = t.x / T(width) * T(2) - T(1), sy = T(1) - t.y / T(height) * T(2);
        return {origin + sx * half_width * right + sy * half_height * up, forward, far};
    }
    /// The point at depth `depth` on the ray through `t`.
    [[nodiscard]] vec3 point_at(int face, const glm::vec<2, T>& t, T depth) const noexcept {
        const shadow_segment<T> r = texel_ray(face, t);
        return r.origin + depth * r.direction;
    }
    [[nodiscard]] static constexpr int faces() noexcept { return 1; }
};

/// A cube map around a point light at `light`: six 90° faces of `resolution`² texels.
template <class T = float>
struct cube_projection {
    using vec3 = glm::vec<3, T>;
    vec3 light{0};                 ///< light position (world units)
    T far = 10;                    ///< maximum distance from the light covered, > 0
    std::size_t resolution = 256;  ///< texels per face side, ≥ 1
    std::size_t width = 256, height = 256;  ///< = resolution (for symmetry with orthographic maps)

    [[nodiscard]] static cube_projection around(const vec3& light, T far, std::size_t resolution) {
        return {light, far, resolution, resolution, resolution};
    }

    // Face axes: (major axis, u axis, v axis) with the face's direction = major + s·u + t·v, s, t ∈ [−1, 1].
    [[nodiscard]] static vec3 face_axis(int face, int which) noexcept {
        static constexpr T a[6][3][3] = {
            {{1, 0, 0}, {0, 0, -1}, {0, -1, 0}}, {{-1, 0, 0}, {0, 0, 1}, {0, -1, 0}}, {{0, 1, 0}, {1, 0, 0}, {0, 0, 1}},
            {{0, -1, 0}, {1, 0, 0}, {0, 0, -1}}, {{0, 0, 1}, {1, 0, 0}, {0, -1, 0}}, {{0, 0, -1}, {-1, 0, 0}, {0, -1, 0}}};
        return {a[face][which][0], a[face][which][1], a[face][which][2]};
    }
    /// The side of a texel at `p`: 2·(distance along the face's major axis)/resolution (at a face's centre;
    /// towards its corners texels shrink in angle but the ray meets the plane obliquely: the max is this).
    [[nodiscard]] T footprint(const vec3& p) const noexcept {
        const vec3 d = p - light;
        const T major = std::max({std::abs(d.x), std::abs(d.y), std::abs(d.z)});
        return T(2) * major / T(resolution);
    }
    /// The area of one texel perpendicular to the ray at `p`: solid angle × distance².
    [[nodiscard]] T texel_area(const vec3& p) const noexcept {
        const vec3 d = p - light;
        const T major = std::max({std::abs(d.x), std::abs(d.y), std::abs(d.z)});
        const T dist = glm::length(d);
        const T side = T(2) / T(resolution);
        // A patch dA on the face plane at distance 1 seen at ℓ = dist/major from the light subtends
        // dΩ = dA·cos α/ℓ² = dA/ℓ³ (cos α = 1/ℓ); perpendicular area at `dist` is dΩ·dist².
        const T c = major / dist;
        return side * side * c * c * c * dist * dist;
    }
    [[nodiscard]] vec3 to_light(const vec3& p) const noexcept { return glm::normalize(light - p); }

    [[nodiscard]] map_point<T> project(const vec3& p) const noexcept {
        const vec3 d = p - light;
        const vec3 a(std::abs(d.x), std::abs(d.y), std::abs(d.z));
        int face = a.x >= a.y && a.x >= a.z ? (d.x >= 0 ? 0 : 1) : a.y >= a.z ? (d.y >= 0 ? 2 : 3) : (d.z >= 0 ? 4 : 5);
        const T major = glm::dot(d, face_axis(face, 0));
        map_point<T> m;
        m.face = face;
        const T s = glm::dot(d, face_axis(face, 1)) / major, t = glm::dot(d, face_axis(face, 2)) / major;
        m.texel = {(s + T(1)) * T(0.5) * T(resolution), (t + T(1)) * T(0.5) * T(resolution)};
        m.depth = glm::length(d);
        return m;
    }
    [[nodiscard]] shadow_segment<T> texel_ray(int face, const glm::vec<2, T>& t) const noexcept {
        const T s = t.x / T(resolution) * T(2) - T(1), v = t.y / T(resolution) * T(2) - T(1);
        const vec3 dir = glm::normalize(face_axis(face, 0) + s * face_axis(face, 1) + v * face_axis(face, 2));
        return {light, dir, far};
    }
    [[nodiscard]] vec3 point_at(int face, const glm::vec<2, T>& t, T depth) const noexcept {
        const shadow_segment<T> r = texel_ray(face, t);
        return r.origin + depth * r.direction;
    }
    [[nodiscard]] static constexpr int faces() noexcept { return 6; }
};

/// How a depth buffer stores depth (FORMULAS.md §3.5). Orthographic depth is linear in all of them.
enum class depth_convention {
    gl_default,    ///< glOrtho + glDepthRange(0, 1): z_tex = (z_ndc + 1)/2, distance = n + z_tex(f − n)
    zero_to_one,   ///< D3D/Vulkan/Metal clip z ∈ [0, 1]: z_tex = z_ndc, distance = n + z_tex(f − n) as well
    reversed_z,    ///< reversed-Z: distance = f − z_tex(f − n)
};

/// World distance along an orthographic light's rays from a stored depth z_tex ∈ [0, 1] with near plane
/// `n` and far plane `f` (FORMULAS.md §3.5: the write-up's bracket −(f−n)/2·(2z_tex − 1 + (f+n)/(f−n))
/// equals −(n + z_tex(f − n)) in GL's default depth range; that is only the z coordinate when the light looks
/// down −Z, so aaf reconstructs the whole point along the light's own `forward` instead).
template <class T>
[[nodiscard]] constexpr T orthographic_depth_distance(T z_tex, T n, T f, depth_convention c) noexcept {
    return c == depth_convention::reversed_z ? f - z_tex * (f - n) : n + z_tex * (f - n);
}

/// One face of a light-space map as views over the caller's (or aaf's) memory. A texel whose position is
/// non-finite is empty (no surface: light passes there). `irradiance` is E·F_t per channel, the irradiance
/// transmitted into the medium, already multiplied by the light's visibility.
template <class T = float>
struct map_face {
    const_image_view<glm::vec<3, T>> positions;   ///< world-space surface points, or empty when `depth` is given
    const_image_view<glm::vec<3, T>> normals;     ///< unit surface normals (outward)
    const_image_view<glm::vec<3, T>> irradiance;  ///< E·F_t, RGB, ≥ 0
    /// Optional instead of `positions` (orthographic maps only): stored depth z_tex ∈ [0, 1] with
    /// `near_plane`, `projection.far` and `convention`; 1 (0 for reversed-Z) or non-finite = empty texel.
    const_image_view<T> depth;
};

/// A light-space map as the gather reads it: a projection plus 1 (orthographic) or 6 (cube) faces.
template <class Projection>
struct light_map_view {
    using T = std::remove_cvref_t<decltype(Projection{}.far)>;
    Projection projection{};
    std::array<map_face<T>, 6> faces{};
    T near_plane = 0;                                    ///< for `depth` faces: distance of depth 0, world units ≥ 0
    depth_convention convention = depth_convention::gl_default;  ///< for `depth` faces
    unsigned depth_bits = 0;  ///< for `depth` faces: bits of the stored depth (16, 24, 32); 0 = floating point
};

/// A texel as read by the gather.
template <class T>
struct map_texel {
    glm::vec<3, T> position{0};
    glm::vec<3, T> normal{0};
    glm::vec<3, T> irradiance{0};
    bool valid = false;
};

/// The texel index of continuous texel coordinate `t` along an axis of `size` texels: ⌊t⌋, or −1 when t is
/// outside [0, size) or NaN (converting a far-away or NaN coordinate to an integer would be undefined).
template <class T>
[[nodiscard]] constexpr std::ptrdiff_t texel_index(T t, std::size_t size) noexcept {
    return t >= T(0) && t < T(size) ? static_cast<std::ptrdiff_t>(t) : std::ptrdiff_t(-1);
}

/// Reads texel (i, j) of face `f`, reconstructing the position from depth when the face stores depth.
template <class Projection>
[[nodiscard]] map_texel<typename light_map_view<Projection>::T> read_texel(const light_map_view<Projection>& m, int f,
                                                                          std::ptrdiff_t i, std::ptrdiff_t j) noexcept {
    using T = typename light_map_view<Projection>::T;
    map_texel<T> t;
    const map_face<T>& face = m.faces[static_cast<std::size_t>(f)];
    const std::size_t w = m.projection.width, h = m.projection.height;
    if (i < 0 || j < 0 || std::size_t(i) >= w || std::size_t(j) >= h) return t;
    const auto x = std::size_t(i), y = std::size_t(j);
    if (!face.positions.empty()) {
        t.position = face.positions(x, y);
    } else {
        const T z = face.depth(x, y);
        const T empty = m.convention == depth_convention::reversed_z ? T(0) : T(1);
        if (!std::isfinite(z) || z == empty) return t;
        const T dist = orthographic_depth_distance(z, m.near_plane, m.projection.far, m.convention);
        t.position = m.projection.point_at(f, {T(i) + T(0.5), T(j) + T(0.5)}, dist);
    }
    t.normal = face.normals(x, y);
    t.irradiance = face.irradiance(x, y);
    t.valid = std::isfinite(t.position.x + t.position.y + t.position.z) && std::isfinite(t.normal.x + t.normal.y + t.normal.z) &&
              std::isfinite(t.irradiance.x + t.irradiance.y + t.irradiance.z);
    return t;
}

/// An owning light-space map (what the builders fill); `view()` is what the gather takes.
template <class Projection>
struct light_map {
    using T = typename light_map_view<Projection>::T;
    Projection projection{};
    std::array<image<glm::vec<3, T>>, 6> positions, normals, irradiance;

    [[nodiscard]] light_map_view<Projection> view() const noexcept {
        light_map_view<Projection> v;
        v.projection = projection;
        for (int f = 0; f < Projection::faces(); ++f)
            v.faces[std::size_t(f)] = {positions[std::size_t(f)].cview(), normals[std::size_t(f)].cview(), irradiance[std::size_t(f)].cview(), {}};
        return v;
    }
};

/// The light of a map: RGB irradiance on a surface facing it (directional light, world units⁻² per unit
/// power), or RGB intensity (point light: irradiance = intensity·cos/d²).
template <class T = float>
struct map_light {
    glm::vec<3, T> power{1};  ///< directional: irradiance perpendicular to the rays; point: radiant intensity. ≥ 0
};

/// A callable giving a surface's unit normal at a hit point: `glm::vec<3,T> operator()(const glm::vec<3,T>&)`.
/// `reconstruct_normals` instead estimates normals from the neighbouring texels' points (central or one-sided
/// differences, whichever side is nearer in depth): exact on planes, first order elsewhere.
struct reconstruct_normals {};

namespace detail {

template <class Projection>
void require_projection(const char* fn, const Projection& p) {
    using T = typename light_map_view<Projection>::T;
    if (p.width == 0 || p.height == 0) aaf::detail::throw_invalid(fn, "`projection` has zero texels (an empty map)");
    if (!(p.far > T(0)) || !std::isfinite(p.far)) aaf::detail::throw_invalid(fn, "`projection.far` must be finite and > 0");
    if constexpr (Projection::faces() == 1) {
        if (!(p.half_width > T(0)) || !(p.half_height > T(0)) || !std::isfinite(p.half_width + p.half_height))
            aaf::detail::throw_invalid(fn, "`projection` half extents must be finite and > 0");
        const auto unit = [](const glm::vec<3, T>& v) { return std::abs(glm::length(v) - T(1)) < T(1e-3); };
        if (!unit(p.forward) || !unit(p.right) || !unit(p.up))
            aaf::detail::throw_invalid(fn, "`projection` axes (forward, right, up) must be unit vectors");
    } else {
        if (p.width != p.height || p.width != p.resolution)
            aaf::detail::throw_invalid(fn, "`projection` of a cube map must have width == height == resolution");
    }
}

}  // namespace detail

/// Renders a light-space map through the user's tracer: one ray per texel centre from the light (the
/// orthographic near rectangle, or the point light), the nearest hit is the surface the light enters.
/// Every hit is visible from the light by construction, so E·F_t = power·cos θ_i·F_t(cos θ_i, η)
/// (·1/d² for a point light); back-facing hits (cos θ_i ≤ 0, e.g. from inconsistent normals) get 0.
/// `normals_of` gives normals at hits (or `reconstruct_normals{}`). Rows run on `exec`; the tracer is called
/// concurrently. Throws aaf::invalid_argument for an empty or invalid projection, negative or non-finite
/// light power, η ≤ 0.
template <class Projection, class Tracer, class NormalFn = reconstruct_normals, class Exec = sequential_executor>
    requires occlusion_tracer<Tracer, typename light_map_view<Projection>::T>
[[nodiscard]] light_map<Projection> build_light_map(const Projection& projection, const map_light<typename light_map_view<Projection>::T>& light,
                                                    typename light_map_view<Projection>::T eta, const Tracer& tracer,
                                                    NormalFn normals_of = {}, Exec&& exec = {}) {
    using T = typename light_map_view<Projection>::T;
    using vec3 = glm::vec<3, T>;
    constexpr const char* fn = "subsurface::build_light_map";
    detail::require_projection(fn, projection);
    if (!subsurface::detail::finite_nonnegative(light.power)) aaf::detail::throw_invalid(fn, "`light.power` must be finite and >= 0");
    if (!(eta > T(0)) || !std::isfinite(eta)) aaf::detail::throw_invalid(fn, "`eta` must be finite and > 0");
    light_map<Projection> map;
    map.projection = projection;
    const std::size_t w = projection.width, h = projection.height;
    const vec3 nan(std::numeric_limits<T>::quiet_NaN());
    for (int f = 0; f < Projection::faces(); ++f) {
        auto& P = map.positions[std::size_t(f)];
        auto& N = map.normals[std::size_t(f)];
        auto& E = map.irradiance[std::size_t(f)];
        P.reset(w, h, nan);
        N.reset(w, h, nan);
        E.reset(w, h, vec3(0));
        exec.parallel_for(h, [&](std::size_t y0, std::size_t y1) {
            for (std::size_t y = y0; y < y1; ++y)
                for (std::size_t x = 0; x < w; ++x) {
                    const shadow_segment<T> ray = projection.texel_ray(f, {T(x) + T(0.5), T(y) + T(0.5)});
                    const occluder_span<T> hit = aaf::detail::trace_one<T>(tracer, ray);
                    if (hit.hit() && std::isfinite(hit.nearest)) P(x, y) = ray.origin + hit.nearest * ray.direction;
                }
        });
        exec.parallel_for(h, [&](std::size_t y0, std::size_t y1) {
            for (std::size_t y = y0; y < y1; ++y)
                for (std::size_t x = 0; x < w; ++x) {
                    const vec3 p = P(x, y);
                    if (!std::isfinite(p.x + p.y + p.z)) continue;
                    const vec3 to_light = projection.to_light(p);
                    vec3 n;
                    if constexpr (std::is_same_v<NormalFn, reconstruct_normals>) {
                        // Differences towards the neighbour nearer in depth on each axis: no normal averages
                        // across a depth discontinuity.
                        const auto pick = [&](std::ptrdiff_t dx, std::ptrdiff_t dy) -> vec3 {
                            const std::ptrdiff_t xa = std::ptrdiff_t(x) - dx, ya = std::ptrdiff_t(y) - dy;
                            const std::ptrdiff_t xb = std::ptrdiff_t(x) + dx, yb = std::ptrdiff_t(y) + dy;
                            const auto ok = [&](std::ptrdiff_t i, std::ptrdiff_t j) {
                                if (i < 0 || j < 0 || std::size_t(i) >= w || std::size_t(j) >= h) return false;
                                const vec3 q = P(std::size_t(i), std::size_t(j));
                                return std::isfinite(q.x + q.y + q.z);
                            };
                            const bool a = ok(xa, ya), b = ok(xb, yb);
                            if (!a && !b) return vec3(0);
                            const vec3 pa = a ? P(std::size_t(xa), std::size_t(ya)) : p, pb = b ? P(std::size_t(xb), std::size_t(yb)) : p;
                            if (a && b) {
                                const T da = glm::length(pa - p), db = glm::length(pb - p);
                                return da < db ? p - pa : pb - p;
                            }
                            return pb - pa;
                        };
                        n = glm::cross(pick(1, 0), pick(0, 1));
                        const T len = glm::length(n);
                        n = len > T(0) ? n / len : to_light;
                        if (glm::dot(n, to_light) < T(0)) n = -n;
                    } else {
                        n = glm::normalize(vec3(normals_of(p)));
                    }
                    N(x, y) = n;
                    const T c = glm::dot(n, to_light);
                    // c > 1 or non-finite: a hit at (or a denormal distance from) a point light, where ω_l is undefined.
                    if (!(c > T(0)) || !(c <= T(1) + T(1e-3))) continue;
                    T scale = c * fresnel_transmittance_in(c, eta);
                    if constexpr (Projection::faces() == 6) {
                        const vec3 d = p - projection.light;
                        scale /= glm::dot(d, d);
                    }
                    // An overflowing E (a hit nearly touching a point light) is dropped rather than stored as ∞, which
                    // would be NaN for a channel of zero power (fuzz finding).
                    const vec3 e = light.power * scale;
                    if (std::isfinite(e.x + e.y + e.z)) E(x, y) = e;
                }
        });
    }
    return map;
}

}  // namespace subsurface
}  // namespace v0
}  // namespace aaf
