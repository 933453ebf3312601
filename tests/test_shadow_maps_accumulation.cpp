// SPDX-License-Identifier: MIT
// Heckbert–Herf accumulation: with the tracer as the hard-shadow source it is regular-grid Monte Carlo
// (aaf::gather_visibility) exactly; with depth maps it differs from that only by light points whose hard
// shadow edge lies within a texel footprint of the receiver; and it converges to the analytic visibility
// as M grows.

#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

#include <aaf/gather.hpp>
#include <aaf/shadow_maps.hpp>

#include "support/analytic_scene.hpp"
#include "support/helpers.hpp"

namespace {

aaf_test::analytic_scene<float> small_scene() {
    aaf_test::analytic_scene<float> s;
    s.width = s.height = 40;
    s.occluders.push_back({-1.4f, -0.9f, 0.5f, 1.1f, 0.6f});  // a second, lower occluder: two depths
    return s;
}

}  // namespace

TEST_CASE("accumulation through the tracer is regular-grid Monte Carlo with M^2 samples", "[shadow_maps][accumulation]") {
    const auto scene = small_scene();
    const aaf_test::analytic_gbuffer<float> g(scene);
    const aaf_test::nearest_tracer<float> tracer{&scene};
    for (const std::uint32_t m : {2u, 5u}) {
        aaf::accumulation_settings<float> s;
        s.grid = m;
        s.source = aaf::hard_shadow_source::tracer;
        aaf::image<float> acc(scene.width, scene.height);
        const aaf::accumulation_stats st = aaf::accumulate_hard_shadows(g.view(), scene.area_light(), tracer, s, acc.view());
        CHECK(st.passes == m * m);
        CHECK(st.map_bytes == 0u);
        aaf::sampling_settings mc;
        mc.pattern = aaf::sample_pattern::regular_grid;
        mc.initial_samples = mc.max_samples = m * m;
        aaf::image<aaf::occlusion_stats<float>> stats(scene.width, scene.height);
        aaf::gather_visibility(g.view(), scene.area_light(), tracer, mc, 0, m * m, stats.view());
        std::size_t differ = 0;
        for (std::size_t y = 0; y < scene.height; ++y)
            for (std::size_t x = 0; x < scene.width; ++x) differ += acc(x, y) != stats(x, y).visibility() ? 1 : 0;
        CHECK(differ == 0u);
    }
}

