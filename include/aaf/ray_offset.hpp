// SPDX-License-Identifier: MIT
#pragma once
// Robust ray-origin offsetting (Wächter & Binder, Ray Tracing Gems ch. 6; FORMULAS.md §6): moves a hit
// point off its surface by a few ULPs along the geometric normal, so shadow rays need no hand-set epsilon
// at any scene scale.

#include <algorithm>
#include <bit>
#include <limits>
#include <cmath>
#include <cstdint>
#include <type_traits>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "simd.hpp"

namespace aaf {
inline namespace v0 {

namespace detail {

template <class T>
struct offset_constants;
template <>
struct offset_constants<float> {
    using int_type = std::int32_t;
    static constexpr float origin = 1.0f / 32.0f;
    static constexpr float int_scale = 256.0f;
};
template <>
struct offset_constants<double> {
    using int_type = std::int64_t;
    static constexpr double origin = 1.0 / 32.0;
    static constexpr double int_scale = 256.0;
};

}  // namespace detail

/// Returns `p` moved off the surface along `n` (the geometric normal, pointing to the side the new
/// ray leaves from). Works in float and double. Non-finite components are returned unchanged.
///
/// Components with |p_c| >= 1/32 move by trunc(256·n_c) ULPs of p_c, exactly as Wächter & Binder.
/// DEPARTURE (docs/DEVIATIONS.md): near the origin W&B add a fixed 2^-16·n_c, which is a hand-set, scale-
/// dependent epsilon: in a scene a few 1e-4 units wide it jumps over whole occluders (light leaks). aaf
/// instead adds 256 ULPs of the point's largest coordinate, 256·ε·max|p_i|·n_c: the same ULP count as the
/// main rule (so the step does not jump at |p_c| = 1/32), 2^-15 for a point of unit magnitude in float
/// (W&B: 2^-16), and proportional to the scene everywhere else (the rounding error of a computed hit point
/// scales with its coordinates, not with the small one being offset).
template <class T>
    requires std::is_floating_point_v<T>
[[nodiscard]] glm::vec<3, T> offset_ray_origin(const glm::vec<3, T>& p, const glm::vec<3, T>& n) noexcept {
    using C = detail::offset_constants<T>;
    using I = typename C::int_type;
    // The components in four lanes (the fourth a copy of the first, never stored) and every case computed
    // and selected per lane with no branch: the compiler runs each step on the three components at once, and
    // neighbouring pixels, whose components take different cases, mispredict nothing.
    using U = std::make_unsigned_t<I>;
    T pc[4], nc[4], out4[4];
    for (int i = 0; i < 4; ++i) pc[i] = p[i % 3], nc[i] = n[i % 3];
    T mag[4];
    bool finite[4];
    for (int i = 0; i < 4; ++i) {
        mag[i] = std::abs(pc[i]);
        finite[i] = mag[i] <= std::numeric_limits<T>::max();  // std::isfinite(pc[i])
        mag[i] = finite[i] ? mag[i] : T(0);
    }
    const T largest = std::max(std::max(mag[0], mag[1]), mag[2]);  // of the finite components, 0 if none
    // Floor: a point at the exact origin still moves by a normal (non-denormal) amount.
    constexpr T floor = std::numeric_limits<T>::min() / std::numeric_limits<T>::epsilon();
    const T fallback_step = C::int_scale * std::numeric_limits<T>::epsilon() * std::max(largest, floor);
    for (int i = 0; i < 4; ++i) {
        const bool ok = finite[i] && std::abs(nc[i]) <= std::numeric_limits<T>::max();
        const T near_origin = pc[i] + fallback_step * nc[i];
        // Normals are unit vectors; clamping keeps a longer one (user data) at 256 ULPs instead of overflowing
        // the float-to-integer conversion (undefined behaviour for |256·n_c| beyond the integer's range, and
        // for a non-finite n_c, which is replaced by 0 here since its result is not used).
        const auto of_i = static_cast<I>(C::int_scale * std::clamp(ok ? nc[i] : T(0), T(-1), T(1)));
        const U bits = std::bit_cast<U>(pc[i]);  // unsigned: wraps where a non-finite pc's (unused) move would overflow
        const T moved = std::bit_cast<T>(pc[i] < T(0) ? bits - static_cast<U>(of_i) : bits + static_cast<U>(of_i));
        out4[i] = !ok ? pc[i] : mag[i] < C::origin ? near_origin : moved;
    }
    const glm::vec<3, T> out(out4[0], out4[1], out4[2]);
    return out;
}

/// The origin of shadow rays from surface point `p` (normal `n`, either orientation) towards `target` (e.g.
/// the light's centre): `p` moved off the surface on the target's side, automatically (offset_ray_origin)
/// when `fixed_offset` < 0, else by `fixed_offset` world units along the normal (0 = not moved).
template <class T>
    requires std::is_floating_point_v<T>
[[nodiscard]] glm::vec<3, T> shadow_ray_origin(const glm::vec<3, T>& p, const glm::vec<3, T>& n, const glm::vec<3, T>& target,
                                               double fixed_offset = -1) noexcept {
    const glm::vec<3, T> towards = glm::dot(n, target - p) >= T(0) ? n : -n;
    return fixed_offset < 0 ? offset_ray_origin(p, towards) : p + static_cast<T>(fixed_offset) * towards;
}

namespace detail {

/// shadow_ray_origin for L points at once, one per lane, by component: p[c·L + k] is component c of point k,
/// and likewise n and out. Each lane's arithmetic is shadow_ray_origin's (the same bits; test_ray_offset.cpp).
/// With explicit vectors of L lanes, offset_ray_origin's steps run on whole vectors. Written as a loop over
/// points, GCC kept a branch per point (the selects' arms hold products, which it will not compute
/// speculatively under -ftrapping-math, the default) and the offsets measured a sixth of aaf's cost per
/// sample (issue 14).
template <class T, std::size_t L>
void shadow_ray_origins(const T* __restrict p, const T* __restrict n, const glm::vec<3, T>& target, double fixed_offset,
                        T* __restrict out) noexcept {
    T keep[L];  // 1: point k moves along n, 0: along −n
    for (std::size_t k = 0; k < L; ++k) {
        const glm::vec<3, T> pk(p[k], p[L + k], p[2 * L + k]), nk(n[k], n[L + k], n[2 * L + k]);
        keep[k] = glm::dot(nk, target - pk) >= T(0) ? T(1) : T(0);
    }
    if (fixed_offset >= 0) {
        const auto d = static_cast<T>(fixed_offset);
        for (std::size_t c = 0; c < 3; ++c)
            for (std::size_t k = 0; k < L; ++k) out[c * L + k] = p[c * L + k] + d * (keep[k] != T(0) ? n[c * L + k] : -n[c * L + k]);
        return;
    }
#if AAF_SIMD_BYTES > 0
    if constexpr (L == simd<T>::lanes) {
        using S = simd<T>;
        using V = typename S::vec;
        using M = typename S::mask;
        using C = offset_constants<T>;
        using I = typename C::int_type;
        using U = std::make_unsigned_t<I>;
        typedef I ints __attribute__((vector_size(simd_bytes)));
        typedef U bits __attribute__((vector_size(simd_bytes)));
        const V max = S::splat(std::numeric_limits<T>::max());
        const auto abs = [](V x) { return std::bit_cast<V>(std::bit_cast<bits>(x) & (~U(0) >> 1)); };  // std::abs: clears the sign
        const auto magnitude = [&](V x) { const V a = abs(x); return a <= max ? a : V{}; };  // 0 where not finite
        const V mx = magnitude(S::load(p)), my = magnitude(S::load(p + L)), mz = magnitude(S::load(p + 2 * L));
        const V mxy = mx < my ? my : mx, largest = mxy < mz ? mz : mxy;
        constexpr T floor = std::numeric_limits<T>::min() / std::numeric_limits<T>::epsilon();
        constexpr T scale = C::int_scale * std::numeric_limits<T>::epsilon();
        const V step = largest < S::splat(floor) ? S::splat(scale * floor) : scale * largest;
        const M along = S::load(keep) != V{};
        for (std::size_t c = 0; c < 3; ++c) {  // offset_ray_origin's steps, per component
            const V pc = S::load(p + c * L), raw = S::load(n + c * L);
            const V nc = along ? raw : -raw;
            const V mag = abs(pc);
            const M ok = (mag <= max) & (abs(nc) <= max);
            const V near_origin = pc + step * nc;
            const V unit = ok ? nc : V{};
            // int_scale·clamp(unit, −1, 1): int_scale is a power of two, so scaling before selecting is exact.
            const V clamped = unit < S::splat(T(-1))  ? S::splat(-C::int_scale)
                              : S::splat(T(1)) < unit ? S::splat(C::int_scale)
                                                      : C::int_scale * unit;
            const bits of = std::bit_cast<bits>(__builtin_convertvector(clamped, ints));  // truncates, as static_cast
            const bits pb = std::bit_cast<bits>(pc);
            const V moved = std::bit_cast<V>(pc < V{} ? pb - of : pb + of);
            S::store(out + c * L, ok ? (mag < S::splat(C::origin) ? near_origin : moved) : pc);
        }
        return;
    }
#endif
    for (std::size_t k = 0; k < L; ++k) {
        const glm::vec<3, T> o = offset_ray_origin(glm::vec<3, T>(p[k], p[L + k], p[2 * L + k]),
                                                   keep[k] != T(0) ? glm::vec<3, T>(n[k], n[L + k], n[2 * L + k])
                                                                   : -glm::vec<3, T>(n[k], n[L + k], n[2 * L + k]));
        for (std::size_t c = 0; c < 3; ++c) out[c * L + k] = o[c];
    }
}

}  // namespace detail

}  // namespace v0
}  // namespace aaf
