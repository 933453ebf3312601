// SPDX-License-Identifier: MIT
// The axis-aligned AO filter: its width and sample count at their limits, convergence to the reference as μ
// grows, guides (IDs, creases), bent normals, and the whole frame driver.

#include <catch2/catch.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>

#include <aaf/occlusion.hpp>

#include "support/ao_scene.hpp"

using aaf_test::ao_half_plane;
using aaf_test::ao_scene;
using aaf_test::ao_tracer;

namespace {

constexpr float inf = std::numeric_limits<float>::infinity();
constexpr float qnan = std::numeric_limits<float>::quiet_NaN();

/// A floor strip seen from above: pixel (x, y) at (x0 + x·d, 0, y·d), normal +y.
struct floor_frame {
    aaf::image<glm::vec3> positions, normals;
    aaf::image<float> pixel_size;
    aaf::image<std::uint32_t> ids;
    floor_frame(std::size_t w, std::size_t h, float d, float x0 = 0)
        : positions(w, h), normals(w, h, glm::vec3(0, 1, 0)), pixel_size(w, h, d), ids(w, h, 0u) {
        for (std::size_t y = 0; y < h; ++y)
            for (std::size_t x = 0; x < w; ++x)
                positions(x, y) = {x0 + d * static_cast<float>(x), 0, d * static_cast<float>(y)};
    }
    [[nodiscard]] aaf::gbuffer<float, aaf::const_image_view<std::uint32_t>> gb() const {
        return {positions.cview(), normals.cview(), pixel_size.cview(), ids.cview()};
    }
};

/// A record with visibility v, z_min = z (and z_max = z), from 16 samples, bent normal b.
aaf::ao_stats<float> record(float v, float z, glm::vec3 b = {0, 1, 0}) {
    aaf::ao_stats<float> r;
    r.samples = r.counted = 16;
    r.visible_sum = 16 * v;
    r.bent_sum = b * (16 * v);
    if (z < inf) r.hits = 1, r.z_min = z, r.z_max = z;
    return r;
}

/// RMSE over columns [0, columns).
double rmse(const aaf::image<float>& a, const aaf::image<float>& b, std::size_t columns) {
    double e = 0;
    for (std::size_t y = 0; y < a.height(); ++y)
        for (std::size_t x = 0; x < columns; ++x) {
            const double d = static_cast<double>(a(x, y)) - static_cast<double>(b(x, y));
            e += d * d;
        }
    return std::sqrt(e / static_cast<double>(columns * a.height()));
}

}  // namespace

TEST_CASE("AO filter width and sample count: formulas and limits", "[occlusion]") {
    const aaf::ao_filter_settings<float> s;  // Ω_h 2.8, μ 2
    CHECK(aaf::ao_filter_width(1.0f, s) == Approx(1.0 / (2 * 2 * 2.8)));
    CHECK(aaf::ao_filter_width(0.5f, s) == Approx(0.5f * aaf::ao_filter_width(1.0f, s)));
    CHECK(aaf::ao_filter_width(inf, s) == 0.0f);   // no hit: not filtered
    CHECK(aaf::ao_filter_width(0.0f, s) == 0.0f);  // contact: nothing to filter over
    CHECK(aaf::ao_filter_width(qnan, s) == 0.0f);
    CHECK(aaf::ao_filter_bandwidth(0.0f, s) == inf);
    CHECK(aaf::ao_filter_bandwidth(inf, s) == 0.0f);
    // n = c (μΩd/z + α)² (1 + μ z_max/z_min)² Ω²
    const float n = aaf::ao_sample_count(1.0f, 3.0f, 0.01f, s);
    const double expect = 0.25 * std::pow(2 * 2.8 * 0.01 + 1, 2) * std::pow(1 + 2 * 3.0, 2) * 2.8 * 2.8;
    CHECK(n == Approx(expect).epsilon(1e-5));
    CHECK(aaf::ao_sample_count(inf, 0.0f, 0.01f, s) == 0.0f);
    CHECK(aaf::ao_sample_count(0.0f, 1.0f, 0.01f, s) == inf);
    CHECK(aaf::target_samples(aaf::ao_sample_count(0.0f, 1.0f, 0.01f, s), 16u, 256u) == 256u);
    CHECK(aaf::ao_sample_count(qnan, 1.0f, 0.01f, s) == 0.0f);
    CHECK(aaf::ao_sample_count(1.0f, 1.0f, qnan, s) == 0.0f);
    // min_distance clamps z_min: contact behaves like z = min_distance.
    aaf::ao_filter_settings<float> clamped = s;
    clamped.min_distance = 0.1f;
    CHECK(aaf::ao_filter_width(0.0f, clamped) == aaf::ao_filter_width(0.1f, clamped));
    CHECK(std::isfinite(aaf::ao_sample_count(0.0f, 1.0f, 0.01f, clamped)));
}

