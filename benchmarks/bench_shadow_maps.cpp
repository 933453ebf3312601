// SPDX-License-Identifier: MIT
// Shadow maps (include/aaf/shadow_maps/): rendering a depth map through a tracer, and the lookup passes over
// a 1280×720 G-buffer, in the same binary as the guided filter (bench_filter.cpp: BM_filter/1280x720/...), so
// one run gives both figures side by side:
//
//   BM_shadow_map_render/<N>/threads:T      render_depth_map of an N×N orthographic map through an analytic
//                                           tracer (ground plane + 24 boxes, a nearest-hit query per texel)
//   BM_shadow_lookup/1280x720/threads:T/filter:F/aligned:A
//                                           shadow_lookup on bench_common's synthetic frame (a plane, gently
//                                           varying normals), 2048² unorm24 map, automatic bias;
//                                           F = 0 hard, 1 PCF 4×4 grid, 2 PCF 4×4 bilinear, 3 PCF 16-tap
//                                           rotated Poisson disc, 4 PCSS (16 blocker taps + 4×4 PCF);
//                                           A = 1 the map's rows run along the frame's rows, 0 across them
//
//   build/release/benchmarks/aaf_benchmarks --benchmark_filter='BM_shadow|BM_filter/1280x720/threads:./light_plane:0/guides:1'
//
// Counters: Mtexels_per_s (render), Mpx_per_s and taps_per_px (lookups; PCSS counts blocker + PCF taps).

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include <aaf/shadow_maps.hpp>

#include "bench_common.hpp"

