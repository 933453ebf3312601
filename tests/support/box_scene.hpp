// SPDX-License-Identifier: MIT
#pragma once
// Axis-aligned boxes as an analytic tracer (nearest_occluder contract of tracer.hpp) with exact face normals,
// for the subsurface tests: a large slab, and a slab with an edge.

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <glm/vec3.hpp>

#include <aaf/tracer.hpp>

namespace aaf_test {

struct box {
    glm::vec3 lo, hi;
};

struct box_scene {
    std::vector<box> boxes;

    /// Nearest hit in (0, length) with any box surface (entry or, from inside, exit).
    [[nodiscard]] float nearest_occluder(const aaf::shadow_segment<float>& s) const {
        float best = aaf::no_occluder<float>;
        for (const box& b : boxes) {
            float t0 = -INFINITY, t1 = INFINITY;
            for (int a = 0; a < 3; ++a) {
                const float inv = 1.0f / s.direction[a];
                float ta = (b.lo[a] - s.origin[a]) * inv, tb = (b.hi[a] - s.origin[a]) * inv;
                if (std::isnan(ta) || std::isnan(tb)) {  // parallel to the slab and on its plane
                    if (s.origin[a] < b.lo[a] || s.origin[a] > b.hi[a]) t0 = INFINITY;
                    continue;
                }
                if (ta > tb) std::swap(ta, tb);
                t0 = std::max(t0, ta);
                t1 = std::min(t1, tb);
            }
            if (t0 > t1) continue;
            const float t = t0 > 0 ? t0 : t1;
            if (t > 0 && t < s.length) best = std::min(best, t);
        }
        return best;
    }

    /// The outward normal of the box face nearest to p.
    [[nodiscard]] glm::vec3 normal_at(const glm::vec3& p) const {
        float best = INFINITY;
        glm::vec3 n(0, 1, 0);
        for (const box& b : boxes)
            for (int a = 0; a < 3; ++a)
                for (int side = 0; side < 2; ++side) {
                    const float d = std::abs(p[a] - (side ? b.hi[a] : b.lo[a]));
                    if (d < best) {
                        best = d;
                        n = glm::vec3(0);
                        n[a] = side ? 1.0f : -1.0f;
                    }
                }
        return n;
    }
};

}  // namespace aaf_test
