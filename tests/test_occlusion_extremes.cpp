// SPDX-License-Identifier: MIT
// Bad input to the AO entry points: named aaf::invalid_argument before any output is written, or a
// documented defined result (docs/EXTREMES.md, ambient-occlusion section).

#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <vector>

#include <aaf/occlusion.hpp>

#include "support/ao_scene.hpp"
#include "support/helpers.hpp"

using aaf_test::what_of;

namespace {
constexpr float inf = std::numeric_limits<float>::infinity();
constexpr float qnan = std::numeric_limits<float>::quiet_NaN();

struct frame {
    aaf::image<glm::vec3> p{6, 5, glm::vec3(0)}, n{6, 5, glm::vec3(0, 1, 0)};
    aaf::image<float> d{6, 5, 0.01f};
    [[nodiscard]] aaf::gbuffer<float> gb() const { return {p.cview(), n.cview(), d.cview()}; }
};
}  // namespace

TEST_CASE("AO settings out of range are named errors", "[occlusion]") {
    const frame f;
    const aaf_test::empty_tracer t;
    aaf::image<aaf::ao_stats<float>> st(6, 5);
    const auto gather = [&](aaf::ao_sampling_settings<float> s) {
        return what_of([&] { aaf::gather_ambient_occlusion(f.gb(), t, s, 0, 4, st.view()); });
    };
    for (float bad : {0.0f, -1.0f, qnan, -inf}) {
        aaf::ao_sampling_settings<float> s;
        s.max_distance = bad;
        CHECK_THAT(gather(s), Catch::Contains("gather_ambient_occlusion") && Catch::Contains("settings.max_distance"));
    }
    aaf::ao_sampling_settings<float> s;
    s.max_distance = inf;  // allowed: the whole scene
    CHECK(gather(s) == "<no aaf::invalid_argument thrown>");
    s.initial_samples = 0;
    CHECK_THAT(gather(s), Catch::Contains("settings.initial_samples"));
    s = {};
    s.origin_offset = std::nan("");
    CHECK_THAT(gather(s), Catch::Contains("settings.origin_offset"));
    s = {};
    CHECK_THAT(what_of([&] { aaf::gather_ambient_occlusion(f.gb(), t, s, 0, 0, st.view()); }), Catch::Contains("samples_per_pixel"));
    CHECK_THAT(what_of([&] { aaf::gather_ambient_occlusion(f.gb(), t, s, 0, 257, st.view()); }), Catch::Contains("samples_per_pixel"));

    aaf::ao_filter_settings<float> fs;
    fs.mu = 0.5f;
    aaf::image<float> out(6, 5);
    CHECK_THAT(what_of([&] { aaf::filter_ambient_occlusion(f.gb(), st.cview(), fs, aaf::ao_outputs<float>{out.view(), {}, {}, {}}); }),
               Catch::Contains("filter_ambient_occlusion") && Catch::Contains("settings.mu"));
    fs = {};
    fs.omega_h = 0;
    CHECK_THAT(what_of([&] { aaf::filter_ambient_occlusion(f.gb(), st.cview(), fs, aaf::ao_outputs<float>{out.view(), {}, {}, {}}); }),
               Catch::Contains("settings.omega_h"));
    fs = {};
    fs.spread_radius = 1025;
    CHECK_THAT(what_of([&] { aaf::filter_ambient_occlusion(f.gb(), st.cview(), fs, aaf::ao_outputs<float>{out.view(), {}, {}, {}}); }),
               Catch::Contains("settings.spread_radius"));
    CHECK_THAT(what_of([&] { aaf::spread_hit_distances(f.gb(), st.view(), 2000); }), Catch::Contains("`radius`"));
    fs = {};
    fs.space = aaf::offset_space::light_plane;  // no light in AO
    CHECK_THAT(what_of([&] { aaf::filter_ambient_occlusion(f.gb(), st.cview(), fs, aaf::ao_outputs<float>{out.view(), {}, {}, {}}); }),
               Catch::Contains("settings.space"));
}