TEST_CASE("the AO filter leaves contact, no-hit and NaN pixels defined and never spreads NaN", "[occlusion]") {
    floor_frame f(16, 4, 0.05f);
    aaf::image<aaf::ao_stats<float>> st(16, 4);
    for (std::size_t y = 0; y < 4; ++y)
        for (std::size_t x = 0; x < 16; ++x) st(x, y) = record(x % 2 ? 0.2f : 0.6f, 1.0f);
    st(3, 1) = record(0.9f, 0.0f);           // contact: β = 0, kept
    st(5, 1) = record(1.0f, inf);            // no hit: β = 0, kept
    st(8, 2) = aaf::ao_stats<float>{};       // no estimate: NaN, kept NaN
    f.positions(10, 2) = glm::vec3(qnan);     // no surface (and no record)
    st(10, 2) = aaf::ao_stats<float>{};
    aaf::image<float> out(16, 4);
    aaf::image<glm::vec3> bent(16, 4);
    aaf::filter_ambient_occlusion(f.gb(), st.cview(), aaf::ao_filter_settings<float>{}, aaf::ao_outputs<float>{out.view(), bent.view(), {}, {}});
    CHECK(out(3, 1) == 0.9f);
    CHECK(out(5, 1) == 1.0f);
    CHECK(std::isnan(out(8, 2)));
    CHECK(std::isnan(out(10, 2)));
    for (std::size_t y = 0; y < 4; ++y)
        for (std::size_t x = 0; x < 16; ++x) {
            if ((x == 8 || x == 10) && y == 2) continue;
            CAPTURE(x, y);
            CHECK(std::isfinite(out(x, y)));
            CHECK(glm::length(bent(x, y)) == Approx(1).epsilon(1e-5));
        }
    // The alternating 0.2 / 0.6 pattern is smoothed towards 0.4 where β is wide (z_min = 1: β = 0.089 = 1.8 px).
    CHECK(std::abs(out(12, 0) - 0.4f) < 0.1f);
}

TEST_CASE("the AO filter never crosses IDs or creases beyond its normal threshold", "[occlusion]") {
    floor_frame f(16, 4, 0.05f);
    aaf::image<aaf::ao_stats<float>> st(16, 4);
    for (std::size_t y = 0; y < 4; ++y)
        for (std::size_t x = 0; x < 16; ++x) st(x, y) = record(x < 8 ? 0.2f : 0.8f, 5.0f);  // β = 0.45 = 9 px
    aaf::image<float> out(16, 4);
    const aaf::ao_outputs<float> o{out.view(), {}, {}, {}};
    SECTION("IDs") {
        for (std::size_t y = 0; y < 4; ++y)
            for (std::size_t x = 8; x < 16; ++x) f.ids(x, y) = 7;
        aaf::filter_ambient_occlusion(f.gb(), st.cview(), aaf::ao_filter_settings<float>{}, o);
        for (std::size_t y = 0; y < 4; ++y)
            for (std::size_t x = 0; x < 16; ++x) CHECK(out(x, y) == Approx(x < 8 ? 0.2f : 0.8f).epsilon(1e-6));
    }
    for (float degrees : {4.0f, 10.0f}) {
        SECTION("a crease of " + std::to_string(degrees) + " degrees against the 5 degree threshold") {
            const float r = degrees * 3.14159265f / 180.0f;
            for (std::size_t y = 0; y < 4; ++y)
                for (std::size_t x = 8; x < 16; ++x) f.normals(x, y) = {std::sin(r), std::cos(r), 0};
            for (auto space : {aaf::offset_space::image, aaf::offset_space::tangent_plane}) {
                aaf::ao_filter_settings<float> s;
                s.space = space;
                aaf::filter_ambient_occlusion(f.gb(), st.cview(), s, o);
                if (degrees > 5.0f) {
                    for (std::size_t y = 0; y < 4; ++y)
                        for (std::size_t x = 0; x < 16; ++x) CHECK(out(x, y) == Approx(x < 8 ? 0.2f : 0.8f).epsilon(1e-6));
                } else {  // within the threshold the two sides mix (so the test above could fail)
                    CHECK(out(7, 1) > 0.3f);
                    CHECK(out(8, 1) < 0.7f);
                }
            }
        }
    }
}

