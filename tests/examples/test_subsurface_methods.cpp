// SPDX-License-Identifier: MIT
// The subsurface family of the examples' registry (examples/common/subsurface_methods.*) on the boxes scene,
// judged against the family's map-free Monte Carlo reference: the write-up's fixes lower the error, and more
// samples per pixel lower it too; the material and light variants are judged against their own reference.

#include <catch2/catch.hpp>

#include <cmath>
#include <string>
#include <vector>

#include "common/bvh.hpp"
#include "common/methods.hpp"
#include "common/render_support.hpp"
#include "common/scene.hpp"
#include "common/tradeoff.hpp"

using namespace aaf_examples;

namespace {

struct small_scene {
    scene s = load_scene("boxes", {});
    mutable aaf::thread_pool pool{2};
    bvh tracer{s.vertices, s.triangles};
    // render_inputs holds a reference to a scene_tracer: one that lives as long as the scene, not a
    // temporary made from the bvh by conversion in inputs()'s return statement (which would dangle).
    scene_tracer any_tracer{tracer};
    gbuffer_images g;
    aaf::image<float> reference;

    small_scene() {
        s.width = 48, s.height = 36;
        s.validate();
        g = render_gbuffer(s, tracer, pool);
        // Two halves with different seeds, averaged, as aaf-tradeoff does.
        const quantity_reference& r = find_reference(quantity::subsurface);
        const aaf::image<float> a = r.render(inputs(), 512, 11).image, b = r.render(inputs(), 512, 12).image;
        reference = aaf::image<float>(a.width(), a.height());
        for (std::size_t i = 0; i < a.size(); ++i) reference.data()[i] = 0.5f * (a.data()[i] + b.data()[i]);
    }
    [[nodiscard]] render_inputs inputs() const { return {.s = s, .tracer = any_tracer, .g = g, .pool = pool, .seed = 3}; }
    /// RMS error over surface pixels of `name` at `samples` against the reference.
    [[nodiscard]] double error(const std::string& name, double samples) const {
        const aaf::image<float> img = find_method(name).render(inputs(), samples).image;
        double sum = 0;
        std::size_t n = 0;
        for (std::size_t i = 0; i < img.size(); ++i)
            if (g.surface(i)) sum += double(img.data()[i] - reference.data()[i]) * double(img.data()[i] - reference.data()[i]), ++n;
        return n ? std::sqrt(sum / double(n)) : 0.0;
    }
};

}  // namespace

TEST_CASE("subsurface methods: the fixes beat no fixes, and the error falls with samples", "[subsurface]") {
    small_scene sc;
    REQUIRE(sc.g.surfaces > 0);
    double mean = 0;
    for (std::size_t i = 0; i < sc.reference.size(); ++i) mean += sc.g.surface(i) ? double(sc.reference.data()[i]) : 0.0;
    mean /= double(sc.g.surfaces);
    INFO("reference mean " << mean);
    REQUIRE(mean > 0.05);  // something is lit and scatters: a black frame would make every comparison vacuous

    const double none = sc.error("sss_no_fixes", 150), bias = sc.error("sss_bias_only", 150), all = sc.error("sss_all_fixes", 150),
                 banding = sc.error("sss_all_fixes_banding", 150), profile = sc.error("sss_profile", 150);
    INFO("RMS error at 150 samples: no fixes " << none << ", bias only " << bias << ", all fixes " << all << ", + banding fix "
                                                << banding << ", profile " << profile);
    CHECK(all < none);
    CHECK(profile < none);

    const double p8 = sc.error("sss_profile", 8), mc8 = sc.error("mc_subsurface", 8), mc150 = sc.error("mc_subsurface", 150);
    INFO("profile 8 samples " << p8 << "; Monte Carlo 8 " << mc8 << ", 150 " << mc150);
    CHECK(profile < p8);
    CHECK(mc150 < mc8);
}

TEST_CASE("subsurface methods: material and light variants are judged against their own reference", "[subsurface]") {
    // The family: five write-up/aaf gathers in marble under the quantity's light, five variants of sss_profile
    // (skim milk, side and back light), and the Monte Carlo baseline.
    std::size_t family = 0, variants = 0;
    for (const method& m : all_methods())
        if (m.what == quantity::subsurface) {
            INFO(m.name);
            ++family;
            if (!m.own_reference) continue;
            ++variants;
            CHECK(m.name.rfind("sss_profile_", 0) == 0);
        }
    CHECK(family == 11);
    CHECK(variants == 5);
    // aaf-tradeoff's curves share the quantity's (marble) reference: the variants are not among them.
    for (const std::string& n : tradeoff::method_names(quantity::subsurface)) CHECK(!find_method(n).own_reference);

    // A variant's own reference is the Monte Carlo integral with its material and light: the back-lit skim milk
    // gather is closer to it than to the quantity's marble reference, which it does not estimate.
    scene s = load_scene("boxes", {});
    s.width = 40, s.height = 30;
    s.validate();
    aaf::thread_pool pool(2);
    const bvh tracer(s.vertices, s.triangles);
    const scene_tracer any(tracer);
    const gbuffer_images g = render_gbuffer(s, tracer, pool);
    REQUIRE(g.surfaces > 0);
    const render_inputs in{.s = s, .tracer = any, .g = g, .pool = pool, .seed = 3};
    const std::vector<unsigned char> mask = g.surface_mask();
    const method& m = find_method("sss_profile_skim_milk_back");
    const aaf::image<float> img = m.render(in, 64).image;
    const aaf::image<float> own = m.own_reference(in, 256, 11);
    const aaf::image<float> marble = find_reference(quantity::subsurface).render(in, 256, 11).image;
    const double e_own = rmse(img, own, mask), e_marble = rmse(img, marble, mask);
    INFO("RMSE against its own reference " << e_own << ", against the marble reference " << e_marble);
    CHECK(e_own < e_marble);
}
