// SPDX-License-Identifier: MIT
// aaf-render: a small soft-shadow renderer that shows aaf inside a real ray tracer. It loads a scene (built
// in, or a JSON file with real meshes), builds a BVH, renders a G-buffer from primary rays, runs the aaf
// pipeline with the BVH as its tracer, renders (or loads from its cache) a converged reference, and writes
// the pictures and a one-screen summary. Run with --help for the options.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <stb_image_write.h>

#include <aaf/aaf.hpp>

#include "common/bvh.hpp"
#include "common/methods.hpp"
#include "common/render_support.hpp"
#include "common/scene.hpp"

namespace {

namespace fs = std::filesystem;
using aaf_examples::clock_type;
using aaf_examples::first_hit_tracer;
using aaf_examples::gbuffer_images;
using aaf_examples::ms_since;
using aaf_examples::parse_count;
using aaf_examples::scene;
using aaf_examples::usage_error;

struct options {
    std::string scene = "plant";
    fs::path scenes_dir = fs::path(__FILE__).parent_path().parent_path() / "scenes";
    fs::path out = "aaf-render-output";
    fs::path cache;  // default: <out>/cache
    std::optional<std::size_t> width, height;
    std::uint32_t reference_spp = 1024;
    bool reference = true;
    std::size_t threads = 0;
    std::optional<float> mu;
    std::optional<std::uint32_t> initial_samples, max_samples;
    aaf::offset_space space = aaf::offset_space::image;
    bool first_hit = false;
    std::uint32_t seed = 0;
    std::string tracer = "bvh";  // --tracer
    aaf::light_weighting weighting = aaf::light_weighting::uniform;
    float scale = 1;            // the whole scene scaled by this (tests scale independence)
    double origin_offset = -1;  // < 0: automatic (aaf's default); >= 0: a fixed epsilon along the normal
    std::string method;         // empty: the detailed aaf render; else a method of the registry
    std::optional<double> knob; // the method's knob (default: the method's own)
};

const char* const help_text =
    "usage: aaf-render [options]\n"
    "Renders the soft shadow of a scene with aaf and writes noisy, filtered and reference pictures,\n"
    "the error and the beta / samples-per-pixel / d2 maps as PNG, plus a summary.\n"
    "\n"
    "  --scene NAME|FILE     built-in scene (lattice, boxes, tentacles), a scene in --scenes-dir\n"
    "                        (bunny, plant, bench, blinds, cornell, car) or a .json file [plant]\n"
    "  --scenes-dir DIR      where scene names are looked up [the repository's scenes/]\n"
    "  --size WxH            image size, overriding the scene's\n"
    "  --out DIR             output folder [aaf-render-output]\n"
    "  --reference-spp N     samples per pixel of the converged reference [1024]\n"
    "  --no-reference        skip the reference (and the error picture)\n"
    "  --cache DIR           where references are cached between runs [OUT/cache]\n"
    "  --threads N           threads (0 = all cores) [0]\n"
    "  --mu X                aaf's mu (>= 1; larger = more samples, narrower filter) [scene's or 2]\n"
    "  --initial-samples N   first-pass samples per pixel [scene's or 9]\n"
    "  --max-samples N       cap on samples per pixel [scene's or 100]\n"
    "  --offsets image|light filter offsets in image space or parallel to the light [image]\n"
    "  --first-hit           the tracer reports only the nearest occluder (else nearest and farthest)\n"
    "  --weighting uniform|gaussian  light samples weighted uniformly (a physical rectangle) or by the\n"
    "                        authors' Gaussian; the reference uses the same weighting [uniform]\n"
    "  --tracer KIND         ray tracer: bvh (the examples' BVH), embree (Embree 3's 16-wide packets through aaf's\n"
    "                        batched queries) or embree-single (Embree one ray at a time); Embree in builds\n"
    "                        with AAF_WITH_EMBREE [bvh]\n"
    "  --seed N              frame seed [0]\n"
    "  --scale S             scale the whole scene (geometry, light, camera) by S, e.g. 1e-3 or 1e4 [1]\n"
    "  --ray-offset auto|E   shadow-ray origins moved off the surface automatically (ULP offsetting), or\n"
    "                        by a fixed epsilon E in world units, to compare with hand-set epsilons [auto]\n"
    "  --method NAME         render one method of the registry instead (listed below): writes NAME.png,\n"
    "                        its own pictures, and the error against its quantity's reference\n"
    "  --knob X              that method's cost knob [the method's default]\n"
    "  --help                this text\n"
    "Large optional meshes (the sports car) are found through the AAF_SCENES_DIR environment variable.\n";

options parse(int argc, char** argv) {
    options o;
    const aaf_examples::shared_options shared{o.scene, o.scenes_dir, o.out, o.cache, o.width, o.height, o.seed, &o.tracer};
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        const auto value = [&]() -> std::string {
            if (i + 1 >= argc) throw usage_error(a + " needs a value (see --help)");
            return argv[++i];
        };
        if (a == "--help" || a == "-h") {
            std::fputs(help_text, stdout);
            std::fputs(aaf_examples::method_list_text().c_str(), stdout);
            std::exit(0);
        } else if (aaf_examples::parse_shared_option(a, value, shared)) {
        } else if (a == "--reference-spp") o.reference_spp = parse_count(a, value(), 1, 1u << 20);
        else if (a == "--no-reference") o.reference = false;
        else if (a == "--threads") o.threads = parse_count(a, value(), 0, 1024);
        else if (a == "--mu") {
            const std::string v = value();
            char* end = nullptr;
            const float mu = std::strtof(v.c_str(), &end);
            if (v.empty() || *end != '\0' || !(mu >= 1.0f) || !std::isfinite(mu)) throw usage_error("--mu must be a number >= 1 (got '" + v + "')");
            o.mu = mu;
        } else if (a == "--initial-samples") o.initial_samples = parse_count(a, value(), 1, 4096);
        else if (a == "--max-samples") o.max_samples = parse_count(a, value(), 1, 1u << 20);
        else if (a == "--offsets") {
            const std::string v = value();
            if (v == "image") o.space = aaf::offset_space::image;
            else if (v == "light") o.space = aaf::offset_space::light_plane;
            else throw usage_error("--offsets must be image or light (got '" + v + "')");
        } else if (a == "--first-hit") o.first_hit = true;
        else if (a == "--weighting") {
            const std::string v = value();
            if (v == "uniform") o.weighting = aaf::light_weighting::uniform;
            else if (v == "gaussian") o.weighting = aaf::light_weighting::gaussian;
            else throw usage_error("--weighting must be uniform or gaussian (got '" + v + "')");
        }
        else if (a == "--scale") {
            const std::string v = value();
            char* end = nullptr;
            const float x = std::strtof(v.c_str(), &end);
            if (v.empty() || *end != '\0' || !(x > 0.0f) || !std::isfinite(x)) throw usage_error("--scale must be a number > 0 (got '" + v + "')");
            o.scale = x;
        } else if (a == "--ray-offset") {
            const std::string v = value();
            if (v == "auto") o.origin_offset = -1;
            else {
                char* end = nullptr;
                const double e = std::strtod(v.c_str(), &end);
                if (v.empty() || *end != '\0' || !(e >= 0.0) || !std::isfinite(e))
                    throw usage_error("--ray-offset must be auto or a distance >= 0 (got '" + v + "')");
                o.origin_offset = e;
            }
        }
        else if (a == "--method") o.method = aaf_examples::find_method(value()).name;
        else if (a == "--knob") {
            const std::string v = value();
            char* end = nullptr;
            const double x = std::strtod(v.c_str(), &end);
            if (v.empty() || *end != '\0' || !std::isfinite(x)) throw usage_error("--knob must be a finite number (got '" + v + "')");
            o.knob = x;
        }
        else throw usage_error("unknown option '" + a + "' (see --help)");
    }
    if (o.knob && o.method.empty()) throw usage_error("--knob needs --method (see --help)");
    if (o.cache.empty()) o.cache = o.out / "cache";
    return o;
}

