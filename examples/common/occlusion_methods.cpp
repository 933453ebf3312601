// SPDX-License-Identifier: MIT
#include "common/occlusion_methods.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include <aaf/occlusion.hpp>

namespace aaf_examples {

namespace {

using gbuffer_view = aaf::gbuffer<float, aaf::const_image_view<std::uint32_t>>;

gbuffer_view view_of(const gbuffer_images& g) {
    return {g.positions.cview(), g.normals.cview(), g.pixel_size.cview(), g.ids.cview()};
}

/// Sky 1, surface pixels without an estimate 1 (no sample counted: nothing occludes what was not seen).
aaf::image<float> displayable_ao(const aaf::image<float>& raw, const gbuffer_images& g) {
    aaf::image<float> out(raw.width(), raw.height());
    for (std::size_t y = 0; y < raw.height(); ++y)
        for (std::size_t x = 0; x < raw.width(); ++x) {
            const float v = raw(x, y);
            out(x, y) = !std::isfinite(g.positions(x, y).x) || !std::isfinite(v) ? 1.0f : v;
        }
    return out;
}

/// Unfiltered Monte Carlo AO: `spp` cosine-weighted samples of `pattern` per surface pixel.
method_output render_mc_ao(const render_inputs& in, aaf::sample_pattern pattern, std::uint32_t spp, std::uint32_t seed,
                           std::uint32_t pass = 0) {
    const std::size_t w = in.g.positions.width(), h = in.g.positions.height();
    aaf::ao_sampling_settings<float> s;
    s.pattern = pattern;
    s.initial_samples = s.max_samples = std::max<std::uint32_t>(spp, 1);
    s.max_distance = ao_max_distance(in.s);
    s.query = aaf::ao_query::visibility;  // any-hit rays: Monte Carlo needs no distances
    s.frame_seed = seed;
    aaf::image<aaf::ao_stats<float>> stats(w, h);
    method_output out;
    const auto t0 = clock_type::now();
    out.rays = aaf::gather_ambient_occlusion(view_of(in.g), in.tracer, s, pass, s.initial_samples, stats.view(), {}, {}, in.pool);
    const double rays_ms = ms_since(t0);
    aaf::image<float> raw(w, h);
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) raw(x, y) = stats(x, y).visibility();
    out.image = displayable_ao(raw, in.g);
    out.total_ms = ms_since(t0);
    out.stages_ms = {{"rays", rays_ms}};
    out.memory_bytes = w * h * sizeof(aaf::ao_stats<float>);
    return out;
}

/// The lecture's pictures from AO and bent normals: bent normals as colours, diffuse only, AO-modulated
/// diffuse plus an ambient term from a gradient sky (SH irradiance at the bent normal).
void add_shading_pictures(method_output& out, const render_inputs& in, const aaf::image<float>& ao,
                          const aaf::image<glm::vec3>& bent) {
    const std::size_t w = ao.width(), h = ao.height();
    aaf::image<float> br(w, h, 1.0f), bg(w, h, 1.0f), bb(w, h, 1.0f), diffuse(w, h, 1.0f), shaded(w, h, 1.0f);
    aaf::sky_model<float> sky;  // white zenith over a dark ground, +y up
    sky.ground = glm::vec3(0.15f);
    const aaf::sh9<float> sh = sky.coefficients();
    const glm::vec3 light = in.s.light.center();
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) {
            const glm::vec3 p = in.g.positions(x, y), n = in.g.normals(x, y);
            if (!std::isfinite(p.x)) continue;
            const glm::vec3 b = bent(x, y);
            br(x, y) = 0.5f + 0.5f * b.x, bg(x, y) = 0.5f + 0.5f * b.y, bb(x, y) = 0.5f + 0.5f * b.z;
            const float albedo = in.g.albedo(x, y);
            const glm::vec3 l = glm::normalize(light - p);
            diffuse(x, y) = albedo * std::max(0.0f, glm::dot(n, l));
            const float occlusion = 1.0f - ao(x, y);
            const float direct = aaf::ao_diffuse(glm::vec3(albedo), occlusion, n, l).x;
            const float ambient = albedo * ao(x, y) * aaf::sh_irradiance(sh, b).x / 3.14159265f;
            shaded(x, y) = std::min(1.0f, 0.7f * direct + 0.3f * ambient);
        }
    aaf::image<aaf::rgb8> bent_rgb(w, h);
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) {
            const auto c = [](float v) { return static_cast<std::uint8_t>(std::lround(255.0f * std::clamp(v, 0.0f, 1.0f))); };
            bent_rgb(x, y) = {c(br(x, y)), c(bg(x, y)), c(bb(x, y))};
        }
    out.colour_pictures.emplace_back("bent_normal", std::move(bent_rgb));
    out.pictures.emplace_back("bent_normal_r", std::move(br));
    out.pictures.emplace_back("bent_normal_g", std::move(bg));
    out.pictures.emplace_back("bent_normal_b", std::move(bb));
    out.pictures.emplace_back("diffuse", std::move(diffuse));
    out.pictures.emplace_back("ao_diffuse_ambient", std::move(shaded));
}

