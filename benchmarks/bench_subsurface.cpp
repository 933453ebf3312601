// SPDX-License-Identifier: MIT
// Subsurface benchmarks (include/aaf/subsurface/): the gather at 640×480 with 150 samples per pixel on 1 and 2
// threads, for both disc samplings and both profiles, and building a light-space map through a tracer.
//
//   BM_subsurface_gather/sampling:S/profile:P/threads:T   samples_per_s (disc samples), time_per_px
//   BM_subsurface_map/res:R/threads:T                      time_per_texel (one ray + normal + E·F_t per texel)
//
// The scene is a 300 mm marble slab lit at 30° (tests/support/box_scene.hpp: an analytic box tracer, so map
// building measures aaf's per-texel work plus a trivial ray-box test, not a BVH).
//
//   scripts/bench 'BM_subsurface'

#include <benchmark/benchmark.h>

#include <vector>

#include <aaf/executor.hpp>
#include <aaf/subsurface.hpp>

#include "support/box_scene.hpp"

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
    ->ArgNames({"sampling", "profile", "threads"})
    ->ArgsProduct({{0, 1}, {0}, {1, 2}})
    ->Args({1, 1, 1})
    ->Args({1, 1, 2})
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

}  // namespace
