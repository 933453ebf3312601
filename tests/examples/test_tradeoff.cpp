// SPDX-License-Identifier: MIT
// aaf-tradeoff's engine (examples/common/tradeoff.hpp) and the metrics it reports
// (examples/common/render_support.hpp): SSIM against hand-computed values and its expected properties,
// RMSE over a mask, the equal-error interpolation on exact power laws and at its edges, and the JSON of a
// tiny in-process run (every field present with the right type, numbers finite, equal_error complete).

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include <aaf/image.hpp>

#include "common/render_support.hpp"
#include "common/tradeoff.hpp"

namespace fs = std::filesystem;
using aaf_examples::tradeoff::curve_point;
using aaf_examples::tradeoff::equal_error_cost;

namespace {

aaf::image<float> noisy_copy(const aaf::image<float>& img, float amplitude, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(-amplitude, amplitude);
    aaf::image<float> out(img.width(), img.height());
    for (std::size_t i = 0; i < img.size(); ++i) out.data()[i] = std::clamp(img.data()[i] + u(rng), 0.0f, 1.0f);
    return out;
}

aaf::image<float> soft_edge(std::size_t w, std::size_t h) {
    aaf::image<float> img(w, h);
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x)
            img(x, y) = 0.5f + 0.5f * std::tanh((static_cast<float>(x) - 0.5f * static_cast<float>(w)) / 4.0f);
    return img;
}

/// A quick in-process run's settings (2 threads, a 32-spp reference cached in the temporary folder `cache`).
aaf_examples::tradeoff::config tiny_run(const char* scene, std::size_t width, std::size_t height, std::uint32_t max_mc_spp,
                                        const char* cache) {
    aaf_examples::tradeoff::config c;
    c.scene = scene;
    c.width = width, c.height = height;
    c.threads = 2;
    c.reference_spp = 32;
    c.repeat = 1;
    c.quick = true;
    c.max_mc_spp = max_mc_spp;
    c.progress = false;
    c.cache = fs::temp_directory_path() / cache;
    return c;
}

}  // namespace

TEST_CASE("ssim: 1 for identical images, the closed form for constant ones, symmetric, lower with noise", "[tradeoff][metrics]") {
    const aaf::image<float> a = soft_edge(40, 30);
    CHECK(aaf_examples::ssim(a, a) == Approx(1.0).margin(1e-12));

    // Constant images: every window has zero variance and covariance, so SSIM = (2ab + C1) / (a² + b² + C1).
    const aaf::image<float> half(16, 16, 0.5f), quarter(16, 16, 0.25f);
    const double c1 = 1e-4;
    CHECK(aaf_examples::ssim(half, quarter) == Approx((2 * 0.5 * 0.25 + c1) / (0.25 + 0.0625 + c1)).epsilon(1e-9));

    // A window by hand: a 1×2 image, x = (0, 1), y = (1, 0). Each pixel's window holds both pixels with
    // Gaussian weights 1 (itself) and e^(-1/(2·1.5²)) (the other), so per pixel with normalised weights
    // p, q = 1 - p: means μx = q, μy = p (or swapped), variances pq, covariance -pq.
    const double k = std::exp(-0.5 / (1.5 * 1.5));
    const double p = 1 / (1 + k), q = k / (1 + k), c2 = 9e-4;
    const double expected = ((2 * p * q + c1) * (-2 * p * q + c2)) / ((p * p + q * q + c1) * (2 * p * q + c2));
    aaf::image<float> x(2, 1), y(2, 1);
    x(0, 0) = 0, x(1, 0) = 1, y(0, 0) = 1, y(1, 0) = 0;
    CHECK(aaf_examples::ssim(x, y) == Approx(expected).epsilon(1e-6));

    const aaf::image<float> n1 = noisy_copy(a, 0.05f, 1), n2 = noisy_copy(a, 0.2f, 2);
    CHECK(aaf_examples::ssim(a, n1) == Approx(aaf_examples::ssim(n1, a)).epsilon(1e-12));
    CHECK(aaf_examples::ssim(a, n1) < 1.0);
    CHECK(aaf_examples::ssim(a, n2) < aaf_examples::ssim(a, n1));
    CHECK(aaf_examples::ssim(a, n2) > -1.0);
}

