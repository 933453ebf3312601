// SPDX-License-Identifier: MIT
// aaf's batched tracer queries with a real packet tracer: the examples' Embree tracer offers trace_batch,
// nearest_batch and occluded_batch with the library's signatures, so render_frame hands it whole pixels'
// segments and it traces them in 16-wide packets. Checked here: the batch path is the one taken (a counting
// wrapper), and a frame through Embree's packets, Embree's single rays and the BVH gives the same statistics.
// Also: the reference cache key holds the tracer's engine. Compiled only with Embree (AAF_WITH_EMBREE).

#include <catch2/catch.hpp>

#include <atomic>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <span>
#include <string>

#include <aaf/executor.hpp>
#include <aaf/image.hpp>
#include <aaf/pipeline.hpp>
#include <aaf/tracer.hpp>

#include "common/bvh.hpp"
#include "common/embree_tracer.hpp"
#include "common/render_support.hpp"
#include "common/scene.hpp"

using aaf_examples::embree_tracer;
using aaf_examples::first_hit_tracer;
using aaf_examples::scene_tracer;
using segment = aaf::shadow_segment<float>;

// What aaf detects in the examples' tracers (tracer.hpp): every batched form, used for both passes.
static_assert(aaf::batch_tracer<embree_tracer> && aaf::nearest_batch_tracer<embree_tracer> &&
              aaf::batch_visibility_tracer<embree_tracer>);
static_assert(aaf::check_tracer<embree_tracer>() && aaf::check_tracer<scene_tracer>() && aaf::check_tracer<first_hit_tracer>());
static_assert(aaf::uses_batches<embree_tracer, float>(false) && aaf::uses_batches<embree_tracer, float>(true));
static_assert(aaf::uses_batches<scene_tracer, float>(false) && aaf::uses_batches<scene_tracer, float>(true));
static_assert(aaf::uses_batches<first_hit_tracer, float>(false) && aaf::uses_batches<first_hit_tracer, float>(true));

namespace {

const std::filesystem::path scenes_dir = std::filesystem::path(AAF_SOURCE_DIR) / "scenes";

/// Calls of each query (atomic: aaf calls the tracer from the pool's threads).
struct call_counts {
    std::atomic<std::uint64_t> single{0};                           // any single-ray query
    std::atomic<std::uint64_t> trace_calls{0}, trace_segments{0};   // trace_batch
    std::atomic<std::uint64_t> nearest_calls{0}, nearest_segments{0};
    std::atomic<std::uint64_t> occluded_calls{0}, occluded_segments{0};
};

/// embree_tracer's six queries, counted. `Spans`: whether it shows aaf trace_batch and occluder_span (all hits),
/// or only the nearest-hit forms (first hit, as first_hit_tracer).
template <bool Spans>
struct counting_tracer {
    const embree_tracer* tracer;
    call_counts* counts;

    [[nodiscard]] aaf::occluder_span<float> occluder_span(const segment& g) const requires Spans {
        ++counts->single;
        return tracer->occluder_span(g);
    }
    [[nodiscard]] float nearest_occluder(const segment& g) const {
        ++counts->single;
        return tracer->nearest_occluder(g);
    }
    [[nodiscard]] bool occluded(const segment& g) const {
        ++counts->single;
        return tracer->occluded(g);
    }
    void trace_batch(std::span<const segment> s, std::span<aaf::occluder_span<float>> out) const requires Spans {
        ++counts->trace_calls, counts->trace_segments += s.size();
        tracer->trace_batch(s, out);
    }
    void nearest_batch(std::span<const segment> s, std::span<float> out) const {
        ++counts->nearest_calls, counts->nearest_segments += s.size();
        tracer->nearest_batch(s, out);
    }
    void occluded_batch(std::span<const segment> s, std::span<bool> out) const {
        ++counts->occluded_calls, counts->occluded_segments += s.size();
        tracer->occluded_batch(s, out);
    }
};

/// The bunny scene small, its G-buffer traced once by the BVH (so every tracer below gets the same rays).
struct small_frame {
    aaf_examples::scene s;
    aaf_examples::gbuffer_images g;
    aaf::thread_pool pool{2};
    small_frame() : s(aaf_examples::load_scene("bunny", scenes_dir)) {
        s.width = 64, s.height = 48;
        const aaf_examples::bvh b(s.vertices, s.triangles);
        g = aaf_examples::render_gbuffer(s, b, pool);
    }
    [[nodiscard]] aaf::gbuffer<float, aaf::const_image_view<std::uint32_t>> gbuffer() const {
        return {g.positions.cview(), g.normals.cview(), g.pixel_size.cview(), g.ids.cview()};
    }
};

struct frame_result {
    aaf::frame_report report;
    aaf::frame_workspace<float> ws;
    aaf::image<float> visibility;
};

/// Built once for the whole file (loading the bunny and tracing its G-buffer is most of these tests' time).
small_frame& shared_frame() {
    static small_frame f;
    return f;
}

template <class Tracer>
frame_result render(small_frame& f, const Tracer& tracer, const aaf::frame_settings<float>& settings = {}) {
    frame_result r;
    r.visibility = aaf::image<float>(f.s.width, f.s.height);
    r.report = aaf::render_frame(f.gbuffer(), f.s.light, tracer, {r.visibility.view()}, r.ws, settings, f.pool);
    return r;
}

}  // namespace

