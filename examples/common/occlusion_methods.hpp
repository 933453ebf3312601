// SPDX-License-Identifier: MIT
#pragma once
// The ambient-occlusion family's methods for the examples' registry (methods.hpp): unfiltered Monte Carlo AO
// (cosine-weighted, stratified or low-discrepancy) and the axis-aligned AO filter, with the converged Monte
// Carlo reference of quantity::ambient_occlusion.

#include "common/methods.hpp"

namespace aaf_examples {

/// The maximum AO distance the examples use on `s`: a fifth of its bounding box's diagonal (world units),
/// so that AO is local in open scenes and not everywhere 0 in closed rooms (the Cornell box).
[[nodiscard]] float ao_max_distance(const scene& s);

/// The family: methods mc_ao_cosine and mc_ao_low_discrepancy (knob "spp"), aaf_ao (knob "mu"), and the
/// reference of quantity::ambient_occlusion (cosine-weighted stratified Monte Carlo, unfiltered).
/// Images: cosine-weighted ambient visibility (1 − occlusion) of surface pixels, sky 1.
/// aaf_ao's pictures: its filter width β in pixels and samples per pixel (heat-map inputs), the bent
/// normal's components as colours (0.5 + 0.5·b per channel, three pictures), diffuse only, and
/// AO-modulated diffuse plus an SH-sky ambient looked up with the bent normal (the lecture's pictures).
[[nodiscard]] method_family occlusion_methods();

}  // namespace aaf_examples
