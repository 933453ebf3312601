// SPDX-License-Identifier: MIT
#include "common/tradeoff.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>

#include <aaf/pipeline.hpp>
#include <aaf/settings.hpp>

#include "common/bvh.hpp"
#include "common/methods.hpp"
#include "common/render_support.hpp"
#include "common/scene.hpp"

namespace aaf_examples::tradeoff {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

std::string fmt(const char* f, double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, f, v);
    return buf;
}

/// ">" when the baseline's sweep never got as low as an equal_error entry's RMSE (its cost is a lower
/// bound), "<" when even its cheapest point is better (an upper bound), "" when interpolated.
std::string bound_mark(const json& e) { return e["bound"] == "lower" ? ">" : e["bound"] == "upper" ? "<" : ""; }

double median(std::vector<double> v) {
    if (v.empty()) return 0;
    std::sort(v.begin(), v.end());
    const std::size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/// One point of one method: its image's errors (from its first run) and the timings of every run.
struct measurement {
    const method* def = nullptr;
    double knob = 0;
    std::uint64_t rays = 0;
    std::size_t memory_bytes = 0;
    double rmse = 0, ssim = 0, max_abs_error = 0;
    json extra = json::object();  ///< the settings fields that vary along the knob
    json regions = json::object();  ///< the error split by the method's regions (region_errors)
    std::vector<double> total_ms;
    std::vector<std::pair<std::string, std::vector<double>>> stages_ms;  ///< per named stage, every run
};

struct context {
    const render_inputs& in;
    const aaf::image<float>& reference;
    const std::vector<unsigned char>& mask;
};

/// The error of the method's image split by each of its regions, over the metric's pixels: the share of those
/// pixels in the region and of the squared error on them, and the RMSE inside and outside (rmse() over the
/// metric's mask narrowed to the region and to the rest, so that rmse² = pixel_share·rmse_in² +
/// (1 − pixel_share)·rmse_out²).
json region_errors(const method_output& out, const context& ctx) {
    json r = json::object();
    const std::size_t n = ctx.reference.size();
    for (const auto& [name, region] : out.regions) {
        if (region.size() != n)
            throw std::logic_error("method region '" + name + "' has " + std::to_string(region.size()) + " pixels, the image " +
                                   std::to_string(n));
        std::vector<unsigned char> inside(n), outside(n);
        std::size_t n_in = 0, n_out = 0;
        for (std::size_t i = 0; i < n; ++i) {
            const bool counted = ctx.mask.empty() || ctx.mask[i];
            inside[i] = counted && region[i], outside[i] = counted && !region[i];
            n_in += inside[i], n_out += outside[i];
        }
        const double rmse_in = rmse(out.image, ctx.reference, inside), rmse_out = rmse(out.image, ctx.reference, outside);  // 0 when empty
        const double sum_in = rmse_in * rmse_in * static_cast<double>(n_in), total = sum_in + rmse_out * rmse_out * static_cast<double>(n_out);
        r[name] = {{"pixel_share", n_in + n_out > 0 ? static_cast<double>(n_in) / static_cast<double>(n_in + n_out) : 0.0},
                   {"error_share", total > 0 ? sum_in / total : 0.0},
                   {"rmse_in", rmse_in},
                   {"rmse_out", rmse_out}};
    }
    return r;
}

/// Renders point `m` once more, appending its timings; the first time also measures its errors.
void run_point(const context& ctx, measurement& m) {
    const bool first = m.total_ms.empty();
    method_output out = m.def->render(ctx.in, m.knob);
    m.total_ms.push_back(out.total_ms);
    m.rays = out.rays;
    m.memory_bytes = out.memory_bytes;
    for (auto& [name, ms] : out.stages_ms) {
        auto it = std::find_if(m.stages_ms.begin(), m.stages_ms.end(), [&](const auto& st) { return st.first == name; });
        if (it == m.stages_ms.end()) it = m.stages_ms.insert(m.stages_ms.end(), {name, {}});
        it->second.push_back(ms);
    }
    if (first) {
        m.extra = std::move(out.point_settings);
        m.rmse = rmse(out.image, ctx.reference, ctx.mask);
        m.ssim = ssim(out.image, ctx.reference, ctx.mask);
        m.max_abs_error = max_abs_error(out.image, ctx.reference, ctx.mask);
        m.regions = region_errors(out, ctx);
    }
}

json point_json(const context& ctx, const measurement& m) {
    const double pixels = static_cast<double>(std::max<std::size_t>(ctx.in.g.surfaces, 1));
    json p;
    p["knob_value"] = m.knob;
    p["rays_per_pixel"] = static_cast<double>(m.rays) / pixels;
    p["time_ms"] = median(m.total_ms);
    p["rays_ms"] = 0.0;    // every method reports these two, 0 when it has no such stage
    p["filter_ms"] = 0.0;
    for (const auto& [name, runs] : m.stages_ms) p[name + "_ms"] = median(runs);
    p["filter_share"] = p["time_ms"].get<double>() > 0 ? p["filter_ms"].get<double>() / p["time_ms"].get<double>() : 0.0;
    p["memory_bytes"] = m.memory_bytes;
    p["rmse"] = m.rmse;
    p["ssim"] = m.ssim;
    p["max_abs_error"] = m.max_abs_error;
    if (!m.regions.empty()) p["regions"] = m.regions;
    p["time_ms_runs"] = m.total_ms;
    p.update(m.extra);
    return p;
}

std::vector<curve_point> curve_of(const json& method) {
    std::vector<curve_point> pts;
    for (const json& p : method["points"]) {
        const curve_point cp{p["rays_per_pixel"].get<double>(), p["time_ms"].get<double>(), p["rmse"].get<double>()};
        if (cp.rays > 0 && cp.time > 0 && cp.rmse > 0 && std::isfinite(cp.rays + cp.time + cp.rmse)) pts.push_back(cp);
    }
    return pts;
}

std::string shell_quote(const std::string& s) {
    std::string q = "'";
    for (char ch : s) q += ch == '\'' ? std::string("'\\''") : std::string(1, ch);
    return q + "'";
}

void write_file(const fs::path& file, const std::string& text) {
    std::ofstream f(file, std::ios::binary);
    f << text;
    f.close();
    if (!f) throw std::runtime_error("cannot write " + file.string());
}

/// The methods a run measures: those named (or all) of the run's quantity, with its baseline first.
std::vector<const method*> select_methods(const config& c, const std::string& baseline) {
    check_methods(c.methods);
    std::vector<const method*> selected;
    bool any_filtered = false;
    for (const method& m : all_methods()) {
        const bool named = std::find(c.methods.begin(), c.methods.end(), m.name) != c.methods.end();
        if (named && m.what != c.what)
            throw usage_error("method '" + m.name + "' estimates " + to_string(m.what) + ", not " + to_string(c.what) +
                              " (choose it with --quantity " + to_string(m.what) + ")");
        if (named && m.own_reference)
            throw usage_error("method '" + m.name + "' renders a variant of " + to_string(m.what) +
                              " judged against its own reference, which aaf-tradeoff's shared reference is not (use aaf-render --method " +
                              m.name + ")");
        if (m.what != c.what || !(c.methods.empty() || named) || m.own_reference) continue;
        selected.push_back(&m);
        any_filtered |= !m.doubling_sweep;
    }
    // equal_error needs the baseline.
    if (any_filtered && std::none_of(selected.begin(), selected.end(), [&](const method* m) { return m->name == baseline; }))
        selected.insert(selected.begin(), &find_method(baseline));
    return selected;
}

}  // namespace

