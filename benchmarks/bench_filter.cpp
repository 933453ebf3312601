// SPDX-License-Identifier: MIT
// The visibility filter (aaf::filter_visibility) and slope spreading (aaf::spread_slopes), on a synthetic
// frame (bench_common.hpp: a plane, smooth visibility, β smooth in [1, 10] px, three IDs, varying normals),
// next to a memory-copy baseline in the same binary. docs/BENCHMARKS.md has the results and how to read them.
//
//   BM_copy_frame/<W>x<H>/threads:T             memcpy of one float plane (cache-resident bandwidth)
//   BM_copy_dram/64MiB/threads:T                memcpy of 64 MiB (DRAM bandwidth)
//   BM_filter/<W>x<H>/threads:T/light_plane:L/guides:G
//                                               float, truncation 3, max_radius 24; guides 0 = none,
//                                               1 = normals + IDs (light_plane needs positions either way)
//   BM_filter_double/1280x720/threads:T/light_plane:L/guides:1     the same in double
//   BM_filter_radius/1280x720/threads:2/truncation:K/max_radius:R  the radius policy (image space, guides 1)
//   BM_filter_small_beta/640x480/...            β in [0.5, 2] px: the library, the reference separable
//   BM_filter_reference_separable/640x480/...   filter and the reference NON-separable 2-D filter
//   BM_filter_reference_2d/640x480/...          (tests/reference/reference_filter.hpp) on the same frame
//   BM_spread_slopes/1280x720/threads:T/ids:I   radius 10 (the default spread_radius)
//
// Every filter case reports Mpx_per_s, taps_per_px_pass (2r + 1 averaged over the frame, r from the
// library's rule min(ceil(truncation·β/d), max_radius)), Gtaps_per_s (both passes) and bytes_per_second
// computed from the bytes the filter must touch (each input plane read once and the output written once
// per pass) — divide by BM_copy_frame's bytes_per_second for the fraction of copy bandwidth.
//
//   build/release/benchmarks/aaf_benchmarks --benchmark_filter='BM_filter/1280x720/threads:2/light_plane:0/guides:1'

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <map>
#include <memory>
#include <string>
#include <tuple>
#include <vector>

#include <aaf/aaf.hpp>

#include "bench_common.hpp"
#include "reference/reference_filter.hpp"

