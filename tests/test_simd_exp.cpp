// SPDX-License-Identifier: MIT
// aaf::detail::exp2_nonpositive (simd_exp.hpp), the light-plane filter's weight: its error against a
// higher-precision 2^x, its limits, and the scalar and vector forms (detail::light_plane_weight) computing
// the same bits. And exp_nonpositive, e^x into the subnormals (the subsurface profile sum's).

#include <catch2/catch.hpp>

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include <aaf/filter.hpp>
#include <aaf/simd_exp.hpp>

namespace {

template <class T>
using int_of = std::conditional_t<sizeof(T) == 8, std::int64_t, std::int32_t>;

/// Distance in units in the last place between two non-negative finite T (0 = same bits).
template <class T>
std::int64_t ulps(T a, T b) {
    const auto ia = static_cast<std::int64_t>(std::bit_cast<int_of<T>>(a));
    const auto ib = static_cast<std::int64_t>(std::bit_cast<int_of<T>>(b));
    return ia > ib ? ia - ib : ib - ia;
}

/// 2^x rounded to T from a wider type (double for float, long double for double: x87's 64-bit mantissa
/// on x86-64; where long double is double the reference is std::exp2 itself, off by at most ~1 ulp).
template <class T>
T reference_exp(T x) {
    if constexpr (sizeof(T) == 4) return static_cast<T>(std::exp2(static_cast<double>(x)));
    else return static_cast<T>(std::exp2(static_cast<long double>(x)));
}

template <class T>
T fast_exp(T x) {
    return aaf::detail::exp2_nonpositive<T>(x);
}

template <class T>
void check_exp_accuracy(T lowest_normal_result) {
    std::int64_t worst = 0;
    T worst_x = 0;
    const int n = 200000;
    for (int i = 0; i <= n; ++i) {
        const T x = lowest_normal_result * static_cast<T>(i) / static_cast<T>(n);
        const T got = fast_exp(x), want = reference_exp(x);
        const std::int64_t u = ulps(got, want);
        if (u > worst) worst = u, worst_x = x;
    }
    INFO("worst " << worst << " ulp at x = " << worst_x);
    CHECK(worst <= 2);
}

}  // namespace

TEMPLATE_TEST_CASE("simd_exp: exp2_nonpositive is within 2 ulp of 2^x down to 2^-125 (float); the weight "
                   "drops taps below it",
                   "[filter][simd_exp]", float, double) {
    using T = TestType;
    const T lowest = aaf::detail::exp2_lowest<T>;
    check_exp_accuracy<T>(lowest);
    // Around the Gaussian's range (x = −log2(e)·d²/(2β²) in [−6.5, 0] for a truncation of 3), densely.
    check_exp_accuracy<T>(T(-6.5));
    // The weight below the domain, and for NaN: NaN, which the filter's callers reject (a dropped tap).
    for (int i = 1; i <= 1000; ++i) {
        const T x = lowest - T(0.01) * static_cast<T>(i);
        CHECK(std::isnan(aaf::detail::light_plane_weight<T>(x)));
        CHECK(reference_exp(x) <= (sizeof(T) == 4 ? T(2.4e-38) : T(4.5e-308)));
    }
}

TEMPLATE_TEST_CASE("simd_exp: exp2_nonpositive and the weight at their limits", "[filter][simd_exp]", float, double) {
    using T = TestType;
    constexpr T inf = std::numeric_limits<T>::infinity(), nan = std::numeric_limits<T>::quiet_NaN();
    CHECK(fast_exp(T(0)) == T(1));
    CHECK(fast_exp(T(-0.0)) == T(1));
    CHECK(fast_exp(-std::numeric_limits<T>::denorm_min()) == T(1));
    CHECK(fast_exp(T(-1)) == T(0.5));
    CHECK(fast_exp(aaf::detail::exp2_lowest<T>) == std::ldexp(T(1), static_cast<int>(aaf::detail::exp2_lowest<T>)));
    const auto weight = [](T x) { return aaf::detail::light_plane_weight<T>(x); };
    CHECK(weight(T(0)) == T(1));
    CHECK(std::isnan(weight(-inf)));
    CHECK(std::isnan(weight(std::numeric_limits<T>::lowest())));
    CHECK(std::isnan(weight(nan)));
    CHECK(aaf::detail::light_plane_accepts<T>(aaf::detail::exp2_lowest<T>));
    CHECK_FALSE(aaf::detail::light_plane_accepts<T>(nan));
}

