// SPDX-License-Identifier: MIT
// Issue 13: the bias a Gaussian filter leaves at the ends of a uniform (box) light's penumbra, and the two
// width rules that act on it: formula_settings::light = light_profile::box (β matched to the sampled
// light's standard deviation σ/√3) and filter_settings::footprint_min_stretch (surface footprints only
// where a pixel is stretched).

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>

#include <aaf/filter.hpp>
#include <aaf/formulas.hpp>
#include <aaf/image.hpp>
#include <aaf/pipeline.hpp>
#include <aaf/settings.hpp>

#include "support/analytic_scene.hpp"

namespace {

/// The largest |filtered − exact| over the row of a straight edge's penumbra, filtering the exact
/// visibility with the β the formulas give for `profile`: the filter's bias alone, no noise.
struct penumbra_bias {
    double max_bias = 0;      ///< largest error anywhere (at the penumbra's ends)
    double middle_error = 0;  ///< error at the penumbra's middle, where the visibility is linear
    double beta = 0;          ///< β in world units
};

penumbra_bias filter_bias(const aaf_test::analytic_scene<float>& sc, float s, aaf::light_profile profile) {
    aaf::formula_settings<float> fs;  // the paper's μ = 2, k = 3
    fs.light = profile;
    const float sigma = sc.area_light().sigma(), d = sc.pixel_size();
    const float beta = aaf::filter_width(aaf::slope_pair<float>{s, s}, sigma, d, fs);
    const std::size_t w = sc.width, h = sc.height;
    aaf::image<float> vis(w, h), exact(w, h), b(w, h, beta), size(w, h, d), out(w, h);
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) vis(x, y) = exact(x, y) = static_cast<float>(sc.exact_visibility(sc.position(x, y)));
    aaf::filter_visibility<float>(vis.cview(), b.cview(), size.cview(), out.view());
    penumbra_bias r{0, 0, beta};
    for (std::size_t x = 0; x < w; ++x) {
        const double e = std::abs(double(out(x, 1)) - double(exact(x, 1)));
        r.max_bias = std::max(r.max_bias, e);
        if (std::abs(exact(x, 1) - 0.5f) < 0.05f) r.middle_error = std::max(r.middle_error, e);
    }
    return r;
}

}  // namespace

