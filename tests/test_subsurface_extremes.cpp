// SPDX-License-Identifier: MIT
// The subsurface gather at scene scales 1e-3 … 1e3 and in mm and m (derived epsilons), its determinism across
// threads and tiles, and bad input (docs/EXTREMES.md, section "subsurface").

#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <vector>

#include <aaf/executor.hpp>
#include <aaf/subsurface.hpp>

#include "support/box_scene.hpp"
#include "support/helpers.hpp"

namespace ss = aaf::subsurface;
using ortho = ss::orthographic_projection<float>;

namespace {

/// A slab with an edge at x = 0, in millimetres × `scale`, lit at 30° from the side, and points near the edge
/// and far from it on both faces.
struct scaled_scene {
    aaf_test::box_scene scene;
    ss::light_map<ortho> map;
    std::vector<glm::vec3> points, normals;
    explicit scaled_scene(float scale) {
        scene.boxes.push_back({glm::vec3(-150, -100, -150) * scale, glm::vec3(0, 0, 150) * scale});
        const glm::vec3 dir = glm::normalize(glm::vec3(-0.5f, -1, 0));
        const ortho proj = ortho::looking_along(dir, glm::vec3(-75, -50, 0) * scale, 200.f * scale, 128);
        map = ss::build_light_map(proj, ss::map_light<float>{glm::vec3(1)}, 1.3f, scene, [&](const glm::vec3& p) { return scene.normal_at(p); });
        for (const float e : {0.05f, 0.5f, 5.0f}) {
            points.push_back(glm::vec3(-e, 0, 1.3f) * scale), normals.push_back({0, 1, 0});
            points.push_back(glm::vec3(0, -e, 1.3f) * scale), normals.push_back({1, 0, 0});
        }
    }
    std::vector<glm::vec3> gather(const ss::material<float>& m, const ss::gather_settings<float>& s) const {
        std::vector<glm::vec3> out(points.size());
        ss::gather_subsurface(ss::visible_points<float>{{points.data(), points.size(), 1}, {normals.data(), normals.size(), 1}}, map.view(), m, s,
                              aaf::image_view<glm::vec3>(out.data(), out.size(), 1));
        return out;
    }
};

}  // namespace

TEST_CASE("derived epsilons scale with the scene: 1e-3 … 1e3, and mm against m", "[subsurface]") {
    const ss::material<float> marble_mm = ss::presets::marble();
    const scaled_scene unit(1);
    for (const auto mode : {ss::disc_sampling::centre_first, ss::disc_sampling::profile}) {
        ss::gather_settings<float> s;
        s.sampling = mode;
        const std::vector<glm::vec3> base = unit.gather(marble_mm, s);
        for (const float scale : {1e-3f, 1e-2f, 1e-1f, 1e1f, 1e2f, 1e3f}) {
            // Coordinates are mm × scale, so one scene unit is 1/scale mm.
            const scaled_scene scaled(scale);
            const ss::material<float> m = marble_mm.in_units(1 / scale);
            const std::vector<glm::vec3> got = scaled.gather(m, s);
            const ss::rgb_dipole d1(marble_mm), ds(m);
            for (std::size_t i = 0; i < got.size(); ++i) {
                INFO("scale " << scale << " mode " << int(mode) << " point " << i);
                // Radiance is scale-invariant (R_d ∝ 1/length², areas ∝ length²): equal to float rounding.
                for (int c = 0; c < 3; ++c) CHECK(got[i][c] == Approx(base[i][c]).epsilon(2e-3).margin(1e-7));
                const auto e1 = ss::epsilons_at(unit.map.view(), s, d1, unit.points[i], unit.normals[i]);
                const auto es = ss::epsilons_at(scaled.map.view(), s, ds, scaled.points[i], scaled.normals[i]);
                CHECK(es.shrink / scale == Approx(e1.shrink).epsilon(1e-4));
                CHECK(es.intrude / scale == Approx(e1.intrude).epsilon(1e-3));
                CHECK(es.bias / scale == Approx(e1.bias).epsilon(1e-3));
                CHECK(es.shrink > 0);
                CHECK(es.bias > 0);
            }
        }
    }
    // Millimetres against metres: the same slab modelled in m with the table's mm⁻¹ coefficients converted.
    const scaled_scene metres(1e-3f);
    const std::vector<glm::vec3> in_m = metres.gather(marble_mm.in_units(1000.0f), ss::gather_settings<float>{});
    const std::vector<glm::vec3> in_mm = unit.gather(marble_mm, ss::gather_settings<float>{});
    for (std::size_t i = 0; i < in_m.size(); ++i) CHECK(in_m[i].x == Approx(in_mm[i].x).epsilon(2e-3).margin(1e-7));
}

