// SPDX-License-Identifier: MIT
// A whole frame, aaf::render_frame, with the examples' BVH (examples/common/bvh.hpp) as the tracer, on
// scenes/bunny.json (the Stanford bunny on a ground plane under a square light) at 640×480, default
// frame_settings (9 initial samples, μ = 2, at most 100 per pixel: ~20 rays per pixel), 1 and 2 threads.
// The G-buffer (the renderers' aaf_examples::render_gbuffer: pinhole camera, primary rays through the same
// BVH) is built once, outside the timing.
//
//   BM_frame/bunny/640x480/threads:T/light_plane:L
//
// Counters, per frame (means over the iterations): total_ms, initial_ms, adaptive_ms, formulas_ms and
// filter_ms from aaf::frame_report; filter_share = filter_ms / total_ms; rays_per_px over all pixels and
// rays_per_surface_px over pixels that see a surface; Mrays_per_s; filter_taps_per_px_pass, the filter's
// mean 2r + 1 over the frame (pixels with β = 0, which are copied, count as 1). The 2-thread speed-up is the ratio of the
// threads:1 and threads:2 real times (docs/BENCHMARKS.md).
//
//   scripts/bench BM_frame
//
// BM_per_sample_cost/bunny/640x480/threads:1: one gathering pass (9 samples per pixel, gather_occlusion) on
// the same G-buffer with a tracer that does nothing, once per sample pattern, beside the same pass with the
// examples' BVH and (AAF_WITH_EMBREE) Embree: <form>_ns = ns of the calling thread's CPU time per traced
// sample, so aaf's own cost per sample stands next to a real tracer's cost per ray (issue 14).
//
// With Embree (AAF_WITH_EMBREE): BM_frame_tracers/bunny/640x480/threads:T renders the same frame (same
// G-buffer, same settings, same samples) with each tracer form in turn within every iteration, so that a
// change in the machine's load hits them alike:
//   bvh, bvh_first            the examples' BVH, one ray at a time: occluder_span (nearest and farthest in one
//                             traversal) or nearest_occluder (first hit); any-hit `occluded` in the adaptive pass
//   embree1, embree1_first    Embree one ray at a time: occluder_span (two rtcIntersect1 per occluded sample)
//                             or nearest_occluder (one); rtcOccluded1 in the adaptive pass
//   embree16/64/256           Embree's packets through aaf's batched queries, sampling_settings::batch_rays =
//                             16, 64 (the default), 256: trace_batch (rtcIntersect16, then back rays of the
//                             occluded samples in packets) and occluded_batch (rtcOccluded16)
//   embree64_first            packets, nearest only: nearest_batch (rtcIntersect16) and occluded_batch
// Counters per form F: F_ms (the frame, render_frame's total_ms), F_trace_ms (its two gathering passes),
// F_Mrays/s (rays over the gathering passes' time, per frame), and F_x = bvh_ms / F_ms (frame speed-up over
// the BVH). scripts/bench prints them as a table.

#include <benchmark/benchmark.h>

#include <cmath>
#include <ctime>
#include <cstdint>
#include <exception>
#include <functional>
#include <span>
#include <utility>
#include <vector>
#include <filesystem>
#include <memory>
#include <string>

#include <aaf/aaf.hpp>

#include "bench_common.hpp"
#include "common/bvh.hpp"
#include "common/render_support.hpp"
#include "common/scene.hpp"
#if AAF_EXAMPLES_EMBREE
#include "common/embree_tracer.hpp"
#endif

namespace {

/// The scene, its BVH and its G-buffer (aaf_examples::render_gbuffer, the renderers' own), built once.
struct frame_scene {
    aaf_examples::scene scene;
    std::unique_ptr<aaf_examples::bvh> tree;
    aaf_examples::gbuffer_images g;
    std::string error;  // non-empty: the scene could not be loaded

