// SPDX-License-Identifier: MIT
#pragma once
// What the example renderers (aaf-render, aaf-tradeoff) share: the G-buffer of a pinhole camera, the
// tracers the BVH offers aaf (all hits, first hit, visibility only), the converged reference and its disk
// cache, unfiltered Monte Carlo, and image metrics (RMSE, SSIM, largest error) over surface pixels.

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <glm/vec3.hpp>

#include <aaf/executor.hpp>
#include <aaf/image.hpp>
#include <aaf/sampler.hpp>
#include <aaf/tracer.hpp>

#include "common/bvh.hpp"
#include "common/scene.hpp"
#if AAF_EXAMPLES_EMBREE
#include "common/embree_tracer.hpp"
#endif

namespace aaf_examples {

using clock_type = std::chrono::steady_clock;

/// Milliseconds since `t0`.
[[nodiscard]] double ms_since(clock_type::time_point t0);

/// A user error of a command-line tool: printed as one line, exit code 1.
struct usage_error : std::runtime_error {
    using std::runtime_error::runtime_error;
};

/// A whole number in [lo, hi] for `flag`, else usage_error naming the flag and the value.
[[nodiscard]] std::uint32_t parse_count(const std::string& flag, const std::string& v, std::uint32_t lo, std::uint32_t hi);
/// "WxH" with each side in [1, max_image_side], else usage_error naming --size.
void parse_size(const std::string& v, std::size_t& width, std::size_t& height);

/// Runs `body` (which returns the exit code) and turns any exception into one line on stderr,
/// "<tool>: <message>", and exit code 1: every error of the examples' command lines looks the same.
template <class Body>
int report_errors(const char* tool, Body&& body) {
    try {
        return body();
    } catch (const std::exception& e) {
        std::string what = e.what();
        std::replace(what.begin(), what.end(), '\n', ' ');
        std::fprintf(stderr, "%s: %s\n", tool, what.c_str());
        return 1;
    }
}

/// Where the options both tools take (--scene, --scenes-dir, --out, --cache, --size, --seed, --tracer) are stored.
struct shared_options {
    std::string& scene;
    std::filesystem::path& scenes_dir;
    std::filesystem::path& out;
    std::filesystem::path& cache;
    std::optional<std::size_t>& width;
    std::optional<std::size_t>& height;
    std::uint32_t& seed;
    std::string* tracer = nullptr;  ///< --tracer bvh|embree (checked by scene_tracer); null: the tool has no --tracer
};

/// The examples' ray tracer: the BVH (common/bvh.hpp), or Embree 3 (common/embree_tracer.hpp) when the examples
/// were built with it, behind the BVH's queries. Either owns its tracer (built from a scene) or borrows a BVH
/// (the implicit conversion, so code holding a `bvh` passes it wherever a scene_tracer is asked for).
///
/// It offers aaf every query of the contract, single-ray and batched (tracer.hpp), so aaf always hands it
/// batches (trace_batch for distances, occluded_batch for visibility; nearest_batch through first_hit_tracer).
/// What a batch costs depends on the kind chosen at run time:
///   "bvh"            the BVH one ray at a time (a single-ray tracer: the batch is a loop, same answers);
///   "embree"         Embree's 16-wide packets (embree_tracer's trace_batch / nearest_batch / occluded_batch);
///   "embree-single"  Embree one ray at a time (rtcIntersect1 / rtcOccluded1), to measure what packets buy.
class scene_tracer {
    // First: the members below deduce their return type from dispatch().
#if AAF_EXAMPLES_EMBREE
    [[nodiscard]] bool is_embree() const noexcept { return embree_ != nullptr; }
    template <class F>
    decltype(auto) dispatch(F&& f) const noexcept { return embree_ ? f(*embree_) : f(*bvh_); }
    std::unique_ptr<embree_tracer> owned_embree_;
    const embree_tracer* embree_ = nullptr;
    bool packets_ = false;  // "embree": batches go to Embree's packets; "embree-single": one ray at a time
    [[nodiscard]] bool packets() const noexcept { return packets_; }
#else
    [[nodiscard]] static constexpr bool packets() noexcept { return false; }
    [[nodiscard]] bool is_embree() const noexcept { return false; }
    template <class F>
    decltype(auto) dispatch(F&& f) const noexcept { return f(*bvh_); }
#endif
    std::unique_ptr<bvh> owned_bvh_;
    const bvh* bvh_ = nullptr;

public:
    /// Builds `kind` ("bvh", "embree" or "embree-single") over the scene's triangles; usage_error for another
    /// name or for an Embree kind in a build without Embree.
    scene_tracer(const scene& s, const std::string& kind);
    scene_tracer(const bvh& borrowed) noexcept : bvh_(&borrowed) {}  // NOLINT: implicit on purpose
    scene_tracer(scene_tracer&&) noexcept = default;
    scene_tracer(const scene_tracer&) = delete;
    scene_tracer& operator=(const scene_tracer&) = delete;
    ~scene_tracer();

