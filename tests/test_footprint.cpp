// SPDX-License-Identifier: MIT
// Tilt-aware image-space widths (footprint.hpp, filter_settings::footprint): the pixel's footprint on its
// own surface from the G-buffer's positions, and render_frame using it.

#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
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

TEST_CASE("surface_footprint_axes: a plane tilted along both image axes has s_x = d sqrt(1 + a^2), s_y = d sqrt(1 + b^2)",
          "[footprint][tilt]") {
    // An orthographic camera looking along −z at the plane z = −(a·X + b·Y) (normal ∝ (a, b, 1)): pixel
    // (x, y) sees (x d, y d, −(a x + b y) d), so a step along x moves d·√(1 + a²) on the plane and a step
    // along y d·√(1 + b²). a = √3: 60° of tilt along x (s_x = 2d); b = 1: 45° along y (s_y = √2 d).
    const std::size_t w = 7, h = 6;
    const float d = 0.05f, a = std::sqrt(3.0f), b = 1.0f;
    aaf::image<glm::vec3> p(w, h), n(w, h, glm::normalize(glm::vec3(a, b, 1)));
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) p(x, y) = glm::vec3(float(x) * d, float(y) * d, -(a * float(x) + b * float(y)) * d);
    aaf::image<float> size(w, h, d), sx(w, h), sy(w, h), one(w, h);
    aaf::surface_footprint_axes<float>(p, n, size, sx.view(), sy.view());
    for (std::size_t i = 0; i < sx.size(); ++i) {
        CHECK(sx.data()[i] == Approx(2 * d).epsilon(1e-5));
        CHECK(sy.data()[i] == Approx(std::sqrt(2.0f) * d).epsilon(1e-5));
    }
    // The scalar modes are the two axes' geometric mean and maximum (on a plane the central and the
    // one-sided steps agree up to rounding).
    aaf::surface_footprint<float>(p, n, size, one.view(), aaf::pixel_footprint::surface_area);
    for (std::size_t i = 0; i < one.size(); ++i) CHECK(one.data()[i] == Approx(std::sqrt(sx.data()[i] * sy.data()[i])).epsilon(1e-5));
    aaf::surface_footprint<float>(p, n, size, one.view(), aaf::pixel_footprint::surface_max);
    for (std::size_t i = 0; i < one.size(); ++i) CHECK(one.data()[i] == Approx(std::max(sx.data()[i], sy.data()[i])).epsilon(1e-5));
    // Projected on a light's plane first (light_axes): on the plane's own normal, the steps themselves; on
    // the image plane (normal z), the x step (d, 0, −a d) becomes (d, 0, 0): d on both axes; on the plane of
    // normal x, the x step keeps only its −a d: √3 d, and the y step (0, d, −b d) is unchanged: √2 d.
    aaf::image<float> lx(w, h), ly(w, h);
    aaf::surface_footprint_light_axes<float>(p, n, size, n(0, 0) * 3.0f, lx.view(), ly.view());
    for (std::size_t i = 0; i < lx.size(); ++i) {
        CHECK(lx.data()[i] == Approx(sx.data()[i]).epsilon(1e-5));
        CHECK(ly.data()[i] == Approx(sy.data()[i]).epsilon(1e-5));
    }
    aaf::surface_footprint_light_axes<float>(p, n, size, glm::vec3(0, 0, -2), lx.view(), ly.view());
    for (std::size_t i = 0; i < lx.size(); ++i) {
        CHECK(lx.data()[i] == Approx(d).epsilon(1e-5));
        CHECK(ly.data()[i] == Approx(d).epsilon(1e-5));
    }
    aaf::surface_footprint_light_axes<float>(p, n, size, glm::vec3(1, 0, 0), lx.view(), ly.view());
    for (std::size_t i = 0; i < lx.size(); ++i) {
        CHECK(lx.data()[i] == Approx(a * d).epsilon(1e-5));
        CHECK(ly.data()[i] == Approx(std::sqrt(2.0f) * d).epsilon(1e-5));
    }
    CHECK_THROWS_WITH(aaf::surface_footprint_light_axes<float>(p, n, size, glm::vec3(0), lx.view(), ly.view()),
                      Catch::Contains("light_normal"));
    CHECK_THROWS_WITH(aaf::surface_footprint<float>(p, n, size, one.view(), aaf::pixel_footprint::light_axes),
                      Catch::Contains("surface_footprint_light_axes"));
    // Each axis at least the camera's d, on its own: with d = 1.6·(2d) the horizontal step is clamped to it and
    // so is the vertical one; with d between the two steps only the shorter axis is.
    aaf::image<float> mid(w, h, 1.6f * d);
    aaf::surface_footprint_axes<float>(p, n, mid, sx.view(), sy.view());
    CHECK(sx(3, 3) == Approx(2 * d).epsilon(1e-5));
    CHECK(sy(3, 3) == 1.6f * d);
    // A silhouette: column 4 onwards is another surface (normal beyond the threshold), row 0 has no
    // surface. Column 3 steps one-sided to column 2 (still 2d); column 4's neighbours along x are column 5
    // (same new surface, a flat step d) ; row 1 steps one-sided to row 2 along y.
    const float nan = std::numeric_limits<float>::quiet_NaN();
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 4; x < w; ++x) n(x, y) = {0, 0, 1}, p(x, y) = glm::vec3(float(x) * d, float(y) * d, -1.0f);
    for (std::size_t x = 0; x < w; ++x) p(x, 0) = glm::vec3(nan);
    aaf::surface_footprint_axes<float>(p, n, size, sx.view(), sy.view());
    CHECK(sx(3, 3) == Approx(2 * d).epsilon(1e-5));
    CHECK(sx(4, 3) == Approx(d).epsilon(1e-5));
    CHECK(sy(4, 3) == Approx(d).epsilon(1e-5));
    CHECK(sy(2, 1) == Approx(std::sqrt(2.0f) * d).epsilon(1e-5));
    CHECK(sx(2, 0) == d);  // no surface: the pixel size on both axes
    CHECK(sy(2, 0) == d);
    // A depth jump to a parallel surface (the same normal: it passes the normal test), like a blind's next
    // slat: rows 0–2 are the tilted plane, rows 3–5 the same plane moved 1 unit along its normal. Row 2's
    // vertical step is its one-sided step to row 1 (not half the jump, as the central distance of the scalar
    // modes would have it); the scalar modes keep their central rule.
    {
        aaf::image<glm::vec3> pj(w, h), nj(w, h, glm::normalize(glm::vec3(a, b, 1)));
        for (std::size_t y = 0; y < h; ++y)
            for (std::size_t x = 0; x < w; ++x)
                pj(x, y) = glm::vec3(float(x) * d, float(y) * d, -(a * float(x) + b * float(y)) * d) + (y >= 3 ? nj(0, 0) : glm::vec3(0));
        aaf::surface_footprint_axes<float>(pj, nj, size, sx.view(), sy.view());
        CHECK(sy(3, 2) == Approx(std::sqrt(2.0f) * d).epsilon(1e-5));
        CHECK(sy(3, 3) == Approx(std::sqrt(2.0f) * d).epsilon(1e-5));
        CHECK(sx(3, 2) == Approx(2 * d).epsilon(1e-5));
        aaf::surface_footprint<float>(pj, nj, size, one.view(), aaf::pixel_footprint::surface_max);
        CHECK(one(3, 2) > 5 * d);  // half the jump
    }
    // A lone pixel (no neighbour on its surface along either axis): d on both.
    aaf::image<glm::vec3> p1(1, 1, glm::vec3(0)), n1(1, 1, glm::vec3(0, 0, 1));
    aaf::image<float> d1(1, 1, d), x1(1, 1), y1(1, 1);
    aaf::surface_footprint_axes<float>(p1, n1, d1, x1.view(), y1.view());
    CHECK(x1(0, 0) == d);
    CHECK(y1(0, 0) == d);
    // Misuse: one output for two footprints, aliased outputs, mismatched sizes.
    CHECK_THROWS_WITH(aaf::surface_footprint<float>(p, n, size, one.view(), aaf::pixel_footprint::surface_axes),
                      Catch::Contains("surface_footprint_axes"));
    CHECK_THROWS_WITH(aaf::surface_footprint_axes<float>(p, n, size, sx.view(), sx.view()), Catch::Contains("distinct"));
    CHECK_THROWS_WITH(aaf::surface_footprint_axes<float>(p, n, size, sx.view(), size.view()), Catch::Contains("distinct"));
    aaf::image<float> small(w - 1, h);
    CHECK_THROWS_WITH(aaf::surface_footprint_axes<float>(p, n, size, sx.view(), small.view()), Catch::Contains("vertical"));
}

