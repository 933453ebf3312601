// SPDX-License-Identifier: MIT
// Automatic shadow-map depth bias through the examples' BVH on a real mesh (the Stanford bunny on its ground,
// scenes/bunny.json) at scene scales 1e-4 … 1e5: receivers come from the camera's primary rays through the
// BVH (with their rounding), the map from the light's centre is rendered through the same BVH (one
// nearest-hit query per texel), and each receiver's hard shadow-map test is compared with the BVH's own
// shadow ray towards the same point (automatic ray-origin offset, itself checked across these scales in
// test_ray_offset_scenes.cpp). With the automatic bias there is no acne and no leak (peter-panning) anywhere
// further than two texel footprints from a true shadow edge, on the curved, self-shadowing mesh as on the
// ground; a constant ε_b tuned to be clean at scale 1 fails at both ends of the range. The analytic
// counterpart (a plate over a plane, every bias mode) is tests/test_shadow_maps_bias.cpp.

#include <catch2/catch.hpp>

#include <cmath>
#include <cstddef>
#include <filesystem>
#include <vector>

#include <aaf/ray_offset.hpp>
#include <aaf/shadow_maps.hpp>

#include "common/bvh.hpp"
#include "common/render_support.hpp"
#include "common/scene.hpp"

namespace {

using namespace aaf_examples;

struct tally {
    std::size_t interior_lit = 0, interior_shadowed = 0;  ///< receivers away from every true shadow edge
    std::size_t acne = 0;                                 ///< interior lit receivers the map shadows
    std::size_t leaks = 0;                                ///< interior shadowed receivers the map lights
};

/// The bunny scene scaled by `s` (geometry, light and camera, as aaf-render --scale does), 64×48 receivers.
scene bunny_at(float s) {
    scene sc = load_scene("bunny", std::filesystem::path(AAF_SOURCE_DIR) / "scenes");
    sc.width = 64, sc.height = 48;
    for (glm::vec3& v : sc.vertices) v *= s;
    sc.light.corner *= s, sc.light.edge_u *= s, sc.light.edge_v *= s;
    sc.view.position *= s, sc.view.target *= s;
    return sc;
}

/// A receiver away from every true shadow edge, with its true visibility.
struct receiver {
    glm::vec3 p, n;
    bool lit;
};

/// The scene's receivers (primary rays through the BVH) and a 256² unorm24 perspective map from the light's
/// centre fitted to them (as the registry's sm_hard does), rendered through the same BVH.
struct setup {
    std::vector<receiver> interior;
    aaf::depth_map<float> map;
};

/// A receiver counts when its 3×3 neighbours k texel footprints apart (displaced across the light's rays and
/// projected along them onto the receiver's tangent plane: the points the neighbouring texels see there) have
/// its true visibility, the BVH's shadow ray towards the light's centre. Receivers within 6° of grazing the
/// light are left out: the bias's slope term is capped at max_slope = 16 (tan 86°) by design.
setup prepare(const scene& sc, const bvh& tracer, aaf::thread_pool& pool, float k = 2) {
    const gbuffer_images g = render_gbuffer(sc, tracer, pool);
    const aaf::gbuffer<float> gb{g.positions.cview(), g.normals.cview(), g.pixel_size.cview(), {}};
    const glm::vec3 y = sc.light.center();
    aaf::light_view<float> view;
    REQUIRE(aaf::fit_perspective_view(gb, y, sc.light.normal(), 1e-3f, 8.0f, view));
    const std::size_t size = 256;
    setup out{{}, aaf::depth_map<float>(size, size, view, aaf::depth_format::unorm24)};
    aaf::render_depth_map(out.map, tracer, pool);
    const aaf::light_frame<float> frame(view);
    const auto truly_lit = [&](const glm::vec3& p, const glm::vec3& n) {
        const glm::vec3 o = aaf::shadow_ray_origin(p, n, y);
        const glm::vec3 to = y - o;
        const float len = glm::length(to);
        return !tracer.occluded({o, to / len, len});
    };
    for (std::size_t j = 0; j < g.positions.height(); ++j)
        for (std::size_t i = 0; i < g.positions.width(); ++i) {
            const glm::vec3 p = g.positions(i, j), n = g.normals(i, j);
            if (!std::isfinite(p.x) || std::abs(glm::dot(n, glm::normalize(y - p))) < 0.1f) continue;
            const bool lit = truly_lit(p, n);
            const float fp = frame.texel_footprint(frame.to_light(p).z, size, size).x;
            bool interior = true;
            for (int dy = -1; dy <= 1 && interior; ++dy)
                for (int dx = -1; dx <= 1 && interior; ++dx) {
                    if (dx == 0 && dy == 0) continue;
                    const glm::vec3 q = p + k * fp * (static_cast<float>(dx) * frame.right + static_cast<float>(dy) * frame.up);
                    const glm::vec3 r = glm::normalize(q - y);
                    const float along = glm::dot(p - y, n) / glm::dot(r, n);  // the ray y → q meets p's tangent plane
                    interior = truly_lit(y + along * r, n) == lit;
                }
            if (interior) out.interior.push_back({p, n, lit});
        }
    return out;
}

/// Hard shadow-map tests of the interior receivers under `bias`, against their true visibility.
tally run(const setup& su, const aaf::bias_settings<float>& bias) {
    aaf::lookup_settings<float> look;
    look.filter = aaf::shadow_filter::hard;
    look.bias = bias;
    const aaf::shadow_map_sampler<float> sampler(su.map.map_view(), look);
    tally t;
    for (const receiver& r : su.interior) {
        const float v = sampler.visibility(r.p, r.n);
        if (r.lit) {
            ++t.interior_lit;
            t.acne += v < 1.0f ? 1 : 0;
        } else {
            ++t.interior_shadowed;
            t.leaks += v > 0.0f ? 1 : 0;
        }
    }
    return t;
}

}  // namespace

