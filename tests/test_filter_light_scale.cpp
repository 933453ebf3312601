// SPDX-License-Identifier: MIT
// Issue 13: formula_settings::light_scale, the factor on the standard deviation β's light term assumes
// (DEVIATIONS.md L1): light-limited widths scale by it exactly, pixel-limited widths and the sample count do
// not move, 1/√3 with the Gaussian profile is the box profile, β still → 0 as μ grows, and on the exact
// penumbra of a box light the kink bias of 0.85 lies between the Gaussian's and the box's. Also
// filter_settings::unfiltered_at_horizon and area_light::straddles_horizon (DEVIATIONS.md L2).

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

#include <aaf/filter.hpp>
#include <aaf/formulas.hpp>
#include <aaf/image.hpp>
#include <aaf/pipeline.hpp>
#include <aaf/settings.hpp>

#include "support/analytic_scene.hpp"

namespace {

/// The largest |filtered − exact| along a straight edge's penumbra when the exact visibility is filtered
/// with the β of `fs` (no noise: the filter's bias alone), and that β.
std::pair<double, float> penumbra_kink_bias(const aaf_test::analytic_scene<float>& sc, float s, const aaf::formula_settings<float>& fs) {
    const float beta = aaf::filter_width(aaf::slope_pair<float>{s, s}, sc.area_light().sigma(), sc.pixel_size(), fs);
    const std::size_t w = sc.width, h = sc.height;
    aaf::image<float> vis(w, h), b(w, h, beta), size(w, h, sc.pixel_size()), out(w, h);
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) vis(x, y) = static_cast<float>(sc.exact_visibility(sc.position(x, y)));
    aaf::filter_visibility<float>(vis.cview(), b.cview(), size.cview(), out.view());
    double worst = 0;
    for (std::size_t x = 0; x < w; ++x) worst = std::max(worst, std::abs(double(out(x, 1)) - double(vis(x, 1))));
    return {worst, beta};
}

}  // namespace

TEST_CASE("light_scale: light-limited widths scale by it, nothing else moves", "[formulas][lightscale13]") {
    const float sigma = 0.75f, d = 1.0f / 32;
    aaf::formula_settings<float> one, scaled;
    scaled.light_scale = 0.85f;
    // Light-limited (1/(σ s2) = 2.7 < 1/(d(1 + s2)) = 21): β = light_scale σ s2/(kμ).
    const aaf::slope_pair<float> far{0.5f, 0.5f};
    const float b1 = aaf::filter_width(far, sigma, d, one), b85 = aaf::filter_width(far, sigma, d, scaled);
    CHECK(b1 == Approx(sigma * 0.5f / (3 * 2)).epsilon(1e-6));
    CHECK(b85 == Approx(0.85 * double(b1)).epsilon(1e-6));
    // 1/√3 with the Gaussian profile is the box profile's width.
    aaf::formula_settings<float> box, root3;
    box.light = aaf::light_profile::box;
    root3.light_scale = 0.57735026918962576451f;
    CHECK(aaf::filter_width(far, sigma, d, root3) == Approx(aaf::filter_width(far, sigma, d, box)).epsilon(1e-6));
    // The factor multiplies the profile's own σ: box × 0.5 is σ/(2√3).
    box.light_scale = 0.5f;
    CHECK(aaf::filter_width(far, sigma, d, box) == Approx(0.5 * double(b1) / std::sqrt(3.0)).epsilon(1e-6));
    // A scale so small that the light term passes the pixel bound: the width is pixel-limited, d(1 + s2)/(kμα).
    scaled.light_scale = 1e-3f;
    CHECK(aaf::filter_width(far, sigma, d, scaled) == Approx(d * 1.5f / 6).epsilon(1e-6));
    scaled.light_scale = 0.85f;
    // Pixel-limited widths (contact) and the sample count do not depend on it.
    const aaf::slope_pair<float> contact{1e-4f, 1e-4f}, wide{1.0f, 0.5f};
    CHECK(aaf::filter_width(contact, sigma, d, scaled) == aaf::filter_width(contact, sigma, d, one));
    CHECK(aaf::sample_count(wide, sigma, d, scaled) == aaf::sample_count(wide, sigma, d, one));
    // No occluder: still no filter.
    CHECK(aaf::filter_width(aaf::slope_pair<float>{}, sigma, d, scaled) == 0.0f);
    // Consistent: β → 0 as μ grows, at the same rate as with scale 1.
    scaled.mu = one.mu = 1e4f;
    CHECK(aaf::filter_width(far, sigma, d, scaled) == Approx(0.85 * 2e-4 * double(b1)).epsilon(1e-5));
    CHECK(aaf::filter_width(far, sigma, d, scaled) == Approx(0.85 * double(aaf::filter_width(far, sigma, d, one))).epsilon(1e-6));
}

TEST_CASE("light_scale: invalid values are rejected by name", "[formulas][lightscale13]") {
    aaf::formula_settings<float> fs;
    CHECK_NOTHROW(aaf::validate(fs, "f"));
    for (float bad : {0.0f, -0.5f, std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity()}) {
        fs.light_scale = bad;
        CHECK_THROWS_WITH(aaf::validate(fs, "f"), Catch::Contains("settings.formulas.light_scale"));
    }
    fs.light_scale = 2.0f;  // wider than the paper's is allowed (a user's choice), and defined
    CHECK_NOTHROW(aaf::validate(fs, "f"));
}