TEST_CASE("a box light's penumbra: the Gaussian filter's bias at its ends, and light_profile::box", "[filter][penumbra][bias13]") {
    // A square light (side 1.5 at height 3, σ = 0.75) over a half-plane occluder at height 1 with its edge at
    // x = 0: s = d1/d2 − 1 = 3/2 − 1 = 0.5 and the visibility across x is a ramp of width P = 2σs = 0.75,
    // with kinks at x = ±P/2 (24 pixels of 1/32).
    aaf_test::analytic_scene<float> sc;
    sc.occluders = {{-10, 0, -10, 10, 1}};
    sc.width = 128, sc.height = 4;  // x: 4/128 = 1/32 per pixel; rows are identical
    sc.x_min = -2 + 1.0f / 64;      // pixel centres at multiples of 1/32: on the kinks
    const float s = 0.5f;
    const double penumbra = 2.0 * double(sc.area_light().sigma()) * double(s);
    REQUIRE(penumbra == Approx(0.75));
    const penumbra_bias gaussian = filter_bias(sc, s, aaf::light_profile::gaussian);
    const penumbra_bias box = filter_bias(sc, s, aaf::light_profile::box);
    // Light-limited: β = σs/(kμ) = 0.0625 (2 px); box: β/√3.
    CHECK(gaussian.beta == Approx(0.0625).epsilon(1e-5));
    CHECK(box.beta == Approx(0.0625 / std::sqrt(3.0)).epsilon(1e-5));
    // A normalised kernel w on a ramp of slope 1/P raises its kink by Σ_{k>0} k d w_k / (P Σ w_k), d the pixel
    // size: β/(√(2π) P) = 0.033 for a continuous Gaussian; here the sampled Gaussian of the filter
    // (truncated at 3β), the exact bias at the kink's pixel.
    const auto kink_bias = [&](double beta) {
        const double d = sc.pixel_size(), r = std::ceil(3 * beta / d);
        double num = 0, den = 1;
        for (double k = 1; k <= r; ++k) {
            const double wk = std::exp(-k * k * d * d / (2 * beta * beta));
            num += k * d * wk, den += 2 * wk;
        }
        return num / (den * penumbra);
    };
    CHECK(kink_bias(gaussian.beta) == Approx(gaussian.beta / (std::sqrt(2 * std::numbers::pi) * penumbra)).epsilon(0.03));  // the 3β cut
    CHECK(gaussian.max_bias == Approx(kink_bias(gaussian.beta)).epsilon(1e-3));
    CHECK(box.max_bias == Approx(kink_bias(box.beta)).epsilon(1e-3));
    // The correction removes ≥ 35 % of the bias at the ends (1 − 1/√3 = 42 % in the continuum) ...
    CHECK(box.max_bias < 0.65 * gaussian.max_bias);
    // ... and neither filter biases the linear middle of the penumbra.
    CHECK(gaussian.middle_error < 2e-3);
    CHECK(box.middle_error < 2e-3);
    // Pixel-limited widths (contact, s2 → 0) do not depend on the light model.
    aaf::formula_settings<float> fs;
    const aaf::slope_pair<float> contact{1e-4f, 1e-4f};
    const float g_beta = aaf::filter_width(contact, 0.75f, 1.0f / 32, fs);
    fs.light = aaf::light_profile::box;
    CHECK(aaf::filter_width(contact, 0.75f, 1.0f / 32, fs) == g_beta);
    // ... nor does the sample count.
    const aaf::slope_pair<float> wide{1.0f, 0.5f};
    const float n_box = aaf::sample_count(wide, 0.75f, 1.0f / 32, fs);
    fs.light = aaf::light_profile::gaussian;
    CHECK(aaf::sample_count(wide, 0.75f, 1.0f / 32, fs) == n_box);
    fs.light = static_cast<aaf::light_profile>(5);
    CHECK_THROWS_WITH(aaf::validate(fs, "f"), Catch::Contains("settings.formulas.light"));
}

TEST_CASE("footprint_min_stretch: surface footprints only on pixels stretched at least that much", "[filter][footprint][bias13]") {
    // The analytic receiver with rows twice as far apart as columns: every pixel's surface footprint is
    // √(d · 2d) = √2 d, a stretch of 1.41.
    aaf_test::analytic_scene<float> sc;
    sc.width = 32, sc.height = 16;
    const aaf_test::analytic_gbuffer<float> gb(sc);
    const aaf_test::span_tracer<float> tracer{&sc};
    aaf::frame_workspace<float> ws;
    aaf::frame_settings<float> s;
    const auto render = [&](aaf::pixel_footprint f, float stretch) {
        aaf::image<float> out(32, 16);
        s.filter.footprint = f;
        s.filter.footprint_min_stretch = stretch;
        aaf::render_frame(gb.view_with_ids(), sc.area_light(), tracer, {out.view()}, ws, s);
        return out;
    };
    const aaf::image<float> camera = render(aaf::pixel_footprint::camera, 1), surface = render(aaf::pixel_footprint::surface_area, 1);
    const aaf::image<float> below = render(aaf::pixel_footprint::surface_area, 1.5f), above = render(aaf::pixel_footprint::surface_area, 1.4f);
    bool differ = false;
    for (std::size_t i = 0; i < camera.size(); ++i) {
        differ |= camera.data()[i] != surface.data()[i];
        CHECK(below.data()[i] == camera.data()[i]);   // 1.41 < 1.5: the camera's d
        CHECK(above.data()[i] == surface.data()[i]);  // 1.41 ≥ 1.4: the surface footprint
    }
    CHECK(differ);  // the two footprints do filter differently here
    s.filter.footprint_min_stretch = 0.5f;
    aaf::image<float> out(32, 16);
    CHECK_THROWS_WITH(aaf::render_frame(gb.view_with_ids(), sc.area_light(), tracer, {out.view()}, ws, s),
                      Catch::Contains("settings.filter.footprint_min_stretch"));
}
