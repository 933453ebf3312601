// SPDX-License-Identifier: MIT
// Depth maps: the encoding and its inverse for both projections and every quantisation at the extremes of
// near/far, the seed's orthographic formula, light-space round trips, rendering through a tracer, wrapping a
// user's depth buffer, and bad input.

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

#include <aaf/shadow_maps.hpp>

#include "support/analytic_scene.hpp"
#include "support/helpers.hpp"

namespace {

using aaf::depth_format;
using aaf::depth_projection;

constexpr depth_format formats[] = {depth_format::float32, depth_format::unorm24, depth_format::unorm16};

}  // namespace

TEST_CASE("depth reconstruction inverts the store up to one quantisation step, both projections, near/far extremes",
          "[shadow_maps][depth]") {
    struct planes {
        depth_projection p;
        double n, f;
    };
    const std::vector<planes> cases = {
        {depth_projection::orthographic, 0, 1},       {depth_projection::orthographic, -1e5, 1e5},
        {depth_projection::orthographic, 1e-4, 2e-4}, {depth_projection::orthographic, 1e3, 1e3 + 1e-2},
        {depth_projection::perspective, 1e-4, 1e5},   {depth_projection::perspective, 1, 1.001},
        {depth_projection::perspective, 0.1, 100},    {depth_projection::perspective, 1e4, 1e5},
    };
    for (const planes& c : cases)
        for (const depth_format fmt : formats) {
            INFO(aaf::to_string(c.p) << " n=" << c.n << " f=" << c.f << " " << aaf::to_string(fmt));
            // Depths spread over [n, f] in the encoded domain (so every part of the z_tex range is hit), plus
            // both planes exactly.
            for (int k = 0; k <= 200; ++k) {
                const double z_true = k / 200.0;
                const double d = k == 0 ? c.n : k == 200 ? c.f : aaf::depth_from_z_tex(c.p, z_true, c.n, c.f);
                const double z = aaf::z_tex_from_depth(c.p, d, c.n, c.f);
                const float stored = aaf::quantize_z_tex(fmt, z);
                const double back = aaf::depth_from_z_tex(c.p, static_cast<double>(stored), c.n, c.f);
                // The stored value is within one step of the exact z_tex (half a step of rounding to the code,
                // at most half a step more of holding a unorm24 code as a float), so the depth it gives back lies
                // between the depths one step either side: the encoding is inverted exactly up to quantisation.
                const double step = aaf::z_tex_step(fmt, z);
                const double lo = aaf::depth_from_z_tex(c.p, std::max(z - step, 0.0), c.n, c.f);
                const double hi = aaf::depth_from_z_tex(c.p, std::min(z + step, 1.0), c.n, c.f);
                const double slack = 1e-12 * (std::abs(c.n) + std::abs(c.f));
                CHECK(back >= lo - slack);
                CHECK(back <= hi + slack);
                if (fmt != depth_format::float32) {  // a unorm value is a code (to float precision)
                    const double levels = fmt == depth_format::unorm24 ? 16777215.0 : 65535.0;
                    CHECK(std::abs(static_cast<double>(stored) * levels - std::nearbyint(static_cast<double>(stored) * levels)) <= 0.5);
                }
            }
            // The planes themselves are stored exactly (z_tex 0 and 1 are representable in every format).
            CHECK(aaf::depth_from_z_tex(c.p, static_cast<double>(aaf::quantize_z_tex(fmt, 0.0)), c.n, c.f) == Approx(c.n).margin(1e-12));
            CHECK(aaf::depth_from_z_tex(c.p, static_cast<double>(aaf::quantize_z_tex(fmt, 1.0)), c.n, c.f) == Approx(c.f).epsilon(1e-12));
        }
}

TEST_CASE("the seed's orthographic world-z formula equals the light's z minus the reconstructed depth", "[shadow_maps][depth]") {
    for (const double n : {0.0, 0.5, 10.0})
        for (const double f : {20.0, 1e4})
            for (const double z : {0.0, 0.25, 0.5, 1.0}) {
                const double zc = 7.0;
                CHECK(aaf::seed_orthographic_world_z(zc, z, n, f) == Approx(zc - aaf::depth_from_z_tex(depth_projection::orthographic, z, n, f)).margin(1e-9));
                CHECK(aaf::depth_from_z_tex(depth_projection::orthographic, z, n, f) == Approx(n + z * (f - n)));
            }
}

