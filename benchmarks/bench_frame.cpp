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

#include <benchmark/benchmark.h>

#include <cstdint>
#include <exception>
#include <filesystem>
#include <memory>
#include <string>

#include <aaf/aaf.hpp>

#include "bench_common.hpp"
#include "common/bvh.hpp"
#include "common/render_support.hpp"
#include "common/scene.hpp"

namespace {

/// The scene, its BVH and its G-buffer (aaf_examples::render_gbuffer, the renderers' own), built once.
struct frame_scene {
    aaf_examples::scene scene;
    std::unique_ptr<aaf_examples::bvh> tree;
    aaf_examples::gbuffer_images g;
    std::string error;  // non-empty: the scene could not be loaded
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

/// Args: threads, light_plane.
void BM_frame(benchmark::State& state) {
    const frame_scene& f = get_scene();
    if (!f.error.empty()) {
        state.SkipWithError(f.error.c_str());
        return;
    }
    const std::size_t w = f.scene.width, h = f.scene.height;
    const aaf::gbuffer<float, aaf::const_image_view<std::uint32_t>> gb{f.g.positions.cview(), f.g.normals.cview(),
                                                                       f.g.pixel_size.cview(), f.g.ids.cview()};
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

}  // namespace
