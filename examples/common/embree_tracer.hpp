// SPDX-License-Identifier: MIT
#pragma once
// The examples' second tracer: the same queries as `aaf_examples::bvh` (common/bvh.hpp) answered by Embree 3
// (Debian's libembree-dev), so that either can be passed wherever the other is. Built only when CMake finds
// Embree (option AAF_WITH_EMBREE; AAF_EXAMPLES_EMBREE is then 1). Embree's headers stay in embree_tracer.cpp.
//
// Input and triangle indices are as for `bvh`: an indexed mesh, triangles with a non-finite vertex or zero area
// dropped and counted (the same `usable_triangle` test), hits reporting the index into the `triangles` given.
//
// How each query maps onto Embree (single-ray forms, rtcIntersect1 / rtcOccluded1; scene built with
// RTC_SCENE_FLAG_ROBUST, so rays through shared edges and vertices do not leak between triangles):
//   nearest_occluder  rtcIntersect1 with tnear = the smallest normal float, tfar = the float below
//                     length·(1 − 2^-20): Embree accepts tnear <= t <= tfar, the contract's open interval
//                     0 < t < length less a margin at the light end, because Embree's distances are not exact
//                     (its AVX2 kernels put a hit at exactly t = length one ulp short of it, which counted the
//                     light's own geometry as an occluder). An occluder within 2^-20 of the length from the
//                     light point is not reported (the BVH, whose distances are exact there, reports it).
//   occluded          rtcOccluded1 over the same interval. It reports no distance (Embree stops at any hit).
//   occluder_span     two rtcIntersect1: the nearest hit from the receiver, then, when there is one, the nearest
//                     hit from the light point back towards the receiver, which is the farthest hit of the
//                     segment. The back ray starts at the light point, or where the segment leaves the scene's
//                     bounds when that is nearer (an infinite segment). Its distance, end - u, is rounded once
//                     more than the BVH's (a few ulps of the segment's length).
//   nearest_hit       rtcIntersect1; the normal is computed from the triangle's vertices exactly as `bvh` does.
// An invalid segment (non-finite origin or direction, zero direction, NaN length) gives NaN / false, as `bvh`;
// so does an origin or direction component beyond Embree's limit of 1.844e18 (which `bvh` would trace).
// All queries are const and thread-safe (Embree's traversal of a committed scene is).

#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <span>
#include <vector>

#include <glm/vec3.hpp>

#include <aaf/tracer.hpp>

#include "common/bvh.hpp"  // ray_hit, usable_triangle

namespace aaf_examples {

/// Embree scene settings.
struct embree_tracer_options {
    /// RTC_SCENE_FLAG_ROBUST: watertight edges and vertices (as the BVH's), at some cost in speed.
    bool robust = true;
    /// RTC_BUILD_QUALITY_HIGH instead of MEDIUM: a slower build (SAH with spatial splits), faster rays.
    bool high_quality = false;
    /// Embree's worker threads for the build (0: Embree's default, all hardware threads).
    unsigned build_threads = 0;
};

/// Embree 3 behind the tracer queries of `bvh`. Move-only; owns its Embree device and scene.
class embree_tracer {
public:
    /// Builds the Embree scene. Throws std::invalid_argument as `bvh` does (no triangles, an index out of range,
    /// no usable triangle) and std::runtime_error when Embree fails (its message included).
    embree_tracer(std::span<const glm::vec3> vertices, std::span<const glm::uvec3> triangles,
                  const embree_tracer_options& options = {});
    ~embree_tracer();
    embree_tracer(embree_tracer&&) noexcept;
    embree_tracer& operator=(embree_tracer&&) noexcept;
    embree_tracer(const embree_tracer&) = delete;
    embree_tracer& operator=(const embree_tracer&) = delete;

    /// Nearest hit of the ray origin + t·direction with 0 < t < t_max (as bvh::nearest_hit).
    [[nodiscard]] ray_hit nearest_hit(const glm::vec3& origin, const glm::vec3& direction,
                                      float t_max = std::numeric_limits<float>::infinity()) const noexcept;
    /// aaf contract: nearest and farthest hit with 0 < t < length (two rays, see above); a miss is a default
    /// span; an invalid segment gives NaN.
    [[nodiscard]] aaf::occluder_span<float> occluder_span(const aaf::shadow_segment<float>& segment) const noexcept;
    /// aaf contract: nearest hit with 0 < t < length, aaf::no_occluder on a miss, NaN for an invalid segment.
    [[nodiscard]] float nearest_occluder(const aaf::shadow_segment<float>& segment) const noexcept;
    /// Any hit with 0 < t < length; false for an invalid segment.
    [[nodiscard]] bool occluded(const aaf::shadow_segment<float>& segment) const noexcept;

    // Batched forms: aaf's batched tracer queries (include/aaf/tracer.hpp: trace_batch, nearest_batch,
    // occluded_batch, with the library's exact signatures, so aaf::render_frame detects and calls them), traced 16
    // at a time through Embree's ray packets (rtcIntersect16 / rtcOccluded16; Embree runs a 16-wide packet as two
    // 8-wide halves where the CPU has no AVX-512). aaf hands them whole pixels' segments, several pixels per call
    // (at least sampling_settings::batch_rays, 64 by default), so packets are full but for the last one of a
    // call. `out` must have the size of `segments` (else std::invalid_argument). Each answers what the single-ray
    // form of the same name answers for every segment (up to the rounding of Embree's packet kernels).
    static constexpr std::size_t packet_size = 16;  ///< rays per Embree packet

    /// Any hit: occluded() of every segment (false for invalid ones); rtcOccluded16.
    void occluded_batch(std::span<const aaf::shadow_segment<float>> segments, std::span<bool> out) const;
    /// Nearest hit only: nearest_occluder() of every segment (aaf::no_occluder on a miss, NaN for invalid ones);
    /// rtcIntersect16. What aaf uses when the tracer is shown to it without trace_batch (a "first hit" tracer).
    void nearest_batch(std::span<const aaf::shadow_segment<float>> segments, std::span<float> out) const;
    /// Nearest and farthest hit: occluder_span() of every segment. A packet cannot return the farthest hit, so
    /// this is the honest packet way of the single-ray form's two rays: packets of nearest hits for all the
    /// segments, then the back rays (from the light point towards the receiver) of the occluded segments alone,
    /// gathered into full packets (up to 256 segments at a time), so an unoccluded segment costs one ray and an
    /// occluded one two.
    void trace_batch(std::span<const aaf::shadow_segment<float>> segments,
                     std::span<aaf::occluder_span<float>> out) const;

    /// Triangles in the Embree scene (after dropping unusable ones).
    [[nodiscard]] std::size_t triangle_count() const noexcept;
    /// Input triangles dropped as unusable (non-finite vertex or zero area).
    [[nodiscard]] std::size_t dropped_triangles() const noexcept;

private:
    struct impl;
    std::unique_ptr<impl> impl_;
};

}  // namespace aaf_examples