std::vector<std::string> method_names(quantity what) {
    std::vector<std::string> n;
    for (const method& m : all_methods())
        if (m.what == what && !m.own_reference) n.push_back(m.name);
    return n;
}

void check_methods(const std::vector<std::string>& methods) {
    for (const std::string& m : methods) (void)find_method(m);
}

equal_cost equal_error_cost(std::vector<curve_point> pts, double target) {
    if (pts.empty()) throw std::invalid_argument("equal_error_cost: the baseline curve is empty");
    if (!(target > 0) || !std::isfinite(target)) throw std::invalid_argument("equal_error_cost: the target RMSE must be finite and > 0");
    for (const curve_point& p : pts)
        if (!(p.rays > 0 && p.time > 0 && p.rmse > 0) || !std::isfinite(p.rays + p.time + p.rmse))
            throw std::invalid_argument("equal_error_cost: every baseline point needs finite, positive rays, time and RMSE");
    std::stable_sort(pts.begin(), pts.end(), [](const curve_point& a, const curve_point& b) { return a.rays < b.rays; });
    if (pts.front().rmse <= target) {
        equal_cost e{pts.front().rays, pts.front().time, pts.front().rmse < target, pts.front().rmse < target ? "upper" : "interpolated"};
        return e;
    }
    for (std::size_t i = 0; i + 1 < pts.size(); ++i) {
        const curve_point& a = pts[i];
        const curve_point& b = pts[i + 1];
        if (b.rmse > target) continue;  // a.rmse > target here: the first segment that reaches the target
        const double f = (std::log(target) - std::log(a.rmse)) / (std::log(b.rmse) - std::log(a.rmse));
        const auto lerp = [f](double u, double v) { return std::exp(std::log(u) + f * (std::log(v) - std::log(u))); };
        return {lerp(a.rays, b.rays), lerp(a.time, b.time), false, "interpolated"};
    }
    // Never reached: at least the most expensive point's cost.
    double time = 0;
    for (const curve_point& p : pts) time = std::max(time, p.time);
    return {pts.back().rays, time, true, "lower"};
}