TEST_CASE("render_frame takes the batched path with Embree: packets for both passes", "[embree][batch]") {
    small_frame& f = shared_frame();
    const embree_tracer e(f.s.vertices, f.s.triangles);
    aaf::frame_settings<float> settings;
    REQUIRE(settings.sampling.adaptive_query == aaf::shadow_query::visibility);  // the default: any-hit adaptive pass

    SECTION("all hits: trace_batch for the first pass, occluded_batch for the adaptive one") {
        call_counts c;
        const frame_result r = render(f, counting_tracer<true>{&e, &c}, settings);
        CHECK(c.single == 0);
        CHECK(c.nearest_calls == 0);
        CHECK(c.trace_segments == r.report.initial_rays);
        CHECK(c.occluded_segments == r.report.adaptive_rays);
        REQUIRE(c.trace_calls > 0);
        REQUIRE(c.occluded_calls > 0);
        // Batches span several pixels: at least batch_rays segments but at the end of an executor task.
        const double per_trace = static_cast<double>(c.trace_segments) / static_cast<double>(c.trace_calls);
        const double per_occluded = static_cast<double>(c.occluded_segments) / static_cast<double>(c.occluded_calls);
        INFO("segments per call: trace_batch " << per_trace << ", occluded_batch " << per_occluded);
        CHECK(per_trace >= settings.sampling.batch_rays);
        CHECK(per_occluded >= 0.5 * settings.sampling.batch_rays);
        // The counted wrapper and scene_tracer("embree") make the same packet calls: the same frame, bit for bit.
        const scene_tracer st(f.s, "embree");
        const frame_result via_scene = render(f, st, settings);
        CHECK(via_scene.report.rays() == r.report.rays());
        for (std::size_t i = 0; i < r.visibility.size(); ++i) {
            const float a = r.visibility.data()[i], b = via_scene.visibility.data()[i];
            CHECK((a == b || (std::isnan(a) && std::isnan(b))));
        }
    }
    SECTION("first hit: nearest_batch (rtcIntersect16, nearest only) for the first pass") {
        call_counts c;
        const frame_result r = render(f, counting_tracer<false>{&e, &c}, settings);
        CHECK(c.single == 0);
        CHECK(c.trace_calls == 0);
        CHECK(c.nearest_segments == r.report.initial_rays);
        CHECK(c.occluded_segments == r.report.adaptive_rays);
        CHECK(c.nearest_calls > 0);
    }
    SECTION("a larger batch_rays gives fewer, larger calls and the same frame") {
        call_counts small_calls, large_calls;
        const frame_result a = render(f, counting_tracer<true>{&e, &small_calls}, settings);
        aaf::frame_settings<float> large = settings;
        large.sampling.batch_rays = 256;
        const frame_result b = render(f, counting_tracer<true>{&e, &large_calls}, large);
        CHECK(large_calls.trace_calls < small_calls.trace_calls);
        CHECK(a.report.rays() == b.report.rays());
        for (std::size_t i = 0; i < a.visibility.size(); ++i) {
            const float x = a.visibility.data()[i], y = b.visibility.data()[i];
            CHECK((x == y || (std::isnan(x) && std::isnan(y))));
        }
    }
}

