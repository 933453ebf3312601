// SPDX-License-Identifier: MIT
// The subsurface family of the examples' registry (examples/common/subsurface_methods.*) on the boxes scene,
// judged against the family's map-free Monte Carlo reference: the write-up's fixes lower the error, and more
// samples per pixel lower it too.

#include <catch2/catch.hpp>

#include <cmath>
#include <string>

#include "common/bvh.hpp"
#include "common/methods.hpp"
#include "common/render_support.hpp"
#include "common/scene.hpp"

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