TEST_CASE("the gather does not depend on threads or tiles", "[subsurface]") {
    const scaled_scene sc(1);
    const ss::material<float> m = ss::presets::skim_milk();
    // A 16×8 G-buffer of top-face points.
    const std::size_t w = 16, h = 8;
    std::vector<glm::vec3> P(w * h), N(w * h, glm::vec3(0, 1, 0)), full(w * h), pooled(w * h), tile(w * h, glm::vec3(-1));
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) P[y * w + x] = {-0.4f * float(x), 0, 0.3f * float(y)};
    const ss::visible_points<float> vp{{P.data(), w, h}, {N.data(), w, h}};
    for (const auto mode : {ss::disc_sampling::centre_first, ss::disc_sampling::profile}) {
        ss::gather_settings<float> s;
        s.sampling = mode;
        s.samples = 40;
        ss::gather_subsurface(vp, sc.map.view(), m, s, aaf::image_view<glm::vec3>(full.data(), w, h));
        aaf::thread_pool pool(2);
        ss::gather_subsurface(vp, sc.map.view(), m, s, aaf::image_view<glm::vec3>(pooled.data(), w, h), pool);
        CHECK(pooled == full);
        // The tile x ∈ [5, 12), y ∈ [3, 8) gathered alone with its region.
        ss::gather_settings<float> st = s;
        st.region = {5, 3};
        const aaf::image_view<glm::vec3> tile_out = aaf::image_view<glm::vec3>(tile.data(), w, h).subview(5, 3, 7, 5);
        ss::gather_subsurface(ss::visible_points<float>{vp.positions.subview(5, 3, 7, 5), vp.normals.subview(5, 3, 7, 5)}, sc.map.view(), m, st,
                              tile_out);
        for (std::size_t y = 3; y < 8; ++y)
            for (std::size_t x = 5; x < 12; ++x) CHECK(tile[y * w + x] == full[y * w + x]);
    }
}

