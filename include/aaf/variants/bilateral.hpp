// SPDX-License-Identifier: MIT
#pragma once
// A joint (cross) bilateral filter guided by the G-buffer (Petschnigg et al. 2004, Eisemann & Durand
// 2004): a 2-D Gaussian in pixels whose taps are weighted by the edge stops of the G-buffer (object ID,
// normal, plane distance), never by the noisy value itself. The simplest image-space denoiser a renderer
// author would apply to a noisy Monte Carlo shadow instead of aaf: one width for the whole image.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <type_traits>
#include <vector>

#include "../config.hpp"
#include "../executor.hpp"
#include "../guides.hpp"
#include "../image_view.hpp"
#include "edge_stops.hpp"

namespace aaf {
inline namespace v0 {

/// Settings of bilateral_filter.
template <class T = float>
struct bilateral_settings {
    T sigma_pixels = 2;             ///< spatial Gaussian's standard deviation in pixels; (0, 64]
    T truncation = 2.5;             ///< window radius ⌈truncation · sigma_pixels⌉ px; (0, 5]
    edge_stop_settings<T> edges{};  ///< ID, normal and plane-distance stops
};

/// Throws aaf::invalid_argument naming the first invalid field.
template <class T>
void validate(const bilateral_settings<T>& s, const char* function = "validate") {
    if (!(s.sigma_pixels > T(0) && s.sigma_pixels <= T(64)))
        detail::throw_invalid(function, "`settings.sigma_pixels` must be in (0, 64] (got " + std::to_string(s.sigma_pixels) + ")");
    if (!(s.truncation > T(0) && s.truncation <= T(5)))
        detail::throw_invalid(function, "`settings.truncation` must be in (0, 5] (got " + std::to_string(s.truncation) + ")");
    validate(s.edges, function, "settings.edges");
}

/// Filters `value` into `output` with the joint bilateral filter (one non-separable 2-D pass, (2r+1)² taps
/// per pixel with r = ⌈truncation·sigma_pixels⌉).
///
/// * `pixel_size` is each pixel's world footprint (the plane-distance stop's scale; may be empty when
///   `guides` has no positions).
/// * Non-finite values never spread: such neighbours are skipped, a non-finite centre takes its accepted
///   neighbours' average (or keeps its value if it has none). A pixel with non-finite guides is copied.
/// * `output` may not alias `value`. Rows run in parallel through `exec`; the result does not depend on it.
/// Throws aaf::invalid_argument (before writing) on mismatched sizes or invalid settings.
template <class T, class G = guides<>, class Exec = sequential_executor>
    requires detail::is_guides<G>::value
void bilateral_filter(std::type_identity_t<const_image_view<T>> value, std::type_identity_t<const_image_view<T>> pixel_size,
                      image_view<T> output, const G& g = {}, const std::type_identity_t<bilateral_settings<T>>& s = {},
                      Exec&& exec = {}) {
    constexpr const char* fn = "bilateral_filter";
    detail::require_nonempty(fn, "value", value);
    const std::size_t w = value.width(), h = value.height();
    if constexpr (G::has_positions) detail::require_size(fn, "pixel_size", pixel_size, w, h);
    else detail::require_size_or_empty(fn, "pixel_size", pixel_size, w, h);
    detail::require_size(fn, "output", output, w, h);
    detail::require_guides(fn, g, w, h);
    validate(s, fn);
    if (output.bytes() == value.bytes()) detail::throw_invalid(fn, "`output` must not alias `value`");

    const long r = static_cast<long>(std::ceil(s.truncation * s.sigma_pixels));
    // The spatial weights and tap distances of the window, once per call.
    const std::size_t side = static_cast<std::size_t>(2 * r + 1);
    std::vector<T> spatial(side * side), dist(side * side);
    for (long j = -r; j <= r; ++j)
        for (long i = -r; i <= r; ++i) {
            const std::size_t k = static_cast<std::size_t>((j + r) * (2 * r + 1) + (i + r));
            const T d2 = static_cast<T>(i * i + j * j);
            spatial[k] = std::exp(-d2 / (T(2) * s.sigma_pixels * s.sigma_pixels));
            dist[k] = std::sqrt(d2);
        }
    exec.parallel_for(h, [&](std::size_t y0, std::size_t y1) {
        for (std::size_t y = y0; y < y1; ++y)
            for (std::size_t x = 0; x < w; ++x) {
                const T c = value(x, y);
                const detail::edge_stop_center<T, G> ec(g, pixel_size, s.edges, x, y);
                T sum = T(0), wsum = T(0);
                if (std::isfinite(c)) sum = c, wsum = T(1);
                if (ec.valid)
                    for (long j = -r; j <= r; ++j) {
                        const long ny = static_cast<long>(y) + j;
                        if (ny < 0 || ny >= static_cast<long>(h)) continue;
                        for (long i = -r; i <= r; ++i) {
                            const long nx = static_cast<long>(x) + i;
                            if ((i == 0 && j == 0) || nx < 0 || nx >= static_cast<long>(w)) continue;
                            const auto ux = static_cast<std::size_t>(nx), uy = static_cast<std::size_t>(ny);
                            const T v = value(ux, uy);
                            if (!std::isfinite(v)) continue;
                            const std::size_t k = static_cast<std::size_t>((j + r) * (2 * r + 1) + (i + r));
                            const T wt = spatial[k] * ec.weight(g, s.edges, ux, uy, dist[k]);
                            if (!(wt > T(0))) continue;
                            sum += wt * v;
                            wsum += wt;
                        }
                    }
                output(x, y) = wsum > T(0) ? sum / wsum : c;
            }
    });
}

}  // namespace v0
}  // namespace aaf
