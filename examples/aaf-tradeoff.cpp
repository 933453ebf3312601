// SPDX-License-Identifier: MIT
// aaf-tradeoff: the speed/accuracy trade-off of aaf against unfiltered Monte Carlo on one scene. Renders
// the scene with every method over its cost knob (samples per pixel, μ), measures shadow rays per pixel,
// wall milliseconds (tracing and filter separately) and the error (RMSE, SSIM) against a converged,
// cached reference, finds for every aaf point how many more rays and how much more time stratified Monte
// Carlo needs for the same error, and writes tradeoff.json, summary.md, tradeoff.gp and two log-log plots
// drawn by gnuplot. The engine is examples/common/tradeoff.cpp; run with --help for the options.

#include <algorithm>
#include <stdexcept>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "common/render_support.hpp"
#include "common/scene.hpp"
#include "common/tradeoff.hpp"

namespace {

namespace fs = std::filesystem;
using aaf_examples::parse_count;
using aaf_examples::usage_error;

const char* const help_text =
    "usage: aaf-tradeoff [options]\n"
    "Renders one scene with every method over its cost knob against a converged reference and writes\n"
    "OUT/tradeoff.json (rays per pixel, milliseconds, RMSE and SSIM of every point, and the equal-error\n"
    "ratios against unfiltered stratified Monte Carlo), OUT/summary.md, OUT/tradeoff.gp and, drawn by\n"
    "gnuplot, OUT/rmse_vs_rays.png and OUT/rmse_vs_time.png. Progress goes to stderr. A method that\n"
    "marks regions (the sheared filter's centres) also gets each point's error split by them: share of\n"
    "pixels and of squared error, RMSE inside and outside (\"regions\" in the JSON).\n"
    "\n"
    "  --scene NAME|FILE     built-in scene (lattice, boxes, tentacles), a scene in --scenes-dir\n"
    "                        (bunny, plant, bench, blinds, cornell, car) or a .json file [boxes]\n"
    "  --scenes-dir DIR      where scene names are looked up [the repository's scenes/]\n"
    "  --size WxH            image size, overriding the scene's\n"
    "  --out DIR             output folder [aaf-tradeoff-output]\n"
    "  --cache DIR           where references are cached between runs [OUT/cache]\n"
    "  --threads N           threads (0 = all cores) [2]\n"
    "  --tracer KIND         ray tracer: bvh (the examples' BVH), embree (Embree 3's 16-wide packets through aaf's\n"
    "                        batched queries) or embree-single (Embree one ray at a time); Embree in builds\n"
    "                        with AAF_WITH_EMBREE [bvh]\n"
    "  --seed N              frame seed of the measured methods; the reference's two halves use other\n"
    "                        seeds derived from it [0]\n"
    "  --reference-spp N     samples per pixel of the reference, rendered as two independent halves whose\n"
    "                        difference estimates its own RMSE [4096]\n"
    "  --repeat N            timings are the median of N runs (images come from the first) [3]\n"
    "  --quantity Q          what to measure: shadow, ambient_occlusion or subsurface (each has its own\n"
    "                        methods, reference and Monte Carlo baseline) [shadow]\n"
    "  --methods A,B,...     methods of the quantity to run [all]; its Monte Carlo baseline (shadow:\n"
    "                        mc_stratified) is added whenever a filtered method is chosen. The registry's\n"
    "                        methods are listed below\n"
    "  --max-mc-spp N        cap of the baseline's sweep, which otherwise doubles its spp until it is\n"
    "                        below every aaf point's RMSE [1024]\n"
    "  --quick               short sweeps (a test run)\n"
    "  --no-plot             skip gnuplot (the JSON, summary and script are still written)\n"
    "  --replot              render nothing: rewrite OUT/summary.md, OUT/tradeoff.gp and the plots from\n"
    "                        OUT/tradeoff.json (after a change to their layout)\n"
    "  --overview FILE DIR... render nothing: write a markdown table comparing the scenes whose\n"
    "                        DIR/tradeoff.json exist (equal-error ratios at the paper's mu = 2, the best\n"
    "                        ratios of any aaf variant) and the presets on each, to FILE; scripts/results\n"
    "                        uses it\n"
    "  --help                this text\n"
    "Large optional meshes (the sports car) are found through the AAF_SCENES_DIR environment variable.\n";

struct options {
    aaf_examples::tradeoff::config config;
    fs::path out = "aaf-tradeoff-output";
    bool plot = true;
    bool replot = false;
    fs::path overview;                 // --overview: the table to write
    std::vector<fs::path> overview_dirs;  // ... from these runs
};

std::vector<std::string> split_list(const std::string& v) {
    std::vector<std::string> items;
    std::size_t start = 0;
    while (start <= v.size()) {
        const std::size_t comma = std::min(v.find(',', start), v.size());
        const std::string item = v.substr(start, comma - start);
        if (item.empty()) throw usage_error("--methods must be a comma-separated list of names (got '" + v + "')");
        items.push_back(item);
        start = comma + 1;
    }
    return items;
}

options parse(int argc, char** argv) {
    options o;
    aaf_examples::tradeoff::config& c = o.config;
    c.scenes_dir = fs::path(__FILE__).parent_path().parent_path() / "scenes";
    const aaf_examples::shared_options shared{c.scene, c.scenes_dir, o.out, c.cache, c.width, c.height, c.seed, &c.tracer};
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
        } else if (a == "--threads") c.threads = parse_count(a, value(), 0, 1024);
        else if (a == "--reference-spp") c.reference_spp = parse_count(a, value(), 2, 1u << 20);
        else if (a == "--repeat") c.repeat = parse_count(a, value(), 1, 1000);
        else if (a == "--max-mc-spp") c.max_mc_spp = parse_count(a, value(), 1, 1u << 16);
        else if (a == "--quantity") c.what = aaf_examples::parse_quantity(value());
        else if (a == "--methods") {
            c.methods = split_list(value());
            aaf_examples::tradeoff::check_methods(c.methods);
        } else if (a == "--quick") c.quick = true;
        else if (a == "--no-plot") o.plot = false;
        else if (a == "--replot") o.replot = true;
        else if (a == "--overview") {
            o.overview = value();
            while (i + 1 < argc && std::string(argv[i + 1]).rfind("--", 0) != 0) o.overview_dirs.emplace_back(argv[++i]);
            if (o.overview_dirs.empty()) throw usage_error("--overview needs FILE and at least one DIR with a tradeoff.json");
        }
        else throw usage_error("unknown option '" + a + "' (see --help)");
    }
    if (c.cache.empty()) c.cache = o.out / "cache";
    return o;
}

