// SPDX-License-Identifier: MIT
// The sheared filter (variants/sheared.hpp): its factored passes against the exact O(n²l²) gather
// (tests/reference/reference_sheared.hpp), its accuracy on a single occluder plane against aaf at the same
// samples, the limits of shear_of, bad input and non-finite data. 32×32 analytic scenes.

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <utility>
#include <limits>
#include <string>

#include <aaf/aaf.hpp>
#include <aaf/variants.hpp>

#include "reference/reference_sheared.hpp"
#include "support/analytic_scene.hpp"

namespace {

using scene_t = aaf_test::analytic_scene<float>;

scene_t small_scene() {
    scene_t sc;
    sc.width = sc.height = 32;
    return sc;
}

/// RMSE over surface pixels that the exact visibility puts in the penumbra or near it (0 < V < 1 within
/// the frame), where filters differ; fully lit and umbra pixels are trivially right for every method.
double penumbra_rmse(const aaf::image<float>& img, const aaf::image<double>& exact) {
    double sum = 0;
    std::size_t n = 0;
    for (std::size_t y = 0; y < img.height(); ++y)
        for (std::size_t x = 0; x < img.width(); ++x) {
            if (!(exact(x, y) > 0.001 && exact(x, y) < 0.999)) continue;
            const double d = static_cast<double>(img(x, y)) - exact(x, y);
            sum += d * d, ++n;
        }
    return n ? std::sqrt(sum / static_cast<double>(n)) : 0.0;
}

/// 48×48, with a second occluder plane (y = 1.6) whose shadow overlaps the first's (y = 1; light at y = 3).
scene_t two_plane_scene() {
    scene_t sc;
    sc.width = sc.height = 48;
    sc.occluders.push_back({-1.2f, 0.2f, -0.1f, 0.9f, 1.6f});
    return sc;
}

/// A scene with its G-buffer and tracer, rendered by render_sheared (IDs as guides). Not copyable: the
/// tracer points at the scene.
struct scene_frame {
    scene_t sc;
    aaf_test::analytic_gbuffer<float> gb{sc};
    aaf_test::span_tracer<float> tracer{&sc};
    explicit scene_frame(scene_t scene) : sc(std::move(scene)) {}
    scene_frame(const scene_frame&) = delete;
    scene_frame& operator=(const scene_frame&) = delete;
    aaf::frame_report render(aaf::image<float>& img, aaf::sheared_workspace<float>& ws, const aaf::sheared_settings<float>& s) const {
        return aaf::render_sheared(gb.view_with_ids(), sc.area_light(), tracer, {img.view()}, ws, s);
    }
};

/// render_sheared over `sc` with `s`, in a workspace of its own.
aaf::image<float> sheared_image(const scene_t& sc, const aaf::sheared_settings<float>& s) {
    const scene_frame f(sc);
    aaf::sheared_workspace<float> ws;
    aaf::image<float> img(sc.width, sc.height);
    f.render(img, ws, s);
    return img;
}

/// `spp` stored samples per pixel of `gb` (gather_light_samples, pass 0, default sampling otherwise); the rays.
std::uint64_t gather_samples(const aaf_test::analytic_gbuffer<float>& gb, const aaf_test::span_tracer<float>& tracer,
                             const aaf::area_light<float>& light, std::uint32_t spp, aaf::light_sample_buffer<float>& samples) {
    aaf::sampling_settings ss;
    ss.initial_samples = spp;
    samples.reset(gb.positions.width(), gb.positions.height(), spp);
    aaf::image<aaf::occlusion_stats<float>> stats(gb.positions.width(), gb.positions.height());
    return aaf::gather_light_samples(gb.view(), light, tracer, ss, 0, samples, stats.view());
}

}  // namespace

