// SPDX-License-Identifier: MIT
// The examples' BVH (examples/common/bvh.hpp): build time, and shadow rays per second for the three tracer
// queries (occluder_span, nearest_occluder, occluded) on 1 and 2 threads, on every shared mesh: the bunny,
// plant, bench, window blinds and Cornell box from assets/meshes, and the 346k-triangle Armadillo and the
// 300k-triangle sports car when they are available (they are not in the repository: AAF_SPORTSCAR=<file>,
// or the file in $AAF_SCENES_DIR, default <source>/../shared/scenes; skipped with an error otherwise).
//
// Segments run from random points on a ground plane under the mesh (its lowest point) to random points on
// a rectangular light above it, half the mesh's footprint wide, one mesh height above its top; the ground
// is twice the footprint, so there are lit, penumbra and umbra samples.
//
// With Embree (AAF_WITH_EMBREE), BM_tracers/<query>/<mesh> traces the same segments with the BVH and with
// Embree (examples/common/embree_tracer.hpp: single rays, and 16-wide packets of consecutive segments) taking
// turns within each iteration, on the bunny, plant, car and Armadillo: nearest hit (nearest_occluder) and any
// hit (occluded), 1 and 2 threads. Counters: bvh_Mrays/s; embree_Mrays/s and embree16_Mrays/s (single rays and
// packets, on the robust scene the examples use: watertight like the BVH); embree_fast_Mrays/s (single rays,
// Embree's default scene flags, not watertight); bvh/embree and bvh/embree_fast, the BVH's rays per second over
// Embree's single-ray ones (wall time), and bvh/embree_cpu, bvh/embree_fast_cpu, the same in process CPU time
// (robust to other load on the machine). The iteration time is the sum of the four.
//
//   build/release/benchmarks/aaf_benchmarks --benchmark_filter=bvh
//   AAF_SCENES_DIR=/work/shared/scenes build/release/benchmarks/aaf_benchmarks --benchmark_filter=BM_tracers

#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <ctime>
#include <exception>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <span>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <aaf/tracer.hpp>

#include "common/bvh.hpp"
#include "common/mesh_io.hpp"
#if AAF_EXAMPLES_EMBREE
#include "common/embree_tracer.hpp"
#endif

