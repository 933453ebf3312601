// SPDX-License-Identifier: MIT
#pragma once
// Explicit vectors for aaf's hot loops (the filter's taps, slope spreading): GCC/Clang vector extensions
// sized to the widest registers the translation unit is compiled for, and a portable fallback.
//
// Why not rely on the auto-vectoriser: the filter's lane loops vectorised well at -march=native with
// AVX-512 (masked blends) but 3-6x worse at -march=x86-64-v3 and at plain -O2, where GCC kept the lanes'
// state in memory and split the masks by width (docs/BENCHMARKS.md, issue 14). With explicit vectors the
// lanes' state stays in registers for a whole kernel and the masks have the data's width on every ISA.
//
// AAF_SIMD_BYTES (define before including aaf) overrides the vector width in bytes (16, 32 or 64); 0
// disables the explicit vectors (the portable per-lane loops run instead). By default: 64 with AVX-512F,
// 32 with AVX, 16 otherwise (SSE2 on x86-64, NEON on AArch64), 0 for compilers without vector extensions.
// Widths wider than the target's registers are legal but slow (the compiler splits every operation).

#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <type_traits>
#include <utility>

#ifndef AAF_SIMD_BYTES
#if defined(__GNUC__) || defined(__clang__)
#if defined(__AVX512F__)
#define AAF_SIMD_BYTES 64
#elif defined(__AVX__)
#define AAF_SIMD_BYTES 32
#else
#define AAF_SIMD_BYTES 16
#endif
#else
#define AAF_SIMD_BYTES 0
#endif
#endif