TEST_CASE("sheared: shear_of at its limits", "[variants][sheared]") {
    aaf::sheared_settings<float> s;
    const float sigma = 0.5f, d = 0.01f;
    SECTION("no occluder: no slopes, not a centre") {
        const auto sh = aaf::shear_of(aaf::slope_pair<float>{}, sigma, d, s);
        CHECK_FALSE(sh.has_slopes());
        CHECK_FALSE(sh.center);
    }
    SECTION("single depth: c = 1/s, unbounded Gaussian (the light window bounds it)") {
        const auto sh = aaf::shear_of(aaf::slope_pair<float>{0.5f, 0.5f}, sigma, d, s);
        CHECK(sh.c == Approx(2.0f));
        CHECK(std::isinf(sh.beta));
        CHECK(sh.center);
    }
    SECTION("two depths: c the mean of 1/s, beta = 1/(k w) without narrowing") {
        s.narrowing_pixels = 0.0f;
        const auto sh = aaf::shear_of(aaf::slope_pair<float>{1.0f, 0.8f}, sigma, d, s);
        CHECK(sh.c == Approx(0.5f * (1.0f + 1.25f)));
        const float w = 2.0f / sigma * 0.5f * (1.25f - 1.0f);
        CHECK(sh.beta == Approx(1.0f / (3.0f * w)));
        CHECK(sh.center);
    }
    SECTION("narrowing: beta = min(1/(k w), n^-1/4 sqrt(narrowing d / (k w)))") {
        const float w = 2.0f / sigma * 0.5f * (1.25f - 1.0f), wedge = 1.0f / (3.0f * w);
        for (const std::uint32_t n : {1u, 16u, 10000u}) {
            s.frame.sampling.initial_samples = n;
            const auto sh = aaf::shear_of(aaf::slope_pair<float>{1.0f, 0.8f}, sigma, d, s);
            const float narrowed = std::pow(static_cast<float>(n), -0.25f) * std::sqrt(3.0f * d * wedge);
            INFO(n << " spp");
            CHECK(sh.beta == Approx(std::min(wedge, narrowed)));
            CHECK(sh.center);
        }
        // A footprint of half the wedge's width leaves 1 spp unnarrowed (√(3·½) > 1): min keeps 1/(k w).
        s.frame.sampling.initial_samples = 1;
        CHECK(aaf::shear_of(aaf::slope_pair<float>{1.0f, 0.8f}, sigma, 0.5f * wedge, s).beta == Approx(wedge));
        CHECK(std::isinf(aaf::shear_of(aaf::slope_pair<float>{0.5f, 0.5f}, sigma, d, s).beta));  // single depth: unbounded
        s.narrowing_pixels = std::numeric_limits<float>::infinity();  // documented as off, like 0 (the limit of the min)
        CHECK(aaf::shear_of(aaf::slope_pair<float>{1.0f, 0.8f}, sigma, d, s).beta == Approx(wedge));
    }
    SECTION("width_scale narrows beta in proportion and nothing else") {
        s.narrowing_pixels = 0.0f;
        const auto wide = aaf::shear_of(aaf::slope_pair<float>{1.0f, 0.8f}, sigma, d, s);
        s.width_scale = 0.25f;
        const auto narrow = aaf::shear_of(aaf::slope_pair<float>{1.0f, 0.8f}, sigma, d, s);
        CHECK(narrow.beta == Approx(0.25f * wide.beta));
        CHECK(narrow.c == wide.c);
        CHECK(narrow.center == wide.center);
        CHECK(std::isinf(aaf::shear_of(aaf::slope_pair<float>{0.5f, 0.5f}, sigma, d, s).beta));  // single depth: still unbounded
    }
    SECTION("s1/s2 above max_slope_ratio falls back to aaf") {
        CHECK_FALSE(aaf::shear_of(aaf::slope_pair<float>{3.0f, 1.0f}, sigma, d, s).center);
        s.max_slope_ratio = std::numeric_limits<float>::infinity();
        CHECK(aaf::shear_of(aaf::slope_pair<float>{3.0f, 1.0f}, sigma, d, s).center);
    }
    SECTION("contact (s2 = 0), point light and a pixel-limited wedge are not centres") {
        CHECK_FALSE(aaf::shear_of(aaf::slope_pair<float>{0.5f, 0.0f}, sigma, d, s).center);
        CHECK_FALSE(aaf::shear_of(aaf::slope_pair<float>{0.5f, 0.5f}, 0.0f, d, s).center);
        // w = (μ/2σ)(1/s2 − 1/s1) = 2·(100 − 1) ≫ 1/(2d)
        CHECK_FALSE(aaf::shear_of(aaf::slope_pair<float>{1.0f, 0.01f}, sigma, 0.1f, s).center);
        CHECK_FALSE(aaf::shear_of(aaf::slope_pair<float>{std::nanf(""), 0.5f}, sigma, d, s).center);
    }
}