TEST_CASE("ssim and rmse ignore masked pixels, inside the window too", "[tradeoff][metrics]") {
    aaf::image<float> a = soft_edge(32, 24), b = a;
    std::vector<unsigned char> mask(a.size(), 1);
    for (std::size_t y = 0; y < 24; ++y)
        for (std::size_t x = 0; x < 8; ++x) {
            mask[y * 32 + x] = 0;
            b(x, y) = 1.0f - a(x, y);  // wildly different, but sky
        }
    CHECK(aaf_examples::rmse(a, b, mask) == 0.0);
    CHECK(aaf_examples::max_abs_error(a, b, mask) == 0.0);
    CHECK(aaf_examples::ssim(a, b, mask) == Approx(1.0).margin(1e-12));
    CHECK(aaf_examples::rmse(a, b) > 0.0);
    CHECK(aaf_examples::ssim(a, b) < 1.0);

    // RMSE by hand: two pixels counted, errors 0.3 and 0.4 → sqrt((0.09 + 0.16) / 2); the third is masked.
    aaf::image<float> u(3, 1, 0.0f), v(3, 1, 0.0f);
    v(0, 0) = 0.3f, v(1, 0) = 0.4f, v(2, 0) = 1.0f;
    CHECK(aaf_examples::rmse(u, v, {1, 1, 0}) == Approx(std::sqrt(0.125)).epsilon(1e-6));
    CHECK(aaf_examples::max_abs_error(u, v, {1, 1, 0}) == Approx(0.4).epsilon(1e-6));
    CHECK_THROWS_AS(aaf_examples::rmse(u, aaf::image<float>(2, 1)), std::invalid_argument);
    CHECK_THROWS_AS(aaf_examples::rmse(u, v, {1, 1}), std::invalid_argument);
}

TEST_CASE("equal_error_cost: exact on power laws, first crossing, bounds outside the curve", "[tradeoff][equal_error]") {
    // rmse = c·rays^-0.5 and time = 2·rays: a target rmse e needs rays = (c/e)².
    const double c = 0.4;
    std::vector<curve_point> curve;
    for (double r = 1; r <= 1024; r *= 2) curve.push_back({r, 2 * r, c / std::sqrt(r)});
    for (double target : {0.3, 0.1, 0.05, 0.0133, c / std::sqrt(1024.0)}) {
        const auto e = equal_error_cost(curve, target);
        const double rays = (c / target) * (c / target);
        CHECK(e.rays == Approx(rays).epsilon(1e-9));
        CHECK(e.time == Approx(2 * rays).epsilon(1e-9));
        CHECK_FALSE(e.extrapolated);
        CHECK(e.bound == "interpolated");
    }
    // Any exponent, unsorted input.
    std::vector<curve_point> steep;
    for (double r : {64.0, 1.0, 16.0, 4.0}) steep.push_back({r, r, 0.5 * std::pow(r, -0.8)});
    CHECK(equal_error_cost(steep, 0.5 * std::pow(10.0, -0.8)).rays == Approx(10.0).epsilon(1e-9));

    SECTION("below the whole curve: a lower bound at its most expensive point") {
        const auto e = equal_error_cost(curve, 0.001);
        CHECK(e.extrapolated);
        CHECK(e.bound == "lower");
        CHECK(e.rays == 1024);
        CHECK(e.time == 2048);
    }
    SECTION("above the whole curve: an upper bound at its cheapest point") {
        const auto e = equal_error_cost(curve, 0.5);
        CHECK(e.extrapolated);
        CHECK(e.bound == "upper");
        CHECK(e.rays == 1);
    }
    SECTION("exactly the cheapest point's error is on the curve") {
        const auto e = equal_error_cost(curve, c);
        CHECK_FALSE(e.extrapolated);
        CHECK(e.rays == 1);
    }
    SECTION("a non-monotone curve: the first crossing from the cheap end") {
        const std::vector<curve_point> bumpy = {{1, 1, 0.1}, {2, 2, 0.05}, {4, 4, 0.07}, {8, 8, 0.02}};
        const auto e = equal_error_cost(bumpy, 0.06);
        CHECK(e.rays > 1);
        CHECK(e.rays < 2);
        // log-log between (1, 0.1) and (2, 0.05): rays = 2^(log(0.06/0.1)/log(0.5)).
        CHECK(e.rays == Approx(std::pow(2.0, std::log(0.6) / std::log(0.5))).epsilon(1e-9));
        CHECK(equal_error_cost(bumpy, 0.03).rays > 4);  // 0.03 is first reached between 4 and 8
    }
    SECTION("bad input") {
        CHECK_THROWS_AS(equal_error_cost({}, 0.1), std::invalid_argument);
        CHECK_THROWS_AS(equal_error_cost(curve, 0.0), std::invalid_argument);
        CHECK_THROWS_AS(equal_error_cost(curve, std::nan("")), std::invalid_argument);
        CHECK_THROWS_AS(equal_error_cost({{1, 1, 0}}, 0.1), std::invalid_argument);
    }
}

