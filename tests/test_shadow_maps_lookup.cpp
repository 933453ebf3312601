// SPDX-License-Identifier: MIT
// Shadow-map lookups: PCF of a straight occluder edge against the analytic covered fraction of the kernel,
// PCSS on the parallel-planes scene against the analytic penumbra, tiles equal to full frames, defined
// results at the edges of the map, and bad settings.

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include <aaf/executor.hpp>
#include <aaf/shadow_maps.hpp>

#include "support/analytic_scene.hpp"
#include "support/helpers.hpp"

namespace {

/// A 64×64 orthographic map looking down −y from y = 10 over [−4, 4]²: texels of column i < `edge` hold an
/// occluder at depth 5 (y = 5), the rest nothing. Receivers lie on the ground (depth 10) facing up.
struct edge_map {
    static constexpr std::size_t size = 64;
    std::vector<float> depth;
    aaf::light_view<float> view;
    aaf::depth_map_view<float> map;
    aaf::light_frame<float> frame;
    explicit edge_map(std::size_t edge) : depth(size * size, 1.0f) {
        view.eye = {0, 10, 0};
        view.forward = {0, -1, 0};
        view.up = {0, 0, 1};
        view.near_plane = 0;
        view.far_plane = 20;
        view.half_width = view.half_height = 4;
        const float z5 = aaf::z_tex_from_depth(view.projection, 5.0f, 0.0f, 20.0f);
        for (std::size_t j = 0; j < size; ++j)
            for (std::size_t i = 0; i < edge; ++i) depth[j * size + i] = z5;
        map = aaf::wrap_depth_buffer(aaf::const_image_view<float>(depth.data(), size, size), view, aaf::depth_format::unorm24);
        frame = aaf::light_frame<float>(view);
    }
    [[nodiscard]] glm::vec3 receiver(float u, float v) const { return frame.world_point(u, v, 10.0f, size, size); }
};

/// Covered fraction of the square [u − r, u + r] (any v) by the half-plane u' < e.
double covered_square(double u, double r, double e) { return std::clamp((e - (u - r)) / (2 * r), 0.0, 1.0); }
/// Mean over [u − r, u + r] of the covered fraction a bilinear tap reads: 1 left of e − ½, 0 right of e + ½,
/// linear between (the integral of clamp(e + ½ − x, 0, 1) in closed form).
double covered_ramp(double u, double r, double e) {
    // covered(x) = 1 left of e − ½, 1 − t on the ramp (t = x − e + ½ ∈ [0, 1]), 0 right of it; the ramp's part
    // of the integral up to x is G(t) = t − t²/2 with t clamped.
    const auto integral = [e](double x) {
        const double t = std::clamp(x - (e - 0.5), 0.0, 1.0);
        return t - 0.5 * t * t;
    };
    const double a = u - r, b = u + r;
    const double left = std::max(0.0, std::min(b, e - 0.5) - a);
    return (left + integral(b) - integral(a)) / (2 * r);
}
/// Covered fraction of the disc of radius r centred at u by the half-plane u' < e (circular segment).
double covered_disc(double u, double r, double e) {
    const double d = std::clamp((u - e) / r, -1.0, 1.0);  // signed distance of the centre beyond the edge
    const double seg = (std::acos(d) - d * std::sqrt(1 - d * d)) / std::numbers::pi;
    return seg;
}

}  // namespace

