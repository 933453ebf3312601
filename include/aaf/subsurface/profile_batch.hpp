// SPDX-License-Identifier: MIT
#pragma once
// The Jensen dipole R_d evaluated over many radii at once: Σ_i w_c[i]·R_d,c(r[i]) per colour channel c. This is
// the gather's inner loop (150 samples per pixel, two exponentials and two square roots per channel and sample,
// in double), which dominated its time when evaluated one sample at a time (docs/SUBSURFACE.md "Speed").
//
// Why explicit vectors and not the auto-vectoriser: without -ffast-math GCC and Clang vectorise neither the
// sum (floating-point reassociation), nor std::exp (a libm call), nor std::sqrt (it may set errno: "control
// flow in loop"), so a plain loop stays scalar at every -O level. Here the lanes run on simd.hpp's vectors,
// the exponential is a polynomial (below), and the square root is simd.hpp's (the ISA's vector instruction on x86: SSE2,
// AVX, AVX-512; other targets take it lane by lane). Lanes whose radii are left over go through the scalar
// dipole::profile.

#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <numbers>

#include <glm/vec3.hpp>

#include "../simd.hpp"
#include "dipole.hpp"

namespace aaf {
inline namespace v0 {
namespace subsurface {
namespace detail {

/// e^x for floor_x ≤ x ≤ 0 (x < floor_x gives 0; NaN must not occur; floor_x ≥ −745.2), to ≈ 1e-14 relative,
/// plus half a step of 2^−1074 where the result is subnormal (below e^−708, as std::exp): x = k·ln 2 + f with
/// |f| ≤ ln 2/2 (Cody–Waite split of ln 2), e^f by its degree-11 Taylor polynomial (remainder ≤ 0.347¹²/12! ≈
/// 6e-15), then times 2^⌊k/2⌋·2^(k−⌊k/2⌋), two normal powers written into the exponent bits, so k down to −1076
/// is exact and a subnormal result is rounded once. Branch-free, so it runs the same per lane of a vector.
template <class V, class I>
[[nodiscard]] inline V exp_nonpositive(V x, V zero, V floor_x) noexcept {
    const auto under = x < floor_x;
    x = under ? floor_x : x;
    const V magic = zero + 0x1.8p52;  // adding it rounds to an integer in the low mantissa bits
    const V kd = (x * 1.4426950408889634 + magic) - magic;
    const V f = (x - kd * 0.6931471803691238) - kd * 1.9082149292705877e-10;
    V p = zero + 1.0 / 39916800;
    p = p * f + 1.0 / 3628800;
    p = p * f + 1.0 / 362880;
    p = p * f + 1.0 / 40320;
    p = p * f + 1.0 / 5040;
    p = p * f + 1.0 / 720;
    p = p * f + 1.0 / 120;
    p = p * f + 1.0 / 24;
    p = p * f + 1.0 / 6;
    p = p * f + 0.5;
    p = p * f + 1.0;
    p = p * f + 1.0;
    // k (−1076 ≤ k ≤ 0) as an integer: the bits of kd + magic minus those of magic; split in two halves that
    // are each a normal power of two (a single 2^k is not below k = −1022).
    const I k = std::bit_cast<I>(kd + magic) - std::bit_cast<I>(magic);
    const I k1 = k >> 1, k2 = k - k1;
    return under ? zero : (p * std::bit_cast<V>((k1 + 1023) << 52)) * std::bit_cast<V>((k2 + 1023) << 52);
}

}  // namespace detail

/// Σ_i w_c[i]·R_d,c(r[i]) for the three channels c of `d` (R_d in 1/length², as dipole::profile), over `n`
/// radii r[i] ≥ 0 (finite) with weights w0, w1, w2 (finite). Vectorised (see the header comment); agrees with
/// summing dipole::profile one radius at a time to ~1e-13 relative (the order of the sum and the exponential's
/// polynomial differ). noexcept, no allocation; thread-safe.
[[nodiscard]] inline glm::dvec3 weighted_profile_sum(const rgb_dipole& d, const double* r, const double* w0, const double* w1,
                                                     const double* w2, std::size_t n) noexcept {
    const double* w[3] = {w0, w1, w2};
    glm::dvec3 sum(0);
    std::size_t i = 0;
#if AAF_SIMD_BYTES > 0
    using S = aaf::detail::simd<double>;
    using V = S::vec;
    using I = S::mask;  // 64-bit integer lanes
    constexpr std::size_t L = S::lanes;
    if (n >= L) {
        // e^x is evaluated down to where std::exp gives 0 (−745.13…), so no term that dipole::profile keeps is lost.
        const V zero = S::splat(0), one = S::splat(1), floor_x = S::splat(-745.2);
        V zr2[3], zv2[3], sig[3], zr[3], zv[3], acc[3];
        for (int c = 0; c < 3; ++c) {
            const dipole& ch = d.channel[c];
            zr2[c] = S::splat(ch.z_r * ch.z_r);
            zv2[c] = S::splat(ch.z_v * ch.z_v);
            sig[c] = S::splat(ch.sigma_tr);
            zr[c] = S::splat(ch.z_r);
            zv[c] = S::splat(ch.z_v);
            acc[c] = zero;
        }
        for (; i + L <= n; i += L) {
            const V rv = S::load(r + i);
            const V r2 = rv * rv;
            for (int c = 0; c < 3; ++c) {
                const V dr = S::sqrt(r2 + zr2[c]), dv = S::sqrt(r2 + zv2[c]);
                // In dipole::profile's order: z·(1 + σd)·e^{−σd} before dividing by d³. Dividing first made a
                // subnormal quotient where d is large and z too (σ_t′ ~ 1e-29), 0.15 % off (fuzz finding).
                const V a = zr[c] * (one + sig[c] * dr) * detail::exp_nonpositive<V, I>(-sig[c] * dr, zero, floor_x) / (dr * dr * dr);
                const V b = zv[c] * (one + sig[c] * dv) * detail::exp_nonpositive<V, I>(-sig[c] * dv, zero, floor_x) / (dv * dv * dv);
                acc[c] += S::load(w[c] + i) * (a + b);
            }
        }
        for (int c = 0; c < 3; ++c) {
            double lanes = 0;
            for (std::size_t l = 0; l < L; ++l) lanes += acc[c][l];
            sum[c] = d.channel[c].alpha_prime / (4 * std::numbers::pi) * lanes;
        }
    }
#endif
    for (; i < n; ++i)
        for (int c = 0; c < 3; ++c) sum[c] += w[c][i] * d.channel[c].profile(r[i]);
    return sum;
}

}  // namespace subsurface
}  // namespace v0
}  // namespace aaf
