// SPDX-License-Identifier: MIT
#pragma once
// The three epsilons of the light-space gather (the write-up's fixes), derived from the texel footprint, the
// depth precision and the material's diffusion length instead of being hand-set.
//
//   h  = the map's texel footprint at x_o (world units; orthographic: max texel side; cube: 2·major/res)
//   δ  = the depth precision of a texel's point: 8·ε_mach·max(|x_o|∞, far) for points stored in floating point
//        (rounding of the stored coordinates and of x_o itself), plus (far − near)/2^bits for a depth map of
//        `bits` bits reconstructed with FORMULAS.md §3.5
//   ℓ  = 1/σ_tr,max, the shortest diffusion length over the channels (∞ for a lossless medium)
//
//   ε_g (shrink along the light direction) = h
//        x'_o = x_o − ε_g(n_o − ω_l(ω_l·n_o)) moves x_o's projection by ε_g·sin θ: at a silhouette (sin θ → 1)
//        by one texel, past the edge texels whose centre ray may miss the object. aaf measures the profile's
//        distances from x_o itself (gather.hpp), so the shift moves only where the map is read and needs no
//        cap by the diffusion length.
//   ε_c (cube-map intrusion) = min(h + δ, ℓ/10)
//        x'_o = x_o − ε_c n_o puts x_o below the surface by one footprint: the cube map's points are a texel
//        apart, so the point of interest no longer coincides with (or lies in front of) the texel points around
//        it, where R_d is steepest.
//   ε_b (depth-reconstruction bias) = 4δ + h·min(tan θ, 8)
//        the slope-scaled bias of FORMULAS.md §3.4 written in world units: a surface tilted by θ from the light
//        changes depth by up to h·tan θ across one texel, and stored depths are uncertain by δ. tan θ is capped
//        at 8 (83°) as slope-scaled biases are.
//
// All three are proportional to the scene's scale when the scene and its coefficients are scaled together
// (h, δ and ℓ all are): tests/test_subsurface_gather.cpp checks 1e-3 … 1e3 and mm against m.

#include <algorithm>
#include <cmath>
#include <limits>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

namespace aaf {
inline namespace v0 {
namespace subsurface {

/// The epsilons in world units. A negative value in `gather_settings` means "derive it" (this struct).
template <class T>
struct gather_epsilons {
    T shrink = 0;   ///< ε_g, world units ≥ 0
    T intrude = 0;  ///< ε_c, world units ≥ 0
    T bias = 0;     ///< ε_b, world units ≥ 0
};

/// Derives the epsilons at a point (see the header comment for the formulas and their reasons).
/// `footprint` h, `far` the map's depth range, `depth_bits` 0 for floating-point positions, `sigma_tr_max`
/// the largest σ_tr over channels, `cos_theta` = n_o·ω_l.
template <class T>
[[nodiscard]] gather_epsilons<T> derive_epsilons(const glm::vec<3, T>& x_o, T footprint, T far, T near_plane,
                                                 unsigned depth_bits, double sigma_tr_max, T cos_theta) noexcept {
    const T largest = std::max({std::abs(x_o.x), std::abs(x_o.y), std::abs(x_o.z), std::abs(far)});
    T delta = T(8) * std::numeric_limits<T>::epsilon() * largest;
    if (depth_bits > 0 && depth_bits < 64) delta += (far - near_plane) / std::ldexp(T(1), int(depth_bits));
    const T ell = sigma_tr_max > 0 ? static_cast<T>(1 / sigma_tr_max) : std::numeric_limits<T>::infinity();
    const T c = std::clamp(std::abs(cos_theta), T(0), T(1));
    const T sin_theta = std::sqrt(std::max(T(0), T(1) - c * c));
    const T tan_theta = c > T(0) ? std::min(sin_theta / c, T(8)) : T(8);
    gather_epsilons<T> e;
    e.shrink = footprint;
    e.intrude = std::min(footprint + delta, ell / T(10));
    e.bias = T(4) * delta + footprint * tan_theta;
    return e;
}

}  // namespace subsurface
}  // namespace v0
}  // namespace aaf
