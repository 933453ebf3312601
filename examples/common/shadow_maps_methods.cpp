// SPDX-License-Identifier: MIT
#include "common/shadow_maps_methods.hpp"

#include <cmath>
#include <string>

#include <aaf/shadow_maps.hpp>

namespace aaf_examples {

namespace {

aaf::gbuffer<float> view_of(const gbuffer_images& g) {
    return {g.positions.cview(), g.normals.cview(), g.pixel_size.cview(), {}};
}

/// 0 where the light cannot reach the receiver at all (behind a one-sided light, or every corner and the
/// centre of the light below the receiver's horizon), as the reference's "no light"; else `v`.
float with_light_mask(const aaf::area_light<float>& light, const glm::vec3& p, const glm::vec3& n, float v) {
    if (!std::isfinite(p.x + p.y + p.z) || !std::isfinite(n.x + n.y + n.z)) return 1.0f;  // sky
    if (!light.emits_towards(p)) return 0.0f;
    for (const glm::vec3 y : {light.corner, light.point(1, 0), light.point(0, 1), light.point(1, 1), light.center()})
        if (glm::dot(n, y - p) > 0.0f) return v;
    return 0.0f;
}

/// One map from the light's centre, then a lookup pass with `look`; knob-independent parts fixed by the caller.
method_output render_single_map(const render_inputs& in, std::size_t map_size, const aaf::lookup_settings<float>& look) {
    method_output out;
    const aaf::gbuffer<float> gb = view_of(in.g);
    const aaf::area_light<float>& light = in.s.light;
    aaf::light_view<float> view;
    out.image.reset(in.g.positions.width(), in.g.positions.height(), 1.0f);
    const auto t0 = clock_type::now();
    if (!aaf::fit_perspective_view(gb, light.center(), light.normal(), 1e-3f, 8.0f, view)) {
        for (std::size_t i = 0; i < out.image.size(); ++i)  // nothing in front of the light: unlit
            out.image.data()[i] = in.g.surface(i) ? 0.0f : 1.0f;
        out.total_ms = ms_since(t0);
        return out;
    }
    aaf::depth_map<float> map(map_size, map_size, view, aaf::depth_format::unorm24);
    out.rays = aaf::render_depth_map(map, in.tracer, in.pool).texels;
    out.stages_ms.emplace_back("map", ms_since(t0));
    const auto t1 = clock_type::now();
    aaf::lookup_settings<float> s = look;
    s.frame_seed = in.seed;
    aaf::shadow_lookup(map.map_view(), gb, s, out.image.view(), {}, in.pool);
    for (std::size_t y = 0; y < out.image.height(); ++y)
        for (std::size_t x = 0; x < out.image.width(); ++x)
            out.image(x, y) = with_light_mask(light, in.g.positions(x, y), in.g.normals(x, y), out.image(x, y));
    out.stages_ms.emplace_back("lookup", ms_since(t1));
    out.total_ms = ms_since(t0);
    out.memory_bytes = map.storage_bytes();
    return out;
}

aaf::lookup_settings<float> hard_settings(aaf::bias_mode mode, float constant = 0) {
    aaf::lookup_settings<float> s;
    s.filter = aaf::shadow_filter::hard;
    s.bias.mode = mode;
    s.bias.constant = constant;
    return s;
}

}  // namespace

method_family shadow_map_methods() {
    method_family f;
    const auto hard = [](const std::string& name, aaf::bias_mode mode, float constant, const std::string& help) {
        method m;
        m.name = name;
        m.family = "shadow_maps";
        m.knob = "map_size";
        m.sweep = {256, 512, 1024, 2048};
        m.default_knob = 1024;
        m.help = help;
        m.settings = {{"projection", "perspective"}, {"format", "unorm24"}, {"filter", "hard"},
                      {"bias", aaf::to_string(mode)}, {"bias_constant", constant}};
        m.render = [mode, constant](const render_inputs& in, double knob) {
            return render_single_map(in, static_cast<std::size_t>(knob), hard_settings(mode, constant));
        };
        return m;
    };
    f.methods.push_back(hard("sm_hard", aaf::bias_mode::automatic, 0,
                             "shadow map from the light's centre, hard test, automatic bias (knob: map size)"));
    f.methods.push_back(hard("sm_hard_no_bias", aaf::bias_mode::none, 0, "shadow map, hard test, no depth bias: acne"));
    f.methods.push_back(hard("sm_hard_constant_bias", aaf::bias_mode::constant, 1e-3f,
                             "shadow map, hard test, the seed's constant bias of 1e-3 world units"));
    // The remaining bias modes with their default settings, so that every mode can be rendered on every scene.
    f.methods.push_back(hard("sm_hard_slope_scaled", aaf::bias_mode::slope_scaled, 0,
                             "shadow map, hard test, slope-scaled bias (glPolygonOffset factor 1, units 1)"));
    f.methods.push_back(hard("sm_hard_normal_offset", aaf::bias_mode::normal_offset, 0,
                             "shadow map, hard test, normal-offset bias (receiver moved one texel footprint along its normal)"));
    f.methods.push_back(hard("sm_hard_receiver_plane", aaf::bias_mode::receiver_plane, 0,
                             "shadow map, hard test, receiver-plane depth bias"));
    {
        method m;
        m.name = "sm_pcf";
        m.family = "shadow_maps";
        m.knob = "taps";
        m.sweep = {1, 4, 16, 64};
        m.default_knob = 16;
        m.help = "percentage-closer filtering, rotated Poisson disc of 2 texels, 1024^2 map (knob: taps)";
        m.settings = {{"map_size", 1024}, {"format", "unorm24"}, {"pattern", "rotated_poisson"}, {"radius_texels", 2}, {"bias", "automatic"}};
        m.render = [](const render_inputs& in, double knob) {
            aaf::lookup_settings<float> s;
            s.pcf.pattern = aaf::pcf_pattern::rotated_poisson;
            s.pcf.taps = static_cast<std::uint32_t>(knob);
            s.pcf.radius = 2;
            return render_single_map(in, 1024, s);
        };
        f.methods.push_back(std::move(m));
    }
    {
        method m;
        m.name = "sm_pcss";
        m.family = "shadow_maps";
        m.knob = "taps";
        m.sweep = {4, 16, 64, 256};
        m.default_knob = 64;
        m.help = "PCSS: blocker search, penumbra from the light's width, rotated-Poisson PCF, 1024^2 map (knob: PCF taps)";
        m.settings = {{"map_size", 1024}, {"format", "unorm24"}, {"blocker_taps", 16}, {"pattern", "rotated_poisson"},
                      {"max_radius_texels", 64}, {"light_width", "sqrt(area)"}, {"bias", "automatic"}};
        m.render = [](const render_inputs& in, double knob) {
            aaf::lookup_settings<float> s;
            s.filter = aaf::shadow_filter::pcss;
            s.pcf.pattern = aaf::pcf_pattern::rotated_poisson;
            s.pcf.taps = static_cast<std::uint32_t>(knob);
            s.pcss.light_width = std::sqrt(in.s.light.area());
            s.pcss.blocker_taps = 16;
            s.pcss.max_radius = 64;
            return render_single_map(in, 1024, s);
        };
        f.methods.push_back(std::move(m));
    }
    {
        method m;
        m.name = "sm_accumulation";
        m.family = "shadow_maps";
        m.knob = "grid";
        m.sweep = {1, 2, 4, 8, 16};
        m.default_knob = 8;
        m.help = "Heckbert-Herf accumulation of MxM hard shadows from 512^2 maps on a regular grid (knob: M)";
        m.settings = {{"map_size", 512}, {"format", "unorm24"}, {"pattern", "regular_grid"}, {"bias", "automatic"}};
        m.render = [](const render_inputs& in, double knob) {
            method_output out;
            aaf::accumulation_settings<float> s;
            s.grid = static_cast<std::uint32_t>(knob);
            s.map_size = 512;
            s.frame_seed = in.seed;
            out.image.reset(in.g.positions.width(), in.g.positions.height());
            const auto t0 = clock_type::now();
            const aaf::accumulation_stats st = aaf::accumulate_hard_shadows(view_of(in.g), in.s.light, in.tracer, s, out.image.view(), in.pool);
            out.total_ms = ms_since(t0);
            out.stages_ms.emplace_back("accumulate", out.total_ms);
            out.rays = st.rays;
            out.memory_bytes = st.map_bytes + st.buffer_bytes;
            return out;
        };
        f.methods.push_back(std::move(m));
    }
    return f;
}

}  // namespace aaf_examples