TEST_CASE("PCF of a straight occluder edge equals the kernel's analytic covered fraction", "[shadow_maps][pcf]") {
    const edge_map m(32);
    const glm::vec3 up(0, 1, 0);
    for (const std::uint32_t taps : {4u, 16u, 64u})
        for (const float radius : {1.0f, 2.0f, 3.5f})
            for (const bool bilinear : {false, true}) {
                aaf::lookup_settings<float> s;
                s.filter = aaf::shadow_filter::pcf;
                s.pcf.taps = taps;
                s.pcf.radius = radius;
                s.pcf.bilinear = bilinear;
                const aaf::shadow_map_sampler<float> sampler(m.map, s);
                const double n = std::sqrt(static_cast<double>(taps));
                // Grid taps at cell centres count the covered cells to within half a cell: 1/(2N). A bilinear tap
                // reads the edge as a ramp one texel wide, so its oracle is the kernel's mean of that ramp, and the
                // midpoint rule errs by at most the ramp's total variation over N cells: 1/N.
                const double bound = (bilinear ? 1.0 : 0.5) / n + 1e-6;
                double worst = 0;
                for (float u = 24.0f; u <= 40.0f; u += 0.0625f) {
                    const double v = sampler.visibility(m.receiver(u, 20.3f), up);
                    const double uu = static_cast<double>(u), r = static_cast<double>(radius);
                    const double exact = bilinear ? 1.0 - covered_ramp(uu, r, 32.0) : 1.0 - covered_square(uu, r, 32.0);
                    worst = std::max(worst, std::abs(v - exact));
                }
                INFO("taps " << taps << " radius " << radius << " bilinear " << bilinear);
                CHECK(worst <= bound);
            }
}

TEST_CASE("Poisson-disc PCF follows the disc's analytic covered fraction; the rotated disc is per-pixel and deterministic",
          "[shadow_maps][pcf]") {
    const edge_map m(32);
    const glm::vec3 up(0, 1, 0);
    for (const auto pattern : {aaf::pcf_pattern::poisson, aaf::pcf_pattern::rotated_poisson}) {
        aaf::lookup_settings<float> s;
        s.pcf.pattern = pattern;
        s.pcf.taps = 64;
        s.pcf.radius = 4;
        const aaf::shadow_map_sampler<float> sampler(m.map, s);
        double sum2 = 0, worst = 0;
        std::size_t count = 0;
        for (float u = 26.0f; u <= 38.0f; u += 0.125f) {
            const aaf::sample_key key{static_cast<std::uint32_t>(u * 8), 7, 0, 0, 0};
            const double v = sampler.visibility(m.receiver(u, 20.3f), up, key);
            const double e = v - (1.0 - covered_disc(static_cast<double>(u), 4.0, 32.0));
            sum2 += e * e, worst = std::max(worst, std::abs(e)), ++count;
            CHECK(v == static_cast<double>(sampler.visibility(m.receiver(u, 20.3f), up, key)));  // same key, same taps
        }
        // 64 best-candidate taps estimate a disc's area fraction to a few per cent; a fixed set errs the same
        // way for every pixel, the rotated one differently for each.
        INFO(aaf::to_string(pattern));
        CHECK(std::sqrt(sum2 / static_cast<double>(count)) < 0.03);
        CHECK(worst < 0.08);
    }
    const std::vector<glm::vec2> disc = aaf::poisson_disc<float>(32);
    REQUIRE(disc.size() == 32u);
    float closest = 1e9f;
    for (std::size_t a = 0; a < disc.size(); ++a) {
        CHECK(glm::length(disc[a]) <= 1.0f);
        for (std::size_t b = 0; b < a; ++b) closest = std::min(closest, glm::length(disc[a] - disc[b]));
    }
    // Best-candidate sets keep points apart: far more than random points would (expected ~0.1 for 32 in a disc).
    CHECK(closest > 0.2f);
}

