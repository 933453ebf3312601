// SPDX-License-Identifier: MIT
#pragma once
// Deterministic per-pixel light-sample sequences on the unit square.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <utility>
#include <vector>

#include <glm/vec2.hpp>

#include "config.hpp"
#include "simd.hpp"

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


/// The constants row `r` of the strata for n samples shares, its first cell being sample `first`: the
/// row spans [row_first/n, row_end/n), its cell c [c/cols, (c + 1)/cols). Computed once per row (divisions
/// included) by generate_samples and once per (n, row) by sample_plan, with the same expressions.
template <class T>
struct strata_row {
    std::uint32_t cols = 1;
    T inv_cols = 1, row_height = 1, row_start = 0, row_first = 0, row_end = 1, n_t = 1, cols_t = 1, u_margin = 0, v_margin = 0;
};

template <class T>
[[nodiscard]] strata_row<T> make_strata_row(const strata_layout& s, std::uint32_t n, std::uint32_t r, std::uint32_t first) noexcept {
    strata_row<T> row;
    row.cols = s.base_cols + (r < s.rows_with_extra ? 1U : 0U);
    row.row_height = static_cast<T>(row.cols) / static_cast<T>(n);
    row.inv_cols = T(1) / static_cast<T>(row.cols);  // multiply per cell, divide once per row
    row.row_first = static_cast<T>(first), row.row_end = static_cast<T>(first + row.cols), row.n_t = static_cast<T>(n);
    row.cols_t = static_cast<T>(row.cols);
    row.u_margin = T(16) * std::numeric_limits<T>::epsilon() * row.cols_t;
    row.v_margin = T(16) * std::numeric_limits<T>::epsilon() * row.n_t;
    row.row_start = row.row_first / row.n_t;  // not accumulated: its error stays within a few ulps for any n
    return row;
}

/// A stratum's point from its jitter (jx, jy) in [0, 1)², before the edge check: cell `c_t` of a row with
/// constants inv_cols, row_start and row_height (strata_row). The one expression of every caller.
template <class T>
[[nodiscard]] constexpr T stratum_u(T c_t, T jx, T inv_cols) noexcept { return (c_t + jx) * inv_cols; }
template <class T>
[[nodiscard]] constexpr T stratum_v(T jy, T row_start, T row_height) noexcept { return row_start + jy * row_height; }

/// The jitter of stratified sample i of the pixel whose key hashes to `seed`.
template <class T>
constexpr void stratum_jitter(std::uint32_t seed, std::uint32_t i, T& jx, T& jy) noexcept {
    const std::uint32_t h = hash_combine(seed, i);
    jx = to_unit<T>(h);
    jy = to_unit<T>(hash32(h ^ 0x68e31da4U));
}

/// The Owen scrambling seeds of the low-discrepancy pattern's two dimensions for a key hash.
[[nodiscard]] constexpr std::uint32_t sobol_seed_x(std::uint32_t seed) noexcept { return hash32(seed ^ 0x63d83595U); }
[[nodiscard]] constexpr std::uint32_t sobol_seed_y(std::uint32_t seed) noexcept { return hash32(seed ^ 0x0b4f3a5dU); }

/// Sobol's second dimension of index i built reversed (its generator columns low bit first), as
/// generate_samples' bit-plane loop builds it for many indices at once.
[[nodiscard]] constexpr std::uint32_t sobol_dim1_reversed(std::uint32_t i) noexcept {
    std::uint32_t r = 0, column = 1;
    for (std::uint32_t b = 0; (i >> b) != 0; ++b, column ^= column << 1) r ^= column & (0U - ((i >> b) & 1U));
    return r;
}