json run(const config& c) {
    const quantity_reference& qref = find_reference(c.what);
    const std::string& baseline = qref.baseline_method;
    const std::vector<const method*> selected = select_methods(c, baseline);
    const bool any_filtered = std::any_of(selected.begin(), selected.end(), [](const method* m) { return !m->doubling_sweep; });
    const auto t_start = clock_type::now();

    if (c.repeat < 1) throw usage_error("--repeat must be >= 1");
    scene s = load_scene(c.scene, c.scenes_dir);
    if (c.width) s.width = *c.width, s.height = *c.height;
    s.validate();
    aaf::thread_pool pool(c.threads);
    const scene_tracer tracer(s, c.tracer);
    const gbuffer_images g = render_gbuffer(s, tracer, pool);
    if (g.surfaces == 0) throw usage_error("scene '" + s.name + "' shows no surface at " + std::to_string(s.width) + "x" + std::to_string(s.height));
    const std::vector<unsigned char> mask = g.surface_mask();
    if (c.progress)
        std::fprintf(stderr, "aaf-tradeoff: scene '%s', %zux%zu, %zu triangles (%s), %zu threads, %zu surface pixels, quantity %s\n",
                     s.name.c_str(), s.width, s.height, tracer.triangle_count(), tracer.name(), pool.size(), g.surfaces, to_string(c.what));
    const render_inputs in{.s = s, .tracer = tracer, .g = g, .pool = pool, .seed = c.seed, .cache = c.cache, .progress = c.progress};

    // The reference: two independent halves (their own frame seeds, never the measured methods'), averaged.
    // With σ² the variance of one half, the difference of the halves has variance 2σ² and their average
    // σ²/2: RMSE(a − b) / 2 estimates the average's own RMSE (its noise; bias both halves share is unseen).
    const std::uint32_t half = std::max<std::uint32_t>(1, c.reference_spp / 2);
    const std::uint32_t seed_a = c.seed ^ 0x52454641u, seed_b = c.seed ^ 0x52454642u;  // "REFA", "REFB"
    const reference_output ra = qref.render(in, half, seed_a);
    const reference_output rb = qref.render(in, half, seed_b);
    aaf::image<float> reference(s.width, s.height);
    for (std::size_t i = 0; i < reference.size(); ++i) reference.data()[i] = 0.5f * (ra.image.data()[i] + rb.image.data()[i]);
    const double reference_rmse = 0.5 * rmse(ra.image, rb.image, mask);
    if (c.progress)
        std::fprintf(stderr, "reference: %u spp (2 x %u)%s, estimated RMSE %.5f\n", 2 * half, half,
                     ra.from_cache && rb.from_cache ? " (cached)" : "", reference_rmse);

    const context ctx{in, reference, mask};
    // Every point is rendered once (image, errors, first timing), in method order; then `repeat - 1` more
    // rounds time every point again. Interleaving the rounds spreads each point's runs over the whole
    // measurement, so a burst of load from elsewhere on the machine lands in one run of many points
    // (which the median discards) rather than in every run of one method.
    std::vector<measurement> points;  // in the order measured
    const auto measure = [&](const method* d, double knob) -> const measurement& {
        measurement m;
        m.def = d, m.knob = knob;
        run_point(ctx, m);
        if (c.progress) {
            const std::string k = d->sweep.size() == 1 && d->knob == "preset" ? std::string("preset") : d->knob + "=" + fmt("%g", knob);
            double filter_ms = 0;
            for (const auto& [name, runs] : m.stages_ms)
                if (name == "filter") filter_ms = runs.back();
            std::fprintf(stderr, "  %-19s %-19s %8.2f rays/px %9.1f ms (filter %6.1f)  rmse %.5f  ssim %.4f\n", d->name.c_str(),
                         k.c_str(), static_cast<double>(m.rays) / static_cast<double>(g.surfaces), m.total_ms.back(), filter_ms, m.rmse,
                         m.ssim);
        }
        points.push_back(std::move(m));
        return points.back();
    };
    double min_filtered_rmse = std::numeric_limits<double>::infinity();
    // Methods with a fixed sweep first: their lowest error tells the baseline how far to go.
    for (const method* d : selected) {
        if (d->doubling_sweep) continue;
        std::vector<double> knobs = d->sweep;
        if (c.quick) knobs = !d->quick_sweep.empty() ? d->quick_sweep : std::vector<double>(d->sweep.begin(), d->sweep.begin() + std::min<std::size_t>(2, d->sweep.size()));
        for (double k : knobs) min_filtered_rmse = std::min(min_filtered_rmse, measure(d, k).rmse);
    }
    // Unfiltered MC: the baseline doubles its spp until it is below every other point's error (so equal error
    // is interpolated) or reaches max_mc_spp; the other samplers sweep as far, at most 256 spp.
    std::uint32_t baseline_last = std::max<std::uint32_t>(1, c.max_mc_spp);
    std::map<std::string, std::uint32_t> mc_cap;
    for (const method* d : selected) {
        if (!d->doubling_sweep) continue;
        const bool is_baseline = d->name == baseline;
        const std::uint32_t cap = is_baseline ? std::max<std::uint32_t>(1, c.max_mc_spp) : std::min<std::uint32_t>(256, baseline_last);
        mc_cap[d->name] = cap;
        for (std::uint32_t spp = 1; spp <= cap; spp *= 2) {
            const double e = measure(d, spp).rmse;
            if (is_baseline) baseline_last = spp;
            if (is_baseline && any_filtered && e <= min_filtered_rmse) break;
            if (spp > cap / 2) break;  // no overflow past 2^31
        }
    }
    for (std::uint32_t round = 1; round < c.repeat; ++round) {
        if (c.progress) std::fprintf(stderr, "timing round %u of %u over all %zu points...\n", round + 1, c.repeat, points.size());
        for (measurement& m : points) run_point(ctx, m);
    }

    json methods = json::object();  // by name; ordered as the registry at the end
    for (const measurement& m : points) {
        const method& d = *m.def;
        if (!methods.contains(d.name)) {
            json j{{"name", d.name}, {"kind", d.family}, {"knob", d.knob}, {"settings", d.settings}, {"points", json::array()}};
            j["settings"]["frame_seed"] = c.seed;
            if (!j["settings"].contains("description")) j["settings"]["description"] = d.help;
            if (d.doubling_sweep) j["settings"]["max_spp"] = mc_cap[d.name];
            if (d.name == baseline)
                j["settings"]["stop_rule"] = "doubling until the RMSE is below every other method's point, or max_mc_spp";
            methods[d.name] = std::move(j);
        }
        methods[d.name]["points"].push_back(point_json(ctx, m));
    }

    json result;
    result["format"] = 1;
    result["generator"] = "aaf-tradeoff";
    result["quantity"] = to_string(c.what);
    result["baseline"] = baseline;
    result["scene"] = s.name;
    result["width"] = s.width;
    result["height"] = s.height;
    result["triangles"] = tracer.triangle_count();
    result["surface_pixels"] = g.surfaces;
    result["threads"] = pool.size();
    result["repeat"] = c.repeat;
    result["seed"] = c.seed;
    result["quick"] = c.quick;
    result["max_mc_spp"] = c.max_mc_spp;
    result["reference_spp"] = 2 * half;
    result["reference_seeds"] = {seed_a, seed_b};
    result["reference_rmse_estimate"] = reference_rmse;
    result["reference_rmse_method"] = "RMSE between the two independent half-spp references, divided by 2";
    result["reference_ms"] = ra.ms + rb.ms;
    result["reference_from_cache"] = ra.from_cache && rb.from_cache;
    result["metric_mask"] = "surface pixels";
    result["metrics"] = std::string("rmse, max_abs_error and ssim (Wang et al. 2004, 11x11 Gaussian window sigma 1.5, C1 = 0.01^2, "
                                    "C2 = 0.03^2, windows restricted to surface pixels) of ") +
                        to_string(c.what) + " in [0, 1] against the reference";
    result["rays_per_pixel_unit"] = "rays traced / surface pixels";
    result["timing"] = "median of `repeat` runs of the whole frame (time_ms) and of each of its named stages (<stage>_ms), "
                       "each taken separately; the runs are interleaved rounds over all points; images and errors from the first run";
    result["methods"] = json::array();
    for (const method& d : all_methods())
        if (methods.contains(d.name)) result["methods"].push_back(methods[d.name]);

    json eq = json::array();
    if (methods.contains(baseline)) {
        const std::vector<curve_point> base = curve_of(methods[baseline]);
        for (const json& m : result["methods"]) {
            if (m["kind"] == "mc") continue;
            for (std::size_t i = 0; i < m["points"].size(); ++i) {
                const json& p = m["points"][i];
                const double e = p["rmse"].get<double>(), rays = p["rays_per_pixel"].get<double>(), t = p["time_ms"].get<double>();
                if (base.empty() || !(e > 0) || !(rays > 0) || !(t > 0)) continue;
                const equal_cost ec = equal_error_cost(base, e);
                eq.push_back(json{{"method", m["name"]}, {"point", i}, {"knob_value", p["knob_value"]}, {"baseline", baseline},
                              {"rmse", e}, {"rays_per_pixel", rays}, {"time_ms", t}, {"baseline_rays_per_pixel", ec.rays},
                              {"baseline_time_ms", ec.time}, {"rays_ratio", ec.rays / rays}, {"time_ratio", ec.time / t},
                              {"extrapolated", ec.extrapolated}, {"bound", ec.bound}});
            }
        }
    }
    result["equal_error"] = std::move(eq);
    result["run_ms"] = ms_since(t_start);
    if (c.progress && std::isfinite(min_filtered_rmse) && reference_rmse > 0.3 * min_filtered_rmse)
        std::fprintf(stderr, "aaf-tradeoff: note: the reference's own RMSE (%.5f) is not small next to the best filtered RMSE (%.5f): it "
                             "adds in quadrature to every point's (equal-error ratios, compared at equal measured error, stay "
                             "fair); raise --reference-spp for truer absolute errors\n", reference_rmse, min_filtered_rmse);
    return result;
}

