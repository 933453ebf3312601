// SPDX-License-Identifier: MIT
// The shadow family of the method registry: unfiltered Monte Carlo (the equal-error baselines), aaf with
// its variants over μ or a fixed sample count, aaf's presets, and the converged shadow reference.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <utility>

#include <aaf/pipeline.hpp>
#include <aaf/settings.hpp>

#include "common/methods.hpp"

namespace aaf_examples {

namespace {

using json = nlohmann::json;

/// The adaptive sweeps' cap on samples per pixel: ∝ μ², 100 at the paper's μ = 2 (the formulas' n grows
/// as μ², so the cap binds equally often at every μ).
std::uint32_t max_samples_for_mu(double mu) { return static_cast<std::uint32_t>(std::lround(100.0 * (mu / 2) * (mu / 2))); }

method mc_method(std::string name, aaf::sample_pattern pattern, std::string description) {
    json j;
    j["description"] = description;
    j["weighting"] = "uniform";
    j["ray_origin_offset"] = "automatic (ULP offsetting)";
    j["pattern"] = aaf::to_string(pattern);
    j["knob"] = "spp: samples per surface pixel, doubling from 1";
    j["tracer"] = "BVH any-hit (visibility only)";
    j["filter"] = "none";
    j["sample_pass"] = 0;
    return method{
        .name = std::move(name),
        .family = "mc",
        .what = quantity::shadow,
        .knob = "spp",
        .sweep = {},
        .quick_sweep = {},
        .doubling_sweep = true,
        .default_knob = 16,
        .help = std::move(description),
        .settings = std::move(j),
        .render =
            [pattern](const render_inputs& in, double knob) {
                mc_result r = render_mc(in.s, in.g, in.tracer,
                                        {.pattern = pattern, .spp = static_cast<std::uint32_t>(knob), .seed = in.seed, .pass = 0}, in.pool);
                method_output out;
                out.image = std::move(r.visibility);
                out.total_ms = r.total_ms;
                out.rays = r.rays;
                out.stages_ms = {{"rays", r.rays_ms}};
                return out;
            },
        .own_reference = {},
    };
}

/// How an aaf point differs from the library's defaults.
struct aaf_variant {
    enum class knob_kind { mu, initial_samples, preset } knob = knob_kind::mu;
    aaf::offset_space space = aaf::offset_space::image;
    bool first_hit = false;
    bool guides = true;
    aaf::frame_preset preset = aaf::frame_preset::balanced;
    aaf::shadow_query adaptive_query = aaf::sampling_settings{}.adaptive_query;  ///< the library's default unless named
    aaf::pixel_footprint footprint = aaf::pixel_footprint::camera;               ///< tilt-aware widths unless camera
    float min_stretch = 1;                                      ///< filter_settings::footprint_min_stretch
    aaf::light_profile light = aaf::light_profile::gaussian;   ///< formula_settings::light (issue 13's box-matched β)
    aaf::sample_pattern pattern = aaf::sampling_settings{}.pattern;  ///< the library's default unless named
    float light_scale = 1;                                      ///< formula_settings::light_scale (issue 13)
    bool horizon = false;                                       ///< filter_settings::unfiltered_at_horizon (issue 13)
};

/// The settings of one point of an aaf or preset method.
aaf::frame_settings<float> aaf_settings(const aaf_variant& v, double knob, std::uint32_t seed, float radiance) {
    using k = aaf_variant::knob_kind;
    aaf::frame_settings<float> fs = v.knob == k::preset ? aaf::preset<float>(v.preset) : aaf::frame_settings<float>{};
    if (v.knob == k::initial_samples) {
        fs.sampling.initial_samples = fs.sampling.max_samples = static_cast<std::uint32_t>(knob);
        fs.sampling.adaptive = false;
    } else if (v.knob == k::mu) {
        fs.formulas.mu = static_cast<float>(knob);
        fs.sampling.initial_samples = 9;
        fs.sampling.max_samples = std::max<std::uint32_t>(9, max_samples_for_mu(knob));
    }
    if (v.knob != k::preset) {
        fs.filter.space = v.space;
        fs.sampling.adaptive_query = v.adaptive_query;
        fs.filter.footprint = v.footprint;
        fs.filter.footprint_min_stretch = v.min_stretch;
        fs.formulas.light = v.light;
        fs.formulas.light_scale = v.light_scale;
        fs.filter.unfiltered_at_horizon = v.horizon;
        fs.sampling.pattern = v.pattern;
        // render_frame always filters with normals (and IDs when the G-buffer has them): a threshold of
        // 180° accepts every finite normal, which is the normal guide switched off.
        if (!v.guides) fs.filter.normal_threshold_degrees = 180;
    }
    fs.sampling.frame_seed = seed;
    fs.radiance = radiance;
    return fs;
}

json aaf_settings_json(const aaf_variant& v, const std::string& description) {
    using k = aaf_variant::knob_kind;
    json j;
    j["description"] = description;
    j["weighting"] = "uniform";
    j["ray_origin_offset"] = "automatic (ULP offsetting)";
    // Everything that defines an aaf frame, from the settings of its first point (the knob's fields vary).
    const aaf::frame_settings<float> fs = aaf_settings(v, v.knob == k::initial_samples ? 9.0 : 2.0, 0, 1.0f);
    j["pattern"] = aaf::to_string(fs.sampling.pattern);
    if (v.knob == k::preset) {
        j["knob"] = "none (one point)";
        j["initial_samples"] = fs.sampling.initial_samples;
        j["max_samples"] = fs.sampling.max_samples;
        j["mu"] = fs.formulas.mu;
    } else if (v.knob == k::initial_samples) {
        j["knob"] = "initial_samples = max_samples (fixed samples per pixel)";
        j["mu"] = fs.formulas.mu;
    } else {
        j["knob"] = "mu";
        j["initial_samples"] = fs.sampling.initial_samples;
        j["max_samples_rule"] = "max(9, round(100 * (mu / 2)^2)): proportional to mu^2, 100 at mu = 2";
    }
    j["adaptive"] = fs.sampling.adaptive;
    if (fs.sampling.adaptive)
        j["adaptive_query"] = fs.sampling.adaptive_query == aaf::shadow_query::visibility ? "visibility" : "distances";
    j["offsets"] = fs.filter.space == aaf::offset_space::light_plane ? "light_plane" : "image";
    j["footprint"] = fs.filter.footprint == aaf::pixel_footprint::camera         ? "camera"
                     : fs.filter.footprint == aaf::pixel_footprint::surface_area ? "surface_area"
                     : fs.filter.footprint == aaf::pixel_footprint::surface_max  ? "surface_max"
                     : fs.filter.footprint == aaf::pixel_footprint::surface_axes ? "surface_axes (s_x horizontal, s_y vertical)"
                                                                                 : "light_axes (s_x, s_y projected on the light's plane)";
    if (fs.filter.footprint != aaf::pixel_footprint::camera) j["footprint_min_stretch"] = fs.filter.footprint_min_stretch;
    j["light_profile"] = fs.formulas.light == aaf::light_profile::box ? "box (beta's light term uses sigma/sqrt 3)" : "gaussian";
    j["light_scale"] = fs.formulas.light_scale;
    j["unfiltered_at_horizon"] = fs.filter.unfiltered_at_horizon;
    json guides = json::array();
    if (v.guides) guides.push_back("normals"), guides.push_back("ids");
    if (fs.filter.space == aaf::offset_space::light_plane) guides.push_back("positions");
    j["guides"] = guides;
    j["normal_threshold_degrees"] = fs.filter.normal_threshold_degrees;
    j["stats"] = v.first_hit ? "first_hit" : "all_hits";
    j["tracer"] = v.first_hit ? "BVH nearest occluder" : "BVH nearest and farthest occluder";
    // Both tracers answer occluded(), which a visibility-only adaptive pass asks instead.
    if (fs.sampling.adaptive && fs.sampling.adaptive_query == aaf::shadow_query::visibility)
        j["tracer"] = j["tracer"].get<std::string>() + "; any-hit in the adaptive pass";
    j["formula_form"] = fs.formulas.form == aaf::formula_form::paper ? "paper" : "authors";
    j["k"] = fs.formulas.k;
    j["alpha"] = fs.formulas.alpha;
    j["truncation"] = fs.filter.truncation;
    j["max_radius"] = fs.filter.max_radius;
    j["spread_slopes"] = fs.filter.spread_slopes;
    j["spread_radius"] = fs.filter.spread_radius;
    j["spread_guide"] = v.guides ? "ids" : "none";
    return j;
}

/// One aaf frame with `tracer` into `out`.
template <class Ids, class Tracer>
void render_aaf(const aaf::gbuffer<float, Ids>& gb, const render_inputs& in, const Tracer& tracer, const aaf::frame_settings<float>& fs,
                method_output& out) {
    aaf::frame_workspace<float> ws;
    ws.resize(in.s.width, in.s.height);  // allocation is not part of a frame
    const aaf::frame_report rep = aaf::render_frame(gb, in.s.light, tracer, {out.image.view()}, ws, fs, in.pool);
    out.rays = rep.rays();
    out.total_ms = rep.total_ms;
    out.stages_ms = {{"rays", rep.initial_ms + rep.adaptive_ms}, {"formulas", rep.formulas_ms}, {"filter", rep.filter_ms}};
}

method aaf_method(std::string name, std::string family, aaf_variant v, std::string description) {
    using k = aaf_variant::knob_kind;
    method m{
        .name = std::move(name),
        .family = std::move(family),
        .what = quantity::shadow,
        .knob = v.knob == k::preset ? "preset" : v.knob == k::initial_samples ? "initial_samples" : "mu",
        .sweep = v.knob == k::preset ? std::vector<double>{0} : v.knob == k::initial_samples ? std::vector<double>{4, 9, 16, 25, 36}
                                                                                               : std::vector<double>{1, 1.5, 2, 3, 4},
        .quick_sweep = v.knob == k::preset ? std::vector<double>{0} : v.knob == k::initial_samples ? std::vector<double>{4, 16}
                                                                                                     : std::vector<double>{1, 2},
        .doubling_sweep = false,
        .default_knob = v.knob == k::preset ? 0.0 : v.knob == k::initial_samples ? 9.0 : 2.0,
        .help = description,
        .settings = aaf_settings_json(v, description),
        .render = {},
        .own_reference = {},
    };
    m.render = [v](const render_inputs& in, double knob) {
        const aaf::frame_settings<float> fs = aaf_settings(v, knob, in.seed, in.s.radiance);
        method_output out;
        out.image = aaf::image<float>(in.s.width, in.s.height);
        const gbuffer_images& g = in.g;
        const auto render = [&](const auto& gb) {  // with the method's tracer
            if (v.first_hit) render_aaf(gb, in, first_hit_tracer{&in.tracer}, fs, out);
            else render_aaf(gb, in, in.tracer, fs, out);
        };
        if (v.guides)
            render(aaf::gbuffer<float, aaf::const_image_view<std::uint32_t>>{g.positions.cview(), g.normals.cview(), g.pixel_size.cview(),
                                                                             g.ids.cview()});
        else
            render(aaf::gbuffer<float>{g.positions.cview(), g.normals.cview(), g.pixel_size.cview()});
        out.point_settings = {{"initial_samples", fs.sampling.initial_samples}, {"max_samples", fs.sampling.max_samples}, {"mu", fs.formulas.mu}};
        return out;
    };
    return m;
}

}  // namespace

method_family shadow_methods() {
    using aaf::offset_space;
    using aaf::sample_pattern;
    using k = aaf_variant::knob_kind;
    method_family f;
    f.methods = {
        mc_method("mc_stratified", sample_pattern::stratified, "unfiltered Monte Carlo, jittered equal-area strata (the equal-error baseline)"),
        mc_method("mc_regular_grid", sample_pattern::regular_grid, "unfiltered Monte Carlo, strata centres, same in every pixel"),
        mc_method("mc_low_discrepancy", sample_pattern::low_discrepancy, "unfiltered Monte Carlo, Owen-scrambled Sobol'"),
        aaf_method("aaf_fixed", "aaf", {.knob = k::initial_samples}, "aaf filter on a fixed sample count, no adaptive pass"),
        aaf_method("aaf_adaptive", "aaf", {},
                   "aaf: 9 initial samples, visibility-only adaptive pass, image-space offsets, all-hits statistics, normal and ID guides"),
        aaf_method("aaf_light_plane", "aaf", {.space = offset_space::light_plane},
                   "as aaf_adaptive with light-parallel world offsets (positions guide)"),
        aaf_method("aaf_first_hit", "aaf", {.first_hit = true}, "as aaf_adaptive with first-hit statistics (nearest occluder only)"),
        aaf_method("aaf_no_guides", "aaf", {.guides = false}, "as aaf_adaptive without normal and ID guides"),
        aaf_method("aaf_refined_slopes", "aaf", {.adaptive_query = aaf::shadow_query::distances},
                   "as aaf_adaptive with adaptive rays that also find occluder distances and refine the slopes (shadow_query::distances)"),
        aaf_method("aaf_tilt_area", "aaf", {.footprint = aaf::pixel_footprint::surface_area},
                   "as aaf_adaptive with tilt-aware widths: beta over the pixel's footprint on its surface, sqrt(s_x s_y)"),
        aaf_method("aaf_tilt_max", "aaf", {.footprint = aaf::pixel_footprint::surface_max},
                   "as aaf_adaptive with tilt-aware widths: beta over the longer side of the pixel's footprint on its surface"),
        aaf_method("aaf_box", "aaf", {.light = aaf::light_profile::box},
                   "as aaf_adaptive with beta matched to the uniform light's standard deviation sigma/sqrt 3 (light_profile::box)"),
        aaf_method("aaf_box_tilt", "aaf", {.footprint = aaf::pixel_footprint::surface_area, .light = aaf::light_profile::box},
                   "aaf_box with tilt-aware widths (surface_area)"),
        aaf_method("aaf_tilt_ld", "aaf", {.footprint = aaf::pixel_footprint::surface_area, .pattern = aaf::sample_pattern::low_discrepancy},
                   "aaf_tilt_area with Owen-scrambled Sobol' light samples (sample_pattern::low_discrepancy)"),
        aaf_method("aaf_box_ld", "aaf", {.light = aaf::light_profile::box, .pattern = aaf::sample_pattern::low_discrepancy},
                   "aaf_box with Owen-scrambled Sobol' light samples"),
        aaf_method("aaf_box_tilt_ld", "aaf",
                   {.footprint = aaf::pixel_footprint::surface_area, .light = aaf::light_profile::box, .pattern = aaf::sample_pattern::low_discrepancy},
                   "aaf_box_tilt with Owen-scrambled Sobol' light samples"),
        aaf_method("aaf_axes", "aaf", {.footprint = aaf::pixel_footprint::surface_axes},
                   "as aaf_adaptive with per-axis tilt-aware widths: beta/s_x horizontally, beta/s_y vertically (surface_axes)"),
        aaf_method("aaf_axes_box", "aaf", {.footprint = aaf::pixel_footprint::surface_axes, .light = aaf::light_profile::box},
                   "aaf_axes with the box-matched width (light_profile::box)"),
        aaf_method("aaf_axes_ld", "aaf", {.footprint = aaf::pixel_footprint::surface_axes, .pattern = aaf::sample_pattern::low_discrepancy},
                   "aaf_axes with Owen-scrambled Sobol' light samples"),
        aaf_method("aaf_axes_box_ld", "aaf",
                   {.footprint = aaf::pixel_footprint::surface_axes, .light = aaf::light_profile::box, .pattern = aaf::sample_pattern::low_discrepancy},
                   "aaf_axes_box with Owen-scrambled Sobol' light samples"),
        aaf_method("aaf_axes_ld90", "aaf",
                   {.footprint = aaf::pixel_footprint::surface_axes, .pattern = aaf::sample_pattern::low_discrepancy, .light_scale = 0.9f},
                   "aaf_axes_ld with beta's light term at 0.9 sigma (formula_settings::light_scale, between the Gaussian's sigma and "
                   "the box's sigma/sqrt 3)"),
        aaf_method("aaf_axes_ld_hz", "aaf",
                   {.footprint = aaf::pixel_footprint::surface_axes, .pattern = aaf::sample_pattern::low_discrepancy, .horizon = true},
                   "aaf_axes_ld with pixels whose tangent plane cuts the light left unfiltered (filter_settings::unfiltered_at_horizon)"),
        aaf_method("aaf_one", "aaf",
                   {.footprint = aaf::pixel_footprint::surface_axes,
                    .pattern = aaf::sample_pattern::low_discrepancy,
                    .light_scale = 0.9f,
                    .horizon = true},
                   "aaf_axes_ld90 with unfiltered_at_horizon: the one configuration with >= 3x fewer rays than stratified MC at mu = 2 "
                   "on all ten scenes (docs/RESULTS.md, issue 13)"),
        aaf_method("aaf_one95", "aaf",
                   {.footprint = aaf::pixel_footprint::surface_axes,
                    .pattern = aaf::sample_pattern::low_discrepancy,
                    .light_scale = 0.95f,
                    .horizon = true},
                   "aaf_one with light_scale 0.95: a thinner margin on the blinds, a smaller cost on car and tentacles "
                   "(docs/RESULTS.md, issue 13)"),
        aaf_method("aaf_laxes", "aaf", {.footprint = aaf::pixel_footprint::light_axes},
                   "as aaf_axes with the per-axis steps projected on the light's plane (light_axes)"),
        aaf_method("aaf_laxes_ld", "aaf", {.footprint = aaf::pixel_footprint::light_axes, .pattern = aaf::sample_pattern::low_discrepancy},
                   "aaf_laxes with Owen-scrambled Sobol' light samples"),
        aaf_method("aaf_laxes_box_ld", "aaf",
                   {.footprint = aaf::pixel_footprint::light_axes, .light = aaf::light_profile::box, .pattern = aaf::sample_pattern::low_discrepancy},
                   "aaf_laxes with the box-matched width and Owen-scrambled Sobol' light samples"),
        aaf_method("aaf_lp_box", "aaf", {.space = offset_space::light_plane, .light = aaf::light_profile::box},
                   "aaf_light_plane with the box-matched width (light_profile::box)"),
        aaf_method("aaf_lp_box_ld", "aaf",
                   {.space = offset_space::light_plane, .light = aaf::light_profile::box, .pattern = aaf::sample_pattern::low_discrepancy},
                   "aaf_lp_box with Owen-scrambled Sobol' light samples"),
        aaf_method("preset_fast", "preset", {.knob = k::preset, .preset = aaf::frame_preset::fast}, "aaf::preset(frame_preset::fast)"),
        aaf_method("preset_balanced", "preset", {.knob = k::preset, .preset = aaf::frame_preset::balanced},
                   "aaf::preset(frame_preset::balanced)"),
        aaf_method("preset_accurate", "preset", {.knob = k::preset, .preset = aaf::frame_preset::accurate},
                   "aaf::preset(frame_preset::accurate)"),
    };
    // AAF_SHADOW_SWEEP=1 registers the footprint_min_stretch candidates of docs/RESULTS.md (issue 13).
    const char* sweep = std::getenv("AAF_SHADOW_SWEEP");
    if (sweep != nullptr && std::string(sweep) == "1")
        for (float t : {1.25f, 1.5f, 2.0f, 3.0f}) {
            const std::string tag = t == 1.25f ? "125" : t == 1.5f ? "15" : std::to_string(static_cast<int>(t));
            f.methods.push_back(aaf_method("aaf_tilt_s" + tag, "aaf", {.footprint = aaf::pixel_footprint::surface_area, .min_stretch = t},
                                           "sweep candidate: aaf_tilt_area only where the pixel is stretched at least " +
                                               std::to_string(t) + "x (footprint_min_stretch)"));
        }
    f.references = {quantity_reference{
        .what = quantity::shadow,
        .name = "shadow",
        .baseline_method = "mc_stratified",
        .render =
            [](const render_inputs& in, std::uint32_t samples, std::uint32_t seed) {
                reference_result r = reference_visibility(in.s, in.g, in.tracer, {.spp = samples, .seed = seed}, in.cache, in.pool, in.progress);
                return reference_output(displayable(r.visibility, in.g), r.ms, r.from_cache);
            },
    }};
    return f;
}

}  // namespace aaf_examples