/// Low-discrepancy sample with index i (its reversed second dimension `dim1`) under scrambles sx, sy.
template <class T>
constexpr void sobol_point(std::uint32_t i, std::uint32_t dim1, std::uint32_t sx, std::uint32_t sy, T& u, T& v) noexcept {
    u = to_unit<T>(reverse_bits(laine_karras(i, sx)));
    v = to_unit<T>(reverse_bits(laine_karras(dim1, sy)));
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
        const std::uint32_t sx = detail::sobol_seed_x(seed), sy = detail::sobol_seed_y(seed);
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
            for (std::uint32_t k = 0; k < m; ++k)  // in lanes: the scrambles write plain arrays
                detail::sobol_point<T>(base + k, dim1[k], sx, sy, u[k], v[k]);
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
        for (std::uint32_t k = 0; k < m; ++k) detail::stratum_jitter<T>(seed, first + k, jitter_x[k], jitter_y[k]);
    };
    if (jittered) fill_jitter(0);
    const detail::strata_layout s = detail::make_strata(n);
    std::uint32_t i = 0;
    for (std::uint32_t r = 0; r < s.rows; ++r) {
        const detail::strata_row<T> row = detail::make_strata_row<T>(s, n, r, i);
        for (std::uint32_t c = 0; c < row.cols; ++c, ++i) {
            T jx = T(0.5), jy = T(0.5);
            if (jittered) {
                if (i - chunk_start == chunk) fill_jitter(i);
                jx = jitter_x[i - chunk_start];
                jy = jitter_y[i - chunk_start];
            }
            const T c_t = static_cast<T>(c);
            T u = detail::stratum_u(c_t, jx, row.inv_cols);
            T v = detail::stratum_v(jy, row.row_start, row.row_height);
            // Keep each point in its own half-open stratum (hence in [0, 1)²) even after rounding.
            if (detail::near_stratum_edge(u, row.cols_t, c_t, c_t + T(1), row.u_margin)) [[unlikely]]
                u = detail::nudge_into_stratum(u, row.cols_t, c_t, c_t + T(1));
            if (detail::near_stratum_edge(v, row.n_t, row.row_first, row.row_end, row.v_margin)) [[unlikely]]
                v = detail::nudge_into_stratum(v, row.n_t, row.row_first, row.row_end);
            out[i] = {u, v};
        }
    }
}

namespace detail {

/// Values of T per vector (1 without explicit vectors): sample_plan pads a pixel's samples to whole vectors.
template <class T>
inline constexpr std::uint32_t sample_lanes = simd_bytes >= sizeof(T) ? static_cast<std::uint32_t>(simd_bytes / sizeof(T)) : 1U;

/// What generate_samples computes per sample that does not depend on the pixel, kept for one (pattern, n)
/// in arrays padded to whole vectors: the strata's row constants, the regular grid's points, Sobol's second
/// dimension. A pass that draws n samples for every pixel then only does, per pixel, the steps that depend
/// on its key (the hashes and scrambles), in lanes and without the per-pixel set-up (make_strata, a square
/// root, divisions per row). The same expressions as generate_samples, so the same bits (test_sampler.cpp).
template <class T>
class sample_plan {
public:
    /// Sets the plan up for `pattern` and `n` samples; nothing to do when it already is (allocates when n grows).
    void prepare(sample_pattern pattern, std::uint32_t n) {
        if (ready_ && n == n_ && pattern == pattern_) [[likely]]
            return;
        build(pattern, n);
    }

    [[nodiscard]] std::uint32_t size() const noexcept { return n_; }
    /// size() rounded up to whole vectors: how many values generate writes.
    [[nodiscard]] std::uint32_t padded() const noexcept { return padded_; }

    /// The samples generate_samples gives the pixel whose key hashes to `seed` (key_hash): sample i is
    /// (u[i], v[i]) for i < size() of the arrays returned, which are `u` and `v` or, for the regular grid (the
    /// same points for every pixel), the plan's own; the padding lanes up to padded() hold points of [0, 1)²
    /// that are no sample.
    [[nodiscard]] std::pair<const T*, const T*> generate(std::uint32_t seed, T* __restrict u, T* __restrict v) const noexcept {
        if (pattern_ == sample_pattern::regular_grid) return {u_.data(), v_.data()};
        if (pattern_ == sample_pattern::low_discrepancy) {
            const std::uint32_t sx = sobol_seed_x(seed), sy = sobol_seed_y(seed);
            const std::uint32_t* dim1 = dim1_.data();
            for (std::uint32_t i = 0; i < padded_; ++i) sobol_point<T>(i, dim1[i], sx, sy, u[i], v[i]);
            return {u, v};
        }
        stratified(seed, u, v);
        return {u, v};
    }

