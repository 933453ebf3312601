// SPDX-License-Identifier: MIT
#pragma once
// The axis-aligned AO filter (Mehta et al. 2013 and the authors' indirect-light code; FORMULAS.md §4.2, §8.3):
// filter width and adaptive sample count from the nearest hit distance z_min (and z_max), and the core's
// guided separable Gaussian (filter.hpp) run over the AO and the bent normals' components.
//
// Limits (tested in tests/test_occlusion_filter.cpp):
// * no hit (z_min = +∞)       → β = 0 (the pixel is left as sampled: with no occluder in range its cosine-
//                               sampled estimate is exactly 1) and n = 0 (no adaptive samples wanted);
//                               render_ambient_occlusion first spreads its neighbours' z to it when it can;
// * contact, z_min → 0        → β → 0 (nothing to filter over) and n → +∞, clamped to the cap;
// * NaN z_min or pixel size   → as "no hit";
// * μ → ∞                     → β → 0: the filtered result is the Monte Carlo one (consistency).

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <type_traits>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "../executor.hpp"
#include "../filter.hpp"
#include "../formulas.hpp"
#include "../gather.hpp"
#include "../guides.hpp"
#include "../image.hpp"
#include "../image_view.hpp"
#include "ao_gather.hpp"
#include "ao_settings.hpp"
#include "ao_stats.hpp"