/// aaf_ao and its variants: `variant` changes the default frame settings (kernel, the authors' terms, or
/// no filter at all on the same samples).
method_output render_aaf_ao(const render_inputs& in, float mu, const std::function<void(aaf::ao_frame_settings<float>&)>& variant = {}) {
    const std::size_t w = in.g.positions.width(), h = in.g.positions.height();
    aaf::ao_frame_settings<float> s;
    s.sampling.max_distance = ao_max_distance(in.s);
    s.sampling.frame_seed = in.seed;
    s.filter.mu = mu;
    if (variant) variant(s);
    aaf::image<float> vis(w, h), beta(w, h);
    aaf::image<glm::vec3> bent(w, h);
    aaf::image<std::uint32_t> spp(w, h);
    method_output out;
    const auto t0 = clock_type::now();
    out.rays = aaf::render_ambient_occlusion(view_of(in.g), in.tracer, s,
                                             aaf::ao_outputs<float>{vis.view(), bent.view(), beta.view(), spp.view()}, {}, in.pool);
    out.total_ms = ms_since(t0);
    out.image = displayable_ao(vis, in.g);
    out.memory_bytes = w * h * (sizeof(aaf::ao_stats<float>) + 8 * sizeof(float));
    aaf::image<float> beta_px(w, h, 0.0f), samples(w, h, 0.0f);
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) {
            const float d = in.g.pixel_size(x, y);
            beta_px(x, y) = d > 0 && std::isfinite(beta(x, y) / d) ? beta(x, y) / d : 0.0f;
            samples(x, y) = static_cast<float>(spp(x, y));
        }
    // Heat maps (viridis; magenta = sky, or β = 0: not filtered): β in pixels on a log scale, samples linear.
    aaf::image<float> beta_heat(w, h), samples_heat(w, h);
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) {
            const bool surface = std::isfinite(in.g.positions(x, y).x);
            beta_heat(x, y) = surface && beta_px(x, y) > 0 ? beta_px(x, y) : std::numeric_limits<float>::quiet_NaN();
            samples_heat(x, y) = surface ? samples(x, y) : std::numeric_limits<float>::quiet_NaN();
        }
    aaf::image<aaf::rgb8> rgb(w, h);
    aaf::heat_map<float>(beta_heat.cview(), rgb.view(), {}, true);
    out.colour_pictures.emplace_back("ao_filter_width_heat", rgb);
    aaf::heat_map<float>(samples_heat.cview(), rgb.view());
    out.colour_pictures.emplace_back("ao_samples_heat", std::move(rgb));
    out.pictures.emplace_back("ao_filter_width_px", std::move(beta_px));
    out.pictures.emplace_back("ao_samples", std::move(samples));
    add_shading_pictures(out, in, out.image, bent);
    return out;
}