TEST_CASE("a frame through Embree's packets, Embree's single rays and the BVH has the same statistics", "[embree][batch]") {
    small_frame& f = shared_frame();
    const scene_tracer bvh(f.s, "bvh"), packets(f.s, "embree"), single(f.s, "embree-single");
    const frame_result rb = render(f, bvh), rp = render(f, packets), rs = render(f, single);
    // Same G-buffer, same samples: the same rays in both passes (the adaptive counts follow from the first
    // pass's statistics, so equal counts also say the slopes agreed).
    CHECK(rp.report.initial_rays == rb.report.initial_rays);
    CHECK(rs.report.initial_rays == rb.report.initial_rays);
    CHECK(rp.report.adaptive_rays == rb.report.adaptive_rays);
    CHECK(rs.report.adaptive_rays == rb.report.adaptive_rays);
    std::size_t occluded_pixels = 0, differing = 0;
    const float tol = 1e-5f * 10.0f;  // test_embree_tracer's relative tolerance; segments are shorter than 10 units
    for (const frame_result* other : {&rp, &rs}) {
        for (std::size_t y = 0; y < f.s.height; ++y)
            for (std::size_t x = 0; x < f.s.width; ++x) {
                const aaf::occlusion_stats<float>&p = rb.ws.stats(x, y), &q = other->ws.stats(x, y);
                INFO("pixel " << x << ", " << y << (other == &rp ? " (packets)" : " (single rays)"));
                REQUIRE(p.samples == q.samples);
                if (p.occluded != q.occluded || p.visible_weight != q.visible_weight) {
                    ++differing;
                    continue;
                }
                CHECK(p.total_weight == q.total_weight);
                if (p.occluded == 0) continue;
                ++occluded_pixels;
                CHECK(std::abs(p.d2min - q.d2min) <= tol);
                CHECK(std::abs(p.d2max - q.d2max) <= tol);
            }
        // The filtered frames: the same up to the filter's response to d2 differences of ~1e-5.
        double max_diff = 0;
        for (std::size_t i = 0; i < rb.visibility.size(); ++i) {
            const float a = rb.visibility.data()[i], b = other->visibility.data()[i];
            REQUIRE(std::isnan(a) == std::isnan(b));
            if (!std::isnan(a)) max_diff = std::max(max_diff, static_cast<double>(std::abs(a - b)));
        }
        CHECK(max_diff <= 1e-3);
    }
    CHECK(occluded_pixels > f.s.width * f.s.height / 10);  // both comparisons: the bunny's shadow is in the frame
    CHECK(differing == 0);
}

TEST_CASE("the reference cache key holds the tracer's engine; both engines' references agree", "[embree][reference]") {
    aaf_examples::scene s = aaf_examples::load_scene("bunny", scenes_dir);
    s.width = 40, s.height = 30;
    const scene_tracer bvh(s, "bvh"), packets(s, "embree"), single(s, "embree-single");
    CHECK(std::string(bvh.engine()) == "bvh");
    CHECK(std::string(packets.engine()) == "embree");
    CHECK(std::string(single.engine()) == "embree");
    CHECK(std::string(single.name()) == "embree-single");
    const aaf_examples::reference_params p{.spp = 64};
    CHECK(aaf_examples::reference_file_name(s, p, "bvh") != aaf_examples::reference_file_name(s, p, "embree"));
    // Each tracer's reference from its own G-buffer, into a fresh cache: they differ only where a sample ray
    // meets a rounding tie or a G-buffer position moved by ~1e-5, i.e. by a sample or two out of 64.
    const std::filesystem::path cache = std::filesystem::temp_directory_path() / "aaf-test-embree-reference";
    std::filesystem::remove_all(cache);
    aaf::thread_pool pool(2);
    const aaf_examples::gbuffer_images gb = aaf_examples::render_gbuffer(s, bvh, pool), ge = aaf_examples::render_gbuffer(s, packets, pool);
    const aaf_examples::reference_result rb = aaf_examples::reference_visibility(s, gb, bvh, p, cache, pool, false);
    const aaf_examples::reference_result re = aaf_examples::reference_visibility(s, ge, packets, p, cache, pool, false);
    CHECK_FALSE(rb.from_cache);
    CHECK_FALSE(re.from_cache);  // a BVH reference is not reused for Embree
    CHECK(aaf_examples::reference_visibility(s, ge, single, p, cache, pool, false).from_cache);  // same engine
    std::size_t surfaces = 0, differing = 0;
    double worst = 0;
    for (std::size_t i = 0; i < rb.visibility.size(); ++i) {
        const float a = rb.visibility.data()[i], b = re.visibility.data()[i];
        REQUIRE(std::isnan(a) == std::isnan(b));
        if (std::isnan(a)) continue;
        ++surfaces;
        differing += a != b;
        worst = std::max(worst, static_cast<double>(std::abs(a - b)));
    }
    INFO(differing << " of " << surfaces << " pixels differ, by at most " << worst);
    CHECK(surfaces > rb.visibility.size() / 2);
    CHECK(differing * 100 <= surfaces);  // at most 1 %
    CHECK(worst <= 2.0 / 64.0 + 1e-6);
    std::filesystem::remove_all(cache);
}
