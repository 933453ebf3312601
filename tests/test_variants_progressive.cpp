// SPDX-License-Identifier: MIT
// Consistent progressive refinement (variants/progressive.hpp) on the analytic scene: the error against
// the exact visibility keeps falling as passes accumulate, reaching Monte Carlo's own error (no bias
// floor), while the same accumulation filtered at a fixed μ stops improving. 32×32 pixels, 16 samples per
// pass, up to 256 passes (4096 samples per pixel).

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <utility>
#include <vector>

#include <glm/geometric.hpp>

#include <aaf/variants.hpp>

#include "support/analytic_scene.hpp"

namespace {

using scene_t = aaf_test::analytic_scene<float>;

/// RMSE against the exact visibility after each pass in `at` (1-based), with μ exponent `gamma`.
std::vector<double> progressive_errors(const scene_t& sc, aaf::mu_schedule schedule, float gamma, const std::vector<unsigned>& at,
                                       unsigned seed, std::vector<double>& mc_errors) {
    const aaf_test::analytic_gbuffer<float> gb(sc);
    const auto exact = sc.exact_image();
    const aaf_test::span_tracer<float> tracer{&sc};
    aaf::progressive_settings<float> s;
    s.frame.sampling.initial_samples = 16;
    s.frame.sampling.frame_seed = seed;
    s.schedule = schedule;
    s.mu_exponent = gamma;
    aaf::progressive_shadow<float> prog;
    prog.reset(sc.width, sc.height);
    aaf::image<float> out(sc.width, sc.height);
    std::vector<double> errors;
    aaf::thread_pool pool(2);
    for (unsigned p = 1; p <= at.back(); ++p) {
        prog.add_pass(gb.view_with_ids(), sc.area_light(), tracer, {out.view()}, s, pool);
        if (std::find(at.begin(), at.end(), p) != at.end()) {
            errors.push_back(aaf_test::rmse(out, exact));
            aaf::image<float> raw(sc.width, sc.height);
            for (std::size_t i = 0; i < raw.size(); ++i) raw.data()[i] = prog.workspace().stats.data()[i].visibility();
            mc_errors.push_back(aaf_test::rmse(raw, exact));
        }
    }
    CHECK(prog.passes() == at.back());
    CHECK(prog.rays() == std::uint64_t(at.back()) * 16 * sc.width * sc.height);
    return errors;
}

}  // namespace

TEST_CASE("progressive_shadow converges to the exact visibility; a fixed mu keeps a bias floor", "[variants][progressive]") {
    scene_t sc;
    sc.width = sc.height = 32;
    const std::vector<unsigned> at{1, 4, 16, 64, 256};
    std::vector<double> prog(at.size(), 0.0), fixed(at.size(), 0.0), mc(at.size(), 0.0);
    for (unsigned seed : {1u}) {
        std::vector<double> m, unused;
        const auto p = progressive_errors(sc, aaf::mu_schedule::matched_samples, 0, at, seed, m);
        const auto f = progressive_errors(sc, aaf::mu_schedule::power, 0, at, seed, unused);
        for (std::size_t i = 0; i < at.size(); ++i) prog[i] += p[i], fixed[i] += f[i], mc[i] += m[i];
    }
    std::ostringstream curve;
    for (std::size_t i = 0; i < at.size(); ++i) curve << "passes " << at[i] << ": progressive " << prog[i] << ", fixed mu " << fixed[i] << ", unfiltered " << mc[i] << "\n";
    INFO(curve.str());
    // The first pass is the same frame either way, and filtering helps it.
    CHECK(prog[0] == Approx(fixed[0]));
    CHECK(prog[0] < mc[0] * 0.8);
    for (std::size_t i = 1; i < at.size(); ++i) {
        INFO("passes " << at[i]);
        CHECK(prog[i] < prog[i - 1] * 0.8);  // keeps falling...
        CHECK(prog[i] <= mc[i] * 1.01);      // ...never worse than the same samples unfiltered
    }
    // Monte Carlo's rate at the end (0.5 per 4x samples), while the fixed-mu filter levels off at its bias.
    CHECK(prog.back() < prog[prog.size() - 2] * 0.6);
    CHECK(fixed.back() > fixed[fixed.size() - 2] * 0.85);
    CHECK(prog.back() < fixed.back() * 0.5);
}

TEST_CASE("progressive_shadow validates its arguments", "[variants][progressive]") {
    scene_t sc;
    sc.width = sc.height = 8;
    const aaf_test::analytic_gbuffer<float> gb(sc);
    const aaf_test::span_tracer<float> tracer{&sc};
    aaf::progressive_shadow<float> prog;
    aaf::image<float> out(8, 8, -1.0f);
    CHECK_THROWS_WITH(prog.add_pass(gb.view(), sc.area_light(), tracer, {out.view()}), Catch::Contains("reset"));
    prog.reset(8, 8);
    aaf::progressive_settings<float> s;
    s.mu_exponent = -1;
    CHECK_THROWS_WITH(prog.add_pass(gb.view(), sc.area_light(), tracer, {out.view()}, s), Catch::Contains("settings.mu_exponent"));
    for (std::size_t i = 0; i < out.size(); ++i) CHECK(out.data()[i] == -1.0f);
    CHECK(prog.passes() == 0);
    CHECK(aaf::progressive_shadow<float>::mu_of_pass({}, 4) == Approx(4.0f));  // 2 · 4^0.5
}

