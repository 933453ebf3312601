// SPDX-License-Identifier: MIT
// The examples' Embree tracer (examples/common/embree_tracer.hpp) against the examples' BVH on the same
// scenes and rays: the same hits and misses, the same distances up to float rounding (Embree's triangle test
// is not the BVH's watertight double-precision one, and occluder_span's farthest hit comes from a second ray
// cast back from the light point), and the same statistics from a small aaf gather. Compiled only when CMake
// found Embree 3 (AAF_WITH_EMBREE).

#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <memory>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <aaf/executor.hpp>
#include <aaf/gather.hpp>
#include <aaf/image.hpp>
#include <aaf/tracer.hpp>

#include "common/bvh.hpp"
#include "common/embree_tracer.hpp"
#include "common/render_support.hpp"
#include "common/scene.hpp"

using aaf_examples::bvh;
using aaf_examples::embree_tracer;
using segment = aaf::shadow_segment<float>;

static_assert(aaf::span_tracer<embree_tracer> && aaf::nearest_tracer<embree_tracer> && aaf::boolean_tracer<embree_tracer>,
              "embree_tracer offers the same aaf tracer queries as bvh");

namespace {

const std::filesystem::path scenes_dir = std::filesystem::path(AAF_SOURCE_DIR) / "scenes";

/// Distances of the two tracers agree to this fraction of the segment's length. Embree's Möller–Trumbore
/// style test and the BVH's sheared one round differently; the back ray of occluder_span adds the rounding
/// of the light point (origin + length·direction). 1e-5 is ~80 float ulps of the length.
constexpr float relative_tolerance = 1e-5f;

/// Shadow segments of the scene's kind: from random points on and above the ground under the objects (a little above it, so
/// that neither tracer's answer depends on how it rounds a hit at t ≈ 0 on the ground itself) towards
/// random points on the light; plus segments between random points of the scene's bounds.
std::vector<segment> random_segments(const aaf_examples::scene& s, std::size_t n, std::uint32_t seed) {
    // The bounds of everything but the ground (which is much wider than the objects on it).
    glm::vec3 lo(std::numeric_limits<float>::infinity()), hi(-lo);
    for (std::size_t i = 0; i < s.triangles.size(); ++i)
        if (s.objects[s.triangle_object[i]].name != "ground")
            for (int k = 0; k < 3; ++k) lo = glm::min(lo, s.vertices[s.triangles[i][k]]), hi = glm::max(hi, s.vertices[s.triangles[i][k]]);
    const glm::vec3 size = hi - lo;
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::vector<segment> out;
    for (std::size_t i = 0; i < n; ++i) {
        glm::vec3 from, to;
        if (i % 4 != 3) {
            from = glm::vec3(lo.x + size.x * u(rng), lo.y + 1e-3f * size.y + 0.5f * size.y * u(rng) * u(rng), lo.z + size.z * u(rng));
            to = s.light.corner + u(rng) * s.light.edge_u + u(rng) * s.light.edge_v;
        } else {
            from = lo + size * glm::vec3(u(rng), u(rng), u(rng));
            to = lo + size * glm::vec3(u(rng), u(rng), u(rng));
        }
        const float length = glm::length(to - from);
        if (!(length > 0.0f)) continue;
        out.push_back({from, (to - from) / length, length});
    }
    return out;
}

struct agreement {
    std::size_t rays = 0, hits = 0, mismatched_hit = 0, far_nearest = 0, far_farthest = 0;
};

/// Every query of both tracers on the same segments.
agreement compare_queries(const bvh& b, const embree_tracer& e, const std::vector<segment>& segments) {
    agreement a;
    for (const segment& g : segments) {
        ++a.rays;
        const bool ob = b.occluded(g), oe = e.occluded(g);
        const float nb = b.nearest_occluder(g), ne = e.nearest_occluder(g);
        const aaf::occluder_span<float> sb = b.occluder_span(g), se = e.occluder_span(g);
        a.hits += ob ? 1 : 0;
        if (ob != oe || ob != (nb != aaf::no_occluder<float>) || ob != (ne != aaf::no_occluder<float>) ||
            ob != sb.hit() || ob != se.hit()) {
            ++a.mismatched_hit;
            continue;
        }
        if (!ob) continue;
        const float tol = relative_tolerance * g.length;
        if (!(std::abs(nb - ne) <= tol) || !(std::abs(sb.nearest - se.nearest) <= tol)) ++a.far_nearest;
        if (!(std::abs(sb.farthest - se.farthest) <= tol)) ++a.far_farthest;
    }
    return a;
}

}  // namespace