TEST_CASE("a tiny in-process run gives the documented JSON", "[tradeoff][json]") {
    aaf_examples::tradeoff::config c = tiny_run("boxes", 40, 30, 64, "aaf-test-tradeoff-cache");
    c.methods = {"aaf_adaptive", "mc_low_discrepancy", "preset_fast"};
    const nlohmann::json r = aaf_examples::tradeoff::run(c);

    for (const char* key : {"scene", "metric_mask", "reference_rmse_method"}) CHECK(r.at(key).is_string());
    for (const char* key : {"width", "height", "reference_spp", "threads", "repeat", "surface_pixels"}) {
        INFO(key);
        CHECK(r.at(key).is_number_integer());
        CHECK(r.at(key).get<long long>() > 0);
    }
    CHECK(r["width"] == 40);
    CHECK(r["reference_spp"] == 32);
    CHECK(r["threads"] == 2);
    CHECK(r["metric_mask"] == "surface pixels");
    CHECK(r.at("reference_rmse_estimate").is_number());
    CHECK(r["reference_rmse_estimate"].get<double>() > 0);
    REQUIRE(r.at("reference_seeds").size() == 2);
    CHECK(r["reference_seeds"][0] != r["seed"]);
    CHECK(r["reference_seeds"][1] != r["seed"]);

    // The baseline joins the chosen methods; methods come in the documented order.
    REQUIRE(r.at("methods").is_array());
    std::vector<std::string> names;
    for (const auto& m : r["methods"]) names.push_back(m.at("name").get<std::string>());
    CHECK(names == std::vector<std::string>{"mc_stratified", "mc_low_discrepancy", "aaf_adaptive", "preset_fast"});
    for (const auto& m : r["methods"]) {
        INFO(m["name"]);
        CHECK(m.at("settings").is_object());
        CHECK(m.at("kind").is_string());
        REQUIRE(!m.at("points").empty());
        for (const auto& p : m["points"]) {
            for (const char* key : {"rays_per_pixel", "time_ms", "rays_ms", "filter_ms", "rmse", "ssim", "max_abs_error", "filter_share"}) {
                INFO(key);
                REQUIRE(p.at(key).is_number());
                CHECK(std::isfinite(p[key].get<double>()));
                CHECK(p[key].get<double>() >= 0);
            }
            CHECK(p["rays_per_pixel"].get<double>() > 0);
            CHECK(p["rmse"].get<double>() > 0);
            CHECK(p["ssim"].get<double>() <= 1);
            if (m["kind"] == "mc") CHECK(p["filter_ms"] == 0.0);
            else CHECK(p.at("formulas_ms").is_number());
        }
    }
    CHECK(r["methods"][2]["settings"]["offsets"] == "image");
    CHECK(r["methods"][2]["settings"]["stats"] == "all_hits");

    // One equal-error entry per aaf and preset point.
    const std::size_t expected = r["methods"][2]["points"].size() + r["methods"][3]["points"].size();
    REQUIRE(r.at("equal_error").size() == expected);
    for (const auto& e : r["equal_error"]) {
        CHECK(e.at("method").is_string());
        CHECK(e.at("baseline") == "mc_stratified");
        CHECK(e.at("extrapolated").is_boolean());
        CHECK(e.at("point").is_number_integer());
        for (const char* key : {"rmse", "rays_per_pixel", "baseline_rays_per_pixel", "rays_ratio", "time_ratio"}) {
            INFO(key);
            REQUIRE(e.at(key).is_number());
            CHECK(std::isfinite(e[key].get<double>()));
            CHECK(e[key].get<double>() > 0);
        }
    }

    SECTION("the markdown summary and the gnuplot script name every method") {
        const std::string md = aaf_examples::tradeoff::summary_markdown(r);
        const std::string gp = aaf_examples::tradeoff::gnuplot_script(r);
        for (const std::string& n : names) {
            CHECK(md.find("## " + n) != std::string::npos);
            CHECK(gp.find("$" + n + " << EOD") != std::string::npos);
        }
        CHECK(md.find("Equal error") != std::string::npos);
        CHECK(gp.find("set logscale xy") != std::string::npos);
        CHECK(gp.find("rmse_vs_rays.png") != std::string::npos);
    }
    SECTION("an unknown method is a usage error naming it") {
        aaf_examples::tradeoff::config bad = c;
        bad.methods = {"aaf_adaptive", "aaf_magic"};
        CHECK_THROWS_WITH(aaf_examples::tradeoff::run(bad), Catch::Contains("unknown method 'aaf_magic'"));
    }
    fs::remove_all(c.cache);
}