TEST_CASE("PCSS on parallel planes: penumbra width and profile match the analytic soft shadow", "[shadow_maps][pcss]") {
    aaf_test::analytic_scene<float> scene;  // light 1.5 wide at y = 3, occluder at y = 1, receiver y = 0
    const aaf_test::nearest_tracer<float> tracer{&scene};
    aaf::light_view<float> v;
    v.projection = aaf::depth_projection::perspective;
    v.eye = {0, 3, 0};  // the light's centre
    v.forward = {0, -1, 0};
    v.up = {0, 0, 1};
    v.near_plane = 0.5f;
    v.far_plane = 4;
    v.half_width = v.half_height = 0.75f;  // covers the receiver over [-2.25, 2.25]
    aaf::depth_map<float> map(512, 512, v, aaf::depth_format::unorm24);
    aaf::render_depth_map(map, tracer);
    aaf::lookup_settings<float> s;
    s.filter = aaf::shadow_filter::pcss;
    s.pcf.taps = 64;
    s.pcss.light_width = 1.5f;
    s.pcss.max_radius = 128;
    const aaf::shadow_map_sampler<float> sampler(map, s);
    const glm::vec3 up(0, 1, 0);
    // Analytic: w = w_light·(d_r − d_b)/d_b = 1.5·(3 − 2)/2 = 0.75, the ramp of exact_visibility from x = 0.525 to 1.275.
    const double w_exact = 0.75;
    CHECK(scene.exact_visibility({0.525f, 0, 0}) == Approx(0.0).margin(1e-9));
    CHECK(scene.exact_visibility({1.275f, 0, 0}) == Approx(1.0).margin(1e-9));
    const double texel = 2 * 0.75 * 3.0 / 512;  // footprint at the receiver's depth
    double worst = 0;
    for (float x = 0.0f; x <= 2.0f; x += 0.01f) {
        const glm::vec3 p(x, 0, 0.01f);
        if (x > 0.55f && x < 1.25f) CHECK(sampler.pcss_penumbra_width(p, up) == Approx(w_exact).margin(0.01));
        worst = std::max(worst, std::abs(static_cast<double>(sampler.visibility(p, up)) - scene.exact_visibility(p)));
    }
    // A box kernel of width w on the hard shadow from the light's centre is the exact soft shadow of a square
    // light on parallel planes; what remains is the 8×8 grid's counting (1/16) and the edge's texel (1 texel of 0.75).
    CHECK(worst <= 1.0 / 16 + 2 * texel / w_exact);
}

TEST_CASE("shadow_lookup: tiles equal the full frame bit for bit, threads change nothing", "[shadow_maps][pcf]") {
    const edge_map m(30);
    const std::size_t w = 40, h = 24;
    aaf::image<glm::vec3> pos(w, h), nrm(w, h, glm::vec3(0.1f, 1, 0.05f));
    aaf::image<float> size(w, h, 0.1f);
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) pos(x, y) = m.receiver(14.0f + 0.9f * static_cast<float>(x), 20.0f + 0.7f * static_cast<float>(y));
    for (const auto filter : {aaf::shadow_filter::hard, aaf::shadow_filter::pcf})
        for (const auto pattern : {aaf::pcf_pattern::grid, aaf::pcf_pattern::rotated_poisson}) {
            aaf::lookup_settings<float> s;
            s.filter = filter;
            s.pcf.pattern = pattern;
            s.frame_seed = 3;
            aaf::image<float> full(w, h), tile(17, 9, -1.0f), pooled(w, h);
            const aaf::gbuffer<float> gb{pos.cview(), nrm.cview(), size.cview(), {}};
            aaf::shadow_lookup(m.map, gb, s, full.view());
            aaf::thread_pool pool(2);
            aaf::shadow_lookup(m.map, gb, s, pooled.view(), {}, pool);
            const aaf::gbuffer<float> sub{pos.cview().subview(11, 5, 17, 9), nrm.cview().subview(11, 5, 17, 9), size.cview().subview(11, 5, 17, 9), {}};
            aaf::shadow_lookup(m.map, sub, s, tile.view(), aaf::frame_region{11, 5});
            bool same = true, varied = false;
            for (std::size_t y = 0; y < h; ++y)
                for (std::size_t x = 0; x < w; ++x) {
                    same = same && pooled(x, y) == full(x, y);
                    varied = varied || (full(x, y) > 0.0f && full(x, y) < 1.0f);
                }
            for (std::size_t y = 0; y < 9; ++y)
                for (std::size_t x = 0; x < 17; ++x) same = same && tile(x, y) == full(x + 11, y + 5);
            CHECK(same);
            if (filter == aaf::shadow_filter::pcf) CHECK(varied);
        }
}