TEST_CASE("embree_tracer and bvh give the same hits and distances on the example scenes", "[embree][scene]") {
    for (const char* name : {"bunny", "plant", "cornell", "blinds"}) {
        INFO("scene " << name);
        const aaf_examples::scene s = aaf_examples::load_scene(name, scenes_dir);
        const bvh b(s.vertices, s.triangles);
        const embree_tracer e(s.vertices, s.triangles);
        CHECK(e.triangle_count() == b.triangle_count());
        CHECK(e.dropped_triangles() == b.dropped_triangles());
        const agreement a = compare_queries(b, e, random_segments(s, 4000, 7));
        INFO(a.rays << " rays, " << a.hits << " occluded");
        CHECK(a.hits > a.rays / 20);  // the rays do meet geometry
        CHECK(a.hits < a.rays);
        CHECK(a.mismatched_hit == 0);
        CHECK(a.far_nearest == 0);
        CHECK(a.far_farthest == 0);
    }
}

TEST_CASE("embree_tracer's primary rays match bvh::nearest_hit", "[embree][scene]") {
    const aaf_examples::scene s = aaf_examples::load_scene("bunny", scenes_dir);
    const bvh b(s.vertices, s.triangles);
    const embree_tracer e(s.vertices, s.triangles);
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    std::size_t hits = 0, same_triangle = 0;
    const std::size_t n = 3000;
    for (std::size_t i = 0; i < n; ++i) {
        const glm::vec3 target = s.view.target + 0.6f * glm::vec3(u(rng), 0.5f * (u(rng) + 1.0f), u(rng));
        const glm::vec3 dir = glm::normalize(target - s.view.position);
        const aaf_examples::ray_hit hb = b.nearest_hit(s.view.position, dir), he = e.nearest_hit(s.view.position, dir);
        REQUIRE(hb.hit() == he.hit());
        if (!hb.hit()) continue;
        ++hits;
        CHECK(std::abs(hb.t - he.t) <= relative_tolerance * hb.t);
        if (hb.triangle != he.triangle) continue;  // a ray through a shared edge may name either triangle
        ++same_triangle;
        CHECK(hb.normal == he.normal);  // both from the same vertices, the same way
        // Two different intersection algorithms: their barycentrics agree to the triangle's conditioning.
        // Measured: up to 1e-4 at -march=native (FMA), 1.7e-4 in the generic x86-64 build (ASan preset).
        CHECK(std::abs(hb.barycentrics.x - he.barycentrics.x) <= 5e-4f);
        CHECK(std::abs(hb.barycentrics.y - he.barycentrics.y) <= 5e-4f);
    }
    CHECK(hits > n / 4);
    CHECK(same_triangle >= hits - hits / 100);
    // t_max bounds the hit as for the BVH: 0 < t < t_max.
    const glm::vec3 dir = glm::normalize(s.view.target - s.view.position);
    const aaf_examples::ray_hit full = e.nearest_hit(s.view.position, dir);
    REQUIRE(full.hit());
    CHECK_FALSE(e.nearest_hit(s.view.position, dir, full.t).hit());
    CHECK(b.nearest_hit(s.view.position, dir, full.t).hit() == e.nearest_hit(s.view.position, dir, full.t).hit());
}

