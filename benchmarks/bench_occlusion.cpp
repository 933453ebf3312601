// SPDX-License-Identifier: MIT
// Ambient occlusion (include/aaf/occlusion/): AO rays per second through the examples' BVH (per-triangle
// baking on the bunny and the plant, any-hit and nearest-hit queries), the AO filter's Mpx/s at 1280×720 on
// 1 and 2 threads, and the library's own cost per AO sample (hemisphere sampling, frame, ray set-up,
// statistics) with a tracer that does nothing, to set against one any-hit BVH ray.
//
//   build/release/benchmarks/aaf_benchmarks --benchmark_filter=ao_

#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <span>
#include <string>
#include <vector>

#include <aaf/occlusion.hpp>

#include "common/bvh.hpp"
#include "common/mesh_io.hpp"

namespace {

namespace fs = std::filesystem;

struct mesh_scene {
    aaf_examples::triangle_mesh mesh;
    std::unique_ptr<aaf_examples::bvh> tree;
    std::vector<glm::vec<3, std::uint32_t>> triangles;
    float size = 1;
    std::string error;
};

const mesh_scene& get_mesh(const std::string& file) {
    static std::map<std::string, mesh_scene> cache;
    if (const auto it = cache.find(file); it != cache.end()) return it->second;
    mesh_scene& s = cache[file];
    try {
        s.mesh = aaf_examples::load_triangles(fs::path(AAF_SOURCE_DIR) / "assets" / "meshes" / file);
        s.tree = std::make_unique<aaf_examples::bvh>(s.mesh.vertices, s.mesh.triangles);
        for (const glm::uvec3& t : s.mesh.triangles) s.triangles.push_back({t.x, t.y, t.z});
        glm::vec3 lo(std::numeric_limits<float>::infinity()), hi(-lo);
        for (const glm::vec3& v : s.mesh.vertices) lo = glm::min(lo, v), hi = glm::max(hi, v);
        s.size = glm::length(hi - lo);
    } catch (const std::exception& e) {
        s.error = e.what();
    }
    return s;
}

/// AO rays per second: every triangle of the mesh baked with 16 cosine samples, R = a quarter of the mesh's
/// diagonal, through the BVH's occluded() (visibility) or nearest_occluder() (distances).
void BM_ao_rays(benchmark::State& state, const std::string& file, aaf::ao_query query) {
    const mesh_scene& s = get_mesh(file);
    if (!s.error.empty()) {
        state.SkipWithError(s.error.c_str());
        return;
    }
    aaf::ao_sampling_settings<float> set;
    set.max_distance = 0.25f * s.size;
    set.query = query;
    std::vector<aaf::ao_stats<float>> stats(s.triangles.size());
    aaf::thread_pool pool(static_cast<std::size_t>(state.range(0)), 256);
    std::uint64_t rays = 0;
    double visible = 0;
    for (auto _ : state) {
        rays += aaf::bake_triangle_occlusion<float>(s.mesh.vertices, s.triangles, *s.tree, set, stats, false, pool);
        benchmark::DoNotOptimize(stats.data());
    }
    for (const auto& r : stats) visible += static_cast<double>(std::isfinite(r.visibility()) ? r.visibility() : 0.0f);
    state.counters["Mrays/s"] = benchmark::Counter(static_cast<double>(rays) * 1e-6, benchmark::Counter::kIsRate);
    state.counters["mean_visibility"] = visible / static_cast<double>(stats.size());
    state.counters["triangles"] = static_cast<double>(s.triangles.size());
}

/// A tracer that does nothing: what remains is aaf's own cost per sample.
struct null_tracer {
    [[nodiscard]] float nearest_occluder(const aaf::shadow_segment<float>&) const noexcept { return aaf::no_occluder<float>; }
    [[nodiscard]] bool occluded(const aaf::shadow_segment<float>&) const noexcept { return false; }
};

/// A 1280×720 view of a ground plane (positions, normals, footprints, IDs) and noisy AO records over it.
struct ao_frame {
    std::size_t w = 1280, h = 720;
    aaf::image<glm::vec3> positions{w, h}, normals{w, h, glm::vec3(0, 1, 0)};
    aaf::image<float> pixel_size{w, h, 0.01f};
    aaf::image<std::uint32_t> ids{w, h, 0u};
    aaf::image<aaf::ao_stats<float>> stats{w, h};
    ao_frame() {
        std::mt19937 rng(7);
        std::uniform_real_distribution<float> u(0, 1);
        for (std::size_t y = 0; y < h; ++y)
            for (std::size_t x = 0; x < w; ++x) {
                positions(x, y) = {0.01f * static_cast<float>(x), 0, 0.01f * static_cast<float>(y)};
                ids(x, y) = static_cast<std::uint32_t>(x / 320);
                aaf::ao_stats<float>& r = stats(x, y);
                r.samples = r.counted = 16;
                r.visible_sum = 16 * u(rng);
                r.bent_sum = glm::vec3(u(rng) - 0.5f, 1, u(rng) - 0.5f);
                // z_min from 0.05 to 0.6 world units: β from 0.45 to 5.4 px at μ = 2.
                const float z = 0.05f + 0.55f * static_cast<float>(x % 97) / 96.0f;
                r.hits = 1, r.z_min = z, r.z_max = 2 * z;
            }
    }
    [[nodiscard]] aaf::gbuffer<float, aaf::const_image_view<std::uint32_t>> gb() const {
        return {positions.cview(), normals.cview(), pixel_size.cview(), ids.cview()};
    }
};

const ao_frame& frame() {
    static const ao_frame f;
    return f;
}

/// The AO filter at 1280×720: visibility only (bent:0) or with the bent normals (bent:1), tangent-plane
/// (space:1, the default) or image-space offsets (space:0).
void BM_ao_filter(benchmark::State& state) {
    const ao_frame& f = frame();
    aaf::thread_pool pool(static_cast<std::size_t>(state.range(0)));
    aaf::image<float> out(f.w, f.h);
    aaf::image<glm::vec3> bent(f.w, f.h);
    aaf::ao_filter_settings<float> s;
    s.space = state.range(2) ? aaf::offset_space::tangent_plane : aaf::offset_space::image;
    const aaf::ao_outputs<float> o{out.view(), state.range(1) ? bent.view() : aaf::image_view<glm::vec3>{}, {}, {}};
    for (auto _ : state) {
        aaf::filter_ambient_occlusion(f.gb(), f.stats.cview(), s, o, pool);
        benchmark::DoNotOptimize(out.data());
    }
    state.counters["Mpx/s"] =
        benchmark::Counter(static_cast<double>(state.iterations() * f.w * f.h) * 1e-6, benchmark::Counter::kIsRate);
}

/// aaf's own cost per AO sample (no tracing): 16 samples per pixel over 256×256 pixels, one thread.
/// visibility (any-hit path, query:0) or distances (nearest path with z statistics, query:1).
void BM_ao_library_cost(benchmark::State& state) {
    const std::size_t n = 256;
    aaf::image<glm::vec3> p(n, n), nn(n, n, glm::normalize(glm::vec3(0.2f, 1, 0.1f)));
    aaf::image<float> d(n, n, 0.01f);
    for (std::size_t y = 0; y < n; ++y)
        for (std::size_t x = 0; x < n; ++x) p(x, y) = {static_cast<float>(x), 0, static_cast<float>(y)};
    const aaf::gbuffer<float> gb{p.cview(), nn.cview(), d.cview()};
    aaf::image<aaf::ao_stats<float>> stats(n, n);
    aaf::ao_sampling_settings<float> s;
    s.query = state.range(0) ? aaf::ao_query::distances : aaf::ao_query::visibility;
    s.max_distance = 1;
    std::uint64_t samples = 0;
    for (auto _ : state) {
        samples += aaf::gather_ambient_occlusion(gb, null_tracer{}, s, 0, 16, stats.view());
        benchmark::DoNotOptimize(stats.data());
    }
    state.counters["ns/sample"] = benchmark::Counter(static_cast<double>(samples) * 1e-9,
                                                     benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

}  // namespace

BENCHMARK_CAPTURE(BM_ao_rays, bunny_anyhit, std::string("bun_zipper.ply"), aaf::ao_query::visibility)
    ->ArgName("threads")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(BM_ao_rays, bunny_nearest, std::string("bun_zipper.ply"), aaf::ao_query::distances)
    ->ArgName("threads")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(BM_ao_rays, plant_anyhit, std::string("plant.obj"), aaf::ao_query::visibility)
    ->ArgName("threads")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_ao_filter)->ArgNames({"threads", "bent", "tangent"})->Args({1, 0, 1})->Args({2, 0, 1})->Args({1, 1, 1})
    ->Args({2, 1, 1})->Args({1, 0, 0})->Args({2, 0, 0})->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_ao_library_cost)->ArgName("query")->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
