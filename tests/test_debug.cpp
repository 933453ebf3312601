// SPDX-License-Identifier: MIT
// Debug views: the heat ramp, heat maps (auto and fixed ranges, log scale), stats extraction and
// difference images.

#include <catch2/catch.hpp>

#include "support/helpers.hpp"

#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <string>

#include <aaf/debug.hpp>
#include <aaf/image.hpp>
#include <aaf/occlusion_stats.hpp>

namespace {

using aaf_test::what_of;
constexpr double nan_d = std::numeric_limits<double>::quiet_NaN();
constexpr float nan_f = std::numeric_limits<float>::quiet_NaN();
const aaf::rgb8 first_knot{68, 1, 84};
const aaf::rgb8 middle_knot{33, 144, 141};  // knot 4 of 0..8
const aaf::rgb8 last_knot{253, 231, 37};
const aaf::rgb8 magenta{255, 0, 255};

}  // namespace

TEST_CASE("debug: heat_color endpoints, knots, clamping and NaN", "[debug]") {
    CHECK(aaf::heat_color(0.0) == first_knot);
    CHECK(aaf::heat_color(1.0) == last_knot);
    CHECK(aaf::heat_color(0.5) == middle_knot);
    CHECK(aaf::heat_color(1.0 / 8.0) == aaf::rgb8{71, 44, 122});
    CHECK(aaf::heat_color(-3.0) == first_knot);  // clamped
    CHECK(aaf::heat_color(7.0) == last_knot);
    CHECK(aaf::heat_color(std::numeric_limits<double>::infinity()) == last_knot);
    CHECK(aaf::heat_color(nan_d) == magenta);
    // Halfway between the first two knots: the rounded mean of (68,1,84) and (71,44,122).
    CHECK(aaf::heat_color(1.0 / 16.0) == aaf::rgb8{70, 23, 103});
    // The ramp's green channel rises monotonically (it is perceptually ordered dark → bright).
    int prev = -1;
    bool monotone = true;
    for (int i = 0; i <= 100; ++i) {
        const int g = aaf::heat_color(i / 100.0).y;
        monotone = monotone && g >= prev;
        prev = g;
    }
    CHECK(monotone);
}

TEST_CASE("debug: heat_map auto range, fixed range and log scale", "[debug]") {
    aaf::image<float> v(4, 2);
    const float vals[8] = {2.0f, 4.0f, 6.0f, 10.0f, nan_f, std::numeric_limits<float>::infinity(), 3.0f, 8.0f};
    for (std::size_t i = 0; i < 8; ++i) v(i % 4, i / 4) = vals[i];
    aaf::image<aaf::rgb8> out(4, 2, aaf::rgb8{1, 2, 3});

    SECTION("auto range = finite min and max; min → first knot, max → last knot, NaN → magenta") {
        const aaf::heat_range r = aaf::heat_map(v.cview(), out.view());
        CHECK(r.lo == 2.0);
        CHECK(r.hi == 10.0);
        CHECK(out(0, 0) == first_knot);
        CHECK(out(3, 0) == last_knot);
        CHECK(out(2, 0) == middle_knot);  // 6 is halfway
        CHECK(out(0, 1) == magenta);
        CHECK(out(1, 1) == magenta);  // +inf is not finite data either
        CHECK(out(2, 1) == aaf::heat_color(1.0 / 8.0));
    }
    SECTION("fixed range: values outside saturate") {
        const aaf::heat_range r = aaf::heat_map(v.cview(), out.view(), aaf::heat_range{4.0, 8.0});
        CHECK(r.lo == 4.0);
        CHECK(r.hi == 8.0);
        CHECK(out(0, 0) == first_knot);  // 2 < lo
        CHECK(out(1, 0) == first_knot);
        CHECK(out(2, 0) == middle_knot);
        CHECK(out(3, 0) == last_knot);  // 10 > hi
        CHECK(out(3, 1) == last_knot);
    }
    SECTION("half-fixed range: the other bound comes from the data") {
        const aaf::heat_range r = aaf::heat_map(v.cview(), out.view(), aaf::heat_range{0.0, nan_d});
        CHECK(r.lo == 0.0);
        CHECK(r.hi == 10.0);
        CHECK(out(3, 0) == last_knot);
        CHECK(out(0, 0) == aaf::heat_color(0.2));
    }
    SECTION("constant data: a degenerate range maps to the first knot") {
        aaf::image<float> c(3, 3, 5.0f);
        aaf::image<aaf::rgb8> o(3, 3);
        const aaf::heat_range r = aaf::heat_map(c.cview(), o.view());
        CHECK(r.lo == 5.0);
        CHECK(r.hi == 5.0);
        CHECK(o(1, 1) == first_knot);
    }
    SECTION("no finite data: range falls back to [0, 1], all magenta") {
        aaf::image<float> c(2, 2, nan_f);
        aaf::image<aaf::rgb8> o(2, 2);
        const aaf::heat_range r = aaf::heat_map(c.cview(), o.view());
        CHECK(r.lo == 0.0);
        CHECK(r.hi == 1.0);
        CHECK(o(0, 0) == magenta);
    }
    SECTION("integer pixels (e.g. samples per pixel)") {
        aaf::image<std::uint32_t> n(3, 1);
        n(0, 0) = 9;
        n(1, 0) = 54;
        n(2, 0) = 99;
        aaf::image<aaf::rgb8> o(3, 1);
        const aaf::heat_range r = aaf::heat_map(n.cview(), o.view());
        CHECK(r.lo == 9.0);
        CHECK(r.hi == 99.0);
        CHECK(o(0, 0) == first_knot);
        CHECK(o(1, 0) == middle_knot);
        CHECK(o(2, 0) == last_knot);
    }
    SECTION("size mismatch throws naming `out`") {
        aaf::image<aaf::rgb8> wrong(3, 2);
        const std::string msg = what_of([&] { aaf::heat_map(v.cview(), wrong.view()); });
        CHECK(msg.find("heat_map") != std::string::npos);
        CHECK(msg.find("`out`") != std::string::npos);
    }
}

