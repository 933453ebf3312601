// SPDX-License-Identifier: MIT
#pragma once
// What the benchmarks share: a synthetic G-buffer and visibility frame (a plane seen from above, smooth
// visibility, a smooth β field, three object IDs in blocks, gently varying normals), the image sizes the
// filter is measured at, and the per-pixel tap count of the filter's kernel radius rule.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <aaf/aaf.hpp>

namespace aaf_bench {

/// The frame sizes of issue 5: 640×480, 1280×720, 1920×1080 (identified by their height).
struct frame_size {
    std::size_t w, h;
    [[nodiscard]] std::string name() const { return std::to_string(w) + "x" + std::to_string(h); }
};
inline constexpr frame_size frame_sizes[] = {{640, 480}, {1280, 720}, {1920, 1080}};

/// World units per pixel of the synthetic frame.
inline constexpr double pixel_world = 0.01;

/// A synthetic frame of w×h pixels in precision T. β (world units) is smooth and ranges over
/// [beta_lo_px, beta_hi_px] pixels; the default [1, 10] px gives ~35 taps per pixel per pass at
/// truncation 3 (issue 5's "smooth β field up to ~10 px").
template <class T>
struct synthetic_frame {
    std::size_t w, h;
    aaf::image<glm::vec<3, T>> positions, normals;
    aaf::image<T> pixel_size, visibility, beta;
    aaf::image<std::uint32_t> ids;

    synthetic_frame(std::size_t w_, std::size_t h_, double beta_lo_px = 1.0, double beta_hi_px = 10.0)
        : w(w_), h(h_), positions(w_, h_), normals(w_, h_), pixel_size(w_, h_, static_cast<T>(pixel_world)),
          visibility(w_, h_), beta(w_, h_), ids(w_, h_) {
        const double mid = 0.5 * (beta_lo_px + beta_hi_px), half = 0.5 * (beta_hi_px - beta_lo_px);
        for (std::size_t y = 0; y < h; ++y)
            for (std::size_t x = 0; x < w; ++x) {
                const double fx = static_cast<double>(x), fy = static_cast<double>(y);
                positions(x, y) = glm::vec<3, T>(glm::dvec3(pixel_world * fx, 0.0, pixel_world * fy));
                visibility(x, y) = static_cast<T>(0.5 + 0.5 * std::sin(0.05 * fx) * std::cos(0.03 * fy));
                beta(x, y) = static_cast<T>(pixel_world * (mid + half * std::sin(0.004 * fx + 0.006 * fy)));
                ids(x, y) = static_cast<std::uint32_t>((x / 200 + y / 150) % 3);
                normals(x, y) = glm::vec<3, T>(glm::normalize(glm::dvec3(0.1 * std::sin(0.01 * fx), 1.0, 0.0)));
            }
    }
    [[nodiscard]] aaf::gbuffer<T> gbuffer() const {
        return {positions.cview(), normals.cview(), pixel_size.cview(), {}};
    }
};

/// The filter's kernel radius for one pixel, the library's own rule (filter.hpp): ceil(truncation·β/d)
/// capped at max_radius; 0 for β ≤ 0 or d ≤ 0 (the pixel is copied).
template <class T>
[[nodiscard]] std::size_t kernel_radius(T b, T d, const aaf::filter_settings<T>& s) {
    return b > T(0) && d > T(0) ? aaf::detail::kernel_radius(b / d, s) : 0;
}

/// Taps per pixel per pass (2r + 1, averaged over the frame); with `square`, taps per pixel of the
/// non-separable 2-D filter, (2r + 1)².
template <class T>
[[nodiscard]] double mean_taps(const aaf::image<T>& beta, const aaf::image<T>& pixel_size,
                               const aaf::filter_settings<T>& s, bool square = false) {
    double sum = 0;
    for (std::size_t i = 0; i < beta.size(); ++i) {
        const double side = 2.0 * static_cast<double>(kernel_radius(beta.data()[i], pixel_size.data()[i], s)) + 1.0;
        sum += square ? side * side : side;
    }
    return sum / static_cast<double>(beta.size());
}

}  // namespace aaf_bench