    /// generate for a group of `sample_lanes<T>` pixels (seeds[k] the key hash of pixel k) in one pass, one
    /// pixel per lane: sample i of pixel k is (u[i·L + k], v[i·L + k]) with L = sample_lanes<T>, for
    /// i < size(). The per-sample constants are the same for every lane, so no lane is padding (size() = 9
    /// fills 9 vectors where generate fills 2 per pixel, 16 per 8 pixels). The same bits as generate.
    void generate_group(const std::uint32_t* __restrict seeds, T* __restrict u, T* __restrict v) const noexcept {
        constexpr std::uint32_t L = sample_lanes<T>;
        if (pattern_ == sample_pattern::regular_grid) {
            for (std::uint32_t i = 0; i < n_; ++i, u += L, v += L)
                for (std::uint32_t k = 0; k < L; ++k) u[k] = u_[i], v[k] = v_[i];
            return;
        }
        if (pattern_ == sample_pattern::low_discrepancy) {
            std::uint32_t sx[L], sy[L];
            for (std::uint32_t k = 0; k < L; ++k) sx[k] = sobol_seed_x(seeds[k]), sy[k] = sobol_seed_y(seeds[k]);
            for (std::uint32_t i = 0; i < n_; ++i, u += L, v += L) {
                const std::uint32_t dim1 = dim1_[i];
                for (std::uint32_t k = 0; k < L; ++k) sobol_point<T>(i, dim1, sx[k], sy[k], u[k], v[k]);
            }
            return;
        }
        std::uint32_t near[L] = {};  // per lane: some sample came near its stratum's edge
        T* const u0 = u;
        T* const v0 = v;
        for (std::uint32_t i = 0; i < n_; ++i, u += L, v += L) {
            const T col = col_[i], inv_cols = inv_cols_[i], row_start = row_start_[i], row_height = row_height_[i];
            const T cols_t = cols_t_[i], u_lo = u_lo_[i], u_hi = u_hi_[i], v_lo = v_lo_[i], v_hi = v_hi_[i];
            for (std::uint32_t k = 0; k < L; ++k)
                near[k] |= stratified_lane(seeds[k], i, col, inv_cols, row_start, row_height, cols_t, u_lo, u_hi, v_lo, v_hi, u[k], v[k]);
        }
        for (std::uint32_t k = 0; k < L; ++k) {
            if (near[k] == 0) [[likely]]
                continue;
            for (std::uint32_t i = 0; i < n_; ++i) nudge_sample(i, u0[i * std::size_t{L} + k], v0[i * std::size_t{L} + k]);
        }
    }

private:
    /// Stratified sample i of the pixel whose key hashes to `seed`, before the edge rule, from its stratum's
    /// constants; returns 1 where it lies near its stratum's edge (near_stratum_edge's tests as 0/1 values,
    /// no branch), else 0. The one expression of stratified and generate_group.
    [[nodiscard]] std::uint32_t stratified_lane(std::uint32_t seed, std::uint32_t i, T col, T inv_cols, T row_start, T row_height,
                                                T cols_t, T u_lo, T u_hi, T v_lo, T v_hi, T& u, T& v) const noexcept {
        T jx, jy;
        stratum_jitter<T>(seed, i, jx, jy);
        const T x = stratum_u(col, jx, inv_cols), y = stratum_v(jy, row_start, row_height);
        u = x, v = y;
        const T tu = x * cols_t, tv = y * static_cast<T>(n_);
        return 1U ^ (static_cast<std::uint32_t>(tu > u_lo) & static_cast<std::uint32_t>(tu < u_hi) &
                     static_cast<std::uint32_t>(tv > v_lo) & static_cast<std::uint32_t>(tv < v_hi));
    }

    /// generate_samples' edge rule for stratified sample i < size() at (u, v).
    void nudge_sample(std::uint32_t i, T& u, T& v) const noexcept {
        const strata_row<T>& row = rows_[row_of_[i]];
        const T c_t = col_[i];
        if (near_stratum_edge(u, row.cols_t, c_t, c_t + T(1), row.u_margin)) u = nudge_into_stratum(u, row.cols_t, c_t, c_t + T(1));
        if (near_stratum_edge(v, row.n_t, row.row_first, row.row_end, row.v_margin))
            v = nudge_into_stratum(v, row.n_t, row.row_first, row.row_end);
    }