namespace {

using aaf_bench::frame_size;
using aaf_bench::synthetic_frame;

/// One synthetic frame per (precision, size, β range), built on first use.
template <class T>
const synthetic_frame<T>& get_frame(std::size_t w, std::size_t h, double beta_lo_px = 1.0, double beta_hi_px = 10.0) {
    static std::map<std::tuple<std::size_t, std::size_t, double, double>, std::unique_ptr<synthetic_frame<T>>> cache;
    auto& f = cache[{w, h, beta_lo_px, beta_hi_px}];
    if (!f) f = std::make_unique<synthetic_frame<T>>(w, h, beta_lo_px, beta_hi_px);
    return *f;
}

/// Sets the counters every filter benchmark reports. `bytes_per_px` is what one pass must touch per pixel.
void set_filter_counters(benchmark::State& state, std::size_t pixels, double taps_per_px_pass, double bytes_per_px_pass) {
    const auto frames = static_cast<double>(state.iterations());
    const auto px = static_cast<double>(pixels);
    state.counters["taps_per_px_pass"] = taps_per_px_pass;
    state.counters["Mpx_per_s"] = benchmark::Counter(frames * px * 1e-6, benchmark::Counter::kIsRate);
    state.counters["Gtaps_per_s"] = benchmark::Counter(frames * px * 2.0 * taps_per_px_pass * 1e-9, benchmark::Counter::kIsRate);
    state.SetBytesProcessed(static_cast<std::int64_t>(frames * px * 2.0 * bytes_per_px_pass));
}

/// Copies one float plane of the frame size (memcpy, split by rows over the threads): the machine's
/// bandwidth for the planes the filter streams. bytes_per_second counts the read and the write.
void BM_copy_frame(benchmark::State& state, frame_size size) {
    const std::size_t w = size.w, h = size.h;
    std::vector<float> a(w * h, 1.0f), b(w * h);
    aaf::thread_pool pool(static_cast<std::size_t>(state.range(0)));
    for (auto _ : state) {
        pool.parallel_for(h, [&](std::size_t y0, std::size_t y1) {
            std::memcpy(b.data() + y0 * w, a.data() + y0 * w, (y1 - y0) * w * sizeof(float));
        });
        benchmark::DoNotOptimize(b.data());
        benchmark::ClobberMemory();
    }
    const auto frames = static_cast<double>(state.iterations());
    state.counters["Mpx_per_s"] = benchmark::Counter(frames * static_cast<double>(w * h) * 1e-6, benchmark::Counter::kIsRate);
    state.SetBytesProcessed(static_cast<std::int64_t>(frames * static_cast<double>(w * h * 2 * sizeof(float))));
}

/// Copies 64 MiB (twice the last-level cache of the machines this was written on), split over the threads:
/// the DRAM bandwidth anchor. bytes_per_second counts the read and the write.
void BM_copy_dram(benchmark::State& state) {
    constexpr std::size_t bytes = std::size_t{64} << 20, rows = 1024, row = bytes / rows;
    std::vector<unsigned char> a(bytes, 1), b(bytes, 0);
    aaf::thread_pool pool(static_cast<std::size_t>(state.range(0)));
    for (auto _ : state) {
        pool.parallel_for(rows, [&](std::size_t r0, std::size_t r1) {
            std::memcpy(b.data() + r0 * row, a.data() + r0 * row, (r1 - r0) * row);
        });
        benchmark::DoNotOptimize(b.data());
        benchmark::ClobberMemory();
    }
    state.SetBytesProcessed(static_cast<std::int64_t>(static_cast<double>(state.iterations()) * 2.0 * bytes));
}

/// The library's separable filter on `f` with settings `fs`, `threads` threads, guides none (positions only,
/// which light_plane needs) or normals + IDs (+ positions).
template <class T>
void run_filter(benchmark::State& state, const synthetic_frame<T>& f, const aaf::filter_settings<T>& fs,
                std::size_t threads, bool with_guides) {
    aaf::image<T> out(f.w, f.h), scratch(f.w, f.h);
    aaf::filter_workspace<T> workspace;  // as a frame loop (frame_workspace) keeps it: no allocation per call
    aaf::thread_pool pool(threads);
    const auto run = [&](const auto& g) {
        aaf::filter_visibility<T>(f.visibility.cview(), f.beta.cview(), f.pixel_size.cview(), out.view(), scratch.view(),
                                  workspace, g, fs, {T(0), T(1), T(0)}, pool);
    };
    const auto frame = [&] {
        if (with_guides) run(aaf::guides{f.normals.cview(), f.ids.cview(), f.positions.cview()});
        else run(aaf::guides<aaf::no_guide, aaf::no_guide, aaf::const_image_view<glm::vec<3, T>>>{{}, {}, f.positions.cview()});
    };
    // One untimed call first, as a frame loop's workspace has served a frame before: the timed calls then
    // measure the filter, not the first touch of the workspace's pages (page faults, tens of MB).
    frame();
    for (auto _ : state) {
        frame();
        benchmark::DoNotOptimize(out.data());
        benchmark::ClobberMemory();
    }
    // Bytes one pass must touch per pixel: source, β, d and destination planes; normals and IDs with guides;
    // positions in light-plane mode.
    double bytes = 4.0 * sizeof(T);
    if (with_guides) bytes += 3.0 * sizeof(T) + sizeof(std::uint32_t);
    if (fs.space == aaf::offset_space::light_plane) bytes += 3.0 * sizeof(T);
    set_filter_counters(state, f.w * f.h, aaf_bench::mean_taps(f.beta, f.pixel_size, fs), bytes);
}

/// Args: threads, light_plane, guides.
template <class T>
void BM_filter(benchmark::State& state, frame_size size) {
    aaf::filter_settings<T> fs;
    fs.space = state.range(1) ? aaf::offset_space::light_plane : aaf::offset_space::image;
    run_filter<T>(state, get_frame<T>(size.w, size.h), fs, static_cast<std::size_t>(state.range(0)), state.range(2) != 0);
}

/// Args: threads, truncation, max_radius (image space, normals + IDs).
void BM_filter_radius(benchmark::State& state, frame_size size) {
    aaf::filter_settings<float> fs;
    fs.truncation = static_cast<float>(state.range(1));
    fs.max_radius = static_cast<std::uint32_t>(state.range(2));
    run_filter<float>(state, get_frame<float>(size.w, size.h), fs, static_cast<std::size_t>(state.range(0)), true);
}

// The small-β frame of the separable-versus-2-D comparison: β in [0.5, 2] px, so the 2-D reference's
// (2r + 1)² window stays small enough to finish in about a second per frame.
constexpr double small_beta_lo = 0.5, small_beta_hi = 2.0;

/// Args: threads, guides (image space). The library on the small-β frame.
void BM_filter_small_beta(benchmark::State& state, frame_size size) {
    run_filter<float>(state, get_frame<float>(size.w, size.h, small_beta_lo, small_beta_hi), {},
                      static_cast<std::size_t>(state.range(0)), state.range(1) != 0);
}

/// Args: guides. The reference implementations (one thread, double accumulation, one exp per tap):
/// `two_d` = the non-separable filter (taps_per_px_2d = (2r + 1)²), else the literal separable one.
void BM_filter_reference(benchmark::State& state, frame_size size, bool two_d) {
    const synthetic_frame<float>& f = get_frame<float>(size.w, size.h, small_beta_lo, small_beta_hi);
    const aaf::filter_settings<float> fs{};
    const auto run = [&](const auto& g) {
        return two_d ? aaf_ref::filter_2d<float>(f.visibility.cview(), f.beta.cview(), f.pixel_size.cview(), g, fs)
                     : aaf_ref::filter_separable<float>(f.visibility.cview(), f.beta.cview(), f.pixel_size.cview(), g, fs);
    };
    for (auto _ : state) {
        const aaf::image<double> out = state.range(0) ? run(aaf::guides{f.normals.cview(), f.ids.cview()}) : run(aaf::guides<>{});
        benchmark::DoNotOptimize(out.data());
    }
    set_filter_counters(state, f.w * f.h, aaf_bench::mean_taps(f.beta, f.pixel_size, fs),
                        4.0 * sizeof(float) + (state.range(0) ? 16.0 : 0.0));
    if (two_d) state.counters["taps_per_px_2d"] = aaf_bench::mean_taps(f.beta, f.pixel_size, fs, true);
}

/// Args: threads, ids. Slope spreading, radius 10, on slopes derived from the synthetic frame (pixels with
/// visibility below 0.5 are occluded, about half). Each iteration first restores the input slopes (a copy of
/// 8 bytes per pixel, included in the time), on the pool's threads: a copy on the calling thread alone was
/// a serial part of the 2-thread time (about 1 ms of 7 MiB, an eighth of the vectorised spreading).
void BM_spread_slopes(benchmark::State& state, frame_size size) {
    const synthetic_frame<float>& f = get_frame<float>(size.w, size.h);
    aaf::image<aaf::slope_pair<float>> input(f.w, f.h), slopes(f.w, f.h), scratch(f.w, f.h);
    for (std::size_t i = 0; i < input.size(); ++i)
        if (f.visibility.data()[i] < 0.5f) input.data()[i] = {1.0f + f.visibility.data()[i], 0.5f};
    constexpr std::uint32_t radius = 10;
    aaf::thread_pool pool(static_cast<std::size_t>(state.range(0)));
    for (auto _ : state) {
        pool.parallel_for(f.h, [&](std::size_t b, std::size_t e) {
            std::copy(input.data() + b * f.w, input.data() + e * f.w, slopes.data() + b * f.w);
        });
        if (state.range(1))
            aaf::spread_slopes<float>(slopes.view(), scratch.view(), radius,
                                      aaf::guides<aaf::no_guide, aaf::const_image_view<std::uint32_t>, aaf::no_guide>{{}, f.ids.cview(), {}}, pool);
        else aaf::spread_slopes<float>(slopes.view(), scratch.view(), radius, aaf::guides<>{}, pool);
        benchmark::DoNotOptimize(slopes.data());
        benchmark::ClobberMemory();
    }
    set_filter_counters(state, f.w * f.h, 2.0 * radius + 1.0,
                        3.0 * sizeof(aaf::slope_pair<float>) + (state.range(1) ? sizeof(std::uint32_t) : 0.0));
}

void register_all() {
    using benchmark::RegisterBenchmark;
    const auto ms = benchmark::kMillisecond;
    const frame_size hd{1280, 720}, vga{640, 480};
    for (const frame_size& s : aaf_bench::frame_sizes)
        RegisterBenchmark(("BM_copy_frame/" + s.name()).c_str(), BM_copy_frame, s)
            ->ArgName("threads")->Arg(1)->Arg(2)->Unit(benchmark::kMicrosecond)->UseRealTime();
    RegisterBenchmark("BM_copy_dram/64MiB", BM_copy_dram)->ArgName("threads")->Arg(1)->Arg(2)->Unit(ms)->UseRealTime();
    for (const frame_size& s : aaf_bench::frame_sizes)
        RegisterBenchmark(("BM_filter/" + s.name()).c_str(), BM_filter<float>, s)
            ->ArgsProduct({{1, 2}, {0, 1}, {0, 1}})->ArgNames({"threads", "light_plane", "guides"})->Unit(ms)->UseRealTime();
    RegisterBenchmark(("BM_filter_double/" + hd.name()).c_str(), BM_filter<double>, hd)
        ->ArgsProduct({{1, 2}, {0, 1}, {1}})->ArgNames({"threads", "light_plane", "guides"})->Unit(ms)->UseRealTime();
    RegisterBenchmark(("BM_filter_radius/" + hd.name()).c_str(), BM_filter_radius, hd)
        ->ArgsProduct({{2}, {2, 3, 4}, {8, 24}})->ArgNames({"threads", "truncation", "max_radius"})->Unit(ms)->UseRealTime();
    RegisterBenchmark(("BM_filter_small_beta/" + vga.name()).c_str(), BM_filter_small_beta, vga)
        ->ArgsProduct({{1}, {1}})->ArgNames({"threads", "guides"})->Unit(ms)->UseRealTime();
    RegisterBenchmark(("BM_filter_reference_separable/" + vga.name()).c_str(), BM_filter_reference, vga, false)
        ->ArgName("guides")->Arg(1)->Unit(ms)->UseRealTime()->Iterations(1);
    RegisterBenchmark(("BM_filter_reference_2d/" + vga.name()).c_str(), BM_filter_reference, vga, true)
        ->ArgName("guides")->Arg(1)->Unit(ms)->UseRealTime()->Iterations(1);
    RegisterBenchmark(("BM_spread_slopes/" + hd.name()).c_str(), BM_spread_slopes, hd)
        ->ArgsProduct({{1, 2}, {0, 1}})->ArgNames({"threads", "ids"})->Unit(ms)->UseRealTime();
}

[[maybe_unused]] const bool registered = (register_all(), true);

}  // namespace