TEST_CASE("tangent-plane distances ignore the offset along the normal; image distances do not see tilt", "[occlusion]") {
    // A tilted receiver whose pixels step 0.05 in x and 0.05 in y (height): tangent-plane distance is measured
    // in the surface, so a narrow β (in world units) weights neighbours by their true in-surface distance.
    floor_frame f(16, 1, 0.05f);
    const glm::vec3 n = glm::normalize(glm::vec3(-1, 1, 0));
    for (std::size_t x = 0; x < 16; ++x) {
        f.positions(x, 0).y = 0.05f * static_cast<float>(x);
        f.normals(x, 0) = n;
    }
    aaf::image<aaf::ao_stats<float>> st(16, 1);
    for (std::size_t x = 0; x < 16; ++x) st(x, 0) = record(x == 8 ? 1.0f : 0.0f, 0.56f);  // β = 0.05
    aaf::image<float> out(16, 1);
    aaf::ao_filter_settings<float> s;
    s.space = aaf::offset_space::tangent_plane;
    aaf::filter_ambient_occlusion(f.gb(), st.cview(), s, aaf::ao_outputs<float>{out.view(), {}, {}, {}});
    // Neighbour at in-surface distance 0.05·√2 with β = 0.05: weight exp(−(√2)²/2) = e^-1 relative to the centre.
    const double w1 = std::exp(-1.0);
    CHECK(out(7, 0) == Approx(w1 / (1 + 2 * w1 + 2 * std::exp(-4.0) + 2 * std::exp(-9.0))).epsilon(0.02));
}

TEST_CASE("filtered AO converges to the reference as mu grows, and equals Monte Carlo as mu goes to infinity", "[occlusion]") {
    // A floor in front of an infinite wall x = 0, R = 0.6. A direction hits the wall within R iff its disc
    // coordinate d.x < −a/R (a = distance to the wall), and the disc coordinates of cosine-distributed
    // directions are uniform on the unit disc: A(a) = 1 − (acos c − c√(1 − c²))/π with c = min(a/R, 1).
    const ao_scene wall{{ao_half_plane{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}}, {}};
    floor_frame f(48, 6, 0.02f, 0.005f);
    aaf::ao_frame_settings<float> s;
    s.sampling.max_distance = 0.6f;
    s.sampling.max_samples = 1u << 14;  // consistency needs n(μ) uncapped (the default cap, 256, stops it)
    aaf::image<float> ref(48, 6);
    for (std::size_t y = 0; y < 6; ++y)
        for (std::size_t x = 0; x < 48; ++x) {
            const double c = std::min(static_cast<double>(f.positions(x, y).x) / 0.6, 1.0);
            ref(x, y) = static_cast<float>(1 - (std::acos(c) - c * std::sqrt(1 - c * c)) / 3.141592653589793);
        }
    // Measured over the whole strip, and over the 15 columns within 0.3 of the wall where every pixel's 16
    // initial samples see it. Farther out some pixels' samples all miss (true A ≈ 0.95–1): with z spreading
    // (the default) they take their neighbours' z and converge too; without it they keep 1 whatever μ.
    for (std::uint32_t spread : {10u, 0u}) {
        s.filter.spread_radius = spread;
        std::vector<double> all, near;
        for (float mu : {1.0f, 2.0f, 4.0f, 8.0f}) {
            s.filter.mu = mu;
            aaf::image<float> out(48, 6);
            aaf::render_ambient_occlusion(f.gb(), ao_tracer{&wall}, s, aaf::ao_outputs<float>{out.view(), {}, {}, {}});
            all.push_back(rmse(out, ref, 48));
            near.push_back(rmse(out, ref, 15));
        }
        CAPTURE(spread, all[0], all[1], all[2], all[3], near[0], near[1], near[2], near[3]);
        CHECK(near[1] < near[0]);
        CHECK(near[2] < near[1]);
        CHECK(near[3] < near[2]);
        CHECK(near[3] < 0.002);
        if (spread > 0) {
            CHECK(all[1] < all[0]);
            CHECK(all[2] < all[1]);
            CHECK(all[3] < all[2]);
            CHECK(all[3] < 0.002);
        } else {
            CHECK(all[3] > 0.01);  // the no-hit pixels' floor (DEVIATIONS.md, occlusion row 8)
        }
    }
    s.filter.spread_radius = 10;
    // μ huge: β ≈ 0, the filter is the identity, the result is the Monte Carlo estimate with the same samples.
    s.filter.mu = 1e6f;
    s.adaptive = false;
    aaf::image<float> filtered(48, 6), mc(48, 6);
    aaf::render_ambient_occlusion(f.gb(), ao_tracer{&wall}, s, aaf::ao_outputs<float>{filtered.view(), {}, {}, {}});
    s.filtered = false;
    aaf::render_ambient_occlusion(f.gb(), ao_tracer{&wall}, s, aaf::ao_outputs<float>{mc.view(), {}, {}, {}});
    for (std::size_t y = 0; y < 6; ++y)
        for (std::size_t x = 0; x < 48; ++x) CHECK(filtered(x, y) == mc(x, y));
}