TEST_CASE("mismatched AO buffers are named errors and leave the outputs untouched", "[occlusion]") {
    frame f;
    const aaf_test::empty_tracer t;
    aaf::image<aaf::ao_stats<float>> small(5, 5);
    small(0, 0).samples = 42;
    const aaf::ao_sampling_settings<float> s;
    CHECK_THAT(what_of([&] { aaf::gather_ambient_occlusion(f.gb(), t, s, 0, 4, small.view()); }), Catch::Contains("`stats`"));
    CHECK(small(0, 0).samples == 42u);
    aaf::image<glm::vec3> n_small(6, 4, glm::vec3(0, 1, 0));
    const aaf::gbuffer<float> bad{f.p.cview(), n_small.cview(), f.d.cview()};
    aaf::image<aaf::ao_stats<float>> st(6, 5);
    CHECK_THAT(what_of([&] { aaf::gather_ambient_occlusion(bad, t, s, 0, 4, st.view()); }), Catch::Contains("gbuffer.normals"));
    aaf::image<float> out(6, 5, 7.0f), out_small(6, 4);
    aaf::image<glm::vec3> bent_small(3, 3);
    CHECK_THAT(what_of([&] { aaf::filter_ambient_occlusion(f.gb(), st.cview(), {}, aaf::ao_outputs<float>{out_small.view(), {}, {}, {}}); }),
               Catch::Contains("outputs.visibility"));
    CHECK_THAT(what_of([&] { aaf::render_ambient_occlusion(f.gb(), t, {}, aaf::ao_outputs<float>{out.view(), bent_small.view(), {}, {}}); }),
               Catch::Contains("outputs.bent_normal"));
    CHECK(out(2, 2) == 7.0f);
    // Baking: spans of different lengths, indices past the vertices.
    const std::vector<glm::vec3> pos{{0, 0, 0}, {1, 0, 0}}, nrm{{0, 1, 0}};
    std::vector<aaf::ao_stats<float>> v(2);
    CHECK_THAT(what_of([&] { aaf::bake_vertex_occlusion<float>(pos, nrm, t, s, v); }), Catch::Contains("`normals`"));
    const std::vector<glm::vec<3, std::uint32_t>> tris{{0, 1, 2}};
    std::vector<aaf::ao_stats<float>> tv(1);
    CHECK_THAT(what_of([&] { aaf::bake_triangle_occlusion<float>(pos, tris, t, s, tv); }), Catch::Contains("triangles[0]"));
}

TEST_CASE("NaN/Inf G-buffer entries, zero normals and failing tracers give documented results", "[occlusion]") {
    frame f;
    f.p(1, 1) = glm::vec3(qnan, 0, 0);
    f.p(2, 1) = glm::vec3(inf, 0, 0);
    f.n(3, 1) = glm::vec3(0);            // zero normal: no surface
    f.n(4, 1) = glm::vec3(qnan, 1, 0);   // NaN normal: no surface
    f.n(5, 1) = glm::vec3(0, 5, 0);      // not unit: normalised
    f.d(0, 2) = qnan;                    // NaN pixel size: that pixel is sampled but not filtered nor adaptive
    const aaf_test::ao_scene scene{{aaf_test::ao_half_plane{{0, 1, 0}, {0, 1, 0}}}, {}};
    aaf::ao_frame_settings<float> s;
    s.sampling.max_distance = 2;
    aaf::image<float> vis(6, 5);
    aaf::image<glm::vec3> bent(6, 5);
    aaf::image<std::uint32_t> spp(6, 5);
    aaf::render_ambient_occlusion(f.gb(), aaf_test::ao_tracer{&scene}, s, aaf::ao_outputs<float>{vis.view(), bent.view(), {}, spp.view()});
    for (std::size_t x = 1; x <= 4; ++x) {
        CAPTURE(x);
        CHECK(std::isnan(vis(x, 1)));  // no estimate
        CHECK(spp(x, 1) == 0u);
    }
    CHECK(vis(5, 1) == Approx(0.25).margin(0.12));
    CHECK(std::isfinite(vis(0, 2)));
    for (std::size_t y = 0; y < 5; ++y)
        for (std::size_t x = 0; x < 6; ++x)
            if (y != 1 || x == 0 || x == 5) CHECK(std::isfinite(vis(x, y)));  // NaN never spread
    // A tracer that fails every sample: counted in `samples`, never in the estimate (NaN visibility).
    aaf::image<aaf::ao_stats<float>> st(6, 5);
    const aaf_test::ao_scene failing{{}, {}, true};
    aaf::ao_sampling_settings<float> ss;
    aaf::gather_ambient_occlusion(f.gb(), aaf_test::ao_tracer{&failing}, ss, 0, 4, st.view());
    CHECK(st(0, 0).samples == 4u);
    CHECK(st(0, 0).counted == 0u);
    CHECK(std::isnan(st(0, 0).visibility()));
    CHECK(st(0, 0).bent_normal({0, 1, 0}) == glm::vec3(0, 1, 0));
    // Falloff helpers at their limits.
    CHECK(aaf::falloff_visibility(aaf::ao_falloff::linear, 1.0f, inf) == 0.0f);  // R = ∞: binary
    CHECK(aaf::falloff_visibility(aaf::ao_falloff::quadratic, 3.0f, 2.0f) == 1.0f);
    CHECK(aaf::falloff_visibility(aaf::ao_falloff::none, inf, inf) == 1.0f);
}