TEST_CASE("light_scale: the penumbra-end bias of 0.85 lies between the Gaussian's and the box's", "[filter][penumbra][lightscale13]") {
    // As test_filter_penumbra.cpp: a square light of σ = 0.75 at height 3, a half-plane occluder at height 1,
    // s = 0.5, penumbra 0.75 wide (24 pixels of 1/32), pixel centres on the kinks.
    aaf_test::analytic_scene<float> sc;
    sc.occluders = {{-10, 0, -10, 10, 1}};
    sc.width = 128, sc.height = 4;
    sc.x_min = -2 + 1.0f / 64;
    aaf::formula_settings<float> gaussian, scaled, box;
    scaled.light_scale = 0.85f;
    box.light = aaf::light_profile::box;
    const auto [bias_g, beta_g] = penumbra_kink_bias(sc, 0.5f, gaussian);
    const auto [bias_s, beta_s] = penumbra_kink_bias(sc, 0.5f, scaled);
    const auto [bias_b, beta_b] = penumbra_kink_bias(sc, 0.5f, box);
    CHECK(beta_s == Approx(0.85 * double(beta_g)).epsilon(1e-6));
    CHECK(bias_b < bias_s);
    CHECK(bias_s < bias_g);
    // The kink bias is ≈ β/(√(2π) P), linear in β: 0.85 of the Gaussian's within the sampled kernel's rounding.
    CHECK(bias_s == Approx(0.85 * bias_g).epsilon(0.03));
}

TEST_CASE("straddles_horizon: the receiver's tangent plane cuts the light", "[lightscale13][horizon]") {
    const aaf_test::analytic_scene<float> sc;  // light [-0.75, 0.75]² at height 3
    const aaf::area_light<float> light = sc.area_light();
    const glm::vec3 up(0, 1, 0), origin(0, 0, 0);
    CHECK_FALSE(light.straddles_horizon(origin, up));                 // facing the light: all above
    CHECK_FALSE(light.straddles_horizon(origin, -up));                // facing away: all below
    const float t = 1.3962634f;                                       // 80°: h = 0.985 (q_x − p_x) + 0.52
    const glm::vec3 tilted(std::sin(t), std::cos(t), 0);
    CHECK(light.straddles_horizon(origin, tilted));                   // h at q_x = ±0.75: −0.22, 1.26
    CHECK_FALSE(light.straddles_horizon({-1.5f, 0, 0}, tilted));      // 0.74 and 2.2: all above
    CHECK(light.straddles_horizon({0, 3, 0}, {1, 0, 0}));              // the plane x = 0 cuts it
    CHECK_FALSE(light.straddles_horizon({0, 3, 0}, {0, 0, 0}));        // a zero normal: no plane
    CHECK_FALSE(light.straddles_horizon({0.75f, 0, 0}, {1, 0, 0}));   // two corners on the plane, two below: no area above
    CHECK_FALSE(light.straddles_horizon({std::numeric_limits<float>::quiet_NaN(), 0, 0}, tilted));
}

TEST_CASE("unfiltered_at_horizon: pixels whose light straddles their horizon keep their own estimate", "[lightscale13][horizon]") {
    // The analytic scene with the left half's normals tilted 80° about z: there the tangent plane cuts the light
    // for receivers near the light's footprint (straddles_horizon), elsewhere the whole light is above.
    aaf_test::analytic_scene<float> sc;
    sc.width = sc.height = 32;
    aaf_test::analytic_gbuffer<float> gb(sc);
    gb.tilt_left_half_to_horizon();
    const aaf_test::span_tracer<float> tracer{&sc};
    aaf::frame_workspace<float> ws;
    aaf::frame_settings<float> s;
    const auto render = [&](bool rule) {
        aaf::image<float> out(32, 32);
        s.filter.unfiltered_at_horizon = rule;
        aaf::render_frame(gb.view_with_ids(), sc.area_light(), tracer, {out.view()}, ws, s);
        return out;
    };
    const aaf::image<float> off = render(false);
    const aaf::image<float> off_beta = ws.filter_width;
    const aaf::image<float> on = render(true);
    const aaf::area_light<float> light = sc.area_light();
    std::size_t straddling = 0, changed = 0;
    for (std::size_t y = 0; y < 32; ++y)
        for (std::size_t x = 0; x < 32; ++x) {
            const bool cut = light.straddles_horizon(gb.positions(x, y), gb.normals(x, y));
            if (x >= 16) CHECK_FALSE(cut);
            if (!cut) {
                CHECK(ws.filter_width(x, y) == off_beta(x, y));  // the rule touches no other pixel's β
                continue;
            }
            ++straddling;
            CHECK(ws.filter_width(x, y) == 0.0f);
            const float raw = ws.raw_visibility(x, y);
            CHECK(on(x, y) == (std::isfinite(raw) ? std::clamp(raw, 0.0f, 1.0f) : 0.0f));  // its own estimate
            if (off_beta(x, y) > 0 && off(x, y) != on(x, y)) ++changed;
        }
    CHECK(straddling > 50);
    CHECK(changed > 10);  // without the rule the filter did move them
}