namespace aaf {
inline namespace v0 {
namespace detail {

/// Bytes per explicit vector (0: none; the portable loops run).
inline constexpr std::size_t simd_bytes = AAF_SIMD_BYTES;

#if AAF_SIMD_BYTES > 0

/// Vectors of T with lanes = simd_bytes / sizeof(T): `vec` holds values, `mask` the result of a comparison
/// (all bits set where true, the same width as T so that selects cost one instruction), `id` the lanes'
/// 32-bit object IDs (converted to a `mask` after comparing).
template <class T>
struct simd {
    static constexpr std::size_t lanes = simd_bytes / sizeof(T);
    using mask_int = std::conditional_t<sizeof(T) == 8, std::int64_t, std::int32_t>;
    typedef T vec __attribute__((vector_size(simd_bytes)));
    typedef mask_int mask __attribute__((vector_size(simd_bytes)));
    typedef std::uint32_t id __attribute__((vector_size(lanes * sizeof(std::uint32_t))));

    /// Unaligned load of `lanes` elements (memcpy: no alignment or aliasing assumption; one instruction).
    template <class V, class U>
    [[nodiscard]] static V load(const U* p) noexcept {
        V v;
        std::memcpy(&v, p, sizeof v);
        return v;
    }
    [[nodiscard]] static vec load(const T* p) noexcept { return load<vec>(p); }
    static void store(T* p, vec v) noexcept { std::memcpy(p, &v, sizeof v); }
    /// x in every lane, bit for bit: x − (+0) is x for every x, −0 included (0 + x, the obvious form, gives +0
    /// for −0, and GCC keeps the add for that case).
    [[nodiscard]] static vec splat(T x) noexcept { return x - vec{}; }
    /// a where m, else b (per lane).
    [[nodiscard]] static vec select(mask m, vec a, vec b) noexcept { return m ? a : b; }
    /// Lanes whose IDs are equal, as a mask of T's width.
    [[nodiscard]] static mask equal(id a, id b) noexcept {
        if constexpr (sizeof(T) == sizeof(std::uint32_t)) {
            return a == b;
        } else {
#if defined(__AVX2__) && AAF_SIMD_BYTES == 32 && defined(__GNUC__) && !defined(__clang__)
            // Double with AVX2: widen the IDs to 64 bits (one vpmovzxdq, fused with the load), then compare.
            // GCC 12 splits __builtin_convertvector(int32×4 → int64×4) into four instructions, and does not
            // see the converted comparison as a mask, so each select costs two compares with zero more: the
            // double image-space filter measured 2.1x the float one at -march=x86-64-v3 (issue 14).
            typedef int v4si __attribute__((vector_size(16)));
            return reinterpret_cast<mask>(__builtin_ia32_pmovzxdq256(reinterpret_cast<v4si>(a)) ==
                                          __builtin_ia32_pmovzxdq256(reinterpret_cast<v4si>(b)));
#elif defined(__AVX512F__) && AAF_SIMD_BYTES == 64
            // Double with AVX-512: widen the IDs to 64 bits (one vpmovzxdq, fused with the load) and compare
            // those, which gives the lanes' mask register directly. Comparing the 32-bit IDs and converting
            // the result took a compare into a vector and two sign extensions per tap, and GCC 12 then kept
            // the vertical pass's four groups in memory: its taps measured 2.8x the float ones (issue 14).
            typedef std::uint32_t narrow __attribute__((vector_size(simd_bytes / 2)));
            typedef std::uint64_t wide __attribute__((vector_size(simd_bytes)));
            return reinterpret_cast<mask>(__builtin_convertvector(reinterpret_cast<narrow>(a), wide) ==
                                          __builtin_convertvector(reinterpret_cast<narrow>(b), wide));
#else
            return __builtin_convertvector(a == b, mask);
#endif
        }
    }
    /// Splits 3·lanes interleaved (x, y, z) values at `p` into three vectors (two two-source shuffles per
    /// component: lane l of component c is element 3l + c of the three loads a|b|c).
    static void deinterleave3(const T* p, vec& x, vec& y, vec& z) noexcept {
        const vec a = load(p), b = load(p + lanes), c = load(p + 2 * lanes);
        constexpr auto seq = std::make_index_sequence<lanes>{};
        x = component<0>(a, b, c, seq), y = component<1>(a, b, c, seq), z = component<2>(a, b, c, seq);
    }
    template <std::size_t C, std::size_t... L>
    [[nodiscard]] static vec component(vec a, vec b, vec c, std::index_sequence<L...>) noexcept {
        const vec ab = __builtin_shufflevector(a, b, static_cast<int>(3 * L + C < 2 * lanes ? 3 * L + C : 0)...);
        return __builtin_shufflevector(ab, c, static_cast<int>(3 * L + C < 2 * lanes ? L : 3 * L + C - lanes)...);
    }
    /// Whether any lane of `m` is set.
    [[nodiscard]] static bool any(mask m) noexcept {
        mask_int a = 0;
        for (std::size_t i = 0; i < lanes; ++i) a |= m[i];
        return a != 0;
    }
    /// |x| <= the largest finite T: false for ±Inf and NaN (the scalar `std::abs(x) <= max` test).
    [[nodiscard]] static mask finite(vec x) noexcept {
        constexpr mask_int magnitude = static_cast<mask_int>(~(std::make_unsigned_t<mask_int>(1) << (8 * sizeof(T) - 1)));
        const vec a = std::bit_cast<vec>(std::bit_cast<mask>(x) & magnitude);
        return a <= splat(std::numeric_limits<T>::max());
    }
    /// √x per lane: the ISA's vector instruction on x86 (a loop over std::sqrt stays scalar: it may set
    /// errno), lane by lane elsewhere. Correctly rounded either way, so the same bits as std::sqrt.
    [[nodiscard]] static vec sqrt(vec x) noexcept {
#if defined(__x86_64__) && AAF_SIMD_BYTES == 64 && defined(__AVX512F__) && defined(__clang__)
        if constexpr (sizeof(T) == 8) return __builtin_ia32_sqrtpd512(x, 4);
        else return __builtin_ia32_sqrtps512(x, 4);
#elif defined(__x86_64__) && AAF_SIMD_BYTES == 64 && defined(__AVX512F__)
        // The masked form with x as its own source: the unmasked intrinsics' undefined source trips GCC 12's
        // -Wmaybe-uninitialized.
        if constexpr (sizeof(T) == 8) return __builtin_ia32_sqrtpd512_mask(x, x, static_cast<unsigned char>(0xff), 4);
        else return __builtin_ia32_sqrtps512_mask(x, x, static_cast<unsigned short>(0xffff), 4);
#elif defined(__x86_64__) && AAF_SIMD_BYTES == 32 && defined(__AVX__)
        if constexpr (sizeof(T) == 8) return __builtin_ia32_sqrtpd256(x);
        else return __builtin_ia32_sqrtps256(x);
#elif defined(__x86_64__) && AAF_SIMD_BYTES == 16
        if constexpr (sizeof(T) == 8) return __builtin_ia32_sqrtpd(x);
        else return __builtin_ia32_sqrtps(x);
#else
        for (std::size_t l = 0; l < lanes; ++l) x[l] = std::sqrt(x[l]);
        return x;
#endif
    }
};

#endif

/// x[i] = √x[i] for i < n: whole vectors through simd<T>::sqrt, the rest one at a time. The same
/// correctly rounded results as std::sqrt, which GCC does not vectorise while it may set errno (unless the
/// user builds with -fno-math-errno). A negative or NaN input gives NaN either way.
template <class T>
void sqrt_each(T* x, std::size_t n) noexcept {
    std::size_t i = 0;
#if AAF_SIMD_BYTES > 0
    using S = simd<T>;
    for (; i + S::lanes <= n; i += S::lanes) S::store(x + i, S::sqrt(S::load(x + i)));
#endif
    for (; i < n; ++i) x[i] = std::sqrt(x[i]);
}

}  // namespace detail
}  // namespace v0
}  // namespace aaf