    void build(sample_pattern pattern, std::uint32_t n) {
        constexpr std::uint32_t lanes = sample_lanes<T>;
        pattern_ = pattern, n_ = n, padded_ = (n + lanes - 1) / lanes * lanes, ready_ = true;
        const std::size_t m = padded_;
        if (n == 0) return;
        if (pattern == sample_pattern::low_discrepancy) {
            dim1_.resize(m);
            for (std::uint32_t i = 0; i < padded_; ++i) dim1_[i] = sobol_dim1_reversed(i);
            return;
        }
        if (pattern == sample_pattern::regular_grid) {  // the same points for every pixel: generate_samples' own
            std::vector<glm::vec<2, T>> uv(n);
            generate_samples<T>(pattern, sample_key{}, uv);
            u_.resize(m), v_.resize(m);
            for (std::uint32_t i = 0; i < padded_; ++i) u_[i] = uv[i < n ? i : 0].x, v_[i] = uv[i < n ? i : 0].y;
            return;
        }
        for (auto* a : {&col_, &inv_cols_, &row_start_, &row_height_, &cols_t_, &u_lo_, &u_hi_, &v_lo_, &v_hi_}) a->resize(m);
        row_of_.resize(m), rows_.clear();
        const strata_layout s = make_strata(n);
        std::uint32_t i = 0;
        for (std::uint32_t r = 0; r < s.rows; ++r) {
            rows_.push_back(make_strata_row<T>(s, n, r, i));
            const strata_row<T>& row = rows_.back();
            for (std::uint32_t c = 0; c < row.cols; ++c, ++i) {
                const T c_t = static_cast<T>(c);
                col_[i] = c_t, inv_cols_[i] = row.inv_cols, row_start_[i] = row.row_start, row_height_[i] = row.row_height;
                // near_stratum_edge's bounds, lo + margin and hi − margin, computed as it computes them.
                cols_t_[i] = row.cols_t, u_lo_[i] = c_t + row.u_margin, u_hi_[i] = (c_t + T(1)) - row.u_margin;
                v_lo_[i] = row.row_first + row.v_margin, v_hi_[i] = row.row_end - row.v_margin;
                row_of_[i] = r;
            }
        }
        for (; i < padded_; ++i) {  // padding lanes: sample 0's constants (points in [0, 1)², never used)
            col_[i] = col_[0], inv_cols_[i] = inv_cols_[0], row_start_[i] = row_start_[0], row_height_[i] = row_height_[0];
            cols_t_[i] = cols_t_[0], u_lo_[i] = u_lo_[0], u_hi_[i] = u_hi_[0], v_lo_[i] = v_lo_[0], v_hi_[i] = v_hi_[0];
            row_of_[i] = 0;
        }
    }

    /// generate for the stratified pattern: the jitter hashes and the points in lanes, then generate_samples'
    /// edge rule sample by sample where some lane came near its stratum's edge.
    void stratified(std::uint32_t seed, T* __restrict u, T* __restrict v) const noexcept {
        const T *col = col_.data(), *inv_cols = inv_cols_.data(), *row_start = row_start_.data(), *row_height = row_height_.data();
        const T *cols_t = cols_t_.data(), *u_lo = u_lo_.data(), *u_hi = u_hi_.data(), *v_lo = v_lo_.data(), *v_hi = v_hi_.data();
        std::uint32_t near = 0;  // some lane (padding included) is near its stratum's edge
        for (std::uint32_t i = 0; i < padded_; ++i)
            near |= stratified_lane(seed, i, col[i], inv_cols[i], row_start[i], row_height[i], cols_t[i], u_lo[i], u_hi[i], v_lo[i],
                                    v_hi[i], u[i], v[i]);
        if (near == 0) [[likely]]
            return;
        for (std::uint32_t i = 0; i < n_; ++i) nudge_sample(i, u[i], v[i]);  // generate_samples' edge rule, sample by sample
    }

    sample_pattern pattern_ = sample_pattern::stratified;
    std::uint32_t n_ = 0, padded_ = 0;
    bool ready_ = false;
    std::vector<T> u_, v_;                                                   // regular grid: the points
    std::vector<std::uint32_t> dim1_;                                        // low discrepancy: reversed dimension 1
    std::vector<T> col_, inv_cols_, row_start_, row_height_;                 // stratified: per sample, its row's
    std::vector<T> cols_t_, u_lo_, u_hi_, v_lo_, v_hi_;                      // constants and edge bounds
    std::vector<std::uint32_t> row_of_;
    std::vector<strata_row<T>> rows_;
};

}  // namespace detail

}  // namespace v0
}  // namespace aaf
