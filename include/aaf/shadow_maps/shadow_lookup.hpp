// SPDX-License-Identifier: MIT
#pragma once
// Shadow-map lookups over the user's G-buffer: the hard-shadow test, percentage-closer filtering (Reeves,
// Salesin & Cook 1987; FORMULAS.md §3.2) over an N×N grid, a Poisson disc or a per-pixel rotated Poisson
// disc, optionally bilinearly weighted (hardware PCF), and PCSS (Fernando 2005; FORMULAS.md §3.3): blocker
// search, penumbra estimate from the light's size, then PCF of that width clamped to the map.
//
// Result per pixel: the lit fraction in [0, 1] of the taps (1 = lit). Defined results, never NaN:
// * a pixel with a non-finite position or normal (no surface, sky) is 1;
// * a receiver outside the map's frustum (laterally, or in front of near / behind far) is 1: the map knows
//   of no occluder for it;
// * a tap that falls outside the map reads "nothing stored" (lit), like a GPU's border depth of 1;
// * a stored NaN never occludes.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <string>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "../executor.hpp"
#include "../gather.hpp"
#include "../image_view.hpp"
#include "../region.hpp"
#include "../sampler.hpp"
#include "depth_bias.hpp"
#include "depth_map.hpp"
#include "poisson_disc.hpp"

