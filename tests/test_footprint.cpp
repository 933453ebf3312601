// SPDX-License-Identifier: MIT
// Tilt-aware image-space widths (footprint.hpp, filter_settings::footprint): the pixel's footprint on its
// own surface from the G-buffer's positions, and render_frame using it.

#include <catch2/catch.hpp>

#include <cmath>
#include <limits>

#include <aaf/pipeline.hpp>

#include "support/analytic_scene.hpp"

TEST_CASE("surface_footprint: a plane tilted by 60 degrees along y spans 2d per row", "[footprint]") {
    const std::size_t w = 6, h = 5;
    const float d = 0.1f, c = 0.5f;  // cos 60°
    aaf::image<glm::vec3> p(w, h), n(w, h, glm::normalize(glm::vec3(0, c, std::sqrt(1 - c * c))));
    aaf::image<float> size(w, h, d), out(w, h);
    // Rows step down the plane by d / cos 60° = 2d (a camera looking along −z sees the plane at 60°).
    const glm::vec3 down = glm::normalize(glm::cross(glm::vec3(1, 0, 0), n(0, 0))) * (d / c);
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) p(x, y) = glm::vec3(float(x) * d, 0, 0) + float(y) * down;
    aaf::surface_footprint<float>(p, n, size, out.view(), aaf::pixel_footprint::surface_area);
    for (std::size_t i = 0; i < out.size(); ++i) CHECK(out.data()[i] == Approx(std::sqrt(2.0f) * d).epsilon(1e-5));
    aaf::surface_footprint<float>(p, n, size, out.view(), aaf::pixel_footprint::surface_max);
    for (std::size_t i = 0; i < out.size(); ++i) CHECK(out.data()[i] == Approx(2 * d).epsilon(1e-5));
    aaf::surface_footprint<float>(p, n, size, out.view(), aaf::pixel_footprint::camera);
    for (std::size_t i = 0; i < out.size(); ++i) CHECK(out.data()[i] == d);
    // Never below the camera's d (a step shorter than d is foreshortening noise, not a surface).
    aaf::image<float> big(w, h, 0.5f);
    aaf::surface_footprint<float>(p, n, big, out.view(), aaf::pixel_footprint::surface_max);
    for (std::size_t i = 0; i < out.size(); ++i) CHECK(out.data()[i] == 0.5f);
    // Another surface (normal beyond the threshold) or no surface is not a neighbour; no neighbour: d.
    const float nan = std::numeric_limits<float>::quiet_NaN();
    for (std::size_t x = 0; x < w; ++x) n(x, 2) = {1, 0, 0};
    p(0, 4) = glm::vec3(nan);
    aaf::surface_footprint<float>(p, n, size, out.view(), aaf::pixel_footprint::surface_max);
    CHECK(out(3, 2) == Approx(d));           // its rows above and below are another surface; along x, d
    CHECK(out(3, 1) == Approx(2 * d));       // one-sided: the row above
    CHECK(out(0, 4) == d);                   // a pixel without a surface keeps its pixel size
    CHECK_THROWS_WITH(aaf::surface_footprint<float>(p, n, size, size.view(), aaf::pixel_footprint::surface_max), Catch::Contains("alias"));
}

TEST_CASE("render_frame with tilt-aware footprints equals camera footprints on a face-on receiver", "[footprint]") {
    aaf_test::analytic_scene<float> sc;
    sc.width = sc.height = 32;
    const aaf_test::analytic_gbuffer<float> gb(sc);
    const aaf_test::span_tracer<float> tracer{&sc};
    aaf::image<float> a(32, 32), b(32, 32);
    aaf::frame_workspace<float> ws;
    aaf::frame_settings<float> s;
    aaf::render_frame(gb.view_with_ids(), sc.area_light(), tracer, {a.view()}, ws, s);
    s.filter.footprint = aaf::pixel_footprint::surface_area;
    aaf::render_frame(gb.view_with_ids(), sc.area_light(), tracer, {b.view()}, ws, s);
    for (std::size_t i = 0; i < a.size(); ++i) CHECK(b.data()[i] == Approx(a.data()[i]).margin(1e-5));
    s.filter.footprint = static_cast<aaf::pixel_footprint>(7);
    CHECK_THROWS_WITH(aaf::render_frame(gb.view(), sc.area_light(), tracer, {b.view()}, ws, s), Catch::Contains("settings.filter.footprint"));
}