namespace aaf {
inline namespace v0 {

/// The AO filter's bandwidth Ω* = Ω_h / z_min (world units⁻¹), with z_min clamped to ≥ settings.min_distance.
/// +∞ at contact (z_min = 0), 0 for no hit (z_min = +∞) and for NaN. The authors' per-neighbour (1 + 50 θ)
/// factor is replaced by the hard normal threshold (DEVIATIONS.md, occlusion row 2).
template <class T>
[[nodiscard]] constexpr T ao_filter_bandwidth(T z_min, const ao_filter_settings<T>& s) noexcept {
    if (std::isnan(z_min)) return T(0);
    return detail::safe_div(s.omega_h, std::max(z_min, s.min_distance));
}

/// The AO filter width β in world units: the standard deviation of the authors' kernel exp(−2μ²Ω*²r²),
/// β = 1/(2μΩ*) = z/(2μΩ_h) with z = max(z_min, min_distance). 0 (do not filter) for no hit, contact and NaN.
/// Computed as z/(2μΩ_h), not through Ω*: with a tiny Ω_h (any finite value > 0 is valid, down to the
/// denormals) Ω* = Ω_h/z underflows, and 1/(2μΩ*) then overflowed to +∞ (or, with Ω* rounded to 0, read as
/// "no hit" and left the pixel unfiltered). A width beyond the largest finite T is clamped to it: "wider than
/// any kernel", whose radius filter.max_radius bounds. So β is always finite and ≥ 0 (heat maps, the filter).
template <class T>
[[nodiscard]] constexpr T ao_filter_width(T z_min, const ao_filter_settings<T>& s) noexcept {
    if (std::isnan(z_min)) return T(0);
    const T z = std::max(z_min, s.min_distance);
    if (!(z > T(0)) || !(z < std::numeric_limits<T>::infinity())) return T(0);
    const T beta = z / (T(2) * s.mu * s.omega_h);  // 2μΩ_h = +∞ (huge μΩ_h): β = 0, below every pixel
    return std::isnan(beta) ? T(0) : std::min(beta, std::numeric_limits<T>::max());
}

/// Samples per pixel n = c_imp (μΩ_h d/z_min + α)² (1 + μ z_max/z_min)² Ω_h² (FORMULAS.md §4.2), real-valued,
/// unclamped: 0 for no hit or NaN input (no adaptive samples wanted), +∞ at contact (clamp it with
/// aaf::target_samples). `pixel_size` d in world units.
template <class T>
[[nodiscard]] constexpr T ao_sample_count(T z_min, T z_max, T pixel_size, const ao_filter_settings<T>& s) noexcept {
    if (std::isnan(z_min) || std::isnan(z_max) || std::isnan(pixel_size) || !(z_min < std::numeric_limits<T>::infinity()))
        return T(0);
    const T zm = std::max(z_min, s.min_distance);
    const T pixel_term = detail::safe_div(s.mu * s.omega_h * std::max(pixel_size, T(0)), zm) + s.alpha;
    const T wedge = T(1) + detail::safe_div(s.mu * std::max(z_max, zm), zm);
    const T n = s.importance_scale * pixel_term * pixel_term * wedge * wedge * s.omega_h * s.omega_h;
    return std::isnan(n) ? T(0) : n;
}

/// Everything one filtered AO frame needs besides buffers and tracer.
template <class T = float>
struct ao_frame_settings {
    ao_sampling_settings<T> sampling{};  ///< hemisphere samples (initial pass 0, adaptive pass 1)
    ao_filter_settings<T> filter{};      ///< the AO filter's constants
    bool adaptive = true;                ///< add samples up to n (ao_sample_count), capped at sampling.max_samples
    bool filtered = true;                ///< run the filter (false: Monte Carlo with the adaptive counts)
};

/// What filter_ambient_occlusion / render_ambient_occlusion write. `visibility` is required; the others are
/// written when non-empty. All must have the G-buffer's size.
template <class T = float>
struct ao_outputs {
    image_view<T> visibility;                ///< cosine-weighted ambient visibility 1 − occlusion; NaN = no estimate
    /// Unit bent normals: the normal where no direction is unoccluded, NaN where there is no estimate.
    image_view<glm::vec<3, T>> bent_normal;
    image_view<T> filter_width;              ///< β per pixel, world units (0 = not filtered), for heat maps
    image_view<std::uint32_t> samples;       ///< samples per pixel after the adaptive pass, for heat maps
};

namespace detail {

template <class T>
void require_ao_outputs(const char* fn, const ao_outputs<T>& o, std::size_t w, std::size_t h) {
    require_size(fn, "outputs.visibility", o.visibility, w, h);
    require_size_or_empty(fn, "outputs.bent_normal", o.bent_normal, w, h);
    require_size_or_empty(fn, "outputs.filter_width", o.filter_width, w, h);
    require_size_or_empty(fn, "outputs.samples", o.samples, w, h);
}

template <class T>
[[nodiscard]] filter_settings<T> ao_core_filter_settings(const ao_filter_settings<T>& s) noexcept {
    filter_settings<T> f;
    f.space = s.space;
    f.truncation = s.truncation;
    f.max_radius = s.max_radius;
    f.normal_threshold_degrees = s.normal_threshold_degrees;
    f.spread_slopes = false;
    return f;
}

/// The direct 2D kernel (ao_filter_kernel::direct): each pixel with a finite value and β > 0 averages its
/// window's accepted neighbours (finite value, same ID, normal within the threshold, and with
/// `reject_beyond_z_min` a world distance below the centre's z) with the weight exp(−e),
/// e = r²(1 + cθ)²/(2β²), r the tangent-plane or image distance as for the separable filter (the centre's
/// normal and pixel size), c = normal_angle_term, θ the normals' angle; taps with e > truncation²/2 are cut
/// (the authors' μ²Ω*²r² ≤ 2). The window is the separable filter's: kernel_radius(β/d) pixels. `values`
/// holds `planes` images filtered with the same weights (AO, then the bent normal's components).
template <class T, class G, class Exec>
void ao_direct_filter(const G& g, const_image_view<T> pixel_size, const image<T>& beta, const image<T>& z,
                      const image<T>* values, image<T>* results, std::size_t planes, const ao_filter_settings<T>& s,
                      Exec& exec) {
    const std::size_t w = beta.width(), h = beta.height();
    const filter_settings<T> fs = ao_core_filter_settings(s);
    const T cos_threshold = std::cos(s.normal_threshold_degrees * T(0.017453292519943295));
    const T e_cut = s.truncation * s.truncation / T(2);
    exec.parallel_for(h, [&](std::size_t y0, std::size_t y1) {
        T sum[4], wsum;
        for (std::size_t y = y0; y < y1; ++y)
            for (std::size_t x = 0; x < w; ++x) {
                for (std::size_t c = 0; c < planes; ++c) results[c](x, y) = values[c](x, y);
                const T b = beta(x, y), d = pixel_size(x, y);
                if (!std::isfinite(values[0](x, y)) || !(b > T(0)) || !(d > T(0))) continue;
                const std::size_t r = kernel_radius(b / d, fs);
                if (r == 0) continue;
                const guide_center<T, G> gc(g, x, y);
                const glm::vec<3, T> p = g.positions(x, y);
                const T inv_two_beta2 = T(1) / (T(2) * b * b);
                const T reject2 = z(x, y) * z(x, y);
                for (std::size_t c = 0; c < planes; ++c) sum[c] = T(0);
                wsum = T(0);
                const std::size_t ya = y >= r ? y - r : 0, yb = std::min(h - 1, y + r);
                const std::size_t xa = x >= r ? x - r : 0, xb = std::min(w - 1, x + r);
                for (std::size_t ny = ya; ny <= yb; ++ny)
                    for (std::size_t nx = xa; nx <= xb; ++nx) {
                        if (!std::isfinite(values[0](nx, ny)) || !gc.accepts(g, nx, ny, cos_threshold)) continue;
                        const glm::vec<3, T> dp = g.positions(nx, ny) - p;
                        if (s.reject_beyond_z_min && !(glm::dot(dp, dp) < reject2)) continue;  // NaN position rejects
                        T r2;
                        if (s.space == offset_space::tangent_plane) {
                            r2 = light_plane_distance2<T>(g.positions(nx, ny), p, gc.normal);
                        } else {
                            const T dx = static_cast<T>(nx) - static_cast<T>(x), dy = static_cast<T>(ny) - static_cast<T>(y);
                            r2 = (dx * dx + dy * dy) * d * d;
                        }
                        T e = r2 * inv_two_beta2;
                        if (s.normal_angle_term > T(0)) {
                            // atan2(|n×m|, n·m), not acos(n·m): acos loses most digits of the small angles
                            // that pass the threshold (float: ~0.1 % of θ at 0.4°, times c = 50 in f).
                            const glm::vec<3, T> m = g.normals(nx, ny);
                            const T angle = std::atan2(glm::length(glm::cross(gc.normal, m)), glm::dot(gc.normal, m));
                            const T f = T(1) + s.normal_angle_term * angle;
                            e *= f * f;
                        }
                        if (!(e <= e_cut)) continue;  // beyond the cut, or a NaN position
                        const T weight = std::exp(-e);
                        for (std::size_t c = 0; c < planes; ++c) sum[c] += weight * values[c](nx, ny);
                        wsum += weight;
                    }
                // The centre is always accepted with weight 1 (e = 0), so wsum >= 1.
                for (std::size_t c = 0; c < planes; ++c) results[c](x, y) = sum[c] / wsum;
            }
    });
}

/// A G-buffer normal as the AO filter's guides want it: unit length, or NaN where it has no direction, so
/// that it rejects every neighbour and is rejected by them.
template <class T>
[[nodiscard]] glm::vec<3, T> ao_guide_normal(const glm::vec<3, T>& unit_or_zero) noexcept {
    return unit_or_zero == glm::vec<3, T>(0) ? glm::vec<3, T>(std::numeric_limits<T>::quiet_NaN()) : unit_or_zero;
}

/// For rejection_boost: per pixel, the fraction f of its filter window (the separable filter's square of
/// kernel_radius(β/d) pixels, clipped to the image) whose pixels the guides reject. Windows wider than
/// 8 pixels are visited on a stride of ⌈r/8⌉ so a pixel costs at most 17² tests (departure from an
/// exhaustive count, DEVIATIONS.md occlusion row 7). 0 where β or d is not positive (no filter: no boost).
template <class T, class G, class Exec>
void ao_rejected_fraction(const G& g, const_image_view<T> pixel_size, const image<T>& beta, image<T>& fraction,
                          const ao_filter_settings<T>& s, Exec& exec) {
    const std::size_t w = beta.width(), h = beta.height();
    const filter_settings<T> fs = ao_core_filter_settings(s);
    const T cos_threshold = std::cos(s.normal_threshold_degrees * T(0.017453292519943295));
    exec.parallel_for(h, [&](std::size_t y0, std::size_t y1) {
        for (std::size_t y = y0; y < y1; ++y)
            for (std::size_t x = 0; x < w; ++x) {
                fraction(x, y) = T(0);
                const T b = beta(x, y), d = pixel_size(x, y);
                if (!(b > T(0)) || !(d > T(0))) continue;
                const std::size_t r = kernel_radius(b / d, fs);
                if (r == 0) continue;
                const std::size_t step = (r + 7) / 8;
                const guide_center<T, G> gc(g, x, y);
                std::size_t seen = 0, rejected = 0;
                // Offsets from the centre so the centre itself is on the stride's lattice.
                for (std::size_t oy = 0; oy <= 2 * r; oy += step) {
                    if (y + oy < r || y + oy - r >= h) continue;
                    const std::size_t ny = y + oy - r;
                    for (std::size_t ox = 0; ox <= 2 * r; ox += step) {
                        if (x + ox < r || x + ox - r >= w) continue;
                        const std::size_t nx = x + ox - r;
                        ++seen;
                        if (!gc.accepts(g, nx, ny, cos_threshold)) ++rejected;
                    }
                }
                fraction(x, y) = seen == 0 ? T(0) : static_cast<T>(rejected) / static_cast<T>(seen);
            }
    });
}

}  // namespace detail

/// Filters a frame of AO records into `out`: β from each pixel's z_min (ao_filter_width), then the core's
/// guided separable Gaussian (aaf::filter_visibility) over the visibility and over each component of the
/// bent normals, which are renormalised (a pixel whose filtered bent normal has zero length keeps its own).
/// Guides: the G-buffer's normals (normalised here; neighbours beyond settings.normal_threshold_degrees are
/// rejected), its IDs when it has them, and its positions for tangent-plane distances.
/// Pixels without an estimate (no surface, every sample failed) stay NaN and never reach a neighbour.
/// Allocates per call: 7 images of T (β, normals, bent components, scratch) and the filter's own memory.
/// Throws aaf::invalid_argument (before writing) on mismatched buffers or invalid settings.
template <class T, class Ids, class Exec = sequential_executor>
void filter_ambient_occlusion(const gbuffer<T, Ids>& gb, const_image_view<ao_stats<T>> stats,
                              const ao_filter_settings<T>& s, const ao_outputs<T>& out, Exec&& exec = {}) {
    constexpr const char* fn = "filter_ambient_occlusion";
    detail::require_gbuffer(fn, gb);
    validate(s, fn);
    const std::size_t w = gb.width(), h = gb.height();
    detail::require_size(fn, "stats", stats, w, h);
    detail::require_ao_outputs(fn, out, w, h);
    image<T> beta(w, h), vis(w, h);
    image<glm::vec<3, T>> normals(w, h);
    std::array<image<T>, 3> bent;
    const bool with_bent = !out.bent_normal.empty();
    if (with_bent)
        for (auto& b : bent) b.reset(w, h);
    constexpr T nan = std::numeric_limits<T>::quiet_NaN();
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) {
            const ao_stats<T>& r = stats(x, y);
            const glm::vec<3, T> n = detail::ao_unit_or_zero(gb.normals(x, y));
            normals(x, y) = detail::ao_guide_normal(n);
            vis(x, y) = r.visibility();
            beta(x, y) = std::isfinite(vis(x, y)) ? ao_filter_width(r.z_min, s) : T(0);
            if (with_bent) {
                const glm::vec<3, T> b = std::isfinite(vis(x, y)) ? r.bent_normal(n) : glm::vec<3, T>(nan);
                for (int c = 0; c < 3; ++c) bent[c](x, y) = b[c];
            }
        }
    if (s.kernel == ao_filter_kernel::direct) {
        // z for reject_beyond_z_min: the centre's z_min as β uses it (clamped by min_distance).
        image<T> z(w, h);
        for (std::size_t y = 0; y < h; ++y)
            for (std::size_t x = 0; x < w; ++x) z(x, y) = std::max(stats(x, y).z_min, s.min_distance);
        std::array<image<T>, 4> in_planes, out_planes;
        in_planes[0] = std::move(vis);
        const std::size_t planes = with_bent ? 4 : 1;
        for (std::size_t c = 1; c < planes; ++c) in_planes[c] = std::move(bent[c - 1]);
        for (std::size_t c = 0; c < planes; ++c) out_planes[c].reset(w, h);
        const auto direct = [&](const auto& g) {
            detail::ao_direct_filter<T>(g, gb.pixel_size, beta, z, in_planes.data(), out_planes.data(), planes, s, exec);
        };
        if constexpr (gbuffer<T, Ids>::has_ids)
            direct(guides{normals.cview(), gb.ids, gb.positions});
        else
            direct(guides{normals.cview(), no_guide{}, gb.positions});
        for (std::size_t y = 0; y < h; ++y)
            for (std::size_t x = 0; x < w; ++x) {
                out.visibility(x, y) = out_planes[0](x, y);
                if (!with_bent) continue;
                const glm::vec<3, T> f = detail::ao_unit_or_zero(
                    glm::vec<3, T>{out_planes[1](x, y), out_planes[2](x, y), out_planes[3](x, y)});
                out.bent_normal(x, y) =
                    f != glm::vec<3, T>(0) ? f : glm::vec<3, T>{in_planes[1](x, y), in_planes[2](x, y), in_planes[3](x, y)};
            }
        if (!out.filter_width.empty())
            for (std::size_t y = 0; y < h; ++y)
                for (std::size_t x = 0; x < w; ++x) out.filter_width(x, y) = beta(x, y);
        return;
    }
    const filter_settings<T> fs = detail::ao_core_filter_settings(s);
    image<T> scratch(w, h);
    const auto run = [&](const image<T>& src, image_view<T> dst) {
        if constexpr (gbuffer<T, Ids>::has_ids)
            filter_visibility<T>(src.view(), beta.view(), gb.pixel_size, dst, scratch.view(),
                                 guides{normals.cview(), gb.ids, gb.positions}, fs, glm::vec<3, T>(0, 1, 0), exec);
        else
            filter_visibility<T>(src.view(), beta.view(), gb.pixel_size, dst, scratch.view(),
                                 guides{normals.cview(), no_guide{}, gb.positions}, fs, glm::vec<3, T>(0, 1, 0), exec);
    };
    run(vis, out.visibility);
    if (with_bent) {
        std::array<image<T>, 3> filtered;
        for (int c = 0; c < 3; ++c) {
            filtered[c].reset(w, h);
            run(bent[c], filtered[c].view());
        }
        for (std::size_t y = 0; y < h; ++y)
            for (std::size_t x = 0; x < w; ++x) {
                const glm::vec<3, T> f =
                    detail::ao_unit_or_zero(glm::vec<3, T>{filtered[0](x, y), filtered[1](x, y), filtered[2](x, y)});
                out.bent_normal(x, y) = f != glm::vec<3, T>(0) ? f : glm::vec<3, T>{bent[0](x, y), bent[1](x, y), bent[2](x, y)};
            }
    }
    if (!out.filter_width.empty())
        for (std::size_t y = 0; y < h; ++y)
            for (std::size_t x = 0; x < w; ++x) out.filter_width(x, y) = beta(x, y);
}

/// Gives every record without hits of its own the smallest z_min and largest z_max of the records with hits
/// within `radius` pixels (a square window, same object ID when the G-buffer has IDs), by the core's
/// aaf::spread_slopes on (s1, s2) = (z_max, z_min): its max/min and "keep your own" rules are exactly the
/// ones needed. `hits` stays 0, so a spread record is still known to have seen nothing itself. Records that
/// receive nothing keep z_min = +∞ (no hit: not filtered, no adaptive samples).
template <class T, class Ids, class Exec = sequential_executor>
void spread_hit_distances(const gbuffer<T, Ids>& gb, image_view<ao_stats<T>> stats, std::uint32_t radius, Exec&& exec = {}) {
    constexpr const char* fn = "spread_hit_distances";
    detail::require_gbuffer(fn, gb);
    const std::size_t w = gb.width(), h = gb.height();
    detail::require_size(fn, "stats", stats, w, h);
    if (radius > 1024) detail::throw_invalid(fn, "`radius` must be <= 1024 (got " + std::to_string(radius) + ")");
    if (radius == 0) return;
    image<slope_pair<T>> z(w, h), scratch(w, h);
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x)
            if (stats(x, y).has_hit() && stats(x, y).z_min < std::numeric_limits<T>::infinity())
                z(x, y) = {stats(x, y).z_max, stats(x, y).z_min};
    if constexpr (gbuffer<T, Ids>::has_ids)
        spread_slopes<T>(z.view(), scratch.view(), radius, guides<no_guide, Ids, no_guide>{{}, gb.ids, {}}, exec);
    else
        spread_slopes<T>(z.view(), scratch.view(), radius, guides<>{}, exec);
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) {
            ao_stats<T>& r = stats(x, y);
            if (r.has_hit() || !z(x, y).has_occluder()) continue;
            r.z_min = z(x, y).s2;
            r.z_max = z(x, y).s1;
        }
}

