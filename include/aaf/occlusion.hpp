// SPDX-License-Identifier: MIT
#pragma once
// Umbrella header of the ambient-occlusion family (include/aaf/occlusion/): hemisphere sampling, AO and bent
// normals per pixel or per mesh vertex / triangle, the axis-aligned AO filter, and AO shading helpers
// (spherical-harmonic irradiance, a sky model). <aaf/aaf.hpp> stays the soft-shadow core's umbrella.

#include "occlusion/ao_filter.hpp"
#include "occlusion/ao_gather.hpp"
#include "occlusion/ao_settings.hpp"
#include "occlusion/ao_stats.hpp"
#include "occlusion/hemisphere.hpp"
#include "occlusion/shading.hpp"
