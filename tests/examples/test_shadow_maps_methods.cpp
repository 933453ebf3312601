// SPDX-License-Identifier: MIT
// The shadow-map family's registry entries (examples/common/shadow_maps_methods.cpp) on a built-in scene:
// every method renders a displayable image (sky 1, values in [0, 1]) comparable with Monte Carlo; the
// accumulation converges towards it as M grows and beats a single hard shadow; the bias panels differ as
// they should (no bias: acne on lit ground).

#include <catch2/catch.hpp>

#include <cmath>
#include <map>
#include <string>

#include "common/render_support.hpp"
#include "common/shadow_maps_methods.hpp"

using namespace aaf_examples;

TEST_CASE("shadow-map methods render displayable images that approach Monte Carlo", "[shadow_maps][examples]") {
    scene s = builtin_scene("boxes");
    s.width = 96, s.height = 72;
    aaf::thread_pool pool(2);
    const bvh tracer(s.vertices, s.triangles);
    const gbuffer_images g = render_gbuffer(s, tracer, pool);
    const render_inputs in{s, tracer, g, pool, 0};
    const aaf::image<float> mc = render_mc(s, g, tracer, {.spp = 256, .seed = 9}, pool).visibility;
    const auto mask = g.surface_mask();
    const method_family f = shadow_map_methods();
    std::map<std::string, double> err;
    for (const method& m : f.methods) {
        INFO(m.name);
        CHECK(m.family == "shadow_maps");
        CHECK(!m.sweep.empty());
        const double knob = m.name == "sm_accumulation" ? 4.0 : m.default_knob;
        const method_output out = m.render(in, knob);
        REQUIRE(out.image.width() == s.width);
        REQUIRE(out.image.height() == s.height);
        bool valid = true;
        for (std::size_t i = 0; i < out.image.size(); ++i) {
            const float v = out.image.data()[i];
            valid = valid && v >= 0.0f && v <= 1.0f && (g.surface(i) || v == 1.0f);
        }
        CHECK(valid);
        CHECK(out.rays > 0u);
        CHECK(out.memory_bytes > 0u);
        err[m.name] = rmse(out.image, mc, mask);
    }
    aaf::image<float> acc2;
    for (const method& m : f.methods)
        if (m.name == "sm_accumulation") acc2 = m.render(in, 2).image;
    const double e2 = rmse(acc2, mc, mask);
    INFO("hard " << err["sm_hard"] << " no bias " << err["sm_hard_no_bias"] << " pcf " << err["sm_pcf"] << " pcss " << err["sm_pcss"]
                 << " accumulation M=4 " << err["sm_accumulation"] << " M=2 " << e2);
    CHECK(err["sm_hard_no_bias"] > err["sm_hard"]);  // acne
    for (const char* biased : {"sm_hard_slope_scaled", "sm_hard_normal_offset", "sm_hard_receiver_plane"}) {
        INFO(biased << " " << err[biased]);
        CHECK(err[biased] < err["sm_hard_no_bias"]);  // every bias mode removes the acne of none on these planar faces
    }
    CHECK(err["sm_accumulation"] < err["sm_hard"]);
    CHECK(err["sm_accumulation"] < e2);
    CHECK(err["sm_pcss"] < err["sm_hard"]);
}
