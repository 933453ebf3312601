// SPDX-License-Identifier: MIT
#pragma once
// Umbrella header of the subsurface family (include/aaf/subsurface/): dipole subsurface scattering gathered
// from a light-space map. <aaf/aaf.hpp> stays the shadow core's; include this one for translucency.

#include "subsurface/material.hpp"
#include "subsurface/dipole.hpp"
#include "subsurface/directional_dipole.hpp"
#include "subsurface/light_map.hpp"
#include "subsurface/area_light_map.hpp"
#include "subsurface/profile_batch.hpp"
#include "subsurface/epsilons.hpp"
#include "subsurface/gather.hpp"
#include "subsurface/reference.hpp"
