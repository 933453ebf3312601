// SPDX-License-Identifier: MIT
#pragma once
// The light-sample patterns of sampler.hpp written one sample at a time, straight from their definitions:
// equal-area jittered strata (or their centres) and the Owen-scrambled Sobol' (0,2)-sequence
// (Burley 2020) with owen_scramble applied to sobol_dim0/sobol_dim1 as stated. The oracle for
// generate_samples' chunked loops, which must give the same bits.

#include <cstdint>
#include <limits>
#include <span>

#include <glm/vec2.hpp>

#include <aaf/sampler.hpp>

namespace aaf_ref {

template <class T>
void generate_samples(aaf::sample_pattern pattern, const aaf::sample_key& key, std::span<glm::vec<2, T>> out) {
    namespace d = aaf::detail;
    const auto n = static_cast<std::uint32_t>(out.size());
    if (n == 0) return;
    const std::uint32_t seed = d::key_hash(key);
    if (pattern == aaf::sample_pattern::low_discrepancy) {
        const std::uint32_t sx = d::hash32(seed ^ 0x63d83595U);
        const std::uint32_t sy = d::hash32(seed ^ 0x0b4f3a5dU);
        for (std::uint32_t i = 0; i < n; ++i)
            out[i] = {d::to_unit<T>(d::owen_scramble(d::sobol_dim0(i), sx)), d::to_unit<T>(d::owen_scramble(d::sobol_dim1(i), sy))};
        return;
    }
    const d::strata_layout s = d::make_strata(n);
    std::uint32_t i = 0;
    for (std::uint32_t r = 0; r < s.rows; ++r) {
        const std::uint32_t cols = s.base_cols + (r < s.rows_with_extra ? 1U : 0U);
        const T row_height = static_cast<T>(cols) / static_cast<T>(n);
        const T inv_cols = T(1) / static_cast<T>(cols);
        const T row_first = static_cast<T>(i), row_end = static_cast<T>(i + cols), n_t = static_cast<T>(n);
        const T cols_t = static_cast<T>(cols);
        const T u_margin = T(16) * std::numeric_limits<T>::epsilon() * cols_t;
        const T v_margin = T(16) * std::numeric_limits<T>::epsilon() * n_t;
        const T row_start = row_first / n_t;
        for (std::uint32_t c = 0; c < cols; ++c, ++i) {
            T jx = T(0.5), jy = T(0.5);
            if (pattern == aaf::sample_pattern::stratified) {
                const std::uint32_t h = d::hash_combine(seed, i);
                jx = d::to_unit<T>(h);
                jy = d::to_unit<T>(d::hash32(h ^ 0x68e31da4U));
            }
            T u = (static_cast<T>(c) + jx) * inv_cols;
            T v = row_start + jy * row_height;
            const T c_t = static_cast<T>(c);
            if (d::near_stratum_edge(u, cols_t, c_t, c_t + T(1), u_margin)) u = d::nudge_into_stratum(u, cols_t, c_t, c_t + T(1));
            if (d::near_stratum_edge(v, n_t, row_first, row_end, v_margin)) v = d::nudge_into_stratum(v, n_t, row_first, row_end);
            out[i] = {u, v};
        }
    }
}

}  // namespace aaf_ref