std::string summary_markdown(const json& r) {
    std::ostringstream o;
    o << "# aaf-tradeoff: " << r["scene"].get<std::string>() << ", " << r["width"] << "x" << r["height"] << ", " << r["threads"]
      << " threads\n\n";
    o << "Reference: " << r["reference_spp"] << " spp (two independent halves), estimated RMSE "
      << fmt("%.5f", r["reference_rmse_estimate"].get<double>()) << ". Errors over " << r["surface_pixels"]
      << " surface pixels; rays per surface pixel; times are medians of " << r["repeat"] << " runs (ms).\n\n";
    for (const json& m : r["methods"]) {
        o << "## " << m["name"].get<std::string>() << "\n\n" << m["settings"]["description"].get<std::string>() << ".\n\n";
        o << "| " << m["knob"].get<std::string>() << " | rays/px | time ms | rays ms | filter ms | filter % | RMSE | SSIM |\n";
        o << "|---:|---:|---:|---:|---:|---:|---:|---:|\n";
        for (const json& p : m["points"]) {
            const std::string knob = m["kind"] == "preset" ? std::string("-") : fmt("%g", p["knob_value"].get<double>());
            o << "| " << knob << " | " << fmt("%.2f", p["rays_per_pixel"].get<double>()) << " | " << fmt("%.1f", p["time_ms"].get<double>())
              << " | " << fmt("%.1f", p["rays_ms"].get<double>()) << " | " << fmt("%.1f", p["filter_ms"].get<double>()) << " | "
              << fmt("%.1f", 100 * p["filter_share"].get<double>()) << " | " << fmt("%.5f", p["rmse"].get<double>()) << " | "
              << fmt("%.4f", p["ssim"].get<double>()) << " |\n";
        }
        o << "\n";
    }
    o << "## Equal error against " << r.value("baseline", std::string(baseline_method)) << "\n\n";
    o << "How many more rays and how much more time unfiltered stratified Monte Carlo needs for the same RMSE "
         "(interpolated on its curve in log-log; \">\" : its sweep never got this low, \"<\" : even 1 spp is as good).\n\n";
    o << "| method | knob | rays/px | time ms | RMSE | MC rays/px | MC time ms | rays ratio | time ratio |\n";
    o << "|---|---:|---:|---:|---:|---:|---:|---:|---:|\n";
    for (const json& e : r["equal_error"]) {
        const std::string mark = bound_mark(e), b = mark.empty() ? mark : mark + " ";
        const std::string method = e["method"].get<std::string>();
        const std::string knob = method.rfind("preset_", 0) == 0 ? std::string("-") : fmt("%g", e["knob_value"].get<double>());
        o << "| " << method << " | " << knob << " | "
          << fmt("%.2f", e["rays_per_pixel"].get<double>()) << " | " << fmt("%.1f", e["time_ms"].get<double>()) << " | "
          << fmt("%.5f", e["rmse"].get<double>()) << " | " << b << fmt("%.1f", e["baseline_rays_per_pixel"].get<double>()) << " | " << b
          << fmt("%.1f", e["baseline_time_ms"].get<double>()) << " | " << b << fmt("%.2f", e["rays_ratio"].get<double>()) << "x | " << b
          << fmt("%.2f", e["time_ratio"].get<double>()) << "x |\n";
    }
    return o.str();
}