    /// The kind: "bvh", "embree" or "embree-single".
    [[nodiscard]] const char* name() const noexcept { return is_embree() ? (packets() ? "embree" : "embree-single") : "bvh"; }
    /// The ray tracer behind it, "bvh" or "embree": what its answers depend on (the kind's batching does not
    /// change them beyond float rounding; the reference cache key holds this).
    [[nodiscard]] const char* engine() const noexcept { return is_embree() ? "embree" : "bvh"; }
    [[nodiscard]] std::size_t triangle_count() const noexcept { return dispatch([](const auto& t) { return t.triangle_count(); }); }
    [[nodiscard]] ray_hit nearest_hit(const glm::vec3& origin, const glm::vec3& direction,
                                      float t_max = std::numeric_limits<float>::infinity()) const noexcept {
        return dispatch([&](const auto& t) { return t.nearest_hit(origin, direction, t_max); });
    }
    [[nodiscard]] aaf::occluder_span<float> occluder_span(const aaf::shadow_segment<float>& g) const noexcept {
        return dispatch([&](const auto& t) { return t.occluder_span(g); });
    }
    [[nodiscard]] float nearest_occluder(const aaf::shadow_segment<float>& g) const noexcept {
        return dispatch([&](const auto& t) { return t.nearest_occluder(g); });
    }
    [[nodiscard]] bool occluded(const aaf::shadow_segment<float>& g) const noexcept {
        return dispatch([&](const auto& t) { return t.occluded(g); });
    }
    // aaf's batched forms (tracer.hpp). `out` has the size of `segments` (aaf's gathers guarantee it).
    void trace_batch(std::span<const aaf::shadow_segment<float>> segments, std::span<aaf::occluder_span<float>> out) const;
    void nearest_batch(std::span<const aaf::shadow_segment<float>> segments, std::span<float> out) const;
    void occluded_batch(std::span<const aaf::shadow_segment<float>> segments, std::span<bool> out) const;
};
/// If `flag` is one of the shared options, stores its value (read with `value()`) and returns true.
bool parse_shared_option(const std::string& flag, const std::function<std::string()>& value, const shared_options& o);

/// The tracer with only its nearest occluder visible: the "first hit" statistics of FORMULAS.md §1.3.
struct first_hit_tracer {
    const scene_tracer* tracer;
    [[nodiscard]] float nearest_occluder(const aaf::shadow_segment<float>& s) const noexcept { return tracer->nearest_occluder(s); }
    // The adaptive pass only asks "occluded?" (shadow_query::visibility): give it the any-hit query too.
    [[nodiscard]] bool occluded(const aaf::shadow_segment<float>& s) const noexcept { return tracer->occluded(s); }
    // Batched, as scene_tracer (nearest-only packets, rtcIntersect16, with --tracer embree).
    void nearest_batch(std::span<const aaf::shadow_segment<float>> s, std::span<float> out) const { tracer->nearest_batch(s, out); }
    void occluded_batch(std::span<const aaf::shadow_segment<float>> s, std::span<bool> out) const { tracer->occluded_batch(s, out); }
};

/// The G-buffer of a pinhole camera, in the layout aaf reads. Sky pixels have NaN position and normal.
struct gbuffer_images {
    aaf::image<glm::vec3> positions, normals;
    aaf::image<float> pixel_size, albedo;
    aaf::image<std::uint32_t> ids;
    std::size_t surfaces = 0;  ///< pixels with a surface