TEST_CASE("sheared: the factored passes equal the exact gather", "[variants][sheared]") {
    const scene_t sc = small_scene();  // light at y = 3, occluder plane at y = 1: s = 0.5, c = 2
    const aaf_test::analytic_gbuffer<float> gb(sc);
    const aaf_test::span_tracer<float> tracer{&sc};
    const aaf::area_light<float> light = sc.area_light();
    aaf::light_sample_buffer<float> samples;
    const auto rays = gather_samples(gb, tracer, light, 4, samples);
    CHECK(rays == 4u * sc.width * sc.height);

    aaf::sheared_settings<float> s;
    aaf::image<aaf::shear<float>> shears(sc.width, sc.height);
    aaf::shear<float> sh = aaf::shear_of(aaf::slope_pair<float>{0.5f, 0.5f}, light.sigma(), sc.pixel_size(), s);
    REQUIRE(sh.center);
    sh.beta = 0.3f;  // a finite Gaussian too (the single-depth shear has none)
    shears.fill(sh);
    const std::size_t r = aaf::detail::shear_radius(sh, sc.pixel_size(), 3.0f, s.frame.filter.truncation, s.max_radius);
    REQUIRE(r == 8);  // 3β = 0.9 world units = 7.2 pixels
    aaf::sheared_workspace<float> ws;
    aaf::image<float> out(sc.width, sc.height);
    const auto max_error = [&](std::uint32_t bins, aaf::sheared_normalization norm) {
        s.bins = bins;
        s.normalization = norm;
        const aaf::image<double> exact = aaf_ref::sheared_gather_exact(gb.positions, light, samples, shears, r,
                                                                       norm == aaf::sheared_normalization::per_cell ? bins : 0);
        aaf::sheared_filter<float>(gb.positions.cview(), gb.pixel_size.cview(), light, samples, shears.cview(), out.view(), ws, aaf::guides<>{}, s);
        double worst = 0, sum = 0;
        for (std::size_t y = 0; y < sc.height; ++y)
            for (std::size_t x = 0; x < sc.width; ++x) {
                REQUIRE(std::isfinite(exact(x, y)));
                const double e = std::abs(static_cast<double>(out(x, y)) - exact(x, y));
                worst = std::max(worst, e), sum += e * e;
            }
        return std::pair{worst, std::sqrt(sum / static_cast<double>(sc.width * sc.height))};
    };
    // Bins keep their samples' mean coordinate: only bins straddling the light's edge (or a cell's) after
    // the column shift are approximate, and they shrink with the bin size.
    SECTION("pooled (FORMULAS.md §9.3 as written)") {
        // Measured: 0.037 at 4 bins, 0.016 at 16 (0.0075 at 32: first order in the bin size).
        const double fine = max_error(16, aaf::sheared_normalization::pooled).first;
        const double coarse = max_error(4, aaf::sheared_normalization::pooled).first;
        INFO("max |fast - exact|: 16 bins " << fine << ", 4 bins " << coarse);
        CHECK(fine < 0.02);
        CHECK(coarse < 0.05);
        CHECK(fine < 0.6 * coarse);
    }
    SECTION("per cell") {
        // Each cell's mean is a ratio of few samples, so a bin that lands in the neighbouring cell moves it
        // more than in the pooled form: compare the RMS over the frame as well as the worst pixel.
        const auto [worst4, rms4] = max_error(4, aaf::sheared_normalization::per_cell);
        const auto [worst8, rms8] = max_error(8, aaf::sheared_normalization::per_cell);
        INFO("|fast - exact|: 4 bins max " << worst4 << " rms " << rms4 << "; 8 bins max " << worst8 << " rms " << rms8);
        // Measured: rms 0.0078 (max 0.047) at 4 bins, 0.0079 (0.051) at 8: limited by the cell a bin's
        // mean falls in, not by the bin size.
        CHECK(rms4 < 0.012);
        CHECK(rms8 < 0.012);
        CHECK(worst4 < 0.07);
    }
}

TEST_CASE("sheared: on a single occluder plane 4 samples beat aaf at 4 samples", "[variants][sheared]") {
    const scene_t sc = small_scene();
    const aaf_test::analytic_gbuffer<float> gb(sc);
    const aaf_test::span_tracer<float> tracer{&sc};
    const aaf::area_light<float> light = sc.area_light();
    const aaf::image<double> exact = sc.exact_image();

    aaf::sheared_settings<float> s;
    s.frame.sampling.initial_samples = 4;
    s.frame.sampling.adaptive = false;
    aaf::sheared_workspace<float> ws;
    aaf::image<float> sheared(sc.width, sc.height), axis(sc.width, sc.height);
    const auto rep = aaf::render_sheared(gb.view_with_ids(), light, tracer, {sheared.view()}, ws, s);
    CHECK(rep.rays() == 4u * sc.width * sc.height);

    aaf::frame_settings<float> fs;
    fs.sampling.initial_samples = 4;
    fs.sampling.adaptive = false;
    aaf::frame_workspace<float> fw;
    aaf::render_frame(gb.view_with_ids(), light, tracer, {axis.view()}, fw, fs);

    const double e_sheared = penumbra_rmse(sheared, exact), e_aaf = penumbra_rmse(axis, exact);
    INFO("penumbra RMSE at 4 spp: sheared " << e_sheared << ", aaf " << e_aaf);
    CHECK(e_sheared < 0.03);
    CHECK(e_aaf > 0.03);
}

