// SPDX-License-Identifier: MIT
#pragma once
// Analytic ambient-occlusion scenes: infinite planes and half-planes (a wall standing on a floor) and the
// inside of a box, traced exactly, so AO, bent normals and hit distances have closed forms (the oracles of
// tests/test_occlusion_*.cpp).

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>

#include <aaf/tracer.hpp>

namespace aaf_test {

/// The plane through `point` with normal `normal`, restricted to the side dot(x − point, keep) ≥ 0 (keep = 0:
/// the whole plane). A wall standing on the floor y = 0 is {wall point, wall normal, keep = (0, 1, 0)}.
struct ao_half_plane {
    glm::vec3 point{0}, normal{0, 1, 0}, keep{0};
};

/// The interior of the axis-aligned box [lo, hi]: every ray from inside hits a face.
struct ao_box {
    glm::vec3 lo{0}, hi{0};
};

/// A set of half-planes and boxes, traced exactly in double precision.
struct ao_scene {
    std::vector<ao_half_plane> planes;
    std::vector<ao_box> boxes;
    mutable bool fail = false;  ///< report NaN for every query (a failing tracer)

    [[nodiscard]] double nearest(const aaf::shadow_segment<float>& s) const {
        const glm::dvec3 o(s.origin), d(s.direction);
        double best = std::numeric_limits<double>::infinity();
        for (const ao_half_plane& p : planes) {
            const glm::dvec3 n(p.normal), q(p.point), k(p.keep);
            const double dn = glm::dot(d, n);
            if (dn == 0) continue;
            const double t = glm::dot(q - o, n) / dn;
            if (!(t > 0)) continue;
            if (glm::dot(o + t * d - q, k) < 0) continue;
            best = std::min(best, t);
        }
        for (const ao_box& b : boxes) {
            double t_exit = std::numeric_limits<double>::infinity();
            for (int a = 0; a < 3; ++a) {
                if (d[a] > 0) t_exit = std::min(t_exit, (static_cast<double>(b.hi[a]) - o[a]) / d[a]);
                if (d[a] < 0) t_exit = std::min(t_exit, (static_cast<double>(b.lo[a]) - o[a]) / d[a]);
            }
            if (t_exit > 0) best = std::min(best, t_exit);
        }
        return best;
    }
};

/// The scene through the nearest-hit query, and the any-hit one (both follow the 0 < t < length contract).
struct ao_tracer {
    const ao_scene* scene;
    [[nodiscard]] float nearest_occluder(const aaf::shadow_segment<float>& s) const {
        if (scene->fail) return std::numeric_limits<float>::quiet_NaN();
        const double t = scene->nearest(s);
        return t < static_cast<double>(s.length) ? static_cast<float>(t) : aaf::no_occluder<float>;
    }
    [[nodiscard]] bool occluded(const aaf::shadow_segment<float>& s) const {
        return scene->nearest(s) < static_cast<double>(s.length);
    }
};

/// Counts calls to each query (to check which one a pass uses).
struct counting_ao_tracer {
    const ao_scene* scene;
    mutable std::size_t nearest_calls = 0, occluded_calls = 0;
    [[nodiscard]] float nearest_occluder(const aaf::shadow_segment<float>& s) const {
        ++nearest_calls;
        return ao_tracer{scene}.nearest_occluder(s);
    }
    [[nodiscard]] bool occluded(const aaf::shadow_segment<float>& s) const {
        ++occluded_calls;
        return ao_tracer{scene}.occluded(s);
    }
};

/// A tracer that hits nothing.
struct empty_tracer {
    [[nodiscard]] float nearest_occluder(const aaf::shadow_segment<float>&) const { return aaf::no_occluder<float>; }
    [[nodiscard]] bool occluded(const aaf::shadow_segment<float>&) const { return false; }
};

/// Rotates every primitive of `s` by `r` (so a scene can be tested with arbitrary normals).
inline ao_scene rotated(const ao_scene& s, const glm::mat3& r) {
    ao_scene out = s;
    for (ao_half_plane& p : out.planes) p.point = r * p.point, p.normal = r * p.normal, p.keep = r * p.keep;
    return out;
}

}  // namespace aaf_test