    [[nodiscard]] bool surface(std::size_t i) const noexcept;
    /// 1 for surface pixels, 0 for sky: the mask the metrics use.
    [[nodiscard]] std::vector<unsigned char> surface_mask() const;
};

/// Primary rays through every pixel centre of `s`'s camera.
[[nodiscard]] gbuffer_images render_gbuffer(const scene& s, const scene_tracer& tracer, aaf::thread_pool& pool);

/// Visibility for display and comparison: sky pixels 1, surface pixels without light (NaN) 0.
[[nodiscard]] aaf::image<float> displayable(const aaf::image<float>& raw, const gbuffer_images& g);

/// What defines a reference: every field is part of its cache key (with the scene's geometry, light,
/// camera and image size).
struct reference_params {
    std::uint32_t spp = 1024;                                   ///< stratified samples per pixel
    std::uint32_t seed = 0;                                     ///< frame seed of its samples (passes 1000+)
    aaf::light_weighting weighting = aaf::light_weighting::uniform;
    double origin_offset = -1;                                  ///< as sampling_settings::origin_offset
};

struct reference_result {
    aaf::image<float> visibility;  ///< NaN where no sample counted (light below the horizon)
    bool from_cache = false;
    double ms = 0;
};

/// The cache file name of a reference: a 64-bit hash of everything it depends on, the tracer's engine
/// ("bvh" or "embree", scene_tracer::engine()) included: the reference is traced from that tracer's G-buffer
/// with that tracer's any-hit query, and the two tracers round differently (G-buffer positions within ~1e-4,
/// a rare ray through a rounding tie), so an Embree run must not silently be judged against a BVH reference.
[[nodiscard]] std::string reference_file_name(const scene& s, const reference_params& p, std::string_view engine);

/// The converged reference: plain stratified Monte Carlo with `p.spp` samples per pixel through the BVH's
/// any-hit query and its own loop (independent of aaf's gathering code, which it judges), in chunks (with a
/// progress bar and an ETA on stderr unless `progress` is false); cached under `cache` (written atomically:
/// temporary file, rename).
[[nodiscard]] reference_result reference_visibility(const scene& s, const gbuffer_images& g, const scene_tracer& tracer,
                                                    const reference_params& p, const std::filesystem::path& cache,
                                                    aaf::thread_pool& pool, bool progress = true);

/// What unfiltered Monte Carlo needs besides the scene.
struct mc_params {
    aaf::sample_pattern pattern = aaf::sample_pattern::stratified;
    std::uint32_t spp = 1;
    std::uint32_t seed = 0;   ///< frame seed
    std::uint32_t pass = 0;   ///< sample pass (aaf's initial pass is 0, so equal spp means equal samples)
    aaf::light_weighting weighting = aaf::light_weighting::uniform;
    double origin_offset = -1;
};

struct mc_result {
    aaf::image<float> visibility;  ///< displayable (sky 1, no light 0)
    std::uint64_t rays = 0;        ///< shadow rays traced
    double rays_ms = 0;            ///< tracing (aaf::gather_occlusion with the any-hit tracer)
    double total_ms = 0;           ///< tracing + averaging into an image
};

/// Unfiltered Monte Carlo: `p.spp` samples per surface pixel of `p.pattern`, averaged.
[[nodiscard]] mc_result render_mc(const scene& s, const gbuffer_images& g, const scene_tracer& tracer, const mc_params& p,
                                  aaf::thread_pool& pool);

/// Image metrics over the pixels where `mask` is non-zero (an empty mask: every pixel).
/// Root mean square of a − b; non-finite differences are errors of 1 (they should not happen).
[[nodiscard]] double rmse(const aaf::image<float>& a, const aaf::image<float>& b, const std::vector<unsigned char>& mask = {});
/// Largest |a − b|.
[[nodiscard]] double max_abs_error(const aaf::image<float>& a, const aaf::image<float>& b, const std::vector<unsigned char>& mask = {});
/// SSIM of Wang, Bovik, Sheikh & Simoncelli (2004) for values in [0, 1] (dynamic range L = 1, C1 = 0.01²,
/// C2 = 0.03²) with their 11×11 Gaussian window (σ = 1.5), averaged over the masked pixels. Local means,
/// variances and covariance are Gaussian-weighted over the masked pixels of the window only, normalised
/// by the weight that remains, so sky pixels and the image border never enter (with no mask and away
/// from the border this is exactly the standard SSIM). 1 for identical images; symmetric.
[[nodiscard]] double ssim(const aaf::image<float>& a, const aaf::image<float>& b, const std::vector<unsigned char>& mask = {});

}  // namespace aaf_examples
