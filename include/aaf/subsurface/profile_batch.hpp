// SPDX-License-Identifier: MIT
#pragma once
// The Jensen dipole R_d evaluated over many radii at once: Σ_i w_c[i]·R_d,c(r[i]) per colour channel c. This is
// the gather's inner loop (150 samples per pixel, two exponentials and two square roots per channel and sample,
// in double), which dominated its time when evaluated one sample at a time (docs/SUBSURFACE.md "Speed").
//
// Why explicit vectors and not the auto-vectoriser: without -ffast-math GCC and Clang vectorise neither the
// sum (floating-point reassociation), nor std::exp (a libm call), nor std::sqrt (it may set errno: "control
// flow in loop"), so a plain loop stays scalar at every -O level. Here the lanes run on simd.hpp's vectors,
// the exponential is simd_exp.hpp's exp_nonpositive (into the subnormals), and the square root is simd.hpp's
// (the ISA's vector instruction on x86: SSE2, AVX, AVX-512; other targets take it lane by lane). Lanes whose
// radii are left over go through the scalar dipole::profile.

#include <cmath>
#include <cstddef>
#include <numbers>

#include <glm/vec3.hpp>

#include "../simd.hpp"
#include "../simd_exp.hpp"
#include "dipole.hpp"

namespace aaf {
inline namespace v0 {
namespace subsurface {

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
    constexpr std::size_t L = S::lanes;
    if (n >= L) {
        const V zero = S::splat(0), one = S::splat(1);
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
        // e^x down to where std::exp gives 0 (−745.2), so no term that dipole::profile keeps is lost.
        const auto exp_subnormal = [](V x) { return aaf::detail::exp_nonpositive<double>(x); };
        for (; i + L <= n; i += L) {
            const V rv = S::load(r + i);
            const V r2 = rv * rv;
            for (int c = 0; c < 3; ++c) {
                const V dr = S::sqrt(r2 + zr2[c]), dv = S::sqrt(r2 + zv2[c]);
                // In dipole::profile's order: z·(1 + σd)·e^{−σd} before dividing by d³. Dividing first made a
                // subnormal quotient where d is large and z too (σ_t′ ~ 1e-29), 0.15 % off (fuzz finding).
                const V a = zr[c] * (one + sig[c] * dr) * exp_subnormal(-sig[c] * dr) / (dr * dr * dr);
                const V b = zv[c] * (one + sig[c] * dv) * exp_subnormal(-sig[c] * dv) / (dv * dv * dv);
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