TEST_CASE("subsurface bad input: named errors before any output, or documented results", "[subsurface]") {
    const scaled_scene sc(1);
    const ss::material<float> m = ss::presets::marble();
    glm::vec3 p(-5, 0, 1), n(0, 1, 0), out(-7);
    const ss::visible_points<float> vp{{&p, 1, 1}, {&n, 1, 1}};
    const aaf::image_view<glm::vec3> o(&out, 1, 1);
    const auto throws = [&](auto&& f, const char* needle) {
        const std::string what = aaf_test::what_of(f);
        INFO(what);
        CHECK(what.find(needle) != std::string::npos);
        CHECK(out == glm::vec3(-7));  // nothing written
    };
    // Materials: negative, NaN, η ≤ 0.
    throws([&] { ss::material<float> b = m; b.sigma_a.x = -1; ss::gather_subsurface(vp, sc.map.view(), b, {}, o); }, "sigma_a");
    throws([&] { ss::material<float> b = m; b.sigma_s_prime.y = std::nanf(""); ss::gather_subsurface(vp, sc.map.view(), b, {}, o); }, "sigma_s_prime");
    throws([&] { ss::material<float> b = m; b.eta = 0; ss::gather_subsurface(vp, sc.map.view(), b, {}, o); }, "eta");
    // Settings.
    throws([&] { ss::gather_settings<float> s; s.samples = 0; ss::gather_subsurface(vp, sc.map.view(), m, s, o); }, "samples");
    throws([&] { ss::gather_settings<float> s; s.radius = std::nanf(""); ss::gather_subsurface(vp, sc.map.view(), m, s, o); }, "radius");
    throws([&] { ss::gather_settings<float> s; s.bias_epsilon = INFINITY; ss::gather_subsurface(vp, sc.map.view(), m, s, o); }, "epsilons");
    // Empty map: no texels, or faces without data.
    throws([&] { ss::light_map_view<ortho> v = sc.map.view(); v.projection.width = 0; ss::gather_subsurface(vp, v, m, {}, o); }, "empty map");
    throws([&] { ss::light_map_view<ortho> v = sc.map.view(); v.faces[0].positions = {}; ss::gather_subsurface(vp, v, m, {}, o); }, "empty map");
    throws([&] { ss::light_map_view<ortho> v = sc.map.view(); v.faces[0].irradiance = {}; ss::gather_subsurface(vp, v, m, {}, o); }, "irradiance");
    throws([&] { ortho pr = sc.map.projection; pr.width = 0; (void)ss::build_light_map(pr, {}, 1.3f, sc.scene); }, "empty map");
    throws([&] { (void)ss::build_light_map(sc.map.projection, {}, -1.0f, sc.scene); }, "eta");
    throws([&] { (void)ss::build_light_map(sc.map.projection, ss::map_light<float>{glm::vec3(-1)}, 1.3f, sc.scene); }, "power");
    // Mismatched buffers.
    glm::vec3 two[2];
    throws([&] { ss::gather_subsurface(ss::visible_points<float>{{&p, 1, 1}, {two, 2, 1}}, sc.map.view(), m, {}, o); }, "normals");
    // Documented results. A point whose disc is entirely outside the map: 0 (no light enters near it).
    glm::vec3 far_p(5000, 0, 0);
    ss::gather_subsurface(ss::visible_points<float>{{&far_p, 1, 1}, {&n, 1, 1}}, sc.map.view(), m, {}, o);
    CHECK(out == glm::vec3(0));
    // Sky (non-finite position) and a NaN normal: 0.
    glm::vec3 sky(std::numeric_limits<float>::quiet_NaN()), bad_n(std::numeric_limits<float>::quiet_NaN());
    ss::gather_subsurface(ss::visible_points<float>{{&sky, 1, 1}, {&n, 1, 1}}, sc.map.view(), m, {}, o);
    CHECK(out == glm::vec3(0));
    ss::gather_subsurface(ss::visible_points<float>{{&p, 1, 1}, {&bad_n, 1, 1}}, sc.map.view(), m, {}, o);
    CHECK(out == glm::vec3(0));
    // Non-finite texels never spread: a map poisoned with NaN and ∞ irradiance gathers finite values.
    ss::light_map<ortho> poisoned = sc.map;
    for (std::size_t y = 0; y < poisoned.projection.height; y += 3)
        for (std::size_t x = 0; x < poisoned.projection.width; x += 2)
            poisoned.irradiance[0](x, y) = glm::vec3((x + y) % 2 ? std::numeric_limits<float>::quiet_NaN() : INFINITY);
    for (const auto mode : {ss::disc_sampling::centre_first, ss::disc_sampling::profile}) {
        ss::gather_settings<float> s;
        s.sampling = mode;
        ss::gather_subsurface(vp, poisoned.view(), m, s, o);
        CHECK((std::isfinite(out.x) && std::isfinite(out.y) && std::isfinite(out.z) && out.x > 0));
    }
    // Extreme but valid materials: no scattering (R_d ≡ 0), huge and tiny coefficients: finite, non-negative.
    for (const auto& b : {ss::material<float>{glm::vec3(1), glm::vec3(0), 1.3f}, ss::material<float>{glm::vec3(1e30f), glm::vec3(1e30f), 1.3f},
                          ss::material<float>{glm::vec3(1e-30f), glm::vec3(1e-30f), 1.3f}, ss::material<float>{glm::vec3(0), glm::vec3(1e-30f), 1e-6f},
                          ss::material<float>{glm::vec3(1), glm::vec3(1), 1e6f}})
        for (const auto mode : {ss::disc_sampling::centre_first, ss::disc_sampling::profile})
            for (const auto model : {ss::profile_model::dipole, ss::profile_model::directional_dipole}) {
                ss::gather_settings<float> s;
                s.sampling = mode;
                s.profile = model;
                s.samples = 16;
                ss::gather_subsurface(vp, sc.map.view(), b, s, o);
                INFO("sigma_a " << b.sigma_a.x << " sigma_s' " << b.sigma_s_prime.x << " eta " << b.eta << " mode " << int(mode) << " model " << int(model));
                CHECK((std::isfinite(out.x) && std::isfinite(out.y) && std::isfinite(out.z) && out.x >= 0 && out.y >= 0 && out.z >= 0));
            }
    // A lossless material (σ_a = 0, Spectralon) is valid: finite, positive.
    ss::gather_subsurface(vp, sc.map.view(), ss::presets::spectralon<float>(), {}, o);
    CHECK((std::isfinite(out.x) && out.x > 0));
}