/// Writes PNGs into `out` only when everything succeeded: each picture goes to a temporary name first, and
/// `commit` renames them all; if the run fails before that, the destructor removes the temporaries.
class picture_writer {
public:
    explicit picture_writer(fs::path out) : out_(std::move(out)) {}
    picture_writer(const picture_writer&) = delete;
    picture_writer& operator=(const picture_writer&) = delete;
    ~picture_writer() {
        std::error_code ec;
        for (const auto& [tmp, final_name] : files_) fs::remove(tmp, ec);
    }
    void gray(const std::string& name, const aaf::image<float>& img, bool gamma = true) {
        std::vector<unsigned char> px(img.size());
        for (std::size_t i = 0; i < img.size(); ++i) {
            const double v = std::clamp(static_cast<double>(img.data()[i]), 0.0, 1.0);
            px[i] = static_cast<unsigned char>(std::lround(255.0 * (gamma ? std::pow(v, 1.0 / 2.2) : v)));
        }
        write(name, 1, px.data(), img.width(), img.height());
    }
    void rgb(const std::string& name, const aaf::image<aaf::rgb8>& img) { write(name, 3, img.data(), img.width(), img.height()); }
    void commit() {
        for (const auto& [tmp, final_name] : files_) fs::rename(tmp, final_name);
        files_.clear();
    }

private:
    void write(const std::string& name, int channels, const void* data, std::size_t w, std::size_t h) {
        fs::create_directories(out_);  // only once there is something to write
        const fs::path final_name = out_ / name;
        const fs::path tmp = out_ / ("." + name + ".tmp");
        files_.emplace_back(tmp, final_name);
        if (!stbi_write_png(tmp.string().c_str(), static_cast<int>(w), static_cast<int>(h), channels, data,
                            static_cast<int>(w) * channels))
            throw std::runtime_error("cannot write " + final_name.string());
    }
    fs::path out_;
    std::vector<std::pair<fs::path, fs::path>> files_;
};

