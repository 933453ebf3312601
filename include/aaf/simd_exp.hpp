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
// Float where GCC has AVX2 (exp2_float_eighths): x = n + j/8 + r instead, 2^(j/8) from an 8-entry table
// held in a register (one permute) and 2^r by a degree-3 polynomial: fewer multiply-adds per value.
// No range check: x must be in [exp2_lowest<T>, 0] (results from 2^−125 in float, 2^−1021 in double,
// normal numbers); the filter drops a tap whose x is below that, or NaN, with the same comparison in its
// vector lanes and its scalar rule (light_plane_weight). Other x give meaningless bits.
// exp_nonpositive (e^x, the subsurface profile sum's) reduces x by ln 2 and uses the same polynomials, and
// reaches the subnormals.
// The rounding to an integer uses the "add 1.5·2^p" trick, so it needs the default rounding mode and
// no -ffast-math reassociation (aaf is not compiled with it).

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <type_traits>
#include <utility>

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

/// Whether exp2_nonpositive<float> uses the eighths table (below) in this build: with AVX2's one-instruction
/// permute of 8 floats (vpermps; GCC's __builtin_shuffle of vectors of ≥ 8 floats) — the same choice for
/// the vector lanes and the scalar form, so that they agree. Elsewhere (SSE, Clang, no vectors) the
/// degree-6 polynomial runs, as in double.
#if AAF_SIMD_BYTES >= 32 && defined(__AVX2__) && defined(__GNUC__) && !defined(__clang__)
inline constexpr bool exp2_float_eighths = true;
#else
inline constexpr bool exp2_float_eighths = false;
#endif

/// 2^(j/8) for j in [0, 8), rounded to float (relative error ≤ 0.27·2^−23); computed for aaf with mpmath at
/// 200 bits.
inline constexpr float exp2_8th[8] = {0x1.000000p+0f, 0x1.172b84p+0f, 0x1.306fe0p+0f, 0x1.4bfdaep+0f,
                                      0x1.6a09e6p+0f, 0x1.8ace54p+0f, 0x1.ae89fap+0f, 0x1.d5818ep+0f};

/// exp2_8th[j] with j·2^20 taken from its representation (a float of no meaning by itself): adding the
/// rounding sum's bits shifted by 20 (n·2^23 + j·2^20) gives 2^(n + j/8)'s.
inline constexpr std::array<float, 8> exp2_8th_less_index = [] {
    std::array<float, 8> t{};
    for (std::uint32_t j = 0; j < 8; ++j) t[j] = std::bit_cast<float>(std::bit_cast<std::uint32_t>(exp2_8th[j]) - (j << 20));
    return t;
}();