/// Shadow-map AO: `directions` orthographic depth maps of `resolution`² texels over the sphere, fitted
/// around the scene's vertices, with the AO reference's maximum distance as a per-receiver depth range.
method_output render_sm_ao(const render_inputs& in, std::uint32_t directions, std::uint32_t resolution) {
    const std::size_t w = in.g.positions.width(), h = in.g.positions.height();
    aaf::shadow_map_ao_settings<float> s;
    s.directions = std::max<std::uint32_t>(directions, 1);
    s.resolution = resolution;
    s.max_distance = ao_max_distance(in.s);
    aaf::image<float> vis(w, h);
    aaf::image<glm::vec3> bent(w, h);
    method_output out;
    const auto t0 = clock_type::now();
    const aaf::shadow_map_ao_stats st = aaf::shadow_map_ao(view_of(in.g), in.tracer, in.s.vertices, s, vis.view(), bent.view(), in.pool);
    out.total_ms = ms_since(t0);
    out.rays = st.map_rays;  // texel rays of the maps; the lookups trace none
    out.image = displayable_ao(vis, in.g);
    out.memory_bytes = st.map_bytes;  // one map live at a time (accumulators: 5 floats per pixel besides)
    add_shading_pictures(out, in, out.image, bent);
    return out;
}

}  // namespace

float ao_max_distance(const scene& s) {
    glm::vec3 lo(std::numeric_limits<float>::infinity()), hi(-lo);
    for (const glm::vec3& v : s.vertices) lo = glm::min(lo, v), hi = glm::max(hi, v);
    const float diag = glm::length(hi - lo);
    return diag > 0 && std::isfinite(diag) ? 0.2f * diag : std::numeric_limits<float>::infinity();
}

