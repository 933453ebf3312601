// SPDX-License-Identifier: MIT
#pragma once
// Umbrella header of aaf's filter variants and peers (include/aaf/variants/): the image-space denoisers
// users compare aaf with (guided à-trous, joint bilateral), consistent progressive refinement and the
// sheared filter of the follow-up work (sheared.hpp).
// <aaf/aaf.hpp> stays the core's; include this one beside it.

#include "variants/atrous.hpp"
#include "variants/bilateral.hpp"
#include "variants/edge_stops.hpp"
#include "variants/progressive.hpp"
#include "variants/sheared.hpp"
