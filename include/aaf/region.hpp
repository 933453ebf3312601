// SPDX-License-Identifier: MIT
#pragma once
// Where a caller's buffers sit inside the full frame. Every technique keys its per-pixel randomness by the
// pixel's coordinate in the *full frame*, so a tile rendered on its own draws exactly the samples the same
// pixels draw in a full-frame render (DESIGN.md: "a frame region is part of the sampling key everywhere").
//
// TILES (bucket renderers)
// ------------------------
// A tile of the frame is rendered by render_frame bit for bit as in a full-frame render when its buffers
// cover the tile plus a halo of `region_halo(settings)` pixels on every side that is not a frame edge
// (plan_region computes that rectangle, clipped to the frame), and `gbuffer.region` says where those buffers
// sit in the frame (with the frame's size, so that render_frame knows which buffer edges are frame edges).
// Why a halo: slope spreading reads `spread_radius` pixels around a pixel, and the filter reads
// `max_radius` pixels of visibility and β around it, each of which needs its own spread slopes.

#include <algorithm>
#include <cstddef>
#include <cstdint>

#include "sampler.hpp"
#include "settings.hpp"

namespace aaf {
inline namespace v0 {

/// The placement of a caller's buffers in the full frame: buffer pixel (x, y) is frame pixel
/// (origin_x + x, origin_y + y). The default (origin 0, 0, frame size unknown) is "the buffers are the whole
/// frame", which is what every call assumed before regions existed.
struct frame_region {
    std::uint32_t origin_x = 0;      ///< frame column of the buffers' first column, [0, 2^32)
    std::uint32_t origin_y = 0;      ///< frame row of the buffers' first row, [0, 2^32)
    /// Full frame width in pixels; 0 = unknown: every edge of the buffers is then taken as a frame edge.
    /// When non-zero (with frame_height), buffer edges inside the frame are halo edges: render_frame checks
    /// that the buffers lie inside the frame and spends no adaptive rays where no exact pixel needs them.
    std::uint32_t frame_width = 0;
    std::uint32_t frame_height = 0;  ///< full frame height in pixels; 0 = unknown (see frame_width)

    /// Whether the frame's size is given (both dimensions non-zero).
    [[nodiscard]] constexpr bool knows_frame() const noexcept { return frame_width != 0 && frame_height != 0; }
};

/// The sample key of buffer pixel (x, y) of `region`: its frame coordinate with the pass, light and frame
/// seed. Every technique (shadows, shadow-map rotations, hemisphere samples, subsurface discs) builds its
/// keys here, so tiles and full frames agree bit for bit.
[[nodiscard]] constexpr sample_key pixel_key(const frame_region& region, std::size_t x, std::size_t y, std::uint32_t pass,
                                             std::uint32_t light, std::uint32_t frame_seed) noexcept {
    return sample_key{region.origin_x + static_cast<std::uint32_t>(x), region.origin_y + static_cast<std::uint32_t>(y), pass,
                      light, frame_seed};
}

/// An axis-aligned rectangle of pixels: columns [x, x + width), rows [y, y + height).
struct pixel_rect {
    std::size_t x = 0;       ///< first column
    std::size_t y = 0;       ///< first row
    std::size_t width = 0;   ///< columns, >= 0
    std::size_t height = 0;  ///< rows, >= 0
};

/// How far render_frame reads around a pixel, split by stage (pixels, Chebyshev distance).
struct halo_extent {
    std::size_t filter = 0;  ///< the filter's reach: settings.filter.max_radius (visibility, β, guides)
    std::size_t spread = 0;  ///< slope spreading's reach: spread_radius, or 0 without spreading
    /// Pixels a tile needs on each side that is not a frame edge.
    [[nodiscard]] constexpr std::size_t total() const noexcept { return filter + spread; }
};

/// The halo a region needs for `settings`, by stage. Nothing else in render_frame reads neighbours: the
/// samples, slopes, sample counts and β of a pixel are its own (only spreading and the filter look around),
/// and the filter's kernel radius is capped at max_radius whatever β is. Defaults: 24 + 10 = 34 pixels.
template <class T>
[[nodiscard]] constexpr halo_extent region_halo_extent(const frame_settings<T>& settings) noexcept {
    return {settings.filter.max_radius, settings.filter.spread_slopes ? settings.filter.spread_radius : 0u};
}

/// The halo in pixels a region needs on each side that is not a frame edge (region_halo_extent().total()).
template <class T>
[[nodiscard]] constexpr std::size_t region_halo(const frame_settings<T>& settings) noexcept {
    return region_halo_extent(settings).total();
}

/// What a caller allocates and renders for one tile.
struct region_plan {
    pixel_rect buffers;   ///< the frame pixels the buffers must hold: the tile grown by the halo, clipped to the frame
    pixel_rect tile;      ///< where the tile sits inside those buffers (copy these pixels of the outputs out)
    frame_region region;  ///< the value for gbuffer.region
};

/// Plans the buffers for `tile` (frame pixels) of a `frame_width` × `frame_height` frame with `halo` pixels
/// (region_halo(settings)). The tile must lie inside the frame; the result is clipped to the frame.
[[nodiscard]] constexpr region_plan plan_region(const pixel_rect& tile, std::size_t frame_width, std::size_t frame_height,
                                                std::size_t halo) noexcept {
    const std::size_t x0 = tile.x > halo ? tile.x - halo : 0, y0 = tile.y > halo ? tile.y - halo : 0;
    const std::size_t x1 = std::min(frame_width, tile.x + tile.width + halo);
    const std::size_t y1 = std::min(frame_height, tile.y + tile.height + halo);
    region_plan p;
    p.buffers = {x0, y0, x1 - x0, y1 - y0};
    p.tile = {tile.x - x0, tile.y - y0, tile.width, tile.height};
    p.region = {static_cast<std::uint32_t>(x0), static_cast<std::uint32_t>(y0), static_cast<std::uint32_t>(frame_width),
                static_cast<std::uint32_t>(frame_height)};
    return p;
}

}  // namespace v0
}  // namespace aaf
