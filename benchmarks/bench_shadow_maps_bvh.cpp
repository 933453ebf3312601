// SPDX-License-Identifier: MIT
// Shadow-map rendering through the examples' BVH (examples/common/bvh.hpp): render_depth_map of an N×N
// unorm24 perspective map from the light's centre of a real scene, one nearest-hit query per texel, on 1 and 2
// threads. bench_shadow_maps.cpp times the same call through an analytic tracer (and the lookups); this one
// is what the registry's sm_hard / sm_pcf / sm_pcss / sm_accumulation pay per map.
//
//   BM_shadow_map_render_bvh/<scene>/<N>/threads:T   scenes/bunny.json (69k triangles); scenes/car.json
//                                                     (300k) when AAF_SCENES_DIR holds sportsCar.obj
//
//   build/release/benchmarks/aaf_benchmarks --benchmark_filter=BM_shadow_map_render_bvh
//
// Counters: Mtexels_per_s (texels, i.e. nearest-hit queries, per second of wall time), hit_fraction.

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <exception>
#include <filesystem>
#include <map>
#include <memory>
#include <string>

#include <aaf/shadow_maps.hpp>

#include "common/bvh.hpp"
#include "common/scene.hpp"

namespace {

/// A scene, its BVH and the perspective view from its light's centre that contains every vertex in front of
/// the light (as fit_perspective_view fits a G-buffer's receivers); loaded once per process.
struct map_scene {
    aaf_examples::scene s;
    std::unique_ptr<aaf_examples::bvh> tree;
    aaf::light_view<float> view;
    std::string error;
};

const map_scene& get_map_scene(const std::string& name) {
    static std::map<std::string, map_scene> cache;
    if (const auto found = cache.find(name); found != cache.end()) return found->second;
    map_scene& m = cache[name];
    try {
        m.s = aaf_examples::load_scene(name, std::filesystem::path(AAF_SOURCE_DIR) / "scenes");
        m.tree = std::make_unique<aaf_examples::bvh>(m.s.vertices, m.s.triangles);
    } catch (const std::exception& e) {
        m.error = std::string(e.what()) + (name == "car" ? " (set AAF_SCENES_DIR to the folder holding sportsCar.obj)" : "");
        return m;
    }
    aaf::light_view<float>& v = m.view;
    v.projection = aaf::depth_projection::perspective;
    v.eye = m.s.light.center();
    v.forward = m.s.light.normal();
    v.up = std::abs(v.forward.y) < 0.9f ? glm::vec3(0, 1, 0) : glm::vec3(1, 0, 0);
    const aaf::light_frame<float> frame(v);
    float far_depth = 0, tx = 1e-3f, ty = 1e-3f;
    for (const glm::vec3& p : m.s.vertices) {
        const glm::vec3 l = frame.to_light(p);
        if (!(l.z > 0.0f)) continue;
        far_depth = std::max(far_depth, l.z);
        tx = std::max(tx, std::abs(l.x) / l.z), ty = std::max(ty, std::abs(l.y) / l.z);
    }
    v.far_plane = 1.01f * far_depth;
    v.near_plane = 1e-3f * v.far_plane;
    v.half_width = std::min(1.01f * tx, 8.0f), v.half_height = std::min(1.01f * ty, 8.0f);
    return m;
}

void BM_shadow_map_render_bvh(benchmark::State& state, const std::string& name) {
    const map_scene& m = get_map_scene(name);
    if (!m.error.empty()) {
        state.SkipWithError(m.error.c_str());
        return;
    }
    const auto n = static_cast<std::size_t>(state.range(0));
    aaf::depth_map<float> map(n, n, m.view, aaf::depth_format::unorm24);
    aaf::thread_pool pool(static_cast<std::size_t>(state.range(1)));
    aaf::depth_render_stats st{};
    for (auto _ : state) {
        st = aaf::render_depth_map(map, *m.tree, pool);
        benchmark::DoNotOptimize(st);
        benchmark::ClobberMemory();
    }
    state.counters["Mtexels_per_s"] = benchmark::Counter(static_cast<double>(state.iterations()) * static_cast<double>(n * n) * 1e-6,
                                                         benchmark::Counter::kIsRate);
    state.counters["hit_fraction"] = static_cast<double>(st.hits) / static_cast<double>(n * n);
}

void register_all() {
    for (const char* name : {"bunny", "car"})
        benchmark::RegisterBenchmark((std::string("BM_shadow_map_render_bvh/") + name).c_str(), BM_shadow_map_render_bvh, std::string(name))
            ->ArgsProduct({{1024}, {1, 2}})->ArgNames({"", "threads"})->Unit(benchmark::kMillisecond)->UseRealTime();
}

[[maybe_unused]] const bool registered = (register_all(), true);

}  // namespace
