// SPDX-License-Identifier: MIT
#pragma once
// Deterministic per-pixel light-sample sequences on the unit square.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>

#include <glm/vec2.hpp>

#include "config.hpp"

namespace aaf {
inline namespace v0 {

/// Which point set a pixel's light samples come from.
enum class sample_pattern {
    /// Jittered strata of equal area for *any* n (rows of ⌊√n⌋ or ⌈√n⌉ cells, row heights proportional
    /// to their cell count so every stratum has area exactly 1/n). Default.
    stratified,
    /// The same strata's centres, no jitter, identical for every pixel (Heckbert–Herf style accumulation;
    /// shows banding, which is the point of having it as a baseline).
    regular_grid,
    /// A 2-D Sobol' (0,2)-sequence with hash-based Owen scrambling per pixel (Burley 2020): every
    /// power-of-two prefix is a (0, m, 2)-net, and any n is allowed.
    low_discrepancy,
};

/// The enumerator's name ("stratified", "regular_grid", "low_discrepancy"), for logs and result files.
[[nodiscard]] constexpr const char* to_string(sample_pattern p) noexcept {
    switch (p) {
        case sample_pattern::stratified: return "stratified";
        case sample_pattern::regular_grid: return "regular_grid";
        case sample_pattern::low_discrepancy: return "low_discrepancy";
    }
    return "?";
}

/// Identifies one pixel's sequence. Samples depend on these fields only: never on thread count or tile order.
struct sample_key {
    std::uint32_t x = 0;           ///< pixel column
    std::uint32_t y = 0;           ///< pixel row
    std::uint32_t pass = 0;        ///< 0 = initial samples, 1 = first adaptive pass, ...
    std::uint32_t light = 0;       ///< light index when a frame has several lights
    std::uint32_t frame_seed = 0;  ///< change per frame to decorrelate noise over time
};

namespace detail {

/// A 32-bit integer hash with good avalanche (Wellons' "lowbias32").
[[nodiscard]] constexpr std::uint32_t hash32(std::uint32_t x) noexcept {
    x ^= x >> 16;
    x *= 0x7feb352dU;
    x ^= x >> 15;
    x *= 0x846ca68bU;
    x ^= x >> 16;
    return x;
}

[[nodiscard]] constexpr std::uint32_t hash_combine(std::uint32_t seed, std::uint32_t v) noexcept {
    return hash32(seed ^ (v + 0x9e3779b9U + (seed << 6) + (seed >> 2)));
}

[[nodiscard]] constexpr std::uint32_t key_hash(const sample_key& k) noexcept {
    std::uint32_t h = hash32(k.frame_seed ^ 0x5bd1e995U);
    h = hash_combine(h, k.x);
    h = hash_combine(h, k.y);
    h = hash_combine(h, k.pass);
    h = hash_combine(h, k.light);
    return h;
}

/// Maps 32 random bits to [0, 1) exactly representable in float (24 bits) — never returns 1.
template <class T>
[[nodiscard]] constexpr T to_unit(std::uint32_t bits) noexcept {
    return static_cast<T>(bits >> 8) * static_cast<T>(1.0 / 16777216.0);
}

[[nodiscard]] constexpr std::uint32_t reverse_bits(std::uint32_t x) noexcept {
    x = ((x >> 1) & 0x55555555U) | ((x & 0x55555555U) << 1);
    x = ((x >> 2) & 0x33333333U) | ((x & 0x33333333U) << 2);
    x = ((x >> 4) & 0x0F0F0F0FU) | ((x & 0x0F0F0F0FU) << 4);
    x = ((x >> 8) & 0x00FF00FFU) | ((x & 0x00FF00FFU) << 8);
    return (x >> 16) | (x << 16);
}

/// Laine–Karras style nested-uniform scramble of a bit-reversed value (Burley 2020, "Practical
/// Hash-based Owen Scrambling").
[[nodiscard]] constexpr std::uint32_t laine_karras(std::uint32_t x, std::uint32_t seed) noexcept {
    x += seed;
    x ^= x * 0x6c50b47cU;
    x ^= x * 0xb82f1e52U;
    x ^= x * 0xc7afe638U;
    x ^= x * 0x8d22f6e6U;
    return x;
}

[[nodiscard]] constexpr std::uint32_t owen_scramble(std::uint32_t x, std::uint32_t seed) noexcept {
    return reverse_bits(laine_karras(reverse_bits(x), seed));
}

/// Sobol' dimension 0 (van der Corput) and 1 (the Pascal-matrix dimension) as 32-bit fractions.
[[nodiscard]] constexpr std::uint32_t sobol_dim0(std::uint32_t i) noexcept { return reverse_bits(i); }
[[nodiscard]] constexpr std::uint32_t sobol_dim1(std::uint32_t i) noexcept {
    std::uint32_t result = 0;
    for (std::uint32_t v = 1U << 31; i != 0; i >>= 1, v ^= v >> 1)
        if (i & 1U) result ^= v;
    return result;
}

/// Samples per step of generate_samples' vectorisable loops (stack buffers of this many values).
inline constexpr std::uint32_t sample_chunk = 64;

/// Row layout of the equal-area strata for n samples: `rows` rows; the first `rows_with_extra` rows hold
/// `base_cols + 1` cells, the rest `base_cols`. Row heights are proportional to cell counts.
struct strata_layout {
    std::uint32_t rows = 1;
    std::uint32_t base_cols = 1;
    std::uint32_t rows_with_extra = 0;
};

[[nodiscard]] inline strata_layout make_strata(std::uint32_t n) noexcept {
    strata_layout s;
    if (n == 0) return s;
    auto rows = static_cast<std::uint32_t>(std::sqrt(static_cast<double>(n)));
    while (rows * rows > n) --rows;        // guard against sqrt rounding up
    while ((rows + 1) * (rows + 1) <= n) ++rows;
    s.rows = rows;
    s.base_cols = n / rows;
    s.rows_with_extra = n % rows;
    return s;
}

/// Moves x by whole ulps into [lo/m, hi/m) (the sign of an fma is exact). Rounding of a jittered coordinate
/// or of its row start can otherwise land a point exactly on the next stratum's edge (about
/// 4 points in 10^7 in float). Only called near an edge: see `near_stratum_edge`.
template <class T>
[[nodiscard]] T nudge_into_stratum(T x, T m, T lo, T hi) noexcept {
    while (std::fma(x, m, -lo) < T(0)) x = std::nextafter(x, T(1));
    while (std::fma(x, m, -hi) >= T(0)) x = std::nextafter(x, T(0));
    return x;
}

/// Cheap rounded test: x·m lies within `margin` (many ulps) of [lo, hi)'s ends, so rounding may have crossed one.
template <class T>
[[nodiscard]] constexpr bool near_stratum_edge(T x, T m, T lo, T hi, T margin) noexcept {
    const T t = x * m;
    return !(t > lo + margin && t < hi - margin);
}

}  // namespace detail

/// Generates the light samples of one pixel in [0, 1)², to be mapped onto the light by
/// `area_light::point(u, v)`. A pure function of (pattern, key, n): thread-safe, allocation-free.
///
/// Different passes of the same pixel (key.pass) get independent sequences; the adaptive pass therefore
/// adds *new* stratified samples rather than repeating the initial ones.
///
/// Written as short loops over up to `detail::sample_chunk` samples at a time, each doing one step for all of
/// them (hashes, Sobol' bit planes, scrambles), so that the compiler can run them in vector lanes; every
/// sample's arithmetic is the plain definition's (tests/test_sampler.cpp compares the bits with it).
template <class T = float>
void generate_samples(sample_pattern pattern, const sample_key& key, std::span<glm::vec<2, T>> out) noexcept {
    const auto n = static_cast<std::uint32_t>(out.size());
    if (n == 0) return;
    const std::uint32_t seed = detail::key_hash(key);
    constexpr std::uint32_t chunk = detail::sample_chunk;
    if (pattern == sample_pattern::low_discrepancy) {
        const std::uint32_t sx = detail::hash32(seed ^ 0x63d83595U);
        const std::uint32_t sy = detail::hash32(seed ^ 0x0b4f3a5dU);
        // Owen scrambling of each dimension decorrelates pixels and keeps every power-of-two prefix a net.
        // The index is not shuffled (Burley's index scramble only matters when padding more dimensions), so
        // only the few bits of i < n enter Sobol's second dimension. owen_scramble(x) reverses x, scrambles
        // and reverses back; dimension 0 is reverse_bits(i) and dimension 1 is built reversed (its
        // generator columns low bit first), so one reversal per dimension is left instead of three.
        std::uint32_t dim1[chunk];
        T u[chunk], v[chunk];
        for (std::uint32_t base = 0; base < n; base += chunk) {
            const std::uint32_t m = std::min(chunk, n - base);
            for (std::uint32_t k = 0; k < m; ++k) dim1[k] = 0;
            std::uint32_t column = 1;  // reversed generator column of bit b
            for (std::uint32_t b = 0; ((base + m - 1) >> b) != 0; ++b, column ^= column << 1)
                for (std::uint32_t k = 0; k < m; ++k) dim1[k] ^= column & (0U - (((base + k) >> b) & 1U));
            for (std::uint32_t k = 0; k < m; ++k) {  // in lanes: the scrambles write plain arrays
                u[k] = detail::to_unit<T>(detail::reverse_bits(detail::laine_karras(base + k, sx)));
                v[k] = detail::to_unit<T>(detail::reverse_bits(detail::laine_karras(dim1[k], sy)));
            }
            for (std::uint32_t k = 0; k < m; ++k) out[base + k] = {u[k], v[k]};
        }
        return;
    }
    const bool jittered = pattern == sample_pattern::stratified;
    T jitter_x[chunk], jitter_y[chunk];  // the jitter of samples [chunk_start, chunk_start + chunk)
    std::uint32_t chunk_start = 0;
    const auto fill_jitter = [&](std::uint32_t first) {
        chunk_start = first;
        const std::uint32_t m = std::min(chunk, n - first);
        for (std::uint32_t k = 0; k < m; ++k) {
            const std::uint32_t h = detail::hash_combine(seed, first + k);
            jitter_x[k] = detail::to_unit<T>(h);
            jitter_y[k] = detail::to_unit<T>(detail::hash32(h ^ 0x68e31da4U));
        }
    };
    if (jittered) fill_jitter(0);
    const detail::strata_layout s = detail::make_strata(n);
    std::uint32_t i = 0;
    for (std::uint32_t r = 0; r < s.rows; ++r) {
        const std::uint32_t cols = s.base_cols + (r < s.rows_with_extra ? 1U : 0U);
        const T row_height = static_cast<T>(cols) / static_cast<T>(n);
        const T inv_cols = T(1) / static_cast<T>(cols);  // multiply in the loop, divide once per row
        // The row spans [row_first/n, row_end/n); cell c spans [c/cols, (c + 1)/cols).
        const T row_first = static_cast<T>(i), row_end = static_cast<T>(i + cols), n_t = static_cast<T>(n);
        const T cols_t = static_cast<T>(cols);
        const T u_margin = T(16) * std::numeric_limits<T>::epsilon() * cols_t;
        const T v_margin = T(16) * std::numeric_limits<T>::epsilon() * n_t;
        const T row_start = row_first / n_t;  // not accumulated: its error stays within a few ulps for any n
        for (std::uint32_t c = 0; c < cols; ++c, ++i) {
            T jx = T(0.5), jy = T(0.5);
            if (jittered) {
                if (i - chunk_start == chunk) fill_jitter(i);
                jx = jitter_x[i - chunk_start];
                jy = jitter_y[i - chunk_start];
            }
            T u = (static_cast<T>(c) + jx) * inv_cols;
            T v = row_start + jy * row_height;
            // Keep each point in its own half-open stratum (hence in [0, 1)²) even after rounding.
            const T c_t = static_cast<T>(c);
            if (detail::near_stratum_edge(u, cols_t, c_t, c_t + T(1), u_margin)) [[unlikely]]
                u = detail::nudge_into_stratum(u, cols_t, c_t, c_t + T(1));
            if (detail::near_stratum_edge(v, n_t, row_first, row_end, v_margin)) [[unlikely]]
                v = detail::nudge_into_stratum(v, n_t, row_first, row_end);
            out[i] = {u, v};
        }
    }
}

}  // namespace v0
}  // namespace aaf