TEST_CASE("shadow lookups: defined results outside the map and for missing surfaces; bad settings throw", "[shadow_maps][extremes]") {
    const edge_map m(64);  // everything occluded at depth 5
    const glm::vec3 up(0, 1, 0);
    aaf::lookup_settings<float> s;
    s.filter = aaf::shadow_filter::hard;
    const aaf::shadow_map_sampler<float> sampler(m.map, s);
    CHECK(sampler.visibility(m.receiver(10, 10), up) == 0.0f);
    CHECK(sampler.visibility(m.receiver(-3, 10), up) == 1.0f);           // beside the frustum: lit
    CHECK(sampler.visibility(m.frame.world_point(10, 10, 25.0f, 64, 64), up) == 1.0f);  // beyond far: lit
    CHECK(sampler.visibility(m.frame.world_point(10, 10, 3.0f, 64, 64), up) == 1.0f);   // in front of the occluder
    CHECK(sampler.visibility(glm::vec3(std::nanf("")), up) == 1.0f);     // no surface
    CHECK(sampler.visibility(m.receiver(10, 10), glm::vec3(std::nanf(""))) == 1.0f);
    // A stored NaN (possible in an owning map written by the caller) never occludes.
    aaf::depth_map<float> own(4, 4, m.view, aaf::depth_format::float32);
    for (std::size_t j = 0; j < 4; ++j)
        for (std::size_t i = 0; i < 4; ++i) own.store_depth(i, j, 5.0f);
    own.store_z_tex(1, 1, std::nan(""));
    const aaf::shadow_map_sampler<float> own_sampler(own, s);
    CHECK(own_sampler.visibility(m.frame.world_point(1.5f, 1.5f, 10.0f, 4, 4), up) == 1.0f);
    CHECK(own_sampler.visibility(m.frame.world_point(2.5f, 1.5f, 10.0f, 4, 4), up) == 0.0f);

    const auto bad = [&](auto edit) {
        aaf::lookup_settings<float> b;
        edit(b);
        return aaf_test::what_of([&] { aaf::shadow_map_sampler<float>(m.map, b); });
    };
    CHECK_THAT(bad([](auto& b) { b.pcf.taps = 0; }), Catch::Contains("`settings.pcf.taps`"));
    CHECK_THAT(bad([](auto& b) { b.pcf.radius = -1; }), Catch::Contains("`settings.pcf.radius`"));
    CHECK_THAT(bad([](auto& b) { b.bias.constant = std::nanf(""); }), Catch::Contains("`settings.bias.constant`"));
    CHECK_THAT(bad([](auto& b) { b.bias.scale = 0.5f; }), Catch::Contains("`settings.bias.scale`"));
    CHECK_THAT(bad([](auto& b) { b.filter = aaf::shadow_filter::pcss; }), Catch::Contains("`settings.pcss.light_angle`"));
    auto persp = m.view;
    persp.projection = aaf::depth_projection::perspective;
    persp.near_plane = 1;
    persp.half_width = persp.half_height = 1;
    aaf::lookup_settings<float> p;
    p.filter = aaf::shadow_filter::pcss;
    CHECK_THAT(aaf_test::what_of([&] { aaf::shadow_map_sampler<float>(aaf::depth_map_view<float>{m.map.depth, persp, {}}, p); }),
               Catch::Contains("`settings.pcss.light_width`"));
    CHECK_THAT(aaf_test::what_of([&] { aaf::shadow_map_sampler<float>(aaf::depth_map_view<float>{}, s); }), Catch::Contains("`map.depth`"));

    aaf::image<glm::vec3> pos(8, 8, m.receiver(10, 10)), nrm(8, 8, up);
    aaf::image<float> out(8, 7, 0.5f);
    const aaf::gbuffer<float> gb{pos.cview(), nrm.cview(), {}, {}};
    CHECK_THAT(aaf_test::what_of([&] { aaf::shadow_lookup(m.map, gb, s, out.view()); }), Catch::Contains("`visibility` is 8x7"));
    CHECK(out(0, 0) == 0.5f);  // nothing written
}