std::string overview_markdown(const std::vector<json>& results) {
    const auto ratio = [](const json& e, const char* field) { return bound_mark(e) + fmt("%.1fx", e[field].get<double>()); };
    const auto knob = [](const json& e) {  // presets have no knob
        const std::string method = e.at("method").get<std::string>();
        return method.rfind("preset_", 0) == 0 ? method : method + ", " + fmt("%g", e.at("knob_value").get<double>());
    };
    std::string md =
        "| scene | size | aaf_adaptive μ=2 rays/px | RMSE | MC rays/px for it | rays ratio | time ratio | filter share | "
        "best rays ratio (method, knob) | best time ratio (method, knob) |\n"
        "|---|---|---:|---:|---:|---:|---:|---:|---|---|\n";
    for (const json& r : results) {
        const json* at_mu2 = nullptr;
        const json *best_rays = nullptr, *best_time = nullptr;
        for (const json& e : r.at("equal_error")) {
            if (e.at("method") == "aaf_adaptive" && e.at("knob_value").get<double>() == 2.0) at_mu2 = &e;  // the paper's μ
            if (!best_rays || e.at("rays_ratio").get<double>() > (*best_rays)["rays_ratio"].get<double>()) best_rays = &e;
            if (!best_time || e.at("time_ratio").get<double>() > (*best_time)["time_ratio"].get<double>()) best_time = &e;
        }
        double share = 0;
        for (const json& m : r.at("methods"))
            if (m.at("name") == "aaf_adaptive")
                for (const json& p : m.at("points"))
                    if (p.value("knob_value", 0.0) == 2.0) share = p.value("filter_share", 0.0);
        md += "| " + r.at("scene").get<std::string>() + " | " + std::to_string(r.at("width").get<int>()) + "x" +
              std::to_string(r.at("height").get<int>()) + " | ";
        if (at_mu2)
            md += fmt("%.1f", (*at_mu2)["rays_per_pixel"].get<double>()) + " | " + fmt("%.4f", (*at_mu2)["rmse"].get<double>()) +
                  " | " + fmt("%.0f", (*at_mu2)["baseline_rays_per_pixel"].get<double>()) + " | " + ratio(*at_mu2, "rays_ratio") +
                  " | " + ratio(*at_mu2, "time_ratio") + " | " + fmt("%.1f %%", 100.0 * share) + " | ";
        else
            md += "- | - | - | - | - | - | ";
        md += (best_rays ? ratio(*best_rays, "rays_ratio") + " (" + knob(*best_rays) + ")" : std::string("-")) + " | " +
              (best_time ? ratio(*best_time, "time_ratio") + " (" + knob(*best_time) + ")" : std::string("-")) + " |\n";
    }
    // The presets on every scene: what each named setting costs and leaves.
    md += "\n| scene | preset | rays/px | time ms | RMSE | SSIM | MC rays/px for that RMSE | rays ratio | time ratio |\n"
          "|---|---|---:|---:|---:|---:|---:|---:|---:|\n";
    for (const json& r : results)
        for (const json& e : r.at("equal_error")) {
            const std::string method = e.at("method").get<std::string>();
            if (method.rfind("preset_", 0) != 0) continue;
            double ssim = 0;
            for (const json& m : r.at("methods"))
                if (m.at("name") == method && !m.at("points").empty()) ssim = m.at("points")[0].value("ssim", 0.0);
            md += "| " + r.at("scene").get<std::string>() + " | " + method.substr(7) + " | " +
                  fmt("%.1f", e.at("rays_per_pixel").get<double>()) + " | " + fmt("%.0f", e.at("time_ms").get<double>()) + " | " +
                  fmt("%.4f", e.at("rmse").get<double>()) + " | " + fmt("%.4f", ssim) + " | " +
                  fmt("%.0f", e.at("baseline_rays_per_pixel").get<double>()) + " | " + ratio(e, "rays_ratio") + " | " +
                  ratio(e, "time_ratio") + " |\n";
        }
    return md;
}

