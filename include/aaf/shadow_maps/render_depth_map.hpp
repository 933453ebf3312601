// SPDX-License-Identifier: MIT
#pragma once
// Rendering a depth map through the user's tracer: one nearest-hit query per texel, along the ray through
// the texel's centre from the near to the far plane (the tracer contract's nearest_occluder is enough;
// tracer.hpp). The texel stores the hit's depth; a miss stores 1 (the cleared depth).

#include <atomic>
#include <cmath>
#include <cstdint>

#include "../executor.hpp"
#include "../tracer.hpp"
#include "depth_map.hpp"

namespace aaf {
inline namespace v0 {

/// What rendering a map did.
struct depth_render_stats {
    std::uint64_t texels = 0;  ///< rays traced (one per texel)
    std::uint64_t hits = 0;    ///< texels that store a surface
    std::uint64_t failed = 0;  ///< texels whose query returned NaN; they store 1 (nothing: lit), as misses do
};

/// Renders `map` (its size, view and format as constructed) through `tracer`: texel (i, j) stores the depth
/// of the nearest hit along texel_ray(i, j), quantised to the map's format, or 1 on a miss. Rows run on
/// `exec`; the tracer is called concurrently (tracer.hpp). Any surface between the near and far planes is
/// stored, the light's own geometry included if the tracer reports it: start the near plane past it.
template <class T, class Tracer, class Exec = sequential_executor>
    requires occlusion_tracer<Tracer, T>
depth_render_stats render_depth_map(depth_map<T>& map, const Tracer& tracer, Exec&& exec = {}) {
    detail::require_light_view("render_depth_map", "map.view()", map.view());
    const light_frame<T> frame(map.view());
    const std::size_t w = map.width(), h = map.height();
    std::atomic<std::uint64_t> hits{0}, failed{0};
    exec.parallel_for(h, [&](std::size_t j0, std::size_t j1) {
        std::uint64_t local_hits = 0, local_failed = 0;
        for (std::size_t j = j0; j < j1; ++j)
            for (std::size_t i = 0; i < w; ++i) {
                T depth_per_t = T(1);
                const shadow_segment<T> ray = frame.texel_ray(i, j, w, h, depth_per_t);
                const occluder_span<T> hit = detail::trace_one<T>(tracer, ray);
                if (std::isnan(hit.nearest)) {
                    ++local_failed;
                    map.store_z_tex(i, j, 1.0);
                } else if (hit.hit()) {
                    ++local_hits;
                    map.store_depth(i, j, map.view().near_plane + hit.nearest * depth_per_t);
                } else {
                    map.store_z_tex(i, j, 1.0);
                }
            }
        hits += local_hits;
        failed += local_failed;
    });
    return {static_cast<std::uint64_t>(w) * h, hits.load(), failed.load()};
}

}  // namespace v0
}  // namespace aaf