// progressive_shadow and render_sheared write their outputs through render_frame's step 6
// (detail::write_frame_outputs): the same meaning for misconfigured pixels and the same report counts.
TEST_CASE("progressive_shadow and render_sheared report misconfigurations and shade zero normals as render_frame does",
          "[variants][progressive][sheared][extremes]") {
    scene_t sc;
    sc.width = sc.height = 16;
    const aaf_test::span_tracer<float> tracer{&sc};
    aaf_test::analytic_gbuffer<float> zero(sc);
    zero.normals.fill(glm::vec3(0));  // orientation-less receivers: they face the light's centre
    aaf::image<float> vis(16, 16), shaded(16, 16);
    const auto check_zero_normals = [&](const aaf::frame_report& rep, const char* who) {
        INFO(who);
        CHECK(rep.pixels == 256u);
        CHECK(rep.pixels_zero_normal == 256u);
        CHECK(rep.pixels_below_horizon == 0u);
        CHECK_THAT(rep.diagnose(), Catch::Contains("have a zero normal"));
        for (const auto& [x, y] : {std::pair<std::size_t, std::size_t>{3, 12}, {8, 8}, {12, 4}}) {
            const glm::vec3 p = sc.position(x, y);
            const glm::vec3 towards = glm::normalize(sc.area_light().center() - p);
            CHECK(shaded(x, y) == Approx(vis(x, y) * aaf::unshadowed_irradiance(sc.area_light(), p, towards)));
        }
        float lit = 0;
        for (std::size_t i = 0; i < shaded.size(); ++i) lit = std::max(lit, shaded.data()[i]);
        CHECK(lit > 0.0f);  // not a silent black frame
    };
    aaf::progressive_shadow<float> prog;
    prog.reset(16, 16);
    check_zero_normals(prog.add_pass(zero.view(), sc.area_light(), tracer, {vis.view(), shaded.view()}), "progressive_shadow");
    aaf::sheared_workspace<float> sws;
    check_zero_normals(aaf::render_sheared(zero.view(), sc.area_light(), tracer, {vis.view(), shaded.view()}, sws), "render_sheared");

    // A one-sided light facing away from every receiver: visibility 0, counted and diagnosed by both.
    const aaf_test::analytic_gbuffer<float> gb(sc);
    aaf::area_light<float> away = sc.area_light();
    std::swap(away.edge_u, away.edge_v);
    const auto check_away = [&](const aaf::frame_report& rep, const char* who) {
        INFO(who);
        CHECK(rep.pixels_behind_light == 256u);
        CHECK_THAT(rep.diagnose(), Catch::Contains("every surface pixel is behind the one-sided light"));
        for (std::size_t i = 0; i < vis.size(); ++i) REQUIRE(vis.data()[i] == 0.0f);
    };
    prog.reset(16, 16);
    check_away(prog.add_pass(gb.view(), away, tracer, {vis.view()}), "progressive_shadow");
    check_away(aaf::render_sheared(gb.view(), away, tracer, {vis.view()}, sws), "render_sheared");
}

TEST_CASE("progressive_shadow and render_sheared follow filter_settings::unfiltered_at_horizon", "[variants][progressive][sheared][horizon]") {
    // The left half's normals tilted 80° about z (as test_filter_light_scale.cpp): their tangent planes cut the light.
    scene_t sc;
    sc.width = sc.height = 16;
    aaf_test::analytic_gbuffer<float> gb(sc);
    gb.tilt_left_half_to_horizon();
    const aaf_test::span_tracer<float> tracer{&sc};
    const aaf::area_light<float> light = sc.area_light();
    aaf::image<float> out(16, 16);
    aaf::progressive_settings<float> ps;
    aaf::sheared_settings<float> ss;
    std::size_t straddling = 0, filtered_without = 0;
    for (const bool rule : {false, true}) {
        ps.frame.filter.unfiltered_at_horizon = ss.frame.filter.unfiltered_at_horizon = rule;
        aaf::progressive_shadow<float> prog;
        prog.reset(16, 16);
        prog.add_pass(gb.view_with_ids(), light, tracer, {out.view()}, ps);
        aaf::sheared_workspace<float> sws;
        aaf::render_sheared(gb.view_with_ids(), light, tracer, {out.view()}, sws, ss);
        for (std::size_t y = 0; y < 16; ++y)
            for (std::size_t x = 0; x < 16; ++x) {
                if (!light.straddles_horizon(gb.positions(x, y), gb.normals(x, y))) continue;
                const float bp = prog.workspace().filter_width(x, y), bs = sws.frame.filter_width(x, y);
                if (rule) {
                    CHECK(bp == 0.0f);
                    CHECK(bs == 0.0f);
                } else {
                    ++straddling;
                    filtered_without += bp > 0.0f;
                }
            }
    }
    CHECK(straddling > 8);  // the scene has such pixels (16 at 16×16)
    CHECK(filtered_without > 10);  // without the rule these pixels are filtered
}