TEST_CASE("light frames map world points to texels and back, both projections", "[shadow_maps][depth]") {
    for (const depth_projection p : {depth_projection::orthographic, depth_projection::perspective}) {
        aaf::light_view<double> v;
        v.projection = p;
        v.eye = {1, 5, -2};
        v.forward = {0.2, -1, 0.1};
        v.up = {0, 0, 1};
        v.near_plane = p == depth_projection::perspective ? 0.5 : -1.0;
        v.far_plane = 20;
        v.half_width = p == depth_projection::perspective ? 0.7 : 6.0;
        v.half_height = p == depth_projection::perspective ? 0.4 : 3.0;
        const aaf::light_frame<double> frame = aaf::make_light_frame(v);
        for (const glm::dvec3 q : {glm::dvec3(1, 0, -2), glm::dvec3(2.5, -3, 0.5), glm::dvec3(-0.5, 1, -3)}) {
            const glm::dvec3 l = frame.to_light(q);
            const glm::dvec2 uv = frame.texel_coords(l, 640, 480);
            const glm::dvec3 back = frame.world_point(uv.x, uv.y, l.z, 640, 480);
            CHECK(glm::length(back - q) < 1e-12);
        }
        // The ray through a texel centre hits, at depth d, the point world_point gives for that texel and depth.
        double dpt = 0;
        const aaf::shadow_segment<double> ray = frame.texel_ray(100, 200, 640, 480, dpt);
        const double t = 3.0;
        const glm::dvec3 hit = ray.origin + t * ray.direction;
        const double depth = v.near_plane + t * dpt;
        CHECK(glm::length(hit - frame.world_point(100.5, 200.5, depth, 640, 480)) < 1e-12);
        CHECK(frame.to_light(hit).z == Approx(depth));
    }
}

TEST_CASE("a map rendered through a tracer stores each texel's nearest occluder depth", "[shadow_maps][depth]") {
    aaf_test::analytic_scene<float> scene;  // occluder plate at y = 1 over x in [-0.6, 0.6], z in [-0.3, 0.3]
    const aaf_test::nearest_tracer<float> tracer{&scene};
    for (const depth_projection p : {depth_projection::orthographic, depth_projection::perspective})
        for (const depth_format fmt : formats) {
            aaf::light_view<float> v;
            v.projection = p;
            v.eye = {0, 3, 0};
            v.forward = {0, -1, 0};
            v.up = {0, 0, 1};
            v.near_plane = 0.1f;
            v.far_plane = 4;
            v.half_width = v.half_height = p == depth_projection::perspective ? 1.0f : 2.0f;
            aaf::depth_map<float> map(64, 48, v, fmt);
            const aaf::depth_render_stats st = aaf::render_depth_map(map, tracer);
            CHECK(st.texels == 64u * 48u);
            CHECK(st.failed == 0u);
            const aaf::light_frame<float> frame(v);
            std::uint64_t hits = 0;
            for (std::size_t j = 0; j < map.height(); ++j)
                for (std::size_t i = 0; i < map.width(); ++i) {
                    // Where the texel's centre ray crosses the occluder plane y = 1 (depth 2 from the eye).
                    const glm::vec3 q = frame.world_point(static_cast<float>(i) + 0.5f, static_cast<float>(j) + 0.5f, 2.0f, 64, 48);
                    const bool on = q.x > -0.6f && q.x < 0.6f && q.z > -0.3f && q.z < 0.3f;
                    if (!on) {
                        CHECK(map.z_tex(i, j) == 1.0f);
                        continue;
                    }
                    ++hits;
                    const double step = aaf::z_tex_step(fmt, 1.0) * aaf::depth_per_z_tex(p, 2.0, 0.1, 4.0);
                    CHECK(std::abs(static_cast<double>(map.depth(i, j)) - 2.0) <= step + 1e-5);
                }
            CHECK(st.hits == hits);
            CHECK(hits > 0u);
        }
}

TEST_CASE("a perspective map far from the origin gives every texel its own ray (scene scales up to 1e5)", "[shadow_maps][depth]") {
    // A tilted plane seen from a light at s·(−1, 3, −0.8): each texel's stored depth must be the plane's depth
    // along that texel's own centre ray (computed in double). Texel rays once went through world points at
    // depth 1, whose lateral offsets rounded away against the eye's coordinates at s = 1e5: neighbouring
    // texels shared a ray and stored depths a texel's depth change apart.
    struct tilted_plane {
        glm::vec3 point, normal;
        [[nodiscard]] float nearest_occluder(const aaf::shadow_segment<float>& r) const {
            const float t = glm::dot(point - r.origin, normal) / glm::dot(r.direction, normal);
            return t > 0 && t < r.length ? t : aaf::no_occluder<float>;
        }
    };
    for (const float s : {1.0f, 1e3f, 1e5f}) {
        INFO("scale " << s);
        const tilted_plane plane{s * glm::vec3(-1, 0, -0.8f), glm::normalize(glm::vec3(-0.3f, 1, 0.2f))};
        aaf::light_view<float> v;
        v.projection = depth_projection::perspective;
        v.eye = s * glm::vec3(-1, 3, -0.8f);
        v.forward = {0, -1, 0};
        v.up = {0, 0, 1};
        v.far_plane = 6 * s;
        v.near_plane = 1e-3f * v.far_plane;
        // Extents and sizes that make texel offsets no power-of-two fractions (those would be exact even at 1e5).
        v.half_width = 0.37f, v.half_height = 0.29f;
        const std::size_t w = 61, h = 47;
        aaf::depth_map<float> map(w, h, v, depth_format::float32);
        CHECK(aaf::render_depth_map(map, plane).hits == w * h);
        aaf::light_view<double> vd;
        vd.projection = v.projection;
        vd.eye = v.eye, vd.forward = v.forward, vd.up = v.up;
        vd.near_plane = v.near_plane, vd.far_plane = v.far_plane, vd.half_width = v.half_width, vd.half_height = v.half_height;
        const aaf::light_frame<double> frame(vd);
        double worst = -1;
        for (std::size_t j = 0; j < h; ++j)
            for (std::size_t i = 0; i < w; ++i) {
                const glm::dvec3 through = frame.world_point(static_cast<double>(i) + 0.5, static_cast<double>(j) + 0.5, 1.0, w, h) - frame.view.eye;
                const double depth = glm::dot(glm::dvec3(plane.point) - frame.view.eye, glm::dvec3(plane.normal)) /
                                     glm::dot(through, glm::dvec3(plane.normal));
                const double step = aaf::z_tex_step(depth_format::float32, 1.0) *
                                    aaf::depth_per_z_tex(depth_projection::perspective, depth, vd.near_plane, vd.far_plane);
                worst = std::max(worst, (std::abs(static_cast<double>(map.depth(i, j)) - depth) - step) / depth);
            }
        // Beyond the quantisation step: float rays and a float tracer, a few ulps of the depth; with the rounded rays
        // of a scene at 1e5 it was a sizeable fraction of a texel's depth change (up to 2e-3 of the depth, measured).
        CHECK(worst < 1e-5);
    }
}