TEST_CASE("embree_tracer follows the tracer contract at its edges, as bvh does", "[embree][contract]") {
    // One unit square in the plane z = 1 (two triangles), plus a zero-area and a non-finite triangle.
    const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
    const std::vector<glm::vec3> v = {{0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}, {2, 2, 2}, {nan, 0, 0}};
    const std::vector<glm::uvec3> t = {{0, 1, 2}, {0, 2, 3}, {4, 4, 4}, {0, 1, 5}};
    const bvh b(v, t);
    const embree_tracer e(v, t);
    CHECK(e.triangle_count() == 2);
    CHECK(e.dropped_triangles() == 2);
    const glm::vec3 o(0.3f, 0.6f, 0.0f), d(0, 0, 1);
    // Lengths on both sides of the hit at t = 1; 1 + 2^-18 is past the wrapper's light-end margin (2^-20 of the
    // length), within which Embree's hits are the light's own position (see below).
    for (const float length : {0.5f, 1.0f, 1.0f + 0x1p-18f, 2.0f, 0.0f, -1.0f, inf}) {
        INFO("length " << length);
        const segment g{o, d, length};
        CHECK(e.occluded(g) == b.occluded(g));
        const float ne = e.nearest_occluder(g), nb = b.nearest_occluder(g);
        // The same distance to the tolerance of the other tests (Embree's is not exact: one ulp short on AVX2).
        CHECK((ne == nb || std::abs(ne - nb) <= relative_tolerance * nb));
        CHECK(e.occluder_span(g).hit() == b.occluder_span(g).hit());
    }
    // The hit at exactly t = length is the light's own position: not an occluder (0 < t < length), for Embree
    // also where its distance comes out an ulp short (AVX2 kernels: the float below 1), and for a hit within
    // the light-end margin (the float above 1 as the length: the BVH's exact distance reports it, Embree not).
    CHECK_FALSE(e.occluded({o, d, 1.0f}));
    CHECK_FALSE(b.occluded({o, d, 1.0f}));
    CHECK_FALSE(e.occluded({o, d, std::nextafter(1.0f, 2.0f)}));
    CHECK(e.nearest_occluder({o, d, std::nextafter(1.0f, 2.0f)}) == aaf::no_occluder<float>);
    for (const glm::vec3& q : {glm::vec3(0.25f, 0.5f, 0.0f), glm::vec3(0.7f, 0.2f, 0.0f), glm::vec3(0.5f, 0.5f, -1.0f)}) {
        INFO("origin " << q.x << " " << q.y << " " << q.z);
        const float to_plane = 1.0f - q.z;  // the light point on the square itself
        CHECK_FALSE(e.occluded({q, d, to_plane}));
        CHECK(e.nearest_occluder({q, d, to_plane}) == aaf::no_occluder<float>);
        CHECK_FALSE(e.occluder_span({q, d, to_plane}).hit());
    }
    // Nor is a hit at exactly t = 0: a receiver lying on another triangle (the Cornell box's floor-wall corner
    // found it; Embree's interval is closed at tnear). Both directions, every query and form, as the BVH.
    for (const glm::vec3& dir : {glm::vec3(0, 0, 1), glm::vec3(0, 0, -1), glm::normalize(glm::vec3(1, 1, 1))}) {
        const segment on{glm::vec3(0.3f, 0.6f, 1.0f), dir, 2.0f};
        CHECK(b.occluded(on) == false);
        CHECK_FALSE(e.occluded(on));
        CHECK(e.nearest_occluder(on) == b.nearest_occluder(on));
        CHECK_FALSE(e.occluder_span(on).hit());
        bool packet_occluded = true;
        float packet_nearest = 0;
        e.occluded_batch(std::span<const segment>(&on, 1), std::span<bool>(&packet_occluded, 1));
        e.nearest_batch(std::span<const segment>(&on, 1), std::span<float>(&packet_nearest, 1));
        CHECK_FALSE(packet_occluded);
        CHECK(packet_nearest == aaf::no_occluder<float>);
    }
    CHECK(e.nearest_occluder({o, d, 2.0f}) == Approx(1.0f).epsilon(relative_tolerance));
    const aaf::occluder_span<float> span = e.occluder_span({o, d, 2.0f});
    CHECK(span.nearest == Approx(1.0f).epsilon(relative_tolerance));
    CHECK(span.farthest == Approx(1.0f).epsilon(1e-6));
    // Invalid segments fail (NaN) or are not occluded, as with the BVH.
    for (const segment& bad : {segment{{nan, 0, 0}, d, 2.0f}, segment{o, {0, 0, 0}, 2.0f}, segment{o, {inf, 0, 0}, 2.0f},
                               segment{o, d, nan}}) {
        CHECK(std::isnan(e.nearest_occluder(bad)));
        CHECK(std::isnan(b.nearest_occluder(bad)));
        CHECK(std::isnan(e.occluder_span(bad).nearest));
        CHECK_FALSE(e.occluded(bad));
    }
    // Input errors are those of the BVH.
    CHECK_THROWS_AS(embree_tracer(v, std::vector<glm::uvec3>{}), std::invalid_argument);
    CHECK_THROWS_AS(embree_tracer(v, std::vector<glm::uvec3>{{0, 1, 9}}), std::invalid_argument);
    CHECK_THROWS_AS(embree_tracer(v, std::vector<glm::uvec3>{{4, 4, 4}}), std::invalid_argument);
}

