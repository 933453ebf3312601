// SPDX-License-Identifier: MIT
#pragma once
// A deterministic Poisson-disc tap set in the unit disc, for PCF kernels (Bunnell & Pellacini, GPU Gems
// ch. 11, use a fixed Poisson disc; a per-pixel rotation of it turns banding into noise).

#include <cmath>
#include <cstdint>
#include <numbers>
#include <vector>

#include <glm/vec2.hpp>

#include "../sampler.hpp"

namespace aaf {
inline namespace v0 {

/// `n` points in the unit disc with large mutual distances, by Mitchell's best-candidate algorithm (each
/// point is the candidate farthest from the points before it, out of 8·k + 1 candidates for the k-th). A
/// pure function of (n, seed): the same taps on every call and platform. O(n²) work: make it once per
/// lookup setup, not per pixel. Candidates are uniform in area (r = √ξ), so the set covers the disc evenly.
template <class T = float>
[[nodiscard]] std::vector<glm::vec<2, T>> poisson_disc(std::uint32_t n, std::uint32_t seed = 0) {
    std::vector<glm::vec<2, T>> out;
    out.reserve(n);
    std::uint32_t state = detail::hash32(seed ^ 0x2545f491U);
    const auto next = [&state] {
        state = detail::hash32(state + 0x9e3779b9U);
        return detail::to_unit<double>(state);
    };
    for (std::uint32_t k = 0; k < n; ++k) {
        glm::dvec2 best(0);
        double best_d2 = -1;
        for (std::uint32_t c = 0; c < 8 * k + 1; ++c) {
            const double r = std::sqrt(next()), a = 2.0 * std::numbers::pi * next();
            const glm::dvec2 cand(r * std::cos(a), r * std::sin(a));
            double d2 = 1e300;
            for (const auto& q : out) {
                const glm::dvec2 d = cand - glm::dvec2(q);
                d2 = std::min(d2, d.x * d.x + d.y * d.y);
            }
            if (d2 > best_d2) best_d2 = d2, best = cand;
        }
        out.emplace_back(glm::vec<2, T>(best));
    }
    return out;
}

}  // namespace v0
}  // namespace aaf