    /// The G-buffer as render_frame and gather_occlusion read it (views of `g`).
    [[nodiscard]] aaf::gbuffer<float, aaf::const_image_view<std::uint32_t>> gbuffer() const {
        return {g.positions.cview(), g.normals.cview(), g.pixel_size.cview(), g.ids.cview()};
    }
};

const frame_scene& get_scene() {
    static const frame_scene f = [] {
        frame_scene r;
        const std::filesystem::path file = std::filesystem::path(AAF_SOURCE_DIR) / "scenes" / "bunny.json";
        try {
            r.scene = aaf_examples::load_scene_file(file);
            r.tree = std::make_unique<aaf_examples::bvh>(r.scene.vertices, r.scene.triangles);
            aaf::thread_pool pool;
            r.g = aaf_examples::render_gbuffer(r.scene, *r.tree, pool);
        } catch (const std::exception& e) {
            r.error = file.string() + ": " + e.what();
        }
        return r;
    }();
    return f;
}

/// The scene, or null after marking the benchmark skipped with the reason it could not be loaded.
const frame_scene* scene_or_skip(benchmark::State& state) {
    const frame_scene& f = get_scene();
    if (f.error.empty()) return &f;
    state.SkipWithError(f.error.c_str());
    return nullptr;
}

/// Args: threads, light_plane.
void BM_frame(benchmark::State& state) {
    const frame_scene* scene = scene_or_skip(state);
    if (!scene) return;
    const frame_scene& f = *scene;
    const std::size_t w = f.scene.width, h = f.scene.height;
    const auto gb = f.gbuffer();
    aaf::frame_settings<float> settings;
    settings.filter.space = state.range(1) ? aaf::offset_space::light_plane : aaf::offset_space::image;
    aaf::frame_workspace<float> ws;
    aaf::image<float> visibility(w, h);
    aaf::thread_pool pool(static_cast<std::size_t>(state.range(0)));
    double total = 0, initial = 0, adaptive = 0, formulas = 0, filter = 0, rays = 0;
    for (auto _ : state) {
        const aaf::frame_report r = aaf::render_frame(gb, f.scene.light, *f.tree, {visibility.view()}, ws, settings, pool);
        benchmark::DoNotOptimize(visibility.data());
        total += r.total_ms, initial += r.initial_ms, adaptive += r.adaptive_ms, formulas += r.formulas_ms;
        filter += r.filter_ms, rays += static_cast<double>(r.rays());
    }
    const auto n = static_cast<double>(state.iterations());
    state.counters["total_ms"] = total / n;
    state.counters["initial_ms"] = initial / n;
    state.counters["adaptive_ms"] = adaptive / n;
    state.counters["formulas_ms"] = formulas / n;
    state.counters["filter_ms"] = filter / n;
    state.counters["filter_share"] = filter / total;
    state.counters["rays_per_px"] = rays / n / static_cast<double>(w * h);
    state.counters["rays_per_surface_px"] = rays / n / static_cast<double>(f.g.surfaces);
    state.counters["filter_taps_per_px_pass"] = aaf_bench::mean_taps(ws.filter_width, f.g.pixel_size, settings.filter);
    state.counters["Mrays_per_s"] = benchmark::Counter(rays * 1e-6, benchmark::Counter::kIsRate);
}
BENCHMARK(BM_frame)
    ->Name("BM_frame/bunny/640x480")
    ->ArgsProduct({{1, 2}, {0, 1}})
    ->ArgNames({"threads", "light_plane"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

/// A tracer that does nothing: every segment is unoccluded. What is left is aaf's own per-sample work.
struct null_tracer {
    [[nodiscard]] aaf::occluder_span<float> occluder_span(const aaf::shadow_segment<float>&) const noexcept { return {}; }
};

/// CPU time of the calling thread in seconds (robust to other processes sharing the cores).
double thread_cpu_seconds() {
    timespec t{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

/// aaf's own cost per shadow sample (sample generation, segments, offsets, statistics) with a tracer that
/// does nothing, for every sample pattern, beside the cost per ray of the examples' BVH (and Embree's,
/// when built with it) on the same G-buffer, light and samples: the bunny at 640x480, 9 samples per
/// pixel, one gathering pass (gather_occlusion, distances), 1 thread. Every form runs once per iteration,
/// in turns; times are the calling thread's CPU time. Counters: <form>_ns = ns per traced sample.
void BM_per_sample_cost(benchmark::State& state) {
    const frame_scene* scene = scene_or_skip(state);
    if (!scene) return;
    const frame_scene& f = *scene;
    const std::size_t w = f.scene.width, h = f.scene.height;
    const auto gb = f.gbuffer();
    aaf::image<aaf::occlusion_stats<float>> stats(w, h);
    const auto gather = [&](const auto& tracer, aaf::sample_pattern pattern) {
        aaf::sampling_settings s;
        s.pattern = pattern;
        stats.fill({});
        const double t0 = thread_cpu_seconds();
        const std::uint64_t rays = aaf::gather_occlusion(gb, f.scene.light, tracer, s, 0, s.initial_samples, stats.view());
        benchmark::DoNotOptimize(stats.data());
        return std::pair<double, double>(thread_cpu_seconds() - t0, static_cast<double>(rays));
    };
    using form = std::pair<const char*, std::function<std::pair<double, double>()>>;
    std::vector<form> forms = {
        {"null_stratified", [&] { return gather(null_tracer{}, aaf::sample_pattern::stratified); }},
        {"null_regular_grid", [&] { return gather(null_tracer{}, aaf::sample_pattern::regular_grid); }},
        {"null_low_discrepancy", [&] { return gather(null_tracer{}, aaf::sample_pattern::low_discrepancy); }},
        {"bvh", [&] { return gather(*f.tree, aaf::sample_pattern::stratified); }},
    };
#if AAF_EXAMPLES_EMBREE
    static const std::unique_ptr<aaf_examples::embree_tracer> embree =
        std::make_unique<aaf_examples::embree_tracer>(f.scene.vertices, f.scene.triangles);
    forms.push_back({"embree", [&] { return gather(*embree, aaf::sample_pattern::stratified); }});
#endif
    std::vector<double> seconds(forms.size(), 0.0), rays(forms.size(), 0.0);
    bool forward = true;
    for (auto _ : state) {
        for (std::size_t k = 0; k < forms.size(); ++k) {
            const std::size_t i = forward ? k : forms.size() - 1 - k;
            const auto [t, r] = forms[i].second();
            seconds[i] += t, rays[i] += r;
        }
        forward = !forward;
    }
    for (std::size_t i = 0; i < forms.size(); ++i) state.counters[std::string(forms[i].first) + "_ns"] = 1e9 * seconds[i] / rays[i];
    state.counters["samples_per_frame"] = rays[0] / static_cast<double>(state.iterations());
}
BENCHMARK(BM_per_sample_cost)->Name("BM_per_sample_cost/bunny/640x480/threads:1")->Unit(benchmark::kMillisecond);

#if AAF_EXAMPLES_EMBREE
// Views of a tracer that show aaf only some of its queries, so that render_frame takes the form measured.
template <class Tracer>
struct single_all_hits {  // occluder_span + occluded, one ray at a time
    const Tracer* t;
    [[nodiscard]] aaf::occluder_span<float> occluder_span(const aaf::shadow_segment<float>& g) const noexcept { return t->occluder_span(g); }
    [[nodiscard]] bool occluded(const aaf::shadow_segment<float>& g) const noexcept { return t->occluded(g); }
};
template <class Tracer>
struct single_first_hit {  // nearest_occluder + occluded, one ray at a time
    const Tracer* t;
    [[nodiscard]] float nearest_occluder(const aaf::shadow_segment<float>& g) const noexcept { return t->nearest_occluder(g); }
    [[nodiscard]] bool occluded(const aaf::shadow_segment<float>& g) const noexcept { return t->occluded(g); }
};
struct packet_first_hit {  // nearest_batch + occluded_batch
    const aaf_examples::embree_tracer* t;
    void nearest_batch(std::span<const aaf::shadow_segment<float>> s, std::span<float> out) const { t->nearest_batch(s, out); }
    void occluded_batch(std::span<const aaf::shadow_segment<float>> s, std::span<bool> out) const { t->occluded_batch(s, out); }
};

/// Args: threads. Every form renders the frame once per iteration, in turns (the order reversed every other
/// iteration); the iteration time is the sum.
void BM_frame_tracers(benchmark::State& state) {
    const frame_scene* scene = scene_or_skip(state);
    if (!scene) return;
    const frame_scene& f = *scene;
    static const std::unique_ptr<aaf_examples::embree_tracer> embree =
        std::make_unique<aaf_examples::embree_tracer>(f.scene.vertices, f.scene.triangles);
    const aaf_examples::bvh& tree = *f.tree;
    const aaf_examples::embree_tracer& e = *embree;
    const std::size_t w = f.scene.width, h = f.scene.height;
    const auto gb = f.gbuffer();
    aaf::frame_workspace<float> ws;
    aaf::image<float> visibility(w, h);
    aaf::thread_pool pool(static_cast<std::size_t>(state.range(0)));
    const auto frame = [&](const auto& tracer, std::uint32_t batch_rays) {
        aaf::frame_settings<float> settings;
        settings.sampling.batch_rays = batch_rays;
        return aaf::render_frame(gb, f.scene.light, tracer, {visibility.view()}, ws, settings, pool);
    };
    using form = std::pair<const char*, std::function<aaf::frame_report()>>;
    const std::vector<form> forms = {
        {"bvh", [&] { return frame(single_all_hits<aaf_examples::bvh>{&tree}, 64); }},
        {"bvh_first", [&] { return frame(single_first_hit<aaf_examples::bvh>{&tree}, 64); }},
        {"embree1", [&] { return frame(single_all_hits<aaf_examples::embree_tracer>{&e}, 64); }},
        {"embree1_first", [&] { return frame(single_first_hit<aaf_examples::embree_tracer>{&e}, 64); }},
        {"embree16", [&] { return frame(e, 16); }},
        {"embree64", [&] { return frame(e, 64); }},
        {"embree256", [&] { return frame(e, 256); }},
        {"embree64_first", [&] { return frame(packet_first_hit{&e}, 64); }},
    };
    std::vector<double> total(forms.size(), 0.0), trace(forms.size(), 0.0), rays(forms.size(), 0.0);
    bool forward = true;
    for (auto _ : state) {
        double iteration = 0;
        for (std::size_t k = 0; k < forms.size(); ++k) {
            const std::size_t i = forward ? k : forms.size() - 1 - k;
            const aaf::frame_report r = forms[i].second();
            benchmark::DoNotOptimize(visibility.data());
            total[i] += r.total_ms, trace[i] += r.initial_ms + r.adaptive_ms, rays[i] += static_cast<double>(r.rays());
            iteration += r.total_ms;
        }
        forward = !forward;
        state.SetIterationTime(iteration * 1e-3);
    }
    const auto n = static_cast<double>(state.iterations());
    for (std::size_t i = 0; i < forms.size(); ++i) {
        const std::string name = forms[i].first;
        state.counters[name + "_ms"] = total[i] / n;
        state.counters[name + "_trace_ms"] = trace[i] / n;
        state.counters[name + "_Mrays/s"] = rays[i] * 1e-3 / trace[i];  // rays per ms = 1e-3 Mrays/s
        state.counters[name + "_x"] = total[0] / total[i];
    }
    state.counters["rays_per_px"] = rays[0] / n / static_cast<double>(w * h);
    // Every all-hits form traces the same rays (the adaptive counts follow from equal statistics).
    for (const std::size_t i : {std::size_t{2}, std::size_t{4}, std::size_t{5}, std::size_t{6}})
        if (std::abs(rays[i] - rays[0]) > 1e-3 * rays[0]) state.SkipWithError("the tracers' frames traced different numbers of rays");
}
BENCHMARK(BM_frame_tracers)
    ->Name("BM_frame_tracers/bunny/640x480")
    ->ArgName("threads")
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->UseManualTime();
#endif

}  // namespace
