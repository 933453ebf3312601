// SPDX-License-Identifier: MIT
// Core benchmarks: the library's own per-ray overhead (sampling + segments + statistics, with a tracer
// that costs nothing), the formulas and the sampler per pixel, and the guided filter at 1280×720 next to a
// plain copy of the frame (the bandwidth anchor), on 1 and 2 threads.
//
//   build/release/benchmarks/aaf_benchmarks --benchmark_repetitions=5 --benchmark_report_aggregates_only=true

#include <benchmark/benchmark.h>

#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <vector>

#include <aaf/aaf.hpp>

namespace {

constexpr std::size_t W = 1280, H = 720;

/// A tracer that answers at once: isolates aaf's per-ray work from tracing. `random_hits` decides hit or
/// miss from a bit of the ray direction (unpredictable branches, the worst case); otherwise the left half
/// of the frame is in shadow (coherent, like real shadows).
struct instant_tracer {
    bool random_hits = false;
    aaf::occluder_span<float> occluder_span(const aaf::shadow_segment<float>& s) const {
        const bool hit = random_hits ? (std::bit_cast<std::uint32_t>(s.direction.x) & 1u) != 0 : s.origin.x < 1.28f;
        return hit ? aaf::occluder_span<float>{0.5f * s.length, 0.5f * s.length} : aaf::occluder_span<float>{};
    }
};

struct frame_data {
    std::size_t w, h;
    aaf::image<glm::vec3> positions, normals;
    aaf::image<float> pixel_size, visibility, beta;
    aaf::image<std::uint32_t> ids;

    frame_data(std::size_t w_, std::size_t h_)
        : w(w_), h(h_), positions(w_, h_), normals(w_, h_, glm::vec3(0, 1, 0)), pixel_size(w_, h_, 0.01f),
          visibility(w_, h_), beta(w_, h_), ids(w_, h_, 1u) {
        for (std::size_t y = 0; y < h; ++y)
            for (std::size_t x = 0; x < w; ++x) {
                const float fx = static_cast<float>(x), fy = static_cast<float>(y);
                positions(x, y) = {0.01f * fx, 0.0f, 0.01f * fy};
                visibility(x, y) = 0.5f + 0.5f * std::sin(0.05f * fx) * std::cos(0.03f * fy);
                // A smooth β field between 1 and 10 pixels (0.01 world units per pixel).
                beta(x, y) = 0.01f * (5.5f + 4.5f * std::sin(0.004f * fx + 0.006f * fy));
                ids(x, y) = (x / 200 + y / 150) % 3;
                normals(x, y) = glm::normalize(glm::vec3(0.1f * std::sin(0.01f * fx), 1.0f, 0.0f));
            }
    }
    [[nodiscard]] aaf::gbuffer<float> gbuffer() const { return {positions.cview(), normals.cview(), pixel_size.cview(), {}}; }
};

void BM_copy_frame(benchmark::State& state) {
    std::vector<float> a(W * H, 1.0f), b(W * H);
    for (auto _ : state) {
        std::memcpy(b.data(), a.data(), a.size() * sizeof(float));
        benchmark::DoNotOptimize(b.data());
        benchmark::ClobberMemory();
    }
    state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * W * H));
    state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * W * H * 2 * sizeof(float)));
}
BENCHMARK(BM_copy_frame)->Unit(benchmark::kMillisecond);

