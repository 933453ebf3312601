// SPDX-License-Identifier: MIT
#pragma once
// The G-buffer edge stops of the image-space denoisers renderer authors compare aaf with (the guided
// à-trous filter of SVGF, a joint bilateral filter): object ID, normal and plane distance, evaluated
// against a centre pixel read once. Shared by variants/atrous.hpp and variants/bilateral.hpp.

#include <cmath>
#include <cstdint>
#include <string>
#include <type_traits>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "../config.hpp"
#include "../guides.hpp"
#include "../image_view.hpp"

namespace aaf {
inline namespace v0 {

/// How strongly the G-buffer stops a filter at edges. Each stop is used only when its guides are given.
template <class T = float>
struct edge_stop_settings {
    /// Normal stop w_n = max(0, n·n′)^normal_power (SVGF's form, Schied et al. 2017, σ_n = 128); [0, 1e4];
    /// 0 = off (any finite normal accepted). Needs `guides.normals`.
    T normal_power = 128;
    /// Plane-distance stop w_p = exp(−|n_c·(p′ − p_c)| / (plane_sigma · d_c · r)), the distance of the
    /// neighbour from the centre's tangent plane in units of the centre's pixel footprint d_c (world units)
    /// times the tap's pixel distance r (so a neighbour on the same plane costs nothing at any distance,
    /// like SVGF's depth stop with its screen-space depth gradient); (0, ∞], +∞ = off. Needs
    /// `guides.normals` and `guides.positions`.
    T plane_sigma = 1;
};

/// Throws aaf::invalid_argument naming the first invalid field.
template <class T>
void validate(const edge_stop_settings<T>& s, const char* function, const char* prefix) {
    const std::string p(prefix);
    if (!(s.normal_power >= T(0) && s.normal_power <= T(1e4)))
        detail::throw_invalid(function, "`" + p + ".normal_power` must be in [0, 1e4] (got " + std::to_string(s.normal_power) + ")");
    if (!(s.plane_sigma > T(0)))  // +∞ allowed (off), NaN rejected
        detail::throw_invalid(function, "`" + p + ".plane_sigma` must be > 0 (+inf = off) (got " + std::to_string(s.plane_sigma) + ")");
}

namespace detail {

/// The centre pixel's guides and pixel footprint, read once; `weight` gives a neighbour's edge-stop weight
/// in [0, 1] (0 = rejected). A NaN or infinite guide on either side rejects: sky pixels and pixels without
/// a surface never mix with surfaces.
template <class T, class G>
struct edge_stop_center {
    static_assert(!G::has_positions || G::has_normals,
                  "aaf variants: the plane-distance stop needs `guides.normals` as well as `guides.positions` (the "
                  "plane is the centre's tangent plane); pass normals or drop positions");
    [[no_unique_address]] std::conditional_t<G::has_normals, glm::vec<3, T>, no_guide> normal{};
    [[no_unique_address]] std::conditional_t<G::has_ids, std::uint32_t, no_guide> id{};
    [[no_unique_address]] std::conditional_t<G::has_positions, glm::vec<3, T>, no_guide> position{};
    T inv_plane_scale = T(0);  ///< 1 / (plane_sigma · d_c); 0 when the stop is off
    bool valid = true;         ///< the centre's own guides are finite (else every neighbour is rejected)

    edge_stop_center(const G& g, const_image_view<T> pixel_size, const edge_stop_settings<T>& s, std::size_t x,
                     std::size_t y) noexcept {
        if constexpr (G::has_ids) id = g.ids(x, y);
        if constexpr (G::has_normals) {
            normal = g.normals(x, y);
            valid = valid && std::isfinite(normal.x + normal.y + normal.z);
        }
        if constexpr (G::has_positions) {
            position = g.positions(x, y);
            valid = valid && std::isfinite(position.x + position.y + position.z);
            const T d = pixel_size.empty() ? T(0) : pixel_size(x, y);
            // A centre without a finite positive footprint has no scale for the stop: it is switched off.
            if (std::isfinite(s.plane_sigma) && d > T(0) && std::isfinite(d)) inv_plane_scale = T(1) / (s.plane_sigma * d);
        }
    }

    /// Weight of neighbour (nx, ny) at pixel distance `r` (> 0) from the centre.
    [[nodiscard]] T weight(const G& g, const edge_stop_settings<T>& s, std::size_t nx, std::size_t ny, T r) const noexcept {
        if constexpr (G::has_ids)
            if (g.ids(nx, ny) != id) return T(0);
        T w = T(1);
        if constexpr (G::has_normals) {
            const T c = glm::dot(normal, g.normals(nx, ny));
            if (!std::isfinite(c)) return T(0);
            if (s.normal_power > T(0)) w = c > T(0) ? std::pow(std::min(c, T(1)), s.normal_power) : T(0);
        }
        if constexpr (G::has_positions) {
            const glm::vec<3, T> q = g.positions(nx, ny);
            const T dist = std::abs(glm::dot(normal, q - position));
            if (!std::isfinite(dist)) return T(0);
            if (inv_plane_scale > T(0)) w *= std::exp(-dist * inv_plane_scale / r);
        }
        return w;
    }
};

}  // namespace detail

}  // namespace v0
}  // namespace aaf
