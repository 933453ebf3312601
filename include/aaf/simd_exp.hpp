// SPDX-License-Identifier: MIT
#pragma once
// exp(x) for x <= 0 in plain arithmetic, one definition for a scalar T and for simd<T> vectors, so that
// the light-plane filter's vector lanes and its scalar remainder compute the same bits (std::exp is a
// library call per value: it cannot run in vector lanes, and it was 8–14x the image-space filter's cost).
//
// Method (the textbook one, e.g. Muller, "Elementary Functions", ch. 11): x = n·ln2 + r with n the
// nearest integer to x/ln2 and r in [−ln2/2, ln2/2] computed with ln2 split in a high part with trailing
// zero bits and a low part (Cody–Waite, so n·ln2_hi is exact); e^r by its Taylor polynomial (degree 7 for
// float, 13 for double: the truncation error is below 0.1 ulp on that interval); 2^n by adding n to the
// exponent field. By default results below the smallest normal number are flushed to 0 (which saves the
// two-step scaling that reaching the subnormals needs; a Gaussian weight of 1e−38 next to the centre's
// weight 1 changes no sum). `exp_range::subnormal` (the subsurface profile sum, whose e^x is multiplied by
// large factors) scales by 2^⌊n/2⌉·2^(n−⌊n/2⌉) instead, two normal powers, so the result is rounded once
// into the subnormals, as std::exp's. Measured against a correctly rounded exp (tests/test_simd_exp.cpp):
// within 2 ulp down to the smallest normal result, and within 2 ulp plus one subnormal step below;
// NaN stays NaN; −∞ gives 0.
// The rounding to an integer uses the "add 1.5·2^(p−1)" trick, so it needs the default rounding mode and
// no -ffast-math reassociation (aaf is not compiled with it).

#include <bit>
#include <cstdint>
#include <type_traits>

#include "simd.hpp"

