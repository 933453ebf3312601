// SPDX-License-Identifier: MIT
#pragma once
// Plain, deliberately slow reference implementations of aaf's visibility filter and slope spreading
// (FORMULAS.md §1.8, §1.11–§1.14), written to be obviously correct rather than fast:
//
//   filter_2d         the NON-separable spatially varying guided Gaussian (what the theory asks for);
//   filter_separable  the literal two-pass version the authors (and aaf) run: horizontal, then vertical,
//                     each pass with the CENTRE pixel's β and guide tests against the centre pixel;
//   spread_square     brute-force slope spreading over the full (2r+1)² window (optionally same-ID only);
//   spread_separable  the literal horizontal-then-vertical spreading rule with IDs.
//
// Weights are evaluated with one direct exp per tap, and sums are accumulated in double. As the weights
// are normalised, each is evaluated relative to the largest one, exp(−(e − e_min)), which is the same
// number in exact arithmetic and cannot underflow to an all-zero sum (see tap_sum). Only the
// *discrete* decisions are made in the input precision T, exactly as the library makes them, so that a
// decision sitting on a rounding boundary cannot flip between the two: the kernel radius
// ceil(truncation·β/d) and the normal test dot(n_c, n_j) >= cos(threshold). In light-plane mode the
// position difference p_j − p_c is also formed in T (it is the input quantity); everything after it is
// double.
//
// Conventions shared with the library (filter.hpp):
// * a centre with β ≤ 0, NaN β, pixel size ≤ 0 / NaN, or a zero kernel radius is copied;
// * in light-plane mode a centre with a non-finite position is copied;
// * the centre tap is the pixel itself: weight 1 if its value is finite, no guide test;
// * non-finite neighbour values and guide-rejected neighbours (other ID; normal angle above the threshold,
//   or a NaN normal on either side; non-finite position in light-plane mode) are skipped;
// * the result is Σw·v / Σw, or the centre's own value when no tap is left.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <utility>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <aaf/guides.hpp>
#include <aaf/image.hpp>
#include <aaf/image_view.hpp>
#include <aaf/occlusion_stats.hpp>
#include <aaf/settings.hpp>

