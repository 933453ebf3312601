// SPDX-License-Identifier: MIT
#pragma once
// aaf-tradeoff's engine: renders one scene with every method over its cost knob against a converged
// reference, measures rays, milliseconds and error per point, finds how many more rays and how much more
// time unfiltered stratified Monte Carlo needs for the same error ("equal error"), and writes the result
// as JSON, a markdown summary and a gnuplot script (examples/aaf-tradeoff.cpp is the command line).
//
// The JSON (tradeoff.json) is a contract other tools read; "format" changes when it does:
//   {"format": 1, "generator": "aaf-tradeoff", "scene", "width", "height", "triangles", "surface_pixels",
//    "threads", "repeat", "seed", "reference_spp", "reference_seeds": [a, b], "reference_rmse_estimate",
//    "reference_ms", "reference_from_cache", "metric_mask": "surface pixels",
//    "rays_per_pixel_unit": ..., "timing": ..., "quick", "max_mc_spp",
//    "quantity": "shadow"|"ambient_occlusion"|"subsurface", "baseline": the equal-error baseline's name,
//    "methods": [{"name", "kind": the method's family ("mc"|"aaf"|"preset"|...), "knob", "settings": {...},
//                 "points": [{"knob_value", "rays_per_pixel", "time_ms", "rays_ms", "filter_ms",
//                             "<stage>_ms" for every stage the method names (aaf and presets: "formulas_ms"),
//                             "filter_share", "memory_bytes", "rmse", "ssim",
//                             "max_abs_error", "time_ms_runs": [...]}]}],
//    "equal_error": [{"method", "point", "knob_value", "baseline": "mc_stratified", "rmse", "rays_per_pixel",
//                     "time_ms", "baseline_rays_per_pixel", "baseline_time_ms", "rays_ratio", "time_ratio",
//                     "extrapolated", "bound": "interpolated"|"lower"|"upper"}]}

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/methods.hpp"

namespace aaf_examples::tradeoff {

/// The registry's methods (examples/common/methods.hpp) that estimate `what`, in the order they are reported.
[[nodiscard]] std::vector<std::string> method_names(quantity what);

/// The shadow quantity's equal-error baseline (each quantity's is its quantity_reference::baseline_method).
inline constexpr const char* baseline_method = "mc_stratified";

struct config {
    std::string scene = "boxes";                ///< built-in name, name in scenes_dir, or a .json file
    std::filesystem::path scenes_dir;           ///< where scene names are looked up
    std::optional<std::size_t> width, height;   ///< override the scene's image size
    std::size_t threads = 2;                    ///< 0 = all cores
    std::filesystem::path cache;                ///< reference cache folder
    std::uint32_t seed = 0;                     ///< frame seed of every measured method
    std::string tracer = "bvh";                 ///< "bvh", "embree" or "embree-single" (--tracer)
    std::uint32_t reference_spp = 4096;         ///< total; rendered as two independent halves
    std::uint32_t repeat = 3;                   ///< timings are the median of this many runs
    std::uint32_t max_mc_spp = 1024;            ///< cap of the stratified baseline's sweep
    quantity what = quantity::shadow;           ///< what the run measures: its methods, reference and baseline
    std::vector<std::string> methods;           ///< empty = all of `what`; the baseline is added when filtered ones are
    bool quick = false;                         ///< short sweeps (tests)
    bool progress = true;                       ///< one line per point on stderr
};

/// Throws usage_error for an unknown method name (naming it and listing the known ones), from the registry.
void check_methods(const std::vector<std::string>& methods);

/// Runs everything and returns tradeoff.json's content. Throws scene_error / usage_error / std::exception.
[[nodiscard]] nlohmann::json run(const config& c);

/// A point of a cost/error curve.
struct curve_point {
    double rays = 0;  ///< rays per pixel
    double time = 0;  ///< milliseconds
    double rmse = 0;
};

/// What the baseline needs to reach an error.
struct equal_cost {
    double rays = 0, time = 0;
    bool extrapolated = false;
    /// "interpolated": on the curve; "lower": the curve never gets this low, so rays/time are its last
    /// point's (the true cost is higher); "upper": even its cheapest point is better, so they are that
    /// point's (the true cost is lower).
    std::string bound = "interpolated";
};

/// The cost at which `baseline` reaches `target_rmse`: the points are sorted by rays, and the first
/// segment (from the cheapest) whose ends straddle the target is interpolated piecewise-linearly in
/// log(rmse)–log(rays) and, with the same parameter, log(rmse)–log(time). Exact for power laws
/// rmse = c·rays^-k on each segment. Throws std::invalid_argument for an empty curve or a target or
/// point that is not finite and positive.
[[nodiscard]] equal_cost equal_error_cost(std::vector<curve_point> baseline, double target_rmse);

/// The markdown summary: one table per method, then the equal-error table.
[[nodiscard]] std::string summary_markdown(const nlohmann::json& result);

/// The cross-scene tables (scripts/results' docs/results/overview.md) from several runs' tradeoff.json: one
/// row per scene (equal error at the paper's μ = 2, the best ratios of any aaf variant, the filter's share),
/// then every preset on every scene.
[[nodiscard]] std::string overview_markdown(const std::vector<nlohmann::json>& results);

/// A self-contained gnuplot script (inline data blocks) that draws rmse_vs_rays.png and rmse_vs_time.png
/// in the current directory.
[[nodiscard]] std::string gnuplot_script(const nlohmann::json& result);

/// Writes tradeoff.json, summary.md, tradeoff.gp and (with `plot`, when gnuplot runs) the two PNGs into
/// `out`: everything is made in a temporary folder inside `out` and renamed into place at the end, so a
/// failed run leaves the previous results. A missing or failing gnuplot is reported on stderr and skipped.
void write_outputs(const nlohmann::json& result, const std::filesystem::path& out, bool plot);

}  // namespace aaf_examples::tradeoff