TEST_CASE("sheared: where occluder depths overlap, narrowing lowers the error floor", "[variants][sheared]") {
    // Two occluder planes overlapping along the shadow rays: a neighbour's sample whose occluder is not at
    // the centre's shear depth lands up to width_scale·σ/(kμ) from its place on the light at |Δx| = β, a
    // blur no number of samples removes (sheared.hpp, width_scale). At many samples a narrower filter must
    // win, and the default narrowing (∝ n^-1/4) must keep lowering the error where the fixed width stalls;
    // at 1 spp the wider fixed filter wins (it averages more neighbours), so no one fixed width is best.
    const scene_t sc = two_plane_scene();
    const aaf::image<double> exact = sc.exact_image();
    const auto error = [&](std::uint32_t spp, float width_scale, float narrowing) {
        aaf::sheared_settings<float> s;
        s.frame.sampling.initial_samples = spp;
        s.frame.sampling.max_samples = std::max(spp, 100u);
        s.max_slope_ratio = std::numeric_limits<float>::infinity();
        s.width_scale = width_scale;
        s.narrowing_pixels = narrowing;
        return penumbra_rmse(sheared_image(sc, s), exact);
    };
    const float standard = aaf::sheared_settings<float>{}.narrowing_pixels;
    const double fixed16 = error(16, 1.0f, 0.0f), fixed64 = error(64, 1.0f, 0.0f), quarter64 = error(64, 0.25f, 0.0f);
    const double narrowed16 = error(16, 1.0f, standard), narrowed64 = error(64, 1.0f, standard);
    const double few_wide = error(1, 1.0f, 0.0f), few_quarter = error(1, 0.25f, 0.0f);
    INFO("penumbra RMSE, width 1: 16 spp " << fixed16 << ", 64 spp " << fixed64 << "; width 0.25 at 64 spp " << quarter64
                                           << "; narrowed: 16 spp " << narrowed16 << ", 64 spp " << narrowed64 << "; 1 spp width 1 "
                                           << few_wide << ", 0.25 " << few_quarter);
    CHECK(quarter64 < 0.8 * fixed64);
    CHECK(narrowed64 < 0.8 * fixed64);
    CHECK(narrowed64 < 0.85 * narrowed16);
    CHECK(few_wide < few_quarter);
}

TEST_CASE("sheared: a sample buffer holds each pixel's own count and appends a second pass after the first", "[variants][sheared]") {
    aaf::image<std::uint32_t> counts(3, 2, 0u);
    counts(0, 0) = 2, counts(2, 0) = 5, counts(1, 1) = 1;
    aaf::light_sample_buffer<float> a, b;
    a.reset(3, 2, 3);
    CHECK(a.max_samples_per_pixel() == 3);
    CHECK(a.size() == 18);
    b.reset(counts.cview());
    CHECK(b.max_samples_per_pixel() == 5);
    CHECK(b.size() == 8);
    CHECK(b.pixel(0, 0).size() == 2);
    CHECK(b.pixel(1, 0).empty());
    CHECK(b.pixel(1, 1).size() == 1);
    // Mark every sample with its pixel and index to see where append puts it.
    for (std::size_t y = 0; y < 2; ++y)
        for (std::size_t x = 0; x < 3; ++x) {
            auto pa = a.pixel(x, y), pb = b.pixel(x, y);
            for (std::size_t i = 0; i < pa.size(); ++i) pa[i].u = static_cast<float>(10 * (y * 3 + x) + i);
            for (std::size_t i = 0; i < pb.size(); ++i) pb[i].u = static_cast<float>(100 + 10 * (y * 3 + x) + i);
        }
    a.append(b);
    CHECK(a.size() == 26);
    CHECK(a.max_samples_per_pixel() == 8);
    for (std::size_t y = 0; y < 2; ++y)
        for (std::size_t x = 0; x < 3; ++x) {
            const auto px = a.pixel(x, y);
            REQUIRE(px.size() == 3 + counts(x, y));
            for (std::size_t i = 0; i < px.size(); ++i) {
                const float want = i < 3 ? static_cast<float>(10 * (y * 3 + x) + i) : static_cast<float>(100 + 10 * (y * 3 + x) + (i - 3));
                CHECK(px[i].u == want);
            }
        }
    aaf::light_sample_buffer<float> other;
    other.reset(2, 2, 1);
    CHECK_THROWS_WITH(a.append(other), Catch::Contains("`more`"));
}