TEST_CASE("automatic depth bias through the BVH on the bunny: no acne, no peter-panning, scales 1e-4 to 1e5",
          "[shadow_maps][bias][scene]") {
    aaf::thread_pool pool(2);
    const aaf::bias_settings<float> automatic;  // the default
    aaf::bias_settings<float> constant;
    constant.mode = aaf::bias_mode::constant;
    // Tuned by hand at scale 1 (of 0.003, 0.01, 0.015, 0.02, 0.03, 0.05, 0.1 world units, 0.015 and above are
    // clean there; 0.01 leaves one receiver with acne, 0.003 four).
    constant.constant = 0.02f;
    // Measured with this constant: all 186 interior shadowed receivers leak at scales 1e-4 and 1e-2 (ε_b is
    // twice the bunny's size at 1e-2), 12 and 13 of ~1720 lit ones have acne at 1e2 and 1e5.
    std::size_t constant_leaks_small = 0, constant_acne_large = 0;
    for (const float s : {1e-4f, 1e-2f, 1.0f, 1e2f, 1e5f}) {
        INFO("scale " << s);
        const scene sc = bunny_at(s);
        const bvh tracer(sc.vertices, sc.triangles);
        const setup su = prepare(sc, tracer, pool);
        const tally a = run(su, automatic);
        INFO("automatic: lit " << a.interior_lit << " shadowed " << a.interior_shadowed << " acne " << a.acne << " leaks " << a.leaks);
        CHECK(a.interior_lit > 1000u);      // the ground, and the bunny's lit side, are mostly interior
        CHECK(a.interior_shadowed > 100u);  // the bunny's shadow and its self-shadowed side
        CHECK(a.acne == 0u);
        CHECK(a.leaks == 0u);
        const tally c = run(su, constant);
        INFO("constant: acne " << c.acne << " leaks " << c.leaks);
        if (s == 1.0f) CHECK(c.acne + c.leaks == 0u);
        if (s < 1.0f) constant_leaks_small += c.leaks;  // ε_b dwarfs the bunny: its shadow is gone
        if (s > 1.0f) constant_acne_large += c.acne;    // ε_b under a texel's depth change: acne
        // Every other mode with its default settings, for the table of docs/SHADOW_MAPS.md (print it with -s):
        // none has acne at every scale; the others are recorded, not asserted (their costs are in the docs).
        for (const aaf::bias_mode mode : {aaf::bias_mode::none, aaf::bias_mode::slope_scaled, aaf::bias_mode::normal_offset,
                                          aaf::bias_mode::receiver_plane}) {
            aaf::bias_settings<float> b;
            b.mode = mode;
            const tally t = run(su, b);
            INFO("mode " << aaf::to_string(mode) << ": lit " << t.interior_lit << " shadowed " << t.interior_shadowed << " acne "
                         << t.acne << " leaks " << t.leaks);
            if (mode == aaf::bias_mode::none) CHECK(t.acne > 0u);
            else CHECK(t.interior_lit == a.interior_lit);
        }
    }
    CHECK(constant_leaks_small > 0u);
    CHECK(constant_acne_large > 0u);
}