TEST_CASE("debug: heat_map in log scale", "[debug]") {
    aaf::image<double> v(5, 1);
    v(0, 0) = 0.01;
    v(1, 0) = 1.0;
    v(2, 0) = 100.0;
    v(3, 0) = 0.0;   // log undefined
    v(4, 0) = -5.0;  // log undefined
    aaf::image<aaf::rgb8> out(5, 1);

    SECTION("auto range is in log10 units") {
        const aaf::heat_range r = aaf::heat_map(v.cview(), out.view(), {}, true);
        CHECK(r.lo == Approx(-2.0));
        CHECK(r.hi == Approx(2.0));
        CHECK(out(0, 0) == first_knot);
        CHECK(out(1, 0) == middle_knot);
        CHECK(out(2, 0) == last_knot);
        CHECK(out(3, 0) == magenta);
        CHECK(out(4, 0) == magenta);
    }
    SECTION("a fixed range is given in data units and returned in log10 units") {
        const aaf::heat_range r = aaf::heat_map(v.cview(), out.view(), aaf::heat_range{1.0, 100.0}, true);
        CHECK(r.lo == Approx(0.0).margin(1e-12));
        CHECK(r.hi == Approx(2.0));
        CHECK(out(0, 0) == first_knot);  // below the range
        CHECK(out(1, 0) == first_knot);
        CHECK(out(2, 0) == last_knot);
    }
    SECTION("a half-fixed range: the given bound is in data units too") {
        // Fix only the lower bound at 1 (log10 = 0); the upper comes from the data (log10 100 = 2).
        const aaf::heat_range r = aaf::heat_map(v.cview(), out.view(), aaf::heat_range{1.0, nan_d}, true);
        CHECK(r.lo == Approx(0.0).margin(1e-12));
        CHECK(r.hi == Approx(2.0));
        CHECK(out(1, 0) == first_knot);
        CHECK(out(2, 0) == last_knot);
        aaf::image<double> mid(1, 1, 10.0);
        aaf::image<aaf::rgb8> o(1, 1);
        aaf::heat_map(mid.cview(), o.view(), aaf::heat_range{nan_d, 100.0}, true);  // lo from data = 10 → log 1
        CHECK(o(0, 0) == first_knot);
        aaf::heat_map(mid.cview(), o.view(), aaf::heat_range{1.0, nan_d}, true);  // hi from data = log 1
        CHECK(o(0, 0) == last_knot);
    }
}