TEST_CASE("infinite, negative, zero and denormal pixel sizes and infinite normals give documented AO results", "[occlusion]") {
    frame f;
    f.d(0, 0) = inf;                                        // n = ∞: max_samples; β/d = 0 px: not filtered
    f.d(1, 0) = -inf;                                       // n from d = 0; not filtered (d ≤ 0)
    f.d(2, 0) = -0.01f;
    f.d(3, 0) = 0.0f;
    f.d(4, 0) = std::numeric_limits<float>::denorm_min();  // β/d = +∞ px: the max_radius window
    f.n(5, 0) = glm::vec3(inf, 1, 0);                       // not finite: no surface
    const aaf_test::ao_scene scene{{aaf_test::ao_half_plane{{0, 1, 0}, {0, 1, 0}}}, {}};
    for (auto kernel : {aaf::ao_filter_kernel::separable, aaf::ao_filter_kernel::direct}) {
        CAPTURE(static_cast<int>(kernel));
        aaf::ao_frame_settings<float> s;
        s.sampling.max_distance = 2;
        s.filter.kernel = kernel;
        aaf::image<float> vis(6, 5), beta(6, 5);
        aaf::image<glm::vec3> bent(6, 5);
        aaf::image<std::uint32_t> spp(6, 5);
        aaf::render_ambient_occlusion(f.gb(), aaf_test::ao_tracer{&scene}, s,
                                      aaf::ao_outputs<float>{vis.view(), bent.view(), beta.view(), spp.view()});
        CHECK(spp(0, 0) == s.sampling.max_samples);
        CHECK(std::isnan(vis(5, 0)));
        CHECK(spp(5, 0) == 0u);
        for (std::size_t y = 0; y < 5; ++y)
            for (std::size_t x = 0; x < 6; ++x) {
                if (x == 5 && y == 0) continue;
                CAPTURE(x, y);
                CHECK(std::isfinite(vis(x, y)));
                CHECK(vis(x, y) >= 0.0f);
                CHECK(vis(x, y) <= 1.0f);
                CHECK(std::isfinite(beta(x, y)));
                CHECK(beta(x, y) >= 0.0f);
                CHECK(spp(x, y) >= s.sampling.initial_samples);
                CHECK(spp(x, y) <= s.sampling.max_samples);
                CHECK(glm::length(bent(x, y)) == Approx(1).epsilon(1e-5));
            }
        // Under a parallel plane at height 1 with R = 2 the exact value is h²/R² = 0.25 everywhere.
        for (std::size_t x = 0; x < 5; ++x) CHECK(vis(x, 0) == Approx(0.25).margin(0.12));
    }
}