TEST_CASE("accumulation of M x M depth maps equals M^2-sample regular-grid Monte Carlo up to one texel footprint",
          "[shadow_maps][accumulation]") {
    const auto scene = small_scene();
    const aaf_test::analytic_gbuffer<float> g(scene);
    const aaf_test::nearest_tracer<float> tracer{&scene};
    const aaf::area_light<float> light = scene.area_light();
    for (const std::uint32_t m : {2u, 4u})
        for (const std::uint32_t size : {24u, 256u}) {
            const aaf::depth_format fmt = size == 256 ? aaf::depth_format::unorm16 : aaf::depth_format::unorm24;
            aaf::accumulation_settings<float> s;
            s.grid = m;
            s.map_size = size;
            s.format = fmt;
            aaf::image<float> maps(scene.width, scene.height), traced(scene.width, scene.height);
            const aaf::accumulation_stats st = aaf::accumulate_hard_shadows(g.view(), light, tracer, s, maps.view());
            CHECK(st.map_bytes == std::size_t{size} * size * sizeof(float));
            CHECK(st.rays == std::uint64_t{m} * m * size * size);
            s.source = aaf::hard_shadow_source::tracer;
            aaf::accumulate_hard_shadows(g.view(), light, tracer, s, traced.view());
            // The oracle: for every light point, is the receiver within one texel footprint (of that point's map,
            // at the receiver's depth) of its hard shadow's edge? Only those points may disagree.
            std::vector<glm::vec2> uv(std::size_t{m} * m);
            aaf::generate_samples<float>(aaf::sample_pattern::regular_grid, {}, uv);
            std::size_t near_edge_pixels = 0, worst_excess = 0;
            double sum_abs = 0;
            for (std::size_t y = 0; y < scene.height; ++y)
                for (std::size_t x = 0; x < scene.width; ++x) {
                    const glm::vec3 p = scene.position(x, y);
                    std::size_t near_edge = 0;
                    for (const glm::vec2& u : uv) {
                        const glm::vec3 yl = light.point(u.x, u.y);
                        aaf::light_view<float> view;
                        REQUIRE(aaf::fit_perspective_view(g.view(), yl, light.normal(), s.near_fraction, s.max_half_tan, view));
                        const float fp = aaf::light_frame<float>(view).texel_footprint(yl.y - p.y, size, size).x;
                        const auto lit_at = [&](glm::vec3 q) {
                            const glm::vec3 d = yl - q;
                            return !scene.span({q, glm::normalize(d), glm::length(d)}).hit();
                        };
                        const bool here = lit_at(p);
                        bool edge = false;
                        for (int dz = -1; dz <= 1; ++dz)
                            for (int dx = -1; dx <= 1; ++dx)
                                edge = edge || lit_at(p + fp * glm::vec3(static_cast<float>(dx), 0, static_cast<float>(dz))) != here;
                        near_edge += edge ? 1 : 0;
                    }
                    near_edge_pixels += near_edge ? 1 : 0;
                    const double diff = std::abs(static_cast<double>(maps(x, y)) - static_cast<double>(traced(x, y)));
                    sum_abs += diff;
                    const double allowed = static_cast<double>(near_edge) / static_cast<double>(m * m) + 1e-6;
                    if (diff > allowed) ++worst_excess;
                }
            INFO("M " << m << " map " << size << " " << aaf::to_string(fmt) << " mean |maps - traced| " << sum_abs / (scene.width * scene.height)
                      << ", pixels near an edge " << near_edge_pixels);
            CHECK(worst_excess == 0u);
            if (size == 24) CHECK(sum_abs > 0);  // a coarse map does differ, so the bound is exercised
            CHECK(near_edge_pixels < scene.width * scene.height / 2);  // most pixels must match exactly
        }
}

TEST_CASE("accumulation converges to the analytic visibility as M grows", "[shadow_maps][accumulation]") {
    auto scene = small_scene();
    scene.width = scene.height = 32;
    const aaf_test::analytic_gbuffer<float> g(scene);
    const aaf_test::nearest_tracer<float> tracer{&scene};
    const aaf::image<double> exact = scene.exact_image();
    double previous = 1e9;
    for (const std::uint32_t m : {1u, 2u, 4u, 8u, 16u}) {
        aaf::accumulation_settings<float> s;
        s.grid = m;
        s.map_size = 256;
        aaf::image<float> acc(scene.width, scene.height);
        aaf::accumulate_hard_shadows(g.view(), scene.area_light(), tracer, s, acc.view());
        const double e = aaf_test::rmse(acc, exact);
        INFO("M " << m << " RMSE " << e);
        // The regular grid is a midpoint rule per light axis: each axis miscounts a straight shadow edge by at
        // most half a cell, so the error is at most 1/M (two axes) plus the maps' texel-size error.
        CHECK(e <= 1.0 / m + 0.01);
        if (m > 1) CHECK(e < previous);
        previous = e;
    }
}

