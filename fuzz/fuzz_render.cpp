// SPDX-License-Identifier: MIT
// libFuzzer harness: gather_occlusion and render_frame on a tiny G-buffer (up to 8x8) with a fuzz-driven
// tracer, in float and double.
//
// The G-buffer starts as a floor under a square light (the README's scene) and every position, normal and
// pixel size can be replaced by anything (NaN, ±Inf, denormals, huge); the light, the settings and the
// outputs' presence are fuzzed too. The tracer answers from the scene's one square occluder, except that
// a fuzzed table of answers overrides some of its calls: arbitrary distances (NaN, negative, zero, at and
// beyond the segment's length, huge), through each tracer shape (span, nearest, batch). A fuzzed progress
// callback may cancel the frame. Settings, light and buffers are validated by the library first; an
// aaf::invalid_argument is not a finding.
//
// Invariants (any violation aborts):
// * gather_occlusion: per pixel, samples == the count asked for (0 without a surface), occluded <= samples,
//   visible_weight <= total_weight, visibility() in [0, 1] when there is light and the weight sum is finite;
// * render_frame: every visibility pixel finite and in [0, 1]; adaptive samples within max - initial; the
//   ray counts add up; a cancelled frame writes no output pixel.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <span>
#include <vector>

#include <aaf/gather.hpp>
#include <aaf/image.hpp>
#include <aaf/pipeline.hpp>

#include "fuzz_input.hpp"

namespace {

template <class T>
struct answer {
    aaf::occluder_span<T> span{};
    bool relative = false;  // distances are fractions of the segment's length
};

/// The scene's square occluder, with a table of fuzzed answers replacing every `period`-th call.
template <class T>
struct fuzz_oracle {
    T x0 = T(-0.5), x1 = T(0.5), z0 = T(-0.5), z1 = T(0.5), y = T(1);
    std::vector<answer<T>> table;
    std::uint32_t period = 1, phase = 0;
    mutable std::uint64_t calls = 0;  // sequential executor only

