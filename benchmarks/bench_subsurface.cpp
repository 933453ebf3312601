// SPDX-License-Identifier: MIT
// Subsurface benchmarks (include/aaf/subsurface/): the gather at 640×480 with 150 samples per pixel on 1 and 2
// threads, for both disc samplings and both profiles, and building a light-space map through a tracer.
//
//   BM_subsurface_gather/sampling:S/profile:P/threads:T/vector:V   samples_per_s (disc samples), time_per_px;
//        vector:1 evaluates R_d for a pixel's samples at once (gather_settings::vector_profile, the default),
//        vector:0 one sample at a time: the side-by-side comparison of the vectorised profile
//   BM_subsurface_profile/vector:V       the profile evaluation alone: 150 radii drawn from marble's R_d, weighted
//        sum over the three channels, scalar dipole::profile (0) against weighted_profile_sum (1); radii_per_s
//   BM_subsurface_map/res:R/threads:T    time_per_texel (one ray + normal + E·F_t per texel), analytic box tracer
//   BM_subsurface_map_bvh/res:R/threads:T  the same map of the bunny (assets/meshes/bun_zipper.ply, 69k
//        triangles) through the examples' BVH, normals reconstructed from the map (as the registry's methods)
//
// The gather's scene is a 300 mm marble slab lit at 30° (tests/support/box_scene.hpp).
//
//   scripts/bench 'BM_subsurface'

#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include <aaf/executor.hpp>
#include <aaf/subsurface.hpp>

#include "support/box_scene.hpp"

#if defined(AAF_SOURCE_DIR)  // built with the examples: their BVH and mesh loader
#include <filesystem>

#include "common/bvh.hpp"
#include "common/mesh_io.hpp"
#endif