method_family occlusion_methods() {
    method_family f;
    const std::vector<double> spp_sweep{4, 8, 16, 32, 64, 128, 256};
    for (const auto& [name, pattern] : {std::pair{std::string("mc_ao_cosine"), aaf::sample_pattern::stratified},
                                        std::pair{std::string("mc_ao_low_discrepancy"), aaf::sample_pattern::low_discrepancy}}) {
        method m;
        m.name = name;
        m.family = "mc";  // unfiltered Monte Carlo, like the shadow baselines: aaf-tradeoff doubles its spp
        m.what = quantity::ambient_occlusion;
        m.knob = "spp";
        m.sweep = spp_sweep;
        m.doubling_sweep = true;
        m.default_knob = 16;
        m.help = std::string("Monte Carlo ambient occlusion, cosine-weighted ") + aaf::to_string(pattern) +
                 " hemisphere samples, unfiltered (any-hit rays)";
        m.settings = {{"density", "cosine"}, {"pattern", aaf::to_string(pattern)}, {"max_distance", "0.2 x scene diagonal"}};
        m.render = [pattern](const render_inputs& in, double knob) {
            return render_mc_ao(in, pattern, static_cast<std::uint32_t>(std::lround(knob)), in.seed);
        };
        f.methods.push_back(std::move(m));
    }
    method a;
    a.name = "aaf_ao";
    a.family = "occlusion";
    a.what = quantity::ambient_occlusion;
    a.knob = "mu";
    a.sweep = {1, 1.5, 2, 3, 4};
    a.default_knob = 2;
    a.help = "axis-aligned AO filter (Mehta et al. 2013): 16 cosine samples, adaptive n from z_min/z_max, guided filter";
    const aaf::ao_frame_settings<float> defaults;
    a.settings = {{"initial_samples", defaults.sampling.initial_samples},
                  {"max_samples", defaults.sampling.max_samples},
                  {"omega_h", defaults.filter.omega_h},
                  {"importance_scale", defaults.filter.importance_scale},
                  {"normal_threshold_degrees", defaults.filter.normal_threshold_degrees},
                  {"space", "tangent_plane"},
                  {"max_distance", "0.2 x scene diagonal"}};
    a.render = [](const render_inputs& in, double knob) { return render_aaf_ao(in, static_cast<float>(knob)); };
    f.methods.push_back(a);

    // Variants of aaf_ao on the same samples (same seed, same adaptive counts): the filter's gain at equal
    // rays, and the authors' kernel terms that aaf leaves out by default (docs/DEVIATIONS.md occlusion rows
    // 2, 3), measured through aaf-tradeoff --methods.
    using frame = aaf::ao_frame_settings<float>;
    const auto variant = [&](std::string name, std::string help, std::function<void(frame&)> change,
                             std::vector<std::pair<std::string, nlohmann::json>> extra) {
        method v = a;
        v.name = std::move(name);
        v.help = std::move(help);
        for (auto& [k, value] : extra) v.settings[k] = std::move(value);
        v.render = [change](const render_inputs& in, double knob) { return render_aaf_ao(in, static_cast<float>(knob), change); };
        f.methods.push_back(std::move(v));
    };
    variant("aaf_ao_unfiltered", "aaf_ao's samples (16 + adaptive n from z_min/z_max), not filtered: the filter's gain at equal rays",
            [](frame& s) { s.filtered = false; }, {{"filtered", false}});
    variant("aaf_ao_direct", "aaf_ao with the direct 2D kernel (ao_filter_kernel::direct) instead of the separable one",
            [](frame& s) { s.filter.kernel = aaf::ao_filter_kernel::direct; }, {{"kernel", "direct"}});
    variant("aaf_ao_50theta", "aaf_ao_direct with the authors' per-neighbour bandwidth (1 + 50 theta) (normal_angle_term = 50)",
            [](frame& s) {
                s.filter.kernel = aaf::ao_filter_kernel::direct;
                s.filter.normal_angle_term = 50;
            },
            {{"kernel", "direct"}, {"normal_angle_term", 50}});
    variant("aaf_ao_zreject", "aaf_ao_direct with the authors' rejection of neighbours farther than z_min (reject_beyond_z_min)",
            [](frame& s) {
                s.filter.kernel = aaf::ao_filter_kernel::direct;
                s.filter.reject_beyond_z_min = true;
            },
            {{"kernel", "direct"}, {"reject_beyond_z_min", true}});
    variant("aaf_ao_zclamp", "aaf_ao with z_min clamped to at least 0.1 world units (min_distance), as the authors' scene constant",
            [](frame& s) { s.filter.min_distance = 0.1f; }, {{"min_distance", 0.1}});
    variant("aaf_ao_boost", "aaf_ao with the authors' pre-filter rejection boost: n / (1 - fraction of the window rejected)",
            [](frame& s) { s.filter.rejection_boost = true; }, {{"rejection_boost", true}});
    variant("aaf_ao_authors", "aaf_ao_direct with both of the authors' terms (50 theta and |dp| < z_min rejection)",
            [](frame& s) {
                s.filter.kernel = aaf::ao_filter_kernel::direct;
                s.filter.normal_angle_term = 50;
                s.filter.reject_beyond_z_min = true;
            },
            {{"kernel", "direct"}, {"normal_angle_term", 50}, {"reject_beyond_z_min", true}});

    method m;
    m.name = "sm_ao";
    m.family = "occlusion";
    m.what = quantity::ambient_occlusion;
    m.knob = "directions";
    m.sweep = {4, 16, 64, 256};
    m.default_knob = 32;
    m.help = "shadow-map AO: N orthographic 256x256 depth maps over the sphere (Fibonacci), hard lookups with the "
             "automatic bias, cosine-weighted; max distance as a per-receiver depth range";
    m.settings = {{"resolution", 256}, {"format", "unorm24"}, {"bias", "automatic"}, {"max_distance", "0.2 x scene diagonal"}};
    m.render = [](const render_inputs& in, double knob) {
        return render_sm_ao(in, static_cast<std::uint32_t>(std::lround(knob)), 256);
    };
    f.methods.push_back(std::move(m));

    quantity_reference r;
    r.what = quantity::ambient_occlusion;
    r.name = "ambient_occlusion";
    r.baseline_method = "mc_ao_cosine";
    // Pass 1000 + seed keeps the reference's samples apart from every measured render's (passes 0 and 1).
    r.render = [](const render_inputs& in, std::uint32_t samples, std::uint32_t seed) {
        return render_mc_ao(in, aaf::sample_pattern::stratified, samples, seed, 1000).image;
    };
    f.references.push_back(std::move(r));
    return f;
}

}  // namespace aaf_examples