std::string gnuplot_script(const json& r) {
    // Colours: MC in greys/browns (dashed), aaf variants in distinct hues (solid), presets as large markers.
    static const char* const colours[] = {"#222222", "#8c564b", "#7f7f7f", "#1f77b4", "#d62728", "#2ca02c",
                                          "#9467bd", "#ff7f0e", "#17becf", "#e377c2", "#bcbd22"};
    std::ostringstream o;
    o << "# Generated by aaf-tradeoff from tradeoff.json (" << r["scene"].get<std::string>()
      << "). Run `gnuplot tradeoff.gp` in this folder to redraw rmse_vs_rays.png and rmse_vs_time.png.\n";
    std::vector<std::string> blocks;
    for (const json& m : r["methods"]) {
        std::string block = m["name"].get<std::string>();
        block.insert(block.begin(), '$');  // not "$" + name: GCC 12's -Wrestrict false positive (PR 105329)
        blocks.push_back(block);
        o << block << " << EOD\n# rays_per_pixel time_ms rmse ssim knob_value\n";
        for (const json& p : m["points"])
            o << fmt("%.6g", p["rays_per_pixel"].get<double>()) << ' ' << fmt("%.6g", p["time_ms"].get<double>()) << ' '
              << fmt("%.6g", p["rmse"].get<double>()) << ' ' << fmt("%.6g", p["ssim"].get<double>()) << ' '
              << fmt("%g", p["knob_value"].get<double>()) << '\n';
        o << "EOD\n";
    }
    o << "set terminal pngcairo size 1200,800 noenhanced font 'sans,12'\n"
         "set logscale xy\n"
         "set format x '%g'\nset format y '%g'\n"
         "set grid xtics ytics mxtics mytics lc rgb '#dddddd'\n"
         "set key outside right top box opaque\n"

         "set ylabel 'RMSE of visibility (surface pixels)'\n";
    o << "set title '" << r["scene"].get<std::string>() << ", " << r["width"] << "x" << r["height"] << ", " << r["threads"]
      << " threads; reference " << r["reference_spp"] << " spp (RMSE ~" << fmt("%.2g", r["reference_rmse_estimate"].get<double>())
      << ")'\n";
    // Ranges from the data with a margin of a factor 1.25 (log axes autoscaled to whole decades waste most
    // of the plot).
    double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {0, 0, 0};  // rays, time, rmse
    for (const json& m : r["methods"])
        for (const json& p : m["points"]) {
            const double v[3] = {p["rays_per_pixel"].get<double>(), p["time_ms"].get<double>(), p["rmse"].get<double>()};
            for (int k = 0; k < 3; ++k)
                if (v[k] > 0 && std::isfinite(v[k])) lo[k] = std::min(lo[k], v[k]), hi[k] = std::max(hi[k], v[k]);
        }
    const auto range = [&](const char* axis, int k) {
        if (hi[k] > 0) o << "set " << axis << "range [" << fmt("%.6g", lo[k] / 1.25) << ":" << fmt("%.6g", hi[k] * 1.25) << "]\n";
    };
    range("y", 2);
    const auto plot = [&](const char* output, const char* xlabel, int xcol) {
        range("x", xcol - 1);
        o << "set output '" << output << "'\nset xlabel '" << xlabel << "'\nplot \\\n";
        std::size_t i = 0, aaf_index = 0;
        static const int aaf_point_types[5] = {7, 9, 5, 13, 11};  // filled: circle, triangle, square, diamond, inverted triangle
        for (const json& m : r["methods"]) {
            const std::string kind = m["kind"].get<std::string>();
            const char* colour = colours[i % (sizeof colours / sizeof *colours)];
            o << "  " << blocks[i] << " using " << xcol << ":3 ";
            if (kind == "mc") o << "with linespoints dt 2 lw 2 pt 6 ps 1.2";
            else if (kind == "preset") o << "with points pt " << (5 + 2 * static_cast<int>(i % 3)) << " ps 2.5";
            else o << "with linespoints lw 2 pt " << aaf_point_types[aaf_index++ % 5] << " ps 1.3";
            o << " lc rgb '" << colour << "' title '" << m["name"].get<std::string>() << "'";
            o << (++i < r["methods"].size() ? ", \\\n" : "\n");
        }
    };
    plot("rmse_vs_rays.png", "shadow rays per surface pixel", 1);
    plot("rmse_vs_time.png", ("wall time per frame, ms (median of " + std::to_string(r["repeat"].get<int>()) + " runs)").c_str(), 2);
    o << "unset output\n";
    return o.str();
}

