// SPDX-License-Identifier: MIT
#pragma once
// Brute-force Monte Carlo visibility: independent uniform points on the light (std::mt19937), one
// plain ray per point, no stratification, no offsets, no statistics. Obviously correct and slow.

#include <cstdint>
#include <random>

#include <glm/geometric.hpp>

#include <aaf/area_light.hpp>
#include <aaf/tracer.hpp>

namespace aaf_ref {

/// Fraction of `samples` uniform light points visible from `p` (all above the horizon assumed),
/// using any callable `occluded(origin, direction, length) -> bool`.
template <class T, class Occluded>
double mc_visibility(const aaf::area_light<T>& light, const glm::vec<3, T>& p, std::uint32_t samples, std::uint32_t seed,
                     Occluded&& occluded) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u01(0.0, 1.0);
    std::uint32_t visible = 0;
    for (std::uint32_t i = 0; i < samples; ++i) {
        const glm::vec<3, T> y = light.point(static_cast<T>(u01(rng)), static_cast<T>(u01(rng)));
        const glm::vec<3, T> d = y - p;
        const T len = glm::length(d);
        if (!occluded(p, d / len, len)) ++visible;
    }
    return static_cast<double>(visible) / samples;
}

}  // namespace aaf_ref
