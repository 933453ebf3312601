// SPDX-License-Identifier: MIT
#pragma once
// Gathering occlusion statistics: sampler → shadow segments → the user's tracer → occlusion_stats.

#include <algorithm>
#include <bit>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <string>
#include <type_traits>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "area_light.hpp"
#include "config.hpp"
#include "executor.hpp"
#include "guides.hpp"
#include "image_view.hpp"
#include "occlusion_stats.hpp"
#include "ray_offset.hpp"
#include "region.hpp"
#include "sampler.hpp"
#include "settings.hpp"
#include "simd.hpp"
#include "tracer.hpp"

namespace aaf {
inline namespace v0 {

/// The user's G-buffer, read in place. `Ids` is `const_image_view<std::uint32_t>` or `no_guide` (a scene
/// without object IDs pays nothing for them).
/// * `positions`: world-space receiver points; a non-finite position means "no surface" (sky).
/// * `normals`: unit surface normals. Used for the horizon test, for offsetting shadow-ray origins
///   (towards the light's side) and as a filter guide. Geometric normals avoid self-shadowing on
///   smooth-shaded low-poly meshes; shading normals also work.
/// * `pixel_size`: projected pixel size d in world units (formulas.hpp: pinhole_pixel_size).
/// * `region`: where these buffers sit in the full frame (region.hpp). Sample keys use frame coordinates,
///   so a tile's buffers (with the halo of region_halo) render the tile's pixels exactly as the full frame.
template <class T = float, class Ids = no_guide>
struct gbuffer {
    const_image_view<glm::vec<3, T>> positions;
    const_image_view<glm::vec<3, T>> normals;
    const_image_view<T> pixel_size;
    Ids ids{};
    frame_region region{};

    static constexpr bool has_ids = !std::is_same_v<Ids, no_guide>;
    [[nodiscard]] std::size_t width() const noexcept { return positions.width(); }
    [[nodiscard]] std::size_t height() const noexcept { return positions.height(); }
};

namespace detail {

/// The region's frame size is both dimensions or neither, and `w` × `h` buffers placed at its origin lie
/// inside the frame (and inside the 2^32 × 2^32 key space when the frame's size is unknown).
inline void require_region(const char* fn, const char* arg, const frame_region& r, std::size_t w, std::size_t h) {
    const auto fits = [](std::uint64_t origin, std::size_t extent, std::uint64_t limit) {
        return static_cast<std::uint64_t>(extent) <= limit && origin <= limit - extent;
    };
    const auto where = [&] {
        return std::to_string(w) + "x" + std::to_string(h) + " buffers at (" + std::to_string(r.origin_x) + ", " +
               std::to_string(r.origin_y) + ")";
    };
    if ((r.frame_width == 0) != (r.frame_height == 0))
        throw_invalid(fn, std::string("`") + arg + "` gives one frame dimension but not the other (" +
                              std::to_string(r.frame_width) + "x" + std::to_string(r.frame_height) + "); give both or neither");
    if (r.knows_frame()) {
        if (!fits(r.origin_x, w, r.frame_width) || !fits(r.origin_y, h, r.frame_height))
            throw_invalid(fn, std::string("`") + arg + "` places " + where() + ", outside the " + std::to_string(r.frame_width) +
                                  "x" + std::to_string(r.frame_height) + " frame");
    } else if (!fits(r.origin_x, w, std::uint64_t{1} << 32) || !fits(r.origin_y, h, std::uint64_t{1} << 32)) {
        throw_invalid(fn, std::string("`") + arg + "` places " + where() + ", beyond 2^32 pixels");
    }
}

template <class T, class Ids>
void require_gbuffer(const char* fn, const gbuffer<T, Ids>& gb) {
    require_nonempty(fn, "gbuffer.positions", gb.positions);
    const std::size_t w = gb.width(), h = gb.height();
    require_size(fn, "gbuffer.normals", gb.normals, w, h);
    require_size(fn, "gbuffer.pixel_size", gb.pixel_size, w, h);
    if constexpr (gbuffer<T, Ids>::has_ids) require_size(fn, "gbuffer.ids", gb.ids, w, h);
    require_region(fn, "gbuffer.region", gb.region, w, h);
}

template <class T>
void require_light(const char* fn, const area_light<T>& light) {
    const T a = light.area();
    const bool finite = std::isfinite(light.corner.x + light.corner.y + light.corner.z) &&
                        std::isfinite(light.edge_u.x + light.edge_u.y + light.edge_u.z) &&
                        std::isfinite(light.edge_v.x + light.edge_v.y + light.edge_v.z);
    if (!finite) throw_invalid(fn, "`light` has non-finite corner or edges");
    if (!(a > T(0))) throw_invalid(fn, "`light` has zero area (its edges are parallel or zero)");
}

/// The normal a receiver is shaded with. A zero normal (dot(n, n) == 0, which includes normals whose
/// square underflows) is an orientation-less receiver — hair, particles, a volume's sample point — and
/// faces the light's centre: every light point within 90° of that direction counts. (Without this, no
/// sample would be above its horizon and the pixel would silently get no light.)
/// Always inlined (`inline` too: GCC wants it with the attribute): draw_next calls it per pixel of a group,
/// and as a call it measured ~1 ns per sample.
template <class T>
[[nodiscard, gnu::always_inline]] inline glm::vec<3, T> receiver_normal(const glm::vec<3, T>& n, const glm::vec<3, T>& p,
                                                                         const glm::vec<3, T>& light_center) noexcept {
    if (glm::dot(n, n) != T(0)) return n;
    const glm::vec<3, T> to = light_center - p;
    const T len = glm::length(to);
    return len > T(0) && std::isfinite(len) ? to * (T(1) / len) : n;
}

/// Reusable per-thread buffers for the samples of the pixels of one batch (one pixel at a time unless the
/// tracer has a batched form of the query, tracer.hpp).
template <class T>
struct pixel_batch {
    struct pending {
        occlusion_stats<T>* stats;
        T d1;
        std::size_t end;        // one past the pixel's last segment
        std::uint32_t skipped;  // samples drawn and counted but not traced (no weight)
    };
    std::vector<shadow_segment<T>> segments;
    std::vector<T> weights;
    std::vector<occluder_span<T>> hits;
    std::vector<visibility_hit> visible;  // visibility-only passes
    std::vector<pending> pixels;
    // The pass's sample pattern for the current count (the same for every pixel of an initial pass).
    sample_plan<T> plan;
    // One pixel's samples (u, v), then its per-sample directions, lengths and weights before the untraceable
    // ones are dropped, one array per component padded to whole vectors (plan.padded()), so that
    // draw_pixel's arithmetic runs in vector lanes with no remainder loop.
    std::vector<T> u, v, dir_x, dir_y, dir_z, lengths, sample_weights;
    std::vector<std::uint32_t> keep;  // 1 where the sample can be traced
    trace_scratch<T> trace;
    std::size_t size = 0;                 // segments pending

    void reserve(std::size_t n) {
        if (segments.size() >= n) return;  // grows a few times per thread, then reused
        segments.resize(n), weights.resize(n), hits.resize(n), visible.resize(n);
    }
    void reserve_samples(std::size_t padded) {  // values per array: a pixel's padded count, or a group's count × lanes
        if (lengths.size() >= padded) return;
        for (auto* a : {&u, &v, &dir_x, &dir_y, &dir_z, &lengths, &sample_weights}) a->resize(padded);
        keep.resize(padded);
    }
};

/// draw_pixel's per-sample arithmetic for the uniform weighting, in vector lanes (`padded` is a whole
/// number of vectors): light point y, weight (light_sample_frame::weight's tests as 0/1 products: the loop
/// body must be one block), the unnormalised segment y − origin and its squared length. Values, not
/// references, and restrict-qualified arrays, so that nothing the loop reads can alias what it writes.
/// uniform_sample is one sample's, the one expression of uniform_samples and uniform_samples_group.
template <class T, bool TwoSided>
void uniform_sample(T su, T sv, const area_light<T>& light, glm::vec<3, T> p, glm::vec<3, T> n, glm::vec<3, T> light_normal,
                    glm::vec<3, T> origin, T& to_x, T& to_y, T& to_z, T& length2, T& weight) noexcept {
    const glm::vec<3, T> y = light.point(su, sv);
    const glm::vec<3, T> to_light = y - p;
    const T cos_r = glm::dot(n, to_light);
    const T cos_l = -glm::dot(light_normal, to_light);
    const T faces = TwoSided ? static_cast<T>(!(cos_l == T(0))) : static_cast<T>(cos_l > T(0));
    weight = static_cast<T>(cos_r > T(0)) * faces;  // 1 where both hold, else 0
    const glm::vec<3, T> to = y - origin;
    to_x = to.x, to_y = to.y, to_z = to.z, length2 = glm::dot(to, to);
}

template <class T, bool TwoSided>
void uniform_samples(const T* __restrict su, const T* __restrict sv, std::uint32_t padded, area_light<T> light,
                     glm::vec<3, T> p, glm::vec<3, T> n, glm::vec<3, T> light_normal, glm::vec<3, T> origin,
                     T* __restrict to_x, T* __restrict to_y, T* __restrict to_z, T* __restrict length2,
                     T* __restrict weight) noexcept {
    for (std::uint32_t i = 0; i < padded; ++i)
        uniform_sample<T, TwoSided>(su[i], sv[i], light, p, n, light_normal, origin, to_x[i], to_y[i], to_z[i], length2[i], weight[i]);
}

/// uniform_samples for a group of L pixels, one per lane: sample i of pixel k at index i·L + k; `lanes` holds
/// the pixels' receivers, normals and origins by component (lanes[c·L + k] for c = p.x, p.y, p.z, n.x, ...,
/// origin.z), in one plain array so that the compiler sees every lane's loads as whole vectors. Not inlined:
/// inlined into gather_rows, GCC 12 no longer vectorised the loop (it could not type the loads from
/// `lanes`), and the call is made once per group.
template <class T, bool TwoSided, std::uint32_t L>
[[gnu::noinline]] void uniform_samples_group(const T* __restrict su, const T* __restrict sv, std::uint32_t count, area_light<T> light,
                           const T* __restrict lanes, glm::vec<3, T> light_normal, T* __restrict to_x, T* __restrict to_y,
                           T* __restrict to_z, T* __restrict length2, T* __restrict weight) noexcept {
    for (std::size_t j = 0; j < std::size_t{count} * L; j += L)  // j: the index of the group's sample i, lane 0
        for (std::size_t k = 0; k < L; ++k) {
            const T* c = lanes + k;
            uniform_sample<T, TwoSided>(su[j + k], sv[j + k], light, {c[0], c[L], c[2 * L]}, {c[3 * L], c[4 * L], c[5 * L]},
                                        light_normal, {c[6 * L], c[7 * L], c[8 * L]}, to_x[j + k], to_y[j + k], to_z[j + k],
                                        length2[j + k], weight[j + k]);
        }
}

/// draw_pixel's directions: (dx, dy, dz) divided by their length, and keep[i] = 1 where the sample can be
/// traced (weight and length finite and positive), else 0. In vector lanes (restrict-qualified arrays).
template <class T>
void normalize_samples(T* __restrict dx, T* __restrict dy, T* __restrict dz, const T* __restrict len, const T* __restrict wgt,
                       std::uint32_t* __restrict keep, std::uint32_t padded) noexcept {
    for (std::uint32_t i = 0; i < padded; ++i) {
        const T inv = T(1) / len[i];  // one division, not three
        dx[i] *= inv, dy[i] *= inv, dz[i] *= inv;
        // As 0/1 values, with no branch: x <= max is false for NaN and ±inf.
        keep[i] = static_cast<std::uint32_t>(wgt[i] > T(0)) & static_cast<std::uint32_t>(wgt[i] <= std::numeric_limits<T>::max()) &
                  static_cast<std::uint32_t>(len[i] > T(0)) & static_cast<std::uint32_t>(len[i] <= std::numeric_limits<T>::max());
    }
}

/// A pixel's samples as draw_pixel (or draw_pixel_group) leaves them in its batch's per-sample arrays:
/// sample i at index first + i·stride.
template <class T>
struct drawn_pixel {
    glm::vec<3, T> origin;     ///< where every segment starts (the receiver, offset)
    T d1;                      ///< the receiver's distance to the light's plane, from `origin`
    std::uint32_t count;       ///< samples drawn
    std::uint32_t first = 0;   ///< index of sample 0 (the pixel's lane in a group)
    std::uint32_t stride = 1;  ///< 1 for one pixel, the group's lanes for a group

    [[nodiscard]] std::size_t at(std::uint32_t i) const noexcept { return first + static_cast<std::size_t>(i) * stride; }
};

/// A receiver's shadow-ray origin, offset to the light's side of the surface (Wächter–Binder: no epsilon
/// to tune), and d1 from that same point, so that d2 = d1·(L − t)/L is exact (t, L are from the origin).
template <class T>
[[nodiscard]] std::pair<glm::vec<3, T>, T> pixel_origin(const glm::vec<3, T>& p, const glm::vec<3, T>& n, const area_light<T>& light,
                                                        const light_sample_frame<T>& frame, double origin_offset) noexcept {
    const glm::vec<3, T> origin = shadow_ray_origin(p, n, frame.center, origin_offset);
    return {origin, std::abs(glm::dot(origin - light.corner, frame.normal))};
}

/// Draws the samples of `batch.plan` (prepared for this pixel's count and the pass's pattern) for the pixel
/// whose sample key hashes to `seed` (key_hash of its pixel_key): per sample i < count, the unit direction
/// (batch.dir_x/y/z), length (batch.lengths) and weight (batch.sample_weights) of its segment, and
/// batch.keep[i] = 1 where it can be traced. Every sample is computed (branch-free for the uniform weighting,
/// so the loops run in vector lanes) before any is dropped: the same values, per sample, as
/// generate_samples and testing each sample in turn.
template <class T>
drawn_pixel<T> draw_pixel(const glm::vec<3, T>& p, const glm::vec<3, T>& n, const area_light<T>& light,
                          const light_sample_frame<T>& frame, double origin_offset, std::uint32_t seed, pixel_batch<T>& batch) {
    const std::uint32_t count = batch.plan.size(), padded = batch.plan.padded();
    batch.reserve_samples(padded);
    const auto [su, sv] = batch.plan.generate(seed, batch.u.data(), batch.v.data());
    const auto [origin, d1] = pixel_origin(p, n, light, frame, origin_offset);
    T* const dx = batch.dir_x.data();
    T* const dy = batch.dir_y.data();
    T* const dz = batch.dir_z.data();
    T* const len = batch.lengths.data();
    T* const wgt = batch.sample_weights.data();
    // Light point, weight and the unnormalised segment `to` (kept in dx, dy, dz) with its squared length.
    if (frame.weighting == light_weighting::uniform) {
        if (frame.two_sided) uniform_samples<T, true>(su, sv, padded, light, p, n, frame.normal, origin, dx, dy, dz, len, wgt);
        else uniform_samples<T, false>(su, sv, padded, light, p, n, frame.normal, origin, dx, dy, dz, len, wgt);
    } else {
        for (std::uint32_t i = 0; i < padded; ++i) {  // the padding lanes too: sqrt_each reads them
            const glm::vec<3, T> y = light.point(su[i], sv[i]);
            wgt[i] = frame.weight(n, y - p, y);
            const glm::vec<3, T> to = y - origin;
            dx[i] = to.x, dy[i] = to.y, dz[i] = to.z, len[i] = glm::dot(to, to);
        }
    }
    sqrt_each(len, padded);  // glm::length(to), in lanes
    normalize_samples(dx, dy, dz, len, wgt, batch.keep.data(), padded);
    return {origin, d1, count};
}

/// Pixels per group of draw_pixel_group: one per vector lane (1 without explicit vectors: no groups).
template <class T>
inline constexpr std::uint32_t group_pixels = sample_lanes<T>;

/// draw_pixel for the group_pixels<T> pixels of row y from column x on, one per vector lane, for the uniform
/// weighting, with key hashes seeds[k]; out[k] says where pixel k's samples are. Returns a bit per pixel
/// with a surface (finite position and normal); the others are drawn as stand-ins and must not be traced.
/// Every lane's arithmetic is draw_pixel's, so each pixel gets draw_pixel's bits; what changes is that no
/// lane is padding (9 samples fill 9 vectors per 8 pixels, not 16) and the per-pixel steps run in lanes.
template <class T>
std::uint32_t draw_pixel_group(const_image_view<glm::vec<3, T>> positions, const_image_view<glm::vec<3, T>> normals, std::size_t x,
                               std::size_t y, const area_light<T>& light, const light_sample_frame<T>& frame, double origin_offset,
                               const std::uint32_t* seeds, pixel_batch<T>& batch, drawn_pixel<T>* out) {
    constexpr std::uint32_t L = group_pixels<T>;
    static_assert(L <= 32, "one bit per pixel of the group");
    const std::uint32_t count = batch.plan.size(), values = count * L;
    batch.reserve_samples(values);
    T lanes[9 * L];  // receivers, normals and origins by component (uniform_samples_group)
    std::uint32_t surfaces = 0;
    for (std::uint32_t k = 0; k < L; ++k) {
        glm::vec<3, T> p = positions(x + k, y), n = normals(x + k, y);
        if (std::isfinite(p.x + p.y + p.z) && std::isfinite(n.x + n.y + n.z)) {
            surfaces |= 1U << k;
            n = receiver_normal(n, p, frame.center);
        } else {
            p = frame.center + frame.normal, n = frame.normal;  // a stand-in: finite, off the light
        }
        for (std::uint32_t c = 0; c < 3; ++c) lanes[c * L + k] = p[c], lanes[(3 + c) * L + k] = n[c];
    }
    shadow_ray_origins<T, L>(lanes, lanes + 3 * L, frame.center, origin_offset, lanes + 6 * L);  // pixel_origin's, in lanes
    for (std::uint32_t k = 0; k < L; ++k) {
        const glm::vec<3, T> origin(lanes[6 * L + k], lanes[7 * L + k], lanes[8 * L + k]);
        out[k] = {origin, std::abs(glm::dot(origin - light.corner, frame.normal)), count, k, L};
    }
    T* const u = batch.u.data();
    T* const v = batch.v.data();
    batch.plan.generate_group(seeds, u, v);
    T* const dx = batch.dir_x.data();
    T* const dy = batch.dir_y.data();
    T* const dz = batch.dir_z.data();
    T* const len = batch.lengths.data();
    T* const wgt = batch.sample_weights.data();
    if (frame.two_sided) uniform_samples_group<T, true, L>(u, v, count, light, lanes, frame.normal, dx, dy, dz, len, wgt);
    else uniform_samples_group<T, false, L>(u, v, count, light, lanes, frame.normal, dx, dy, dz, len, wgt);
    sqrt_each(len, values);  // a whole number of vectors
    normalize_samples(dx, dy, dz, len, wgt, batch.keep.data(), values);
    return surfaces;
}

/// Appends the traceable segments of the pixel draw_pixel left in `batch` to the batch's pending segments
/// (traced by flush_batch).
template <class T>
void append_pixel(const drawn_pixel<T>& d, occlusion_stats<T>& stats, pixel_batch<T>& batch) {
    batch.reserve(batch.size + d.count);
    const T *dx = batch.dir_x.data(), *dy = batch.dir_y.data(), *dz = batch.dir_z.data();
    const T *len = batch.lengths.data(), *wgt = batch.sample_weights.data();
    const std::uint32_t* keep = batch.keep.data();
    // Every sample is written at the next free place and only the traceable ones advance it (room for all
    // of them was reserved), so the loop has no branch to mispredict.
    std::size_t traced = batch.size;
    shadow_segment<T>* const segments = batch.segments.data();
    T* const weights = batch.weights.data();
    for (std::uint32_t i = 0; i < d.count; ++i) {
        const std::size_t j = d.at(i);
        segments[traced] = {d.origin, {dx[j], dy[j], dz[j]}, len[j]};
        weights[traced] = wgt[j];
        traced += keep[j];
    }
    const std::uint32_t skipped = d.count - static_cast<std::uint32_t>(traced - batch.size);
    batch.pixels.push_back({&stats, d.d1, traced, skipped});
    batch.size = traced;
}

/// Adds one traced visibility query to a pixel's statistics: a failed query is counted and dropped (as
/// add_sample drops NaN hits), any other adds its visibility. The one rule for flush_batch and trace_pixel.
template <class T>
void record_visibility(occlusion_stats<T>& stats, T weight, visibility_hit visible) noexcept {
    if (visible == visibility_hit::failed) ++stats.samples;
    else stats.add_visibility_sample(weight, visible == visibility_hit::blocked);
}

/// Traces the batch's segments in one query (the tracer's batched form, or one call per segment) and adds
/// each pixel's samples to its statistics, in the pixel's sample order: the same numbers whatever the
/// batch holds. Returns the number of rays traced.
template <shadow_query Query, class T, class Tracer>
std::uint64_t flush_batch(const Tracer& tracer, pixel_batch<T>& batch) {
    const std::size_t n = batch.size;
    std::fill_n(batch.hits.begin(), n, occluder_span<T>{});
    const std::span<const shadow_segment<T>> segments(batch.segments.data(), n);
    const std::span<occluder_span<T>> hits(batch.hits.data(), n);
    if (n != 0) {
        if constexpr (Query == shadow_query::visibility)
            trace_visibility<T>(tracer, segments, hits, std::span<visibility_hit>(batch.visible.data(), n), &batch.trace);
        else
            trace_all<T>(tracer, segments, hits, &batch.trace);
    }
    std::size_t i = 0;
    for (const auto& px : batch.pixels) {
        occlusion_stats<T> stats = *px.stats;  // in registers (trace_pixel)
        // Statistics do not depend on sample order, so traced samples are added first, skipped ones after.
        for (; i < px.end; ++i) {
            if constexpr (Query == shadow_query::visibility)
                record_visibility(stats, batch.weights[i], batch.visible[i]);
            else
                stats.add_sample(batch.weights[i], px.d1, batch.segments[i].length, batch.hits[i]);
        }
        stats.samples += px.skipped;
        *px.stats = stats;
    }
    batch.pixels.clear();
    batch.size = 0;
    return n;
}

/// For a tracer without a batched form of the query: traces the traceable samples of the pixel draw_pixel
/// left in `batch` one at a time, each added to the pixel's statistics as it returns, with no array of
/// segments or hits in between. The same calls in the same order, and the same statistics, as appending
/// the pixel and flushing the batch. Returns the number of rays traced.
template <shadow_query Query, class T, class Tracer>
std::uint64_t trace_pixel(const Tracer& tracer, const drawn_pixel<T>& d, occlusion_stats<T>& out, pixel_batch<T>& batch) {
    static_assert(!uses_batches<Tracer, T>(Query == shadow_query::visibility), "batched tracers go through flush_batch");
    const T *dx = batch.dir_x.data(), *dy = batch.dir_y.data(), *dz = batch.dir_z.data();
    const T *len = batch.lengths.data(), *wgt = batch.sample_weights.data();
    const std::uint32_t* keep = batch.keep.data();
    // A local copy, written back once: through the reference, every sample's sums would go through memory
    // (the compiler cannot tell the weights' array from the record), a store-to-load chain per sample.
    occlusion_stats<T> stats = out;
    std::uint32_t traced = 0;
    for (std::uint32_t i = 0; i < d.count; ++i) {
        const std::size_t j = d.at(i);
        if (keep[j] == 0) continue;
        ++traced;
        const shadow_segment<T> segment{d.origin, {dx[j], dy[j], dz[j]}, len[j]};
        if constexpr (Query == shadow_query::visibility) {
            occluder_span<T> hit{};
            visibility_hit visible = visibility_hit::visible;
            trace_visibility<T>(tracer, std::span<const shadow_segment<T>>(&segment, 1), std::span<occluder_span<T>>(&hit, 1),
                                std::span<visibility_hit>(&visible, 1), &batch.trace);
            record_visibility(stats, wgt[j], visible);
        } else {
            stats.add_sample(wgt[j], d.d1, len[j], trace_one<T>(tracer, segment));
        }
    }
    stats.samples += d.count - traced;  // the skipped ones, counted after the traced ones as in flush_batch
    out = stats;
    return traced;
}

/// key_hash(pixel_key(region, x0 + k, y, pass, light, frame_seed)) for k < m, in vector lanes: the seeds of a
/// run of pixels of one row (pixel_key's frame column wraps as x0 + k does).
inline void pixel_key_hashes(const frame_region& region, std::size_t x0, std::size_t y, std::uint32_t m, std::uint32_t pass,
                             std::uint32_t light, std::uint32_t frame_seed, std::uint32_t* __restrict out) noexcept {
    const sample_key first = pixel_key(region, x0, y, pass, light, frame_seed);
    for (std::uint32_t k = 0; k < m; ++k) out[k] = key_hash({first.x + k, first.y, first.pass, first.light, first.frame_seed});
}

}  // namespace detail

namespace detail {

/// A gathering pass's checks of its inputs (independent of the tracer: compiled once per G-buffer type).
template <class T, class Ids>
void require_gather_inputs(const char* fn, const gbuffer<T, Ids>& gb, const area_light<T>& light, const sampling_settings& s,
                           std::uint32_t samples_per_pixel, image_view<occlusion_stats<T>> stats,
                           const_image_view<std::uint32_t> sample_counts) {
    require_gbuffer(fn, gb);
    require_light(fn, light);
    validate(s, fn);
    const std::size_t w = gb.width(), h = gb.height();
    require_size(fn, "stats", stats, w, h);
    require_size_or_empty(fn, "sample_counts", sample_counts, w, h);
    if (samples_per_pixel > s.max_samples && sample_counts.empty())
        throw_invalid(fn, "`samples_per_pixel` exceeds settings.max_samples");
}

/// What drawing a pass's pixels needs besides the batch, none of it dependent on the tracer.
template <class T>
struct pass_pixels {
    const_image_view<glm::vec<3, T>> positions, normals;
    const_image_view<std::uint32_t> sample_counts;  ///< empty: samples_per_pixel for every pixel
    const area_light<T>* light;
    const light_sample_frame<T>* frame;
    const sampling_settings* settings;
    std::uint32_t samples_per_pixel;
    /// Non-zero: every pixel draws this many samples with the uniform weighting, so whole groups of
    /// group_pixels<T> pixels are drawn at once (draw_pixel_group: the same bits, no padding lanes); 0: one
    /// pixel at a time. Up to counts where a pixel's padding lanes cost little.
    std::uint32_t group_count;
};

template <class T>
[[nodiscard]] pass_pixels<T> make_pass_pixels(const_image_view<glm::vec<3, T>> positions, const_image_view<glm::vec<3, T>> normals,
                                              const_image_view<std::uint32_t> sample_counts, const area_light<T>& light,
                                              const light_sample_frame<T>& frame, const sampling_settings& s,
                                              std::uint32_t samples_per_pixel) noexcept {
    const std::uint32_t count = std::min(samples_per_pixel, s.max_samples);
    const bool grouped = group_pixels<T> > 1 && sample_counts.empty() && s.weighting == light_weighting::uniform && count <= 256;
    return {positions, normals, sample_counts, &light, &frame, &s, samples_per_pixel, grouped ? count : 0U};
}

/// Draws the next pixels of row y from column x0 + k (k < m; seeds[k] is that pixel's key hash): a whole group
/// when the pass draws groups and one fits before m, else one pixel. Advances k past them; d[i] says where
/// the samples of the i-th of them are, and bit i of the result is set when it is to be traced (it has a
/// surface and samples).
template <class T>
std::uint32_t draw_next(const pass_pixels<T>& r, std::size_t x0, std::size_t y, std::uint32_t m, const std::uint32_t* seeds,
                        std::uint32_t& k, pixel_batch<T>& batch, drawn_pixel<T>* d) {
    constexpr std::uint32_t G = group_pixels<T>;
    const sampling_settings& s = *r.settings;
    if (r.group_count != 0 && k + G <= m) {
        batch.plan.prepare(s.pattern, r.group_count);
        const std::uint32_t first = k;
        k += G;
        return draw_pixel_group(r.positions, r.normals, x0 + first, y, *r.light, *r.frame, s.origin_offset, seeds + first, batch, d);
    }
    const std::uint32_t column = k++;
    const std::size_t x = x0 + column;
    const std::uint32_t count = r.sample_counts.empty() ? r.samples_per_pixel : r.sample_counts(x, y);
    if (count == 0) return 0;
    const glm::vec<3, T> p = r.positions(x, y);
    const glm::vec<3, T> n = r.normals(x, y);
    if (!std::isfinite(p.x + p.y + p.z) || !std::isfinite(n.x + n.y + n.z)) return 0;
    batch.plan.prepare(s.pattern, std::min(count, s.max_samples));
    d[0] = draw_pixel(p, receiver_normal(n, p, r.frame->center), *r.light, *r.frame, s.origin_offset, seeds[column], batch);
    return 1;
}

/// The one part of a frame compiled per tracer type: the rows' samples traced by `tracer`. Everything
/// that does not call the tracer (checks, sample generation and segments: draw_next, append_pixel) is compiled per
/// pixel type only, and the executor is taken by reference (executor_ref).
template <shadow_query Query, class T, class Ids, class Tracer>
std::uint64_t gather_rows(const char* fn, const gbuffer<T, Ids>& gb, const area_light<T>& light, const Tracer& tracer,
                          const sampling_settings& s, std::uint32_t pass, std::uint32_t samples_per_pixel,
                          image_view<occlusion_stats<T>> stats, const_image_view<std::uint32_t> sample_counts,
                          executor_ref exec) {
    require_gather_inputs(fn, gb, light, s, samples_per_pixel, stats, sample_counts);
    const std::size_t w = gb.width(), h = gb.height();
    std::atomic<std::uint64_t> rays{0};
    const light_sample_frame<T> frame(light, s.weighting);
    // A tracer with a batched form of this query gets whole pixels' segments, several pixels (of a row or
    // of the task's consecutive rows) per call, at least batch_rays of them when the task has that many.
    // Any other tracer gets one call per segment as each pixel's samples are drawn (trace_pixel).
    constexpr bool batched = uses_batches<Tracer, T>(Query == shadow_query::visibility);
    [[maybe_unused]] const std::size_t batch_target = s.batch_rays;
    constexpr std::uint32_t G = group_pixels<T>;
    const pass_pixels<T> rows = make_pass_pixels(gb.positions, gb.normals, sample_counts, light, frame, s, samples_per_pixel);
    exec.parallel_for(h, [&](std::size_t y0, std::size_t y1) {
        pixel_batch<T> batch;
        std::uint64_t local = 0;
        constexpr std::uint32_t run = 64;  // pixels whose key hashes are computed together
        std::uint32_t seeds[run];
        for (std::size_t y = y0; y < y1; ++y) {
            for (std::size_t x0 = 0; x0 < w; x0 += run) {
                const auto m = static_cast<std::uint32_t>(std::min<std::size_t>(run, w - x0));
                pixel_key_hashes(gb.region, x0, y, m, pass, s.light_index, s.frame_seed, seeds);
                for (std::uint32_t k = 0; k < m;) {
                    drawn_pixel<T> d[G];
                    const std::size_t x = x0 + k;
                    for (std::uint32_t todo = draw_next(rows, x0, y, m, seeds, k, batch, d); todo != 0; todo &= todo - 1) {
                        const auto i = static_cast<std::uint32_t>(std::countr_zero(todo));
                        occlusion_stats<T>& out = stats(x + i, y);
                        if constexpr (!batched) {
                            local += trace_pixel<Query>(tracer, d[i], out, batch);
                        } else {
                            append_pixel(d[i], out, batch);
                            if (batch.size >= batch_target) local += flush_batch<Query>(tracer, batch);
                        }
                    }
                }
            }
        }
        if constexpr (batched)
            if (!batch.pixels.empty()) local += flush_batch<Query>(tracer, batch);
        rays += local;
    });
    return rays.load();
}

}  // namespace detail

/// Adds `samples_per_pixel` light samples of pass `pass` to every pixel with a surface, accumulating into
/// `stats` (which the caller initialises, e.g. to `occlusion_stats<T>{}`). When `sample_counts` is
/// non-empty it gives each pixel's count instead (0 = skip the pixel). Rows run on `exec`; the tracer is
/// called concurrently (see tracer.hpp). Returns the number of shadow rays traced.
template <class T, class Ids, class Tracer, class Exec = sequential_executor>
std::uint64_t gather_occlusion(const gbuffer<T, Ids>& gb, const area_light<T>& light, const Tracer& tracer,
                               const sampling_settings& s, std::uint32_t pass, std::uint32_t samples_per_pixel,
                               image_view<occlusion_stats<T>> stats, const_image_view<std::uint32_t> sample_counts = {},
                               Exec&& exec = {}) {
    static_assert(check_tracer<Tracer, T>());  // a message naming the member and the reason (tracer.hpp)
    if constexpr (occlusion_tracer<Tracer, T>)
        return detail::gather_rows<shadow_query::distances>("gather_occlusion", gb, light, tracer, s, pass, samples_per_pixel,
                                                             stats, sample_counts, detail::executor_ref(exec));
    else
        return 0;
}

/// As gather_occlusion, but each sample asks only "occluded or not" (the tracer's `occluded` when it has
/// one, else its distance query with the distances ignored) and is recorded with
/// occlusion_stats::add_visibility_sample: visibility and sample counts change, d1/d2min/d2max do not.
/// Same samples as gather_occlusion for the same key and pass, so the two agree on visibility.
template <class T, class Ids, class Tracer, class Exec = sequential_executor>
std::uint64_t gather_visibility(const gbuffer<T, Ids>& gb, const area_light<T>& light, const Tracer& tracer,
                                const sampling_settings& s, std::uint32_t pass, std::uint32_t samples_per_pixel,
                                image_view<occlusion_stats<T>> stats, const_image_view<std::uint32_t> sample_counts = {},
                                Exec&& exec = {}) {
    static_assert(check_tracer<Tracer, T>());  // a message naming the member and the reason (tracer.hpp)
    if constexpr (occlusion_tracer<Tracer, T>)
        return detail::gather_rows<shadow_query::visibility>("gather_visibility", gb, light, tracer, s, pass, samples_per_pixel,
                                                             stats, sample_counts, detail::executor_ref(exec));
    else
        return 0;
}

// The compiled mode's instantiations (config.hpp: AAF_EXTERN_TEMPLATES): what a gathering pass does
// besides calling the tracer.
#define AAF_DETAIL_GATHER_INSTANTIATIONS(KEYWORD, T)                                                            \
    AAF_DETAIL_INSTANTIATE(KEYWORD, detail::draw_pixel<T>)                                                      \
    AAF_DETAIL_INSTANTIATE(KEYWORD, detail::draw_pixel_group<T>)                                                \
    AAF_DETAIL_INSTANTIATE(KEYWORD, detail::draw_next<T>)                                                       \
    AAF_DETAIL_INSTANTIATE(KEYWORD, detail::make_pass_pixels<T>)                                                \
    AAF_DETAIL_INSTANTIATE(KEYWORD, detail::append_pixel<T>)                                                    \
    AAF_DETAIL_INSTANTIATE(KEYWORD, detail::require_gather_inputs<T, no_guide>)                                 \
    AAF_DETAIL_INSTANTIATE(KEYWORD, detail::require_gather_inputs<T, const_image_view<std::uint32_t>>)
#ifdef AAF_EXTERN_TEMPLATES
AAF_DETAIL_GATHER_INSTANTIATIONS(extern, float)
AAF_DETAIL_GATHER_INSTANTIATIONS(extern, double)
#endif

}  // namespace v0
}  // namespace aaf
