// SPDX-License-Identifier: MIT
#pragma once
// offset_ray_origin written case by case, one branch per case, as ray_offset.hpp states it (FORMULAS.md §6 with
// aaf's near-origin step): the oracle for the library's branch-free form, which must give the same bits.

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <type_traits>

#include <glm/vec3.hpp>

namespace aaf_ref {

template <class T>
glm::vec<3, T> offset_ray_origin(const glm::vec<3, T>& p, const glm::vec<3, T>& n) {
    using I = std::conditional_t<sizeof(T) == 4, std::int32_t, std::int64_t>;
    T largest = T(0);
    for (int i = 0; i < 3; ++i)
        if (std::isfinite(p[i])) largest = std::max(largest, std::abs(p[i]));
    constexpr T floor = std::numeric_limits<T>::min() / std::numeric_limits<T>::epsilon();
    const T fallback_step = T(256) * std::numeric_limits<T>::epsilon() * std::max(largest, floor);
    glm::vec<3, T> out;
    for (int i = 0; i < 3; ++i) {
        const T pc = p[i];
        const T nc = n[i];
        if (!std::isfinite(pc) || !std::isfinite(nc)) {  // passes through
            out[i] = pc;
        } else if (std::abs(pc) < T(1.0 / 32.0)) {       // near the origin: 256 ULPs of the largest coordinate
            out[i] = pc + fallback_step * nc;
        } else {                                         // trunc(256·n_c) ULPs of p_c, away from zero when n_c > 0
            const auto of_i = static_cast<I>(T(256) * std::clamp(nc, T(-1), T(1)));
            const I bits = std::bit_cast<I>(pc);
            out[i] = std::bit_cast<T>(static_cast<I>(pc < T(0) ? bits - of_i : bits + of_i));
        }
    }
    return out;
}

}  // namespace aaf_ref