TEST_CASE("the AO frame driver: adaptive counts, heat maps, bent normals filtered and unit", "[occlusion]") {
    const ao_scene wall{{ao_half_plane{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}}, {}};
    floor_frame f(24, 4, 0.02f, 0.005f);
    aaf::ao_frame_settings<float> s;
    s.sampling.max_distance = 2.0f;
    aaf::image<float> vis(24, 4), beta(24, 4);
    aaf::image<glm::vec3> bent(24, 4);
    aaf::image<std::uint32_t> spp(24, 4);
    const auto rays = aaf::render_ambient_occlusion(f.gb(), ao_tracer{&wall}, s,
                                                    aaf::ao_outputs<float>{vis.view(), bent.view(), beta.view(), spp.view()});
    std::uint64_t total = 0;
    for (std::size_t y = 0; y < 4; ++y)
        for (std::size_t x = 0; x < 24; ++x) {
            total += spp(x, y);
            CHECK(spp(x, y) >= 16u);
            CHECK(spp(x, y) <= 256u);
            CHECK(beta(x, y) >= 0.0f);
            CHECK(glm::length(bent(x, y)) == Approx(1).epsilon(1e-5));
            CHECK(bent(x, y).x > 0.0f);  // leaning away from the wall
            CHECK(vis(x, y) > 0.45f);    // half the hemisphere is free, and more away from the wall
        }
    CHECK(total == rays);
    // Pixels near the wall (small z_min) get more samples than pixels far from it.
    CHECK(spp(0, 0) > spp(23, 0));
}

