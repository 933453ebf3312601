// SPDX-License-Identifier: MIT
// Embedding aaf in a production renderer (issue 12): misconfigurations are reported or have a documented
// meaning, tracers of the wrong shape are named, batched queries (distances and any-hit) spanning several
// pixels give the single-ray path's bits, the thread pool's start hook, and FTZ/DAZ safety.

#include <catch2/catch.hpp>

#include <atomic>
#include <cmath>
#include <cstring>
#include <limits>
#include <mutex>
#include <span>
#include <vector>

#include <aaf/pipeline.hpp>

#include "support/analytic_scene.hpp"
#include "support/helpers.hpp"

#if defined(__SSE__) || defined(_M_X64)
#include <xmmintrin.h>
#define AAF_TEST_HAS_MXCSR 1
#endif

using namespace aaf_test;

namespace {

analytic_scene<float> scene(std::size_t size = 32) {
    analytic_scene<float> sc;
    sc.width = sc.height = size;
    sc.occluders = {{-0.6f, 0.6f, -0.3f, 0.3f, 1.0f}, {0.2f, 1.4f, 0.1f, 0.5f, 1.8f}};
    return sc;
}

struct frame {
    aaf::image<float> visibility, shaded;
    aaf::frame_report report;
    aaf::frame_workspace<float> ws;
};

template <class Tracer, class Exec = aaf::sequential_executor>
frame render(const aaf::gbuffer<float>& gb, const aaf::area_light<float>& light, const Tracer& tracer,
             const aaf::frame_settings<float>& settings = {}, Exec&& exec = {}) {
    frame f{aaf::image<float>(gb.width(), gb.height()), aaf::image<float>(gb.width(), gb.height()), {}, {}};
    f.report = aaf::render_frame(gb, light, tracer, {f.visibility.view(), f.shaded.view()}, f.ws, settings, exec);
    return f;
}

bool bitwise_equal(const aaf::image<float>& a, const aaf::image<float>& b) {
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

float max_abs_difference(const aaf::image<float>& a, const aaf::image<float>& b) {
    float m = 0;
    for (std::size_t y = 0; y < a.height(); ++y)
        for (std::size_t x = 0; x < a.width(); ++x) m = std::max(m, std::abs(a(x, y) - b(x, y)));
    return m;
}

}  // namespace

// ---------------------------------------------------------------------------------------------------
// No silent misconfiguration.

TEST_CASE("a one-sided light facing away from every receiver: visibility 0, counted, and diagnosed", "[embedding][extremes]") {
    const analytic_scene<float> sc = scene();
    const analytic_gbuffer<float> gb(sc);
    aaf::area_light<float> light = sc.area_light();
    std::swap(light.edge_u, light.edge_v);  // the normal now points up, away from the floor
    const frame f = render(gb.view(), light, span_tracer<float>{&sc});
    CHECK(f.report.rays() == 0);
    CHECK(f.report.pixels == 32u * 32u);
    CHECK(f.report.pixels_behind_light == 32u * 32u);
    CHECK(f.report.pixels_below_horizon == 0);
    for (std::size_t i = 0; i < f.visibility.size(); ++i) REQUIRE(f.visibility.data()[i] == 0.0f);
    CHECK_THAT(f.report.diagnose(), Catch::Contains("every surface pixel is behind the one-sided light") &&
                                        Catch::Contains("swap light.edge_u and light.edge_v"));
    // The correctly oriented light: nothing to diagnose.
    CHECK(render(gb.view(), sc.area_light(), span_tracer<float>{&sc}).report.diagnose().empty());
}

TEST_CASE("normals facing away from the light: visibility 0, counted, and diagnosed as normals facing away from the camera",
          "[embedding][extremes]") {
    const analytic_scene<float> sc = scene();
    analytic_gbuffer<float> gb(sc);
    gb.normals.fill(glm::vec3(0, -1, 0));  // Embree's Ng of a floor wound the other way
    const frame f = render(gb.view(), sc.area_light(), span_tracer<float>{&sc});
    CHECK(f.report.rays() == 0);
    CHECK(f.report.pixels_below_horizon == 32u * 32u);
    CHECK(f.report.pixels_behind_light == 0);
    CHECK_THAT(f.report.diagnose(), Catch::Contains("do gbuffer.normals face away from the camera"));
    // Half of them flipped: counted, not called "every".
    for (std::size_t y = 0; y < 32; ++y)
        for (std::size_t x = 0; x < 32; ++x) gb.normals(x, y) = glm::vec3(0, x < 16 ? -1.0f : 1.0f, 0);
    const frame half = render(gb.view(), sc.area_light(), span_tracer<float>{&sc});
    CHECK(half.report.pixels_below_horizon == 16u * 32u);
    CHECK_THAT(half.report.diagnose(), Catch::Contains("512 of 1024 surface pixels have the light below their horizon"));
}

TEST_CASE("a zero normal is an orientation-less receiver facing the light's centre", "[embedding][extremes]") {
    const analytic_scene<float> sc = scene();
    const analytic_gbuffer<float> up(sc);
    analytic_gbuffer<float> zero(sc);
    zero.normals.fill(glm::vec3(0));
    // Also a normal whose square underflows: zero as far as directions go.
    zero.normals(3, 3) = glm::vec3(1e-30f, 0, 0);
    const frame a = render(up.view(), sc.area_light(), span_tracer<float>{&sc});
    const frame b = render(zero.view(), sc.area_light(), span_tracer<float>{&sc});
    CHECK(b.report.pixels_zero_normal == 32u * 32u);
    CHECK(b.report.pixels_below_horizon == 0);
    CHECK_THAT(b.report.diagnose(), Catch::Contains("have a zero normal (taken to face the light's centre)"));
    // Every light point is within 90 degrees of the centre's direction here, so the samples and their weights
    // are those of the upward normal; only the ray origins' offset direction differs (by ULPs).
    CHECK(rmse(a.ws.raw_visibility, b.ws.raw_visibility) < 1e-3);
    CHECK(b.report.rays() == a.report.rays());
    // The normal guide rejects a zero normal's neighbours (their cosine, 0, is below the threshold): such
    // pixels are not filtered, which README documents (a threshold of 90 degrees or more accepts them).
    CHECK(bitwise_equal(b.visibility, b.ws.raw_visibility));
    aaf::frame_settings<float> wide;
    wide.filter.normal_threshold_degrees = 90;
    const frame c = render(zero.view(), sc.area_light(), span_tracer<float>{&sc}, wide);
    CHECK(rmse(c.visibility, sc.exact_image()) < rmse(c.ws.raw_visibility, sc.exact_image()));
    // The shaded output uses the same normal: the irradiance of a receiver facing the light's centre.
    const glm::vec3 p = sc.position(10, 20);
    const glm::vec3 towards = glm::normalize(sc.area_light().center() - p);
    CHECK(b.shaded(10, 20) == Approx(b.visibility(10, 20) * aaf::unshadowed_irradiance(sc.area_light(), p, towards)));
    CHECK(b.shaded(10, 20) > 0.0f);
}

TEST_CASE("pixel sizes that are not positive finite world lengths get max_samples, are not filtered, and are counted",
          "[embedding][extremes]") {
    const analytic_scene<float> sc = scene();
    analytic_gbuffer<float> gb(sc);
    const std::size_t bad[4][2] = {{3, 4}, {16, 15}, {20, 16}, {30, 30}};
    const float values[4] = {0.0f, -0.125f, std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity()};
    for (int i = 0; i < 4; ++i) gb.pixel_size(bad[i][0], bad[i][1]) = values[i];
    aaf::frame_settings<float> settings;
    const frame f = render(gb.view(), sc.area_light(), span_tracer<float>{&sc}, settings);
    CHECK(f.report.pixels_bad_pixel_size == 4);
    CHECK_THAT(f.report.diagnose(), Catch::Contains("4 of 1024 surface pixels have a gbuffer.pixel_size that is not a positive finite world length"));
    for (const auto& xy : bad) {
        CAPTURE(xy[0], xy[1]);
        CHECK(f.ws.stats(xy[0], xy[1]).samples == settings.sampling.max_samples);
        CHECK(f.ws.filter_width(xy[0], xy[1]) == 0.0f);
        CHECK(f.visibility(xy[0], xy[1]) == std::clamp(f.ws.raw_visibility(xy[0], xy[1]), 0.0f, 1.0f));
    }
    // Every pixel bad: a converged unfiltered frame at max_samples, not a black one.
    gb.pixel_size.fill(0.0f);
    const frame all = render(gb.view(), sc.area_light(), span_tracer<float>{&sc}, settings);
    CHECK(all.report.rays() == 32u * 32u * settings.sampling.max_samples);
    CHECK(rmse(all.visibility, sc.exact_image()) < 0.05);
}

TEST_CASE("a frame without any surface is diagnosed", "[embedding][extremes]") {
    const analytic_scene<float> sc = scene(8);
    analytic_gbuffer<float> gb(sc);
    gb.positions.fill(glm::vec3(std::numeric_limits<float>::infinity()));
    const frame f = render(gb.view(), sc.area_light(), span_tracer<float>{&sc});
    CHECK(f.report.pixels_without_surface == 64);
    CHECK_THAT(f.report.diagnose(), Catch::Contains("no pixel has a surface"));
}

// ---------------------------------------------------------------------------------------------------
// Tracers of the wrong shape.

namespace shapes {
using seg = aaf::shadow_segment<float>;
struct non_const_span {
    aaf::occluder_span<float> occluder_span(const seg&);
};
struct non_const_nearest {
    float nearest_occluder(const seg&);
};
struct wrong_span_signature {
    aaf::occluder_span<float> occluder_span(const glm::vec3&, const glm::vec3&) const;
};
struct only_occluded {
    bool occluded(const seg&) const;
};
/// Usable, but its any-hit query is not const: aaf would silently trace both ends instead.
struct non_const_any_hit {
    aaf::occluder_span<float> occluder_span(const seg&) const;
    bool occluded(const seg&);
};
/// Usable, with a guessed batch name: not detected (no contract name), which describe_tracer shows.
struct guessed_batch_name {
    float nearest_occluder(const seg&) const;
    void occluded_packet(std::span<const seg>, std::span<bool>) const;
};
/// Usable, with its own `occluded` overload for another ray type: left alone.
struct own_occluded {
    float nearest_occluder(const seg&) const;
    bool occluded(const glm::vec3& from, const glm::vec3& to) const;
};
struct packet {
    void nearest_batch(std::span<const seg>, std::span<float>) const;
    void occluded_batch(std::span<const seg>, std::span<bool>) const;
};

static_assert(!aaf::occlusion_tracer<non_const_span>);
static_assert(!aaf::occlusion_tracer<non_const_nearest>);
static_assert(!aaf::occlusion_tracer<wrong_span_signature>);
static_assert(!aaf::occlusion_tracer<only_occluded>);
static_assert(aaf::occlusion_tracer<non_const_any_hit> && !aaf::boolean_tracer<non_const_any_hit>);
static_assert(aaf::occlusion_tracer<guessed_batch_name> && !aaf::batch_visibility_tracer<guessed_batch_name>);
static_assert(aaf::occlusion_tracer<own_occluded>);
static_assert(aaf::occlusion_tracer<packet> && aaf::nearest_batch_tracer<packet> && aaf::batch_visibility_tracer<packet>);
static_assert(!aaf::span_tracer<packet> && !aaf::batch_tracer<packet>);
static_assert(aaf::check_tracer<packet>());
static_assert(aaf::check_tracer<own_occluded>());
static_assert(aaf::check_tracer<span_tracer<float>>());
static_assert(aaf::check_tracer<aaf::bisecting_tracer<boolean_tracer<float>>>());
}  // namespace shapes

TEST_CASE("tracer_problem names the member and the reason that check_tracer stops the compilation with", "[embedding][tracer]") {
    using namespace shapes;
    CHECK(std::string(aaf::tracer_problem<non_const_span>()) == "`occluder_span` is not const");
    CHECK(std::string(aaf::tracer_problem<non_const_nearest>()) == "`nearest_occluder` is not const");
    CHECK(std::string(aaf::tracer_problem<wrong_span_signature>()) == "`occluder_span` has the wrong signature");
    CHECK(std::string(aaf::tracer_problem<only_occluded>()) == "the tracer answers only `occluded`: wrap it in aaf::bisecting_tracer");
    CHECK(std::string(aaf::tracer_problem<non_const_any_hit>()) == "`occluded` is not const");
    CHECK(std::string(aaf::tracer_problem<int>()) == "the tracer has no query that gives distances");
    CHECK(aaf::tracer_problem<guessed_batch_name>() == nullptr);
    CHECK(aaf::tracer_problem<own_occluded>() == nullptr);
    CHECK(aaf::tracer_problem<packet>() == nullptr);
    // The documented way to see that a guessed name was not detected:
    CHECK(std::string(aaf::describe_tracer<guessed_batch_name>()) ==
          "distances: nearest_occluder (nearest only); visibility: nearest_occluder");
    CHECK(std::string(aaf::describe_tracer<packet>()) ==
          "distances: nearest_batch (nearest only, batched); visibility: occluded_batch");
}

// ---------------------------------------------------------------------------------------------------
// Batched queries.

namespace {

/// The analytic scene through the batched forms, counting calls and segments (thread-safe counters).
struct batch_counts {
    std::atomic<std::uint64_t> calls{0}, segments{0}, min_size{~std::uint64_t{0}};
    void add(std::size_t n) {
        ++calls, segments += n;
        std::uint64_t m = min_size.load();
        while (n < m && !min_size.compare_exchange_weak(m, n)) {}
    }
};

template <bool Spans>
struct counting_packet_tracer {
    const analytic_scene<float>* scene;
    mutable batch_counts distances, visibility;
    void nearest_batch(std::span<const aaf::shadow_segment<float>> in, std::span<float> out) const
        requires(!Spans) {
        distances.add(in.size());
        for (std::size_t i = 0; i < in.size(); ++i) {
            const auto s = scene->span(in[i]);
            out[i] = s.hit() ? s.nearest : aaf::no_occluder<float>;
        }
    }
    void trace_batch(std::span<const aaf::shadow_segment<float>> in, std::span<aaf::occluder_span<float>> out) const
        requires Spans {
        distances.add(in.size());
        for (std::size_t i = 0; i < in.size(); ++i) out[i] = scene->span(in[i]);
    }
    void occluded_batch(std::span<const aaf::shadow_segment<float>> in, std::span<bool> out) const {
        visibility.add(in.size());
        for (std::size_t i = 0; i < in.size(); ++i) out[i] = scene->span(in[i]).hit();
    }
};

/// The same answers one ray at a time.
template <bool Spans>
struct single_ray_tracer {
    const analytic_scene<float>* scene;
    float nearest_occluder(const aaf::shadow_segment<float>& s) const requires(!Spans) {
        const auto sp = scene->span(s);
        return sp.hit() ? sp.nearest : aaf::no_occluder<float>;
    }
    aaf::occluder_span<float> occluder_span(const aaf::shadow_segment<float>& s) const requires Spans { return scene->span(s); }
    bool occluded(const aaf::shadow_segment<float>& s) const { return scene->span(s).hit(); }
};

static_assert(aaf::nearest_batch_tracer<counting_packet_tracer<false>> && !aaf::batch_tracer<counting_packet_tracer<false>>);
static_assert(aaf::batch_tracer<counting_packet_tracer<true>> && !aaf::nearest_batch_tracer<counting_packet_tracer<true>>);

template <bool Spans>
void check_batches(aaf::shadow_query query) {
    const analytic_scene<float> sc = scene(48);
    const analytic_gbuffer<float> gb(sc);
    aaf::frame_settings<float> settings;
    settings.sampling.adaptive_query = query;
    const frame single = render(gb.view(), sc.area_light(), single_ray_tracer<Spans>{&sc}, settings);
    for (const std::uint32_t batch_rays : {1u, 16u, 64u, 1000u}) {
        CAPTURE(batch_rays);
        settings.sampling.batch_rays = batch_rays;
        counting_packet_tracer<Spans> packets{&sc, {}, {}};
        aaf::thread_pool pool(2);
        const frame batched = render(gb.view(), sc.area_light(), packets, settings, pool);
        CHECK(bitwise_equal(single.visibility, batched.visibility));
        CHECK(bitwise_equal(single.shaded, batched.shaded));
        CHECK(batched.report.initial_rays == single.report.initial_rays);
        CHECK(batched.report.adaptive_rays == single.report.adaptive_rays);
        const bool any_hit = query == aaf::shadow_query::visibility;
        // Every ray went through a batch call of the right query.
        CHECK(packets.distances.segments == batched.report.initial_rays + (any_hit ? 0 : batched.report.adaptive_rays));
        CHECK(packets.visibility.segments == (any_hit ? batched.report.adaptive_rays : 0));
        // Batches hold several pixels: at least batch_rays segments but at the end of a task (a row here).
        const std::uint64_t rows = 2 * 48;  // at most one short batch per row and pass
        CHECK(packets.distances.calls <= packets.distances.segments / batch_rays + rows);
        if (batch_rays == 64) {
            CHECK(packets.distances.segments / packets.distances.calls >= 48);  // about 7 pixels of 9 rays per call
            if (any_hit) CHECK(packets.visibility.segments / packets.visibility.calls >= 16);
        }
    }
}

}  // namespace

TEST_CASE("batched nearest-only and any-hit queries spanning several pixels give the single-ray path's bits",
          "[embedding][batch]") {
    check_batches<false>(aaf::shadow_query::visibility);
    check_batches<false>(aaf::shadow_query::distances);
}

TEST_CASE("batched nearest-and-farthest queries spanning several pixels give the single-ray path's bits", "[embedding][batch]") {
    check_batches<true>(aaf::shadow_query::visibility);
    check_batches<true>(aaf::shadow_query::distances);
}

TEST_CASE("batch_rays outside [1, 65536] is an invalid_argument naming it", "[embedding][batch][extremes]") {
    const analytic_scene<float> sc = scene(8);
    const analytic_gbuffer<float> gb(sc);
    aaf::frame_settings<float> settings;
    settings.sampling.batch_rays = 0;
    CHECK_THAT(what_of([&] { render(gb.view(), sc.area_light(), span_tracer<float>{&sc}, settings); }),
               Catch::Contains("`settings.sampling.batch_rays` must be in [1, 65536] (got 0)"));
}

// ---------------------------------------------------------------------------------------------------
// Threads: the start hook, and FTZ/DAZ.

TEST_CASE("thread_pool's start hook runs once on every thread, and only hooked threads run work", "[embedding][executor]") {
    std::mutex m;
    std::vector<std::size_t> started;
    std::vector<std::thread::id> hooked;
    aaf::thread_pool pool(3, 1, [&](std::size_t i) {
        std::lock_guard lock(m);
        started.push_back(i);
        hooked.push_back(std::this_thread::get_id());
    });
    CHECK(pool.size() == 3);
    std::atomic<int> foreign{0}, items{0};
    for (int round = 0; round < 3; ++round)
        pool.parallel_for(100, [&](std::size_t b, std::size_t e) {
            std::lock_guard lock(m);
            if (std::find(hooked.begin(), hooked.end(), std::this_thread::get_id()) == hooked.end()) ++foreign;
            items += static_cast<int>(e - b);
        });
    CHECK(foreign == 0);
    CHECK(items == 300);
    std::sort(started.begin(), started.end());
    CHECK(started == std::vector<std::size_t>{0, 1, 2});
    // Exceptions still reach the caller.
    CHECK_THROWS_AS(pool.parallel_for(4, [](std::size_t, std::size_t) { throw std::runtime_error("x"); }), std::runtime_error);
}

#ifdef AAF_TEST_HAS_MXCSR
namespace {
constexpr unsigned ftz_daz = 0x8040;  // MXCSR bit 15 flush-to-zero, bit 6 denormals-are-zero
struct mxcsr_guard {
    unsigned saved = _mm_getcsr();
    ~mxcsr_guard() { _mm_setcsr(saved); }
};
}  // namespace

TEST_CASE("aaf is FTZ/DAZ-safe: frames with denormals flushed match the IEEE frames", "[embedding][ftz]") {
    // Tolerance stated in README "Threads": bitwise on these scenes; at most 1e-6 allowed, the size of a
    // denormal weight's share of a normalised sum.
    for (const float scale : {1.0f, 1e-4f, 1e4f}) {
        CAPTURE(scale);
        analytic_scene<float> sc = scene(40);
        for (auto* r : {&sc.light}) r->x0 *= scale, r->x1 *= scale, r->z0 *= scale, r->z1 *= scale, r->y *= scale;
        for (auto& r : sc.occluders) r.x0 *= scale, r.x1 *= scale, r.z0 *= scale, r.z1 *= scale, r.y *= scale;
        sc.x_min *= scale, sc.z_min *= scale, sc.extent *= scale;
        const analytic_gbuffer<float> gb(sc);
        for (const aaf::offset_space space : {aaf::offset_space::image, aaf::offset_space::light_plane}) {
            aaf::frame_settings<float> settings;
            settings.filter.space = space;
            settings.sampling.weighting = aaf::light_weighting::irradiance;  // r⁻⁴ weights: the smallest numbers
            const frame ieee = render(gb.view(), sc.area_light(), span_tracer<float>{&sc}, settings);
            frame flushed;
            {
                const mxcsr_guard guard;
                _mm_setcsr(guard.saved | ftz_daz);
                flushed = render(gb.view(), sc.area_light(), span_tracer<float>{&sc}, settings);
            }
            const float diff = max_abs_difference(ieee.visibility, flushed.visibility);
            CHECK(diff <= 1e-6f);
            if (diff != 0.0f) WARN("FTZ/DAZ changed the frame by at most " << diff);
            CHECK(bitwise_equal(ieee.visibility, flushed.visibility));  // measured: the same bits on these scenes
            CHECK(flushed.report.rays() == ieee.report.rays());
            // The pool's start hook sets the modes on its threads; the caller's are untouched.
            const unsigned before = _mm_getcsr();
            std::atomic<int> unflushed{0};
            aaf::thread_pool pool(2, 1, [](std::size_t) { _mm_setcsr(_mm_getcsr() | ftz_daz); });
            pool.parallel_for(8, [&](std::size_t, std::size_t) { unflushed += (_mm_getcsr() & ftz_daz) != ftz_daz; });
            CHECK(unflushed == 0);
            const frame pooled = render(gb.view(), sc.area_light(), span_tracer<float>{&sc}, settings, pool);
            CHECK(_mm_getcsr() == before);
            CHECK(bitwise_equal(pooled.visibility, flushed.visibility));
        }
    }
}
#endif