TEST_CASE("render_frame with per-axis footprints: each pass its own axis's step; filter_visibility_axes' bits", "[footprint][tilt]") {
    // The analytic receiver with rows twice as far apart as columns: s_x = d, s_y = 2d.
    aaf_test::analytic_scene<float> sc;
    sc.width = 32, sc.height = 16;
    const aaf_test::analytic_gbuffer<float> gb(sc);
    const aaf_test::span_tracer<float> tracer{&sc};
    aaf::frame_workspace<float> ws;
    aaf::frame_settings<float> s;
    aaf::image<float> axes(32, 16), area(32, 16), again(32, 16), scratch(32, 16);
    s.filter.footprint = aaf::pixel_footprint::surface_area;
    aaf::render_frame(gb.view_with_ids(), sc.area_light(), tracer, {area.view()}, ws, s);
    s.filter.footprint = aaf::pixel_footprint::surface_axes;
    aaf::render_frame(gb.view_with_ids(), sc.area_light(), tracer, {axes.view()}, ws, s);
    const auto v = gb.view_with_ids();
    for (std::size_t y = 1; y + 1 < 16; ++y)
        for (std::size_t x = 1; x + 1 < 32; ++x) {
            CHECK(ws.footprint(x, y) == Approx(v.pixel_size(x, y)).epsilon(1e-4));
            CHECK(ws.footprint_vertical(x, y) == Approx(2 * v.pixel_size(x, y)).epsilon(1e-4));
        }
    // The frame's filter is filter_visibility_axes on its own buffers, bit for bit.
    aaf::filter_workspace<float> fw;
    const aaf::guides g{v.normals, v.ids};
    aaf::filter_visibility_axes<float>(ws.raw_visibility, ws.filter_width, ws.footprint, ws.footprint_vertical, again.view(),
                                       scratch.view(), fw, g, s.filter);
    CHECK(std::memcmp(again.data(), ws.filtered.data(), again.size() * sizeof(float)) == 0);
    bool differ = false;  // √2 d on both axes is not (d, 2d)
    for (std::size_t i = 0; i < axes.size(); ++i) differ |= axes.data()[i] != area.data()[i];
    CHECK(differ);
    // min_stretch per axis: 1.5 gives the horizontal axis (stretch 1) the camera's d and keeps the vertical
    // 2d; 2.5 gives both the camera's d, which is the camera's frame.
    s.filter.footprint_min_stretch = 1.5f;
    aaf::render_frame(gb.view_with_ids(), sc.area_light(), tracer, {again.view()}, ws, s);
    for (std::size_t y = 1; y + 1 < 16; ++y)
        for (std::size_t x = 1; x + 1 < 32; ++x) {
            CHECK(ws.footprint(x, y) == v.pixel_size(x, y));
            CHECK(ws.footprint_vertical(x, y) == Approx(2 * v.pixel_size(x, y)).epsilon(1e-4));
        }
    aaf::image<float> camera(32, 16);
    s.filter.footprint_min_stretch = 2.5f;
    aaf::render_frame(gb.view_with_ids(), sc.area_light(), tracer, {again.view()}, ws, s);
    s.filter.footprint = aaf::pixel_footprint::camera;
    aaf::render_frame(gb.view_with_ids(), sc.area_light(), tracer, {camera.view()}, ws, s);
    CHECK(std::memcmp(again.data(), camera.data(), again.size() * sizeof(float)) == 0);
    s.filter.footprint = aaf::pixel_footprint::surface_axes;
    s.filter.footprint_min_stretch = 1;
    aaf::render_frame(gb.view_with_ids(), sc.area_light(), tracer, {again.view()}, ws, s);  // ws.footprint* again
    // Same footprint on both axes: filter_visibility's bits.
    aaf::image<float> one(32, 16);
    aaf::filter_visibility<float>(ws.raw_visibility, ws.filter_width, ws.footprint_vertical, one.view(), scratch.view(), fw, g, s.filter);
    aaf::filter_visibility_axes<float>(ws.raw_visibility, ws.filter_width, ws.footprint_vertical, ws.footprint_vertical, again.view(),
                                       scratch.view(), fw, g, s.filter);
    CHECK(std::memcmp(again.data(), one.data(), one.size() * sizeof(float)) == 0);
    CHECK_THROWS_WITH(aaf::filter_visibility_axes<float>(ws.raw_visibility, ws.filter_width, ws.footprint, aaf::const_image_view<float>{},
                                                         again.view(), scratch.view(), fw, g, s.filter),
                      Catch::Contains("pixel_size_vertical"));
}