// fuzz_occlusion's finding (fuzz/fuzz_occlusion.cpp, "β finite and ≥ 0"): a valid but denormal Ω_h (the fuzz
// input's bit pattern 0x0000baba, 6.7e-41) under an occluder at 0.5 made Ω* = Ω_h/z_min ≈ 1.3e-40 and
// β = 1/(2μΩ*) overflow to +∞ in the filter-width heat map; with a larger z_min, Ω* underflowed to 0 and the
// pixel read as "no hit" (β = 0), the wrong limit. β → ∞ as Ω_h → 0: it is clamped to the largest float.
TEST_CASE("AO filter width stays finite when the bandlimit is tiny or the occluder far (fuzz finding)", "[occlusion]") {
    aaf::ao_filter_settings<float> s;
    s.omega_h = std::bit_cast<float>(0x0000babau);
    REQUIRE(s.omega_h > 0.0f);
    REQUIRE(s.omega_h < std::numeric_limits<float>::min());  // denormal
    REQUIRE_NOTHROW(aaf::validate(s));
    constexpr float big = std::numeric_limits<float>::max();
    CHECK(aaf::ao_filter_width(0.5f, s) == big);
    CHECK(aaf::ao_filter_width(0.0f, s) == 0.0f);  // contact and no hit keep their meaning
    CHECK(aaf::ao_filter_width(inf, s) == 0.0f);
    aaf::ao_filter_settings<float> far;
    far.omega_h = 1e-30f;
    CHECK(aaf::ao_filter_width(1e30f, far) == big);  // Ω* = 1e-60 underflows; β must not read as "no hit"
    CHECK(aaf::ao_filter_width(1.0f, far) == Approx(1.0 / (2 * 2 * 1e-30)).epsilon(1e-5));
    aaf::ao_filter_settings<float> huge;  // 2μΩ_h overflows: β below any pixel, not NaN
    huge.mu = 1e30f;
    huge.omega_h = 1e30f;
    CHECK(aaf::ao_filter_width(1.0f, huge) == 0.0f);

    // The fuzz input's situation through the frame driver: a floor under a ceiling at 0.5, max distance 1.
    const ao_scene ceiling{{ao_half_plane{{0, 0.5f, 0}, {0, -1, 0}, {}}}, {}};
    floor_frame f(6, 3, 0.1f);
    aaf::ao_frame_settings<float> fs;
    fs.sampling.max_distance = 1.0f;
    fs.filter.omega_h = s.omega_h;
    aaf::image<float> vis(6, 3), raw(6, 3), beta(6, 3);
    aaf::image<glm::vec3> bent(6, 3);
    aaf::image<std::uint32_t> spp(6, 3);
    aaf::render_ambient_occlusion(f.gb(), ao_tracer{&ceiling}, fs, aaf::ao_outputs<float>{vis.view(), bent.view(), beta.view(), spp.view()});
    fs.filtered = false;
    aaf::render_ambient_occlusion(f.gb(), ao_tracer{&ceiling}, fs, aaf::ao_outputs<float>{raw.view(), {}, {}, {}});
    float lo = 1, hi = 0;
    for (std::size_t y = 0; y < 3; ++y)
        for (std::size_t x = 0; x < 6; ++x) lo = std::min(lo, raw(x, y)), hi = std::max(hi, raw(x, y));
    for (std::size_t y = 0; y < 3; ++y)
        for (std::size_t x = 0; x < 6; ++x) {
            CAPTURE(x, y);
            CHECK(beta(x, y) == big);  // every pixel sees the ceiling at 0.5
            CHECK(std::isfinite(vis(x, y)));
            CHECK(vis(x, y) >= lo - 1e-6f);  // a normalised average of the sampled values (the widest kernel)
            CHECK(vis(x, y) <= hi + 1e-6f);
            CHECK(glm::length(bent(x, y)) == Approx(1).epsilon(1e-5));
        }
}

namespace {

/// The direct kernel's definition for one pixel, in double, on a floor_frame without IDs differences:
/// Σ w v / Σ w over the window, w = exp(−r²(1 + cθ)²/(2β²)), cut at e > truncation²/2, tangent-plane r.
double direct_reference(const floor_frame& f, const aaf::image<aaf::ao_stats<float>>& st, std::size_t x, std::size_t y,
                        const aaf::ao_filter_settings<float>& s) {
    const double beta = aaf::ao_filter_width(st(x, y).z_min, s), d = f.pixel_size(x, y);
    const auto r = static_cast<long>(std::min<double>(std::ceil(static_cast<double>(s.truncation) * beta / d), s.max_radius));
    const glm::dvec3 p(f.positions(x, y)), n = glm::normalize(glm::dvec3(f.normals(x, y)));
    const double cos_threshold = std::cos(static_cast<double>(s.normal_threshold_degrees) * 3.14159265358979 / 180);
    double sum = 0, wsum = 0;
    for (long dy = -r; dy <= r; ++dy)
        for (long dx = -r; dx <= r; ++dx) {
            const long nx = static_cast<long>(x) + dx, ny = static_cast<long>(y) + dy;
            if (nx < 0 || ny < 0 || nx >= static_cast<long>(st.width()) || ny >= static_cast<long>(st.height())) continue;
            const auto ux = static_cast<std::size_t>(nx), uy = static_cast<std::size_t>(ny);
            const glm::dvec3 q(f.positions(ux, uy)), m = glm::normalize(glm::dvec3(f.normals(ux, uy)));
            if (glm::dot(n, m) < cos_threshold) continue;
            const glm::dvec3 dp = q - p;
            if (s.reject_beyond_z_min && glm::length(dp) >= static_cast<double>(st(x, y).z_min)) continue;
            const double along = glm::dot(dp, n), r2 = glm::dot(dp, dp) - along * along;
            const double factor = 1 + static_cast<double>(s.normal_angle_term) * std::acos(std::clamp(glm::dot(n, m), -1.0, 1.0));
            const double e = r2 * factor * factor / (2 * beta * beta);
            if (e > static_cast<double>(s.truncation * s.truncation) / 2) continue;
            sum += std::exp(-e) * static_cast<double>(st(ux, uy).visibility());
            wsum += std::exp(-e);
        }
    return sum / wsum;
}

}  // namespace

