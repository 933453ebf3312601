// SPDX-License-Identifier: MIT
// Core benchmarks, in time per pixel / sample / ray: the library's own per-ray overhead (sampling +
// segments + statistics, with a tracer that costs nothing), the formulas, the sampler and the occlusion
// statistics (add_sample, merge, slopes). The filter is in bench_filter.cpp, the whole frame in bench_frame.cpp.
//
//   BM_per_ray_overhead/spp:N/pattern:P/random_hits:R   time_per_ray
//   BM_formulas_per_pixel                                time_per_px: filter_width + sample_count
//   BM_sampler_per_sample/n:N/pattern:P                  time_per_sample (one pixel's N samples per iteration)
//   BM_stats_add_sample                                  time_per_sample: occlusion_stats::add_sample
//   BM_stats_merge_slopes                                time_per_px: merge of two records + slopes()
//   BM_stats_per_pixel/samples:N                         time_per_px: N × add_sample, merge, slopes()
//
// The time_per_* counters are seconds per item shown with an SI prefix ("26n" = 26 ns).
//
//   scripts/bench 'BM_(per_ray|formulas|sampler|stats)'

#include <benchmark/benchmark.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <vector>

#include <aaf/aaf.hpp>

#include "bench_common.hpp"

namespace {

/// Seconds per item (`items` over the whole run), shown with an SI prefix: "26n" = 26 ns.
void per_item(benchmark::State& state, const char* name, double items) {
    state.counters[name] = benchmark::Counter(items, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

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

/// ns of library work per shadow ray: sample generation, segment set-up, offsetting, statistics.
void BM_per_ray_overhead(benchmark::State& state) {
    const aaf_bench::synthetic_frame<float> f(256, 256);
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
    per_item(state, "time_per_ray", static_cast<double>(rays));
    state.SetItemsProcessed(static_cast<std::int64_t>(rays));
}
BENCHMARK(BM_per_ray_overhead)
    ->ArgsProduct({{9, 16, 64}, {0, 1, 2}, {0, 1}})
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
    per_item(state, "time_per_px", static_cast<double>(state.iterations()) * static_cast<double>(slopes.size()));
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
    per_item(state, "time_per_sample", static_cast<double>(state.iterations()) * static_cast<double>(out.size()));
}
BENCHMARK(BM_sampler_per_sample)->ArgsProduct({{9, 64}, {0, 1, 2}})->ArgNames({"n", "pattern"});

/// Sample records of a penumbra: `receivers` pixels × `per_pixel` samples, about 40 % occluded, with
/// varied occluder distances (so the min/max updates are not predictable).
struct sample_batch {
    struct sample {
        float weight, d1, length;
        aaf::occluder_span<float> hit;
    };
    std::vector<sample> samples;
    sample_batch(std::size_t receivers, std::size_t per_pixel) : samples(receivers * per_pixel) {
        std::uint32_t r = 12345u;
        const auto next = [&r] { return static_cast<float>((r = r * 1664525u + 1013904223u) >> 8) * 0x1p-24f; };
        for (std::size_t i = 0; i < samples.size(); ++i) {
            const float d1 = 2.0f + next(), len = d1 * (1.0f + 0.2f * next());
            const float t = len * (0.1f + 0.8f * next());
            samples[i] = {1.0f, d1, len, next() < 0.4f ? aaf::occluder_span<float>{t, std::min(len, t * 1.2f)} : aaf::occluder_span<float>{}};
        }
    }
};

void BM_stats_add_sample(benchmark::State& state) {
    const sample_batch batch(4096, 1);
    for (auto _ : state) {
        aaf::occlusion_stats<float> st;
        for (const auto& s : batch.samples) st.add_sample(s.weight, s.d1, s.length, s.hit);
        benchmark::DoNotOptimize(st);
    }
    per_item(state, "time_per_sample", static_cast<double>(state.iterations()) * static_cast<double>(batch.samples.size()));
}
BENCHMARK(BM_stats_add_sample);

/// Per pixel: the merge of an initial and an adaptive record and the slopes of the result.
void BM_stats_merge_slopes(benchmark::State& state) {
    constexpr std::size_t pixels = 4096;
    const sample_batch batch(pixels, 8);
    std::vector<aaf::occlusion_stats<float>> a(pixels), b(pixels);
    for (std::size_t i = 0; i < pixels; ++i)
        for (std::size_t k = 0; k < 4; ++k) {
            const auto& s = batch.samples[8 * i + k];
            const auto& t = batch.samples[8 * i + 4 + k];
            a[i].add_sample(s.weight, s.d1, s.length, s.hit);
            b[i].add_sample(t.weight, t.d1, t.length, t.hit);
        }
    std::vector<aaf::slope_pair<float>> out(pixels);
    for (auto _ : state) {
        for (std::size_t i = 0; i < pixels; ++i) out[i] = aaf::slopes(aaf::merge(a[i], b[i]), 1e6f);
        benchmark::DoNotOptimize(out.data());
        benchmark::ClobberMemory();
    }
    per_item(state, "time_per_px", static_cast<double>(state.iterations()) * static_cast<double>(pixels));
}
BENCHMARK(BM_stats_merge_slopes);

/// A pixel's whole statistics work at N samples (e.g. ~20, the default frame's mean): N add_sample into
/// the initial/adaptive records (half each), the merge and slopes().
void BM_stats_per_pixel(benchmark::State& state) {
    constexpr std::size_t pixels = 1024;
    const auto n = static_cast<std::size_t>(state.range(0));
    const sample_batch batch(pixels, n);
    std::vector<aaf::slope_pair<float>> out(pixels);
    for (auto _ : state) {
        for (std::size_t i = 0; i < pixels; ++i) {
            aaf::occlusion_stats<float> a, b;
            for (std::size_t k = 0; k < n / 2; ++k) {
                const auto& s = batch.samples[n * i + k];
                a.add_sample(s.weight, s.d1, s.length, s.hit);
            }
            for (std::size_t k = n / 2; k < n; ++k) {
                const auto& s = batch.samples[n * i + k];
                b.add_sample(s.weight, s.d1, s.length, s.hit);
            }
            out[i] = aaf::slopes(aaf::merge(a, b), 1e6f);
        }
        benchmark::DoNotOptimize(out.data());
        benchmark::ClobberMemory();
    }
    per_item(state, "time_per_px", static_cast<double>(state.iterations()) * static_cast<double>(pixels));
}
BENCHMARK(BM_stats_per_pixel)->ArgName("samples")->Arg(9)->Arg(20);

}  // namespace
