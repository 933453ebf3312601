// SPDX-License-Identifier: MIT
#pragma once
// Depth maps as a GPU stores them: normalised z_tex per texel, quantised to float, 24-bit or 16-bit
// precision (precision is what makes shadow acne, so it is modelled, not idealised). An owning depth_map
// for maps aaf renders, and depth_map_view, the non-owning form every lookup takes, which also wraps the
// user's own rasterised depth buffer (wrap_depth_buffer).

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>

#include "../image.hpp"
#include "../image_view.hpp"
#include "light_view.hpp"

namespace aaf {
inline namespace v0 {

/// The precision a depth map's z_tex values carry.
enum class depth_format {
    float32,  ///< D32F: z_tex as a float (relative precision 2^-24, so a perspective map loses most near 1)
    unorm24,  ///< D24: z_tex = k / (2^24 − 1), k integer
    unorm16,  ///< D16: z_tex = k / (2^16 − 1), k integer
};

[[nodiscard]] constexpr const char* to_string(depth_format f) noexcept {
    switch (f) {
        case depth_format::float32: return "float32";
        case depth_format::unorm24: return "unorm24";
        case depth_format::unorm16: return "unorm16";
    }
    return "?";
}

/// Bytes per texel a GPU allocates for the format (D32F 4, D24 with its X8/S8 companion 4, D16 2).
[[nodiscard]] constexpr std::size_t gpu_bytes_per_texel(depth_format f) noexcept { return f == depth_format::unorm16 ? 2 : 4; }

/// The spacing of representable z_tex values near `z_tex`: 1/(2^b − 1) for unorm formats, one float ulp
/// (at least the smallest normal float) for float32.
[[nodiscard]] inline double z_tex_step(depth_format f, double z_tex) noexcept {
    switch (f) {
        case depth_format::unorm24: return 1.0 / 16777215.0;
        case depth_format::unorm16: return 1.0 / 65535.0;
        case depth_format::float32: break;
    }
    const float z = static_cast<float>(std::abs(z_tex));
    return static_cast<double>(std::nextafter(std::max(z, std::numeric_limits<float>::min()), 2.0f) -
                               std::max(z, std::numeric_limits<float>::min()));
}

/// z_tex as the format stores it. Unorm formats clamp to [0, 1] and round to the nearest code, which is
/// returned as the nearest float (for unorm24 that adds at most 2^-25, below half a code step); float32
/// rounds to float. NaN stays NaN.
[[nodiscard]] inline float quantize_z_tex(depth_format f, double z_tex) noexcept {
    if (std::isnan(z_tex)) return std::numeric_limits<float>::quiet_NaN();
    if (f == depth_format::float32) return static_cast<float>(z_tex);
    const double levels = f == depth_format::unorm24 ? 16777215.0 : 65535.0;
    const double code = std::nearbyint(std::clamp(z_tex, 0.0, 1.0) * levels);
    return static_cast<float>(code / levels);
}

/// What every lookup reads: a W×H grid of z_tex values (texel layout in light_view.hpp), the view it was
/// rendered from and the precision it carries (the automatic bias needs the quantisation step).
template <class T = float>
struct depth_map_view {
    const_image_view<float> depth;                   ///< z_tex per texel, in [0, 1] (1 = nothing nearer than the far plane)
    light_view<T> view;                              ///< the view the map was rendered from
    depth_format format = depth_format::float32;     ///< the precision the values carry

    [[nodiscard]] std::size_t width() const noexcept { return depth.width(); }
    [[nodiscard]] std::size_t height() const noexcept { return depth.height(); }
};

namespace detail {
template <class T>
void require_depth_map(const char* fn, const depth_map_view<T>& map) {
    require_nonempty(fn, "map.depth", map.depth);
    require_light_view(fn, "map.view", map.view);
}
}  // namespace detail

/// Wraps the user's own rasterised depth buffer (z_tex values as read back from the GPU, layout in
/// light_view.hpp) with the view it was rendered from. Validates once, so lookups need not: throws
/// aaf::invalid_argument naming `depth` (empty, misaligned, or a texel that is NaN or outside [0, 1]) or
/// `view`. `format` is the precision the buffer was rendered at (the automatic bias uses its step).
template <class T>
[[nodiscard]] depth_map_view<T> wrap_depth_buffer(const_image_view<float> depth, const light_view<T>& view,
                                                  depth_format format = depth_format::float32) {
    constexpr const char* fn = "wrap_depth_buffer";
    detail::require_nonempty(fn, "depth", depth);
    detail::require_light_view(fn, "view", view);
    for (std::size_t j = 0; j < depth.height(); ++j)
        for (std::size_t i = 0; i < depth.width(); ++i) {
            const float z = depth(i, j);
            if (!(z >= 0.0f && z <= 1.0f))
                detail::throw_invalid(fn, "`depth` texel (" + std::to_string(i) + ", " + std::to_string(j) + ") is " +
                                              std::to_string(z) + ", not a z_tex in [0, 1]");
        }
    return {depth, view, format};
}

/// An owning depth map: width×height z_tex values at `format` precision, rendered from `view`. Every texel
/// starts at 1 (the cleared depth: nothing in front of the far plane). Storage is one float per texel
/// whatever the format (storage_bytes); gpu_bytes is what the same map costs on a GPU.
template <class T = float>
class depth_map {
public:
    depth_map() = default;
    /// Throws aaf::invalid_argument naming `width`/`height` (zero) or `view` (see light_view).
    depth_map(std::size_t width, std::size_t height, const light_view<T>& view, depth_format format = depth_format::unorm24)
        : view_(view), format_(format) {
        constexpr const char* fn = "depth_map";
        if (width == 0 || height == 0)
            detail::throw_invalid(fn, "`width` and `height` must be > 0 (got " + std::to_string(width) + "x" +
                                          std::to_string(height) + ")");
        detail::require_light_view(fn, "view", view);
        z_.reset(width, height, 1.0f);
    }

    [[nodiscard]] std::size_t width() const noexcept { return z_.width(); }
    [[nodiscard]] std::size_t height() const noexcept { return z_.height(); }
    [[nodiscard]] const light_view<T>& view() const noexcept { return view_; }
    [[nodiscard]] depth_format format() const noexcept { return format_; }
    [[nodiscard]] std::size_t storage_bytes() const noexcept { return z_.size() * sizeof(float); }
    [[nodiscard]] std::size_t gpu_bytes() const noexcept { return z_.size() * gpu_bytes_per_texel(format_); }

    /// Re-targets the map at a new view (same size and format), clearing it to 1. Throws like the constructor.
    void reset(const light_view<T>& view) {
        detail::require_light_view("depth_map::reset", "view", view);
        view_ = view;
        z_.fill(1.0f);
    }

    /// The stored z_tex of texel (i, j).
    [[nodiscard]] float z_tex(std::size_t i, std::size_t j) const noexcept { return z_(i, j); }
    /// Stores z_tex at the map's precision (quantize_z_tex).
    void store_z_tex(std::size_t i, std::size_t j, double z) noexcept { z_(i, j) = quantize_z_tex(format_, z); }
    /// Stores the point at `depth` in front of the light (encoded by the view's projection, then quantised).
    void store_depth(std::size_t i, std::size_t j, T depth) noexcept {
        store_z_tex(i, j, z_tex_from_depth<double>(view_.projection, static_cast<double>(depth), static_cast<double>(view_.near_plane),
                                                   static_cast<double>(view_.far_plane)));
    }
    /// The depth in front of the light that texel (i, j) holds, reconstructed from its stored z_tex.
    [[nodiscard]] T depth(std::size_t i, std::size_t j) const noexcept {
        return static_cast<T>(depth_from_z_tex<double>(view_.projection, static_cast<double>(z_(i, j)),
                                                       static_cast<double>(view_.near_plane), static_cast<double>(view_.far_plane)));
    }

    [[nodiscard]] depth_map_view<T> map_view() const noexcept { return {z_.cview(), view_, format_}; }
    operator depth_map_view<T>() const noexcept { return map_view(); }  // NOLINT(google-explicit-constructor)

private:
    light_view<T> view_{};
    depth_format format_ = depth_format::unorm24;
    image<float> z_;
};

}  // namespace v0
}  // namespace aaf