TEST_CASE("simd_exp: the float eighths table holds 2^(j/8) rounded to float, and the method exp2_nonpositive uses is "
          "the build's", "[filter][simd_exp]") {
    // Rounded from double's 2^(j/8) (within 1 ulp of double: far inside half a float ulp unless a value sat
    // on a float midpoint, which none of these does — mpmath at 200 bits gives the same floats).
    for (int j = 0; j < 8; ++j) CHECK(aaf::detail::exp2_8th[j] == static_cast<float>(std::exp2(j / 8.0)));
    // The table path needs AVX2's permute under GCC; elsewhere the polynomial (both pass the tests above).
#if AAF_SIMD_BYTES >= 32 && defined(__AVX2__) && defined(__GNUC__) && !defined(__clang__)
    CHECK(aaf::detail::exp2_float_eighths);
#else
    CHECK_FALSE(aaf::detail::exp2_float_eighths);
#endif
    // Every eighth from 0 to −125 in the table path is t·2^n exactly (r = 0): the rounding, the index and
    // the exponent field work at every step of the range, and 2^(−j/8) lies on the table's own values.
    for (int m = 0; m >= -1000; --m) {
        const float x = static_cast<float>(m) / 8.0f;
        const int j = ((m % 8) + 8) % 8, n = (m - j) / 8;
        const float want = aaf::detail::exp2_float_eighths ? std::ldexp(aaf::detail::exp2_8th[j], n) : fast_exp(x);
        INFO("x = " << x);
        CHECK(fast_exp(x) == want);
    }
}

TEMPLATE_TEST_CASE("simd_exp: exp_nonpositive is within 2 ulp of e^x, plus a step in the subnormals, until it rounds to 0",
                   "[simd_exp][subsurface]", float, double) {
    using T = TestType;
    const auto e = [](T x) { return aaf::detail::exp_nonpositive<T>(x); };
    // e^x rounded to T from a wider type (as reference_exp for 2^x).
    const auto want_e = [](T x) {
        if constexpr (sizeof(T) == 4) return static_cast<T>(std::exp(static_cast<double>(x)));
        else return static_cast<T>(std::exp(static_cast<long double>(x)));
    };
    constexpr T tiny = std::numeric_limits<T>::denorm_min(), eps = std::numeric_limits<T>::epsilon();
    const T lowest = sizeof(T) == 4 ? T(-104.0) : T(-745.2);
    const T last_normal = std::log(std::numeric_limits<T>::min());  // e^x normal above it
    std::int64_t worst_ulp = 0;
    T worst_steps = 0;
    for (int i = 0; i <= 200000; ++i) {
        // Densely over the normal results, then over the subnormal ones.
        const T x = i <= 150000 ? last_normal * static_cast<T>(i) / T(150000)
                                : last_normal + (lowest - last_normal) * static_cast<T>(i - 150000) / T(50000);
        const T got = e(x), want = want_e(x);
        if (want >= std::numeric_limits<T>::min()) worst_ulp = std::max(worst_ulp, ulps(got, want));
        else worst_steps = std::max(worst_steps, (std::abs(got - want) - T(2) * eps * want) / tiny);
    }
    INFO("worst " << worst_ulp << " ulp over normal results, " << worst_steps << " subnormal steps beyond 2 ulp below");
    CHECK(worst_ulp <= 2);
    CHECK(worst_steps <= 1);
    // e^x is half the smallest subnormal at −745.13 (double) and −103.97 (float): above it not 0, below 0.
    CHECK(e(sizeof(T) == 4 ? T(-103.5) : T(-744.8)) > T(0));
    CHECK(e(lowest) == T(0));
    CHECK(e(lowest * T(1.001)) == T(0));
    CHECK(e(std::numeric_limits<T>::lowest()) == T(0));
    CHECK(e(-std::numeric_limits<T>::infinity()) == T(0));
    CHECK(std::isnan(e(std::numeric_limits<T>::quiet_NaN())));
    CHECK(e(T(0)) == T(1));
    CHECK(e(T(-0.0)) == T(1));
}

