// SPDX-License-Identifier: MIT
// The ambient-occlusion family of the examples' registry (examples/common/occlusion_methods.hpp) on a small
// built-in scene: every method renders a displayable AO image of the frame's size, aaf_ao's pictures are
// there, and aaf_ao at μ = 2 is closer to the converged reference than unfiltered Monte Carlo at 16 spp
// (fewer rays than aaf_ao spends, which starts from 16).

#include <catch2/catch.hpp>

#include <cmath>
#include <string>

#include "common/bvh.hpp"
#include "common/occlusion_methods.hpp"
#include "common/render_support.hpp"
#include "common/scene.hpp"

using namespace aaf_examples;

TEST_CASE("occlusion methods render the boxes scene and aaf_ao beats Monte Carlo at 16 spp", "[occlusion]") {
    scene s = builtin_scene("boxes");
    s.width = 96, s.height = 72;
    const bvh tracer(s.vertices, s.triangles);
    aaf::thread_pool pool(2);
    const gbuffer_images g = render_gbuffer(s, tracer, pool);
    const render_inputs in{s, tracer, g, pool, 3};
    const method_family f = occlusion_methods();
    REQUIRE(f.methods.size() == 11);  // mc x2, aaf_ao and its 7 variants, sm_ao
    REQUIRE(f.references.size() == 1);
    CHECK(f.references[0].what == quantity::ambient_occlusion);
    const aaf::image<float> ref = f.references[0].render(in, 1024, 77).image;
    const auto mask = g.surface_mask();
    double mc_error = 0, aaf_error = 0, unfiltered_error = 0, authors_error = 0;
    for (const method& m : f.methods) {
        CAPTURE(m.name);
        CHECK(m.what == quantity::ambient_occlusion);
        const bool filtered = m.name.rfind("aaf_ao", 0) == 0;
        const method_output out = m.render(in, filtered ? 2.0 : 16.0);
        REQUIRE(out.image.width() == s.width);
        REQUIRE(out.image.height() == s.height);
        CHECK(out.rays >= 16 * g.surfaces);
        for (std::size_t y = 0; y < s.height; ++y)
            for (std::size_t x = 0; x < s.width; ++x) {
                REQUIRE(std::isfinite(out.image(x, y)));
                REQUIRE(out.image(x, y) >= 0.0f);
                REQUIRE(out.image(x, y) <= 1.0f);
            }
        const double e = rmse(out.image, ref, mask);
        if (m.name == "mc_ao_cosine") mc_error = e;
        if (m.name == "aaf_ao") {
            aaf_error = e;
            CHECK(out.pictures.size() == 7);
            REQUIRE(out.colour_pictures.size() == 3);  // bent normals, β and samples heat maps
            for (const auto& [name, picture] : out.colour_pictures) {
                CAPTURE(name);
                CHECK(picture.width() == s.width);
                CHECK(picture.height() == s.height);
            }
        }
        if (m.name == "aaf_ao_unfiltered") unfiltered_error = e;
        if (m.name == "aaf_ao_authors") authors_error = e;
    }
    CAPTURE(mc_error, aaf_error, unfiltered_error, authors_error);
    CHECK(aaf_error < mc_error);
    CHECK(aaf_error < unfiltered_error);     // the same samples, filtered or not
    CHECK(authors_error < unfiltered_error);

    // sm_ao: one 256² map live at a time, and more directions bring it nearer the reference.
    const method* sm = nullptr;
    for (const method& m : f.methods)
        if (m.name == "sm_ao") sm = &m;
    REQUIRE(sm != nullptr);
    const method_output few = sm->render(in, 4.0), more = sm->render(in, 32.0);
    CHECK(few.memory_bytes == 256u * 256u * sizeof(float));
    CHECK(more.rays == 32u * 256u * 256u);
    CHECK(more.pictures.size() == 5);
    const double few_error = rmse(few.image, ref, mask), more_error = rmse(more.image, ref, mask);
    CAPTURE(few_error, more_error);
    CHECK(more_error < few_error);
}