TEST_CASE("an aaf gather through embree_tracer gives the BVH's statistics", "[embree][gather]") {
    aaf_examples::scene s = aaf_examples::load_scene("bunny", scenes_dir);
    s.width = 64, s.height = 48;
    const bvh b(s.vertices, s.triangles);
    const embree_tracer e(s.vertices, s.triangles);
    aaf::thread_pool pool(2);
    const aaf_examples::gbuffer_images g = aaf_examples::render_gbuffer(s, b, pool);
    REQUIRE(g.surfaces > s.width * s.height / 2);
    const aaf::gbuffer<float> gb{g.positions.cview(), g.normals.cview(), g.pixel_size.cview(), {}};
    aaf::sampling_settings sampling;
    const std::uint32_t spp = 16;
    aaf::image<aaf::occlusion_stats<float>> sb(s.width, s.height), se(s.width, s.height);
    const std::uint64_t rays_b = aaf::gather_occlusion(gb, s.light, b, sampling, 0, spp, sb.view());
    const std::uint64_t rays_e = aaf::gather_occlusion(gb, s.light, e, sampling, 0, spp, se.view());
    CHECK(rays_b == rays_e);
    std::size_t occluded_pixels = 0, differing = 0;
    for (std::size_t y = 0; y < s.height; ++y)
        for (std::size_t x = 0; x < s.width; ++x) {
            const aaf::occlusion_stats<float>&p = sb(x, y), &q = se(x, y);
            INFO("pixel " << x << ", " << y);
            REQUIRE(p.samples == q.samples);
            if (p.occluded != q.occluded || p.visible_weight != q.visible_weight) {
                ++differing;  // a sample whose hit one tracer rounds to just inside (0, length), the other not
                continue;
            }
            CHECK(p.total_weight == q.total_weight);
            if (p.occluded == 0) continue;
            ++occluded_pixels;
            const float tol = relative_tolerance * 10.0f;  // segments are shorter than 10 scene units
            CHECK(std::abs(p.d2min - q.d2min) <= tol);
            CHECK(std::abs(p.d2max - q.d2max) <= tol);
        }
    CHECK(occluded_pixels > s.width * s.height / 20);  // the bunny's shadow and self-shadowing
    CHECK(differing == 0);

    // The adaptive pass's visibility-only query (the tracers' `occluded`): the same counts.
    aaf::image<aaf::occlusion_stats<float>> vb(s.width, s.height), ve(s.width, s.height);
    CHECK(aaf::gather_visibility(gb, s.light, b, sampling, 1, spp, vb.view()) ==
          aaf::gather_visibility(gb, s.light, e, sampling, 1, spp, ve.view()));
    std::size_t differing_visibility = 0;
    for (std::size_t y = 0; y < s.height; ++y)
        for (std::size_t x = 0; x < s.width; ++x)
            differing_visibility += vb(x, y).samples != ve(x, y).samples || vb(x, y).occluded != ve(x, y).occluded ||
                                    vb(x, y).visible_weight != ve(x, y).visible_weight;
    CHECK(differing_visibility == 0);
}