TEST_CASE("the direct AO kernel: its definition, the authors' 50-theta term and z_min rejection", "[occlusion]") {
    // A gently curved strip: the normal turns 0.4 degrees per column (within the 5 degree threshold over
    // 12 columns), AO alternating by column, β = 0.6/(2·2·2.8) = 0.054 = 1.07 px.
    floor_frame f(24, 5, 0.05f);
    aaf::image<aaf::ao_stats<float>> st(24, 5);
    for (std::size_t y = 0; y < 5; ++y)
        for (std::size_t x = 0; x < 24; ++x) {
            const float a = 0.4f * static_cast<float>(x) * 3.14159265f / 180.0f;
            f.normals(x, y) = {std::sin(a), std::cos(a), 0};
            st(x, y) = record(x % 2 ? 0.2f : 0.6f, 0.6f);
        }
    aaf::image<float> plain(24, 5), theta(24, 5);
    aaf::ao_filter_settings<float> s;
    s.kernel = aaf::ao_filter_kernel::direct;
    s.space = aaf::offset_space::tangent_plane;
    aaf::filter_ambient_occlusion(f.gb(), st.cview(), s, aaf::ao_outputs<float>{plain.view(), {}, {}, {}});
    aaf::ao_filter_settings<float> authors = s;
    authors.normal_angle_term = 50;
    aaf::filter_ambient_occlusion(f.gb(), st.cview(), authors, aaf::ao_outputs<float>{theta.view(), {}, {}, {}});
    for (std::size_t y = 0; y < 5; ++y)
        for (std::size_t x = 0; x < 24; ++x) {
            CAPTURE(x, y);
            CHECK(plain(x, y) == Approx(direct_reference(f, st, x, y, s)).epsilon(1e-4));
            CHECK(theta(x, y) == Approx(direct_reference(f, st, x, y, authors)).epsilon(1e-4));
        }
    // Narrower across curvature: the 50θ filter keeps more of each pixel's own value (0.2 or 0.6) than the
    // plain one, which smooths towards 0.4.
    double own_plain = 0, own_theta = 0;
    for (std::size_t y = 0; y < 5; ++y)
        for (std::size_t x = 0; x < 24; ++x) {
            own_plain += static_cast<double>(std::abs(plain(x, y) - 0.4f));
            own_theta += static_cast<double>(std::abs(theta(x, y) - 0.4f));
        }
    CHECK(own_theta > 2 * own_plain);

    SECTION("a step along the normal passes the tangent-plane distance; z_min rejection stops it") {
        floor_frame g(16, 3, 0.05f);
        aaf::image<aaf::ao_stats<float>> st2(16, 3);
        for (std::size_t y = 0; y < 3; ++y)
            for (std::size_t x = 0; x < 16; ++x) {
                if (x >= 8) g.positions(x, y).y = 1.0f;                 // a ledge 1 unit up, same normal and ID
                st2(x, y) = record(x < 8 ? 0.2f : 0.8f, 0.9f);  // z_min 0.9 < the step: β = 0.08 = 1.6 px
            }
        aaf::image<float> out(16, 3);
        aaf::ao_filter_settings<float> r = s;
        aaf::filter_ambient_occlusion(g.gb(), st2.cview(), r, aaf::ao_outputs<float>{out.view(), {}, {}, {}});
        CHECK(out(7, 1) > 0.25f);  // the ledge's 0.8 leaks across the step
        r.reject_beyond_z_min = true;
        aaf::filter_ambient_occlusion(g.gb(), st2.cview(), r, aaf::ao_outputs<float>{out.view(), {}, {}, {}});
        for (std::size_t y = 0; y < 3; ++y)
            for (std::size_t x = 0; x < 16; ++x) CHECK(out(x, y) == Approx(x < 8 ? 0.2f : 0.8f).epsilon(1e-6));
    }
    SECTION("bent normals through the direct kernel stay unit") {
        aaf::image<glm::vec3> bent(24, 5);
        aaf::filter_ambient_occlusion(f.gb(), st.cview(), authors, aaf::ao_outputs<float>{theta.view(), bent.view(), {}, {}});
        for (std::size_t y = 0; y < 5; ++y)
            for (std::size_t x = 0; x < 24; ++x) CHECK(glm::length(bent(x, y)) == Approx(1).epsilon(1e-5));
    }
    SECTION("the separable kernel refuses the terms it cannot apply") {
        aaf::ao_filter_settings<float> bad = authors;
        bad.kernel = aaf::ao_filter_kernel::separable;
        CHECK_THROWS_WITH(aaf::filter_ambient_occlusion(f.gb(), st.cview(), bad, aaf::ao_outputs<float>{theta.view(), {}, {}, {}}),
                          Catch::Contains("settings.kernel"));
        bad = s;
        bad.normal_angle_term = qnan;
        CHECK_THROWS_WITH(aaf::validate(bad), Catch::Contains("settings.normal_angle_term"));
        bad.normal_angle_term = -1;
        CHECK_THROWS_WITH(aaf::validate(bad), Catch::Contains("settings.normal_angle_term"));
    }
}