TEST_CASE("shadow-map bad input: zero-sized map, near >= far, degenerate views, NaN or out-of-range depths", "[shadow_maps][depth][extremes]") {
    aaf::light_view<float> v;
    CHECK_THAT(aaf_test::what_of([&] { aaf::depth_map<float>(0, 16, v); }), Catch::Contains("`width` and `height`"));
    auto bad = v;
    bad.near_plane = bad.far_plane = 1;
    CHECK_THAT(aaf_test::what_of([&] { aaf::depth_map<float>(4, 4, bad); }), Catch::Contains("`view.near_plane` is not less than"));
    bad = v;
    bad.near_plane = 2;
    CHECK_THAT(aaf_test::what_of([&] { aaf::depth_map<float>(4, 4, bad); }), Catch::Contains("near_plane"));
    bad = v;
    bad.projection = aaf::depth_projection::perspective;
    bad.near_plane = 0;
    CHECK_THAT(aaf_test::what_of([&] { aaf::depth_map<float>(4, 4, bad); }), Catch::Contains("> 0 for a perspective view"));
    bad = v;
    bad.up = bad.forward;
    CHECK_THAT(aaf_test::what_of([&] { aaf::depth_map<float>(4, 4, bad); }), Catch::Contains("`view.up` is zero or parallel"));
    bad = v;
    bad.forward = glm::vec3(0);
    CHECK_THAT(aaf_test::what_of([&] { aaf::depth_map<float>(4, 4, bad); }), Catch::Contains("`view.forward` is zero"));
    bad = v;
    bad.half_width = 0;
    CHECK_THAT(aaf_test::what_of([&] { aaf::depth_map<float>(4, 4, bad); }), Catch::Contains("half_width"));
    bad = v;
    bad.eye.x = std::nanf("");
    CHECK_THAT(aaf_test::what_of([&] { aaf::depth_map<float>(4, 4, bad); }), Catch::Contains("non-finite"));
    bad = v;
    bad.near_plane = 1e8f, bad.far_plane = 1e8f + 1.0f;  // the same float
    CHECK_THAT(aaf_test::what_of([&] { aaf::depth_map<float>(4, 4, bad); }), Catch::Contains("view"));

    std::vector<float> depth(16, 0.5f);
    CHECK_NOTHROW(aaf::wrap_depth_buffer(aaf::const_image_view<float>(depth.data(), 4, 4), v));
    depth[5] = std::nanf("");
    CHECK_THAT(aaf_test::what_of([&] { (void)aaf::wrap_depth_buffer(aaf::const_image_view<float>(depth.data(), 4, 4), v); }),
               Catch::Contains("`depth` texel (1, 1)"));
    depth[5] = 1.5f;
    CHECK_THAT(aaf_test::what_of([&] { (void)aaf::wrap_depth_buffer(aaf::const_image_view<float>(depth.data(), 4, 4), v); }),
               Catch::Contains("`depth` texel (1, 1)"));
    depth[5] = -0.25f;
    CHECK_THAT(aaf_test::what_of([&] { (void)aaf::wrap_depth_buffer(aaf::const_image_view<float>(depth.data(), 4, 4), v); }),
               Catch::Contains("not a z_tex"));
    CHECK_THAT(aaf_test::what_of([&] { (void)aaf::wrap_depth_buffer(aaf::const_image_view<float>(depth.data(), 0, 4), v); }),
               Catch::Contains("`depth` has zero size"));

    const std::vector<glm::vec3> none = {glm::vec3(std::nanf(""))};
    CHECK_THAT(aaf_test::what_of([&] { (void)aaf::fit_orthographic_view(glm::vec3(0, -1, 0), none); }), Catch::Contains("no finite point"));
    CHECK_THAT(aaf_test::what_of([&] { (void)aaf::fit_orthographic_view(glm::vec3(0), none); }), Catch::Contains("`direction`"));
}