// fuzz_occlusion's second finding: a normal of components 3.2e-23 (float) passes the "|n| > 0" rule, but its
// squares are denormal, |n| came out 20 % long and n/|n| had length 0.85; a fully occluded pixel's bent
// normal is its normal, so the unit-length invariant broke. Unit normals come from the scaled vector now.
TEST_CASE("tiny and large G-buffer normals are normalised to unit length (fuzz finding)", "[occlusion]") {
    for (float c : {3.18675e-23f, 1e-30f, 1e-19f, 1e18f, 1e30f}) {  // 1e-30, 1e30: |n| under- or overflows
        CAPTURE(c);
        frame f;
        for (std::size_t y = 0; y < 5; ++y)
            for (std::size_t x = 0; x < 6; ++x) {
                f.p(x, y) = glm::vec3(0.1f * static_cast<float>(x), 0.5f, 0.1f * static_cast<float>(y));
                f.n(x, y) = glm::vec3(c);
            }
        const aaf_test::ao_scene inside{{}, {aaf_test::ao_box{glm::vec3(-1), glm::vec3(2)}}};  // every ray hits
        for (bool filtered : {false, true}) {
            aaf::ao_frame_settings<float> s;
            s.filtered = filtered;
            aaf::image<float> vis(6, 5);
            aaf::image<glm::vec3> bent(6, 5);
            aaf::render_ambient_occlusion(f.gb(), aaf_test::ao_tracer{&inside}, s, aaf::ao_outputs<float>{vis.view(), bent.view(), {}, {}});
            for (std::size_t y = 0; y < 5; ++y)
                for (std::size_t x = 0; x < 6; ++x) {
                    CAPTURE(filtered, x, y);
                    CHECK(vis(x, y) == 0.0f);
                    CHECK(glm::length(bent(x, y)) == Approx(1).epsilon(1e-5));
                    CHECK(bent(x, y).x == Approx(1 / std::sqrt(3.0f)).epsilon(1e-5));
                }
        }
    }
}

// fuzz_occlusion's third finding, the same underflow in the bent-normal sum: a quadratic falloff with R = 2.7e11
// under an occluder at 0.5 weighs every direction by (t/R)² ≈ 3e-24, and Σ w·ω normalised by its own length
// gave bent normals of length 0.96–1.03.
TEST_CASE("bent normals of tiny falloff weights are unit (fuzz finding)", "[occlusion]") {
    aaf::ao_stats<float> r;
    r.bent_sum = glm::vec3(1e-23f, 2e-23f, -1e-23f);
    CHECK(glm::length(r.bent_normal({0, 1, 0})) == Approx(1).epsilon(1e-6));
    CHECK(r.bent_normal({0, 1, 0}).y == Approx(2 / std::sqrt(6.0f)).epsilon(1e-6));
    frame f;
    const aaf_test::ao_scene ceiling{{aaf_test::ao_half_plane{{0, 0.5f, 0}, {0, -1, 0}, {}}}, {}};
    for (bool filtered : {false, true}) {
        aaf::ao_frame_settings<float> s;
        s.sampling.max_distance = 2.74878e11f;
        s.sampling.falloff = aaf::ao_falloff::quadratic;
        s.filtered = filtered;
        aaf::image<float> vis(6, 5);
        aaf::image<glm::vec3> bent(6, 5);
        aaf::render_ambient_occlusion(f.gb(), aaf_test::ao_tracer{&ceiling}, s, aaf::ao_outputs<float>{vis.view(), bent.view(), {}, {}});
        for (std::size_t y = 0; y < 5; ++y)
            for (std::size_t x = 0; x < 6; ++x) {
                CAPTURE(filtered, x, y);
                CHECK(vis(x, y) < 1e-20f);
                CHECK(vis(x, y) > 0.0f);
                CHECK(glm::length(bent(x, y)) == Approx(1).epsilon(1e-5));
            }
    }
}