namespace aaf {
inline namespace v0 {
namespace detail {

/// Where exp_nonpositive stops: a little above the smallest normal result (the default), or where a
/// correctly rounded e^x becomes 0.
enum class exp_range { normal, subnormal };

/// e^x for x ≤ 0 (or NaN, or −∞), lane by lane. `V` is T or a GCC/Clang vector of T; `U` the unsigned
/// integer (or integer vector) of the same size. With exp_range::normal, results below e^−86.6 = 2.5e−38
/// in float, e^−707.7 = 4.5e−308 in double (a little above the smallest normal numbers) are flushed to 0;
/// with exp_range::subnormal, below e^−104 (float) and e^−745.2 (double), where e^x rounds to 0.
/// x > 0 is outside the domain (the filter only passes −distance²·1/(2β²) ≤ 0): such results are wrong.
template <class T, class V, class U, exp_range Range = exp_range::normal>
[[nodiscard]] inline V exp_nonpositive(V x) noexcept {
    static_assert(std::is_floating_point_v<T> && sizeof(V) == sizeof(U));
    constexpr bool single = sizeof(T) == 4;
    constexpr bool subnormal = Range == exp_range::subnormal;
    constexpr int mantissa_bits = single ? 23 : 52;
    constexpr unsigned exponent_bias = single ? 127 : 1023;
    // normal: e^lowest is a little above the smallest normal, n ≥ −(bias − 2) below, so that adding n to
    // the exponent of e^r (in [0.7, 1.42]) keeps it normal. subnormal: half a step below the smallest
    // subnormal (n ≥ −(bias + mantissa bits + 1), so each half of n is a normal power of two).
    constexpr T lowest = subnormal ? (single ? T(-104.0) : T(-745.2)) : (single ? T(-86.6) : T(-707.7));
    constexpr T log2e = T(1.4426950408889634073599246810018921);
    // ln 2 = ln2_hi + ln2_lo; ln2_hi has at least 11 trailing zero bits, so n·ln2_hi is exact for |n| ≤ 1100.
    constexpr T ln2_hi = single ? T(0.693359375) : T(6.93147180369123816490e-01);
    constexpr T ln2_lo = single ? T(-2.12194440e-4) : T(1.90821492927058770002e-10);
    // Adding 1.5·2^p (p = mantissa bits) rounds a value of magnitude < 2^(p−1) to an integer, which is then
    // the low bits of the sum's representation.
    constexpr T round_magic = single ? T(12582912.0) : T(6755399441055744.0);
    const V zero = V{} + T(0);
    const V low = zero + lowest;
    const V xc = low > x ? low : x;  // keeps the exponent bits below in range; NaN stays (x86's max: one instruction)
    const V shifted = xc * log2e + round_magic;
    const V n = shifted - round_magic;                                // round(x / ln 2), as T
    const V r = (xc - n * ln2_hi) - n * ln2_lo;                       // in [−ln2/2, ln2/2] (+ rounding)
    // e^r by Horner's rule on the Taylor series: 1 + r(1 + r(1/2 + r(1/6 + …))).
    V p;
    if constexpr (single) {
        p = zero + T(1.0 / 5040);
        p = p * r + T(1.0 / 720);
        p = p * r + T(1.0 / 120);
        p = p * r + T(1.0 / 24);
        p = p * r + T(1.0 / 6);
        p = p * r + T(0.5);
    } else {
        p = zero + T(1.0 / 6227020800.0);
        p = p * r + T(1.0 / 479001600.0);
        p = p * r + T(1.0 / 39916800.0);
        p = p * r + T(1.0 / 3628800.0);
        p = p * r + T(1.0 / 362880.0);
        p = p * r + T(1.0 / 40320.0);
        p = p * r + T(1.0 / 5040.0);
        p = p * r + T(1.0 / 720.0);
        p = p * r + T(1.0 / 120.0);
        p = p * r + T(1.0 / 24.0);
        p = p * r + T(1.0 / 6.0);
        p = p * r + T(0.5);
    }
    p = p * r + T(1);
    p = p * r + T(1);
    // e^r·2^n: n added to the exponent field of e^r (the integer n is the low bits of `shifted`). In
    // unsigned arithmetic, so that a NaN lane's garbage bits are not signed overflow (its result is NaN).
    const U ni = std::bit_cast<U>(shifted) - std::bit_cast<U>(zero + round_magic);
    if constexpr (subnormal) {
        // 2^n as 2^n1·2^n2, n1 = n/2 rounded, each a normal power: p·2^n1 is exact, ·2^n2 rounds once.
        const V shifted1 = n * T(0.5) + round_magic;
        const U n1 = std::bit_cast<U>(shifted1) - std::bit_cast<U>(zero + round_magic);
        const U n2 = ni - n1;
        const U bias = std::bit_cast<U>(zero) + exponent_bias;  // wraps like n: unsigned, two's complement
        const V y = (p * std::bit_cast<V>((n1 + bias) << mantissa_bits)) * std::bit_cast<V>((n2 + bias) << mantissa_bits);
        return x < low ? zero : y;
    } else {
        const V y = std::bit_cast<V>(std::bit_cast<U>(p) + (ni << mantissa_bits));
        return x < low ? zero : y;                                    // NaN stays NaN (x − … propagates)
    }
}

/// exp_nonpositive for a T or a simd<T>::vec, with the unsigned integer type of the same shape picked here.
template <class T, exp_range Range = exp_range::normal, class V>
[[nodiscard]] inline V exp_nonpositive_of(V x) noexcept {
    using U = std::conditional_t<sizeof(T) == 8, std::uint64_t, std::uint32_t>;
#if AAF_SIMD_BYTES > 0
    if constexpr (!std::is_same_v<V, T>) {
        typedef U uvec __attribute__((vector_size(sizeof(V))));
        return exp_nonpositive<T, V, uvec, Range>(x);
    } else
#endif
    {
        return exp_nonpositive<T, V, U, Range>(x);
    }
}

}  // namespace detail
}  // namespace v0
}  // namespace aaf
