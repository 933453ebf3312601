// SPDX-License-Identifier: MIT
// The variants family of the method registry: the image-space denoisers a renderer author would apply to
// stratified Monte Carlo instead of aaf (the guided à-trous filter of SVGF, a joint bilateral filter), at
// every spp, with the settings chosen by the parameter sweep of docs/RESULTS.md ("Peers and variants").
// With AAF_VARIANTS_SWEEP=1 in the environment the sweep's candidate settings are registered too
// (atrous_i<iterations>_l<luminance sigma, 0 = off>, bilateral_s<sigma px>), so aaf-tradeoff can rerun it.

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <algorithm>
#include <string>
#include <utility>
#include <vector>

#include <aaf/variants.hpp>

#include "common/methods.hpp"

namespace aaf_examples {

namespace {

using json = nlohmann::json;

/// Which peer and its fixed settings.
struct peer {
    enum class kind { atrous, bilateral } what = kind::atrous;
    aaf::atrous_settings<float> atrous{};
    aaf::bilateral_settings<float> bilateral{};
    bool luminance = true;  ///< à-trous: the variance-driven luminance stop (variance from estimate_mean_variance)
};

json peer_json(const peer& p, const std::string& description) {
    json j;
    j["description"] = description;
    j["input"] = "mc_stratified at the knob's spp (same samples as mc_stratified, seed and pass 0)";
    j["knob"] = "spp";
    j["guides"] = {"normals", "ids", "positions"};
    if (p.what == peer::kind::atrous) {
        j["filter"] = "guided a-trous (5x5 B3, step doubling)";
        j["iterations"] = p.atrous.iterations;
        j["normal_power"] = p.atrous.edges.normal_power;
        j["plane_sigma"] = p.atrous.edges.plane_sigma;
        j["luminance_stop"] = p.luminance;
        if (p.luminance) {
            j["luminance_sigma"] = p.atrous.luminance_sigma;
            j["variance"] = "Bernoulli m(1-m)/spp of the 3x3 same-ID mean (aaf::estimate_mean_variance)";
        }
    } else {
        j["filter"] = "joint bilateral (2-D Gaussian with G-buffer edge stops)";
        j["sigma_pixels"] = p.bilateral.sigma_pixels;
        j["truncation"] = p.bilateral.truncation;
        j["normal_power"] = p.bilateral.edges.normal_power;
        j["plane_sigma"] = p.bilateral.edges.plane_sigma;
    }
    return j;
}

method peer_method(std::string name, peer p, std::string description) {
    method m{
        .name = std::move(name),
        .family = "variants",
        .what = quantity::shadow,
        .knob = "spp",
        .sweep = {1, 2, 4, 8, 16, 32, 64, 128},
        .quick_sweep = {1, 4},
        .doubling_sweep = false,
        .default_knob = 4,
        .help = description,
        .settings = peer_json(p, description),
        .render = {},
        .own_reference = {},
    };
    m.render = [p](const render_inputs& in, double knob) {
        const auto spp = static_cast<std::uint32_t>(knob);
        mc_result mc = render_mc(in.s, in.g, in.tracer, {.pattern = aaf::sample_pattern::stratified, .spp = spp, .seed = in.seed, .pass = 0}, in.pool);
        const auto t0 = clock_type::now();
        const gbuffer_images& g = in.g;
        const aaf::guides guides{g.normals.cview(), g.ids.cview(), g.positions.cview()};
        method_output out;
        out.image = aaf::image<float>(in.s.width, in.s.height);
        if (p.what == peer::kind::atrous) {
            aaf::image<float> scratch(in.s.width, in.s.height), variance;
            if (p.luminance) {
                variance.reset(in.s.width, in.s.height);
                aaf::estimate_mean_variance<float>(mc.visibility, static_cast<float>(spp), variance.view(), guides, in.pool);
            }
            aaf::atrous_filter<float>(mc.visibility, variance.cview(), g.pixel_size, out.image.view(), scratch.view(), guides, p.atrous, in.pool);
        } else {
            aaf::bilateral_filter<float>(mc.visibility, g.pixel_size, out.image.view(), guides, p.bilateral, in.pool);
        }
        const double filter_ms = ms_since(t0);
        for (std::size_t i = 0; i < out.image.size(); ++i)  // displayable, as mc_stratified: sky 1
            if (!g.surface(i)) out.image.data()[i] = 1.0f;
        out.total_ms = mc.total_ms + filter_ms;
        out.rays = mc.rays;
        out.stages_ms = {{"rays", mc.rays_ms}, {"filter", filter_ms}};
        return out;
    };
    return m;
}

/// Progressive aaf: `knob` passes of 9 stratified samples each into one aaf::progressive_shadow, μ matched
/// to each pixel's accumulated samples (mu_schedule::matched_samples, μ_1 = 2); the image after the last
/// pass, the time and rays of all passes.
method progressive_method() {
    json j;
    j["description"] = "progressive aaf: passes of 9 stratified samples accumulated per pixel, each pixel's mu raised until n(mu) matches its samples";
    j["knob"] = "passes";
    j["samples_per_pass"] = 9;
    j["mu_first_pass"] = 2;
    j["schedule"] = "matched_samples";
    j["offsets"] = "image";
    j["guides"] = {"normals", "ids"};
    j["tracer"] = "BVH nearest and farthest occluder";
    method m{
        .name = "aaf_progressive",
        .family = "variants",
        .what = quantity::shadow,
        .knob = "passes",
        .sweep = {1, 2, 4, 8, 16},
        .quick_sweep = {1, 2},
        .doubling_sweep = false,
        .default_knob = 4,
        .help = "progressive aaf (aaf::progressive_shadow): 9 samples per pass, per-pixel mu matched to its samples; knob = passes",
        .settings = std::move(j),
        .render = {},
        .own_reference = {},
    };
    m.render = [](const render_inputs& in, double knob) {
        const gbuffer_images& g = in.g;
        const aaf::gbuffer<float, aaf::const_image_view<std::uint32_t>> gb{g.positions.cview(), g.normals.cview(), g.pixel_size.cview(),
                                                                          g.ids.cview()};
        aaf::progressive_settings<float> ps;
        ps.frame.sampling.initial_samples = 9;
        ps.frame.sampling.frame_seed = in.seed;
        ps.frame.radiance = in.s.radiance;
        aaf::progressive_shadow<float> prog;
        prog.reset(in.s.width, in.s.height);  // allocation is not part of a frame
        method_output out;
        out.image = aaf::image<float>(in.s.width, in.s.height);
        double rays_ms = 0, formulas_ms = 0, filter_ms = 0;
        const auto passes = static_cast<std::uint32_t>(knob);
        for (std::uint32_t p = 0; p < passes; ++p) {
            const aaf::frame_report r = prog.add_pass(gb, in.s.light, in.tracer, {out.image.view()}, ps, in.pool);
            out.total_ms += r.total_ms;
            rays_ms += r.initial_ms, formulas_ms += r.formulas_ms, filter_ms += r.filter_ms;
        }
        out.rays = prog.rays();
        out.stages_ms = {{"rays", rays_ms}, {"formulas", formulas_ms}, {"filter", filter_ms}};
        out.point_settings = {{"passes", passes}, {"samples_per_pixel", 9 * passes}};
        return out;
    };
    return m;
}

/// The sheared filter (aaf::render_sheared, variants/sheared.hpp): `knob` samples per pixel kept with their
/// light coordinates; pixels whose s1/s2 exceeds `max_slope_ratio` (or that are pixel-limited, or have no
/// slopes but occluders nearby) fall back to aaf with its adaptive samples at mu = 2 (max 100); +inf = never.
/// Unset options keep the library's defaults (sheared_settings).
struct sheared_options {
    float max_slope_ratio = aaf::sheared_settings<float>{}.max_slope_ratio;
    float shear_tolerance = aaf::sheared_settings<float>{}.shear_tolerance;
    std::uint32_t max_radius = aaf::sheared_settings<float>{}.max_radius;
    std::uint32_t bins = aaf::sheared_settings<float>{}.bins;
    float bin_margin = aaf::sheared_settings<float>{}.bin_margin;
    float width_scale = aaf::sheared_settings<float>{}.width_scale;
    float narrowing_pixels = aaf::sheared_settings<float>{}.narrowing_pixels;
    bool per_sample_depth = aaf::sheared_settings<float>{}.per_sample_depth;
    std::vector<double> sweep = {1, 2, 4, 9, 16, 25};  ///< samples kept per pixel
    /// 0: the knob is every pixel's samples (one pass). Otherwise every pixel gets min(knob, first_pass)
    /// and the centres end with the knob's (sheared_settings::centre_samples).
    std::uint32_t first_pass = 0;
    aaf::sample_pattern pattern = aaf::sample_pattern::stratified;
    /// 0: the fallback pixels keep aaf at μ = 2. Otherwise the knob at which their μ starts growing as
    /// 2·√(knob / this) (aaf's samples grow about as μ², the centres' as the knob), cap 25·μ² samples.
    double fallback_grows_from = 0;
};

/// The settings of the sheared entries registered before the narrowing (docs/RESULTS.md's first tables).
sheared_options before_narrowing(sheared_options o) {
    o.bins = 4, o.bin_margin = 0.5f, o.narrowing_pixels = 0.0f, o.per_sample_depth = false;
    return o;
}

method sheared_method(std::string name, std::string description, sheared_options o = {}) {
    aaf::sheared_settings<float> base;
    base.max_slope_ratio = o.max_slope_ratio;
    base.shear_tolerance = o.shear_tolerance;
    base.max_radius = o.max_radius;
    base.bins = o.bins;
    base.bin_margin = o.bin_margin;
    base.width_scale = o.width_scale;
    base.narrowing_pixels = o.narrowing_pixels;
    base.per_sample_depth = o.per_sample_depth;
    base.frame.sampling.pattern = o.pattern;
    json j;
    j["description"] = description;
    j["knob"] = o.first_pass == 0 ? "initial_samples (samples stored per pixel, stratified)"
                                  : "centre_samples (samples a sheared centre ends with; every pixel first gets min(knob, first_pass))";
    if (o.first_pass != 0) j["first_pass"] = o.first_pass;
    if (o.fallback_grows_from > 0)
        j["fallback_mu"] = "2 * sqrt(knob / " + std::to_string(static_cast<int>(o.fallback_grows_from)) +
                           ") above that knob, else 2; fallback max_samples 25 mu^2";
    j["pattern"] = o.pattern == aaf::sample_pattern::low_discrepancy ? "low_discrepancy (a centre's second pass continues its sequence)"
                   : o.pattern == aaf::sample_pattern::regular_grid  ? "regular_grid"
                                                                     : "stratified";
    j["max_slope_ratio"] = std::isinf(o.max_slope_ratio) ? json("inf") : json(o.max_slope_ratio);
    j["shear_tolerance"] = base.shear_tolerance;
    j["bins_per_light_width"] = base.bins;
    j["bin_margin"] = base.bin_margin;
    j["max_radius"] = base.max_radius;
    j["width_scale"] = base.width_scale;
    j["narrowing_pixels"] = base.narrowing_pixels;
    j["per_sample_depth"] = base.per_sample_depth;
    j["mu"] = base.frame.formulas.mu;
    j["k"] = base.frame.formulas.k;
    j["fallback"] = "aaf: adaptive visibility samples n(mu), max 100, image-space offsets, normal and ID guides";
    j["guides"] = {"normals", "ids"};
    j["tracer"] = "BVH nearest and farthest occluder";
    method m{
        .name = std::move(name),
        .family = "variants",
        .what = quantity::shadow,
        .knob = o.first_pass == 0 ? "initial_samples" : "centre_samples",
        .sweep = o.sweep,
        .quick_sweep = {1, 4},
        .doubling_sweep = false,
        .default_knob = 4,
        .help = description,
        .settings = std::move(j),
        .render = {},
        .own_reference = {},
    };
    m.render = [base, first_pass = o.first_pass, grows_from = o.fallback_grows_from](const render_inputs& in, double knob) {
        const gbuffer_images& g = in.g;
        const aaf::gbuffer<float, aaf::const_image_view<std::uint32_t>> gb{g.positions.cview(), g.normals.cview(), g.pixel_size.cview(),
                                                                          g.ids.cview()};
        aaf::sheared_settings<float> s = base;
        const auto samples = static_cast<std::uint32_t>(knob);
        s.frame.sampling.initial_samples = first_pass == 0 ? samples : std::min(samples, first_pass);
        s.centre_samples = first_pass == 0 ? 0 : samples;
        s.frame.sampling.max_samples = std::max<std::uint32_t>(100, s.frame.sampling.initial_samples);
        if (grows_from > 0 && knob > grows_from) {
            s.fallback_mu = static_cast<float>(2.0 * std::sqrt(knob / grows_from));
            const double mu = static_cast<double>(s.fallback_mu);
            s.frame.sampling.max_samples = std::max(s.frame.sampling.max_samples, static_cast<std::uint32_t>(std::ceil(25.0 * mu * mu)));
        }
        s.frame.sampling.frame_seed = in.seed;
        s.frame.radiance = in.s.radiance;
        aaf::sheared_workspace<float> ws;
        ws.resize(in.s.width, in.s.height, s);  // allocation is not part of a frame (as aaf's frame_workspace)
        method_output out;
        out.image = aaf::image<float>(in.s.width, in.s.height);
        const aaf::frame_report r = aaf::render_sheared(gb, in.s.light, in.tracer, {out.image.view()}, ws, s, in.pool);
        std::size_t centres = 0;
        aaf::image<float> centre_picture(in.s.width, in.s.height);  // 1 where the sheared filter gave the pixel
        std::vector<unsigned char> centre_region(in.s.width * in.s.height, 0);
        for (std::size_t y = 0; y < in.s.height; ++y)
            for (std::size_t x = 0; x < in.s.width; ++x) {
                const bool c = ws.shears(x, y).center;
                centre_picture(x, y) = c ? 1.0f : 0.0f;
                centre_region[y * in.s.width + x] = c ? 1 : 0;
                centres += c ? 1 : 0;
            }
        out.pictures.emplace_back("centres", std::move(centre_picture));
        out.regions.emplace_back("sheared_centres", std::move(centre_region));
        out.total_ms = r.total_ms;
        out.rays = r.rays();
        out.stages_ms = {{"rays", r.initial_ms + r.adaptive_ms}, {"formulas", r.formulas_ms}, {"filter", r.filter_ms}};
        out.point_settings = {{"initial_samples", s.frame.sampling.initial_samples},
                              {"fallback_mu", s.fallback_mu > 0 ? s.fallback_mu : s.frame.formulas.mu},
                              {"centre_samples", s.samples_per_centre()},
                              {"sheared_pixels", centres},
                              {"sample_bytes", ws.samples.bytes()},
                              {"bin_bytes", ws.bins.size() * sizeof(ws.bins[0])}};
        return out;
    };
    return m;
}

peer atrous_peer(std::uint32_t iterations, float luminance_sigma) {
    peer p;
    p.atrous.iterations = iterations;
    p.luminance = luminance_sigma > 0;
    if (p.luminance) p.atrous.luminance_sigma = luminance_sigma;
    return p;
}

peer bilateral_peer(float sigma) {
    peer p;
    p.what = peer::kind::bilateral;
    p.bilateral.sigma_pixels = sigma;
    return p;
}

}  // namespace

method_family variant_methods() {
    method_family f;
    constexpr float inf = std::numeric_limits<float>::infinity();
    // Settings from the sweep of docs/RESULTS.md ("Peers and variants"): every candidate at 1-64 spp on
    // cornell and plant, ranked by the rays each needs to reach aaf_adaptive's error at mu = 2. Without
    // the luminance stop, and for the bilateral filter at any width, the peers keep a bias floor (they blur
    // across the visibility edges no G-buffer edge marks: the light plane's line on the walls, contact
    // shadows), so only narrow settings are registered.
    f.methods = {
        peer_method("mc_atrous", atrous_peer(2, 2),
                    "stratified MC at spp, then the guided a-trous filter (SVGF's spatial part): 2 iterations, "
                    "normal/plane/ID stops, luminance stop sigma_l = 2 (best on cornell)"),
        peer_method("mc_atrous_l4", atrous_peer(2, 4),
                    "as mc_atrous with SVGF's luminance stop sigma_l = 4 (best on plant)"),
        peer_method("mc_bilateral", bilateral_peer(1),
                    "stratified MC at spp, then a joint bilateral filter (sigma 1 px, normal/plane/ID stops; the best "
                    "bilateral width on cornell and plant)"),
        progressive_method(),
        sheared_method("aaf_sheared",
                       "sheared filter (Yan et al. 2015, FORMULAS 9.3) on pixels with s1/s2 <= 2, aaf with adaptive samples "
                       "elsewhere; 4 light cells per axis, no narrowing; knob = samples per pixel kept",
                       before_narrowing({})),
        sheared_method("aaf_sheared_all", "as aaf_sheared without the fallback on s1/s2 (sheared wherever the wedge is not pixel-limited)",
                       before_narrowing({.max_slope_ratio = inf})),
        sheared_method("aaf_sheared_tight", "as aaf_sheared with a shear tolerance of 0.1 and a 6-pixel radius cap",
                       before_narrowing({.shear_tolerance = 0.1f, .max_radius = 6})),
        sheared_method("aaf_sheared_consistent",
                       "sheared filter with the library's defaults (8 light cells per axis, width narrowed as spp^-1/4 "
                       "times sqrt(3 px x wedge width), blocked samples moved through their own occluder in the row pass), "
                       "no fallback on s1/s2: its bias falls as samples grow",
                       {.max_slope_ratio = inf, .sweep = {1, 2, 4, 9, 16, 25, 36, 64}}),
        sheared_method("aaf_sheared_adaptive",
                       "as aaf_sheared_consistent with the rays where its error is: every pixel min(4, knob) samples, "
                       "the sheared centres end with the knob's (sheared_settings::centre_samples)",
                       {.max_slope_ratio = inf, .sweep = {1, 2, 4, 9, 16, 25, 36, 64, 100}, .first_pass = 4}),
    };
    const char* sweep = std::getenv("AAF_VARIANTS_SWEEP");
    if (sweep != nullptr && std::string(sweep) == "1") {
        for (std::uint32_t it = 1; it <= 5; ++it)
            for (float lum : {0.0f, 2.0f, 4.0f, 8.0f})
                f.methods.push_back(peer_method("atrous_i" + std::to_string(it) + "_l" + std::to_string(static_cast<int>(lum)),
                                                atrous_peer(it, lum), "sweep candidate of the a-trous peer"));
        for (float s : {1.0f, 1.5f, 2.0f, 3.0f, 4.0f, 6.0f})
            f.methods.push_back(peer_method("bilateral_s" + std::to_string(static_cast<int>(s * 10)), bilateral_peer(s),
                                            "sweep candidate of the bilateral peer (sigma in tenths of a pixel)"));
        for (float w : {0.5f, 0.25f, 0.125f})
            f.methods.push_back(sheared_method("sheared_all_w" + std::to_string(static_cast<int>(w * 1000)),
                                               "sweep candidate: aaf_sheared_all at one width_scale at every spp (in thousandths)",
                                               before_narrowing({.max_slope_ratio = inf, .width_scale = w})));
        f.methods.push_back(sheared_method("sheared_one_shear",
                                           "sweep candidate: aaf_sheared_consistent moving every sample with the centre's shear",
                                           {.max_slope_ratio = inf, .per_sample_depth = false, .sweep = {1, 2, 4, 9, 16, 25, 36, 64}}));
        for (float r : {0.5f, 1.0f, 2.0f, 4.0f})
            f.methods.push_back(sheared_method("sheared_narrow_" + std::to_string(static_cast<int>(r * 1000)),
                                               "sweep candidate: aaf_sheared_consistent at another narrowing_pixels (in thousandths)",
                                               {.max_slope_ratio = inf, .narrowing_pixels = r}));
        for (std::uint32_t first : {2u, 9u})
            f.methods.push_back(sheared_method("sheared_adaptive_f" + std::to_string(first),
                                               "sweep candidate: aaf_sheared_adaptive with another first pass",
                                               {.max_slope_ratio = inf, .sweep = {1, 2, 4, 9, 16, 25, 36, 64, 100}, .first_pass = first}));
        for (double from : {16.0, 25.0})
            f.methods.push_back(sheared_method("sheared_adaptive_fb" + std::to_string(static_cast<int>(from)),
                                               "sweep candidate: aaf_sheared_adaptive with the fallback's mu growing as 2 sqrt(knob / " +
                                                   std::to_string(static_cast<int>(from)) + ")",
                                               {.max_slope_ratio = inf, .sweep = {1, 2, 4, 9, 16, 25, 36, 64, 100, 144},
                                                .first_pass = 4, .fallback_grows_from = from}));
        f.methods.push_back(sheared_method("sheared_adaptive_ld",
                                           "sweep candidate: aaf_sheared_adaptive with low-discrepancy samples (a centre's second pass "
                                           "continues its sequence)",
                                           {.max_slope_ratio = inf, .sweep = {1, 2, 4, 9, 16, 25, 36, 64, 100}, .first_pass = 4,
                                            .pattern = aaf::sample_pattern::low_discrepancy}));
    }
    return f;
}

}  // namespace aaf_examples