TEST_CASE("a point far outside the map gathers 0 without converting a huge texel coordinate (fuzz finding)", "[subsurface]") {
    // fuzz_subsurface: a disc sample 1e20 texels away was converted to an integer index (undefined behaviour,
    // caught by UBSan). texel_index now reports it as outside.
    CHECK(ss::texel_index(6.9e20f, 4) == -1);
    CHECK(ss::texel_index(-0.5f, 4) == -1);
    CHECK(ss::texel_index(std::numeric_limits<float>::quiet_NaN(), 4) == -1);
    CHECK(ss::texel_index(4.0f, 4) == -1);
    CHECK(ss::texel_index(3.99f, 4) == 3);
    const scaled_scene scene(1);
    for (const float far : {1e20f, 3e38f}) {
        const glm::vec3 p(far, 0, -far), n(0, 1, 0);
        glm::vec3 out(-1);
        for (const auto sampling : {ss::disc_sampling::profile, ss::disc_sampling::centre_first}) {
            ss::gather_settings<float> s;
            s.sampling = sampling;
            s.samples = 16;
            s.radius = far;  // a disc reaching far beyond the map as well
            ss::gather_subsurface(ss::visible_points<float>{{&p, 1, 1}, {&n, 1, 1}}, scene.map.view(), ss::presets::marble<float>(), s,
                                  aaf::image_view<glm::vec3>(&out, 1, 1));
            for (int c = 0; c < 3; ++c) {
                CHECK(std::isfinite(out[c]));
                CHECK(out[c] >= 0);
            }
        }
    }
}

TEST_CASE("total diffuse reflectance stays the disc integral's limit when 1 - alpha' rounds to 0 (fuzz finding)", "[subsurface]") {
    // σ_a/σ_s′ ≈ 2e-19: α′ = 1 in double, yet σ_tr·z_v ≈ 1.9 with A = 2e9 (η = 0.098, the classical fit clamped).
    // The textbook form of R_d^tot gave 1 against the disc integral's limit 0.573, so the 99 % radius was never
    // found and default_gather_radius returned 1.3e154 (NaN profiles and outputs followed).
    ss::material<double> m = ss::presets::marble<double>();
    m.sigma_s_prime[1] = 2.62 * std::ldexp(1.0, 53);
    m.sigma_s_prime[2] = 0;
    m.eta = 0.09765625;
    const ss::rgb_dipole d(m);
    for (int c = 0; c < 3; ++c) {
        CHECK(d.channel[c].total() == Approx(d.channel[c].disc_integral(1e12)).epsilon(1e-9));
        CHECK(std::isfinite(d.channel[c].profile(1e200)));
        CHECK(d.channel[c].profile(1e200) == 0);
        CHECK(std::isfinite(d.channel[c].disc_integral(1e200)));
        CHECK(d.channel[c].disc_integral(1e10, INFINITY) == 0);
    }
    CHECK(d.channel[1].total() == Approx(0.5 * (1 + std::exp(-d.channel[1].sigma_tr * d.channel[1].z_v))));
    const double R = ss::default_gather_radius(d);
    CHECK(std::isfinite(R));
    CHECK(R < 100);  // 11.9 mm: 99 % of the red channel
    // The same material on a default slab map: finite output.
    const scaled_scene scene(1);
    ss::material<float> mf;
    mf.sigma_a = glm::vec3(m.sigma_a), mf.sigma_s_prime = glm::vec3(m.sigma_s_prime), mf.eta = float(m.eta);
    for (const auto sampling : {ss::disc_sampling::profile, ss::disc_sampling::centre_first}) {
        ss::gather_settings<float> s;
        s.sampling = sampling;
        s.samples = 32;
        for (const glm::vec3& o : scene.gather(mf, s))
            for (int c = 0; c < 3; ++c) CHECK((std::isfinite(o[c]) && o[c] >= 0));
    }
}