TEST_CASE("a method's regions split its error: shares that recombine to the point's RMSE", "[tradeoff][json]") {
    // The sheared methods mark the pixels the sheared filter gave (the rest are aaf's): the split must be a
    // partition of the metric's pixels and of the squared error.
    // Its own cache folder: ctest may run this case beside the one above, which removes its folder.
    aaf_examples::tradeoff::config c = tiny_run("lattice", 64, 48, 16, "aaf-test-tradeoff-regions-cache");
    c.methods = {"aaf_sheared_consistent"};
    const nlohmann::json r = aaf_examples::tradeoff::run(c);
    bool found = false, some_inside = false;
    for (const auto& m : r.at("methods")) {
        if (m.at("name") != "aaf_sheared_consistent") {
            for (const auto& p : m.at("points")) CHECK_FALSE(p.contains("regions"));  // Monte Carlo has none
            continue;
        }
        found = true;
        for (const auto& p : m.at("points")) {
            REQUIRE(p.contains("regions"));
            const auto& g = p["regions"].at("sheared_centres");
            const double share = g.at("pixel_share").get<double>(), err_share = g.at("error_share").get<double>();
            const double in = g.at("rmse_in").get<double>(), out = g.at("rmse_out").get<double>(), all = p.at("rmse").get<double>();
            INFO("pixel share " << share << ", error share " << err_share << ", rmse in " << in << " out " << out << " all " << all);
            CHECK(share >= 0.0);
            CHECK(share <= 1.0);
            CHECK(err_share >= 0.0);
            CHECK(err_share <= 1.0);
            CHECK(share * in * in + (1 - share) * out * out == Approx(all * all).epsilon(1e-9));
            CHECK(err_share * all * all == Approx(share * in * in).epsilon(1e-9).margin(1e-15));
            some_inside = some_inside || share > 0;
        }
    }
    CHECK(found);
    CHECK(some_inside);
    fs::remove_all(c.cache);
}
