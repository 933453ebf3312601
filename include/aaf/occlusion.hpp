// SPDX-License-Identifier: MIT
#pragma once
// Umbrella header of the ambient-occlusion family (include/aaf/occlusion/): hemisphere sampling, AO and bent
// normals per pixel or per mesh vertex / triangle, the axis-aligned AO filter, AO shading helpers
// (spherical-harmonic irradiance, a sky model), and shadow-map AO from directional depth maps (built on the
// shadow-map family, include/aaf/shadow_maps/). <aaf/aaf.hpp> stays the soft-shadow core's umbrella.

#include "occlusion/ao_filter.hpp"
#include "occlusion/ao_gather.hpp"
#include "occlusion/ao_settings.hpp"
#include "occlusion/ao_stats.hpp"
#include "occlusion/hemisphere.hpp"
#include "occlusion/shading.hpp"
#include "occlusion/shadow_map_ao.hpp"