nlohmann::json read_json(const fs::path& file, const char* flag) {
    std::ifstream in(file);
    if (!in) throw usage_error(std::string(flag) + ": cannot open " + file.string());
    try {
        return nlohmann::json::parse(in);
    } catch (const nlohmann::json::exception& e) {
        throw usage_error(std::string(flag) + ": " + file.string() + " is not valid JSON (" + e.what() + ")");
    }
}

/// The cross-scene tables from the runs in `dirs`, each JSON read once, written to `file` in one rename.
void write_overview(const fs::path& file, const std::vector<fs::path>& dirs) {
    std::vector<nlohmann::json> results;
    for (const fs::path& dir : dirs) results.push_back(read_json(dir / "tradeoff.json", "--overview"));
    const fs::path tmp = file.string() + ".tmp";
    {
        std::ofstream out(tmp);
        out << aaf_examples::tradeoff::overview_markdown(results);
        if (!out) throw std::runtime_error("cannot write " + tmp.string());
    }
    fs::rename(tmp, file);
}

int run(const options& o) {
    if (!o.overview.empty()) {
        write_overview(o.overview, o.overview_dirs);
        return 0;
    }
    if (o.replot) {
        aaf_examples::tradeoff::write_outputs(read_json(o.out / "tradeoff.json", "--replot"), o.out, o.plot);
        return 0;
    }
    const nlohmann::json result = aaf_examples::tradeoff::run(o.config);
    aaf_examples::tradeoff::write_outputs(result, o.out, o.plot);
    std::fprintf(stderr, "aaf-tradeoff: %zu methods, %zu equal-error entries in %s (%.1f s)\n", result["methods"].size(),
                 result["equal_error"].size(), fs::absolute(o.out).string().c_str(), result["run_ms"].get<double>() / 1000.0);
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    return aaf_examples::report_errors("aaf-tradeoff", [&] { return run(parse(argc, argv)); });
}