void write_outputs(const json& result, const fs::path& out, bool plot) {
    fs::create_directories(out);
    const fs::path staging = out / (".tradeoff-tmp-" + std::to_string(::getpid()));
    struct cleanup {
        fs::path dir;
        ~cleanup() {
            std::error_code ec;
            fs::remove_all(dir, ec);
        }
    } guard{staging};
    fs::remove_all(staging);
    fs::create_directories(staging);
    std::vector<std::string> files = {"tradeoff.json", "summary.md", "tradeoff.gp"};
    write_file(staging / "tradeoff.json", result.dump(2) + "\n");
    write_file(staging / "summary.md", summary_markdown(result));
    write_file(staging / "tradeoff.gp", gnuplot_script(result));
    if (plot) {
        if (std::system("command -v gnuplot >/dev/null 2>&1") != 0) {
            std::fprintf(stderr, "aaf-tradeoff: gnuplot not found (Debian: gnuplot-nox); no plots, run `gnuplot tradeoff.gp` in %s later\n",
                         out.string().c_str());
        } else if (std::system(("cd " + shell_quote(staging.string()) + " && gnuplot tradeoff.gp 2> gnuplot.log").c_str()) != 0) {
            std::string first;
            std::ifstream log(staging / "gnuplot.log");
            std::getline(log, first);
            std::fprintf(stderr, "aaf-tradeoff: gnuplot failed (%s); no plots\n", first.c_str());
        } else {
            files.push_back("rmse_vs_rays.png");
            files.push_back("rmse_vs_time.png");
        }
    }
    for (const std::string& f : files) fs::rename(staging / f, out / f);
}

}  // namespace aaf_examples::tradeoff
