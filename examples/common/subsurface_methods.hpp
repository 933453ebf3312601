// SPDX-License-Identifier: MIT
#pragma once
// The subsurface family's methods for the examples' registry (methods.hpp): texture-space subsurface
// scattering gathered from an orthographic light-space map (aaf/subsurface.hpp) in the write-up's variants,
// and the map-free Monte Carlo reference of quantity::subsurface.
//
// What every method renders (docs/SUBSURFACE.md, "The examples"; the variants below change the material or light):
// * every object of the scene is marble (Jensen 2001, aaf::subsurface::presets::marble()), the scene scaled so
//   that its bounding box's diagonal is 300 mm (a statue-sized bunny): material = marble().in_units(300/diagonal);
// * lit by a directional light of irradiance 1 travelling along the scene's area light's normal (flipped
//   towards the scene's centre when it points away);
// * image = min(1, 3 · mean over R, G, B of the gathered radiance) (exposure 3, before the exit Fresnel
//   factor, as the gather returns it); sky 0.

#include "common/methods.hpp"

namespace aaf_examples {

/// The family: sss_no_fixes, sss_bias_only, sss_all_fixes, sss_all_fixes_banding (centre-first),
/// sss_profile (the library's default), mc_subsurface (the reference at a chosen sample count, family "mc"),
/// all over the knob "samples" (per pixel), and the reference of quantity::subsurface. Besides, variants of
/// sss_profile in another material or light (sss_profile_side, sss_profile_back, sss_profile_skim_milk,
/// sss_profile_skim_milk_side, sss_profile_skim_milk_back: skim milk is Jensen 2001's preset; "side" travels
/// perpendicular to the camera's view direction, from the camera's right; "back" travels level (tilted 19° down) from behind the object
/// towards the camera, so thin parts glow), each with its own reference (method::own_reference) of the same
/// material and light; aaf-tradeoff leaves them out.
[[nodiscard]] method_family subsurface_methods();

}  // namespace aaf_examples
