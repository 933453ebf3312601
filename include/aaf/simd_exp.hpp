// SPDX-License-Identifier: MIT
#pragma once
// 2^x for x <= 0 in plain arithmetic, one definition for a scalar T and for simd<T> vectors, so that the
// light-plane filter's vector lanes and its scalar remainder compute the same bits (std::exp is a library
// call per value: it cannot run in vector lanes, and it was 8–14x the image-space filter's cost). The
// filter's weight e^(−d²/(2β²)) is 2^(d²·s) with s = −log2(e)/(2β²) computed once per centre, which saves
// the reduction's multiplication by 1/ln 2 and the two-part (Cody–Waite) subtraction of n·ln 2 per tap.
//
// Method (the textbook one, e.g. Muller, "Elementary Functions", ch. 11): x = n + r with n the nearest
// integer to x and r = x − n in [−1/2, 1/2] (exact); 2^r by a polynomial; 2^n by adding n to the exponent
// field. Float: the degree-6 polynomial interpolating 2^r at the 7 Chebyshev nodes of [−1/2, 1/2]
// (relative error 1.9e−8 = 0.32·2^−24 with its float coefficients, in exact arithmetic); double: the
// Taylor polynomial of e^(r·ln 2) to degree 13 (truncation error below 1e−17). Measured against a
// correctly rounded 2^x (tests/test_simd_exp.cpp): within 2 ulp down to the smallest result it computes.
// No range check: x must be in [exp2_lowest<T>, 0] (results from 2^−125 in float, 2^−1021 in double,
// normal numbers); the filter drops a tap whose x is below that, or NaN, with the same comparison in its
// vector lanes and its scalar rule (light_plane_weight). Other x give meaningless bits.
// exp_nonpositive (e^x, the subsurface profile sum's) reduces x by ln 2 and uses the same polynomials, and
// reaches the subnormals.
// The rounding to an integer uses the "add 1.5·2^p" trick, so it needs the default rounding mode and
// no -ffast-math reassociation (aaf is not compiled with it).

#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <type_traits>

#include "simd.hpp"

