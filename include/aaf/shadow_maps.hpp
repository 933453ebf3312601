// SPDX-License-Identifier: MIT
#pragma once
// Umbrella header of the shadow-map family (include/aaf/shadow_maps/): depth maps from a light's view
// (orthographic, perspective; float, 24-bit, 16-bit), rendered through the user's tracer or wrapped around
// the user's depth buffer; depth bias (automatic by default); hard, PCF and PCSS lookups; Heckbert–Herf
// accumulation. docs/SHADOW_MAPS.md compares the techniques. <aaf/aaf.hpp> stays the core's.

#include "shadow_maps/accumulation.hpp"
#include "shadow_maps/depth_bias.hpp"
#include "shadow_maps/depth_map.hpp"
#include "shadow_maps/light_view.hpp"
#include "shadow_maps/poisson_disc.hpp"
#include "shadow_maps/render_depth_map.hpp"
#include "shadow_maps/shadow_lookup.hpp"
