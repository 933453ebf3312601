// SPDX-License-Identifier: MIT
#pragma once
// The guided edge-avoiding à-trous wavelet filter (Dammertz, Sewtz, Hanika, Lensch 2010) in the form of
// SVGF's spatial filter (Schied et al. 2017): a 5×5 B3-spline kernel applied 1–5 times with the step
// doubling (1, 2, 4, 8, 16 px), each tap weighted by G-buffer edge stops (object ID, normal, plane
// distance) and, optionally, by a luminance stop driven by the per-pixel variance of the input, which is
// filtered along with the value. The peer a renderer author would pick instead of aaf for a noisy
// Monte Carlo shadow: it needs no occluder distances, only the G-buffer.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <type_traits>
#include <utility>

#include "../config.hpp"
#include "../executor.hpp"
#include "../guides.hpp"
#include "../image.hpp"
#include "../image_view.hpp"
#include "edge_stops.hpp"

namespace aaf {
inline namespace v0 {

/// Settings of atrous_filter.
template <class T = float>
struct atrous_settings {
    std::uint32_t iterations = 3;   ///< passes of the 5×5 kernel, step 2^i px in pass i; [1, 5] (SVGF 5)
    edge_stop_settings<T> edges{};  ///< ID, normal and plane-distance stops
    /// Luminance stop w_l = exp(−|v_c − v′| / (luminance_sigma · √(g ⊛ var)_c + ε)) with the centre's
    /// variance prefiltered by a 3×3 Gaussian g (SVGF, σ_l = 4); (0, ∞]. Used only when a variance image
    /// is given; +∞ = off.
    T luminance_sigma = 4;
    T luminance_epsilon = T(1e-4);  ///< ε above, in visibility units; > 0 (keeps a zero variance finite)
};

/// Throws aaf::invalid_argument naming the first invalid field.
template <class T>
void validate(const atrous_settings<T>& s, const char* function = "validate") {
    if (s.iterations < 1 || s.iterations > 5)
        detail::throw_invalid(function, "`settings.iterations` must be in [1, 5] (got " + std::to_string(s.iterations) + ")");
    validate(s.edges, function, "settings.edges");
    if (!(s.luminance_sigma > T(0)))
        detail::throw_invalid(function, "`settings.luminance_sigma` must be > 0 (+inf = off) (got " + std::to_string(s.luminance_sigma) + ")");
    if (!(s.luminance_epsilon > T(0)) || !std::isfinite(s.luminance_epsilon))
        detail::throw_invalid(function, "`settings.luminance_epsilon` must be finite and > 0 (got " + std::to_string(s.luminance_epsilon) + ")");
}

namespace detail {

/// The 1-D B3-spline taps (1, 4, 6, 4, 1)/16 at offsets −2..2.
template <class T>
inline constexpr std::array<T, 5> b3_taps{T(1) / 16, T(1) / 4, T(3) / 8, T(1) / 4, T(1) / 16};

/// One à-trous pass with step `step` over rows [y0, y1): `src` → `dst`, and (with a variance) `var_src` →
/// `var_dst` (the variance of the weighted mean, Σw²var′/(Σw)², as SVGF). `var_pre` is the centre's
/// prefiltered variance for the luminance stop (empty = no luminance stop).
template <class T, class G>
void atrous_pass(const_image_view<T> src, image_view<T> dst, const_image_view<T> var_src, image_view<T> var_dst,
                 const_image_view<T> var_pre, const_image_view<T> pixel_size, const G& g, const atrous_settings<T>& s,
                 std::size_t step, std::size_t y0, std::size_t y1) noexcept {
    const std::size_t w = src.width(), h = src.height();
    const bool variance = !var_src.empty();
    const bool luminance = !var_pre.empty() && std::isfinite(s.luminance_sigma);
    for (std::size_t y = y0; y < y1; ++y)
        for (std::size_t x = 0; x < w; ++x) {
            const T c = src(x, y);
            const bool finite_centre = std::isfinite(c);
            const edge_stop_center<T, G> ec(g, pixel_size, s.edges, x, y);
            T inv_lum = T(0);
            if (luminance && finite_centre) {
                const T sd = std::sqrt(std::max(var_pre(x, y), T(0)));
                inv_lum = T(1) / (s.luminance_sigma * (std::isfinite(sd) ? sd : T(0)) + s.luminance_epsilon);
            }
            // The centre tap (weight h0², no stop) when finite; a non-finite centre takes its accepted
            // neighbours' average without the luminance stop (which needs a centre value), or stays.
            T sum = T(0), wsum = T(0), vsum = T(0);
            if (finite_centre) {
                const T w0 = b3_taps<T>[2] * b3_taps<T>[2];
                sum = w0 * c, wsum = w0;
                if (variance) vsum = w0 * w0 * var_src(x, y);
            }
            if (ec.valid)
                for (int j = -2; j <= 2; ++j) {
                    const long ny = static_cast<long>(y) + j * static_cast<long>(step);
                    if (ny < 0 || ny >= static_cast<long>(h)) continue;
                    for (int i = -2; i <= 2; ++i) {
                        if (i == 0 && j == 0) continue;
                        const long nx = static_cast<long>(x) + i * static_cast<long>(step);
                        if (nx < 0 || nx >= static_cast<long>(w)) continue;
                        const auto ux = static_cast<std::size_t>(nx), uy = static_cast<std::size_t>(ny);
                        const T v = src(ux, uy);
                        if (!std::isfinite(v)) continue;
                        const T r = static_cast<T>(step) * std::sqrt(static_cast<T>(i * i + j * j));
                        T wt = b3_taps<T>[static_cast<std::size_t>(i + 2)] * b3_taps<T>[static_cast<std::size_t>(j + 2)] *
                               ec.weight(g, s.edges, ux, uy, r);
                        if (inv_lum > T(0)) wt *= std::exp(-std::abs(c - v) * inv_lum);
                        if (!(wt > T(0))) continue;
                        sum += wt * v;
                        wsum += wt;
                        if (variance) vsum += wt * wt * var_src(ux, uy);
                    }
                }
            if (wsum > T(0)) {
                dst(x, y) = sum / wsum;
                if (variance) var_dst(x, y) = vsum / (wsum * wsum);
            } else {
                dst(x, y) = c;
                if (variance) var_dst(x, y) = var_src(x, y);
            }
        }
}

/// 3×3 Gaussian (1 2 1)ᵀ(1 2 1)/16 of `var` over finite neighbours with the same ID (SVGF's prefilter of
/// the variance for the luminance stop), rows [y0, y1).
template <class T, class G>
void prefilter_variance(const_image_view<T> var, image_view<T> out, const G& g, std::size_t y0, std::size_t y1) noexcept {
    const std::size_t w = var.width(), h = var.height();
    constexpr std::array<T, 3> k{T(1), T(2), T(1)};
    for (std::size_t y = y0; y < y1; ++y)
        for (std::size_t x = 0; x < w; ++x) {
            T sum = T(0), wsum = T(0);
            for (int j = -1; j <= 1; ++j)
                for (int i = -1; i <= 1; ++i) {
                    const long nx = static_cast<long>(x) + i, ny = static_cast<long>(y) + j;
                    if (nx < 0 || ny < 0 || nx >= static_cast<long>(w) || ny >= static_cast<long>(h)) continue;
                    const auto ux = static_cast<std::size_t>(nx), uy = static_cast<std::size_t>(ny);
                    if constexpr (G::has_ids)
                        if (g.ids(ux, uy) != g.ids(x, y)) continue;
                    const T v = var(ux, uy);
                    if (!std::isfinite(v)) continue;
                    const T wt = k[static_cast<std::size_t>(i + 1)] * k[static_cast<std::size_t>(j + 1)];
                    sum += wt * v, wsum += wt;
                }
            out(x, y) = wsum > T(0) ? sum / wsum : T(0);
        }
}

}  // namespace detail

/// Filters `value` (e.g. Monte Carlo visibility) into `output` with `settings.iterations` à-trous passes.
///
/// * `variance` (optional; empty = no luminance stop) is each pixel's variance of its value (for a mean of
///   n samples, the variance of that mean: see estimate_mean_variance); it drives the luminance stop and is
///   filtered along with the value, as in SVGF.
/// * `pixel_size` is each pixel's world footprint (the plane-distance stop's scale; may be empty when
///   `guides` has no positions).
/// * Guides (aaf::guides): `ids` (hard stop), `normals`, `positions` (needs normals); absent ones cost nothing.
/// * Non-finite values never spread: such neighbours are skipped, a non-finite centre takes its accepted
///   neighbours' average (or keeps its value if it has none). A pixel with non-finite guides is copied.
/// * `output` and `scratch` are the passes' ping-pong buffers; neither may alias `value`. With a variance,
///   three images of T are allocated per call (its ping-pong and prefilter).
/// * Cost: 25 taps per pixel and pass; rows run in parallel through `exec`, and the result does not depend on it.
/// Throws aaf::invalid_argument (before writing) on mismatched sizes or invalid settings.
template <class T, class G = guides<>, class Exec = sequential_executor>
    requires detail::is_guides<G>::value
void atrous_filter(std::type_identity_t<const_image_view<T>> value, std::type_identity_t<const_image_view<T>> variance,
                   std::type_identity_t<const_image_view<T>> pixel_size, image_view<T> output,
                   std::type_identity_t<image_view<T>> scratch, const G& g = {},
                   const std::type_identity_t<atrous_settings<T>>& s = {}, Exec&& exec = {}) {
    constexpr const char* fn = "atrous_filter";
    detail::require_nonempty(fn, "value", value);
    const std::size_t w = value.width(), h = value.height();
    detail::require_size_or_empty(fn, "variance", variance, w, h);
    if constexpr (G::has_positions) detail::require_size(fn, "pixel_size", pixel_size, w, h);
    else detail::require_size_or_empty(fn, "pixel_size", pixel_size, w, h);
    detail::require_size(fn, "output", output, w, h);
    detail::require_size(fn, "scratch", scratch, w, h);
    detail::require_guides(fn, g, w, h);
    validate(s, fn);
    if (output.bytes() == value.bytes() || output.bytes() == scratch.bytes() || scratch.bytes() == value.bytes())
        detail::throw_invalid(fn, "`output`, `scratch` and `value` must be distinct buffers");

    const bool has_var = !variance.empty();
    image<T> var_a, var_b, var_pre;
    if (has_var) var_a.reset(w, h), var_b.reset(w, h), var_pre.reset(w, h);
    // Ping-pong so that the last pass writes `output`: the first pass writes `output` for an odd count.
    image_view<T> bufs[2] = {output, scratch};
    std::size_t target = s.iterations % 2 == 1 ? 0 : 1;
    const_image_view<T> src = value, var_src = variance;
    for (std::uint32_t it = 0; it < s.iterations; ++it) {
        image_view<T> dst = bufs[target];
        image_view<T> var_dst = has_var ? (it % 2 == 0 ? var_a.view() : var_b.view()) : image_view<T>{};
        if (has_var)
            exec.parallel_for(h, [&](std::size_t b, std::size_t e) { detail::prefilter_variance<T>(var_src, var_pre.view(), g, b, e); });
        const_image_view<T> pre = has_var ? var_pre.cview() : const_image_view<T>{};
        const std::size_t step = std::size_t{1} << it;
        exec.parallel_for(h, [&](std::size_t b, std::size_t e) {
            detail::atrous_pass<T>(src, dst, var_src, var_dst, pre, pixel_size, g, s, step, b, e);
        });
        src = dst;
        var_src = var_dst;
        target ^= 1;
    }
}

/// The variance of a pixel's mean of `samples` binary (0/1) samples, estimated as m(1 − m)/samples with m
/// the 3×3 average of the finite values of the same object (IDs, when `g` has them): the Bernoulli
/// variance, taken from the neighbourhood so that a pixel whose few samples happen to agree (a 1-sample
/// pixel always does) still gets a variance near a penumbra. Non-finite values give NaN. `samples` ≥ 1.
template <class T, class G = guides<>, class Exec = sequential_executor>
    requires detail::is_guides<G>::value
void estimate_mean_variance(std::type_identity_t<const_image_view<T>> value, T samples, image_view<T> output,
                            const G& g = {}, Exec&& exec = {}) {
    constexpr const char* fn = "estimate_mean_variance";
    detail::require_nonempty(fn, "value", value);
    const std::size_t w = value.width(), h = value.height();
    detail::require_size(fn, "output", output, w, h);
    detail::require_guides(fn, g, w, h);
    if (!(samples >= T(1)) || !std::isfinite(samples))
        detail::throw_invalid(fn, "`samples` must be finite and >= 1 (got " + std::to_string(samples) + ")");
    if (output.bytes() == value.bytes()) detail::throw_invalid(fn, "`output` must not alias `value`");
    exec.parallel_for(h, [&](std::size_t y0, std::size_t y1) {
        for (std::size_t y = y0; y < y1; ++y)
            for (std::size_t x = 0; x < w; ++x) {
                if (!std::isfinite(value(x, y))) {
                    output(x, y) = std::numeric_limits<T>::quiet_NaN();
                    continue;
                }
                T sum = T(0);
                int n = 0;
                for (int j = -1; j <= 1; ++j)
                    for (int i = -1; i <= 1; ++i) {
                        const long nx = static_cast<long>(x) + i, ny = static_cast<long>(y) + j;
                        if (nx < 0 || ny < 0 || nx >= static_cast<long>(w) || ny >= static_cast<long>(h)) continue;
                        const auto ux = static_cast<std::size_t>(nx), uy = static_cast<std::size_t>(ny);
                        if constexpr (G::has_ids)
                            if (g.ids(ux, uy) != g.ids(x, y)) continue;
                        const T v = value(ux, uy);
                        if (std::isfinite(v)) sum += v, ++n;
                    }
                const T m = std::clamp(sum / static_cast<T>(n), T(0), T(1));
                output(x, y) = m * (T(1) - m) / samples;
            }
    });
}

}  // namespace v0
}  // namespace aaf