/// One filtered AO frame: `settings.sampling.initial_samples` samples per pixel (pass 0, with distances),
/// then hit distances spread to pixels without hits (spread_hit_distances, filter.spread_radius), then, when
/// `adaptive`, each pixel with a (possibly spread) z_min gets up to n = ao_sample_count(…) samples in total
/// (pass 1, visibility only, capped at sampling.max_samples), then the filter (when `filtered`). Writes
/// `out`; returns the number of rays traced. `region` places the buffers in the full frame (tiles).
template <class T, class Ids, class Tracer, class Exec = sequential_executor>
std::uint64_t render_ambient_occlusion(const gbuffer<T, Ids>& gb, const Tracer& tracer, const ao_frame_settings<T>& s,
                                       const ao_outputs<T>& out, const frame_region& region = {}, Exec&& exec = {}) {
    constexpr const char* fn = "render_ambient_occlusion";
    detail::require_gbuffer(fn, gb);
    validate(s.sampling, fn);
    validate(s.filter, fn);
    const std::size_t w = gb.width(), h = gb.height();
    detail::require_ao_outputs(fn, out, w, h);
    image<ao_stats<T>> stats(w, h);
    std::uint64_t rays =
        gather_ambient_occlusion(gb, tracer, s.sampling, 0, s.sampling.initial_samples, stats.view(), {}, region, exec);
    spread_hit_distances(gb, stats.view(), s.filter.spread_radius, exec);
    image<std::uint32_t> extra(w, h, 0u);
    if (s.adaptive) {
        image<T> rejected;  // the rejection boost's fraction f per pixel, when enabled
        if (s.filter.rejection_boost) {
            image<T> beta(w, h);
            image<glm::vec<3, T>> normals(w, h);
            for (std::size_t y = 0; y < h; ++y)
                for (std::size_t x = 0; x < w; ++x) {
                    normals(x, y) = detail::ao_guide_normal(detail::ao_unit_or_zero(gb.normals(x, y)));
                    beta(x, y) = stats(x, y).samples == 0 ? T(0) : ao_filter_width(stats(x, y).z_min, s.filter);
                }
            rejected.reset(w, h);
            if constexpr (gbuffer<T, Ids>::has_ids)
                detail::ao_rejected_fraction<T>(guides{normals.cview(), gb.ids, no_guide{}}, gb.pixel_size, beta, rejected,
                                                s.filter, exec);
            else
                detail::ao_rejected_fraction<T>(guides{normals.cview(), no_guide{}, no_guide{}}, gb.pixel_size, beta,
                                                rejected, s.filter, exec);
        }
        bool any = false;
        for (std::size_t y = 0; y < h; ++y)
            for (std::size_t x = 0; x < w; ++x) {
                const ao_stats<T>& r = stats(x, y);
                if (r.samples == 0 || !(r.z_min < std::numeric_limits<T>::infinity())) continue;
                T n = ao_sample_count(r.z_min, r.z_max, gb.pixel_size(x, y), s.filter);
                // f = 1 gives n/0 = +∞ (or NaN for n = 0, which target_samples reads as the minimum): the cap.
                if (s.filter.rejection_boost) n = n / (T(1) - rejected(x, y));
                const std::uint32_t target = target_samples(n, s.sampling.initial_samples, s.sampling.max_samples);
                extra(x, y) = target > r.samples ? target - r.samples : 0u;
                any = any || extra(x, y) > 0;
            }
        if (any) rays += gather_ambient_occlusion(gb, tracer, s.sampling, 1, 0, stats.view(), extra.cview(), region, exec);
    }
    if (!out.samples.empty())
        for (std::size_t y = 0; y < h; ++y)
            for (std::size_t x = 0; x < w; ++x) out.samples(x, y) = stats(x, y).samples;
    if (s.filtered) {
        filter_ambient_occlusion(gb, stats.cview(), s.filter, out, exec);
        return rays;
    }
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) {
            out.visibility(x, y) = stats(x, y).visibility();
            if (!out.bent_normal.empty())
                out.bent_normal(x, y) = std::isfinite(out.visibility(x, y))
                                            ? stats(x, y).bent_normal(detail::ao_unit_or_zero(gb.normals(x, y)))
                                            : glm::vec<3, T>(std::numeric_limits<T>::quiet_NaN());
            if (!out.filter_width.empty()) out.filter_width(x, y) = T(0);
        }
    return rays;
}

}  // namespace v0
}  // namespace aaf