TEST_CASE("sheared: centre_samples traces the centres' extra samples and no others", "[variants][sheared]") {
    // Same first pass and shears with and without centre_samples, so the rays differ by exactly the
    // centres' extra samples, and each pixel's stored samples are its first pass plus (centres only) the rest.
    const scene_frame f(two_plane_scene());
    const scene_t& sc = f.sc;
    aaf::sheared_settings<float> s;
    s.frame.sampling.initial_samples = 4;
    s.max_slope_ratio = std::numeric_limits<float>::infinity();
    aaf::sheared_workspace<float> one, two;
    aaf::image<float> img(sc.width, sc.height);
    const auto base = f.render(img, one, s);
    s.centre_samples = 16;
    const auto more = f.render(img, two, s);
    std::size_t centres = 0, others = 0;
    for (std::size_t y = 0; y < sc.height; ++y)
        for (std::size_t x = 0; x < sc.width; ++x) {
            REQUIRE(two.shears(x, y).center == one.shears(x, y).center);
            const auto px = two.samples.pixel(x, y);
            if (two.shears(x, y).center) {
                ++centres;
                REQUIRE(px.size() == 16);
                CHECK(std::equal(px.begin(), px.begin() + 4, one.samples.pixel(x, y).begin(),
                                 [](const auto& a, const auto& b) { return a.u == b.u && a.v == b.v && a.state == b.state; }));
                const bool same_points = std::equal(px.begin() + 4, px.begin() + 8, px.begin(),
                                                    [](const auto& a, const auto& b) { return a.u == b.u && a.v == b.v; });
                CHECK_FALSE(same_points);  // pass 1's keys, not a copy of pass 0
            } else {
                ++others;
                REQUIRE(px.size() == 4);
            }
        }
    INFO(centres << " centres, " << others << " other pixels");
    REQUIRE(centres > 100);
    REQUIRE(others > 100);
    CHECK(more.initial_rays == base.initial_rays);
    CHECK(more.adaptive_rays == base.adaptive_rays + 12u * centres);
    // The workspace is reused: a frame without centre_samples afterwards holds 4 samples everywhere again.
    s.centre_samples = 0;
    f.render(img, two, s);
    CHECK(two.samples.size() == 4u * sc.width * sc.height);
    // Low discrepancy: a centre's 16 samples are the 16-point sequence of a frame with 16 everywhere.
    s.frame.sampling.pattern = aaf::sample_pattern::low_discrepancy;
    s.centre_samples = 16;
    f.render(img, two, s);
    s.frame.sampling.initial_samples = 16;
    s.centre_samples = 0;
    f.render(img, one, s);
    std::size_t equal = 0, ld_centres = 0;
    for (std::size_t y = 0; y < sc.height; ++y)
        for (std::size_t x = 0; x < sc.width; ++x)
            if (two.shears(x, y).center)
                ++ld_centres, equal += std::equal(two.samples.pixel(x, y).begin(), two.samples.pixel(x, y).end(), one.samples.pixel(x, y).begin(),
                                    one.samples.pixel(x, y).end(),
                                    [](const auto& a, const auto& b) { return a.u == b.u && a.v == b.v && a.state == b.state; });
    CHECK(ld_centres > 100);
    CHECK(equal == ld_centres);
}

TEST_CASE("sheared: centre_samples reaches the error of as many samples everywhere with fewer rays", "[variants][sheared]") {
    // The error is on the centres, so the lit pixels around need no more than their first pass. With the
    // low-discrepancy pattern the second pass continues each centre's sequence (one net of 16) and the
    // centres' shears are recomputed from all 16 samples, so the frame must match 16 samples everywhere;
    // stratified samples come as a second, independent set (4 + 12 strata: less even than 16).
    const scene_frame f(two_plane_scene());
    const scene_t& sc = f.sc;
    const aaf::image<double> exact = sc.exact_image();
    for (const auto pattern : {aaf::sample_pattern::stratified, aaf::sample_pattern::low_discrepancy}) {
        const auto run = [&](std::uint32_t initial, std::uint32_t centre) {
            aaf::sheared_settings<float> s;
            s.frame.sampling.initial_samples = initial;
            s.frame.sampling.pattern = pattern;
            s.centre_samples = centre;
            s.max_slope_ratio = std::numeric_limits<float>::infinity();
            aaf::sheared_workspace<float> ws;
            aaf::image<float> img(sc.width, sc.height);
            const auto r = f.render(img, ws, s);
            return std::pair{penumbra_rmse(img, exact), r.rays()};
        };
        const auto [e4, rays4] = run(4, 0);
        const auto [e16, rays16] = run(16, 0);
        const auto [e4_16, rays4_16] = run(4, 16);
        INFO((pattern == aaf::sample_pattern::stratified ? "stratified" : "low discrepancy")
             << ": penumbra RMSE (rays): 4 spp " << e4 << " (" << rays4 << "), 16 spp " << e16 << " (" << rays16 << "), 4 + centres 16 "
             << e4_16 << " (" << rays4_16 << ")");
        CHECK(e4_16 < 0.7 * e4);
        CHECK(e4_16 < (pattern == aaf::sample_pattern::stratified ? 1.2 : 1.01) * e16);
        CHECK(rays4_16 < rays16);
    }
}