/// The scene with the command line's size, aaf settings and scale applied, validated.
scene prepare_scene(const options& opt) {
    scene s = aaf_examples::load_scene(opt.scene, opt.scenes_dir);
    if (opt.width) s.width = *opt.width, s.height = *opt.height;
    if (opt.mu) s.aaf.mu = *opt.mu;
    if (opt.initial_samples) s.aaf.initial_samples = *opt.initial_samples;
    if (opt.max_samples) s.aaf.max_samples = *opt.max_samples;
    if (opt.scale != 1.0f) {
        for (glm::vec3& v : s.vertices) v *= opt.scale;
        s.light.corner *= opt.scale, s.light.edge_u *= opt.scale, s.light.edge_v *= opt.scale;
        s.view.position *= opt.scale, s.view.target *= opt.scale;
    }
    if (s.aaf.max_samples < s.aaf.initial_samples)
        throw usage_error("--max-samples (" + std::to_string(s.aaf.max_samples) + ") is below the initial samples (" +
                          std::to_string(s.aaf.initial_samples) + ")");
    s.validate();
    return s;
}

/// --method: one method of the registry at one knob value, its pictures and its error.
int run_method(const options& opt) {
    const auto t_start = clock_type::now();
    const scene s = prepare_scene(opt);
    const aaf_examples::method& m = aaf_examples::find_method(opt.method);
    aaf::thread_pool pool(opt.threads);
    const aaf_examples::scene_tracer bvh(s, opt.tracer);
    const gbuffer_images g = aaf_examples::render_gbuffer(s, bvh, pool);
    const aaf_examples::render_inputs in{.s = s, .tracer = bvh, .g = g, .pool = pool, .seed = opt.seed, .cache = opt.cache, .progress = true};
    const double knob = opt.knob.value_or(m.default_knob);
    const aaf_examples::method_output out = m.render(in, knob);

    picture_writer pictures(opt.out);
    pictures.gray(m.name + ".png", out.image);
    for (const auto& [name, picture] : out.pictures) pictures.gray(m.name + "-" + name + ".png", picture);
    for (const auto& [name, picture] : out.colour_pictures) pictures.rgb(m.name + "-" + name + ".png", picture);
    double error = std::numeric_limits<double>::quiet_NaN();
    if (opt.reference) {
        // A variant (own_reference) is judged against the reference of its own material and light.
        const aaf_examples::reference_output ref = m.own_reference ? aaf_examples::reference_output(m.own_reference(in, opt.reference_spp, 0))
                                                                   : aaf_examples::find_reference(m.what).render(in, opt.reference_spp, 0);
        aaf::image<aaf::rgb8> rgb(s.width, s.height);
        error = aaf_examples::rmse(out.image, ref.image, g.surface_mask());
        aaf::difference_image<float>(out.image.cview(), ref.image.cview(), rgb.view(), 0.1);
        pictures.gray(m.own_reference ? "reference-" + m.name + ".png" : std::string("reference-") + aaf_examples::to_string(m.what) + ".png",
                      ref.image);
        pictures.rgb(m.name + "-error.png", rgb);
    }
    pictures.commit();

    const double pixels = static_cast<double>(g.surfaces ? g.surfaces : 1);
    std::printf("aaf-render: scene '%s', %zux%zu, %zu threads, method %s (%s), %s = %g\n", s.name.c_str(), s.width, s.height, pool.size(),
                m.name.c_str(), aaf_examples::to_string(m.what), m.knob.c_str(), knob);
    std::printf("  %-34s %10.1f\n", "total ms", out.total_ms);
    for (const auto& [stage, ms] : out.stages_ms) std::printf("  %-34s %10.1f\n", (stage + " ms").c_str(), ms);
    std::printf("  rays per surface pixel: %.2f; working memory %.2f MiB\n", static_cast<double>(out.rays) / pixels,
                static_cast<double>(out.memory_bytes) / (1024.0 * 1024.0));
    if (opt.reference) std::printf("  RMSE vs the %u-spp reference: %.5f\n", opt.reference_spp, error);
    std::printf("pictures in %s (%.1f s)\n", fs::absolute(opt.out).string().c_str(), ms_since(t_start) / 1000.0);
    return 0;
}

