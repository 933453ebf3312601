// SPDX-License-Identifier: MIT
#pragma once
// Robust ray-origin offsetting (Wächter & Binder, Ray Tracing Gems ch. 6; FORMULAS.md §6): moves a hit
// point off its surface by a few ULPs along the geometric normal, so shadow rays need no hand-set epsilon
// at any scene scale.

#include <bit>
#include <cmath>
#include <cstdint>
#include <type_traits>

#include <glm/vec3.hpp>

namespace aaf {
inline namespace v0 {

namespace detail {

template <class T>
struct offset_constants;
template <>
struct offset_constants<float> {
    using int_type = std::int32_t;
    static constexpr float origin = 1.0f / 32.0f;
    static constexpr float float_scale = 1.0f / 65536.0f;
    static constexpr float int_scale = 256.0f;
};
template <>
struct offset_constants<double> {
    // Same ULP count as the float version; the fallback scales with double's finer grid near 0.
    using int_type = std::int64_t;
    static constexpr double origin = 1.0 / 32.0;
    static constexpr double float_scale = 1.0 / 65536.0 / 536870912.0;  // 2^-16 · 2^-29 (29 = 52 - 23)
    static constexpr double int_scale = 256.0;
};

}  // namespace detail

/// Returns `p` moved off the surface along `n` (the geometric normal, pointing to the side the new
/// ray leaves from). Works in float and double. Non-finite inputs are returned unchanged.
template <class T>
    requires std::is_floating_point_v<T>
[[nodiscard]] glm::vec<3, T> offset_ray_origin(const glm::vec<3, T>& p, const glm::vec<3, T>& n) noexcept {
    using C = detail::offset_constants<T>;
    using I = typename C::int_type;
    glm::vec<3, T> out;
    for (int i = 0; i < 3; ++i) {
        const T pc = p[i];
        const T nc = n[i];
        if (!std::isfinite(pc) || !std::isfinite(nc)) {
            out[i] = pc;
            continue;
        }
        if (std::abs(pc) < C::origin) {
            out[i] = pc + C::float_scale * nc;
            continue;
        }
        const auto of_i = static_cast<I>(C::int_scale * nc);
        const I bits = std::bit_cast<I>(pc);
        out[i] = std::bit_cast<T>(static_cast<I>(pc < T(0) ? bits - of_i : bits + of_i));
    }
    return out;
}

}  // namespace v0
}  // namespace aaf