TEST_CASE("embree_tracer's packet forms give its single-ray answers", "[embree][packet]") {
    const aaf_examples::scene s = aaf_examples::load_scene("plant", scenes_dir);
    const embree_tracer e(s.vertices, s.triangles);
    std::vector<segment> segments = random_segments(s, 1000, 3);
    // Invalid segments in the middle of a packet fail alone.
    const float nan = std::numeric_limits<float>::quiet_NaN();
    segments[5].direction = glm::vec3(0.0f);
    segments[21].length = nan;
    segments[22].origin.x = std::numeric_limits<float>::infinity();
    for (const std::size_t n : {std::size_t{1}, std::size_t{15}, std::size_t{17}, segments.size()}) {
        INFO(n << " segments");
        const std::span<const segment> in(segments.data(), n);
        std::unique_ptr<bool[]> occluded_out(new bool[n]);
        std::vector<float> nearest(n);
        std::vector<aaf::occluder_span<float>> spans(n);
        e.occluded_batch(in, std::span<bool>(occluded_out.get(), n));
        e.nearest_batch(in, nearest);
        e.trace_batch(in, spans);
        std::size_t hits = 0;
        for (std::size_t i = 0; i < n; ++i) {
            INFO("segment " << i);
            const segment& g = segments[i];
            const float tol = relative_tolerance * (std::isfinite(g.length) ? g.length : 1.0f);
            REQUIRE(occluded_out[i] == e.occluded(g));
            hits += occluded_out[i] ? 1 : 0;
            const float single = e.nearest_occluder(g);
            REQUIRE(std::isnan(nearest[i]) == std::isnan(single));
            REQUIRE((nearest[i] == aaf::no_occluder<float>) == (single == aaf::no_occluder<float>));
            if (std::isfinite(single)) CHECK(std::abs(nearest[i] - single) <= tol);
            const aaf::occluder_span<float> one = e.occluder_span(g);
            REQUIRE(std::isnan(spans[i].nearest) == std::isnan(one.nearest));
            REQUIRE(spans[i].hit() == one.hit());
            if (one.hit()) {
                CHECK(std::abs(spans[i].nearest - one.nearest) <= tol);
                CHECK(std::abs(spans[i].farthest - one.farthest) <= tol);
            }
        }
        if (n == segments.size()) CHECK(hits > n / 20);
    }
    std::vector<float> wrong(3);
    CHECK_THROWS_AS(e.nearest_batch(segments, wrong), std::invalid_argument);
}

TEST_CASE("scene_tracer (--tracer) builds either tracer, and both give the same G-buffer", "[embree][tracer_option]") {
    aaf_examples::scene s = aaf_examples::load_scene("bunny", scenes_dir);
    s.width = 48, s.height = 36;
    const aaf_examples::scene_tracer with_bvh(s, "bvh"), with_embree(s, "embree");
    CHECK(std::string(with_bvh.name()) == "bvh");
    CHECK(std::string(with_embree.name()) == "embree");
    CHECK(with_bvh.triangle_count() == with_embree.triangle_count());
    aaf::thread_pool pool(2);
    const aaf_examples::gbuffer_images a = aaf_examples::render_gbuffer(s, with_bvh, pool);
    const aaf_examples::gbuffer_images b = aaf_examples::render_gbuffer(s, with_embree, pool);
    REQUIRE(a.surfaces == b.surfaces);
    std::size_t other_triangle = 0;
    for (std::size_t y = 0; y < s.height; ++y)
        for (std::size_t x = 0; x < s.width; ++x) {
            if (!a.surface(y * s.width + x)) continue;
            CHECK(glm::length(a.positions(x, y) - b.positions(x, y)) <= 1e-4f);
            other_triangle += a.ids(x, y) != b.ids(x, y) ? 1 : 0;  // object IDs: always the same object
        }
    CHECK(other_triangle == 0);
    CHECK_THROWS_AS(aaf_examples::scene_tracer(s, "optix"), aaf_examples::usage_error);
}