/// ns of library work per shadow ray: sample generation, segment set-up, offsetting, statistics.
void BM_per_ray_overhead(benchmark::State& state) {
    const frame_data f(256, 256);
    aaf::image<aaf::occlusion_stats<float>> stats(f.w, f.h);
    aaf::sampling_settings s;
    s.initial_samples = s.max_samples = static_cast<std::uint32_t>(state.range(0));
    s.pattern = static_cast<aaf::sample_pattern>(state.range(1));
    const aaf::area_light<float> light{{-0.5f, 3.0f, -0.5f}, {1, 0, 0}, {0, 0, 1}};
    std::uint64_t rays = 0;
    for (auto _ : state) {
        stats.fill({});
        rays += aaf::gather_occlusion(f.gbuffer(), light, instant_tracer{state.range(2) != 0}, s, 0, s.initial_samples,
                                      stats.view());
        benchmark::DoNotOptimize(stats.data());
    }
    // Seconds per ray, shown with an SI prefix (e.g. "26n" = 26 ns per ray).
    state.counters["time_per_ray"] = benchmark::Counter(static_cast<double>(rays),
                                                      benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
    state.SetItemsProcessed(static_cast<std::int64_t>(rays));
}
BENCHMARK(BM_per_ray_overhead)
    ->ArgsProduct({{9, 16, 64}, {0, 2}, {0, 1}})
    ->ArgNames({"spp", "pattern", "random_hits"})
    ->Unit(benchmark::kMillisecond);

void BM_formulas_per_pixel(benchmark::State& state) {
    std::vector<aaf::slope_pair<float>> slopes(4096);
    for (std::size_t i = 0; i < slopes.size(); ++i) {
        const float a = 0.01f + 3.0f * static_cast<float>(i % 97) / 97.0f;
        slopes[i] = {a * 1.5f, a};
    }
    const aaf::formula_settings<float> fs{};
    for (auto _ : state)
        for (const auto& s : slopes) {
            benchmark::DoNotOptimize(aaf::filter_width(s, 0.5f, 0.01f, fs));
            benchmark::DoNotOptimize(aaf::sample_count(s, 0.5f, 0.01f, fs));
        }
    state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * slopes.size()));
}
BENCHMARK(BM_formulas_per_pixel);

void BM_sampler_per_sample(benchmark::State& state) {
    std::vector<glm::vec2> out(static_cast<std::size_t>(state.range(0)));
    const auto pattern = static_cast<aaf::sample_pattern>(state.range(1));
    std::uint32_t x = 0;
    for (auto _ : state) {
        aaf::generate_samples<float>(pattern, {x++, 7, 0, 0, 0}, out);
        benchmark::DoNotOptimize(out.data());
    }
    state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * out.size()));
}
BENCHMARK(BM_sampler_per_sample)->ArgsProduct({{9, 64}, {0, 1, 2}})->ArgNames({"n", "pattern"});

/// The guided separable filter at 1280×720, β smooth in [1, 10] px. Args: threads, offset space,
/// guides (0 none, 1 normals + IDs).
void BM_filter(benchmark::State& state) {
    static const frame_data f(W, H);
    aaf::image<float> out(W, H), scratch(W, H);
    aaf::filter_settings<float> fs;
    fs.space = state.range(1) ? aaf::offset_space::light_plane : aaf::offset_space::image;
    aaf::thread_pool pool(static_cast<std::size_t>(state.range(0)));
    const auto run = [&](const auto& g) {
        aaf::filter_visibility<float>(f.visibility.cview(), f.beta.cview(), f.pixel_size.cview(), out.view(), scratch.view(), g,
                                      fs, {0.0f, 1.0f, 0.0f}, pool);
    };
    for (auto _ : state) {
        if (state.range(2)) run(aaf::guides{f.normals.cview(), f.ids.cview(), f.positions.cview()});
        else run(aaf::guides<aaf::no_guide, aaf::no_guide, aaf::const_image_view<glm::vec3>>{{}, {}, f.positions.cview()});
        benchmark::DoNotOptimize(out.data());
    }
    // Taps per pixel per pass, for reading the throughput: 2·ceil(3β)+1 averaged over the frame.
    double taps = 0;
    for (std::size_t i = 0; i < f.beta.size(); ++i) taps += 2.0 * std::min(std::ceil(3.0 * static_cast<double>(f.beta.data()[i]) / 0.01), 24.0) + 1.0;
    state.counters["taps_per_px_pass"] = taps / static_cast<double>(f.beta.size());
    state.counters["Mpx_per_s"] = benchmark::Counter(static_cast<double>(state.iterations() * W * H) * 1e-6, benchmark::Counter::kIsRate);
}
BENCHMARK(BM_filter)
    ->ArgsProduct({{1, 2}, {0, 1}, {0, 1}})
    ->ArgNames({"threads", "light_plane", "guides"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// Recorded in the benchmark's context header (and JSON output): the flags this binary was built with.
#ifdef AAF_BUILD_FLAGS
[[maybe_unused]] const bool build_flags_recorded = [] {
    benchmark::AddCustomContext("aaf_build_flags", AAF_BUILD_FLAGS);
    return true;
}();
#endif

}  // namespace