namespace aaf_ref {

using dvec3 = glm::vec<3, double>;

namespace detail {

/// Kernel radius of a centre with world width `b` and pixel size `d`, or -1 when the centre is copied.
/// Computed in T like the library (a discrete decision).
template <class T>
long kernel_radius(T b, T d, const aaf::filter_settings<T>& s) {
    if (!(b > T(0)) || !(d > T(0))) return -1;
    const T beta_px = b / d;
    if (!(beta_px > T(0))) return -1;
    const T r = std::ceil(s.truncation * beta_px);
    const long rr = r < static_cast<T>(s.max_radius) ? static_cast<long>(r) : static_cast<long>(s.max_radius);
    return rr == 0 ? -1 : rr;
}

template <class T>
T cos_threshold(const aaf::filter_settings<T>& s) {
    return std::cos(s.normal_threshold_degrees * std::numbers::pi_v<T> / T(180));
}

/// Guide test of neighbour (nx, ny) against centre (cx, cy): same ID, normals within the threshold.
template <class T, class G>
bool accepts(const G& g, std::size_t cx, std::size_t cy, std::size_t nx, std::size_t ny, T cos_thr) {
    if constexpr (G::has_ids)
        if (g.ids(nx, ny) != g.ids(cx, cy)) return false;
    if constexpr (G::has_normals) {
        const T c = glm::dot(g.normals(cx, cy), g.normals(nx, ny));
        if (!(c >= cos_thr)) return false;  // NaN on either side rejects
    }
    return true;
}

template <class T>
bool finite3(const glm::vec<3, T>& p) {
    return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
}

/// Exponent e of the Gaussian weight exp(−e) of neighbour (nx, ny) for centre (cx, cy), or NaN if the
/// neighbour must be skipped (non-finite position). `light_plane` chooses the distance:
/// image space e = (dx² + dy²)/(2β_px²); light plane e = r²/(2β²), r² = |Δp|² − (Δp·n_L)².
template <class T, class G>
double tap_exponent(const G& g, bool light_plane, const dvec3& n_light, std::size_t cx, std::size_t cy, std::size_t nx,
                    std::size_t ny, double beta_world, double beta_px) {
    if (!light_plane) {
        const double dx = static_cast<double>(nx) - static_cast<double>(cx);
        const double dy = static_cast<double>(ny) - static_cast<double>(cy);
        return (dx * dx + dy * dy) / (2.0 * beta_px * beta_px);
    } else {
        if constexpr (G::has_positions) {
            const glm::vec<3, T> pj = g.positions(nx, ny);
            if (!finite3(pj)) return std::numeric_limits<double>::quiet_NaN();
            const dvec3 dp(pj - g.positions(cx, cy));  // difference formed in T, the rest in double
            const double along = glm::dot(dp, n_light);
            const double r2 = std::max(glm::dot(dp, dp) - along * along, 0.0);
            return r2 / (2.0 * beta_world * beta_world);
        } else {
            return std::numeric_limits<double>::quiet_NaN();
        }
    }
}

/// Σ w·v / Σ w over taps (exponent e, value v) with w = exp(−e), or `fallback` if there are none.
/// The weights are normalised, so they are evaluated as exp(−(e − e_min)): exact in exact arithmetic,
/// and it never underflows to an all-zero sum (which matters for a non-finite centre, whose result is
/// the neighbours' weights only: with a narrow kernel exp(−e) itself can be 0 even in double).
struct tap_sum {
    std::vector<std::pair<double, double>> taps;
    void add(double e, double v) { taps.emplace_back(e, v); }
    [[nodiscard]] double result(double fallback) const {
        if (taps.empty()) return fallback;
        double e_min = std::numeric_limits<double>::infinity();
        for (const auto& t : taps) e_min = std::min(e_min, t.first);
        if (!std::isfinite(e_min)) return fallback;
        double sum = 0, wsum = 0;
        for (const auto& t : taps) {
            const double w = std::exp(-(t.first - e_min));
            sum += w * t.second;
            wsum += w;
        }
        return sum / wsum;
    }
};

template <class T>
dvec3 unit_light_normal(const glm::vec<3, T>& n) {
    const dvec3 d(n);
    return d / glm::length(d);
}

}  // namespace detail

/// A copy of a view as an owning double image.
template <class T>
aaf::image<double> to_double(aaf::const_image_view<T> v) {
    aaf::image<double> out(v.width(), v.height());
    for (std::size_t y = 0; y < v.height(); ++y)
        for (std::size_t x = 0; x < v.width(); ++x) out(x, y) = static_cast<double>(v(x, y));
    return out;
}

/// (a) The NON-separable 2-D spatially varying guided Gaussian: for each centre, the full (2r+1)² window.
template <class T, class G>
aaf::image<double> filter_2d(aaf::const_image_view<T> vis, aaf::const_image_view<T> beta,
                             aaf::const_image_view<T> pixel_size, const G& g, const aaf::filter_settings<T>& s,
                             const glm::vec<3, T>& light_normal = {0, 1, 0}) {
    const std::size_t w = vis.width(), h = vis.height();
    const bool light_plane = s.space == aaf::offset_space::light_plane;
    const dvec3 nl = detail::unit_light_normal(light_normal);
    const T cos_thr = detail::cos_threshold(s);
    aaf::image<double> out(w, h);
    for (std::size_t cy = 0; cy < h; ++cy)
        for (std::size_t cx = 0; cx < w; ++cx) {
            const double centre = static_cast<double>(vis(cx, cy));
            out(cx, cy) = centre;
            const long r = detail::kernel_radius(beta(cx, cy), pixel_size(cx, cy), s);
            if (r < 0) continue;
            if constexpr (G::has_positions)
                if (light_plane && !detail::finite3(g.positions(cx, cy))) continue;
            const double bw = static_cast<double>(beta(cx, cy));
            const double bpx = bw / static_cast<double>(pixel_size(cx, cy));
            detail::tap_sum acc;
            if (std::isfinite(centre)) acc.add(0.0, centre);  // the centre tap: weight exp(0) = 1
            for (long dy = -r; dy <= r; ++dy)
                for (long dx = -r; dx <= r; ++dx) {
                    if (dx == 0 && dy == 0) continue;  // the centre tap, counted above
                    const long nxl = static_cast<long>(cx) + dx, nyl = static_cast<long>(cy) + dy;
                    if (nxl < 0 || nyl < 0 || nxl >= static_cast<long>(w) || nyl >= static_cast<long>(h)) continue;
                    const auto nx = static_cast<std::size_t>(nxl), ny = static_cast<std::size_t>(nyl);
                    const double v = static_cast<double>(vis(nx, ny));
                    if (!std::isfinite(v) || !detail::accepts(g, cx, cy, nx, ny, cos_thr)) continue;
                    const double e = detail::tap_exponent<T>(g, light_plane, nl, cx, cy, nx, ny, bw, bpx);
                    if (std::isnan(e)) continue;
                    acc.add(e, v);
                }
            out(cx, cy) = acc.result(centre);
        }
    return out;
}

/// One literal 1-D pass of the separable filter (horizontal if `horizontal`), reading `src` (double).
template <class T, class G>
aaf::image<double> filter_pass(const aaf::image<double>& src, bool horizontal, aaf::const_image_view<T> beta,
                               aaf::const_image_view<T> pixel_size, const G& g, const aaf::filter_settings<T>& s,
                               const glm::vec<3, T>& light_normal) {
    const std::size_t w = src.width(), h = src.height();
    const bool light_plane = s.space == aaf::offset_space::light_plane;
    const dvec3 nl = detail::unit_light_normal(light_normal);
    const T cos_thr = detail::cos_threshold(s);
    aaf::image<double> out(w, h);
    for (std::size_t cy = 0; cy < h; ++cy)
        for (std::size_t cx = 0; cx < w; ++cx) {
            const double centre = src(cx, cy);
            out(cx, cy) = centre;
            const long r = detail::kernel_radius(beta(cx, cy), pixel_size(cx, cy), s);
            if (r < 0) continue;
            if constexpr (G::has_positions)
                if (light_plane && !detail::finite3(g.positions(cx, cy))) continue;
            const double bw = static_cast<double>(beta(cx, cy));
            const double bpx = bw / static_cast<double>(pixel_size(cx, cy));
            detail::tap_sum acc;
            if (std::isfinite(centre)) acc.add(0.0, centre);  // the centre tap: weight exp(0) = 1
            for (long k = -r; k <= r; ++k) {
                if (k == 0) continue;
                const long nxl = static_cast<long>(cx) + (horizontal ? k : 0);
                const long nyl = static_cast<long>(cy) + (horizontal ? 0 : k);
                if (nxl < 0 || nyl < 0 || nxl >= static_cast<long>(w) || nyl >= static_cast<long>(h)) continue;
                const auto nx = static_cast<std::size_t>(nxl), ny = static_cast<std::size_t>(nyl);
                const double v = src(nx, ny);
                if (!std::isfinite(v) || !detail::accepts(g, cx, cy, nx, ny, cos_thr)) continue;
                const double e = detail::tap_exponent<T>(g, light_plane, nl, cx, cy, nx, ny, bw, bpx);
                if (std::isnan(e)) continue;
                acc.add(e, v);
            }
            out(cx, cy) = acc.result(centre);
        }
    return out;
}

/// (b) The literal separable filter: a horizontal pass, then a vertical pass over its result.
template <class T, class G>
aaf::image<double> filter_separable(aaf::const_image_view<T> vis, aaf::const_image_view<T> beta,
                                    aaf::const_image_view<T> pixel_size, const G& g, const aaf::filter_settings<T>& s,
                                    const glm::vec<3, T>& light_normal = {0, 1, 0}) {
    const aaf::image<double> src = to_double(vis);
    const aaf::image<double> tmp = filter_pass(src, true, beta, pixel_size, g, s, light_normal);
    return filter_pass(tmp, false, beta, pixel_size, g, s, light_normal);
}

// ----------------------------------------------------------------------------------------------------
// Slope spreading (FORMULAS.md §1.12).

/// (c) Brute force over the full square window: every pixel without an occluder (s2 = +∞) gets the max s1
/// and min s2 (starting from the identity {0, +∞}) of the occluded pixels (s2 finite) within `radius`
/// in x and y; with `ids` non-empty, only those with the centre's ID. Occluded pixels keep their slopes.
/// Without IDs this is exactly what a horizontal-then-vertical max/min computes. With IDs it is the ideal
/// "same object within the square" rule, which the separable pass only approximates.
template <class T>
aaf::image<aaf::slope_pair<T>> spread_square(aaf::const_image_view<aaf::slope_pair<T>> in, long radius,
                                             aaf::const_image_view<std::uint32_t> ids = {}) {
    const long w = static_cast<long>(in.width()), h = static_cast<long>(in.height());
    aaf::image<aaf::slope_pair<T>> out(in.width(), in.height());
    for (long y = 0; y < h; ++y)
        for (long x = 0; x < w; ++x) {
            const auto& c = in(static_cast<std::size_t>(x), static_cast<std::size_t>(y));
            auto& o = out(static_cast<std::size_t>(x), static_cast<std::size_t>(y));
            if (std::isfinite(c.s2)) {
                o = c;
                continue;
            }
            if (radius == 0) {
                o = c;  // radius 0: the library does nothing at all
                continue;
            }
            aaf::slope_pair<T> acc{};  // {0, +inf}
            for (long j = std::max(0L, y - radius); j <= std::min(h - 1, y + radius); ++j)
                for (long i = std::max(0L, x - radius); i <= std::min(w - 1, x + radius); ++i) {
                    const auto& v = in(static_cast<std::size_t>(i), static_cast<std::size_t>(j));
                    if (!std::isfinite(v.s2)) continue;
                    if (!ids.empty() &&
                        ids(static_cast<std::size_t>(i), static_cast<std::size_t>(j)) !=
                            ids(static_cast<std::size_t>(x), static_cast<std::size_t>(y)))
                        continue;
                    acc.s1 = std::max(acc.s1, v.s1);
                    acc.s2 = std::min(acc.s2, v.s2);
                }
            o = acc;
        }
    return out;
}

/// The literal separable spreading rule of the authors' code, with IDs:
///   H(x, y) = max/min over occluded (i, y), |i − x| ≤ r, with ids(i, y) == ids(x, y);
///   result(x, y) for an unoccluded pixel = max/min over (x, j), |j − y| ≤ r, with ids(x, j) == ids(x, y)
///   and H(x, j) non-empty, of H(x, j). Occluded pixels keep their own slopes.
template <class T>
aaf::image<aaf::slope_pair<T>> spread_separable(aaf::const_image_view<aaf::slope_pair<T>> in, long radius,
                                                aaf::const_image_view<std::uint32_t> ids) {
    const long w = static_cast<long>(in.width()), h = static_cast<long>(in.height());
    const auto at = [](auto& img, long x, long y) -> decltype(auto) {
        return img(static_cast<std::size_t>(x), static_cast<std::size_t>(y));
    };
    const auto id = [&](long x, long y) { return ids.empty() ? 0u : at(ids, x, y); };
    if (radius == 0) {
        aaf::image<aaf::slope_pair<T>> same(in.width(), in.height());
        for (long y = 0; y < h; ++y)
            for (long x = 0; x < w; ++x) at(same, x, y) = at(in, x, y);
        return same;
    }
    aaf::image<aaf::slope_pair<T>> hp(in.width(), in.height()), out(in.width(), in.height());
    for (long y = 0; y < h; ++y)
        for (long x = 0; x < w; ++x) {
            aaf::slope_pair<T> acc{};
            for (long i = std::max(0L, x - radius); i <= std::min(w - 1, x + radius); ++i) {
                const auto& v = at(in, i, y);
                if (!std::isfinite(v.s2) || id(i, y) != id(x, y)) continue;
                acc.s1 = std::max(acc.s1, v.s1);
                acc.s2 = std::min(acc.s2, v.s2);
            }
            at(hp, x, y) = acc;
        }
    for (long y = 0; y < h; ++y)
        for (long x = 0; x < w; ++x) {
            if (std::isfinite(at(in, x, y).s2)) {
                at(out, x, y) = at(in, x, y);
                continue;
            }
            aaf::slope_pair<T> acc{};
            for (long j = std::max(0L, y - radius); j <= std::min(h - 1, y + radius); ++j) {
                const auto& v = at(hp, x, j);
                if (!std::isfinite(v.s2) || id(x, j) != id(x, y)) continue;
                acc.s1 = std::max(acc.s1, v.s1);
                acc.s2 = std::min(acc.s2, v.s2);
            }
            at(out, x, y) = acc;
        }
    return out;
}

// ----------------------------------------------------------------------------------------------------
// Small deterministic input generators shared by the filter and spreading tests (no <random>
// distributions, so the inputs are the same on every standard library).

/// splitmix64: a tiny, well-mixed, portable generator.
struct rng {
    std::uint64_t state;
    explicit rng(std::uint64_t seed) : state(seed) {}
    std::uint64_t next() {
        std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        return z ^ (z >> 31);
    }
    /// Uniform in [0, 1).
    double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
    double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
    std::uint32_t below(std::uint32_t n) { return static_cast<std::uint32_t>(next() % n); }
};

}  // namespace aaf_ref