namespace aaf {
inline namespace v0 {
namespace detail {

/// The unsigned integer of T's size, as a scalar when V is T and as a vector of V's width otherwise: the
/// exponent-field arithmetic of exp2_nonpositive and exp_nonpositive.
/// (Vectors only where simd.hpp has them: other compilers do not parse the vector attribute.)
template <class T, class V>
struct unsigned_lanes {
    using scalar = std::conditional_t<sizeof(T) == 8, std::uint64_t, std::uint32_t>;
#if AAF_SIMD_BYTES > 0
    template <std::size_t Bytes>
    struct vector_of {
        typedef scalar type __attribute__((vector_size(Bytes)));
    };
    using type = typename std::conditional_t<std::is_same_v<V, T>, std::type_identity<scalar>, vector_of<sizeof(V)>>::type;
#else
    using type = scalar;
#endif
};
template <class T, class V>
using unsigned_lanes_t = typename unsigned_lanes<T, V>::type;

/// The smallest x that exp2_nonpositive accepts: 2^x is then a normal number (so is every partial result).
template <class T>
inline constexpr T exp2_lowest = sizeof(T) == 4 ? T(-125) : T(-1021);

/// 2^r for r in [−1/2, 1/2] (the reduced argument of exp2_nonpositive and exp_nonpositive), by the
/// polynomials described at the top; in [0.70, 1.42].
template <class T, class V>
[[nodiscard]] inline V exp2_reduced(V r) noexcept {
    constexpr bool single = sizeof(T) == 4;
    const V zero = V{} + T(0);
    V p;
    if constexpr (single) {
        p = zero + T(1.54614449e-4);
        p = p * r + T(1.34004280e-3);
        p = p * r + T(9.61805694e-3);
        p = p * r + T(5.55032715e-2);
        p = p * r + T(2.40226507e-1);
        p = p * r + T(6.93147182e-1);
    } else {
        // c_k = (ln 2)^k / k!, k = 13 down to 1, evaluated in long double.
        constexpr auto c = [](int k) {
            long double v = 1.0L;
            for (int i = 1; i <= k; ++i) v = v * 0.693147180559945309417232121458176568L / static_cast<long double>(i);
            return static_cast<T>(v);
        };
        p = zero + c(13);
        p = p * r + c(12);
        p = p * r + c(11);
        p = p * r + c(10);
        p = p * r + c(9);
        p = p * r + c(8);
        p = p * r + c(7);
        p = p * r + c(6);
        p = p * r + c(5);
        p = p * r + c(4);
        p = p * r + c(3);
        p = p * r + c(2);
        p = p * r + c(1);
    }
    p = p * r + T(1);
    return p;
}

/// 2^x for x in [exp2_lowest<T>, 0], lane by lane (no check of the range: see above). `V` is T or a
/// GCC/Clang vector of T; `U` the unsigned integer (or integer vector) of the same size.
template <class T, class V, class U = unsigned_lanes_t<T, V>>
[[nodiscard]] inline V exp2_nonpositive(V x) noexcept {
    static_assert(std::is_floating_point_v<T> && sizeof(V) == sizeof(U));
    constexpr bool single = sizeof(T) == 4;
    constexpr int mantissa_bits = single ? 23 : 52;
    // Adding 1.5·2^p (p = mantissa bits) rounds a value of magnitude < 2^(p−1) to an integer n, which is then
    // the low bits of the sum's representation; the constant's own bits vanish when shifted into the
    // exponent field (its low p − 11 bits are 0), so the sum's bits shifted are n's.
    constexpr T round_magic = single ? T(12582912.0) : T(6755399441055744.0);
    const V shifted = x + round_magic;
    const V r = x - (shifted - round_magic);  // exact: r in [−1/2, 1/2]
    const V p = exp2_reduced<T>(r);
    // 2^r·2^n: n added to the exponent field of 2^r (in [0.7, 1.42]), in unsigned arithmetic (wraps).
    return std::bit_cast<V>(std::bit_cast<U>(p) + (std::bit_cast<U>(shifted) << mantissa_bits));
}

/// e^x for x ≤ 0 rounded once into the subnormals, as std::exp (the subsurface profile sum, whose e^x is
/// multiplied by large factors, subsurface/profile_batch.hpp): 0 below e^−104 (float) and e^−745.2 (double),
/// where e^x rounds to 0, and for −∞; NaN stays NaN. x = n·ln 2 + r′ (n the nearest integer to x/ln 2, ln 2
/// in two parts as Cody–Waite, so r′ is within a few ulp), e^r′ = 2^(r′·log2 e) by exp2_reduced (the
/// product's rounding costs ≤ 0.2 ulp), times 2^n as 2^n1·2^(n−n1) with n1 = n/2 rounded, two normal
/// powers: p·2^n1 is exact and ·2^(n−n1) rounds once. Within 2 ulp (tests/test_simd_exp.cpp), plus one
/// subnormal step below the smallest normal result. `U` as for exp2_nonpositive.
template <class T, class V, class U = unsigned_lanes_t<T, V>>
[[nodiscard]] inline V exp_nonpositive(V x) noexcept {
    static_assert(std::is_floating_point_v<T> && sizeof(V) == sizeof(U));
    constexpr bool single = sizeof(T) == 4;
    constexpr int mantissa_bits = single ? 23 : 52;
    constexpr unsigned exponent_bias = single ? 127 : 1023;
    // Half a step below the smallest subnormal: n ≥ −(bias + mantissa bits + 1), so each half of n is normal.
    constexpr T lowest = single ? T(-104.0) : T(-745.2);
    constexpr T log2e = T(1.4426950408889634073599246810018921);
    // ln 2 = ln2_hi + ln2_lo; ln2_hi has at least 11 trailing zero bits, so n·ln2_hi is exact for |n| ≤ 1100.
    constexpr T ln2_hi = single ? T(0.693359375) : T(6.93147180369123816490e-01);
    constexpr T ln2_lo = single ? T(-2.12194440e-4) : T(1.90821492927058770002e-10);
    constexpr T round_magic = single ? T(12582912.0) : T(6755399441055744.0);
    const V zero = V{} + T(0);
    const V low = zero + lowest;
    const V xc = low > x ? low : x;  // keeps the exponent bits below in range; NaN stays
    const V shifted = xc * log2e + round_magic;
    const V n = shifted - round_magic;                  // round(x / ln 2), as T
    const V r = ((xc - n * ln2_hi) - n * ln2_lo) * log2e;  // in [−1/2, 1/2] (+ rounding)
    const V p = exp2_reduced<T>(r);
    const V shifted1 = n * T(0.5) + round_magic;
    const U ni = std::bit_cast<U>(shifted) - std::bit_cast<U>(zero + round_magic);
    const U n1 = std::bit_cast<U>(shifted1) - std::bit_cast<U>(zero + round_magic);
    const U bias = std::bit_cast<U>(zero) + exponent_bias;  // unsigned arithmetic: wraps as two's complement
    const V y = (p * std::bit_cast<V>((n1 + bias) << mantissa_bits)) * std::bit_cast<V>((ni - n1 + bias) << mantissa_bits);
    return x < low ? zero : y;  // NaN stays NaN (r propagates it)
}

/// Whether exp_negated_as_std computes float lanes in vectors: with 32- or 64-byte vectors, against glibc
/// 2.27 or later, whose expf (the algorithm of ARM's optimized-routines, also musl's) is within 0.502 ulp
/// of e^x (its source's measured bound; tests/test_simd_exp.cpp checks the agreement on this machine's
/// libm, and every float in [0, 104] was checked once, docs/BENCHMARKS.md issue 14). Elsewhere (another
/// libm, narrower vectors, double) the scalar std::exp loop runs.
#if AAF_SIMD_BYTES >= 32 && defined(__GLIBC__) && (__GLIBC__ > 2 || (__GLIBC__ == 2 && __GLIBC_MINOR__ >= 27))
inline constexpr bool exp_negated_vectors = true;
#else
inline constexpr bool exp_negated_vectors = false;
#endif

/// out[i] = full[i] > 0 ? std::exp(−a[i]) : 0 for i in [0, n): the image-space filter's m_1 = e^−a per pixel
/// (0 without a kernel), with the same bits as that scalar expression, which the per-pixel definition and
/// the reference filters use. One std::exp call per pixel was a quarter of the horizontal pass (issue 14).
/// Where exp_negated_vectors holds, float lanes compute e^−a in double instead: n = round(−a/ln 2), r = −a −
/// n·ln 2 (ln 2 in two parts, Cody–Waite: |r| ≤ 0.347), e^r by its Taylor polynomial of degree 10
/// (truncation below 2^−42 relative; with the rounding errors well below 2^−40), times 2^n. Rounding that
/// double y to float gives the correctly rounded e^−a unless y lies within 2^−8 float ulp (2^21 units of
/// y's last place) of a midpoint between two floats; and glibc's expf, within 0.502 ulp, returns the
/// correctly rounded value whenever e^−a is more than 0.002 ulp from a midpoint. So outside that band the
/// rounded y is std::exp's bits; lanes inside it (about 0.8 % of them), lanes with −a outside [−87, 0] (a
/// result that may be subnormal, Inf or NaN inputs) call std::exp as before.
template <class T>
void exp_negated_as_std(std::size_t n, const T* full, const T* a, T* out) noexcept {
    std::size_t i = 0;
#if AAF_SIMD_BYTES >= 32
    if constexpr (exp_negated_vectors && std::is_same_v<T, float>) {
        constexpr std::size_t L = simd_bytes / 8;  // doubles per vector
        typedef double vd __attribute__((vector_size(simd_bytes)));
        typedef std::int64_t vi __attribute__((vector_size(simd_bytes)));
        typedef std::uint64_t vu __attribute__((vector_size(simd_bytes)));
        typedef float vf __attribute__((vector_size(simd_bytes / 2)));
        constexpr double shift = 0x1.8p52;  // adding it rounds to an integer, held in the low bits
        constexpr std::int64_t band = std::int64_t(1) << 21, midpoint = std::int64_t(1) << 28;
        const std::size_t whole = n - n % L;  // (i + L <= n: GCC 12 warned of an overflow in the loop after it)
        for (; i < whole; i += L) {
            vf af, ff;
            std::memcpy(&af, a + i, sizeof af);
            std::memcpy(&ff, full + i, sizeof ff);
            const vd x = -__builtin_convertvector(af, vd);  // exact
            const vd t = x * 0x1.71547652b82fep0 + shift;   // 1/ln 2
            const vd k = t - shift;
            const vd r = (x - k * 0x1.62e42fee00000p-1) - k * 0x1.a39ef35793c76p-33;  // k·ln2_hi exact
            vd p = vd{} + 1.0 / 3628800.0;
            p = p * r + 1.0 / 362880.0;
            p = p * r + 1.0 / 40320.0;
            p = p * r + 1.0 / 5040.0;
            p = p * r + 1.0 / 720.0;
            p = p * r + 1.0 / 120.0;
            p = p * r + 1.0 / 24.0;
            p = p * r + 1.0 / 6.0;
            p = p * r + 0.5;
            p = p * r + 1.0;
            p = p * r + 1.0;
            // 2^k added to the exponent field (p in [0.7, 1.42], k in [−126, 0]: y is a normal double). In
            // unsigned lanes: a lane outside that range (it calls std::exp below) may wrap, which must be
            // defined (UBSan found the signed form's overflow).
            const vu y = std::bit_cast<vu>(p) + ((std::bit_cast<vu>(t) - std::bit_cast<vu>(vd{} + shift)) << 52);
            // The 29 bits that rounding to float drops, relative to the midpoint pattern 1000…0.
            const vi off = std::bit_cast<vi>(y & std::uint64_t(2 * midpoint - 1)) - midpoint;
            const vi has = __builtin_convertvector(ff, vd) > 0.0;
            const vi exact = (x >= -87.0) & (x <= 0.0) & ((off >= band) | (off <= -band));
            const vi scalar = has & ~exact;
            vf o = __builtin_convertvector(has ? std::bit_cast<vd>(y) : vd{}, vf);
            // Whether any lane needs std::exp: one instruction on the vectors' ISA (the generic lane loop
            // was scalarised by GCC 12).
#if AAF_SIMD_BYTES == 64 && defined(__AVX512F__)
            typedef long long v8di __attribute__((vector_size(64)));
            const bool any = __builtin_ia32_ptestmq512(std::bit_cast<v8di>(scalar), std::bit_cast<v8di>(scalar), 0xff) != 0;
#elif AAF_SIMD_BYTES == 32 && defined(__AVX__)
            const bool any = __builtin_ia32_movmskpd256(std::bit_cast<vd>(scalar)) != 0;
#else
            bool any = false;
            for (std::size_t l = 0; l < L; ++l) any = any | (scalar[l] != 0);
#endif
            if (any) [[unlikely]]
                for (std::size_t l = 0; l < L; ++l)
                    if (scalar[l]) o[l] = std::exp(-a[i + l]);
            std::memcpy(out + i, &o, sizeof o);
        }
    }
#endif
    for (; i < n; ++i) out[i] = full[i] > T(0) ? std::exp(-a[i]) : T(0);
}

}  // namespace detail
}  // namespace v0
}  // namespace aaf