// The authors' pre-filter rejection boost (FORMULAS.md §8.3, DEVIATIONS.md occlusion row 7): n / (1 − f), f the
// fraction of the filter window the guides reject. Pixels whose window holds another object get more samples;
// pixels whose window is all their own keep exactly the formula's n.
TEST_CASE("the rejection boost adds samples only where the filter window is rejected", "[occlusion]") {
    const ao_scene wall{{ao_half_plane{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}}, {}};
    floor_frame f(24, 4, 0.02f, 0.005f);
    for (std::size_t y = 0; y < 4; ++y)
        for (std::size_t x = 12; x < 24; ++x) f.ids(x, y) = 7;
    aaf::ao_frame_settings<float> s;
    s.sampling.max_distance = 2.0f;
    aaf::image<float> vis(24, 4), beta(24, 4);
    aaf::image<std::uint32_t> plain(24, 4), boosted(24, 4);
    const auto rays_plain =
        aaf::render_ambient_occlusion(f.gb(), ao_tracer{&wall}, s, aaf::ao_outputs<float>{vis.view(), {}, beta.view(), plain.view()});
    s.filter.rejection_boost = true;
    const auto rays_boosted =
        aaf::render_ambient_occlusion(f.gb(), ao_tracer{&wall}, s, aaf::ao_outputs<float>{vis.view(), {}, {}, boosted.view()});
    CHECK(rays_boosted > rays_plain);
    const aaf::filter_settings<float> fs = aaf::detail::ao_core_filter_settings(s.filter);
    int checked_boosts = 0;
    for (std::size_t y = 0; y < 4; ++y)
        for (std::size_t x = 0; x < 24; ++x) {
            CHECK(boosted(x, y) >= plain(x, y));
            const std::size_t r = aaf::detail::kernel_radius(beta(x, y) / 0.02f, fs);
            const bool window_crosses = x < 12 ? x + r >= 12 : x < 12 + r;
            if (!window_crosses) {
                CHECK(boosted(x, y) == plain(x, y));
            } else if (plain(x, y) < s.sampling.max_samples) {
                CHECK(boosted(x, y) > plain(x, y));
                ++checked_boosts;
            }
        }
    CHECK(checked_boosts >= 4);  // the boosted branch was taken (pixels below the cap whose window crosses)
}
