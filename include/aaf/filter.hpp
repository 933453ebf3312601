// SPDX-License-Identifier: MIT
#pragma once
// The separable, spatially varying, guided Gaussian filter of visibility (FORMULAS.md §1.8, §1.11–§1.14)
// and the slope-spreading pass that gives unoccluded pixels their occluded neighbours' slopes (§1.12).

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <type_traits>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "executor.hpp"
#include "guides.hpp"
#include "image.hpp"
#include "image_view.hpp"
#include "occlusion_stats.hpp"
#include "settings.hpp"

namespace aaf {
inline namespace v0 {

namespace detail {

enum class pass_direction { horizontal, vertical };

/// Kernel radius in pixels for a width of `beta_px` pixels.
template <class T>
[[nodiscard]] std::size_t kernel_radius(T beta_px, const filter_settings<T>& s) noexcept {
    if (!(beta_px > T(0))) return 0;
    const T r = std::ceil(s.truncation * beta_px);
    return r < static_cast<T>(s.max_radius) ? static_cast<std::size_t>(r) : s.max_radius;
}

/// For k = 1..radius: calls `step(k)`, then `f(k, nx, ny, v)` for the neighbours at distance k along `Dir`
/// from (x, y) (`pos` is x or y, `extent` the width or height) whose value v is finite and which the guides
/// accept. The one definition of "a tap", shared by the filter pass (whose `step` advances its weight
/// recurrence once per k, in the hot loop) and the non-finite-centre fallback.
template <pass_direction Dir, class T, class G, class Step, class F>
void for_each_accepted_tap(const_image_view<T> src, const G& g, const guide_center<T, G>& gc, std::size_t x, std::size_t y,
                           std::size_t pos, std::size_t extent, std::size_t radius, T cos_threshold, Step&& step,
                           F&& f) noexcept {
    for (std::size_t k = 1; k <= radius; ++k) {
        step(k);
        for (int side = -1; side <= 1; side += 2) {
            if (side < 0 ? k > pos : pos + k >= extent) continue;
            const std::size_t j = side < 0 ? pos - k : pos + k;
            const std::size_t nx = Dir == pass_direction::horizontal ? j : x;
            const std::size_t ny = Dir == pass_direction::horizontal ? y : j;
            const T v = src(nx, ny);
            if (!std::isfinite(v) || !gc.accepts(g, nx, ny, cos_threshold)) continue;
            f(k, nx, ny, v);
        }
    }
}

/// Squared distance between the centre `p` and neighbour (nx, ny), projected on the light plane (§1.11).
template <class T, class G>
[[nodiscard]] T light_plane_distance2(const G& g, std::size_t nx, std::size_t ny, const glm::vec<3, T>& p,
                                      const glm::vec<3, T>& light_normal) noexcept {
    const glm::vec<3, T> dp = g.positions(nx, ny) - p;
    const T along = glm::dot(dp, light_normal);
    return std::max(glm::dot(dp, dp) - along * along, T(0));  // NaN stays NaN (std::max keeps its first argument)
}

/// The result of a pass for a non-finite centre: the Gaussian average of its accepted finite neighbours.
/// Such a centre has no weight of its own, so the result is a ratio of neighbour weights only, and for a
/// narrow kernel every exp(−e) can underflow to 0 in T (e.g. β/d < 0.07 px in float: exp(−1/(2·0.07²)) = 0)
/// although valid neighbours exist. The weights are normalised, so evaluate them relative to the largest,
/// exp(−(e − e_min)); `centre` is returned only when no neighbour is accepted.
template <pass_direction Dir, offset_space Space, class T, class G>
[[nodiscard]] T non_finite_centre_average(const_image_view<T> src, const G& g, const guide_center<T, G>& gc,
                                          const glm::vec<3, T>& p, const glm::vec<3, T>& light_normal, std::size_t x,
                                          std::size_t y, std::size_t pos, std::size_t extent, std::size_t radius, T a,
                                          T inv_two_beta2, T cos_threshold, T centre) noexcept {
    const auto for_each_tap = [&](auto&& f) {
        for_each_accepted_tap<Dir>(src, g, gc, x, y, pos, extent, radius, cos_threshold, [](std::size_t) {},
                                   [&](std::size_t k, std::size_t nx, std::size_t ny, T v) {
                                       T e;
                                       if constexpr (Space == offset_space::light_plane)
                                           e = light_plane_distance2(g, nx, ny, p, light_normal) * inv_two_beta2;
                                       else
                                           e = static_cast<T>(k) * static_cast<T>(k) * a;
                                       if (!std::isnan(e)) f(e, v);  // NaN position
                                   });
    };
    T e_min = std::numeric_limits<T>::infinity();
    for_each_tap([&](T e, T) { e_min = std::min(e_min, e); });
    if (!(e_min < std::numeric_limits<T>::infinity())) return centre;
    T sum = T(0), wsum = T(0);
    for_each_tap([&](T e, T v) {
        const T weight = std::exp(-(e - e_min));
        sum += weight * v;
        wsum += weight;
    });
    return sum / wsum;
}

/// One 1-D pass. For each pixel: the Gaussian of the *centre's* width over the neighbours along `dir`,
/// skipping neighbours that are non-finite or rejected by a guide, normalised by the weight sum.
/// A centre with β ≤ 0 (or NaN) is copied; a centre whose neighbours are all rejected keeps its value;
/// a non-finite centre gets its accepted finite neighbours' average (non_finite_centre_average).
template <pass_direction Dir, offset_space Space, class T, class G>
void filter_pass(const_image_view<T> src, image_view<T> dst, const_image_view<T> beta, const_image_view<T> pixel_size,
                 const G& g, const glm::vec<3, T>& light_normal, const filter_settings<T>& s, std::size_t y_begin,
                 std::size_t y_end) noexcept {
    const std::size_t w = src.width(), h = src.height();
    const T cos_threshold = std::cos(s.normal_threshold_degrees * std::numbers::pi_v<T> / T(180));
    for (std::size_t y = y_begin; y < y_end; ++y) {
        for (std::size_t x = 0; x < w; ++x) {
            const T centre = src(x, y);
            const T b = beta(x, y);
            const T d = pixel_size(x, y);
            const T beta_px = b / d;
            const std::size_t radius = (b > T(0) && d > T(0)) ? kernel_radius(beta_px, s) : 0;
            if (radius == 0) {
                dst(x, y) = centre;
                continue;
            }
            const guide_center<T, G> gc(g, x, y);
            glm::vec<3, T> p{0};
            T inv_two_beta2 = T(0);
            if constexpr (Space == offset_space::light_plane) {
                p = g.positions(x, y);
                inv_two_beta2 = T(1) / (T(2) * b * b);
                if (!std::isfinite(p.x + p.y + p.z)) {  // no position: cannot measure distances
                    dst(x, y) = centre;
                    continue;
                }
            }
            const bool centre_ok = std::isfinite(centre);
            const std::size_t pos = Dir == pass_direction::horizontal ? x : y;
            const std::size_t extent = Dir == pass_direction::horizontal ? w : h;
            if (!centre_ok) {
                dst(x, y) = non_finite_centre_average<Dir, Space>(src, g, gc, p, light_normal, x, y, pos, extent,
                                                                 radius, T(1) / (T(2) * beta_px * beta_px),
                                                                 inv_two_beta2, cos_threshold, centre);
                continue;
            }
            T sum = centre;
            T wsum = T(1);
            // Image space: w_k = exp(-k² a) by the recurrence w_k = w_{k-1}·m_k, m_k = exp(-(2k-1)a):
            // two exp per pixel instead of one per tap.
            const T a = T(1) / (T(2) * beta_px * beta_px);
            T wk = T(1), mk = std::exp(-a);
            const T q = mk * mk;
            for_each_accepted_tap<Dir>(
                src, g, gc, x, y, pos, extent, radius, cos_threshold,
                [&](std::size_t) {
                    if constexpr (Space == offset_space::image) {
                        wk *= mk;
                        mk *= q;
                    }
                },
                [&](std::size_t, std::size_t nx, std::size_t ny, T v) {
                    T weight = wk;
                    if constexpr (Space == offset_space::light_plane) {
                        weight = std::exp(-light_plane_distance2(g, nx, ny, p, light_normal) * inv_two_beta2);
                        if (!std::isfinite(weight)) return;  // NaN position
                    }
                    sum += weight * v;
                    wsum += weight;
                });
            dst(x, y) = wsum > T(0) ? sum / wsum : centre;
        }
    }
}

}  // namespace detail

/// Filters `visibility` into `output` with the separable guided Gaussian: a horizontal pass into
/// `scratch`, then a vertical pass into `output`, each with the centre pixel's width (as the authors).
///
/// * `filter_width` β is per pixel in world units (formulas.hpp); β ≤ 0 or NaN = leave that pixel as is.
/// * `pixel_size` d is each pixel's projected footprint (world units); image-space offsets use β/d pixels.
/// * Offsets in `offset_space::light_plane` need `guides.positions` and use distances projected on the
///   plane of `light_normal`; the window is still sized by β/d.
/// * Non-finite visibility never spreads: such neighbours are skipped; a non-finite centre takes its
///   valid neighbours' average (or stays as it was if it has none).
/// * `output` may alias neither `visibility` nor `scratch`. All views must have the same size.
/// Throws aaf::invalid_argument (before touching `output`) on mismatched sizes or invalid settings.
/// T is deduced from `output` only, so mutable views and `image<T>`s convert to the read-only inputs.
template <class T, class G = guides<>, class Exec = sequential_executor>
    requires detail::is_guides<G>::value
void filter_visibility(std::type_identity_t<const_image_view<T>> visibility,
                       std::type_identity_t<const_image_view<T>> filter_width,
                       std::type_identity_t<const_image_view<T>> pixel_size, image_view<T> output,
                       std::type_identity_t<image_view<T>> scratch, const G& g = {},
                       const std::type_identity_t<filter_settings<T>>& s = {},
                       const std::type_identity_t<glm::vec<3, T>>& light_normal = {0, 1, 0}, Exec&& exec = {}) {
    constexpr const char* fn = "filter_visibility";
    detail::require_nonempty(fn, "visibility", visibility);
    const std::size_t w = visibility.width(), h = visibility.height();
    detail::require_size(fn, "filter_width", filter_width, w, h);
    detail::require_size(fn, "pixel_size", pixel_size, w, h);
    detail::require_size(fn, "output", output, w, h);
    detail::require_size(fn, "scratch", scratch, w, h);
    detail::require_guides(fn, g, w, h);
    validate(s, fn);
    if (output.bytes() == visibility.bytes() || output.bytes() == scratch.bytes() ||
        scratch.bytes() == visibility.bytes())
        detail::throw_invalid(fn, "`output`, `scratch` and `visibility` must be distinct buffers");
    if (s.space == offset_space::light_plane) {
        if constexpr (!G::has_positions) {
            detail::throw_invalid(fn, "`settings.space` is light_plane but `guides.positions` is absent");
        } else {
            const T len = glm::length(light_normal);
            if (!(len > T(0)) || !std::isfinite(len)) detail::throw_invalid(fn, "`light_normal` must be a finite non-zero vector");
            const glm::vec<3, T> n = light_normal / len;
            exec.parallel_for(h, [&](std::size_t b, std::size_t e) {
                detail::filter_pass<detail::pass_direction::horizontal, offset_space::light_plane, T>(visibility, scratch, filter_width, pixel_size, g, n, s, b, e);
            });
            exec.parallel_for(h, [&](std::size_t b, std::size_t e) {
                detail::filter_pass<detail::pass_direction::vertical, offset_space::light_plane, T>(scratch, output, filter_width, pixel_size, g, n, s, b, e);
            });
            return;
        }
    }
    exec.parallel_for(h, [&](std::size_t b, std::size_t e) {
        detail::filter_pass<detail::pass_direction::horizontal, offset_space::image, T>(visibility, scratch, filter_width, pixel_size, g, light_normal, s, b, e);
    });
    exec.parallel_for(h, [&](std::size_t b, std::size_t e) {
        detail::filter_pass<detail::pass_direction::vertical, offset_space::image, T>(scratch, output, filter_width, pixel_size, g, light_normal, s, b, e);
    });
}

/// Convenience overload that allocates its own scratch image.
template <class T, class G = guides<>, class Exec = sequential_executor>
    requires detail::is_guides<G>::value
void filter_visibility(std::type_identity_t<const_image_view<T>> visibility,
                       std::type_identity_t<const_image_view<T>> filter_width,
                       std::type_identity_t<const_image_view<T>> pixel_size, image_view<T> output, const G& g = {},
                       const std::type_identity_t<filter_settings<T>>& s = {},
                       const std::type_identity_t<glm::vec<3, T>>& light_normal = {0, 1, 0}, Exec&& exec = {}) {
    image<T> scratch(visibility.width(), visibility.height());
    filter_visibility<T>(visibility, filter_width, pixel_size, output, scratch.view(), g, s, light_normal,
                         std::forward<Exec>(exec));
}

namespace detail {

template <pass_direction Dir, class T, class G>
void spread_pass(const_image_view<slope_pair<T>> src, image_view<slope_pair<T>> dst, const_image_view<slope_pair<T>> original,
                 const G& g, std::size_t radius, std::size_t y_begin, std::size_t y_end) noexcept {
    const std::size_t w = src.width(), h = src.height();
    for (std::size_t y = y_begin; y < y_end; ++y) {
        for (std::size_t x = 0; x < w; ++x) {
            if constexpr (Dir == pass_direction::vertical) {
                if (original(x, y).has_occluder()) {  // occluded pixels keep their own slopes
                    dst(x, y) = original(x, y);
                    continue;
                }
            }
            const std::size_t pos = Dir == pass_direction::horizontal ? x : y;
            const std::size_t extent = Dir == pass_direction::horizontal ? w : h;
            const std::size_t lo = pos > radius ? pos - radius : 0;
            const std::size_t hi = std::min(pos + radius, extent - 1);
            [[maybe_unused]] std::uint32_t id = 0;
            if constexpr (G::has_ids) id = g.ids(x, y);
            slope_pair<T> acc{};
            for (std::size_t j = lo; j <= hi; ++j) {
                const std::size_t nx = Dir == pass_direction::horizontal ? j : x;
                const std::size_t ny = Dir == pass_direction::horizontal ? y : j;
                if constexpr (G::has_ids)
                    if (g.ids(nx, ny) != id) continue;
                const slope_pair<T>& v = src(nx, ny);
                if (!v.has_occluder()) continue;
                acc.s1 = std::max(acc.s1, v.s1);
                acc.s2 = std::min(acc.s2, v.s2);
            }
            dst(x, y) = acc;
        }
    }
}

}  // namespace detail

/// Slope spreading (FORMULAS.md §1.12, the authors' pass): every pixel with no occluder of its own takes
/// the max s1 and min s2 of the occluded pixels within `radius` pixels (a square window, computed as a
/// horizontal then a vertical pass; with an `ids` guide, same object only). Occluded pixels keep theirs.
/// Pixels that receive nothing stay "no occluder" (s2 = +∞). In place on `slopes`, with `scratch` of the
/// same size. Only `g.ids` is used.
template <class T, class G = guides<>, class Exec = sequential_executor>
void spread_slopes(image_view<slope_pair<T>> slopes, image_view<slope_pair<T>> scratch, std::uint32_t radius,
                   const G& g = {}, Exec&& exec = {}) {
    static_assert(detail::is_guides<G>::value, "aaf::spread_slopes: `g` must be an aaf::guides<...>");
    constexpr const char* fn = "spread_slopes";
    detail::require_nonempty(fn, "slopes", slopes);
    const std::size_t w = slopes.width(), h = slopes.height();
    detail::require_size(fn, "scratch", scratch, w, h);
    if constexpr (G::has_ids) detail::require_size(fn, "guides.ids", g.ids, w, h);
    if (radius > 1024) detail::throw_invalid(fn, "`radius` must be <= 1024 (got " + std::to_string(radius) + ")");
    if (scratch.bytes() == slopes.bytes()) detail::throw_invalid(fn, "`scratch` must not alias `slopes`");
    if (radius == 0) return;
    // Horizontal: scratch = row-window max/min over occluded pixels. Vertical reads scratch, writes slopes,
    // skipping occluded pixels (whose values in `slopes` are still the originals it needs to keep).
    exec.parallel_for(h, [&](std::size_t b, std::size_t e) {
        detail::spread_pass<detail::pass_direction::horizontal, T>(slopes, scratch, slopes, g, radius, b, e);
    });
    exec.parallel_for(h, [&](std::size_t b, std::size_t e) {
        detail::spread_pass<detail::pass_direction::vertical, T>(scratch, slopes, slopes, g, radius, b, e);
    });
}

}  // namespace v0
}  // namespace aaf
