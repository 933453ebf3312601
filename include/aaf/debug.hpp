// SPDX-License-Identifier: MIT
#pragma once
// Debug views: heat maps of any per-pixel quantity (β, samples per pixel, d1, d2min/d2max, slopes) and
// difference images. Functions over views; no I/O (write the RGB8 result with any image writer).

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>

#include <glm/vec3.hpp>

#include "image_view.hpp"
#include "occlusion_stats.hpp"

namespace aaf {
inline namespace v0 {

using rgb8 = glm::vec<3, std::uint8_t>;

/// Colour of t in [0, 1] on a perceptually ordered dark-blue → teal → yellow ramp (viridis, 9 knots,
/// linearly interpolated). NaN maps to magenta so undefined pixels stand out.
[[nodiscard]] inline rgb8 heat_color(double t) noexcept {
    if (std::isnan(t)) return {255, 0, 255};
    static constexpr std::array<std::array<std::uint8_t, 3>, 9> knots{{{68, 1, 84},
                                                                       {71, 44, 122},
                                                                       {59, 81, 139},
                                                                       {44, 113, 142},
                                                                       {33, 144, 141},
                                                                       {39, 173, 129},
                                                                       {92, 200, 99},
                                                                       {170, 220, 50},
                                                                       {253, 231, 37}}};
    t = std::clamp(t, 0.0, 1.0) * 8.0;
    const auto i = std::min<std::size_t>(static_cast<std::size_t>(t), 7);
    const double f = t - static_cast<double>(i);
    rgb8 c;
    for (int k = 0; k < 3; ++k)
        c[k] = static_cast<std::uint8_t>(std::lround(knots[i][k] * (1.0 - f) + knots[i + 1][k] * f));
    return c;
}

/// The range a heat map spans. Defaults: the finite min and max of the data.
struct heat_range {
    double lo = std::numeric_limits<double>::quiet_NaN();
    double hi = std::numeric_limits<double>::quiet_NaN();
};

/// Heat map of `values(x, y)` (any arithmetic pixel type) into `out`. `range` fixes the colour scale
/// (NaN bounds = auto from the finite data); `log_scale` maps log10 of positive values (for β or n).
/// Returns the range used, for a legend. Throws aaf::invalid_argument on size mismatch.
template <class V>
heat_range heat_map(const_image_view<V> values, image_view<rgb8> out, heat_range range = {}, bool log_scale = false) {
    detail::require_nonempty("heat_map", "values", values);
    detail::require_size("heat_map", "out", out, values.width(), values.height());
    const auto map = [&](double v) { return log_scale ? (v > 0 ? std::log10(v) : std::numeric_limits<double>::quiet_NaN()) : v; };
    if (std::isnan(range.lo) || std::isnan(range.hi)) {
        double lo = std::numeric_limits<double>::infinity(), hi = -lo;
        for (std::size_t y = 0; y < values.height(); ++y)
            for (std::size_t x = 0; x < values.width(); ++x) {
                const double v = map(static_cast<double>(values(x, y)));
                if (!std::isfinite(v)) continue;
                lo = std::min(lo, v);
                hi = std::max(hi, v);
            }
        // A bound the caller fixed is in data units, like a fully fixed range: map it as well.
        range.lo = std::isnan(range.lo) ? (std::isfinite(lo) ? lo : 0.0) : map(range.lo);
        range.hi = std::isnan(range.hi) ? (std::isfinite(hi) ? hi : 1.0) : map(range.hi);
    } else if (log_scale) {
        range = {map(range.lo), map(range.hi)};
    }
    const double span = range.hi > range.lo ? range.hi - range.lo : 1.0;
    for (std::size_t y = 0; y < values.height(); ++y)
        for (std::size_t x = 0; x < values.width(); ++x) {
            const double v = map(static_cast<double>(values(x, y)));
            out(x, y) = std::isfinite(v) ? heat_color((v - range.lo) / span) : heat_color(std::numeric_limits<double>::quiet_NaN());
        }
    return range;
}

/// Which field of occlusion_stats a heat map shows.
enum class stats_field { samples, occluded, visibility, d1, d2min, d2max, s1, s2 };

/// Extracts one field of the statistics (or a slope) as doubles, for heat_map. Undefined values
/// (no occluder for d2/s, no light for visibility) are NaN.
template <class T>
void extract(const_image_view<occlusion_stats<T>> stats, stats_field field, image_view<double> out) {
    detail::require_nonempty("extract", "stats", stats);
    detail::require_size("extract", "out", out, stats.width(), stats.height());
    constexpr double nan = std::numeric_limits<double>::quiet_NaN();
    for (std::size_t y = 0; y < stats.height(); ++y)
        for (std::size_t x = 0; x < stats.width(); ++x) {
            const occlusion_stats<T>& s = stats(x, y);
            const slope_pair<T> sl = slopes(s);
            double v = nan;
            switch (field) {
                case stats_field::samples: v = s.samples; break;
                case stats_field::occluded: v = s.occluded; break;
                case stats_field::visibility: v = static_cast<double>(s.visibility()); break;
                case stats_field::d1: v = s.has_light() ? static_cast<double>(s.d1) : nan; break;
                case stats_field::d2min: v = s.has_occluder() ? static_cast<double>(s.d2min) : nan; break;
                case stats_field::d2max: v = s.has_occluder() ? static_cast<double>(s.d2max) : nan; break;
                case stats_field::s1: v = sl.has_occluder() ? static_cast<double>(sl.s1) : nan; break;
                case stats_field::s2: v = sl.has_occluder() ? static_cast<double>(sl.s2) : nan; break;
            }
            out(x, y) = v;
        }
}

/// Signed-difference image a − b on a diverging blue–white–red ramp, saturating at ±`scale`
/// (e.g. 0.1 visibility). Returns the RMSE over pixels where both are finite.
template <class T>
double difference_image(const_image_view<T> a, const_image_view<T> b, image_view<rgb8> out, double scale = 0.1) {
    detail::require_nonempty("difference_image", "a", a);
    detail::require_size("difference_image", "b", b, a.width(), a.height());
    detail::require_size("difference_image", "out", out, a.width(), a.height());
    if (!(scale > 0)) detail::throw_invalid("difference_image", "`scale` must be > 0");
    double sum = 0;
    std::size_t count = 0;
    for (std::size_t y = 0; y < a.height(); ++y)
        for (std::size_t x = 0; x < a.width(); ++x) {
            const double d = static_cast<double>(a(x, y)) - static_cast<double>(b(x, y));
            if (!std::isfinite(d)) {
                out(x, y) = {255, 0, 255};
                continue;
            }
            sum += d * d;
            ++count;
            const double t = std::clamp(d / scale, -1.0, 1.0);
            const auto fade = static_cast<std::uint8_t>(std::lround(255.0 * (1.0 - std::abs(t))));
            out(x, y) = t >= 0 ? rgb8{255, fade, fade} : rgb8{fade, fade, 255};
        }
    return count ? std::sqrt(sum / static_cast<double>(count)) : 0.0;
}

}  // namespace v0
}  // namespace aaf