TEST_CASE("accumulation: bad input throws naming the argument; receivers no light point lights are 0, sky 1",
          "[shadow_maps][accumulation][extremes]") {
    auto scene = small_scene();
    scene.width = scene.height = 8;
    aaf_test::analytic_gbuffer<float> g(scene);
    const aaf_test::nearest_tracer<float> tracer{&scene};
    aaf::image<float> out(8, 8, -1.0f);
    aaf::accumulation_settings<float> s;
    auto light = scene.area_light();
    light.edge_v = light.edge_u;  // degenerate: zero area
    CHECK_THAT(aaf_test::what_of([&] { aaf::accumulate_hard_shadows(g.view(), light, tracer, s, out.view()); }), Catch::Contains("`light` has zero area"));
    s.grid = 0;
    CHECK_THAT(aaf_test::what_of([&] { aaf::accumulate_hard_shadows(g.view(), scene.area_light(), tracer, s, out.view()); }), Catch::Contains("`settings.grid`"));
    s.grid = 2;
    s.map_size = 0;
    CHECK_THAT(aaf_test::what_of([&] { aaf::accumulate_hard_shadows(g.view(), scene.area_light(), tracer, s, out.view()); }), Catch::Contains("`settings.map_size`"));
    s.map_size = 64;
    s.near_fraction = 1;
    CHECK_THAT(aaf_test::what_of([&] { aaf::accumulate_hard_shadows(g.view(), scene.area_light(), tracer, s, out.view()); }), Catch::Contains("`settings.near_fraction`"));
    s.near_fraction = 1e-3f;
    CHECK(out(0, 0) == -1.0f);
    g.positions(0, 0) = glm::vec3(std::nanf(""));   // sky
    g.positions(1, 0) = glm::vec3(0, 5, 0);          // above the one-sided light: not lit by any point
    aaf::accumulate_hard_shadows(g.view(), scene.area_light(), tracer, s, out.view());
    CHECK(out(0, 0) == 1.0f);
    CHECK(out(1, 0) == 0.0f);
    CHECK(out(2, 0) == 1.0f);  // an ordinary lit receiver beside them
}

TEST_CASE("accumulation with the sampler's stratified and low-discrepancy light points; double precision",
          "[shadow_maps][accumulation]") {
    auto scene = small_scene();
    scene.width = scene.height = 32;
    const aaf_test::analytic_gbuffer<float> g(scene);
    const aaf_test::nearest_tracer<float> tracer{&scene};
    const aaf::image<double> exact = scene.exact_image();
    for (const auto pattern : {aaf::sample_pattern::stratified, aaf::sample_pattern::low_discrepancy}) {
        aaf::accumulation_settings<float> s;
        s.grid = 8;
        s.map_size = 256;
        s.pattern = pattern;
        aaf::image<float> acc(scene.width, scene.height);
        aaf::accumulate_hard_shadows(g.view(), scene.area_light(), tracer, s, acc.view());
        INFO(aaf::to_string(pattern) << " RMSE " << aaf_test::rmse(acc, exact));
        // 64 points spread over the light: within the regular grid's 1/M bound, without its banding.
        CHECK(aaf_test::rmse(acc, exact) <= 1.0 / 8 + 0.01);
    }
    // The same in double: tracer source equals gather_visibility, maps stay within the texel bound's spirit.
    aaf_test::analytic_scene<double> sd;
    sd.width = sd.height = 24;
    const aaf_test::analytic_gbuffer<double> gd(sd);
    const aaf_test::nearest_tracer<double> td{&sd};
    aaf::accumulation_settings<double> s;
    s.grid = 3;
    s.source = aaf::hard_shadow_source::tracer;
    aaf::image<double> traced(24, 24), maps(24, 24);
    aaf::accumulate_hard_shadows(gd.view(), sd.area_light(), td, s, traced.view());
    aaf::sampling_settings mc;
    mc.pattern = aaf::sample_pattern::regular_grid;
    mc.initial_samples = mc.max_samples = 9;
    aaf::image<aaf::occlusion_stats<double>> stats(24, 24);
    aaf::gather_visibility(gd.view(), sd.area_light(), td, mc, 0, 9, stats.view());
    bool same = true;
    for (std::size_t y = 0; y < 24; ++y)
        for (std::size_t x = 0; x < 24; ++x) same = same && traced(x, y) == stats(x, y).visibility();
    CHECK(same);
    s.source = aaf::hard_shadow_source::depth_maps;
    s.map_size = 512;
    aaf::accumulate_hard_shadows(gd.view(), sd.area_light(), td, s, maps.view());
    CHECK(aaf_test::rmse(maps, traced) < 0.02);
}
