// SPDX-License-Identifier: MIT
#pragma once
// An orthonormal basis around a unit vector: the hemisphere's local frame in ambient occlusion
// (occlusion/hemisphere.hpp) and the light-plane filter's coordinate axes (filter.hpp). One construction
// for both, so that the two cannot drift apart.

#include <cmath>

#include <glm/vec3.hpp>

namespace aaf {
inline namespace v0 {

/// An orthonormal basis (t, b, n) around a unit normal n: world = t·x + b·y + n·z.
template <class T = float>
struct tangent_frame {
    glm::vec<3, T> t{1, 0, 0}, b{0, 1, 0}, n{0, 0, 1};

    tangent_frame() = default;
    /// From a unit normal, without branches on a threshold (Duff et al. 2017, "Building an orthonormal
    /// basis, revisited", JCGT 6(1), listing 3): continuous everywhere except across n.z = 0's sign, and
    /// exact to rounding.
    explicit tangent_frame(const glm::vec<3, T>& normal) noexcept : n(normal) {
        const T sign = std::copysign(T(1), n.z);
        const T a = T(-1) / (sign + n.z);
        const T c = n.x * n.y * a;
        t = {T(1) + sign * n.x * n.x * a, sign * c, -sign * n.x};
        b = {c, sign + n.y * n.y * a, -n.y};
    }
    [[nodiscard]] glm::vec<3, T> to_world(const glm::vec<3, T>& local) const noexcept {
        return t * local.x + b * local.y + n * local.z;
    }
};

}  // namespace v0
}  // namespace aaf
