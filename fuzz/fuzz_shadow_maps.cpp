// SPDX-License-Identifier: MIT
// libFuzzer harness: the shadow-map family (include/aaf/shadow_maps/) with arbitrary views, stored depths,
// lookup settings and receivers, in float.
//
// Input: a light view (validated by depth_map's constructor: rejected views are not findings), a map of up to
// 8×8 texels whose z_tex values are arbitrary (NaN, ±Inf, out of [0, 1]: what a caller may store), lookup
// settings (rejected ones are not findings), then receivers (position, normal, sample key).
//
// Invariants (any violation aborts):
// * every lookup (hard, PCF in every pattern, bilinear or not, PCSS) returns a value in [0, 1], never NaN;
// * PCSS's penumbra estimate is >= 0 or +Inf, never NaN;
// * wrap_depth_buffer accepts a buffer only if every texel is a z_tex in [0, 1];
// * for an accepted view, stored z_tex 0 and 1 reconstruct depths ordered as near <= far (or non-finite
//   when the planes' difference overflows).

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include <aaf/shadow_maps.hpp>

#include "fuzz_input.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    aaf_fuzz::reader in(data, size);
    aaf::light_view<float> v;
    v.projection = in.flag() ? aaf::depth_projection::perspective : aaf::depth_projection::orthographic;
    v.eye = in.vec3(glm::vec3(0, 3, 0));
    v.forward = in.vec3(glm::vec3(0, -1, 0));
    v.up = in.vec3(glm::vec3(0, 0, 1));
    v.near_plane = in.value(0.5f);
    v.far_plane = in.value(4.0f);
    v.half_width = in.value(1.0f);
    v.half_height = in.value(1.0f);
    const std::size_t w = 1 + in.below(8), h = 1 + in.below(8);
    const aaf::depth_format fmt = static_cast<aaf::depth_format>(in.below(3));
    aaf::depth_map<float> map;
    try {
        map = aaf::depth_map<float>(w, h, v, fmt);
    } catch (const aaf::invalid_argument&) {
        return 0;
    }
    std::vector<float> raw(w * h);
    for (std::size_t j = 0; j < h; ++j)
        for (std::size_t i = 0; i < w; ++i) {
            const double z = static_cast<double>(in.value(0.5f));
            map.store_z_tex(i, j, z);
            raw[j * w + i] = static_cast<float>(z);
        }
    bool in_range = true;
    for (const float z : raw) in_range = in_range && z >= 0.0f && z <= 1.0f;
    try {
        (void)aaf::wrap_depth_buffer(aaf::const_image_view<float>(raw.data(), w, h), v, fmt);
        AAF_FUZZ_CHECK(in_range);
    } catch (const aaf::invalid_argument&) {
        AAF_FUZZ_CHECK(!in_range);
    }
    const float d0 = aaf::depth_from_z_tex(v.projection, 0.0f, v.near_plane, v.far_plane);
    const float d1 = aaf::depth_from_z_tex(v.projection, 1.0f, v.near_plane, v.far_plane);
    AAF_FUZZ_CHECK(!(d0 > d1));

    aaf::lookup_settings<float> s;
    s.filter = static_cast<aaf::shadow_filter>(in.below(3));
    s.pcf.pattern = static_cast<aaf::pcf_pattern>(in.below(3));
    s.pcf.taps = 1 + in.below(64);
    s.pcf.radius = in.value(2.0f);
    s.pcf.bilinear = in.flag();
    s.pcss.light_width = in.value(1.0f);
    s.pcss.light_angle = in.value(0.1f);
    s.pcss.blocker_taps = 1 + in.below(64);
    s.pcss.max_radius = in.value(32.0f);
    s.bias.mode = static_cast<aaf::bias_mode>(in.below(6));
    s.bias.constant = in.value(0.0f);
    s.bias.slope_factor = in.value(1.0f);
    s.bias.units = in.value(1.0f);
    s.bias.normal_offset = in.value(1.0f);
    s.bias.max_slope = in.value(16.0f);
    s.bias.scale = in.value(1.5f);
    std::optional<aaf::shadow_map_sampler<float>> sampler;
    try {
        sampler.emplace(map.map_view(), s);
    } catch (const aaf::invalid_argument&) {
        return 0;
    }
    const aaf::light_frame<float> frame(v);
    for (int k = 0; k < 4 && !in.empty(); ++k) {
        // Receivers near the map's middle by default, anywhere when the input says so.
        const glm::vec3 p = in.vec3(frame.world_point(0.5f * static_cast<float>(w), 0.5f * static_cast<float>(h),
                                                      0.5f * (v.near_plane + v.far_plane), w, h));
        const glm::vec3 n = in.vec3(-frame.forward);
        const aaf::sample_key key{in.raw<std::uint32_t>(), in.raw<std::uint32_t>(), 0, 0, in.raw<std::uint32_t>()};
        const float vis = sampler->visibility(p, n, key);
        AAF_FUZZ_CHECK(vis >= 0.0f && vis <= 1.0f);
        const float pen = sampler->pcss_penumbra_width(p, n);
        AAF_FUZZ_CHECK(pen >= 0.0f);
    }
    return 0;
}