namespace aaf {
inline namespace v0 {

/// Which lookup a pixel gets.
enum class shadow_filter {
    hard,  ///< one texel, one comparison (the texel containing the receiver)
    pcf,   ///< percentage-closer filtering with pcf_settings
    pcss,  ///< percentage-closer soft shadows with pcss_settings (PCF taps from pcf_settings)
};

[[nodiscard]] constexpr const char* to_string(shadow_filter f) noexcept {
    return f == shadow_filter::hard ? "hard" : f == shadow_filter::pcf ? "pcf" : "pcss";
}

/// Where a PCF kernel's taps lie.
enum class pcf_pattern {
    grid,             ///< N×N taps at the centres of equal cells of the square [−r, r]², N = ⌊√taps⌋
    poisson,          ///< a fixed Poisson disc of radius r (poisson_disc), the same for every pixel
    rotated_poisson,  ///< that disc rotated per pixel by an angle from the pixel's sample key (region.hpp)
};

[[nodiscard]] constexpr const char* to_string(pcf_pattern p) noexcept {
    return p == pcf_pattern::grid ? "grid" : p == pcf_pattern::poisson ? "poisson" : "rotated_poisson";
}

/// PCF kernel settings.
template <class T = float>
struct pcf_settings {
    pcf_pattern pattern = pcf_pattern::grid;  ///< see pcf_pattern
    std::uint32_t taps = 16;                  ///< taps per pixel (grid: rounded down to a square), [1, 4096]
    T radius = 2;                             ///< kernel half-width (grid) or radius (disc) in texels, [0, 4096]; 2 with a 4×4 grid = the 16 nearest texel centres
    bool bilinear = false;                    ///< each tap weighs the 2×2 texels around it bilinearly (hardware PCF); 4 comparisons per tap
};

/// PCSS settings: the light's size (the field for the map's projection is required) and the search.
template <class T = float>
struct pcss_settings {
    T light_width = 0;                  ///< perspective maps: the light's width w_light (world units), > 0
    T light_angle = 0;                  ///< orthographic maps: tan of the light's full angular width, > 0
    std::uint32_t blocker_taps = 16;    ///< blocker-search taps, an N×N grid over the search region, [1, 4096]
    T max_radius = 32;                  ///< the search and PCF radii are clamped to this many texels, (0, 4096]
};

/// Everything a lookup pass needs besides the map and the G-buffer.
template <class T = float>
struct lookup_settings {
    shadow_filter filter = shadow_filter::pcf;  ///< see shadow_filter
    pcf_settings<T> pcf{};                      ///< PCF kernel (pcf, and pcss's final filter)
    pcss_settings<T> pcss{};                    ///< PCSS only
    bias_settings<T> bias{};                    ///< depth bias (default: automatic)
    std::uint32_t light_index = 0;              ///< sample-key field of the rotated Poisson disc
    std::uint32_t frame_seed = 0;               ///< sample-key field of the rotated Poisson disc
};

namespace detail {
template <class T>
void validate_lookup(const char* fn, const lookup_settings<T>& s, depth_projection projection) {
    validate_bias(fn, s.bias);
    if (s.pcf.taps < 1 || s.pcf.taps > 4096) throw_invalid(fn, "`settings.pcf.taps` must be in [1, 4096]");
    if (!(s.pcf.radius >= T(0) && s.pcf.radius <= T(4096))) throw_invalid(fn, "`settings.pcf.radius` must be in [0, 4096] texels");
    // The search's fields have valid defaults, so they are checked always (pcss_penumbra_width reads them in
    // any mode); the light's size only for PCSS, which cannot run without it.
    if (s.pcss.blocker_taps < 1 || s.pcss.blocker_taps > 4096) throw_invalid(fn, "`settings.pcss.blocker_taps` must be in [1, 4096]");
    if (!(s.pcss.max_radius > T(0) && s.pcss.max_radius <= T(4096))) throw_invalid(fn, "`settings.pcss.max_radius` must be in (0, 4096] texels");
    if (s.filter != shadow_filter::pcss) return;
    if (projection == depth_projection::perspective && !(s.pcss.light_width > T(0) && std::isfinite(s.pcss.light_width)))
        throw_invalid(fn, "`settings.pcss.light_width` must be finite and > 0 for a perspective map (PCSS needs the light's size)");
    if (projection == depth_projection::orthographic && !(s.pcss.light_angle > T(0) && std::isfinite(s.pcss.light_angle)))
        throw_invalid(fn, "`settings.pcss.light_angle` must be finite and > 0 for an orthographic map (PCSS needs the light's size)");
}

[[nodiscard]] inline std::uint32_t grid_side(std::uint32_t taps) noexcept {
    auto n = static_cast<std::uint32_t>(std::sqrt(static_cast<double>(taps)));
    while (n * n > taps) --n;
    while ((n + 1) * (n + 1) <= taps) ++n;
    return std::max(n, 1u);
}

template <class T>
[[nodiscard]] std::vector<glm::vec<2, T>> grid_offsets(std::uint32_t taps) {
    const std::uint32_t n = grid_side(taps);
    std::vector<glm::vec<2, T>> out;
    out.reserve(std::size_t{n} * n);
    for (std::uint32_t b = 0; b < n; ++b)
        for (std::uint32_t a = 0; a < n; ++a)
            out.emplace_back(static_cast<T>(2 * a + 1) / static_cast<T>(n) - T(1), static_cast<T>(2 * b + 1) / static_cast<T>(n) - T(1));
    return out;
}
}  // namespace detail

/// A depth map prepared for lookups with fixed settings: validates once, makes the tap pattern once, then
/// answers per point. Thread-safe (const); also the building block for helpers that look up several maps
/// (e.g. ambient occlusion from directional maps). The map's memory must outlive the sampler.
template <class T = float>
class shadow_map_sampler {
public:
    /// Throws aaf::invalid_argument naming `map` (empty, bad view) or the `settings` field.
    shadow_map_sampler(const depth_map_view<T>& map, const lookup_settings<T>& settings)
        : map_(map), settings_(settings) {
        constexpr const char* fn = "shadow_map_sampler";
        detail::require_depth_map(fn, map);
        detail::validate_lookup(fn, settings, map.view.projection);
        frame_ = light_frame<T>(map.view);
        taps_ = settings.pcf.pattern == pcf_pattern::grid ? detail::grid_offsets<T>(settings.pcf.taps)
                                                          : poisson_disc<T>(settings.pcf.taps);
        const std::uint32_t side = detail::grid_side(settings.pcf.taps);
        for (std::uint32_t a = 0; a < side; ++a) grid_1d_.push_back(taps_[a].x);  // the first row's x = every row's
        blocker_taps_ = detail::grid_offsets<T>(settings.pcss.blocker_taps);
    }

    [[nodiscard]] const depth_map_view<T>& map() const noexcept { return map_; }
    [[nodiscard]] const lookup_settings<T>& settings() const noexcept { return settings_; }
    /// The PCF kernel's taps as offsets in units of the kernel radius.
    [[nodiscard]] const std::vector<glm::vec<2, T>>& taps() const noexcept { return taps_; }

    /// Lit fraction at receiver `p` with unit normal `n` (either orientation); `key` seeds the rotated disc.
    [[nodiscard]] T visibility(const glm::vec<3, T>& p, const glm::vec<3, T>& n, const sample_key& key = {}) const noexcept {
        if (!detail::finite3(p) || !detail::finite3(n)) return T(1);
        const detail::prepared_receiver<T> r = prepare(p, n);
        if (!r.inside) return T(1);
        switch (settings_.filter) {
            case shadow_filter::hard: return hard(r);
            case shadow_filter::pcf: return pcf(r, settings_.pcf.radius, settings_.pcf.radius, key);
            case shadow_filter::pcss: return pcss(r, key);
        }
        return T(1);
    }

    /// The PCSS penumbra width (world units, at the receiver) this sampler estimates for `p`, or 0 when its
    /// blocker search finds no blocker (lit), `p` is outside the map, or the settings give no light size for
    /// the map's projection: for tests and debug views.
    [[nodiscard]] T pcss_penumbra_width(const glm::vec<3, T>& p, const glm::vec<3, T>& n) const noexcept {
        const T size = map_.view.projection == depth_projection::perspective ? settings_.pcss.light_width : settings_.pcss.light_angle;
        if (!(size > T(0) && std::isfinite(size)) || !detail::finite3(p) || !detail::finite3(n)) return T(0);
        const detail::prepared_receiver<T> r = prepare(p, n);
        if (!r.inside) return T(0);
        T d_blocker = 0;
        if (!blocker_search(r, d_blocker)) return T(0);
        return penumbra(r.depth, d_blocker);
    }

private:
    [[nodiscard]] detail::prepared_receiver<T> prepare(const glm::vec<3, T>& p, const glm::vec<3, T>& n) const noexcept {
        return detail::prepare_receiver(frame_, map_.width(), map_.height(), map_.format, settings_.bias, p, n);
    }

    /// True when texel (i, j) (any integers) occludes r; texels outside the map do not.
    [[nodiscard]] bool occludes(const detail::prepared_receiver<T>& r, std::ptrdiff_t i, std::ptrdiff_t j) const noexcept {
        if (i < 0 || j < 0 || static_cast<std::size_t>(i) >= map_.width() || static_cast<std::size_t>(j) >= map_.height()) return false;
        const auto ui = static_cast<std::size_t>(i), uj = static_cast<std::size_t>(j);
        return r.occluded_by(map_.depth(ui, uj), ui, uj);
    }

    [[nodiscard]] T hard(const detail::prepared_receiver<T>& r) const noexcept {
        // u == width (the frustum's closed edge) reads the last texel.
        const auto i = std::min(static_cast<std::ptrdiff_t>(r.u), static_cast<std::ptrdiff_t>(map_.width()) - 1);
        const auto j = std::min(static_cast<std::ptrdiff_t>(r.v), static_cast<std::ptrdiff_t>(map_.height()) - 1);
        return occludes(r, i, j) ? T(0) : T(1);
    }

    /// The N×N grid without bilinear weights, separably: a grid's taps share N columns and N rows, so the column
    /// and row indices, bounds and bias terms are computed 2N times instead of N² (threshold(i, j) is a sum of a
    /// column term and a row term), and each tap is a load and a comparison. Same taps as the general loop.
    [[nodiscard]] T pcf_grid(const detail::prepared_receiver<T>& r, T ru, T rv) const noexcept {
        constexpr std::size_t max_side = 64;  // taps <= 4096
        std::size_t cols[max_side], rows[max_side];
        T col_term[max_side], row_term[max_side];
        std::size_t nc = 0, nr = 0;
        const auto w = static_cast<std::ptrdiff_t>(map_.width()), h = static_cast<std::ptrdiff_t>(map_.height());
        for (const T o : grid_1d_) {
            const auto i = static_cast<std::ptrdiff_t>(std::floor(r.u + ru * o));
            if (i < 0 || i >= w) continue;  // outside the map: lit
            const T du = static_cast<T>(i) + T(0.5) - r.u;
            cols[nc] = static_cast<std::size_t>(i), col_term[nc++] = r.su * du - r.au * std::abs(du);
        }
        for (const T o : grid_1d_) {
            const auto j = static_cast<std::ptrdiff_t>(std::floor(r.v + rv * o));
            if (j < 0 || j >= h) continue;
            const T dv = static_cast<T>(j) + T(0.5) - r.v;
            rows[nr] = static_cast<std::size_t>(j), row_term[nr++] = r.z - r.c0 + r.sv * dv - r.av * std::abs(dv);
        }
        std::size_t occluded = 0;
        for (std::size_t b = 0; b < nr; ++b)
            for (std::size_t a = 0; a < nc; ++a) occluded += static_cast<T>(map_.depth(cols[a], rows[b])) < row_term[b] + col_term[a] ? 1 : 0;
        return T(1) - static_cast<T>(occluded) / static_cast<T>(taps_.size());
    }

    /// Lit fraction over the taps scaled by (ru, rv) texels around the receiver.
    [[nodiscard]] T pcf(const detail::prepared_receiver<T>& r, T ru, T rv, const sample_key& key) const noexcept {
        if (settings_.pcf.pattern == pcf_pattern::grid && !settings_.pcf.bilinear) return pcf_grid(r, ru, rv);
        T c = 1, s = 0;
        if (settings_.pcf.pattern == pcf_pattern::rotated_poisson) {
            glm::vec<2, T> xi;
            generate_samples<T>(sample_pattern::stratified, key, std::span<glm::vec<2, T>>(&xi, 1));
            const T a = T(2) * std::numbers::pi_v<T> * xi.x;
            c = std::cos(a), s = std::sin(a);
        }
        T lit = 0;
        for (const glm::vec<2, T>& o : taps_) {
            const T tu = r.u + ru * (c * o.x - s * o.y), tv = r.v + rv * (s * o.x + c * o.y);
            if (!settings_.pcf.bilinear) {
                lit += occludes(r, static_cast<std::ptrdiff_t>(std::floor(tu)), static_cast<std::ptrdiff_t>(std::floor(tv))) ? T(0) : T(1);
                continue;
            }
            // The four texels whose centres surround the tap, weighted by the tap's position between them.
            const T fu = tu - T(0.5), fv = tv - T(0.5);
            const T iu = std::floor(fu), iv = std::floor(fv);
            const T wu = fu - iu, wv = fv - iv;
            const auto i0 = static_cast<std::ptrdiff_t>(iu), j0 = static_cast<std::ptrdiff_t>(iv);
            const T l00 = occludes(r, i0, j0) ? T(0) : T(1), l10 = occludes(r, i0 + 1, j0) ? T(0) : T(1);
            const T l01 = occludes(r, i0, j0 + 1) ? T(0) : T(1), l11 = occludes(r, i0 + 1, j0 + 1) ? T(0) : T(1);
            lit += (T(1) - wv) * ((T(1) - wu) * l00 + wu * l10) + wv * ((T(1) - wu) * l01 + wu * l11);
        }
        return lit / static_cast<T>(taps_.size());
    }

    /// PCSS step 1: the mean depth of the occluding texels in the search region (similar triangles towards
    /// the near plane, FORMULAS.md §3.3). False when there is none.
    [[nodiscard]] bool blocker_search(const detail::prepared_receiver<T>& r, T& d_blocker) const noexcept {
        const light_view<T>& v = map_.view;
        const bool persp = v.projection == depth_projection::perspective;
        // Half-width of the search region in world units: perspective w_light/2·(z_r − n)/z_r at the near plane
        // (Fernando's w_search is its full width); orthographic (z_r − n)·tan/2 at any depth.
        const T half = persp ? settings_.pcss.light_width * T(0.5) * (r.depth - v.near_plane) / r.depth
                             : (r.depth - v.near_plane) * settings_.pcss.light_angle * T(0.5);
        const glm::vec<2, T> fp = frame_.texel_footprint(persp ? v.near_plane : r.depth, map_.width(), map_.height());
        const auto clamp_radius = [&](T k) { return k >= T(0) ? std::min(k, settings_.pcss.max_radius) : T(0); };
        const T su = clamp_radius(half / fp.x), sv = clamp_radius(half / fp.y);
        T sum = 0;
        std::uint32_t count = 0;
        for (const glm::vec<2, T>& o : blocker_taps_) {
            const auto i = static_cast<std::ptrdiff_t>(std::floor(r.u + su * o.x));
            const auto j = static_cast<std::ptrdiff_t>(std::floor(r.v + sv * o.y));
            if (!occludes(r, i, j)) continue;
            const float z = map_.depth(static_cast<std::size_t>(i), static_cast<std::size_t>(j));
            sum += depth_from_z_tex(v.projection, static_cast<T>(z), v.near_plane, v.far_plane);
            ++count;
        }
        if (count == 0) return false;
        d_blocker = sum / static_cast<T>(count);
        return true;
    }

    /// PCSS step 2 (parallel planes): w = (d_r − d_b)·w_light/d_b for a perspective map, (d_r − d_b)·tan for
    /// an orthographic one. d_b > 0 always (it is at least the near plane, > 0 for perspective maps).
    [[nodiscard]] T penumbra(T d_receiver, T d_blocker) const noexcept {
        const T gap = std::max(d_receiver - d_blocker, T(0));
        const T w = map_.view.projection == depth_projection::perspective ? gap * settings_.pcss.light_width / d_blocker
                                                                          : gap * settings_.pcss.light_angle;
        return w >= T(0) ? w : T(0);  // a blocker depth that is not a number (caller-written ±Inf) gives a hard edge
    }

    [[nodiscard]] T pcss(const detail::prepared_receiver<T>& r, const sample_key& key) const noexcept {
        T d_blocker = 0;
        if (!blocker_search(r, d_blocker)) return T(1);
        // Step 3: PCF whose kernel spans the penumbra (radius = w/2 at the receiver), clamped to max_radius.
        const T w = penumbra(r.depth, d_blocker);
        const glm::vec<2, T> fp = frame_.texel_footprint(r.depth, map_.width(), map_.height());
        // NaN (a blocker depth that is not a number, from a caller-written map) gives the hard test's radius 0.
        const auto radius = [&](T footprint) {
            const T k = T(0.5) * w / footprint;
            return k >= T(0) ? std::min(k, settings_.pcss.max_radius) : T(0);
        };
        return pcf(r, radius(fp.x), radius(fp.y), key);
    }

    depth_map_view<T> map_;
    lookup_settings<T> settings_;
    light_frame<T> frame_;
    std::vector<glm::vec<2, T>> taps_, blocker_taps_;
    std::vector<T> grid_1d_;  ///< the grid's N offsets along one axis
};

/// The shadow-map lookup pass: writes each pixel's lit fraction (see the top of this header) into
/// `visibility`. G-buffer as the core's (gather.hpp; pixel_size and ids are not read). Rows run on `exec`;
/// the rotated disc is keyed by pixel_key(region, x, y, 0, light_index, frame_seed), so tiles equal full
/// frames bit for bit. Throws aaf::invalid_argument (map, settings, gbuffer, visibility) before writing.
template <class T, class Ids, class Exec = sequential_executor>
void shadow_lookup(const depth_map_view<T>& map, const gbuffer<T, Ids>& gb, const lookup_settings<T>& settings,
                   image_view<T> visibility, const frame_region& region = {}, Exec&& exec = {}) {
    constexpr const char* fn = "shadow_lookup";
    detail::require_nonempty(fn, "gbuffer.positions", gb.positions);
    const std::size_t w = gb.width(), h = gb.height();
    detail::require_size(fn, "gbuffer.normals", gb.normals, w, h);
    detail::require_size(fn, "visibility", visibility, w, h);
    detail::require_depth_map(fn, map);
    detail::validate_lookup(fn, settings, map.view.projection);
    const shadow_map_sampler<T> sampler(map, settings);
    // Pixels in 8×8 blocks, bands of 8 rows per task: neighbouring pixels read overlapping texels, and a block
    // keeps them in cache whatever the map's orientation to the frame (row by row, a map whose rows run across
    // the frame's would touch a new cache line per tap). Each pixel's value is independent of the order.
    constexpr std::size_t block = 8;
    exec.parallel_for((h + block - 1) / block, [&](std::size_t b0, std::size_t b1) {
        for (std::size_t b = b0; b < b1; ++b) {
            const std::size_t y0 = b * block, y1 = std::min(y0 + block, h);
            for (std::size_t x0 = 0; x0 < w; x0 += block)
                for (std::size_t y = y0; y < y1; ++y)
                    for (std::size_t x = x0, x1 = std::min(x0 + block, w); x < x1; ++x)
                        visibility(x, y) = sampler.visibility(gb.positions(x, y), gb.normals(x, y),
                                                              pixel_key(region, x, y, 0, settings.light_index, settings.frame_seed));
        }
    });
}

}  // namespace v0
}  // namespace aaf