TEST_CASE("debug: extract() of every stats field, NaN where undefined", "[debug]") {
    aaf::image<aaf::occlusion_stats<float>> s(3, 1);
    // (0,0): nothing counted (all light points below the horizon).
    s(0, 0).samples = 4;
    // (1,0): lit, unoccluded.
    s(1, 0).samples = 9;
    s(1, 0).total_weight = 9;
    s(1, 0).visible_weight = 9;
    s(1, 0).d1 = 2.0f;
    // (2,0): partly occluded: d1 = 2, d2min = 0.5, d2max = 1 → s1 = 2/0.5 − 1 = 3, s2 = 2/1 − 1 = 1.
    s(2, 0).samples = 16;
    s(2, 0).occluded = 12;
    s(2, 0).total_weight = 16;
    s(2, 0).visible_weight = 4;
    s(2, 0).d1 = 2.0f;
    s(2, 0).d2min = 0.5f;
    s(2, 0).d2max = 1.0f;

    aaf::image<double> out(3, 1, -1.0);
    const auto get = [&](aaf::stats_field f) {
        out.fill(-1.0);
        aaf::extract(s.cview(), f, out.view());
        return out;
    };
    using F = aaf::stats_field;
    auto o = get(F::samples);
    CHECK(o(0, 0) == 4.0);
    CHECK(o(1, 0) == 9.0);
    CHECK(o(2, 0) == 16.0);
    o = get(F::occluded);
    CHECK(o(0, 0) == 0.0);
    CHECK(o(1, 0) == 0.0);
    CHECK(o(2, 0) == 12.0);
    o = get(F::visibility);
    CHECK(std::isnan(o(0, 0)));
    CHECK(o(1, 0) == 1.0);
    CHECK(o(2, 0) == 0.25);
    o = get(F::d1);
    CHECK(std::isnan(o(0, 0)));
    CHECK(o(1, 0) == 2.0);
    CHECK(o(2, 0) == 2.0);
    o = get(F::d2min);
    CHECK(std::isnan(o(0, 0)));
    CHECK(std::isnan(o(1, 0)));
    CHECK(o(2, 0) == 0.5);
    o = get(F::d2max);
    CHECK(std::isnan(o(0, 0)));
    CHECK(std::isnan(o(1, 0)));
    CHECK(o(2, 0) == 1.0);
    o = get(F::s1);
    CHECK(std::isnan(o(0, 0)));
    CHECK(std::isnan(o(1, 0)));
    CHECK(o(2, 0) == Approx(3.0));
    o = get(F::s2);
    CHECK(std::isnan(o(0, 0)));
    CHECK(std::isnan(o(1, 0)));
    CHECK(o(2, 0) == Approx(1.0));

    aaf::image<double> wrong(2, 1);
    const std::string msg = what_of([&] { aaf::extract(s.cview(), F::d1, wrong.view()); });
    CHECK(msg.find("extract") != std::string::npos);
    CHECK(msg.find("`out`") != std::string::npos);
}

TEST_CASE("debug: difference_image RMSE and signed colours", "[debug]") {
    aaf::image<float> a(3, 2), b(3, 2);
    // a − b: +0.05, −0.05, 0, +0.2 (saturates), −0.3 (saturates), NaN (excluded).
    const float av[6] = {0.55f, 0.45f, 0.5f, 0.7f, 0.2f, nan_f};
    const float bv[6] = {0.5f, 0.5f, 0.5f, 0.5f, 0.5f, 0.5f};
    for (std::size_t i = 0; i < 6; ++i) {
        a(i % 3, i / 3) = av[i];
        b(i % 3, i / 3) = bv[i];
    }
    double sum = 0;
    for (std::size_t i = 0; i < 5; ++i) {
        const double d = static_cast<double>(av[i]) - static_cast<double>(bv[i]);
        sum += d * d;
    }
    const double rmse_by_hand = std::sqrt(sum / 5.0);  // ≈ sqrt((0.0025·2 + 0.04 + 0.09)/5) = 0.1643
    aaf::image<aaf::rgb8> out(3, 2);
    const double rmse = aaf::difference_image(a.cview(), b.cview(), out.view(), 0.1);
    CHECK(rmse == Approx(rmse_by_hand).epsilon(1e-12));
    CHECK(rmse == Approx(std::sqrt(0.135 / 5.0)).epsilon(1e-6));
    // a > b is red, a < b is blue, equal is white; half the scale is half-faded; beyond it saturates.
    const aaf::rgb8 plus_half = out(0, 0), minus_half = out(1, 0);
    CHECK(plus_half.x == 255);
    CHECK(plus_half.y == plus_half.z);
    CHECK(int(plus_half.y) == Approx(128).margin(1));
    CHECK(minus_half.z == 255);
    CHECK(minus_half.x == minus_half.y);
    CHECK(int(minus_half.x) == Approx(128).margin(1));
    CHECK(out(2, 0) == aaf::rgb8{255, 255, 255});
    CHECK(out(0, 1) == aaf::rgb8{255, 0, 0});
    CHECK(out(1, 1) == aaf::rgb8{0, 0, 255});
    CHECK(out(2, 1) == magenta);

    // Identical images: RMSE 0, all white.
    CHECK(aaf::difference_image(b.cview(), b.cview(), out.view()) == 0.0);
    CHECK(out(1, 1) == aaf::rgb8{255, 255, 255});

    aaf::image<aaf::rgb8> wrong(2, 2);
    aaf::image<float> wrong_b(3, 3);
    CHECK(what_of([&] { aaf::difference_image(a.cview(), b.cview(), out.view(), 0.0); }).find("scale") != std::string::npos);
    CHECK(what_of([&] { aaf::difference_image(a.cview(), b.cview(), wrong.view()); }).find("`out`") != std::string::npos);
    CHECK(what_of([&] { aaf::difference_image(a.cview(), wrong_b.cview(), out.view()); }).find("`b`") != std::string::npos);
}
