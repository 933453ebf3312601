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
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <numbers>
#include <span>
#include <string>
#include <type_traits>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "../executor.hpp"
#include "../gather.hpp"
#include "../image_view.hpp"
#include "../region.hpp"
#include "../sampler.hpp"
#include "../simd.hpp"
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
        for (std::size_t k = 0; k <= taps_.size(); ++k) grid_lit_.push_back(T(1) - static_cast<T>(k) / static_cast<T>(taps_.size()));
        needs_key_ = settings.filter != shadow_filter::hard && settings.pcf.pattern == pcf_pattern::rotated_poisson;
        grid4_lanes_ = std::is_same_v<T, float> && settings.filter == shadow_filter::pcf && settings.pcf.pattern == pcf_pattern::grid &&
                       !settings.pcf.bilinear && grid_1d_.size() == 4 && map.depth.pixel_stride() == sizeof(float) &&
                       map.width() < (std::size_t{1} << 23) && map.height() < (std::size_t{1} << 23);
    }

    [[nodiscard]] const depth_map_view<T>& map() const noexcept { return map_; }
    [[nodiscard]] const lookup_settings<T>& settings() const noexcept { return settings_; }
    /// The PCF kernel's taps as offsets in units of the kernel radius.
    [[nodiscard]] const std::vector<glm::vec<2, T>>& taps() const noexcept { return taps_; }

    /// Lit fraction at receiver `p` with unit normal `n` (either orientation); `key` seeds the rotated disc.
    /// visibility_lanes for one receiver (bit-equal to the pass); many receivers are cheaper through it.
    [[nodiscard]] T visibility(const glm::vec<3, T>& p, const glm::vec<3, T>& n, const sample_key& key = {}) const noexcept {
        T a[6][lanes], out[lanes];
        for (std::size_t l = 0; l < lanes; ++l) a[0][l] = p.x, a[1][l] = p.y, a[2][l] = p.z, a[3][l] = n.x, a[4][l] = n.y, a[5][l] = n.z;
        visibility_lanes(a[0], a[1], a[2], a[3], a[4], a[5], 1, out, &key);
        return out[0];
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

    /// The continuous texel coordinates of `p` in the map (no bias, no normal offset); false when `p` is not
    /// finite or behind a perspective light. For passes that pick their pixel order from the map's layout.
    [[nodiscard]] bool texel_position(const glm::vec<3, T>& p, glm::vec<2, T>& uv) const noexcept {
        if (!detail::finite3(p)) return false;
        const glm::vec<3, T> l = frame_.to_light(p);
        if (frame_.perspective() && !(l.z > T(0))) return false;
        uv = frame_.texel_coords(l, map_.width(), map_.height());
        return detail::finite3(glm::vec<3, T>(uv, T(0)));
    }

    /// Asks the processor to start fetching the map texels that lookups at receivers near `points` will
    /// read (the bounding box of their texel coordinates, widened by the kernel's reach); non-finite points
    /// and points behind a perspective light are skipped. Changes no result: for passes, which know their
    /// next pixels before they need them, so that the map's cache misses overlap the work on earlier pixels
    /// instead of stalling it (the map is usually far larger than the caches). Regions above 64 KiB are not
    /// fetched: a block of pixels whose receivers spread that far gains nothing from it.
    void prefetch_around(std::span<const glm::vec<3, T>> points) const noexcept {
#if defined(__GNUC__) || defined(__clang__)
        T u0 = std::numeric_limits<T>::infinity(), v0 = u0, u1 = -u0, v1 = -u0;
        for (const glm::vec<3, T>& p : points) {
            if (!detail::finite3(p)) continue;
            const glm::vec<3, T> l = frame_.to_light(p);
            if (frame_.perspective() && !(l.z > T(0))) continue;
            const glm::vec<2, T> uv = frame_.texel_coords(l, map_.width(), map_.height());
            u0 = std::min(u0, uv.x), u1 = std::max(u1, uv.x), v0 = std::min(v0, uv.y), v1 = std::max(v1, uv.y);
        }
        const T reach = (settings_.filter == shadow_filter::pcss ? std::min(settings_.pcss.max_radius, T(16)) : settings_.pcf.radius) + T(2);
        const T w = static_cast<T>(map_.width()), h = static_cast<T>(map_.height());
        // Also false for an empty box (no usable point) and NaN.
        if (!(u1 + reach >= T(0) && u0 - reach < w && v1 + reach >= T(0) && v0 - reach < h)) return;
        const auto i0 = static_cast<std::size_t>(std::max(u0 - reach, T(0))), i1 = static_cast<std::size_t>(std::min(u1 + reach, w - T(1)));
        const auto j0 = static_cast<std::size_t>(std::max(v0 - reach, T(0))), j1 = static_cast<std::size_t>(std::min(v1 + reach, h - T(1)));
        if ((i1 - i0 + 1) * (j1 - j0 + 1) * map_.depth.pixel_stride() > (std::size_t{64} << 10)) return;
        for (std::size_t j = j0; j <= j1; ++j) {
            const auto* first = reinterpret_cast<const char*>(&map_.depth(i0, j));
            const auto* last = reinterpret_cast<const char*>(&map_.depth(i1, j));
            for (const char* a = first; a <= last; a += 64) __builtin_prefetch(a);
            __builtin_prefetch(last);
        }
#else
        (void)points;
#endif
    }

    /// Receivers per visibility_lanes call: the lanes of the widest vector of T the code is compiled for
    /// (1 without vector extensions).
    static constexpr std::size_t lanes = detail::receiver_lanes<T>::lanes;

    /// Whether the lookups read the sample key (the rotated disc): passes need not make keys otherwise.
    [[nodiscard]] bool reads_sample_key() const noexcept { return needs_key_; }

    /// visibility() of `count` ≤ lanes receivers at once: receiver l is (px[l], py[l], pz[l]) with normal
    /// (nx[l], ny[l], nz[l]) and sample key keys[l] (`keys` may be null when reads_sample_key() is false);
    /// each array holds `lanes` values, those past `count` are read but ignored; the result goes to out[l]
    /// for l < count. For passes: the receivers' setup runs in the lanes of one vector, and the default 4×4
    /// grid compares each of its rows of texels with one vector compare. visibility() is this function with
    /// one receiver, so the two agree bit for bit on every ISA; it is not inlined, so that every caller runs
    /// the same instructions (an inlined copy could contract a·b + c into an fma where another does not,
    /// which made a first, inlined version differ from visibility() at -march=native).
#if AAF_SIMD_BYTES > 0
    [[gnu::noinline]]
#endif
    void visibility_lanes(const T* px, const T* py, const T* pz, const T* nx, const T* ny, const T* nz, std::size_t count, T* out,
                          const sample_key* keys) const noexcept {
        using S = detail::receiver_lanes<T>;
        using V = typename S::vec;
        const auto load = [](const T* a) {
            if constexpr (S::lanes == 1) return *a;
            else return S::load(a);
        };
        const auto finite = [](V x) {
            if constexpr (S::lanes == 1) return std::isfinite(x);
            else return S::finite(x);
        };
        const V vpx = load(px), vpy = load(py), vpz = load(pz), vnx = load(nx), vny = load(ny), vnz = load(nz);
        const detail::prepared_receivers<T> r =
            detail::prepare_lanes(frame_, map_.width(), map_.height(), map_.format, settings_.bias, vpx, vpy, vpz, vnx, vny, vnz);
        // Non-finite receivers and those outside the frustum are lit.
        typename S::mask live;
        if constexpr (S::lanes == 1) live = finite(vpx) && finite(vpy) && finite(vpz) && finite(vnx) && finite(vny) && finite(vnz) && r.inside;
        else live = finite(vpx) & finite(vpy) & finite(vpz) & finite(vnx) & finite(vny) & finite(vnz) & r.inside;
#if AAF_SIMD_BYTES > 0
        if constexpr (std::is_same_v<T, float>) {
            if (grid4_lanes_) {
                pcf_grid4_lanes(r, live, count, out);
                return;
            }
        }
#endif
        for (std::size_t l = 0; l < count; ++l) {
            bool lane_live;
            if constexpr (S::lanes == 1) lane_live = live;
            else lane_live = live[l] != 0;
            if (!lane_live) {
                out[l] = T(1);
                continue;
            }
            const detail::prepared_receiver<T> rl = r.lane(l);
            const sample_key key = needs_key_ ? keys[l] : sample_key{};
            T lit = T(1);
            switch (settings_.filter) {
                case shadow_filter::hard: lit = hard(rl); break;
                case shadow_filter::pcf: lit = pcf(rl, settings_.pcf.radius, settings_.pcf.radius, key); break;
                case shadow_filter::pcss: lit = pcss(rl, key); break;
            }
            out[l] = lit;
        }
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
    /// `max_side` = 4 instantiates the default 4×4 grid with arrays and loops of fixed size, which the
    /// compiler unrolls (the general one, sized for 64×64, kept spilling its arrays through the stack).
    template <std::size_t max_side = 64>  // taps <= 4096
    [[nodiscard]] T pcf_grid(const detail::prepared_receiver<T>& r, T ru, T rv) const noexcept {
        std::size_t cols[max_side], rows[max_side];
        T col_term[max_side], row_term[max_side];
        std::size_t nc = 0, nr = 0;
        const auto w = static_cast<std::ptrdiff_t>(map_.width()), h = static_cast<std::ptrdiff_t>(map_.height());
        for (std::size_t k = 0; k < max_side && k < grid_1d_.size(); ++k) {
            const T o = grid_1d_[k];
            const auto i = static_cast<std::ptrdiff_t>(std::floor(r.u + ru * o));
            if (i < 0 || i >= w) continue;  // outside the map: lit
            const T du = static_cast<T>(i) + T(0.5) - r.u;
            cols[nc] = static_cast<std::size_t>(i), col_term[nc++] = r.su * du - r.au * std::abs(du);
        }
        for (std::size_t k = 0; k < max_side && k < grid_1d_.size(); ++k) {
            const T o = grid_1d_[k];
            const auto j = static_cast<std::ptrdiff_t>(std::floor(r.v + rv * o));
            if (j < 0 || j >= h) continue;
            const T dv = static_cast<T>(j) + T(0.5) - r.v;
            rows[nr] = static_cast<std::size_t>(j), row_term[nr++] = r.z - r.c0 + r.sv * dv - r.av * std::abs(dv);
        }
        std::size_t occluded = 0;
        // The usual case, a 4×4 grid of radius 2 away from the map's edges: its columns are 4 consecutive
        // texels, so each grid row is 4 neighbouring floats of a packed map row, compared with fixed trip
        // counts the compiler turns into one vector load and compare. Same operands and operations as below,
        // so the same bits.
        if (max_side == 4 && nc == 4 && cols[3] == cols[0] + 3 && map_.depth.pixel_stride() == sizeof(float)) {
            const T c0 = col_term[0], c1 = col_term[1], c2 = col_term[2], c3 = col_term[3];
            for (std::size_t b = 0; b < nr; ++b) {
                const float* t = &map_.depth(cols[0], rows[b]);
                const T th = row_term[b];
                occluded += static_cast<std::size_t>(static_cast<T>(t[0]) < th + c0) + static_cast<std::size_t>(static_cast<T>(t[1]) < th + c1) +
                            static_cast<std::size_t>(static_cast<T>(t[2]) < th + c2) + static_cast<std::size_t>(static_cast<T>(t[3]) < th + c3);
            }
            return grid_lit_[occluded];
        }
        for (std::size_t b = 0; b < nr; ++b)
            for (std::size_t a = 0; a < nc; ++a) occluded += static_cast<T>(map_.depth(cols[a], rows[b])) < row_term[b] + col_term[a] ? 1 : 0;
        return grid_lit_[occluded];
    }

#if AAF_SIMD_BYTES > 0
    /// pcf_grid<4> of the receivers in `r` (radius settings.pcf.radius on both axes), for float maps of packed
    /// rows: the grid's columns, rows and their bias terms in lanes (the same operations as pcf_grid, lane by
    /// lane), then per receiver one 4-wide load, add and compare per grid row. Receivers whose grid is not 4
    /// consecutive columns on 4 rows inside the map (the map's edges, or a radius that skips texels) take
    /// pcf_grid<4>; receivers not `live` are lit.
    void pcf_grid4_lanes(const detail::prepared_receivers<T>& r, typename detail::simd<T>::mask live, std::size_t count, T* out) const noexcept {
        using S = detail::simd<T>;
        using V = typename S::vec;
        using I = typename S::mask;  // integer lanes of T's width
        constexpr std::size_t L = S::lanes;
        typedef T v4 __attribute__((vector_size(4 * sizeof(T))));
        typedef typename S::mask_int i4 __attribute__((vector_size(4 * sizeof(T))));
        const T radius = settings_.pcf.radius;
        const I wi = I{} + static_cast<typename S::mask_int>(map_.width()), hi = I{} + static_cast<typename S::mask_int>(map_.height());
        // Lanes that are not live hold garbage or NaN: 0 instead, so that the conversions to integers see
        // numbers in range (grid4_lanes_ requires a map below 2^23 texels a side, and radius <= 4096).
        const V u = S::select(live, r.u, V{}), v = S::select(live, r.v, V{});
        const auto abs_v = [](V x) {
            constexpr auto magnitude = static_cast<typename S::mask_int>(~(std::make_unsigned_t<typename S::mask_int>(1) << (8 * sizeof(T) - 1)));
            return std::bit_cast<V>(std::bit_cast<I>(x) & magnitude);
        };
        const auto floor_i = [](V x) {  // std::floor, as an integer (|x| < 2^24)
            const I t = __builtin_convertvector(x, I);     // towards zero
            return t + (__builtin_convertvector(t, V) > x);  // −1 where that rounded up
        };
        alignas(64) typename S::mask_int col0[L], rows[4][L];
        alignas(64) T col_term[4][L], row_term[4][L];
        I fast = live, first_col{};
        for (std::size_t k = 0; k < 4; ++k) {
            const T o = grid_1d_[k];
            const I i = floor_i(u + S::splat(radius) * o), j = floor_i(v + S::splat(radius) * o);
            fast &= (i >= I{}) & (i < wi) & (j >= I{}) & (j < hi);
            if (k == 0) first_col = i;
            if (k == 3) fast &= i == first_col + 3;
            const V du = __builtin_convertvector(i, V) + T(0.5) - u, dv = __builtin_convertvector(j, V) + T(0.5) - v;
            S::store(col_term[k], r.su * du - r.au * abs_v(du));
            S::store(row_term[k], r.z - r.c0 + r.sv * dv - r.av * abs_v(dv));
            std::memcpy(rows[k], &j, sizeof j);
        }
        std::memcpy(col0, &first_col, sizeof first_col);
        for (std::size_t l = 0; l < count; ++l) {
            if (!live[l]) {
                out[l] = T(1);
                continue;
            }
            if (!fast[l]) {
                out[l] = pcf_grid<4>(r.lane(l), radius, radius);
                continue;
            }
            const v4 c = {col_term[0][l], col_term[1][l], col_term[2][l], col_term[3][l]};
            i4 occluded{};
            for (std::size_t b = 0; b < 4; ++b) {
                v4 t;
                std::memcpy(&t, &map_.depth(static_cast<std::size_t>(col0[l]), static_cast<std::size_t>(rows[b][l])), sizeof t);
                occluded -= t < row_term[b][l] + c;  // a true comparison is −1
            }
            out[l] = grid_lit_[static_cast<std::size_t>(occluded[0] + occluded[1] + occluded[2] + occluded[3])];
        }
    }
#endif

    /// Lit fraction over the taps scaled by (ru, rv) texels around the receiver.
    [[nodiscard]] T pcf(const detail::prepared_receiver<T>& r, T ru, T rv, const sample_key& key) const noexcept {
        if (settings_.pcf.pattern == pcf_pattern::grid && !settings_.pcf.bilinear) return grid_1d_.size() == 4 ? pcf_grid<4>(r, ru, rv) : pcf_grid(r, ru, rv);
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
    std::vector<T> grid_lit_;  ///< [k] = 1 − k/taps, the grid's result with k occluded taps (no division per pixel)
    bool needs_key_ = false;    ///< the kernel reads the sample key (the rotated disc)
    bool grid4_lanes_ = false;  ///< visibility_lanes may take pcf_grid4_lanes
};

namespace detail {
/// Whether a step along a frame row moves further along the map's rows (u) than across them (v), judged
/// from neighbouring pixels on a few rows (sky and receivers behind the light are skipped; none: false).
/// Only chooses the pass's pixel order, never a result.
template <class T>
[[nodiscard]] bool frame_rows_along_map_rows(const shadow_map_sampler<T>& sampler, const const_image_view<glm::vec<3, T>>& positions) noexcept {
    const std::size_t w = positions.width(), h = positions.height();
    if (w < 2) return false;
    T du = 0, dv = 0;
    for (std::size_t k = 1; k <= 7; ++k) {
        const std::size_t y = h * k / 8, x = (w - 1) * k / 8;
        glm::vec<2, T> a, b;
        if (!sampler.texel_position(positions(x, y), a) || !sampler.texel_position(positions(x + 1, y), b)) continue;
        du += std::abs(b.x - a.x), dv += std::abs(b.y - a.y);
    }
    return du > dv;
}
}  // namespace detail

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
    // Pixels in bands of 8 rows per task, in one of two orders (each pixel's value is independent of the
    // order). When the frame's rows run along the map's rows, row by row: a pixel row then reads the same
    // few map rows from left to right, streams the hardware prefetcher follows, which stay in L1. Otherwise
    // in blocks of 8 rows and 8 columns (or a vector's lanes, if more): row by row, a map whose rows run
    // across the frame's would touch a new cache line per tap, and a block keeps its texels in cache. Blocks
    // read ~20-30 map rows at once; with a power-of-two map pitch (a 2048-texel row is 8 KiB) those all fall
    // in the same L1 sets, which is why row order wins when the orientation allows it. Blocks prefetch the
    // texels of the block after next (prefetch_around), so those misses overlap the work on the two blocks
    // before it. Pixels go through visibility_lanes a vector's lanes at a time.
    constexpr std::size_t block = 8, lanes = shadow_map_sampler<T>::lanes, block_w = std::max(block, lanes);
    const bool row_order = detail::frame_rows_along_map_rows(sampler, gb.positions), keyed = sampler.reads_sample_key();
    exec.parallel_for((h + block - 1) / block, [&](std::size_t b0, std::size_t b1) {
        alignas(64) T p[3][lanes], n[3][lanes], out[lanes];
        sample_key keys[lanes];
        // Pixels [x0, x1) of row y, a vector's lanes at a time.
        const auto run = [&](std::size_t x0, std::size_t x1, std::size_t y) {
            for (std::size_t x = x0; x < x1; x += lanes) {
                const std::size_t count = std::min(lanes, x1 - x);
                bool loaded = false;
#if AAF_SIMD_BYTES > 0
                if constexpr (sizeof(glm::vec<3, T>) == 3 * sizeof(T)) {  // GLM's packed layout (the default)
                    if (count == lanes && gb.positions.packed_rows() && gb.normals.packed_rows()) {
                        using S = detail::simd<T>;
                        typename S::vec a, b, c;
                        S::deinterleave3(&gb.positions(x, y).x, a, b, c);
                        S::store(p[0], a), S::store(p[1], b), S::store(p[2], c);
                        S::deinterleave3(&gb.normals(x, y).x, a, b, c);
                        S::store(n[0], a), S::store(n[1], b), S::store(n[2], c);
                        loaded = true;
                    }
                }
#endif
                for (std::size_t l = 0; !loaded && l < lanes; ++l) {  // lanes past the row's end: NaN (ignored)
                    const glm::vec<3, T> pl = l < count ? gb.positions(x + l, y) : glm::vec<3, T>(std::numeric_limits<T>::quiet_NaN());
                    const glm::vec<3, T> nl = l < count ? gb.normals(x + l, y) : glm::vec<3, T>(std::numeric_limits<T>::quiet_NaN());
                    p[0][l] = pl.x, p[1][l] = pl.y, p[2][l] = pl.z, n[0][l] = nl.x, n[1][l] = nl.y, n[2][l] = nl.z;
                }
                for (std::size_t l = 0; keyed && l < count; ++l) keys[l] = pixel_key(region, x + l, y, 0, settings.light_index, settings.frame_seed);
                sampler.visibility_lanes(p[0], p[1], p[2], n[0], n[1], n[2], count, out, keys);
                for (std::size_t l = 0; l < count; ++l) visibility(x + l, y) = out[l];
            }
        };
        for (std::size_t b = b0; b < b1; ++b) {
            const std::size_t y0 = b * block, y1 = std::min(y0 + block, h);
            if (row_order) {
                for (std::size_t y = y0; y < y1; ++y) run(0, w, y);
                continue;
            }
            for (std::size_t x0 = 0; x0 < w; x0 += block_w) {
                if (const std::size_t xa = x0 + 2 * block_w; xa < w) {
                    const std::size_t xb = std::min(xa + block_w, w) - 1, yb = y1 - 1;
                    const glm::vec<3, T> corners[4] = {gb.positions(xa, y0), gb.positions(xb, y0), gb.positions(xa, yb), gb.positions(xb, yb)};
                    sampler.prefetch_around(corners);
                }
                for (std::size_t y = y0; y < y1; ++y) run(x0, std::min(x0 + block_w, w), y);
            }
        }
    });
}

}  // namespace v0
}  // namespace aaf