namespace {

namespace fs = std::filesystem;
using aaf_examples::bvh;
using segment = aaf::shadow_segment<float>;

/// The shared meshes that are too large for the repository: used when present, skipped otherwise.
bool optional_mesh(const std::string& name) { return name == "sportsCar.obj" || name == "Armadillo.ply"; }

/// Where a benchmark mesh may be, in order of preference (only the optional ones have more than one place).
std::vector<fs::path> mesh_candidates(const std::string& name) {
    const fs::path assets = fs::path(AAF_SOURCE_DIR) / "assets" / "meshes";
    if (!optional_mesh(name)) return {assets / name};
    std::vector<fs::path> candidates;
    if (const char* file = std::getenv("AAF_SPORTSCAR")) candidates.emplace_back(file);
    candidates.push_back(assets / name);
    if (const char* dir = std::getenv("AAF_SCENES_DIR")) candidates.push_back(fs::path(dir) / name);
    candidates.push_back((fs::path(AAF_SOURCE_DIR) / ".." / "shared" / "scenes" / name).lexically_normal());
    return candidates;
}

/// A loaded mesh, its BVH and a batch of shadow segments; loaded once per process.
struct scene {
    aaf_examples::triangle_mesh mesh;
    std::unique_ptr<bvh> tree;
#if AAF_EXAMPLES_EMBREE
    std::unique_ptr<aaf_examples::embree_tracer> embree, embree_fast;  // robust (the examples') and default scene flags
#endif
    std::vector<segment> segments;
    std::string error;  // non-empty: the mesh is unavailable
};

const scene& get_scene(const std::string& name) {
    static std::map<std::string, scene> cache;
    const auto found = cache.find(name);
    if (found != cache.end()) return found->second;
    scene& s = cache[name];
    fs::path path;
    for (const fs::path& p : mesh_candidates(name))
        if (path.empty() && fs::is_regular_file(p)) path = p;
    if (path.empty()) {
        s.error = name + " not found; tried:";
        for (const fs::path& p : mesh_candidates(name)) s.error += " " + p.string();
        if (optional_mesh(name)) s.error += " (set AAF_SCENES_DIR=<dir>" + std::string(name == "sportsCar.obj" ? " or AAF_SPORTSCAR=<file>" : "") + ")";
        return s;
    }
    try {
        s.mesh = aaf_examples::load_triangles(path);
        s.tree = std::make_unique<bvh>(s.mesh.vertices, s.mesh.triangles);
#if AAF_EXAMPLES_EMBREE
        s.embree = std::make_unique<aaf_examples::embree_tracer>(s.mesh.vertices, s.mesh.triangles);
        s.embree_fast = std::make_unique<aaf_examples::embree_tracer>(s.mesh.vertices, s.mesh.triangles,
                                                                      aaf_examples::embree_tracer_options{.robust = false});
#endif
    } catch (const std::exception& e) {
        s.error = e.what();
        return s;
    }
    glm::vec3 lo(std::numeric_limits<float>::infinity()), hi(-lo);
    for (const glm::vec3& v : s.mesh.vertices) lo = glm::min(lo, v), hi = glm::max(hi, v);
    const glm::vec3 centre = 0.5f * (lo + hi), size = hi - lo;
    std::mt19937 rng(42);
    std::uniform_real_distribution<float> u(-0.5f, 0.5f);
    const std::size_t n = 256;  // receivers: one jittered point per cell of an n×n grid, in scanline order
    s.segments.resize(n * n);
    for (std::size_t i = 0; i < n * n; ++i) {
        segment& seg = s.segments[i];
        const float gx = (static_cast<float>(i % n) + 0.5f + u(rng)) / static_cast<float>(n) - 0.5f;
        const float gz = (static_cast<float>(i / n) + 0.5f + u(rng)) / static_cast<float>(n) - 0.5f;
        const glm::vec3 ground(centre.x + 2.0f * size.x * gx, lo.y, centre.z + 2.0f * size.z * gz);
        const glm::vec3 light(centre.x + 0.5f * size.x * u(rng), hi.y + size.y, centre.z + 0.5f * size.z * u(rng));
        seg.length = glm::length(light - ground);
        seg.direction = (light - ground) / seg.length;
        seg.origin = ground;
    }
    return s;
}

/// Runs `trace(segment) -> count` over the batch, split over `threads` threads (the caller's included).
template <class Trace>
std::size_t run_batch(const std::vector<segment>& segments, unsigned threads, Trace trace) {
    std::vector<std::size_t> counts(threads, 0);
    const auto work = [&](unsigned t) {
        const std::size_t first = segments.size() * t / threads, last = segments.size() * (t + 1) / threads;
        std::size_t c = 0;
        for (std::size_t i = first; i < last; ++i) c += trace(segments[i]);
        counts[t] = c;
    };
    std::vector<std::thread> workers;
    for (unsigned t = 1; t < threads; ++t) workers.emplace_back(work, t);
    work(0);
    for (std::thread& w : workers) w.join();
    std::size_t total = 0;
    for (const std::size_t c : counts) total += c;
    return total;
}

void BM_bvh_build(benchmark::State& state, const std::string& name) {
    const scene& s = get_scene(name);
    if (!s.error.empty()) {
        state.SkipWithError(s.error.c_str());
        return;
    }
    const aaf_examples::bvh_build_options options{4, static_cast<unsigned>(state.range(0))};
    for (auto _ : state) {
        const bvh tree(s.mesh.vertices, s.mesh.triangles, options);
        benchmark::DoNotOptimize(tree.nodes().data());
    }
    state.counters["triangles"] = static_cast<double>(s.tree->triangle_count());
    state.counters["nodes"] = static_cast<double>(s.tree->nodes().size());
    state.counters["depth"] = s.tree->depth();
    state.counters["Mtris/s"] = benchmark::Counter(static_cast<double>(state.iterations()) *
                                                       static_cast<double>(s.mesh.triangles.size()) * 1e-6,
                                                   benchmark::Counter::kIsRate);
}

enum class query { occluder_span, nearest_occluder, occluded };

void BM_bvh_shadow(benchmark::State& state, const std::string& name, query q) {
    const scene& s = get_scene(name);
    if (!s.error.empty()) {
        state.SkipWithError(s.error.c_str());
        return;
    }
    const bvh& tree = *s.tree;
    const auto threads = static_cast<unsigned>(state.range(0));
    std::size_t occluded = 0;
    for (auto _ : state) {
        switch (q) {
        case query::occluder_span:
            occluded = run_batch(s.segments, threads, [&](const segment& g) { return std::size_t{tree.occluder_span(g).hit()}; });
            break;
        case query::nearest_occluder:
            occluded = run_batch(s.segments, threads, [&](const segment& g) {
                return std::size_t{tree.nearest_occluder(g) != aaf::no_occluder<float>};
            });
            break;
        case query::occluded:
            occluded = run_batch(s.segments, threads, [&](const segment& g) { return std::size_t{tree.occluded(g)}; });
            break;
        }
        benchmark::DoNotOptimize(occluded);
    }
    const double rays = static_cast<double>(state.iterations()) * static_cast<double>(s.segments.size());
    state.counters["Mrays/s"] = benchmark::Counter(rays * 1e-6, benchmark::Counter::kIsRate);
    state.counters["occluded"] = static_cast<double>(occluded) / static_cast<double>(s.segments.size());
    state.counters["triangles"] = static_cast<double>(tree.triangle_count());
}

#if AAF_EXAMPLES_EMBREE
/// Runs `trace(first, last) -> count` over the batch in chunks of `chunk` segments (a packet tracer's unit),
/// split over `threads` threads as run_batch does.
template <class Trace>
std::size_t run_chunks(const std::vector<segment>& segments, unsigned threads, std::size_t chunk, Trace trace) {
    const std::size_t chunks = (segments.size() + chunk - 1) / chunk;
    std::vector<std::size_t> counts(threads, 0);
    const auto work = [&](unsigned t) {
        std::size_t c = 0;
        for (std::size_t k = chunks * t / threads; k < chunks * (t + 1) / threads; ++k)
            c += trace(k * chunk, std::min(segments.size(), (k + 1) * chunk));
        counts[t] = c;
    };
    std::vector<std::thread> workers;
    for (unsigned t = 1; t < threads; ++t) workers.emplace_back(work, t);
    work(0);
    for (std::thread& w : workers) w.join();
    std::size_t total = 0;
    for (const std::size_t c : counts) total += c;
    return total;
}

/// The BVH and Embree on the same segments, side by side: each iteration traces the batch with each tracer
/// (the order alternating between iterations), so that a change in the machine's load hits both alike.
void BM_tracers(benchmark::State& state, const std::string& name, query q) {
    const scene& s = get_scene(name);
    if (!s.error.empty()) {
        state.SkipWithError(s.error.c_str());
        return;
    }
    const bvh& tree = *s.tree;
    const aaf_examples::embree_tracer& embree = *s.embree;
    const aaf_examples::embree_tracer& embree_fast = *s.embree_fast;
    const auto threads = static_cast<unsigned>(state.range(0));
    using clock = std::chrono::steady_clock;
    double seconds[4] = {0, 0, 0, 0};  // BVH, Embree single rays, Embree packets, Embree single rays without ROBUST
    double cpu_seconds[4] = {0, 0, 0, 0};  // the same in CPU time of the process (all its threads)
    const auto cpu_now = [] {
        timespec t{};
        clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
        return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
    };
    std::size_t occluded[4] = {0, 0, 0, 0};
    const auto run = [&](int which) {
        const clock::time_point t0 = clock::now();
        const double cpu0 = cpu_now();
        std::size_t c = 0;
        if (which == 0 && q == query::occluded) {
            c = run_batch(s.segments, threads, [&](const segment& g) { return std::size_t{tree.occluded(g)}; });
        } else if (which == 0) {
            c = run_batch(s.segments, threads, [&](const segment& g) { return std::size_t{tree.nearest_occluder(g) != aaf::no_occluder<float>}; });
        } else if (which == 1 && q == query::occluded) {
            c = run_batch(s.segments, threads, [&](const segment& g) { return std::size_t{embree.occluded(g)}; });
        } else if (which == 1) {
            c = run_batch(s.segments, threads, [&](const segment& g) { return std::size_t{embree.nearest_occluder(g) != aaf::no_occluder<float>}; });
        } else if (which == 3 && q == query::occluded) {
            c = run_batch(s.segments, threads, [&](const segment& g) { return std::size_t{embree_fast.occluded(g)}; });
        } else if (which == 3) {
            c = run_batch(s.segments, threads, [&](const segment& g) { return std::size_t{embree_fast.nearest_occluder(g) != aaf::no_occluder<float>}; });
        } else {
            constexpr std::size_t n = aaf_examples::embree_tracer::packet_size;
            c = run_chunks(s.segments, threads, n, [&](std::size_t first, std::size_t last) {
                const std::span<const segment> in(s.segments.data() + first, last - first);
                std::size_t hits = 0;
                if (q == query::occluded) {
                    bool out[n];
                    embree.occluded_batch(in, std::span<bool>(out, in.size()));
                    for (std::size_t i = 0; i < in.size(); ++i) hits += out[i] ? 1 : 0;
                } else {
                    float out[n];
                    embree.nearest_batch(in, std::span<float>(out, in.size()));
                    for (std::size_t i = 0; i < in.size(); ++i) hits += out[i] != aaf::no_occluder<float> ? 1 : 0;
                }
                return hits;
            });
        }
        const double elapsed = std::chrono::duration<double>(clock::now() - t0).count();
        seconds[which] += elapsed;
        cpu_seconds[which] += cpu_now() - cpu0;
        occluded[which] = c;
        return elapsed;
    };
    bool bvh_first = true;
    for (auto _ : state) {
        double iteration = 0;
        for (int k = 0; k < 4; ++k) iteration += run(bvh_first ? k : 3 - k);
        bvh_first = !bvh_first;
        state.SetIterationTime(iteration);
    }
    const double rays = static_cast<double>(state.iterations()) * static_cast<double>(s.segments.size());
    state.counters["bvh_Mrays/s"] = rays * 1e-6 / seconds[0];
    state.counters["embree_Mrays/s"] = rays * 1e-6 / seconds[1];
    state.counters["embree16_Mrays/s"] = rays * 1e-6 / seconds[2];
    state.counters["embree_fast_Mrays/s"] = rays * 1e-6 / seconds[3];
    state.counters["bvh/embree"] = seconds[1] / seconds[0];
    state.counters["bvh/embree_fast"] = seconds[3] / seconds[0];
    // The same ratios in CPU time: on a machine shared with other work, wall time also counts the time the
    // benchmark's threads waited for a core; CPU time does not.
    state.counters["bvh/embree_cpu"] = cpu_seconds[1] / cpu_seconds[0];
    state.counters["bvh/embree_fast_cpu"] = cpu_seconds[3] / cpu_seconds[0];
    state.counters["occluded"] = static_cast<double>(occluded[0]) / static_cast<double>(s.segments.size());
    // The tracers must agree on the answer (up to rays through float-rounding ties, far fewer than 0.1 %).
    const auto differs = [&](std::size_t a, std::size_t b) { return (a > b ? a - b : b - a) * 1000 > s.segments.size(); };
    if (differs(occluded[0], occluded[1]) || differs(occluded[1], occluded[2]) || differs(occluded[1], occluded[3]))
        state.SkipWithError("the BVH and Embree disagree on which segments are occluded");
}
#endif

void register_all() {
    // Every mesh of ../shared/scenes (README: "report build time and shadow rays per second on each").
    constexpr const char* meshes[] = {"bun_zipper.ply", "Armadillo.ply", "plant.obj", "bench.obj", "window-blinds.obj",
                                      "CornellBox-Original.obj", "sportsCar.obj"};
    for (const char* mesh : meshes)
        benchmark::RegisterBenchmark((std::string("BM_bvh_build/") + mesh).c_str(), BM_bvh_build, std::string(mesh))
            ->ArgName("threads")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime()->MeasureProcessCPUTime();
    const std::pair<const char*, query> queries[] = {{"occluder_span", query::occluder_span},
                                                     {"nearest_occluder", query::nearest_occluder},
                                                     {"occluded", query::occluded}};
    for (const char* mesh : meshes)
        for (const auto& [qname, q] : queries)
            benchmark::RegisterBenchmark((std::string("BM_bvh_") + qname + "/" + mesh).c_str(), BM_bvh_shadow,
                                         std::string(mesh), q)
                ->ArgName("threads")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime()->MeasureProcessCPUTime();
#if AAF_EXAMPLES_EMBREE
    // The meshes (12: "the bunny, plant, car and Armadillo"), nearest hit and any hit.
    const std::pair<const char*, query> compared[] = {{"nearest_occluder", query::nearest_occluder}, {"occluded", query::occluded}};
    for (const char* mesh : {"bun_zipper.ply", "plant.obj", "sportsCar.obj", "Armadillo.ply"})
        for (const auto& [qname, q] : compared)
            benchmark::RegisterBenchmark((std::string("BM_tracers/") + qname + "/" + mesh).c_str(), BM_tracers,
                                         std::string(mesh), q)
                ->ArgName("threads")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseManualTime();
#endif
}

[[maybe_unused]] const bool registered = (register_all(), true);

}  // namespace
