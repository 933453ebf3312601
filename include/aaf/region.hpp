// SPDX-License-Identifier: MIT
#pragma once
// Where a caller's buffers sit inside the full frame. Every technique keys its per-pixel randomness by the
// pixel's coordinate in the *full frame*, so a tile rendered on its own draws exactly the samples the same
// pixels draw in a full-frame render (DESIGN.md: "a frame region is part of the sampling key everywhere").

#include <cstddef>
#include <cstdint>

#include "sampler.hpp"

namespace aaf {
inline namespace v0 {

/// The placement of a caller's buffers in the full frame: buffer pixel (x, y) is frame pixel
/// (origin_x + x, origin_y + y). The default (origin 0, 0) is "the buffers are the whole frame", which is
/// what every call assumed before regions existed.
struct frame_region {
    std::uint32_t origin_x = 0;  ///< frame column of the buffers' first column, [0, 2^32)
    std::uint32_t origin_y = 0;  ///< frame row of the buffers' first row, [0, 2^32)
};

/// The sample key of buffer pixel (x, y) of `region`: its frame coordinate with the pass, light and frame
/// seed. Every technique (shadows, shadow-map rotations, hemisphere samples, subsurface discs) builds its
/// keys here, so tiles and full frames agree bit for bit.
[[nodiscard]] constexpr sample_key pixel_key(const frame_region& region, std::size_t x, std::size_t y, std::uint32_t pass,
                                             std::uint32_t light, std::uint32_t frame_seed) noexcept {
    return sample_key{region.origin_x + static_cast<std::uint32_t>(x), region.origin_y + static_cast<std::uint32_t>(y), pass,
                      light, frame_seed};
}

}  // namespace v0
}  // namespace aaf