TEST_CASE("sheared: a reused workspace gives the frames of fresh ones, also when the bins change", "[variants][sheared]") {
    // The row pass clears only the bins it writes and marks them occupied; a workspace resized between
    // frames (other bins, other samples) must not leak a former frame's bins into the column pass.
    const scene_frame f(two_plane_scene());
    const scene_t& sc = f.sc;
    const auto frame = [&](aaf::sheared_workspace<float>& ws, std::uint32_t bins, std::uint32_t spp) {
        aaf::sheared_settings<float> s;
        s.frame.sampling.initial_samples = spp;
        s.bins = bins;
        s.max_slope_ratio = std::numeric_limits<float>::infinity();
        aaf::image<float> img(sc.width, sc.height);
        f.render(img, ws, s);
        return img;
    };
    aaf::sheared_workspace<float> reused;
    reused.resize(sc.width, sc.height, aaf::sheared_settings<float>{});
    for (const auto& [bins, spp] : {std::pair{8u, 16u}, std::pair{4u, 4u}, std::pair{8u, 4u}, std::pair{12u, 9u}}) {
        aaf::sheared_workspace<float> fresh;
        const aaf::image<float> a = frame(reused, bins, spp), b = frame(fresh, bins, spp);
        INFO(bins << " bins, " << spp << " spp");
        CHECK(std::equal(a.data(), a.data() + a.size(), b.data(), [](float x, float y) { return x == y || (x != x && y != y); }));
    }
}

TEST_CASE("sheared: fallback_mu raises aaf's mu on the fallback pixels only", "[variants][sheared]") {
    // With max_slope_ratio 1 every pixel with two depths falls back to aaf; a larger μ there must give those
    // pixels more samples and narrower filters and leave the sheared centres' samples and shears alone.
    const scene_frame f(two_plane_scene());
    const scene_t& sc = f.sc;
    aaf::sheared_settings<float> s;
    s.frame.sampling.initial_samples = 4;
    s.frame.sampling.max_samples = 400;
    s.max_slope_ratio = 1.0f;
    aaf::sheared_workspace<float> at2, at4;
    aaf::image<float> img(sc.width, sc.height);
    const auto r2 = f.render(img, at2, s);
    s.fallback_mu = 4.0f;
    const auto r4 = f.render(img, at4, s);
    CHECK(r4.initial_rays == r2.initial_rays);
    CHECK(r4.adaptive_rays > r2.adaptive_rays);
    std::size_t fallback = 0, narrower = 0, centres = 0;
    for (std::size_t y = 0; y < sc.height; ++y)
        for (std::size_t x = 0; x < sc.width; ++x) {
            const bool centre = at2.shears(x, y).center;
            REQUIRE(at4.shears(x, y).center == centre);
            if (centre) {
                ++centres;
                CHECK(at4.shears(x, y).beta == at2.shears(x, y).beta);
                CHECK(at4.frame.adaptive_samples(x, y) == 0);
            } else if (at2.frame.filter_width(x, y) > 0.0f) {
                ++fallback;
                CHECK(at4.frame.adaptive_samples(x, y) >= at2.frame.adaptive_samples(x, y));
                narrower += at4.frame.filter_width(x, y) < at2.frame.filter_width(x, y) ? 1 : 0;
            }
        }
    INFO(centres << " centres, " << fallback << " filtered fallback pixels, " << narrower << " narrower at mu 4");
    CHECK(centres > 50);
    CHECK(fallback > 50);
    CHECK(narrower == fallback);
}