/// 2^x for x in [exp2_lowest<T>, 0], lane by lane (no check of the range: see above). `V` is T or a
/// GCC/Clang vector of T; `U` the unsigned integer (or integer vector) of the same size.
/// Float with exp2_float_eighths: x = n + j/8 + r with n + j/8 the nearest multiple of 1/8 (j in [0, 8)),
/// r in [−1/16, 1/16] exact; 2^r = 1 + r·q(r), q the degree-2 polynomial interpolating (2^r − 1)/r at the
/// Chebyshev nodes of [−1/16, 1/16] (relative error of 1 + r·q below 0.32·2^−23 with its float
/// coefficients, in exact arithmetic; mpmath); 2^x = t + (t·r)·q with t = 2^(j/8)·2^n, the table entry
/// (one permute of a register) with n added to its exponent field. 4 multiply-adds instead of the
/// polynomial's 6 and a permute more: 10 operations instead of 11, two fewer on the multiply-add ports
/// (issue 14: the light-plane taps at x86-64-v3 are bound by their operation count). Within 2 ulp of a
/// correctly rounded 2^x (tests/test_simd_exp.cpp): 1.31 ulp worst over every float in [−125, 0] with FMA
/// (the polynomial: 0.99), 1.54 without; near 2^−125 t·r can be subnormal, which costs up to half an ulp.
template <class T, class V, class U = unsigned_lanes_t<T, V>>
[[nodiscard]] inline V exp2_nonpositive(V x) noexcept {
    static_assert(std::is_floating_point_v<T> && sizeof(V) == sizeof(U));
    constexpr bool single = sizeof(T) == 4;
    constexpr int mantissa_bits = single ? 23 : 52;
    if constexpr (single && exp2_float_eighths) {
        // 1.5·2^20: the sum's last place is 1/8, so it rounds x to n + j/8; its representation's low bits are
        // then 2^22 + 8n + j (x ≥ −125 keeps it positive), j the low 3 of them.
        constexpr T round_magic = T(1572864.0);
        const V shifted = x + round_magic;
        const V r = x - (shifted - round_magic);  // exact: r in [−1/16, 1/16]
        const U bits = std::bit_cast<U>(shifted);
        // t = exp2_8th[j]·2^n (the scaling exact): the table entry's bits less j·2^20 (exp2_8th_less_index)
        // plus the sum's bits shifted by 20, n·2^23 + j·2^20 (the constant's own bits shift out); scaling
        // before the polynomial takes the exponent's integer work off the end of the chain.
        U tb;
        if constexpr (std::is_same_v<V, T>) {
            tb = std::bit_cast<U>(exp2_8th_less_index[bits & 7u]);  // in bounds whatever the bits
        } else {
#if AAF_SIMD_BYTES >= 32 && defined(__GNUC__) && !defined(__clang__)
            // Repeated to the lanes' count: the permute takes the index modulo the lanes (8 or 16). Built
            // from a pack, so that it is a constant: a loop of stores was rebuilt per call by GCC 12 at
            // -O2 -march=native (30 % slower light plane there).
            constexpr std::size_t lanes = sizeof(V) / sizeof(T);
            static_assert(lanes % 8 == 0, "the eighths table needs a multiple of 8 lanes");
            const V table = []<std::size_t... l>(std::index_sequence<l...>) {
                return V{exp2_8th_less_index[l % 8]...};
            }(std::make_index_sequence<lanes>{});
            tb = std::bit_cast<U>(__builtin_shuffle(table, bits));
#endif
        }
        const V t = std::bit_cast<V>(tb + (bits << (mantissa_bits - 3)));
        V q = V{} + T(0x1.c6b8bep-5);
        q = q * r + T(0x1.ec0aa6p-3);
        q = q * r + T(0x1.62e430p-1);
        const V tr = t * r;
        return tr * q + t;
    } else {
        // Adding 1.5·2^p (p = mantissa bits) rounds a value of magnitude < 2^(p−1) to an integer n, which is
        // then the low bits of the sum's representation; the constant's own bits vanish when shifted into
        // the exponent field (its low p − 11 bits are 0), so the sum's bits shifted are n's.
        constexpr T round_magic = single ? T(12582912.0) : T(6755399441055744.0);
        const V shifted = x + round_magic;
        const V r = x - (shifted - round_magic);  // exact: r in [−1/2, 1/2]
        const V p = exp2_reduced<T>(r);
        // 2^r·2^n: n added to the exponent field of 2^r (in [0.7, 1.42]), in unsigned arithmetic (wraps).
        return std::bit_cast<V>(std::bit_cast<U>(p) + (std::bit_cast<U>(shifted) << mantissa_bits));
    }
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
/// libm, narrower vectors) the scalar std::exp loop runs; double lanes: exp_negated_vectors_double.
#if AAF_SIMD_BYTES >= 32 && defined(__GLIBC__) && (__GLIBC__ > 2 || (__GLIBC__ == 2 && __GLIBC_MINOR__ >= 27))
inline constexpr bool exp_negated_vectors = true;
#else
inline constexpr bool exp_negated_vectors = false;
#endif

/// Whether exp_negated_as_std computes double lanes in vectors: with 32- or 64-byte vectors, against glibc
/// 2.28 or later, whose exp (ARM's optimized-routines algorithm, sysdeps/ieee754/dbl-64/e_exp.c) is within
/// 0.511 ulp of e^x: its documented bound, "ulp error: 0.509 (0.511 without fma)" (e_exp_data.c), derived
/// in e_exp.c as 0.5 + 1.11/N + (polynomial error)·2^53 ulp with N = 128, plus 0.25/N ulp without FMA.
/// aaf relies on that bound (docs/DEVIATIONS.md); tests/test_simd_exp.cpp checks the agreement on random
/// and edge inputs, and 4·10^9 random inputs were checked once (docs/BENCHMARKS.md, "Issue 14: double").
#if AAF_SIMD_BYTES >= 32 && defined(__GLIBC__) && (__GLIBC__ > 2 || (__GLIBC__ == 2 && __GLIBC_MINOR__ >= 28))
inline constexpr bool exp_negated_vectors_double = true;
#else
inline constexpr bool exp_negated_vectors_double = false;
#endif

/// 2^(j/32) = exp2_32nd_hi[j] + exp2_32nd_lo[j] for j in [0, 32): the high part rounded to 26 significant
/// bits (so that its product with a 26-bit number is exact in double), the low part the rest rounded to
/// double (relative error of the sum below 2^−79). Computed for aaf with 200-digit decimal arithmetic
/// (Python's decimal module: exp(j·ln 2/32)).
inline constexpr double exp2_32nd_hi[32] = {
    0x1.0000000000000p+0, 0x1.059b0d0000000p+0, 0x1.0b55870000000p+0, 0x1.11301d0000000p+0,
    0x1.172b840000000p+0, 0x1.1d48730000000p+0, 0x1.2387a70000000p+0, 0x1.29e9df8000000p+0,
    0x1.306fe08000000p+0, 0x1.371a738000000p+0, 0x1.3dea650000000p+0, 0x1.44e0860000000p+0,
    0x1.4bfdad8000000p+0, 0x1.5342b58000000p+0, 0x1.5ab07e0000000p+0, 0x1.6247eb0000000p+0,
    0x1.6a09e68000000p+0, 0x1.71f75e8000000p+0, 0x1.7a11470000000p+0, 0x1.8258998000000p+0,
    0x1.8ace540000000p+0, 0x1.93737b0000000p+0, 0x1.9c49180000000p+0, 0x1.a5503b0000000p+0,
    0x1.ae89f98000000p+0, 0x1.b7f76f0000000p+0, 0x1.c199be0000000p+0, 0x1.cb720e0000000p+0,
    0x1.d5818e0000000p+0, 0x1.dfc9730000000p+0, 0x1.ea4afa0000000p+0, 0x1.f507658000000p+0};
inline constexpr double exp2_32nd_lo[32] = {
    0x0.0p+0, 0x1.8ac2ba1d73e2ap-27, -0x1.833b784eb3a37p-27, 0x1.25b50a4ebbf1bp-32, -0x1.c15742919041cp-27,
    0x1.68b9aa7805b80p-28, -0x1.8a9dc7993e052p-28, -0x1.70108f69ed175p-27, 0x1.18db8a96f46adp-27,
    -0x1.8aac6ab1d7560p-29, -0x1.f6e5eee525f6fp-27, 0x1.8624b40c4dbd0p-30, -0x1.64eaec715e343p-27,
    -0x1.62b07e20f57c4p-28, -0x1.5bd5eb539b67fp-27, 0x1.d2ac258f87d03p-31, -0x1.80c4336f74d05p-28,
    0x1.d8bee7ba46e1ep-29, 0x1.f580c36bea881p-27, 0x1.4cce128acf88bp-28, 0x1.15506dadd3e2bp-27,
    0x1.9b8bc9e8a0388p-29, 0x1.51f8480e3e236p-27, 0x1.1f12ae45a1225p-27, 0x1.5ad3ad5e8734dp-28,
    0x1.7daf237553d84p-27, -0x1.3d56b1eeef9a7p-27, -0x1.8837cb757e1a1p-27, -0x1.822dbc6d12fd3p-27,
    0x1.bdcdaf5cb4656p-27, 0x1.52486cc2c7b9dp-27, 0x1.b722a033a7c26p-27};

#if AAF_SIMD_BYTES >= 32
/// Whether any lane of a vector of 64-bit masks (0 or all bits) is set: one instruction on the vectors'
/// ISA (the generic lane loop was scalarised by GCC 12).
template <class VI>
[[nodiscard]] inline bool any_lane_set(VI m) noexcept {
#if AAF_SIMD_BYTES == 64 && defined(__AVX512F__) && !defined(__clang__)  // (GCC's builtin)
    typedef long long v8di __attribute__((vector_size(64)));
    return __builtin_ia32_ptestmq512(std::bit_cast<v8di>(m), std::bit_cast<v8di>(m), 0xff) != 0;
#elif AAF_SIMD_BYTES == 32 && defined(__AVX__)
    typedef double v4df __attribute__((vector_size(32)));
    return __builtin_ia32_movmskpd256(std::bit_cast<v4df>(m)) != 0;
#else
    bool any = false;
    for (std::size_t l = 0; l < sizeof(VI) / 8; ++l) any = any | (m[l] != 0);
    return any;
#endif
}

/// The lanes of a vector of 64-bit masks (0 or all bits) as the low bits of an integer (lane l: bit l).
template <class VI>
[[nodiscard]] inline unsigned lane_bits(VI m) noexcept {
#if AAF_SIMD_BYTES == 64 && defined(__AVX512F__) && !defined(__clang__)  // (GCC's builtin)
    typedef long long v8di __attribute__((vector_size(64)));
    return __builtin_ia32_ptestmq512(std::bit_cast<v8di>(m), std::bit_cast<v8di>(m), 0xff);
#elif AAF_SIMD_BYTES == 32 && defined(__AVX__)
    typedef double v4df __attribute__((vector_size(32)));
    return static_cast<unsigned>(__builtin_ia32_movmskpd256(std::bit_cast<v4df>(m)));
#else
    unsigned bits = 0;
    for (std::size_t l = 0; l < sizeof(VI) / 8; ++l) bits |= (m[l] != 0 ? 1u : 0u) << l;
    return bits;
#endif
}

/// e^x in double lanes for x in (−512, 0], rounded to nearest, and `exact`: the lanes where that result is
/// certainly std::exp(x)'s bits (glibc ≥ 2.28; see exp_negated_vectors_double); other lanes' results are
/// meaningless. x = k·ln 2/32 + r (k the nearest integer to 32x/ln 2, |r| ≤ ln 2/64), e^x = 2^(k/32)·e^r,
/// carried in two doubles (double-double) to a relative error below 2^−62 (0.002 ulp):
/// * r = rh + rl: ln 2/32 in three parts, the first two of 38 bits so that k·part is exact for |k| < 2^15;
///   x − k·part1 is exact (Sterbenz), the subtraction of k·part2 is an exact TwoSum; error below 2^−100.
/// * e^r = 1 + rh + q + rl·(1 + rh), q = rh²·(1/2 + rh/6 + … + rh^6/8!) in double: truncation below 2^−76,
///   q < 2^−14 with rounding errors below 2^−65.
/// * rh = rhh + (rh − rhh), rhh rounded to a multiple of 2^−32 (26 bits), so that hi·rhh is exact with the
///   table's 26-bit high part hi; the rest ul (< 2^−13.9) is added in double (errors below 2^−63 in all).
/// * z = hi + hi·rhh (exact Fast2Sum) + [hi·ul + lo·(1 + rhh + ul)], and a final Fast2Sum gives y = yh + yl
///   with yh = y rounded to nearest and yl exact; then yh·2^(k div 32) by adding to the exponent field.
/// Every product is either exact or only rounded, and only additions must be exact, so a compiler that
/// fuses a multiply and an add (FMA contraction, GCC's default) changes no bound.
/// `exact`: |yl| < (1/2 − 1/64)·ulp(yh), yh not a power of two (where the spacing below halves), x in
/// (−512, 0] (glibc's main path; a normal result). Then e^x lies more than 1/64 − 0.002 > 0.013 ulp from
/// every midpoint between doubles, so it rounds to yh, and an exp within 0.511 ulp returns yh: every other
/// double is more than 0.513 ulp from e^x. About 3 % of lanes fail the test (they call std::exp).
typedef double f64_lanes __attribute__((vector_size(simd_bytes)));
typedef std::int64_t i64_lanes __attribute__((vector_size(simd_bytes)));
[[nodiscard]] inline f64_lanes exp_nonpositive_dd(f64_lanes x, i64_lanes& exact) noexcept {
    using VD = f64_lanes;
    typedef std::uint64_t vu __attribute__((vector_size(simd_bytes)));
    constexpr double shift = 0x1.8p52;  // adding it rounds to an integer, held in the low bits
    const VD t = x * 0x1.71547652b82fep+5 + shift;  // 32/ln 2
    const VD kd = t - shift;
    const VD r1 = x - kd * 0x1.62e42fefa0000p-6;  // exact (ln 2/32, first 38 bits)
    const VD k2 = kd * -0x1.cf79abc9e0000p-45;   // exact (next 38 bits)
    const VD rh = r1 + k2;                        // TwoSum(r1, k2)
    const VD bv = rh - r1;
    const VD rl = ((r1 - (rh - bv)) + (k2 - bv)) - kd * 0x1.d9cc01f97b57ap-84;
    VD p = VD{} + 1.0 / 40320.0;
    p = p * rh + 1.0 / 5040.0;
    p = p * rh + 1.0 / 720.0;
    p = p * rh + 1.0 / 120.0;
    p = p * rh + 1.0 / 24.0;
    p = p * rh + 1.0 / 6.0;
    p = p * rh + 0.5;
    const VD q = (rh * rh) * p;
    const VD rhh = (rh + 0x1.8p20) - 0x1.8p20;  // a multiple of 2^−32
    const VD ul = (rh - rhh) + (q + rl * (1.0 + rh));
    const vu ku = std::bit_cast<vu>(t) - std::bit_cast<vu>(VD{} + shift);  // k (unsigned: wraps, defined)
    VD hi, lo;
    for (std::size_t l = 0; l < sizeof(VD) / 8; ++l) {
        const std::size_t j = static_cast<std::size_t>(ku[l] & 31u);
        hi[l] = exp2_32nd_hi[j], lo[l] = exp2_32nd_lo[j];
    }
    const VD hr = hi * rhh;  // exact
    const VD zh = hi + hr;   // Fast2Sum(hi, hr): |hi| ≥ |hr|
    const VD zl = hr - (zh - hi);
    const VD m = (zl + (hi * ul + (lo + lo * (rhh + ul))));
    const VD yh = zh + m;  // Fast2Sum(zh, m)
    const VD yl = m - (yh - zh);
    const vu bits = std::bit_cast<vu>(yh);
    const VD pow2 = std::bit_cast<VD>(bits & 0x7ff0000000000000u);  // 2^e ≤ yh; ulp(yh) = 2^(e−52)
    const VD ayl = std::bit_cast<VD>(std::bit_cast<vu>(yl) & 0x7fffffffffffffffu);
    exact = (x > -512.0) & (x <= 0.0) & (ayl < pow2 * (0x1p-53 - 0x1p-58)) & (yh != pow2);
    // yh·2^(k div 32): k div 32 added to the exponent field (bits 5… of k shifted there; high bits drop).
    return std::bit_cast<VD>(bits + ((ku >> 5) << 52));
}
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
/// Where exp_negated_vectors_double holds, double lanes compute e^−a in double-double (exp_nonpositive_dd)
/// and keep its rounding where that is certainly glibc's; the other lanes (~3 %) call std::exp.
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
            if (any_lane_set(scalar)) [[unlikely]]
                for (std::size_t l = 0; l < L; ++l)
                    if (scalar[l]) o[l] = std::exp(-a[i + l]);
            std::memcpy(out + i, &o, sizeof o);
        }
    }
    if constexpr (exp_negated_vectors_double && std::is_same_v<T, double>) {
        constexpr std::size_t L = simd_bytes / 8;  // doubles per vector
        using vd = f64_lanes;
        using vi = i64_lanes;
        // In chunks: the vectors first, without a branch, noting the lanes that need std::exp; then those
        // lanes. (A branch per vector on the lanes' test, taken by ~20 % of 8-lane vectors, resolved only at
        // the end of the vector's long dependency chain: the mispredictions cost as much as the arithmetic.)
        constexpr std::size_t chunk = 32;  // vectors
        const std::size_t whole = n - n % L;
        while (i < whole) {
            const std::size_t begin = i, end = std::min(whole, i + chunk * L);
            unsigned char need[chunk];  // per vector: bit l set if lane l calls std::exp
            std::size_t c = 0;
            for (; i < end; i += L, ++c) {
                vd av, ff;
                std::memcpy(&av, a + i, sizeof av);
                std::memcpy(&ff, full + i, sizeof ff);
                vi exact;
                const vd y = exp_nonpositive_dd(-av, exact);
                const vi has = ff > 0.0;
                need[c] = static_cast<unsigned char>(lane_bits(has & ~exact));
                const vd o = has ? y : vd{};
                std::memcpy(out + i, &o, sizeof o);
            }
            for (std::size_t v = 0; v < c; ++v)
                for (unsigned bits = need[v]; bits != 0; bits &= bits - 1) {
                    const std::size_t at = begin + v * L + static_cast<std::size_t>(std::countr_zero(bits));
                    out[at] = std::exp(-a[at]);
                }
        }
    }
#endif
    for (; i < n; ++i) out[i] = full[i] > T(0) ? std::exp(-a[i]) : T(0);
}

}  // namespace detail
}  // namespace v0
}  // namespace aaf