#if AAF_SIMD_BYTES > 0
TEMPLATE_TEST_CASE("simd_exp: the vector form computes the scalar form's bits in every lane", "[filter][simd_exp]", float,
                   double) {
    using T = TestType;
    using S = aaf::detail::simd<T>;
    constexpr std::size_t N = S::lanes;
    std::vector<T> xs;
    for (int i = 0; i <= 40000; ++i) xs.push_back(T(-125) * static_cast<T>(i) / T(40000));
    for (int i = 0; i <= 4000; ++i) xs.push_back(aaf::detail::exp2_lowest<T> * static_cast<T>(i) / T(4000));
    while (xs.size() % N) xs.push_back(T(-1));
    std::size_t differ = 0;  // in the domain (the filter masks the other lanes with light_plane_accepts)
    for (std::size_t i = 0; i < xs.size(); i += N) {
        const typename S::vec y = aaf::detail::light_plane_weight<T>(S::load(&xs[i]));
        for (std::size_t l = 0; l < N; ++l) {
            const T scalar = aaf::detail::light_plane_weight<T>(xs[i + l]);
            const T lane = y[l];
            if (std::bit_cast<int_of<T>>(scalar) != std::bit_cast<int_of<T>>(lane) && !(std::isnan(scalar) && std::isnan(lane)))
                ++differ;
        }
    }
    CHECK(differ == 0);
}
#endif

#if AAF_SIMD_BYTES > 0
// A broadcast value is every lane's, bit for bit: a −0 splatted as 0 + x came out +0, so a vector form
// selecting −0 (a sum's neutral term that keeps −0) differed from its scalar form.
TEMPLATE_TEST_CASE("simd: splat puts the value's bits in every lane, -0 included", "[filter][simd_exp]", float, double) {
    using T = TestType;
    using S = aaf::detail::simd<T>;
    constexpr T inf = std::numeric_limits<T>::infinity();
    for (const T x : {T(-0.0), T(0), T(-1), T(0.1), std::numeric_limits<T>::denorm_min(), -std::numeric_limits<T>::denorm_min(),
                      std::numeric_limits<T>::max(), std::numeric_limits<T>::lowest(), inf, -inf}) {
        const typename S::vec v = S::splat(x);
        INFO("x = " << x << (std::signbit(x) ? " (sign bit set)" : ""));
        for (std::size_t l = 0; l < S::lanes; ++l) CHECK(std::bit_cast<int_of<T>>(T(v[l])) == std::bit_cast<int_of<T>>(x));
    }
    const typename S::vec nan = S::splat(std::numeric_limits<T>::quiet_NaN());
    for (std::size_t l = 0; l < S::lanes; ++l) CHECK(std::isnan(nan[l]));
}
#endif

// The image-space filter's m_1 = e^−a per pixel (exp_negated_as_std): the same bits as std::exp(−a) for
// every a it can be given, whichever path (vector lanes with glibc, the scalar loop elsewhere) computes it.
// A dense sample of all floats in [0, 104] (every 4099th bit pattern: ~270 000 values, each binade and the
// near-midpoint cases the vector path hands to std::exp included), the ends of the range, non-finite and
// negative a, and lanes without a kernel (0); odd lengths and offsets exercise the scalar remainder.
TEMPLATE_TEST_CASE("simd_exp: exp_negated_as_std computes std::exp(-a)'s bits", "[filter][simd_exp]", float, double) {
    using T = TestType;
    constexpr T inf = std::numeric_limits<T>::infinity(), nan = std::numeric_limits<T>::quiet_NaN();
    std::vector<T> a{T(0), T(-0.0), T(1e-30), T(0.5), T(86.999), T(87), T(87.001), T(87.5), T(103.9), T(104), T(110),
                     T(745), T(-1), T(-0.25), inf, -inf, nan, std::numeric_limits<T>::denorm_min(),
                     std::numeric_limits<T>::min()};
    const auto top = std::bit_cast<std::uint32_t>(104.0f);
    for (std::uint32_t b = 0; b <= top; b += 4099) a.push_back(static_cast<T>(std::bit_cast<float>(b)));
    std::vector<T> full;  // a kernel (3) but every 7th lane without one (0), and a NaN radius (none either)
    for (std::size_t i = 0; i < a.size(); ++i) full.push_back(i % 7 == 0 ? T(0) : i == 1 ? nan : T(3));
    for (const std::size_t offset : {std::size_t{0}, std::size_t{3}}) {
        const std::size_t n = a.size() - offset;
        std::vector<T> got(n, T(-1));
        aaf::detail::exp_negated_as_std<T>(n, full.data() + offset, a.data() + offset, got.data());
        std::size_t wrong = 0, first = n;
        for (std::size_t i = 0; i < n; ++i) {
            const T want = full[offset + i] > T(0) ? std::exp(-a[offset + i]) : T(0);
            const bool same = std::bit_cast<int_of<T>>(got[i]) == std::bit_cast<int_of<T>>(want);
            if (!same && wrong++ == 0) first = i;
        }
        INFO("vector lanes: " << aaf::detail::exp_negated_vectors << "; first difference at a = "
                              << (first < n ? a[offset + first] : T(0)));
        CHECK(wrong == 0);
    }
}

