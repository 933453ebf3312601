// SPDX-License-Identifier: MIT
// The method registry (examples/common/methods.hpp): the contract every registered method keeps, checked for
// every family at once so a new technique is tested the moment it registers — unique names, a reference
// for its quantity, a cheapest point that renders a full-size image with values in [0, 1] on every surface
// pixel, a positive time, and the same image again for the same seed.

#include <catch2/catch.hpp>

#include <cmath>
#include <set>
#include <string>

#include "common/bvh.hpp"
#include "common/methods.hpp"
#include "common/render_support.hpp"
#include "common/scene.hpp"

using namespace aaf_examples;

TEST_CASE("registry: names are unique and every quantity in use has a reference", "[methods]") {
    std::set<std::string> names;
    for (const method& m : all_methods()) {
        INFO(m.name);
        CHECK(names.insert(m.name).second);
        CHECK(!m.family.empty());
        CHECK(!m.knob.empty());
        CHECK(!m.help.empty());
        CHECK((m.doubling_sweep || !m.sweep.empty()));
        CHECK(static_cast<bool>(m.render));
        CHECK(find_reference(m.what).what == m.what);
        CHECK(&find_method(m.name) == &m);
        // The baseline of a quantity is one of its own methods.
        CHECK(find_method(find_reference(m.what).baseline_method).what == m.what);
    }
    CHECK(names.count("mc_stratified") == 1);
    CHECK(names.count("aaf_adaptive") == 1);
    CHECK_THROWS_WITH(find_method("frobnicate"), Catch::Contains("unknown method 'frobnicate'") && Catch::Contains("mc_stratified"));
    CHECK(parse_quantity("ambient_occlusion") == quantity::ambient_occlusion);
    CHECK_THROWS_WITH(parse_quantity("loudness"), Catch::Contains("unknown quantity 'loudness'"));
}

TEST_CASE("registry: every method renders its cheapest point on a small scene", "[methods]") {
    scene s = load_scene("boxes", {});
    s.width = 40, s.height = 30;
    s.validate();
    aaf::thread_pool pool(2);
    const bvh tracer(s.vertices, s.triangles);
    const gbuffer_images g = render_gbuffer(s, tracer, pool);
    REQUIRE(g.surfaces > 0);
    const render_inputs in{.s = s, .tracer = tracer, .g = g, .pool = pool, .seed = 3};
    for (const method& m : all_methods()) {
        INFO(m.name);
        const double knob = m.doubling_sweep ? 1.0 : !m.quick_sweep.empty() ? m.quick_sweep.front() : m.sweep.front();
        const method_output a = m.render(in, knob);
        REQUIRE(a.image.width() == s.width);
        REQUIRE(a.image.height() == s.height);
        std::size_t bad = 0;
        for (std::size_t i = 0; i < a.image.size(); ++i)
            if (g.surface(i) && !(a.image.data()[i] >= 0.0f && a.image.data()[i] <= 1.0f)) ++bad;
        CHECK(bad == 0);
        CHECK(a.total_ms > 0);
        CHECK(std::isfinite(a.total_ms));
        // Deterministic for a seed: the registry's images are what both tools compare.
        const method_output b = m.render(in, knob);
        std::size_t differ = 0;
        for (std::size_t i = 0; i < a.image.size(); ++i)
            if (!(a.image.data()[i] == b.image.data()[i]) && !(std::isnan(a.image.data()[i]) && std::isnan(b.image.data()[i]))) ++differ;
        CHECK(differ == 0);
        CHECK(a.rays == b.rays);
    }
}
