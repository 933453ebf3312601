// SPDX-License-Identifier: MIT
#pragma once
// Optional filter guides (normals, object IDs, world positions) as types: a guide a scene lacks is
// `no_guide`, and the test it would drive is not even compiled.

#include <cmath>
#include <cstdint>
#include <type_traits>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "image_view.hpp"

namespace aaf {
inline namespace v0 {

/// Stands for a guide buffer the scene does not have. Costs nothing.
struct no_guide {};

/// The guides a filter may use. Each member is either `no_guide` or a read-only view:
/// * `normals`:   `const_image_view<glm::vec<3,T>>`, unit normals; a neighbour whose normal is more than
///                `filter_settings::normal_threshold_degrees` away from the centre's is rejected;
/// * `ids`:       `const_image_view<std::uint32_t>`, object IDs; neighbours with another ID are rejected;
/// * `positions`: `const_image_view<glm::vec<3,T>>`, world positions; needed for light-plane offsets.
/// Non-finite normals or positions reject the neighbour (they never reach the output).
///
///     aaf::guides g{normals_view, aaf::no_guide{}, positions_view};   // CTAD picks the types
template <class Normals = no_guide, class Ids = no_guide, class Positions = no_guide>
struct guides {
    Normals normals{};
    Ids ids{};
    Positions positions{};

    static constexpr bool has_normals = !std::is_same_v<Normals, no_guide>;
    static constexpr bool has_ids = !std::is_same_v<Ids, no_guide>;
    static constexpr bool has_positions = !std::is_same_v<Positions, no_guide>;
};

template <class N, class I, class P>
guides(N, I, P) -> guides<N, I, P>;
template <class N, class I>
guides(N, I) -> guides<N, I, no_guide>;
template <class N>
guides(N) -> guides<N, no_guide, no_guide>;

namespace detail {

template <class G>
struct is_guides : std::false_type {};
template <class N, class I, class P>
struct is_guides<guides<N, I, P>> : std::true_type {};

/// Checks every present guide's size against the frame.
template <class G>
void require_guides(const char* function, const G& g, std::size_t w, std::size_t h) {
    if constexpr (G::has_normals) require_size(function, "guides.normals", g.normals, w, h);
    if constexpr (G::has_ids) require_size(function, "guides.ids", g.ids, w, h);
    if constexpr (G::has_positions) require_size(function, "guides.positions", g.positions, w, h);
}

/// The centre pixel's guide values, read once per pixel; `accepts` tests a neighbour against them.
template <class T, class G>
struct guide_center {
    [[no_unique_address]] std::conditional_t<G::has_normals, glm::vec<3, T>, no_guide> normal{};
    [[no_unique_address]] std::conditional_t<G::has_ids, std::uint32_t, no_guide> id{};

    guide_center(const G& g, std::size_t x, std::size_t y) noexcept {
        if constexpr (G::has_normals) normal = g.normals(x, y);
        if constexpr (G::has_ids) id = g.ids(x, y);
    }

    [[nodiscard]] bool accepts(const G& g, std::size_t x, std::size_t y, T cos_threshold) const noexcept {
        if constexpr (G::has_ids)
            if (g.ids(x, y) != id) return false;
        if constexpr (G::has_normals) {
            // Written so that NaN normals (either side) reject.
            if (!(glm::dot(normal, g.normals(x, y)) >= cos_threshold)) return false;
        }
        return true;
    }
};

}  // namespace detail

}  // namespace v0
}  // namespace aaf