namespace {

/// The ground y = 0 over the synthetic frame ([0, 12.8] × [0, 7.2]) and 24 boxes above it.
struct box_scene {
    struct box {
        glm::vec3 lo, hi;
    };
    std::vector<box> boxes;
    box_scene() {
        std::uint32_t h = 12345;
        const auto rnd = [&h] {
            h = aaf::detail::hash32(h + 0x9e3779b9U);
            return aaf::detail::to_unit<float>(h);
        };
        for (int i = 0; i < 24; ++i) {
            const glm::vec3 c(12.8f * rnd(), 0.2f + 0.8f * rnd(), 7.2f * rnd());
            const glm::vec3 half(0.1f + 0.4f * rnd(), 0.05f + 0.1f * rnd(), 0.1f + 0.4f * rnd());
            boxes.push_back({c - half, c + half});
        }
    }
    [[nodiscard]] float nearest_occluder(const aaf::shadow_segment<float>& r) const {
        float best = aaf::no_occluder<float>;
        if (r.direction.y != 0.0f) {
            const float t = -r.origin.y / r.direction.y;
            if (t > 0 && t < r.length) best = t;
        }
        for (const box& b : boxes) {
            float t0 = 0, t1 = std::min(best, r.length);
            for (int a = 0; a < 3 && t0 <= t1; ++a) {
                const float inv = 1.0f / r.direction[a];
                float ta = (b.lo[a] - r.origin[a]) * inv, tb = (b.hi[a] - r.origin[a]) * inv;
                if (ta > tb) std::swap(ta, tb);
                t0 = std::max(t0, ta), t1 = std::min(t1, tb);
            }
            if (t0 <= t1 && t0 > 0) best = t0;
        }
        return best;
    }
};

const box_scene& scene() {
    static const box_scene s;
    return s;
}

/// The light's view, fitted to the scene. `aligned`: the map's rows run along the frame's rows (world x), so a
/// row of pixels reads a few rows of texels; otherwise its rows run along world z (fit_orthographic_view's
/// own choice of up for this direction), the transposed case, where consecutive pixels read texels a map
/// row apart: the worst case for caches, and as likely in a real renderer as the aligned one.
aaf::light_view<float> view(bool aligned) {
    std::vector<glm::vec3> corners;
    for (const float x : {0.0f, 12.8f})
        for (const float z : {0.0f, 7.2f})
            for (const float y : {0.0f, 1.2f}) corners.emplace_back(x, y, z);
    aaf::light_view<float> v = aaf::fit_orthographic_view(glm::vec3(-0.3f, -1.0f, -0.2f), corners);
    if (aligned) {  // refit with the up hint along z, so that right (the map's rows) is along x
        const aaf::light_frame<float> f(v);
        v.up = glm::vec3(0, 0, 1);
        const aaf::light_frame<float> g(v);
        const glm::vec3 centre = v.eye + 0.5f * (v.near_plane + v.far_plane) * f.forward;
        float hx = 0, hy = 0;
        for (const glm::vec3& c : corners) {
            const glm::vec3 l = g.to_light(c) - g.to_light(centre);
            hx = std::max(hx, std::abs(l.x)), hy = std::max(hy, std::abs(l.y));
        }
        v.half_width = hx * 1.01f, v.half_height = hy * 1.01f;
    }
    return v;
}

/// The lookups' maps, rendered once.
const aaf::depth_map<float>& lookup_map(bool aligned) {
    static std::unique_ptr<aaf::depth_map<float>> maps[2];
    auto& map = maps[aligned ? 1 : 0];
    if (!map) {
        map = std::make_unique<aaf::depth_map<float>>(2048, 2048, view(aligned), aaf::depth_format::unorm24);
        aaf::thread_pool pool(2);
        aaf::render_depth_map(*map, scene(), pool);
    }
    return *map;
}

void BM_shadow_map_render(benchmark::State& state) {
    const auto n = static_cast<std::size_t>(state.range(0));
    aaf::depth_map<float> map(n, n, view(false), aaf::depth_format::unorm24);
    aaf::thread_pool pool(static_cast<std::size_t>(state.range(1)));
    for (auto _ : state) {
        benchmark::DoNotOptimize(aaf::render_depth_map(map, scene(), pool));
        benchmark::ClobberMemory();
    }
    state.counters["Mtexels_per_s"] = benchmark::Counter(static_cast<double>(state.iterations()) * static_cast<double>(n * n) * 1e-6,
                                                         benchmark::Counter::kIsRate);
    state.counters["map_bytes"] = static_cast<double>(map.gpu_bytes());
}

void BM_shadow_lookup(benchmark::State& state) {
    static const aaf_bench::synthetic_frame<float> frame(1280, 720);
    aaf::lookup_settings<float> s;
    double taps = 16;
    switch (state.range(1)) {
        case 0: s.filter = aaf::shadow_filter::hard, taps = 1; break;
        case 1: break;
        case 2: s.pcf.bilinear = true, taps = 64; break;
        case 3: s.pcf.pattern = aaf::pcf_pattern::rotated_poisson, s.pcf.radius = 2.5f; break;
        default:
            s.filter = aaf::shadow_filter::pcss;
            s.pcss.light_angle = 0.05f;
            taps = 32;
            break;
    }
    const aaf::depth_map<float>& map = lookup_map(state.range(2) != 0);
    aaf::image<float> out(frame.w, frame.h);
    aaf::thread_pool pool(static_cast<std::size_t>(state.range(0)));
    for (auto _ : state) {
        aaf::shadow_lookup(map.map_view(), frame.gbuffer(), s, out.view(), {}, pool);
        benchmark::DoNotOptimize(out.data());
        benchmark::ClobberMemory();
    }
    double lit = 0;
    for (std::size_t i = 0; i < out.size(); ++i) lit += static_cast<double>(out.data()[i]);
    state.counters["mean_visibility"] = lit / static_cast<double>(out.size());
    state.counters["taps_per_px"] = taps;
    state.counters["Mpx_per_s"] = benchmark::Counter(static_cast<double>(state.iterations()) * static_cast<double>(frame.w * frame.h) * 1e-6,
                                                     benchmark::Counter::kIsRate);
}

void register_all() {
    benchmark::RegisterBenchmark("BM_shadow_map_render", BM_shadow_map_render)
        ->ArgsProduct({{1024, 2048}, {1, 2}})->ArgNames({"", "threads"})->Unit(benchmark::kMillisecond)->UseRealTime();
    benchmark::RegisterBenchmark("BM_shadow_lookup/1280x720", BM_shadow_lookup)
        ->ArgsProduct({{1, 2}, {0, 1, 2, 3, 4}, {1, 0}})->ArgNames({"threads", "filter", "aligned"})->Unit(benchmark::kMillisecond)->UseRealTime();
}

[[maybe_unused]] const bool registered = (register_all(), true);

}  // namespace