TEST_CASE("map texels whose area or distance overflows contribute 0, and built maps never hold NaN (fuzz findings)", "[subsurface]") {
    // A cube map whose +x texel claims a point 1e30 away: the sample's area (distance² ratio) overflowed to ∞ and
    // met a profile of 0: NaN.
    using cube = ss::cube_projection<float>;
    const cube proj = cube::around(glm::vec3(0, 3, 0), 10.0f, 1);
    glm::vec3 P[6], N[6], E[6];
    for (int f = 0; f < 6; ++f) {
        const auto ray = proj.texel_ray(f, {0.5f, 0.5f});
        P[f] = ray.origin + ray.direction, N[f] = -ray.direction, E[f] = glm::vec3(0.5f);
    }
    P[0] = glm::vec3(-1e30f, 5.7e-6f, 0);
    ss::light_map_view<cube> view;
    view.projection = proj;
    for (int f = 0; f < 6; ++f) view.faces[std::size_t(f)] = {{&P[f], 1, 1}, {&N[f], 1, 1}, {&E[f], 1, 1}, {}};
    const glm::vec3 p(1, 3, 0), n(-1, 0, 0);
    for (const bool exact : {false, true})
        for (const auto sampling : {ss::disc_sampling::profile, ss::disc_sampling::centre_first}) {
            ss::gather_settings<float> s;
            s.sampling = sampling;
            s.samples = 16;
            s.exact_centre = exact;
            s.tangent_plane = false;
            s.fix_shrink = s.fix_intrude = s.fix_bias = false;
            glm::vec3 out(-1);
            ss::gather_subsurface(ss::visible_points<float>{{&p, 1, 1}, {&n, 1, 1}}, view, ss::presets::marble<float>(), s,
                                  aaf::image_view<glm::vec3>(&out, 1, 1));
            for (int c = 0; c < 3; ++c) CHECK((std::isfinite(out[c]) && out[c] >= 0));
        }
    // A point light whose tracer reports a hit a denormal distance from it, with a channel of zero power: the
    // irradiance power·c/d² was 0·∞ = NaN there.
    struct touching_tracer {
        float nearest_occluder(const aaf::shadow_segment<float>&) const noexcept { return 1e-30f; }
    };
    const auto map = ss::build_light_map(cube::around(glm::vec3(0), 10.0f, 4), ss::map_light<float>{glm::vec3(1, 0, 2)}, 1.3f,
                                         touching_tracer{}, [](const glm::vec3& q) { return glm::vec3(-glm::normalize(glm::dvec3(q))); });
    for (int f = 0; f < 6; ++f)
        for (std::size_t y = 0; y < 4; ++y)
            for (std::size_t x = 0; x < 4; ++x)
                for (int c = 0; c < 3; ++c) {
                    const float e = map.irradiance[std::size_t(f)](x, y)[c];
                    CHECK((std::isfinite(e) && e >= 0));
                }
}
