// SPDX-License-Identifier: MIT
// libFuzzer harness: the ambient-occlusion family (include/aaf/occlusion/) on a tiny G-buffer with fuzzed
// positions, normals, footprints and IDs, fuzzed sampling and filter settings, and a tracer whose answers
// are fuzzed distances (NaN, negative, +inf, huge, beyond the ray's length), through render_ambient_occlusion.
//
// Settings that validation rejects end the run (not a finding); so do settings beyond the harness's budget
// (more than 256 samples per pixel, kernel or spread radii above 64 px). Both kernels (separable, direct with
// the authors' 50θ term and z_min rejection) are fuzzed.
//
// Invariants (any violation aborts):
// * a pixel with a non-finite position or a zero / non-finite normal has 0 samples, NaN visibility and a NaN
//   bent normal; every other pixel has between 1 and max_samples samples;
// * visibility is NaN (every sample failed) or finite; under cosine sampling it is in [0, 1] (filtered or
//   not: the filter is a normalised average), under uniform sampling >= 0;
// * bent normals of pixels with a finite visibility are unit vectors; β (filter_width) is >= 0 and finite.

#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>

#include <aaf/occlusion.hpp>

#include "fuzz_input.hpp"

namespace {

struct fuzz_tracer {
    float answers[16] = {};
    [[nodiscard]] std::uint32_t slot(const aaf::shadow_segment<float>& s) const noexcept {
        const std::uint32_t h = std::bit_cast<std::uint32_t>(s.direction.x) * 0x9e3779b9u ^
                                std::bit_cast<std::uint32_t>(s.direction.y) * 0x85ebca6bu ^
                                std::bit_cast<std::uint32_t>(s.direction.z);
        return (h ^ (h >> 15)) % 16u;
    }
    [[nodiscard]] float nearest_occluder(const aaf::shadow_segment<float>& s) const noexcept { return answers[slot(s)]; }
    [[nodiscard]] bool occluded(const aaf::shadow_segment<float>& s) const noexcept {
        const float t = answers[slot(s)];
        return t > 0.0f && t < s.length;
    }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    aaf_fuzz::reader in(data, size);
    const std::size_t w = 1 + in.below(6), h = 1 + in.below(6);
    aaf::image<glm::vec3> positions(w, h), normals(w, h);
    aaf::image<float> pixel_size(w, h);
    aaf::image<std::uint32_t> ids(w, h);
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) {
            positions(x, y) = in.vec3(glm::vec3(0.1f * static_cast<float>(x), 0.0f, 0.1f * static_cast<float>(y)));
            normals(x, y) = in.vec3(glm::vec3(0, 1, 0));
            pixel_size(x, y) = in.value(0.1f);
            ids(x, y) = in.below(3);
        }
    aaf::ao_frame_settings<float> s;
    s.sampling.density = in.flag() ? aaf::hemisphere_sampling::uniform : aaf::hemisphere_sampling::cosine;
    s.sampling.pattern = static_cast<aaf::sample_pattern>(in.below(3));
    s.sampling.initial_samples = in.count(16);
    s.sampling.max_samples = in.count(64);
    s.sampling.max_distance = in.value(1.0f);
    s.sampling.falloff = static_cast<aaf::ao_falloff>(in.below(3));
    s.sampling.query = in.flag() ? aaf::ao_query::visibility : aaf::ao_query::distances;
    s.sampling.frame_seed = in.byte();
    s.sampling.origin_offset = in.flag() ? static_cast<double>(in.value(0.001f)) : -1.0;
    s.filter.omega_h = in.value(2.8f);
    s.filter.mu = in.value(2.0f);
    s.filter.alpha = in.value(1.0f);
    s.filter.importance_scale = in.value(0.25f);
    s.filter.min_distance = in.value(0.0f);
    s.filter.normal_threshold_degrees = in.value(5.0f);
    s.filter.truncation = in.value(2.83f);
    s.filter.max_radius = in.count(50);
    s.filter.spread_radius = in.count(10);
    s.filter.space = in.flag() ? aaf::offset_space::image : aaf::offset_space::tangent_plane;
    s.adaptive = !in.flag();
    s.filtered = !in.flag();
    if (s.sampling.max_samples > 256 || s.filter.max_radius > 64 || s.filter.spread_radius > 64) return 0;
    fuzz_tracer tracer;
    for (float& a : tracer.answers) a = in.value(0.5f);
    // Read last, so that inputs found before these settings existed decode as they did (separable kernel).
    if (in.flag()) {
        s.filter.kernel = aaf::ao_filter_kernel::direct;
        s.filter.normal_angle_term = in.flag() ? in.value(50.0f) : 0.0f;
        s.filter.reject_beyond_z_min = in.flag();
    }
    s.filter.rejection_boost = in.flag();  // read after the kernel's flags for the same reason

    const aaf::gbuffer<float, aaf::const_image_view<std::uint32_t>> gb{positions.cview(), normals.cview(), pixel_size.cview(),
                                                                       ids.cview()};
    aaf::image<float> vis(w, h), beta(w, h);
    aaf::image<glm::vec3> bent(w, h);
    aaf::image<std::uint32_t> spp(w, h);
    try {
        aaf::render_ambient_occlusion(gb, tracer, s, aaf::ao_outputs<float>{vis.view(), bent.view(), beta.view(), spp.view()});
    } catch (const aaf::invalid_argument&) {
        return 0;
    }
    const bool cosine = s.sampling.density == aaf::hemisphere_sampling::cosine;
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) {
            const glm::vec3 p = positions(x, y), n = normals(x, y);
            // The library's rule (EXTREMES.md): a normal is usable unless it is zero or has a non-finite
            // component, however short or long (not "|n| > 0 and finite" in float, which under/overflows).
            const bool normal_ok = std::isfinite(n.x) && std::isfinite(n.y) && std::isfinite(n.z) && n != glm::vec3(0);
            const bool surface = std::isfinite(p.x + p.y + p.z) && normal_ok;
            const float v = vis(x, y);
            AAF_FUZZ_CHECK(beta(x, y) >= 0.0f && std::isfinite(beta(x, y)));
            if (!surface) {
                AAF_FUZZ_CHECK(spp(x, y) == 0u);
                AAF_FUZZ_CHECK(std::isnan(v));
                AAF_FUZZ_CHECK(std::isnan(bent(x, y).x));
                continue;
            }
            AAF_FUZZ_CHECK(spp(x, y) >= 1u && spp(x, y) <= s.sampling.max_samples);
            if (std::isnan(v)) continue;  // every sample failed
            AAF_FUZZ_CHECK(std::isfinite(v));
            AAF_FUZZ_CHECK(v >= 0.0f);
            if (cosine) AAF_FUZZ_CHECK(v <= 1.0f + 1e-5f);
            AAF_FUZZ_CHECK(std::abs(glm::length(bent(x, y)) - 1.0f) < 1e-3f);
        }
    return 0;
}
