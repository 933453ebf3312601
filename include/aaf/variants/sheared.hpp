// SPDX-License-Identifier: MIT
#pragma once
// Sheared filtering of soft shadows, factored into two image passes (after Yan, Mehta, Ramamoorthi,
// Durand 2015, "fast 4D sheared filtering"; reconstruction in FORMULAS.md §9.1 and §9.3, the paper's body
// could not be read). Where the axis-aligned filter keeps each pixel's *visibility* and blurs it, the
// sheared filter keeps each *sample* (its light coordinate and whether it reached the light) and reuses a
// neighbour's samples for the centre by moving them along the shear: a neighbour at light-plane offset Δ,
// looking through light point y′, sees the same occluder point as the centre through y′ − cΔ (c = 1/s of
// the occluder). On a single occluder depth every neighbour's samples are then samples of the centre's own
// visibility integral, so a few samples per pixel suffice. Where occluders at several depths overlap the
// spectrum leaves the wedge (§9.1, §9.5) and the shear is wrong for part of the samples: there (s1/s2
// above sheared_settings::max_slope_ratio, or a pixel-limited wedge) the pixel falls back to aaf's
// axis-aligned filter with its adaptive samples (render_sheared).
//
// Memory (what the abstract calls FSF's "high-dimensional data storage"): every sample is kept,
// sizeof(light_sample<float>) = 16 bytes per sample (u, v, a state byte and the occluder's height) and an
// 8-byte offset per pixel: 5.5 MB at 320×240 and 4 spp, 20.3 MB at 16 spp (1080p at 16 spp: 547 MB; with
// sheared_settings::centre_samples only the centres hold that many). The row pass keeps (bins·(1 + 2·bin_margin))² bins of 4
// values per pixel: 12×12 × 16 bytes = 2.3 KB per pixel at the defaults (bins 8, margin 0.25), 177 MB at
// 320×240 and 4.8 GB at 1080p (bins 4, margin 0.5: 1 KB, 78.6 MB, 2 GB); a renderer would keep only the
// 2·max_radius + 1 rows the column pass reads. aaf's own frame keeps one
// occlusion_stats (28 bytes) per pixel.

#include <algorithm>
#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "../area_light.hpp"
#include "../executor.hpp"
#include "../filter.hpp"
#include "../formulas.hpp"
#include "../gather.hpp"
#include "../guides.hpp"
#include "../image.hpp"
#include "../occlusion_stats.hpp"
#include "../pipeline.hpp"
#include "../ray_offset.hpp"
#include "../region.hpp"
#include "../sampler.hpp"
#include "../settings.hpp"
#include "../tracer.hpp"