namespace {

namespace ss = aaf::subsurface;
using ortho = ss::orthographic_projection<float>;

struct slab {
    aaf_test::box_scene scene;
    ortho proj;
    slab(std::size_t res) {
        scene.boxes.push_back({glm::vec3(-150, -100, -150), glm::vec3(150, 0, 150)});
        proj = ortho::looking_along(glm::normalize(glm::vec3(0.5f, -1, 0)), glm::vec3(0, -50, 0), 270.f, res);
    }
    [[nodiscard]] ss::light_map<ortho> build(aaf::thread_pool& pool) const {
        return ss::build_light_map(proj, ss::map_light<float>{glm::vec3(1)}, 1.3f, scene,
                                   [this](const glm::vec3& p) { return scene.normal_at(p); }, pool);
    }
};

void BM_subsurface_gather(benchmark::State& state) {
    const auto sampling = static_cast<ss::disc_sampling>(state.range(0));
    const auto profile = static_cast<ss::profile_model>(state.range(1));
    aaf::thread_pool pool(static_cast<std::size_t>(state.range(2)));
    const slab s(512);
    const ss::light_map<ortho> map = s.build(pool);
    const std::size_t w = 640, h = 480;
    std::vector<glm::vec3> P(w * h), N(w * h, glm::vec3(0, 1, 0)), out(w * h);
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) P[y * w + x] = {-120.0f + 240.0f * float(x) / float(w), 0, -90.0f + 180.0f * float(y) / float(h)};
    ss::gather_settings<float> settings;
    settings.sampling = sampling;
    settings.profile = profile;
    settings.samples = 150;
    settings.vector_profile = state.range(3) != 0;
    const ss::visible_points<float> vp{{P.data(), w, h}, {N.data(), w, h}};
    std::uint64_t samples = 0;
    for (auto _ : state) {
        samples += ss::gather_subsurface(vp, map.view(), ss::presets::marble<float>(), settings, aaf::image_view<glm::vec3>(out.data(), w, h), pool).samples;
        benchmark::DoNotOptimize(out.data());
    }
    state.counters["samples_per_s"] = benchmark::Counter(double(samples), benchmark::Counter::kIsRate);
    state.counters["time_per_px"] =
        benchmark::Counter(double(state.iterations()) * double(w * h), benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_subsurface_gather)
    ->ArgNames({"sampling", "profile", "threads", "vector"})
    ->ArgsProduct({{0, 1}, {0}, {1, 2}, {1}})
    ->Args({0, 0, 1, 0})
    ->Args({1, 0, 1, 0})
    ->Args({1, 1, 1, 1})
    ->Args({1, 1, 2, 1})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_subsurface_map(benchmark::State& state) {
    aaf::thread_pool pool(static_cast<std::size_t>(state.range(1)));
    const slab s(static_cast<std::size_t>(state.range(0)));
    for (auto _ : state) {
        const ss::light_map<ortho> map = s.build(pool);
        benchmark::DoNotOptimize(map.positions[0].data());
    }
    state.counters["time_per_texel"] = benchmark::Counter(double(state.iterations()) * double(state.range(0) * state.range(0)),
                                                          benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_subsurface_map)->ArgNames({"res", "threads"})->ArgsProduct({{512}, {1, 2}})->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_subsurface_profile(benchmark::State& state) {
    const bool vector = state.range(0) != 0;
    const ss::rgb_dipole d(ss::presets::marble<double>());
    const ss::radius_sampler sampler(d, ss::default_gather_radius(d));
    constexpr std::size_t n = 150, sets = 64;  // 64 pixels' worth, so the radii do not sit in registers
    std::mt19937 rng(1);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::vector<double> r(n * sets), w0(n * sets), w1(n * sets), w2(n * sets);
    for (std::size_t i = 0; i < n * sets; ++i) {
        r[i] = sampler.radius(int(i % 3), u(rng));
        w0[i] = u(rng), w1[i] = u(rng), w2[i] = u(rng);
    }
    std::size_t set = 0;
    for (auto _ : state) {
        const std::size_t o = (set++ % sets) * n;
        glm::dvec3 sum(0);
        if (vector) {
            sum = ss::weighted_profile_sum(d, r.data() + o, w0.data() + o, w1.data() + o, w2.data() + o, n);
        } else {
            for (std::size_t i = o; i < o + n; ++i) sum += glm::dvec3(w0[i], w1[i], w2[i]) * d.profile(r[i]);
        }
        benchmark::DoNotOptimize(sum);
    }
    state.counters["radii_per_s"] = benchmark::Counter(double(state.iterations()) * double(n), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_subsurface_profile)->ArgNames({"vector"})->DenseRange(0, 1);

#if defined(AAF_SOURCE_DIR)
void BM_subsurface_map_bvh(benchmark::State& state) {
    static const aaf_examples::triangle_mesh mesh =
        aaf_examples::load_triangles(std::filesystem::path(AAF_SOURCE_DIR) / "assets" / "meshes" / "bun_zipper.ply");
    static const aaf_examples::bvh tree(mesh.vertices, mesh.triangles);
    glm::vec3 lo(INFINITY), hi(-INFINITY);
    for (const glm::vec3& v : mesh.vertices) lo = glm::min(lo, v), hi = glm::max(hi, v);
    const auto res = static_cast<std::size_t>(state.range(0));
    const ortho proj = ortho::looking_along(glm::normalize(glm::vec3(0.5f, -1, 0.3f)), 0.5f * (lo + hi), 0.5f * glm::length(hi - lo), res);
    aaf::thread_pool pool(static_cast<std::size_t>(state.range(1)));
    std::size_t hits = 0;
    for (auto _ : state) {
        const ss::light_map<ortho> map =
            ss::build_light_map(proj, ss::map_light<float>{glm::vec3(1)}, 1.3f, tree, ss::reconstruct_normals{}, pool);
        benchmark::DoNotOptimize(map.positions[0].data());
        hits = 0;
        for (std::size_t y = 0; y < res; ++y)
            for (std::size_t x = 0; x < res; ++x) hits += std::isfinite(map.positions[0](x, y).x) ? 1 : 0;
    }
    state.counters["time_per_texel"] =
        benchmark::Counter(double(state.iterations()) * double(res * res), benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
    state.counters["covered"] = double(hits) / double(res * res);
}
BENCHMARK(BM_subsurface_map_bvh)->ArgNames({"res", "threads"})->ArgsProduct({{512}, {1, 2}})->Unit(benchmark::kMillisecond)->UseRealTime();
#endif

}  // namespace