TEST_CASE("sheared: blocked samples keep their occluder's height and move through it", "[variants][sheared]") {
    // Two occluder planes at y = 1 and 1.6 between the floor (y = 0) and the light (y = 3): every blocked
    // sample's occluder fraction must say which plane stopped it.
    const scene_t sc = two_plane_scene();
    const aaf_test::analytic_gbuffer<float> gb(sc);
    const aaf_test::span_tracer<float> tracer{&sc};
    aaf::light_sample_buffer<float> samples;
    gather_samples(gb, tracer, sc.area_light(), 4, samples);
    std::size_t blocked = 0, wrong = 0;
    for (std::size_t y = 0; y < sc.height; ++y)
        for (std::size_t x = 0; x < sc.width; ++x)
            for (const auto& smp : samples.pixel(x, y)) {
                if (smp.state != aaf::sample_state::blocked) {
                    CHECK(std::isnan(smp.occluder));
                    continue;
                }
                ++blocked;
                // Height of the occluder above the light plane over the receiver's (3 above the floor): the
                // planes at y = 1 and 1.6 are 2 and 1.4 below the light, i.e. fractions 2/3 and 1.4/3 (the ray
                // origin's small offset aside).
                const float f = smp.occluder;
                if (!(std::abs(f - 2.0f / 3.0f) < 0.01f || std::abs(f - 1.4f / 3.0f) < 0.01f)) ++wrong;
            }
    CHECK(blocked > 100);
    CHECK(wrong == 0);

    // Moving blocked samples through their own occluder: on one occluder plane that is the shear's own depth,
    // so the frame must not change beyond rounding; with the second plane it must not get worse (on this
    // scene the shear's visible samples and the column pass's single shear leave the error where it was:
    // 0.01068 against 0.01064 at 16 spp; the gain is on the meshes, docs/RESULTS.md).
    const auto render = [](const scene_t& scene, bool per_sample) {
        aaf::sheared_settings<float> s;
        s.frame.sampling.initial_samples = 16;
        s.max_slope_ratio = std::numeric_limits<float>::infinity();
        s.per_sample_depth = per_sample;
        return sheared_image(scene, s);
    };
    scene_t one;
    one.width = one.height = 48;
    const aaf::image<float> own1 = render(one, true), shear1 = render(one, false);
    double worst = 0;
    for (std::size_t i = 0; i < own1.size(); ++i) worst = std::max(worst, std::abs(double(own1.data()[i]) - double(shear1.data()[i])));
    INFO("one plane: largest difference " << worst);
    CHECK(worst < 1e-4);  // measured 1.4e-6
    const aaf::image<double> exact = sc.exact_image();
    const double own = penumbra_rmse(render(sc, true), exact), one_shear = penumbra_rmse(render(sc, false), exact);
    INFO("two planes, penumbra RMSE at 16 spp: own occluder " << own << ", one shear " << one_shear);
    CHECK(own < 1.02 * one_shear);
}

TEST_CASE("sheared: bad input throws naming the argument", "[variants][sheared]") {
    const scene_t sc = small_scene();
    const aaf_test::analytic_gbuffer<float> gb(sc);
    const aaf_test::span_tracer<float> tracer{&sc};
    const aaf::area_light<float> light = sc.area_light();
    aaf::sheared_workspace<float> ws;
    aaf::image<float> out(sc.width, sc.height), small(8, 8);
    const auto throws_with = [&](auto&& f, const std::string& what) {
        try {
            f();
            FAIL("no exception for " << what);
        } catch (const aaf::invalid_argument& e) {
            CHECK_THAT(e.what(), Catch::Contains(what));
        }
    };
    throws_with([&] { aaf::render_sheared(gb.view(), light, tracer, {small.view()}, ws); }, "outputs.visibility");
    aaf::sheared_settings<float> s;
    s.bins = 0;
    throws_with([&] { aaf::render_sheared(gb.view(), light, tracer, {out.view()}, ws, s); }, "settings.bins");
    s = {};
    s.max_slope_ratio = 0.5f;
    throws_with([&] { aaf::render_sheared(gb.view(), light, tracer, {out.view()}, ws, s); }, "settings.max_slope_ratio");
    s = {};
    for (const float bad : {0.0f, -0.5f, 1.5f, std::nanf("")}) {
        s.width_scale = bad;
        throws_with([&] { aaf::render_sheared(gb.view(), light, tracer, {out.view()}, ws, s); }, "settings.width_scale");
    }
    s = {};
    for (const float bad : {-1.0f, std::nanf("")}) {
        s.narrowing_pixels = bad;
        throws_with([&] { aaf::render_sheared(gb.view(), light, tracer, {out.view()}, ws, s); }, "settings.narrowing_pixels");
    }
    s = {};
    s.shear_tolerance = std::nanf("");
    throws_with([&] { aaf::render_sheared(gb.view(), light, tracer, {out.view()}, ws, s); }, "settings.shear_tolerance");
    s = {};
    s = {};
    for (const float bad : {-1.0f, 0.5f, std::nanf(""), std::numeric_limits<float>::infinity()}) {
        s.fallback_mu = bad;
        throws_with([&] { aaf::render_sheared(gb.view(), light, tracer, {out.view()}, ws, s); }, "settings.fallback_mu");
    }
    s = {};
    for (const std::uint32_t bad : {1u, 8u, 5000u}) {  // below initial_samples (9), above 4096
        s.centre_samples = bad;
        throws_with([&] { aaf::render_sheared(gb.view(), light, tracer, {out.view()}, ws, s); }, "settings.centre_samples");
    }
    aaf::light_sample_buffer<float> samples;
    samples.reset(8, 8, 4);
    aaf::image<aaf::occlusion_stats<float>> stats(sc.width, sc.height);
    throws_with([&] { aaf::gather_light_samples(gb.view(), light, tracer, aaf::sampling_settings{}, 0, samples, stats.view()); }, "`samples`");
    aaf::image<aaf::shear<float>> shears(sc.width, sc.height);
    throws_with(
        [&] {
            aaf::sheared_filter<float>(gb.positions.cview(), gb.pixel_size.cview(), light, samples, shears.cview(), out.view(), ws);
        },
        "`samples`");
    aaf::image<aaf::shear<float>> shears_small(4, 4);
    samples.reset(sc.width, sc.height, 4);
    throws_with(
        [&] {
            aaf::sheared_filter<float>(gb.positions.cview(), gb.pixel_size.cview(), light, samples, shears_small.cview(), out.view(), ws);
        },
        "shears");
}

