// SPDX-License-Identifier: MIT
#pragma once
// Umbrella header: all of aaf. Include single headers (e.g. <aaf/formulas.hpp>) to take less.

#include "area_light.hpp"
#include "config.hpp"
#include "debug.hpp"
#include "executor.hpp"
#include "filter.hpp"
#include "footprint.hpp"
#include "formulas.hpp"
#include "gather.hpp"
#include "guides.hpp"
#include "image.hpp"
#include "image_view.hpp"
#include "occlusion_stats.hpp"
#include "pipeline.hpp"
#include "ray_offset.hpp"
#include "region.hpp"
#include "sampler.hpp"
#include "settings.hpp"
#include "tracer.hpp"
#include "version.hpp"