// The double lanes of exp_negated_as_std (exp_nonpositive_dd, where exp_negated_vectors_double holds): e^x
// carried in two doubles, rounded, and its bits kept only where they are certainly glibc's. Double cannot be
// checked exhaustively: ~2 million random and edge inputs here (the distributions the filter meets, a = 1/(2β²)
// for β in [0.05, 20] px, and the whole accepted range), 4·10^9 once (docs/BENCHMARKS.md, "Issue 14: double").
TEST_CASE("simd_exp: exp_negated_as_std computes std::exp(-a)'s bits in double on random and edge inputs",
          "[filter][simd_exp]") {
    std::vector<double> a{0x1p-60, 0x1p-54, 0x1.0000000000001p-54, 0x1p-53, 0x1p-52, 511.9999999999999, 512.0,
                          512.0000000000001, 0x1.62e42fefa39efp-6, 0x1.62e42fefa39efp-7, 708.0, 709.0, 745.0};
    std::uint64_t state = 0x9e3779b97f4a7c15u;  // splitmix64: the same inputs on every platform
    const auto next = [&state] {
        std::uint64_t z = (state += 0x9e3779b97f4a7c15u);
        z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9u;
        z = (z ^ (z >> 27)) * 0x94d049bb133111ebu;
        return z ^ (z >> 31);
    };
    const auto uniform = [&next] { return static_cast<double>(next() >> 11) * 0x1p-53; };  // [0, 1)
    for (int i = 0; i < 2000000; ++i) {
        switch (i % 5) {
        case 0: {
            const double beta = 0.05 + 19.95 * uniform();
            a.push_back(1.0 / (2.0 * beta * beta));
        } break;
        case 1: a.push_back(512.0 * uniform()); break;
        case 2: a.push_back(std::exp2(-60.0 + 69.0 * uniform())); break;
        case 3: a.push_back(uniform()); break;
        default: {  // next to k·ln 2/32, where the reduction's k changes
            const double k = std::floor(23700.0 * uniform());
            a.push_back(std::abs(k * 0x1.62e42fefa39efp-6 + (uniform() - 0.5) * 1e-9));
        }
        }
    }
    std::vector<double> full(a.size(), 3.0), got(a.size(), -1.0);
    aaf::detail::exp_negated_as_std<double>(a.size(), full.data(), a.data(), got.data());
    std::size_t wrong = 0, first = a.size();
    for (std::size_t i = 0; i < a.size(); ++i)
        if (std::bit_cast<std::uint64_t>(got[i]) != std::bit_cast<std::uint64_t>(std::exp(-a[i])) && wrong++ == 0) first = i;
    INFO("vector lanes: " << aaf::detail::exp_negated_vectors_double << "; first difference at a = "
                          << (first < a.size() ? a[first] : 0.0));
    CHECK(wrong == 0);
}

// The table of 2^(j/32) the double lanes use: high parts of 26 bits (their products with the reduced
// argument's 26-bit part must be exact), low parts below half the high part's last place, and the sums equal
// to 2^(j/32) within the precision a long double can check (x87's 64-bit mantissa on x86-64).
TEST_CASE("simd_exp: the double lanes' table of 2^(j/32)", "[filter][simd_exp]") {
    for (int j = 0; j < 32; ++j) {
        const double hi = aaf::detail::exp2_32nd_hi[j], lo = aaf::detail::exp2_32nd_lo[j];
        INFO("j = " << j);
        CHECK(hi * 0x1p25 == std::floor(hi * 0x1p25));
        CHECK(std::abs(lo) <= 0x1p-26);
        if constexpr (std::numeric_limits<long double>::digits >= 64) {
            const long double want = std::exp2(static_cast<long double>(j) / 32.0L);
            const long double got = static_cast<long double>(hi) + static_cast<long double>(lo);
            CHECK(std::abs(got - want) <= 0x1p-61L * want);
        }
    }
}