    aaf::occluder_span<T> operator()(const aaf::shadow_segment<T>& s) const {
        const std::uint64_t i = calls++;
        if (!table.empty() && i % period == phase % period) {
            const answer<T>& a = table[(i / period) % table.size()];
            if (!a.relative) return a.span;
            return {a.span.nearest * s.length, a.span.farthest * s.length};
        }
        if (s.direction.y == T(0)) return {};
        const T t = (y - s.origin.y) / s.direction.y;
        const T hx = s.origin.x + t * s.direction.x, hz = s.origin.z + t * s.direction.z;
        if (!(t > T(0) && t < s.length) || hx < x0 || hx > x1 || hz < z0 || hz > z1) return {};
        return {t, t};
    }
};

template <class T>
struct span_shape {
    const fuzz_oracle<T>* o;
    aaf::occluder_span<T> occluder_span(const aaf::shadow_segment<T>& s) const { return (*o)(s); }
};
template <class T>
struct nearest_shape {
    const fuzz_oracle<T>* o;
    T nearest_occluder(const aaf::shadow_segment<T>& s) const {
        const aaf::occluder_span<T> h = (*o)(s);
        return std::isnan(h.nearest) || h.hit() ? h.nearest : aaf::no_occluder<T>;
    }
};
template <class T>
struct batch_shape {
    const fuzz_oracle<T>* o;
    void trace_batch(std::span<const aaf::shadow_segment<T>> in, std::span<aaf::occluder_span<T>> out) const {
        for (std::size_t i = 0; i < in.size(); ++i) out[i] = (*o)(in[i]);
    }
};

template <class T>
void check_stats(const aaf::image<aaf::occlusion_stats<T>>& stats) {
    for (std::size_t i = 0; i < stats.size(); ++i) {
        const aaf::occlusion_stats<T>& r = stats.data()[i];
        AAF_FUZZ_CHECK(r.occluded <= r.samples);
        AAF_FUZZ_CHECK(!(r.visible_weight > r.total_weight));
        // A normal far from unit length (user error) can make irradiance weights overflow their sum; the
        // estimate is then undefined (NaN) and render_frame treats it so (docs/EXTREMES.md).
        if (r.has_light() && std::isfinite(r.total_weight)) AAF_FUZZ_CHECK(r.visibility() >= T(0) && r.visibility() <= T(1));
    }
}

template <class T, class Tracer>
void frame_case(aaf_fuzz::reader& in, const aaf::gbuffer<T>& gb, const aaf::area_light<T>& light, const Tracer& tracer,
                const aaf::frame_settings<T>& s) {
    const std::size_t w = gb.width(), h = gb.height();
    // gather_occlusion on its own: the initial pass, or fuzzed per-pixel counts.
    {
        aaf::image<aaf::occlusion_stats<T>> stats(w, h);
        aaf::image<std::uint32_t> counts(w, h);
        const bool per_pixel = in.flag();
        for (std::size_t i = 0; i < counts.size(); ++i) counts.data()[i] = per_pixel ? in.byte() % 80u : 0u;
        const std::uint32_t spp = in.count(s.sampling.initial_samples);
        try {
            const std::uint64_t rays = aaf::gather_occlusion(gb, light, tracer, s.sampling, 0, spp, stats.view(),
                                                             per_pixel ? counts.cview() : aaf::const_image_view<std::uint32_t>{});
            check_stats(stats);
            std::uint64_t drawn = 0;
            for (std::size_t y = 0; y < h; ++y)
                for (std::size_t x = 0; x < w; ++x) {
                    const std::uint32_t asked = std::min(per_pixel ? counts(x, y) : spp, s.sampling.max_samples);
                    const auto p = gb.positions(x, y);
                    const auto n = gb.normals(x, y);
                    const bool surface = std::isfinite(p.x + p.y + p.z) && std::isfinite(n.x + n.y + n.z);
                    AAF_FUZZ_CHECK(stats(x, y).samples == (surface ? asked : 0u));
                    drawn += stats(x, y).samples;
                }
            AAF_FUZZ_CHECK(rays <= drawn);
        } catch (const aaf::invalid_argument&) {
        }
    }
    // The whole frame.
    aaf::image<T> vis(w, h, T(-7)), shaded(w, h, T(-7)), unshadowed(w, h);
    const std::uint8_t outputs = in.byte();
    for (std::size_t i = 0; i < unshadowed.size(); ++i) unshadowed.data()[i] = in.value(T(1));
    aaf::frame_outputs<T> out{vis.view()};
    if (outputs & 1u) out.shaded = shaded.view();
    if (outputs & 2u) out.unshadowed = unshadowed.cview();
    const std::uint8_t cancel_at = in.byte() % 5u;  // 1..3: cancel at the 1st..3rd progress call
    std::uint32_t progress_calls = 0;
    const auto progress = [&](double) { return ++progress_calls != cancel_at; };
    aaf::frame_workspace<T> ws;
    aaf::frame_report report;
    try {
        report = aaf::render_frame(gb, light, tracer, out, ws, s, aaf::sequential_executor{}, progress);
    } catch (const aaf::invalid_argument&) {
        for (std::size_t i = 0; i < vis.size(); ++i) AAF_FUZZ_CHECK(vis.data()[i] == T(-7) && shaded.data()[i] == T(-7));
        return;
    }
    if (report.cancelled) {
        for (std::size_t i = 0; i < vis.size(); ++i) AAF_FUZZ_CHECK(vis.data()[i] == T(-7) && shaded.data()[i] == T(-7));
        return;
    }
    for (std::size_t i = 0; i < vis.size(); ++i) AAF_FUZZ_CHECK(vis.data()[i] >= T(0) && vis.data()[i] <= T(1));
    check_stats(ws.stats);
    const std::uint32_t extra = s.sampling.adaptive ? s.sampling.max_samples - s.sampling.initial_samples : 0u;
    std::uint64_t samples = 0;
    for (std::size_t i = 0; i < ws.adaptive_samples.size(); ++i) {
        AAF_FUZZ_CHECK(ws.adaptive_samples.data()[i] <= extra);
        AAF_FUZZ_CHECK(ws.stats.data()[i].samples <= s.sampling.max_samples);
        samples += ws.stats.data()[i].samples;
    }
    AAF_FUZZ_CHECK(report.rays() <= samples);
}

template <class T>
int run(aaf_fuzz::reader& in) {
    using vec3 = glm::vec<3, T>;
    const std::size_t w = 1 + in.byte() % 8u, h = 1 + in.byte() % 8u;
    const T d0 = T(4) / static_cast<T>(std::max(w, h));

    aaf::frame_settings<T> s;
    s.sampling.initial_samples = 1 + in.byte() % 16u;
    if (s.sampling.initial_samples == 1) s.sampling.initial_samples = 9;  // the zero byte: the default
    s.sampling.max_samples = std::min<std::uint32_t>(in.count(s.sampling.max_samples), 64u);
    s.sampling.adaptive = !in.flag();
    s.sampling.pattern = static_cast<aaf::sample_pattern>(in.byte() % 3u);
    s.sampling.weighting = static_cast<aaf::light_weighting>(in.byte() % 3u);
    s.sampling.frame_seed = in.raw<std::uint32_t>();
    s.sampling.light_index = in.raw<std::uint32_t>();
    // From a bit already read, so the corpus's byte layout stays as it was.
    s.sampling.adaptive_query = (s.sampling.frame_seed & 1u) ? aaf::shadow_query::distances : aaf::shadow_query::visibility;
    if (in.flag()) s.sampling.origin_offset = in.value(1e-3);
    s.formulas.form = in.flag() ? aaf::formula_form::authors : aaf::formula_form::paper;
    s.formulas.k = in.value(s.formulas.k);
    s.formulas.mu = in.value(s.formulas.mu);
    s.formulas.alpha = in.value(s.formulas.alpha);
    s.formulas.max_slope = in.value(s.formulas.max_slope);
    // Issue 13's options, from bits already read (the corpus's byte layout stays as it was).
    s.formulas.light_scale = (s.sampling.light_index & 2u) ? T(0.9) : T(1);
    s.filter.unfiltered_at_horizon = (s.sampling.light_index & 4u) != 0;
    s.filter.space = in.flag() ? aaf::offset_space::light_plane : aaf::offset_space::image;
    s.filter.truncation = in.value(s.filter.truncation);
    s.filter.max_radius = in.count(s.filter.max_radius);
    s.filter.normal_threshold_degrees = in.value(s.filter.normal_threshold_degrees);
    s.filter.spread_slopes = !in.flag();
    s.filter.spread_radius = in.count(s.filter.spread_radius);
    s.radiance = in.value(s.radiance);

    aaf::area_light<T> light{{T(-0.5), T(3), T(-0.5)}, {T(1), T(0), T(0)}, {T(0), T(0), T(1)}};
    light.corner = in.vec3(light.corner);
    light.edge_u = in.vec3(light.edge_u);
    light.edge_v = in.vec3(light.edge_v);
    light.two_sided = in.flag();

    aaf::image<vec3> positions(w, h), normals(w, h);
    aaf::image<T> pixel_size(w, h);
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) {
            positions(x, y) = in.vec3(vec3(T(-2) + (static_cast<T>(x) + T(0.5)) * d0, T(0), T(-2) + (static_cast<T>(y) + T(0.5)) * d0));
            normals(x, y) = in.vec3(vec3(0, 1, 0));
            pixel_size(x, y) = in.value(d0);
        }
    const aaf::gbuffer<T> gb{positions.cview(), normals.cview(), pixel_size.cview(), {}};