TEST_CASE("sheared: non-finite data does not spread", "[variants][sheared]") {
    const scene_t sc = small_scene();
    aaf_test::analytic_gbuffer<float> gb(sc);
    const aaf_test::span_tracer<float> tracer{&sc};
    const aaf::area_light<float> light = sc.area_light();
    // A hole (sky) and a NaN normal in the penumbra.
    gb.positions(12, 12) = glm::vec3(std::numeric_limits<float>::quiet_NaN());
    gb.normals(13, 12) = glm::vec3(std::numeric_limits<float>::quiet_NaN());
    aaf::sheared_settings<float> s;
    s.frame.sampling.initial_samples = 4;
    aaf::sheared_workspace<float> ws;
    aaf::image<float> out(sc.width, sc.height);
    aaf::render_sheared(gb.view(), light, tracer, {out.view()}, ws, s);
    for (std::size_t y = 0; y < sc.height; ++y)
        for (std::size_t x = 0; x < sc.width; ++x) {
            INFO(x << ", " << y);
            REQUIRE(std::isfinite(out(x, y)));
            REQUIRE(out(x, y) >= 0.0f);
            REQUIRE(out(x, y) <= 1.0f);
        }
    CHECK(out(12, 12) == 1.0f);  // no surface: sky
    CHECK(out(13, 12) == 1.0f);
}

// Not run by default (hidden tag): the figures DEVIATIONS.md H1 and RESULTS.md quote, printed with WARN.
// build/release/tests/aaf_tests "[.sheared_probe]"
TEST_CASE("sheared: probe of the error against samples on one and two occluder planes", "[.sheared_probe]") {
    for (const bool two : {false, true}) {
        scene_t sc;
        sc.width = sc.height = 64;
        if (two) sc.occluders.push_back({-1.2f, 0.2f, -0.1f, 0.9f, 1.6f});
        const aaf_test::analytic_gbuffer<float> gb(sc);
        const aaf_test::span_tracer<float> tracer{&sc};
        const aaf::image<double> exact = sc.exact_image();
        for (const unsigned spp : {1u, 4u, 16u, 64u}) {
            double e[3] = {};
            for (int form = 0; form < 2; ++form) {
                aaf::sheared_settings<float> s;
                s.frame.sampling.initial_samples = spp;
                s.frame.sampling.max_samples = std::max(spp, 100u);
                s.max_slope_ratio = std::numeric_limits<float>::infinity();
                s.normalization = form == 0 ? aaf::sheared_normalization::pooled : aaf::sheared_normalization::per_cell;
                aaf::sheared_workspace<float> ws;
                aaf::image<float> img(sc.width, sc.height);
                aaf::render_sheared(gb.view_with_ids(), sc.area_light(), tracer, {img.view()}, ws, s);
                e[form] = aaf_test::rmse(img, exact);
            }
            aaf::frame_settings<float> fs;
            fs.sampling.initial_samples = spp;
            fs.sampling.max_samples = std::max(spp, 100u);
            fs.sampling.adaptive = false;
            aaf::frame_workspace<float> fw;
            aaf::image<float> img(sc.width, sc.height);
            aaf::render_frame(gb.view_with_ids(), sc.area_light(), tracer, {img.view()}, fw, fs);
            e[2] = aaf_test::rmse(img, exact);
            WARN((two ? "two planes" : "one plane") << ", " << spp << " spp: RMSE sheared pooled " << e[0] << ", per cell " << e[1]
                                                   << ", aaf (no adaptive samples) " << e[2]);
        }
    }
}