namespace aaf {
inline namespace v0 {

/// What became of one stored sample.
enum class sample_state : std::uint8_t {
    unused = 0,   ///< not traced (below the horizon, behind the light) or failed: no weight anywhere
    blocked = 1,  ///< an occluder lies between the receiver and the light point
    visible = 2,  ///< the light point is visible
};

/// One stored shadow sample: its light point `area_light::point(u, v)` and what the ray found.
template <class T = float>
struct light_sample {
    T u = 0, v = 0;  ///< light parameters in [0, 1)²
    sample_state state = sample_state::unused;
    /// A blocked sample's nearest occluder: its height above the light plane as a fraction of the shadow
    /// ray's origin's (1 − t/length along the ray); NaN for other states. Lets the row pass move the sample
    /// through its own occluder point (sheared_settings::per_sample_depth).
    T occluder = std::numeric_limits<T>::quiet_NaN();
};

/// Every pixel's stored samples, row-major (the sheared filter's input). Each pixel holds its own count:
/// reset() gives every pixel the same, append() adds a second pass's samples after a pixel's own (the
/// centres' extra samples of sheared_settings::centre_samples), so a pixel's span is its samples of every pass.
template <class T = float>
class light_sample_buffer {
public:
    /// Sizes the buffer for w×h pixels with `spp` samples each; every sample unused.
    void reset(std::size_t w, std::size_t h, std::uint32_t spp) {
        w_ = w, h_ = h, max_ = spp;
        data_.assign(w * h * spp, light_sample<T>{});
        start_.resize(w * h + 1);
        for (std::size_t i = 0; i <= w * h; ++i) start_[i] = i * spp;
    }
    /// Sizes the buffer for `counts`' pixels with counts(x, y) samples each; every sample unused.
    void reset(const_image_view<std::uint32_t> counts) {
        w_ = counts.width(), h_ = counts.height(), max_ = 0;
        start_.resize(w_ * h_ + 1);
        start_[0] = 0;
        for (std::size_t y = 0; y < h_; ++y)
            for (std::size_t x = 0; x < w_; ++x) {
                start_[y * w_ + x + 1] = start_[y * w_ + x] + counts(x, y);
                max_ = std::max(max_, counts(x, y));
            }
        data_.assign(start_.back(), light_sample<T>{});
    }
    /// Appends each pixel's samples of `more` (same size) after its own.
    void append(const light_sample_buffer& more) {
        if (more.w_ != w_ || more.h_ != h_)
            detail::throw_invalid("light_sample_buffer::append", "`more` holds " + std::to_string(more.w_) + "x" + std::to_string(more.h_) +
                                                                     " pixels but this buffer " + std::to_string(w_) + "x" + std::to_string(h_));
        if (more.data_.empty()) return;
        std::vector<light_sample<T>> joined;
        joined.reserve(data_.size() + more.data_.size());
        std::vector<std::size_t> start(w_ * h_ + 1, 0);
        max_ = 0;
        for (std::size_t i = 0; i < w_ * h_; ++i) {
            joined.insert(joined.end(), data_.begin() + static_cast<std::ptrdiff_t>(start_[i]), data_.begin() + static_cast<std::ptrdiff_t>(start_[i + 1]));
            joined.insert(joined.end(), more.data_.begin() + static_cast<std::ptrdiff_t>(more.start_[i]),
                          more.data_.begin() + static_cast<std::ptrdiff_t>(more.start_[i + 1]));
            start[i + 1] = joined.size();
            max_ = std::max(max_, static_cast<std::uint32_t>(start[i + 1] - start[i]));
        }
        data_ = std::move(joined), start_ = std::move(start);
    }
    [[nodiscard]] std::size_t width() const noexcept { return w_; }
    [[nodiscard]] std::size_t height() const noexcept { return h_; }
    /// The largest count of any pixel (every pixel's after reset(w, h, spp)).
    [[nodiscard]] std::uint32_t max_samples_per_pixel() const noexcept { return max_; }
    /// Samples held in all.
    [[nodiscard]] std::size_t size() const noexcept { return data_.size(); }
    /// Bytes held (the memory cost the header comment quotes; a pixel's offset adds 8 bytes).
    [[nodiscard]] std::size_t bytes() const noexcept { return data_.size() * sizeof(light_sample<T>) + start_.size() * sizeof(std::size_t); }
    [[nodiscard]] std::span<light_sample<T>> pixel(std::size_t x, std::size_t y) noexcept {
        const std::size_t i = y * w_ + x;
        return {data_.data() + start_[i], start_[i + 1] - start_[i]};
    }
    [[nodiscard]] std::span<const light_sample<T>> pixel(std::size_t x, std::size_t y) const noexcept {
        const std::size_t i = y * w_ + x;
        return {data_.data() + start_[i], start_[i + 1] - start_[i]};
    }

private:
    std::size_t w_ = 0, h_ = 0;
    std::uint32_t max_ = 0;
    std::vector<light_sample<T>> data_;
    std::vector<std::size_t> start_{0};  // pixel i's samples are data_[start_[i], start_[i + 1])
};

/// A pixel's shear (FORMULAS.md §9.1): `c` = ½(1/s1 + 1/s2), the light-plane shift per unit of receiver
/// offset (dimensionless; NaN = the pixel has no slopes); `beta` = 1/(k·w), the spatial Gaussian's standard
/// deviation in world units on the light plane, with w = (μΩ_L/2)(1/s2 − 1/s1) the wedge's half-width
/// (+∞ for a single depth, s1 = s2); `center` = the sheared filter (not aaf's) gives this pixel's output.
template <class T = float>
struct shear {
    T c = std::numeric_limits<T>::quiet_NaN();
    T beta = 0;
    bool center = false;
    [[nodiscard]] bool has_slopes() const noexcept { return std::isfinite(c); }
};

/// How the sheared gather turns its weighted samples into a visibility.
enum class sheared_normalization {
    /// One ratio Σ a·L·V / Σ a·L over all moved samples (FORMULAS.md §9.3 as written). Biased wherever the
    /// moved samples do not cover the centre's light evenly: each neighbour's samples cover its light shifted
    /// by cΔ, so near the light's edges fewer neighbours contribute and the light's middle is over-weighted.
    pooled,
    /// The centre's light cut into bins × bins cells: each cell's weighted mean visibility, averaged with the
    /// cells' emission as weights (cells without samples are left out). Removes that density bias
    /// (DEVIATIONS.md). The default.
    per_cell,
};

/// Settings of the sheared filter and of render_sheared.
template <class T = float>
struct sheared_settings {
    /// `sampling.initial_samples`: the samples kept per pixel (centres may get more: centre_samples); `formulas`
    /// (k, μ, α) for both filters; `filter` for aaf's filter on the fallback pixels and for slope spreading,
    /// the normal threshold and the truncation (in units of β) of the sheared one; `sampling.adaptive`:
    /// fallback pixels get aaf's adaptive samples n(μ), capped at `sampling.max_samples`.
    frame_settings<T> frame{};
    /// s1/s2 above which a pixel falls back to aaf: there occluders at several depths overlap and the
    /// sheared filter has a bias floor (FORMULAS.md §9.3 table); [1, ∞], +∞ = never fall back.
    T max_slope_ratio = T(2);
    /// A neighbour whose c differs from the centre's by more than this fraction of it is rejected (its
    /// samples would be moved along the wrong shear, §9.5); [0, ∞], +∞ = no test.
    T shear_tolerance = T(0.5);
    /// Bins per light width and axis of the row pass's reprojected samples; [1, 32]. Each bin keeps the
    /// weighted mean of its samples' coordinates, so a bin of one sample is exact. 8, not 4: from 9 samples
    /// per pixel on, 4 bins' coarser cells are most of the remaining error (docs/RESULTS.md: lattice at
    /// 25 spp 0.0085 → 0.0063 RMSE); 12 was worse than 8 (0.0078 against 0.0070 at a fixed width: more
    /// cells without samples).
    std::uint32_t bins = 8;
    /// Light widths the bins extend beyond the light on each side (a sample moved off the light by the row
    /// pass may be moved back by the column pass); [0, 2]. 0.25 and 0.5 gave the same result to 4 digits.
    T bin_margin = T(0.25);
    /// Cap on the kernel radius in pixels (each pass); [0, 64].
    std::uint32_t max_radius = 12;
    /// The spatial Gaussian's standard deviation as a fraction of the wedge's 1/(k·w); (0, 1]. Why below 1:
    /// a neighbour's sample whose occluder is not at the centre's shear depth lands up to |Δx|·(1/s2 − 1/s1)/2
    /// from where it belongs on the light, i.e. up to width_scale·σ/(k·μ) at |Δx| = β — independent of how
    /// far apart the depths are. On a hard-edged light that blur of the visibility is a bias no number of
    /// samples removes (the floor of docs/RESULTS.md); narrowing the filter shrinks it in proportion, at the
    /// price of fewer neighbours. `narrowing_pixels` lowers it as samples grow.
    T width_scale = T(1);
    /// Narrows each pixel's spatial width with the samples per pixel n so that the filter is consistent:
    /// β = min(width_scale·β_w, n^(−1/4)·√(narrowing_pixels·d·β_w)), β_w = 1/(k·w) and d the pixel's
    /// footprint; [0, ∞], 0 = off (∞ too: the min keeps width_scale·β_w). Why that form: the bias above grows as β, the variance falls as the
    /// samples the kernel holds, n·(β/d)²; their sum is least at β ∝ n^(−1/4)·√(d·β_w), so the bias → 0 while
    /// the samples held still grow as √n. The default 3 is the best of 0.5/1/2/3/4 on our scenes
    /// (docs/RESULTS.md); a single-depth pixel (β_w = ∞) keeps its unbounded Gaussian.
    T narrowing_pixels = T(3);
    /// How the weighted samples become a visibility (also the cells of per_cell: `bins` per axis).
    sheared_normalization normalization = sheared_normalization::per_cell;
    /// Row pass: a neighbour's blocked sample is moved through its own nearest occluder point (light_sample::
    /// occluder) instead of through the occluder plane of the centre's shear; its visible samples still move
    /// with the shear. Where occluders at other depths than the shear's overlap, their samples then land where
    /// they belong on the light (docs/DEVIATIONS.md H9; the column pass still moves bins with one shear).
    bool per_sample_depth = true;
    /// Samples a sheared centre ends with, its initial ones included: render_sheared traces the difference in
    /// a second pass (pass 1; with sample_pattern::low_discrepancy the rest of the centre's pass-0 sequence,
    /// so that its samples are one net) and stores it after the first, recomputing the centres' shears from
    /// all of them (DEVIATIONS.md H10), while every other pixel keeps
    /// `frame.sampling.initial_samples` (fallback pixels: aaf's adaptive samples). The centres are where the
    /// sheared filter's error is (docs/RESULTS.md: 87–100 % of it on nine of ten scenes at 16 spp) and a
    /// fully lit pixel needs only enough samples to find no occluder, so the rays go where they pay, as aaf's
    /// adaptive pass does (FORMULAS.md §9.3 "Sampling rate"). The narrowing above counts these samples.
    /// 0 = initial_samples (one pass); otherwise [initial_samples, 4096].
    std::uint32_t centre_samples = 0;
    /// μ of aaf's formulas on the fallback pixels (their filter width and adaptive samples), so that they can
    /// follow the centres down as centre_samples grows: at a fixed μ = 2 they keep aaf's μ = 2 error, a floor
    /// under the whole frame's (docs/RESULTS.md: plant 0.0078 outside the centres at every knob). 0 = the
    /// μ of `frame.formulas` (which the sheared centres' wedge always uses); otherwise finite and ≥ 1.
    T fallback_mu = T(0);
    /// The samples a centre ends with (initial_samples when centre_samples is 0).
    [[nodiscard]] std::uint32_t samples_per_centre() const noexcept {
        return std::max(centre_samples, frame.sampling.initial_samples);
    }
};

/// Throws aaf::invalid_argument naming the first invalid field.
template <class T>
void validate(const sheared_settings<T>& s, const char* function = "validate") {
    validate(s.frame, function);
    if (!(s.max_slope_ratio >= T(1)))
        detail::throw_invalid(function, "`settings.max_slope_ratio` must be in [1, inf] (got " + std::to_string(s.max_slope_ratio) + ")");
    if (!(s.shear_tolerance >= T(0)))
        detail::throw_invalid(function, "`settings.shear_tolerance` must be in [0, inf] (got " + std::to_string(s.shear_tolerance) + ")");
    if (s.bins < 1 || s.bins > 32) detail::throw_invalid(function, "`settings.bins` must be in [1, 32] (got " + std::to_string(s.bins) + ")");
    if (!(s.bin_margin >= T(0) && s.bin_margin <= T(2)))
        detail::throw_invalid(function, "`settings.bin_margin` must be in [0, 2] (got " + std::to_string(s.bin_margin) + ")");
    if (s.normalization != sheared_normalization::pooled && s.normalization != sheared_normalization::per_cell)
        detail::throw_invalid(function, "`settings.normalization` must be sheared_normalization::pooled or per_cell");
    if (s.max_radius > 64) detail::throw_invalid(function, "`settings.max_radius` must be in [0, 64] (got " + std::to_string(s.max_radius) + ")");
    if (!(s.width_scale > T(0) && s.width_scale <= T(1)))
        detail::throw_invalid(function, "`settings.width_scale` must be in (0, 1] (got " + std::to_string(s.width_scale) + ")");
    if (!(s.narrowing_pixels >= T(0)))
        detail::throw_invalid(function, "`settings.narrowing_pixels` must be in [0, inf] (got " + std::to_string(s.narrowing_pixels) + ")");
    if (!(s.fallback_mu == T(0) || (std::isfinite(s.fallback_mu) && s.fallback_mu >= T(1))))
        detail::throw_invalid(function, "`settings.fallback_mu` must be 0 or finite and >= 1 (got " + std::to_string(s.fallback_mu) + ")");
    if (s.centre_samples != 0 && (s.centre_samples < s.frame.sampling.initial_samples || s.centre_samples > 4096))
        detail::throw_invalid(function, "`settings.centre_samples` must be 0 or in [frame.sampling.initial_samples = " +
                                            std::to_string(s.frame.sampling.initial_samples) + ", 4096] (got " +
                                            std::to_string(s.centre_samples) + ")");
}

/// A pixel's shear from its slopes (FORMULAS.md §9.1), σ of the light and its footprint d. Not a
/// `center` (aaf's filter instead) when: no slopes; s2 = 0 (contact: c → ∞, nothing to reuse); σ = 0;
/// s1/s2 > max_slope_ratio; or the wedge is pixel-limited, 2w·d > α (one primary ray per pixel would alias
/// the pixel-grid replicas, §9.3 "Sampling rate").
template <class T>
[[nodiscard]] shear<T> shear_of(const slope_pair<T>& s, T sigma, T pixel_size, const sheared_settings<T>& set) noexcept {
    shear<T> r;
    if (!s.has_occluder() || !(s.s2 > T(0)) || !std::isfinite(s.s1) || !(sigma > T(0)) || !std::isfinite(sigma)) return r;
    const formula_settings<T>& f = set.frame.formulas;
    const T inv1 = T(1) / s.s1, inv2 = T(1) / s.s2;
    r.c = T(0.5) * (inv1 + inv2);
    const T w = f.mu / sigma * T(0.5) * std::max(inv2 - inv1, T(0));
    const T wedge_beta = w > T(0) ? T(1) / (f.k * w) : std::numeric_limits<T>::infinity();
    r.beta = set.width_scale * wedge_beta;
    if (set.narrowing_pixels > T(0) && std::isfinite(set.narrowing_pixels) && std::isfinite(pixel_size) && pixel_size > T(0)) {
        const T n = static_cast<T>(std::max<std::uint32_t>(set.samples_per_centre(), 1));
        r.beta = std::min(r.beta, std::sqrt(set.narrowing_pixels * pixel_size * wedge_beta / std::sqrt(n)));  // inf stays inf
    }
    const bool pixel_limited = std::isfinite(pixel_size) && pixel_size > T(0) && T(2) * w * pixel_size > f.alpha;
    r.center = std::isfinite(r.c) && !(s.s1 > set.max_slope_ratio * s.s2) && !pixel_limited && std::isfinite(pixel_size) &&
               pixel_size > T(0);
    return r;
}

namespace detail {

/// The light's affine frame: (u, v) of a point's projection along the light normal, its height above the
/// light plane, and the light's emission profile at (u, v).
template <class T>
struct light_plane {
    glm::vec<3, T> corner, eu, ev, normal, dual_u, dual_v;
    T inv_two_sigma2 = 0;
    bool gaussian = false;
    T extent = 0;  // |eu| + |ev|: no shift larger than this keeps a sample on the light

    light_plane(const area_light<T>& light, light_weighting weighting) noexcept
        : corner(light.corner), eu(light.edge_u), ev(light.edge_v), normal(light.normal()) {
        const T g00 = glm::dot(eu, eu), g01 = glm::dot(eu, ev), g11 = glm::dot(ev, ev);
        const T det = g00 * g11 - g01 * g01;
        const T i00 = det > T(0) ? g11 / det : T(0), i01 = det > T(0) ? -g01 / det : T(0), i11 = det > T(0) ? g00 / det : T(0);
        dual_u = i00 * eu + i01 * ev;  // dual_u·eu = 1, dual_u·ev = 0, dual_u·normal = 0
        dual_v = i01 * eu + i11 * ev;
        const T s = light.sigma();
        inv_two_sigma2 = s > T(0) ? T(1) / (T(2) * s * s) : T(0);
        gaussian = weighting == light_weighting::gaussian;
        extent = glm::length(eu) + glm::length(ev);
    }
    /// (u, v, height) of a world point.
    [[nodiscard]] glm::vec<3, T> coords(const glm::vec<3, T>& p) const noexcept {
        const glm::vec<3, T> d = p - corner;
        return {glm::dot(d, dual_u), glm::dot(d, dual_v), glm::dot(d, normal)};
    }
    /// Emission weight at light parameters (u, v): 0 off the light; 1 (uniform); the Gaussian of §1.4.
    /// The receiver's horizon and irradiance weighting are not re-evaluated for moved samples (DEVIATIONS).
    [[nodiscard]] T profile(T u, T v) const noexcept {
        if (!(u >= T(0) && u <= T(1) && v >= T(0) && v <= T(1))) return T(0);
        if (!gaussian) return T(1);
        const glm::vec<3, T> d = (u - T(0.5)) * eu + (v - T(0.5)) * ev;
        return std::exp(-glm::dot(d, d) * inv_two_sigma2);
    }
    /// The profile averaged over a square of half-width `half` around (u, v), taking the samples of a bin
    /// as spread uniformly over it: the fraction of the square on the light (times the Gaussian at its
    /// centre). A bin straddling the light's edge then counts in part instead of all or nothing, which makes
    /// the binning error second order in the bin size where the edge is straight.
    [[nodiscard]] T profile_box(T u, T v, T half) const noexcept {
        if (!(half > T(0))) return profile(u, v);
        const auto cover = [half](T c) { return std::clamp((std::min(c + half, T(1)) - std::max(c - half, T(0))) / (T(2) * half), T(0), T(1)); };
        const T f = cover(u) * cover(v);
        if (!(f > T(0))) return T(0);
        if (!gaussian) return f;
        const glm::vec<3, T> d = (u - T(0.5)) * eu + (v - T(0.5)) * ev;
        return f * std::exp(-glm::dot(d, d) * inv_two_sigma2);
    }
};

/// Moves light parameters (u, v) seen from a receiver at plane coordinates `from` (u, v, height) into the
/// frame of a receiver at `to`, through the occluder plane at height `d2` above the light: the ray from
/// `from` to the light point crosses that plane at o; the returned point is where the ray from `to` through
/// o meets the light. Exact for receivers at different heights (tilted surfaces); for equal heights it is
/// y − c·(x_to − x_from) with c = d2/(h − d2), FORMULAS.md §9.1. NaN when the occluder plane is not
/// between both receivers and the light.
template <class T>
[[nodiscard]] glm::vec<2, T> reproject(glm::vec<2, T> y, const glm::vec<3, T>& from, const glm::vec<3, T>& to, T d2) noexcept {
    const T t_from = d2 / from.z, t_to = d2 / to.z;
    if (!(t_from >= T(0) && t_from < T(1) && t_to >= T(0) && t_to < T(1))) return glm::vec<2, T>(std::numeric_limits<T>::quiet_NaN());
    const glm::vec<2, T> o = y + (glm::vec<2, T>(from.x, from.y) - y) * t_from;
    return (o - glm::vec<2, T>(to.x, to.y) * t_to) / (T(1) - t_to);
}

/// detail::reproject as the affine map y ↦ scale·y + offset for one pair of receivers (computed once per
/// neighbour, applied per sample or bin). `valid` false where reproject gives NaN.
template <class T>
struct reprojection {
    T scale = 1;
    glm::vec<2, T> offset{0};
    bool valid = true;
    reprojection(const glm::vec<3, T>& from, const glm::vec<3, T>& to, T d2) noexcept {
        const T t_from = d2 / from.z, t_to = d2 / to.z;
        valid = t_from >= T(0) && t_from < T(1) && t_to >= T(0) && t_to < T(1);
        if (!valid) return;
        const T inv = T(1) / (T(1) - t_to);
        scale = (T(1) - t_from) * inv;
        offset = (glm::vec<2, T>(from.x, from.y) * t_from - glm::vec<2, T>(to.x, to.y) * t_to) * inv;
    }
    [[nodiscard]] glm::vec<2, T> operator()(glm::vec<2, T> y) const noexcept { return y * scale + offset; }
};

/// Squared offset of two world points projected onto the light plane.
template <class T>
[[nodiscard]] T plane_distance2(const glm::vec<3, T>& a, const glm::vec<3, T>& b, const glm::vec<3, T>& n) noexcept {
    const glm::vec<3, T> d = a - b;
    const T along = glm::dot(d, n);
    return std::max(glm::dot(d, d) - along * along, T(0));
}

/// The kernel radius in pixels of a pixel with shear `sh` and footprint d: β·truncation, and no farther
/// than a shift of one light extent, capped.
template <class T>
[[nodiscard]] std::size_t shear_radius(const shear<T>& sh, T pixel_size, T extent, T truncation, std::uint32_t cap) noexcept {
    if (!sh.has_slopes() || !(pixel_size > T(0)) || !std::isfinite(pixel_size)) return 0;
    T r = sh.beta * truncation;
    if (sh.c > T(0)) r = std::min(r, extent / sh.c);
    const T px = r / pixel_size;
    if (!(px >= T(0))) return 0;
    return static_cast<std::size_t>(std::min(std::ceil(px), static_cast<T>(cap)));
}

/// Accepts neighbour shear `n` for centre shear `c`: a neighbour without slopes (fully lit around) is
/// accepted, one with slopes must have a c within `tol` of the centre's.
template <class T>
[[nodiscard]] bool shear_similar(const shear<T>& center, const shear<T>& n, T tol) noexcept {
    if (!n.has_slopes()) return true;
    return std::abs(n.c - center.c) <= tol * center.c;
}

}  // namespace detail

/// Working memory of the sheared passes and of render_sheared (kept between frames).
template <class T = float>
struct sheared_workspace {
    /// One bin of the row pass: Σ weight, Σ weight·visible, Σ weight·u, Σ weight·v.
    struct bin {
        T w = 0, wv = 0, wu = 0, wy = 0;
    };
    light_sample_buffer<T> samples;  ///< every pixel's stored samples (render_sheared)
    light_sample_buffer<T> centre_extra;        ///< render_sheared: the centres' second pass, before it joins `samples`
    image<std::uint32_t> centre_extra_counts;   ///< render_sheared: each pixel's samples of that pass
    image<shear<T>> shears;          ///< every pixel's shear
    std::vector<bin> bins;           ///< row pass: bins_per_axis² per pixel
    std::size_t bins_per_axis = 0;
    /// Row pass: which of a pixel's bins hold samples, one bit each (bin_words words per pixel), so that the
    /// column pass reads only those, in the same order.
    std::vector<std::uint64_t> occupied;
    std::size_t bin_words = 0;
    image<T> sheared;                ///< sheared filter's output (NaN where not a centre)
    /// aaf's buffers (statistics, slopes, β, its filter) for the fallback; after render_sheared,
    /// `frame.filtered` holds the frame's result before clamping (`sheared` on the centres, aaf's elsewhere).
    frame_workspace<T> frame;

    /// Allocates what a w×h frame with settings `s` needs (the centres' second pass excepted: its size
    /// depends on the frame), so that a renderer's first frame does not pay for it (as frame_workspace::resize).
    /// render_sheared calls it for every frame (sizes that already fit are kept).
    void resize(std::size_t w, std::size_t h, const sheared_settings<T>& s) {
        frame.resize(w, h);
        if (shears.width() != w || shears.height() != h) shears.reset(w, h), sheared.reset(w, h);
        if (centre_extra_counts.width() != w || centre_extra_counts.height() != h) centre_extra_counts.reset(w, h);
        samples.reset(w, h, s.frame.sampling.initial_samples);  // the last frame's centres may have appended theirs
        resize_bins(w, h, s);
    }
    /// Sizes the row pass's bins and their occupancy bits for w×h pixels (sheared_filter calls it): bins ·
    /// (1 + 2·bin_margin) bins per axis, rounded up; not cleared (the row pass clears each pixel's own).
    void resize_bins(std::size_t w, std::size_t h, const sheared_settings<T>& s) {
        bins_per_axis = static_cast<std::size_t>(std::ceil(static_cast<T>(s.bins) * (T(1) + T(2) * s.bin_margin)));
        bin_words = (bins_per_axis * bins_per_axis + 63) / 64;
        if (bins.size() != w * h * bins_per_axis * bins_per_axis) bins.resize(w * h * bins_per_axis * bins_per_axis);
        if (occupied.size() != w * h * bin_words) occupied.resize(w * h * bin_words);
    }
};

/// The two factored passes of the sheared filter over stored samples, on every pixel whose shear is a
/// `center` (others get NaN in `output`):
/// * rows: each pixel q gathers its row neighbours' samples within its radius, moves them into its own
///   frame with its shear (detail::reproject), weighs them with the spatial Gaussian of its β and splats
///   them into bins of the moved light coordinate (bins per light width: settings.bins);
/// * columns: each centre p gathers its column neighbours' bins, moves each bin's mean coordinate into its
///   own frame with its shear and sums Gaussian × light profile × visibility over weights.
/// With a constant shear and rows orthogonal to columns on the light plane this is the exact O(n²l²)
/// light-integrated sheared gather (tests/reference/reference_sheared.hpp) up to the binning; otherwise it
/// approximates it as aaf's separable passes approximate its 2-D filter (FORMULAS.md §9.3).
/// Neighbours are rejected by `g` (normals, IDs; a normal guide uses settings.frame.filter's threshold),
/// by non-finite positions and by a shear differing by more than settings.shear_tolerance.
/// Throws aaf::invalid_argument (before writing) on mismatched sizes or invalid settings.
template <class T, class G = guides<>, class Exec = sequential_executor>
    requires detail::is_guides<G>::value
void sheared_filter(const_image_view<glm::vec<3, T>> positions, const_image_view<T> pixel_size, const area_light<T>& light,
                    const light_sample_buffer<T>& samples, const_image_view<shear<T>> shears, image_view<T> output,
                    sheared_workspace<T>& ws, const G& g = {}, const sheared_settings<T>& s = {}, Exec&& exec = {}) {
    constexpr const char* fn = "sheared_filter";
    detail::require_nonempty(fn, "positions", positions);
    const std::size_t w = positions.width(), h = positions.height();
    detail::require_size(fn, "pixel_size", pixel_size, w, h);
    detail::require_size(fn, "shears", shears, w, h);
    detail::require_size(fn, "output", output, w, h);
    detail::require_guides(fn, g, w, h);
    if (samples.width() != w || samples.height() != h)
        detail::throw_invalid(fn, "`samples` holds " + std::to_string(samples.width()) + "x" + std::to_string(samples.height()) +
                                      " pixels but `positions` is " + std::to_string(w) + "x" + std::to_string(h));
    detail::require_light(fn, light);
    validate(s, fn);

    const detail::light_plane<T> lp(light, s.frame.sampling.weighting);
    const T tol = s.shear_tolerance, trunc = s.frame.filter.truncation;
    const T cos_thr = std::cos(s.frame.filter.normal_threshold_degrees * T(3.14159265358979323846) / T(180));
    const T B = static_cast<T>(s.bins), margin = s.bin_margin;
    // Sized here, cleared per pixel by the row pass (one sweep over the 2.3 KB a pixel instead of two).
    ws.resize_bins(w, h, s);
    const std::size_t nb = ws.bins_per_axis, words = ws.bin_words;
    const auto plane = [&](std::size_t x, std::size_t y) { return lp.coords(positions(x, y)); };
    const auto finite3 = [](const glm::vec<3, T>& p) { return std::isfinite(p.x + p.y + p.z); };

    // Rows: every pixel with slopes gathers its row into its bins; one without slopes keeps its own samples
    // unmoved (a column centre moves them with its own shear).
    exec.parallel_for(h, [&](std::size_t y0, std::size_t y1) {
        for (std::size_t y = y0; y < y1; ++y)
            for (std::size_t x = 0; x < w; ++x) {
                typename sheared_workspace<T>::bin* out = ws.bins.data() + (y * w + x) * nb * nb;
                std::uint64_t* used = ws.occupied.data() + (y * w + x) * words;
                std::fill_n(out, nb * nb, typename sheared_workspace<T>::bin{});
                std::fill_n(used, words, std::uint64_t{0});
                const glm::vec<3, T> p0 = positions(x, y);
                if (!finite3(p0)) continue;
                const shear<T> sh = shears(x, y);
                const glm::vec<3, T> q = plane(x, y);
                const std::size_t r = sh.has_slopes() ? detail::shear_radius(sh, pixel_size(x, y), lp.extent, trunc, s.max_radius) : 0;
                const T d2 = sh.has_slopes() ? q.z * sh.c / (T(1) + sh.c) : T(0);
                const T inv_two_beta2 = std::isfinite(sh.beta) && sh.beta > T(0) ? T(1) / (T(2) * sh.beta * sh.beta) : T(0);
                const detail::guide_center<T, G> gc(g, x, y);
                const std::size_t xa = x >= r ? x - r : 0, xb = std::min(w - 1, x + r);
                for (std::size_t xn = xa; xn <= xb; ++xn) {
                    const glm::vec<3, T> pn = positions(xn, y);
                    if (!finite3(pn)) continue;
                    if (xn != x && (!gc.accepts(g, xn, y, cos_thr) || !detail::shear_similar(sh, shears(xn, y), tol))) continue;
                    const T a = std::exp(-detail::plane_distance2(p0, pn, lp.normal) * inv_two_beta2);
                    const glm::vec<3, T> from = plane(xn, y);
                    const detail::reprojection<T> move(from, q, d2);
                    if (xn != x && !move.valid) continue;
                    for (const light_sample<T>& smp : samples.pixel(xn, y)) {
                        if (smp.state == sample_state::unused) continue;
                        glm::vec<2, T> m(smp.u, smp.v);
                        // Its own occluder point (NaN, so no bin, when that is not between the receivers and the light).
                        if (xn != x && s.per_sample_depth && smp.state == sample_state::blocked && std::isfinite(smp.occluder))
                            m = detail::reproject(m, from, q, from.z * smp.occluder);
                        else if (xn != x) m = move(m);
                        const T bu = std::floor((m.x + margin) * B), bv = std::floor((m.y + margin) * B);
                        if (!(bu >= T(0) && bu < static_cast<T>(nb) && bv >= T(0) && bv < static_cast<T>(nb))) continue;
                        const std::size_t at = static_cast<std::size_t>(bv) * nb + static_cast<std::size_t>(bu);
                        auto& b = out[at];
                        used[at / 64] |= std::uint64_t{1} << (at % 64);
                        b.w += a, b.wu += a * m.x, b.wy += a * m.y;
                        if (smp.state == sample_state::visible) b.wv += a;
                    }
                }
            }
    });

    // Columns: each centre gathers its column's bins.
    const bool per_cell = s.normalization == sheared_normalization::per_cell;
    exec.parallel_for(h, [&](std::size_t y0, std::size_t y1) {
        std::vector<T> cell_num(per_cell ? std::size_t{s.bins} * s.bins : 0), cell_den(cell_num.size());
        for (std::size_t y = y0; y < y1; ++y)
            for (std::size_t x = 0; x < w; ++x) {
                const shear<T> sh = shears(x, y);
                const glm::vec<3, T> p0 = positions(x, y);
                if (!sh.center || !finite3(p0)) {
                    output(x, y) = std::numeric_limits<T>::quiet_NaN();
                    continue;
                }
                const glm::vec<3, T> q = plane(x, y);
                const std::size_t r = detail::shear_radius(sh, pixel_size(x, y), lp.extent, trunc, s.max_radius);
                const T d2 = q.z * sh.c / (T(1) + sh.c);
                const T inv_two_beta2 = std::isfinite(sh.beta) && sh.beta > T(0) ? T(1) / (T(2) * sh.beta * sh.beta) : T(0);
                const detail::guide_center<T, G> gc(g, x, y);
                const T half_bin = T(0.5) / B;
                const std::size_t ya = y >= r ? y - r : 0, yb = std::min(h - 1, y + r);
                T num = 0, den = 0;
                if (per_cell) std::fill(cell_num.begin(), cell_num.end(), T(0)), std::fill(cell_den.begin(), cell_den.end(), T(0));
                for (std::size_t yn = ya; yn <= yb; ++yn) {
                    const glm::vec<3, T> pn = positions(x, yn);
                    if (!finite3(pn)) continue;
                    if (yn != y && (!gc.accepts(g, x, yn, cos_thr) || !detail::shear_similar(sh, shears(x, yn), tol))) continue;
                    const T a = std::exp(-detail::plane_distance2(p0, pn, lp.normal) * inv_two_beta2);
                    const detail::reprojection<T> move(plane(x, yn), q, d2);
                    if (yn != y && !move.valid) continue;
                    const typename sheared_workspace<T>::bin* in = ws.bins.data() + (yn * w + x) * nb * nb;
                    const std::uint64_t* used = ws.occupied.data() + (yn * w + x) * words;
                    // The occupied bins in ascending order, as a loop over all of them that skips the empty ones.
                    for (std::size_t word = 0; word < words; ++word) {
                        for (std::uint64_t bits = used[word]; bits != 0; bits &= bits - 1) {
                            const auto& b = in[word * 64 + static_cast<std::size_t>(std::countr_zero(bits))];
                            if (!(b.w > T(0))) continue;
                            glm::vec<2, T> m(b.wu / b.w, b.wy / b.w);
                            if (yn != y) m = move(m);
                            const T l = lp.profile_box(m.x, m.y, half_bin);
                            if (!(l > T(0))) continue;
                            if (per_cell) {
                                const auto cu = static_cast<std::size_t>(std::clamp(m.x * B, T(0), B - T(1)));
                                const auto cv = static_cast<std::size_t>(std::clamp(m.y * B, T(0), B - T(1)));
                                cell_num[cv * s.bins + cu] += a * l * b.wv, cell_den[cv * s.bins + cu] += a * l * b.w;
                            } else {
                                num += a * l * b.wv, den += a * l * b.w;
                            }
                        }
                    }
                }
                if (per_cell) {  // each light cell's mean visibility, weighed by its emission (not by its samples)
                    for (std::size_t c = 0; c < cell_num.size(); ++c) {
                        if (!(cell_den[c] > T(0))) continue;
                        const T e = lp.profile((static_cast<T>(c % s.bins) + T(0.5)) / B, (static_cast<T>(c / s.bins) + T(0.5)) / B);
                        num += e * cell_num[c] / cell_den[c], den += e;
                    }
                }
                output(x, y) = den > T(0) ? num / den : std::numeric_limits<T>::quiet_NaN();
            }
    });
}

/// Traces as many samples of pass `pass` per surface pixel as the pixel holds in `samples` (sized by the
/// caller with reset(); keys from pixel_key, so the same samples as gather_occlusion draws for that pass),
/// stores each sample's light coordinate, visibility and occluder height there and adds them to `stats` as
/// gather_occlusion does (nearest and farthest occluder). Returns the rays traced.
/// `skip`: a pixel's samples are the indices [skip, skip + its count) of the pass's sequence. With
/// sample_pattern::low_discrepancy every prefix of a pixel's sequence is a net, so a second call with the
/// same pass and `skip` = the first call's count continues it (one net over both calls); for the other
/// patterns the points of a sequence depend on its length, so leave it 0 and use another pass.
template <class T, class Ids, class Tracer, class Exec = sequential_executor>
    requires occlusion_tracer<Tracer, T>
std::uint64_t gather_light_samples(const gbuffer<T, Ids>& gb, const area_light<T>& light, const Tracer& tracer,
                                   const sampling_settings& s, std::uint32_t pass, light_sample_buffer<T>& samples,
                                   image_view<occlusion_stats<T>> stats, Exec&& exec = {}, std::uint32_t skip = 0) {
    constexpr const char* fn = "gather_light_samples";
    detail::require_gbuffer(fn, gb);
    detail::require_light(fn, light);
    validate(s, fn);
    const std::size_t w = gb.width(), h = gb.height();
    detail::require_size(fn, "stats", stats, w, h);
    if (samples.width() != w || samples.height() != h)
        detail::throw_invalid(fn, "`samples` holds " + std::to_string(samples.width()) + "x" + std::to_string(samples.height()) +
                                      " pixels; reset it to the G-buffer's " + std::to_string(w) + "x" + std::to_string(h));
    const std::uint32_t max_spp = samples.max_samples_per_pixel();
    const light_sample_frame<T> frame(light, s.weighting);
    std::atomic<std::uint64_t> rays{0};
    exec.parallel_for(h, [&](std::size_t y0, std::size_t y1) {
        std::vector<glm::vec<2, T>> uv(std::size_t{max_spp} + skip);
        std::vector<shadow_segment<T>> seg(max_spp);
        std::vector<occluder_span<T>> hit(max_spp);
        std::vector<T> wgt(max_spp);
        std::vector<std::uint32_t> index(max_spp);
        detail::trace_scratch<T> scratch;
        std::uint64_t local = 0;
        for (std::size_t y = y0; y < y1; ++y)
            for (std::size_t x = 0; x < w; ++x) {
                std::span<light_sample<T>> out = samples.pixel(x, y);
                for (auto& o : out) o = {};
                const auto spp = static_cast<std::uint32_t>(out.size());
                if (spp == 0) continue;
                const glm::vec<3, T> p = gb.positions(x, y);
                const glm::vec<3, T> n0 = gb.normals(x, y);
                if (!std::isfinite(p.x + p.y + p.z) || !std::isfinite(n0.x + n0.y + n0.z)) continue;
                const glm::vec<3, T> n = detail::receiver_normal(n0, p, frame.center);
                generate_samples<T>(s.pattern, pixel_key(gb.region, x, y, pass, s.light_index, s.frame_seed), std::span(uv.data(), std::size_t{skip} + spp));
                const glm::vec<3, T> origin = shadow_ray_origin(p, n, frame.center, s.origin_offset);
                const T d1 = std::abs(glm::dot(origin - light.corner, frame.normal));
                std::uint32_t traced = 0;
                occlusion_stats<T>& st = stats(x, y);
                for (std::uint32_t i = 0; i < spp; ++i) {
                    const glm::vec<2, T> at = uv[skip + i];
                    out[i].u = at.x, out[i].v = at.y;
                    const glm::vec<3, T> yl = light.point(at.x, at.y);
                    const T wi = frame.weight(n, yl - p, yl);
                    const glm::vec<3, T> to = yl - origin;
                    const T len = glm::length(to);
                    if (!(wi > T(0)) || !std::isfinite(wi) || !(len > T(0)) || !std::isfinite(len)) {
                        ++st.samples;  // drawn, no weight (as gather_occlusion)
                        continue;
                    }
                    seg[traced] = {origin, to * (T(1) / len), len};
                    wgt[traced] = wi;
                    index[traced] = i;
                    ++traced;
                }
                std::fill_n(hit.begin(), traced, occluder_span<T>{});
                detail::trace_all<T>(tracer, std::span<const shadow_segment<T>>(seg.data(), traced), std::span<occluder_span<T>>(hit.data(), traced),
                             &scratch);
                local += traced;
                for (std::uint32_t j = 0; j < traced; ++j) {
                    st.add_sample(wgt[j], d1, seg[j].length, hit[j]);
                    const bool failed = std::isnan(hit[j].nearest) || std::isnan(hit[j].farthest);
                    out[index[j]].state = failed ? sample_state::unused : hit[j].hit() ? sample_state::blocked : sample_state::visible;
                    if (!failed && hit[j].hit()) out[index[j]].occluder = T(1) - hit[j].nearest / seg[j].length;
                }
            }
        rays += local;
    });
    return rays.load();
}

/// A whole frame with the sheared filter (FORMULAS.md §9.3) where it applies and aaf elsewhere:
/// 1. `settings.frame.sampling.initial_samples` samples per pixel, stored (gather_light_samples, pass 0);
/// 2. slopes, spread to unoccluded neighbours (§1.12), and each pixel's shear (shear_of);
/// 3. pixels that are not sheared centres but have slopes get aaf's adaptive samples (visibility only,
///    pass 1, n(μ) capped at max_samples, μ = settings.fallback_mu if set) and aaf's filter (image-space
///    offsets, normals and IDs); the centres get settings.centre_samples − initial_samples more stored
///    samples (pass 1, or the rest of their pass-0 sequence with low-discrepancy samples), if any, and their
///    shears again from all their samples;
/// 4. the sheared passes (sheared_filter) on the centres.
/// report.adaptive_rays counts both second passes.
/// Outputs and the report's pixel counts as render_frame's (sky 1, no light 0, clamped to [0, 1];
/// report.diagnose()). Throws aaf::invalid_argument before writing on mismatched buffers or invalid settings.
template <class T, class Ids, class Tracer, class Exec = sequential_executor>
    requires occlusion_tracer<Tracer, T>
frame_report render_sheared(const gbuffer<T, Ids>& gb, const area_light<T>& light, const Tracer& tracer, const frame_outputs<T>& out,
                            sheared_workspace<T>& ws, const sheared_settings<T>& settings = {}, Exec&& exec = {}) {
    constexpr const char* fn = "render_sheared";
    using clock = std::chrono::steady_clock;
    detail::require_gbuffer(fn, gb);
    detail::require_light(fn, light);
    validate(settings, fn);
    const std::size_t w = gb.width(), h = gb.height();
    detail::require_size(fn, "outputs.visibility", out.visibility, w, h);
    detail::require_size_or_empty(fn, "outputs.shaded", out.shaded, w, h);
    detail::require_size_or_empty(fn, "outputs.unshadowed", out.unshadowed, w, h);

    frame_report report;
    const auto t_frame = clock::now();
    ws.resize(w, h, settings);
    frame_workspace<T>& fw = ws.frame;
    fw.stats.fill(occlusion_stats<T>{});
    fw.adaptive_samples.fill(0);
    const sampling_settings& ss = settings.frame.sampling;
    const formula_settings<T>& fs = settings.frame.formulas;
    formula_settings<T> fallback = fs;  // aaf's formulas on the pixels that are not sheared centres
    if (settings.fallback_mu > T(0)) fallback.mu = settings.fallback_mu;
    const std::uint32_t centre_extra = settings.samples_per_centre() - ss.initial_samples;
    const T sigma = light.sigma();

    auto t0 = clock::now();
    report.initial_rays = gather_light_samples(gb, light, tracer, ss, 0, ws.samples, fw.stats.view(), exec);
    report.initial_ms = detail::ms_since(t0);

    t0 = clock::now();
    exec.parallel_for(h, [&](std::size_t y0, std::size_t y1) {
        for (std::size_t y = y0; y < y1; ++y)
            for (std::size_t x = 0; x < w; ++x) fw.slopes(x, y) = slopes(fw.stats(x, y), fs.max_slope);
    });
    const auto id_guides = [&] {
        if constexpr (gbuffer<T, Ids>::has_ids) return guides<no_guide, Ids, no_guide>{{}, gb.ids, {}};
        else return guides<>{};
    }();
    if (settings.frame.filter.spread_slopes)
        spread_slopes<T>(fw.slopes.view(), fw.slope_scratch.view(), settings.frame.filter.spread_radius, id_guides, exec);
    const bool horizon_rule = settings.frame.filter.unfiltered_at_horizon;
    const glm::vec<3, T> centre = light.center();
    exec.parallel_for(h, [&](std::size_t y0, std::size_t y1) {
        for (std::size_t y = y0; y < y1; ++y)
            for (std::size_t x = 0; x < w; ++x) {
                const T d = gb.pixel_size(x, y);
                const shear<T> sh = shear_of(fw.slopes(x, y), sigma, d, settings);
                ws.shears(x, y) = sh;
                fw.filter_width(x, y) = sh.center ? T(0) : filter_width(fw.slopes(x, y), sigma, d, fallback);
                // aaf's pixels follow render_frame's horizon rule (the sheared centres have their own gather).
                if (horizon_rule && detail::straddles_horizon_at(gb, light, centre, x, y)) fw.filter_width(x, y) = T(0);
                std::uint32_t extra = 0;
                if (!sh.center && ss.adaptive && fw.slopes(x, y).has_occluder()) {
                    const std::uint32_t n = target_samples(sample_count(fw.slopes(x, y), sigma, d, fallback), ss.initial_samples, ss.max_samples);
                    extra = n - ss.initial_samples;
                }
                fw.adaptive_samples(x, y) = extra;
                ws.centre_extra_counts(x, y) = sh.center ? centre_extra : 0;
            }
    });
    report.formulas_ms = detail::ms_since(t0);

    // Second pass (pass 1; fallback pixels and centres are disjoint): aaf's visibility-only samples on the
    // fallback pixels, stored samples on the centres (centre_samples), appended to their first ones.
    t0 = clock::now();
    report.adaptive_rays = gather_visibility(gb, light, tracer, ss, 1, 0, fw.stats.view(), fw.adaptive_samples.cview(), exec);
    if (centre_extra > 0) {
        ws.centre_extra.reset(ws.centre_extra_counts.cview());
        const bool continues = ss.pattern == sample_pattern::low_discrepancy;  // one net per centre
        report.adaptive_rays += gather_light_samples(gb, light, tracer, ss, continues ? 0 : 1, ws.centre_extra, fw.stats.view(), exec,
                                                     continues ? ss.initial_samples : 0);
        ws.samples.append(ws.centre_extra);
        // The centres' slopes from all their samples now (their own occluders; spread slopes where none was
        // found): the shear and β of 4 samples' d2min, d2max left 11 % more error on two overlapping planes
        // (tests). A centre stays a centre: it has no aaf samples to fall back on.
        exec.parallel_for(h, [&](std::size_t y0, std::size_t y1) {
            for (std::size_t y = y0; y < y1; ++y)
                for (std::size_t x = 0; x < w; ++x) {
                    if (!ws.shears(x, y).center) continue;
                    const slope_pair<T> sp = slopes(fw.stats(x, y), fs.max_slope);
                    if (!sp.has_occluder()) continue;
                    shear<T> sh = shear_of(sp, sigma, gb.pixel_size(x, y), settings);
                    if (!sh.has_slopes()) continue;
                    sh.center = true;
                    ws.shears(x, y) = sh;
                }
        });
    }
    report.adaptive_ms = detail::ms_since(t0);

    t0 = clock::now();
    exec.parallel_for(h, [&](std::size_t y0, std::size_t y1) {
        for (std::size_t y = y0; y < y1; ++y)
            for (std::size_t x = 0; x < w; ++x) fw.raw_visibility(x, y) = fw.stats(x, y).visibility();
    });
    {
        guides<const_image_view<glm::vec<3, T>>, Ids, no_guide> g{gb.normals, gb.ids, {}};
        filter_settings<T> f = settings.frame.filter;
        f.space = offset_space::image;
        f.footprint = pixel_footprint::camera;
        filter_visibility<T>(fw.raw_visibility.cview(), fw.filter_width.cview(), gb.pixel_size, fw.filtered.view(), fw.scratch.view(),
                             fw.filter, g, f, light.normal(), exec);
        sheared_filter<T>(gb.positions, gb.pixel_size, light, ws.samples, ws.shears.cview(), ws.sheared.view(), ws, g, settings, exec);
    }
    report.filter_ms = detail::ms_since(t0);

    // The sheared result on its centres, aaf's elsewhere, into fw.filtered; then render_frame's outputs.
    exec.parallel_for(h, [&](std::size_t y0, std::size_t y1) {
        for (std::size_t y = y0; y < y1; ++y)
            for (std::size_t x = 0; x < w; ++x)
                if (ws.shears(x, y).center && std::isfinite(ws.sheared(x, y))) fw.filtered(x, y) = ws.sheared(x, y);
    });
    detail::write_frame_outputs<T, Ids>(gb, light, fw.stats.cview(), fw.filtered.cview(), out, settings.frame.radiance,
                                        detail::executor_ref(exec), report);
    report.total_ms = detail::ms_since(t_frame);
    return report;
}

}  // namespace v0
}  // namespace aaf
