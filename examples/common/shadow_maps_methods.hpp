// SPDX-License-Identifier: MIT
#pragma once
// The shadow-map family in the examples' method registry (methods.hpp): hard shadows, PCF, PCSS and
// Heckbert–Herf accumulation from include/aaf/shadow_maps/, each rendered from the scene's BVH and the
// camera's G-buffer into an image comparable with the shadow reference (sky 1, no light 0).
//
//   sm_hard             knob map_size: one perspective map from the light's centre, hard test, automatic bias
//   sm_hard_no_bias     the same with no bias (acne), and with the seed's constant ε_b (tuned to a 1-unit
//   sm_hard_constant_bias  scene: 1e-3 world units): the bias figure's three panels with sm_hard
//   sm_hard_slope_scaled, sm_hard_normal_offset, sm_hard_receiver_plane
//                       the same with each remaining bias mode (default settings), knob map_size
//   sm_pcf              knob taps: the same map (1024²), PCF over a rotated Poisson disc of 2 texels' radius
//   sm_pcss             knob taps: PCSS (light width √area, 16 blocker taps) with that many PCF taps
//   sm_accumulation     knob grid M: M×M maps (512², one at a time) from a regular grid on the light

#include "common/methods.hpp"

namespace aaf_examples {

/// The shadow-map family's methods (no new quantity: they are judged against the shadow reference).
[[nodiscard]] method_family shadow_map_methods();

}  // namespace aaf_examples