int run(const options& opt) {
    if (!opt.method.empty()) return run_method(opt);
    const auto t_start = clock_type::now();
    const scene s = prepare_scene(opt);
    const std::size_t w = s.width, h = s.height;

    aaf::thread_pool pool(opt.threads);
    auto t0 = clock_type::now();
    const aaf_examples::scene_tracer bvh(s, opt.tracer);  // the BVH or Embree (--tracer)
    const double bvh_ms = ms_since(t0);
    t0 = clock_type::now();
    const gbuffer_images g = aaf_examples::render_gbuffer(s, bvh, pool);
    const double gbuffer_ms = ms_since(t0);

    aaf::frame_settings<float> settings;
    settings.formulas.mu = s.aaf.mu;
    settings.sampling.initial_samples = s.aaf.initial_samples;
    settings.sampling.max_samples = s.aaf.max_samples;
    settings.sampling.frame_seed = opt.seed;
    settings.sampling.weighting = opt.weighting;
    settings.sampling.origin_offset = opt.origin_offset;
    settings.filter.space = opt.space;
    settings.radiance = s.radiance;
    const aaf::gbuffer<float, aaf::const_image_view<std::uint32_t>> gb{g.positions.cview(), g.normals.cview(),
                                                                       g.pixel_size.cview(), g.ids.cview()};
    aaf::frame_workspace<float> ws;
    aaf::image<float> filtered(w, h), irradiance(w, h);
    // The exact unshadowed irradiance, for display; the pipeline would compute the same for outputs.shaded.
    pool.parallel_for(h, [&](std::size_t y0, std::size_t y1) {
        for (std::size_t y = y0; y < y1; ++y)
            for (std::size_t x = 0; x < w; ++x)
                irradiance(x, y) = std::isfinite(g.positions(x, y).x)
                                       ? aaf::unshadowed_irradiance(s.light, g.positions(x, y), g.normals(x, y), s.radiance)
                                       : 0.0f;
    });
    const aaf::frame_report report =
        opt.first_hit ? aaf::render_frame(gb, s.light, first_hit_tracer{&bvh}, {filtered.view()}, ws, settings, pool)
                      : aaf::render_frame(gb, s.light, bvh, {filtered.view()}, ws, settings, pool);

    const aaf::image<float> noisy = aaf_examples::displayable(ws.raw_visibility, g);
    // The plain baseline: stratified Monte Carlo with the same number of rays spread evenly over the pixels.
    const auto equal_spp = static_cast<std::uint32_t>(
        std::ceil(static_cast<double>(report.rays()) / static_cast<double>(std::max<std::size_t>(g.surfaces, 1))));
    const aaf::image<float> equal_rays =
        aaf_examples::render_mc(s, g, bvh, {.pattern = settings.sampling.pattern, .spp = std::max<std::uint32_t>(equal_spp, 1),
                                            .seed = opt.seed, .pass = 500, .weighting = opt.weighting,
                                            .origin_offset = opt.origin_offset}, pool).visibility;
    std::optional<aaf::image<float>> reference;
    bool from_cache = false;
    double reference_ms = 0;
    if (opt.reference) {
        aaf_examples::reference_result r = aaf_examples::reference_visibility(
            s, g, bvh, {.spp = opt.reference_spp, .seed = 0, .weighting = opt.weighting, .origin_offset = opt.origin_offset},
            opt.cache, pool);
        reference = aaf_examples::displayable(r.visibility, g);
        from_cache = r.from_cache, reference_ms = r.ms;
    }

    // Pictures: shaded = albedo × (ambient + exposure · E · visibility), gamma 2.2; exposure from the 95th
    // percentile of E so the lit floor is near white whatever the light's radiance.
    std::vector<float> es;
    for (std::size_t i = 0; i < irradiance.size(); ++i)
        if (irradiance.data()[i] > 0.0f) es.push_back(irradiance.data()[i]);
    float exposure = 1.0f;
    if (!es.empty()) {
        std::nth_element(es.begin(), es.begin() + static_cast<std::ptrdiff_t>(es.size() * 95 / 100), es.end());
        exposure = 1.0f / es[es.size() * 95 / 100];
    }
    const auto shade = [&](const aaf::image<float>& vis) {
        aaf::image<float> img(w, h, 0.18f);  // background
        for (std::size_t i = 0; i < img.size(); ++i)
            if (std::isfinite(g.positions.data()[i].x))
                img.data()[i] = g.albedo.data()[i] * (0.06f + 0.94f * std::min(1.0f, irradiance.data()[i] * exposure) * vis.data()[i]);
        return img;
    };
    picture_writer pictures(opt.out);
    pictures.gray("noisy.png", shade(noisy));
    pictures.gray("filtered.png", shade(filtered));
    pictures.gray("visibility-noisy.png", noisy);
    pictures.gray("visibility-filtered.png", filtered);
    aaf::image<aaf::rgb8> rgb(w, h);
    pictures.gray("equal-rays.png", shade(equal_rays));
    double rmse_noisy = std::numeric_limits<double>::quiet_NaN(), rmse_filtered = rmse_noisy, rmse_equal = rmse_noisy;
    if (reference) {
        pictures.gray("reference.png", shade(*reference));
        pictures.gray("visibility-reference.png", *reference);
        rmse_equal = aaf::difference_image<float>(equal_rays.cview(), reference->cview(), rgb.view(), 0.1);
        rmse_noisy = aaf::difference_image<float>(noisy.cview(), reference->cview(), rgb.view(), 0.1);
        pictures.rgb("error-noisy.png", rgb);
        rmse_filtered = aaf::difference_image<float>(filtered.cview(), reference->cview(), rgb.view(), 0.1);
        pictures.rgb("error.png", rgb);
    }
    aaf::image<float> beta_px(w, h, std::numeric_limits<float>::quiet_NaN());
    for (std::size_t i = 0; i < beta_px.size(); ++i)
        if (ws.filter_width.data()[i] > 0.0f) beta_px.data()[i] = ws.filter_width.data()[i] / g.pixel_size.data()[i];
    const aaf::heat_range beta_range = aaf::heat_map<float>(beta_px.cview(), rgb.view(), {}, true);
    pictures.rgb("beta.png", rgb);
    aaf::image<double> field(w, h);
    aaf::extract<float>(ws.stats.cview(), aaf::stats_field::samples, field.view());
    const aaf::heat_range spp_range = aaf::heat_map<double>(field.cview(), rgb.view());
    pictures.rgb("spp.png", rgb);
    aaf::extract<float>(ws.stats.cview(), aaf::stats_field::d2min, field.view());
    const aaf::heat_range d2min_range = aaf::heat_map<double>(field.cview(), rgb.view());
    pictures.rgb("d2min.png", rgb);
    aaf::extract<float>(ws.stats.cview(), aaf::stats_field::d2max, field.view());
    aaf::heat_map<double>(field.cview(), rgb.view(), d2min_range);
    pictures.rgb("d2max.png", rgb);
    pictures.commit();

    const double pixels = static_cast<double>(g.surfaces ? g.surfaces : 1);
    std::printf("aaf-render: scene '%s', %zux%zu, %zu triangles, %zu threads, light sigma %.4g\n", s.name.c_str(), w, h,
                bvh.triangle_count(), pool.size(), static_cast<double>(s.light.sigma()));
    std::printf("  %-34s %10s\n", "stage", "ms");
    std::printf("  %-34s %10.1f\n", opt.tracer != "bvh" ? "Embree scene build" : "BVH build", bvh_ms);
    std::printf("  %-34s %10.1f\n", "G-buffer (primary rays)", gbuffer_ms);
    std::printf("  %-34s %10.1f\n", "initial shadow samples", report.initial_ms);
    std::printf("  %-34s %10.1f\n", "slopes, spreading, beta, n", report.formulas_ms);
    std::printf("  %-34s %10.1f\n", "adaptive shadow samples", report.adaptive_ms);
    std::printf("  %-34s %10.1f\n", "filter", report.filter_ms);
    std::printf("  %-34s %10.1f\n", "aaf frame total", report.total_ms);
    if (reference)
        std::printf("  %-34s %10.1f%s\n", ("reference, " + std::to_string(opt.reference_spp) + " spp").c_str(), reference_ms,
                    from_cache ? " (cached)" : "");
    std::printf("  shadow rays per surface pixel: %.2f (initial %.2f, adaptive %.2f); %.1f Mrays/s in the frame\n",
                static_cast<double>(report.rays()) / pixels, static_cast<double>(report.initial_rays) / pixels,
                static_cast<double>(report.adaptive_rays) / pixels,
                static_cast<double>(report.rays()) / (report.initial_ms + report.adaptive_ms) / 1000.0);
    if (reference) {
        const auto ratio = [](double a, double b) { return b > 0 ? a / b : std::numeric_limits<double>::quiet_NaN(); };
        std::printf("  RMSE of visibility vs the reference:\n");
        std::printf("    stratified MC, %u rays in every pixel       %.4f\n", equal_spp, rmse_equal);
        std::printf("    aaf's adaptive samples, unfiltered         %.4f\n", rmse_noisy);
        std::printf("    aaf, filtered                              %.4f  (%.2fx below equal-ray MC, %.2fx below unfiltered)\n",
                    rmse_filtered, ratio(rmse_equal, rmse_filtered), ratio(rmse_noisy, rmse_filtered));
    }
    std::printf("  beta %.2g..%.2g px, samples per pixel %.0f..%.0f\n", std::pow(10.0, beta_range.lo), std::pow(10.0, beta_range.hi),
                spp_range.lo, spp_range.hi);
    std::printf("pictures in %s: noisy filtered equal-rays%s visibility-* beta spp d2min d2max (.png); total %.1f s\n",
                fs::absolute(opt.out).string().c_str(), reference ? " reference error error-noisy" : "", ms_since(t_start) / 1000.0);
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    return aaf_examples::report_errors("aaf-render", [&] { return run(parse(argc, argv)); });
}
