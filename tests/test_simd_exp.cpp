// SPDX-License-Identifier: MIT
// aaf::detail::exp_nonpositive (simd_exp.hpp), the light-plane filter's weight and (with its subnormal
// range) the subsurface profile sum's exponential: its error against a higher-precision exp, its limits,
// and the scalar and vector forms computing the same bits.

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

/// e^x rounded to T from a wider type (double for float, long double for double: x87's 64-bit mantissa
/// on x86-64; where long double is double the reference is std::exp itself, off by at most ~1 ulp).
template <class T>
T reference_exp(T x) {
    if constexpr (sizeof(T) == 4) return static_cast<T>(std::exp(static_cast<double>(x)));
    else return static_cast<T>(std::exp(static_cast<long double>(x)));
}

template <class T>
T fast_exp(T x) {
    return aaf::detail::exp_nonpositive<T, T, std::make_unsigned_t<int_of<T>>>(x);
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

TEMPLATE_TEST_CASE("simd_exp: exp_nonpositive is within 2 ulp of e^x; below e^-86.6 (float) it is 0", "[filter][simd_exp]",
                   float, double) {
    using T = TestType;
    // The flush threshold: results down to it are normal numbers.
    const T lowest = sizeof(T) == 4 ? T(-86.6) : T(-707.7);
    check_exp_accuracy<T>(lowest);
    // Around the Gaussian's range (x = −d²/(2β²) in [−4.5, 0] for a truncation of 3), densely.
    check_exp_accuracy<T>(T(-4.5));
    // Below: 0, where e^x is below 2.5e-38 (float) or 4.5e-308 (double).
    for (int i = 1; i <= 1000; ++i) {
        const T x = lowest - T(0.01) * static_cast<T>(i);
        CHECK(fast_exp(x) == T(0));
        CHECK(reference_exp(x) <= (sizeof(T) == 4 ? T(2.5e-38) : T(4.5e-308)));
    }
}

TEMPLATE_TEST_CASE("simd_exp: exp_nonpositive at its limits", "[filter][simd_exp]", float, double) {
    using T = TestType;
    constexpr T inf = std::numeric_limits<T>::infinity(), nan = std::numeric_limits<T>::quiet_NaN();
    CHECK(fast_exp(T(0)) == T(1));
    CHECK(fast_exp(T(-0.0)) == T(1));
    CHECK(fast_exp(-inf) == T(0));
    CHECK(fast_exp(std::numeric_limits<T>::lowest()) == T(0));
    CHECK(fast_exp(T(-800)) == T(0));
    CHECK(std::isnan(fast_exp(nan)));
    CHECK(fast_exp(T(1e-30)) == T(1));  // outside the domain: clamped to e^0
    CHECK(fast_exp(-std::numeric_limits<T>::denorm_min()) == T(1));
}

TEMPLATE_TEST_CASE("simd_exp: the subnormal range follows e^x until it rounds to 0", "[filter][simd_exp][subsurface]", float,
                   double) {
    using T = TestType;
    using aaf::detail::exp_range;
    const auto sub = [](T x) { return aaf::detail::exp_nonpositive_of<T, exp_range::subnormal>(x); };
    constexpr T tiny = std::numeric_limits<T>::denorm_min(), smallest_normal = std::numeric_limits<T>::min();
    const T lowest = sizeof(T) == 4 ? T(-104.0) : T(-745.2);
    // Where the result is normal: the default range's bits (the same polynomial; both scalings are exact there).
    const T flush = sizeof(T) == 4 ? T(-86.6) : T(-707.7);
    std::size_t differ = 0;
    for (int i = 0; i <= 20000; ++i) {
        const T x = flush * static_cast<T>(i) / T(20000);
        if (ulps(sub(x), fast_exp(x)) != 0) ++differ;
    }
    CHECK(differ == 0);
    // Below the smallest normal result: within 2 ulp of the normal result's scale plus one subnormal step.
    T worst = 0, worst_x = 0;
    for (int i = 0; i <= 20000; ++i) {
        const T x = flush + (lowest - flush) * static_cast<T>(i) / T(20000);
        const T want = reference_exp(x);
        const T err = std::abs(sub(x) - want) - T(2) * std::numeric_limits<T>::epsilon() * want;
        if (err > worst) worst = err, worst_x = x;
    }
    INFO("worst error beyond 2 ulp: " << worst / tiny << " subnormal steps at x = " << worst_x);
    CHECK(worst <= tiny);
    // e^x is half the smallest subnormal at −745.13 (double) and −103.97 (float): above it, not 0.
    CHECK(sub(sizeof(T) == 4 ? T(-103.5) : T(-744.8)) > T(0));
    CHECK(sub(lowest) == T(0));
    CHECK(sub(lowest * T(1.001)) == T(0));
    CHECK(sub(-std::numeric_limits<T>::infinity()) == T(0));
    CHECK(std::isnan(sub(std::numeric_limits<T>::quiet_NaN())));
    CHECK(sub(T(0)) == T(1));
    CHECK(sub(flush) >= smallest_normal);
}

#if AAF_SIMD_BYTES > 0
TEMPLATE_TEST_CASE("simd_exp: the vector form computes the scalar form's bits in every lane", "[filter][simd_exp]", float,
                   double) {
    using T = TestType;
    using S = aaf::detail::simd<T>;
    constexpr std::size_t N = S::lanes;
    std::vector<T> xs;
    for (int i = 0; i <= 40000; ++i) xs.push_back(T(-90) * static_cast<T>(i) / T(40000));
    for (int i = 0; i <= 4000; ++i) xs.push_back(T(-800) * static_cast<T>(i) / T(4000));
    xs.push_back(std::numeric_limits<T>::quiet_NaN());
    xs.push_back(-std::numeric_limits<T>::infinity());
    while (xs.size() % N) xs.push_back(T(-1));
    std::size_t differ = 0;
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