    fuzz_oracle<T> oracle;
    oracle.x0 = in.value(oracle.x0);
    oracle.x1 = in.value(oracle.x1);
    oracle.y = in.value(oracle.y);
    const std::uint32_t answers = in.byte() % 17u;
    oracle.period = 1 + in.byte() % 8u;
    oracle.phase = in.byte();
    for (std::uint32_t i = 0; i < answers; ++i) {
        answer<T> a;
        switch (in.byte() % 4u) {
            case 1: a.span = {in.value(T(1)), in.value(T(1))}; break;
            case 2: a.span = {in.value(T(0.5)), in.value(T(0.5))}, a.relative = true; break;
            case 3: a.span = {std::numeric_limits<T>::quiet_NaN(), in.value(T(1))}; break;
            default: break;  // a miss
        }
        oracle.table.push_back(a);
    }
    switch (in.byte() % 3u) {
        case 1: frame_case<T>(in, gb, light, nearest_shape<T>{&oracle}, s); break;
        case 2: frame_case<T>(in, gb, light, batch_shape<T>{&oracle}, s); break;
        default: frame_case<T>(in, gb, light, span_shape<T>{&oracle}, s); break;
    }
    return 0;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    aaf_fuzz::reader in(data, size);
    return in.flag() ? run<double>(in) : run<float>(in);
}
