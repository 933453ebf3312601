// SPDX-License-Identifier: MIT
// The lookup pass's fast paths (issue 9: a fixed-size 4×4 grid reading 4 consecutive texels per row, a table
// for the lit fraction, row order or prefetched 8×8 blocks) against the per-pixel, per-tap definition they
// replace, bit for bit, on a map with varied depths, slanted receivers (non-zero bias slopes) and receivers
// that hang over the map's edges, with the frame's rows along and across the map's rows.

#include <catch2/catch.hpp>

#include <bit>
#include <cmath>
#include <cstdint>
#include <vector>

#include <aaf/shadow_maps.hpp>

namespace {

/// The grid PCF of one receiver as the pass computed it before issue 9: every tap's column and row terms
/// summed and compared one by one, the lit fraction divided out. Non-finite or outside receivers are lit.
float reference_grid(const aaf::depth_map_view<float>& map, const aaf::lookup_settings<float>& s, const glm::vec3& p, const glm::vec3& n) {
    if (!aaf::detail::finite3(p) || !aaf::detail::finite3(n)) return 1.0f;
    const aaf::light_frame<float> frame(map.view);
    const auto r = aaf::detail::prepare_receiver(frame, map.width(), map.height(), map.format, s.bias, p, n);
    if (!r.inside) return 1.0f;
    const std::uint32_t side = aaf::detail::grid_side(s.pcf.taps);
    const auto offsets = aaf::detail::grid_offsets<float>(s.pcf.taps);
    const auto w = static_cast<std::ptrdiff_t>(map.width()), h = static_cast<std::ptrdiff_t>(map.height());
    std::size_t occluded = 0;
    for (std::uint32_t b = 0; b < side; ++b)
        for (std::uint32_t a = 0; a < side; ++a) {
            const auto i = static_cast<std::ptrdiff_t>(std::floor(r.u + s.pcf.radius * offsets[a].x));
            const auto j = static_cast<std::ptrdiff_t>(std::floor(r.v + s.pcf.radius * offsets[b].x));
            if (i < 0 || i >= w || j < 0 || j >= h) continue;
            const float du = static_cast<float>(i) + 0.5f - r.u, dv = static_cast<float>(j) + 0.5f - r.v;
            const float col = r.su * du - r.au * std::abs(du), row = r.z - r.c0 + r.sv * dv - r.av * std::abs(dv);
            occluded += map.depth(static_cast<std::size_t>(i), static_cast<std::size_t>(j)) < row + col ? 1 : 0;
        }
    return 1.0f - static_cast<float>(occluded) / static_cast<float>(side * side);
}

}  // namespace

TEST_CASE("shadow_lookup's grid fast paths equal the per-tap definition bit for bit", "[shadow_maps][pcf]") {
    constexpr std::size_t size = 48;
    std::vector<float> depth(size * size);
    for (std::size_t j = 0; j < size; ++j)
        for (std::size_t i = 0; i < size; ++i)  // a bumpy occluder field around the receivers' depth (z_tex 0.5)
            depth[j * size + i] = 0.5f + 0.02f * std::sin(0.7f * static_cast<float>(i)) * std::cos(0.45f * static_cast<float>(j)) - 0.004f;
    const std::size_t w = 37, h = 29;
    for (const bool across : {false, true}) {
        aaf::light_view<float> view;
        view.eye = {0, 10, 0}, view.forward = {0, -1, 0};
        view.up = across ? glm::vec3(1, 0, 0) : glm::vec3(0, 0, 1);  // the map's rows along world x, or along z
        view.near_plane = 0, view.far_plane = 20, view.half_width = view.half_height = 4;
        const auto map = aaf::wrap_depth_buffer(aaf::const_image_view<float>(depth.data(), size, size), view, aaf::depth_format::unorm24);
        // Receivers on a slanted plane around depth 10 (y = 0), the frame's rows along world x, reaching past
        // the map's edges ([−4, 4]²) on every side; one sky pixel.
        std::vector<glm::vec3> pos(w * h), nrm(w * h, glm::normalize(glm::vec3(0.2f, 1, -0.1f)));
        for (std::size_t y = 0; y < h; ++y)
            for (std::size_t x = 0; x < w; ++x) {
                const float wx = -4.3f + 8.6f * static_cast<float>(x) / static_cast<float>(w - 1);
                const float wz = -4.2f + 8.4f * static_cast<float>(y) / static_cast<float>(h - 1);
                pos[y * w + x] = {wx, -0.2f * wx + 0.1f * wz + 0.01f * std::sin(3.0f * wx), wz};
            }
        pos[5 * w + 7] = glm::vec3(NAN);
        const aaf::gbuffer<float> gb{aaf::const_image_view<glm::vec3>(pos.data(), w, h), aaf::const_image_view<glm::vec3>(nrm.data(), w, h), {}, {}};
        for (const std::uint32_t taps : {16u, 9u, 25u})
            for (const float radius : {2.0f, 1.3f}) {
                aaf::lookup_settings<float> s;
                s.pcf.taps = taps, s.pcf.radius = radius;
                std::vector<float> out(w * h, -1.0f);
                aaf::shadow_lookup(map, gb, s, aaf::image_view<float>(out.data(), w, h));
                std::size_t differ = 0, partial = 0;
                for (std::size_t k = 0; k < w * h; ++k) {
                    differ += out[k] == reference_grid(map, s, pos[k], nrm[k]) ? 0 : 1;
                    partial += out[k] > 0.0f && out[k] < 1.0f ? 1 : 0;
                }
                INFO("across " << across << ", taps " << taps << ", radius " << radius);
                CHECK(differ == 0);
                CHECK(partial > w * h / 8);  // the comparison sees penumbrae (20-40 % of the pixels), not a uniform frame
            }
    }
}

TEST_CASE("shadow_lookup's receivers in lanes equal shadow_map_sampler::visibility bit for bit", "[shadow_maps][pcf]") {
    // The pass prepares a vector's lanes of receivers at once (detail::prepare_receivers, a second copy of
    // prepare_receiver's arithmetic) and compares the default grid's texel rows in vectors; the sampler's
    // visibility() does one receiver and one tap at a time. Every filter, kernel and bias mode, both
    // projections, float and unorm depth; rows of 37 pixels also exercise a partly filled last vector.
    constexpr std::size_t size = 48, w = 37, h = 29;
    for (const auto projection : {aaf::depth_projection::orthographic, aaf::depth_projection::perspective})
        for (const auto format : {aaf::depth_format::float32, aaf::depth_format::unorm24}) {
            aaf::light_view<float> view;
            view.eye = {0.3f, 10, -0.2f}, view.forward = {0.05f, -1, 0.02f}, view.up = {0, 0, 1}, view.projection = projection;
            view.near_plane = projection == aaf::depth_projection::perspective ? 1.0f : 0.0f, view.far_plane = 20;
            view.half_width = view.half_height = projection == aaf::depth_projection::perspective ? 0.4f : 4.0f;
            std::vector<float> depth(size * size);
            for (std::size_t j = 0; j < size; ++j)
                for (std::size_t i = 0; i < size; ++i) {  // a bumpy occluder field through the receivers' depths
                    const double d = 9.95 + 0.5 * std::sin(0.7 * static_cast<double>(i)) * std::cos(0.45 * static_cast<double>(j));
                    depth[j * size + i] = aaf::quantize_z_tex(format, aaf::z_tex_from_depth(projection, d, double(view.near_plane), double(view.far_plane)));
                }
            const auto map = aaf::wrap_depth_buffer(aaf::const_image_view<float>(depth.data(), size, size), view, format);
            std::vector<glm::vec3> pos(w * h), nrm(w * h);
            for (std::size_t y = 0; y < h; ++y)
                for (std::size_t x = 0; x < w; ++x) {
                    const float wx = -4.3f + 8.6f * static_cast<float>(x) / static_cast<float>(w - 1);
                    const float wz = -4.2f + 8.4f * static_cast<float>(y) / static_cast<float>(h - 1);
                    pos[y * w + x] = {wx, -0.2f * wx + 0.1f * wz + 0.01f * std::sin(3.0f * wx), wz};
                    nrm[y * w + x] = glm::normalize(glm::vec3(0.2f + 0.3f * std::sin(wz), 1, -0.1f + 0.2f * std::cos(wx)));
                }
            pos[5 * w + 7] = glm::vec3(NAN), nrm[6 * w + 20] = glm::vec3(NAN), nrm[7 * w + 3] = glm::vec3(0);  // sky, no normal, a zero normal
            pos[8 * w + 33] = glm::vec3(0.5f, 30.0f, 0.5f);                                                    // in front of the near plane
            const aaf::gbuffer<float> gb{aaf::const_image_view<glm::vec3>(pos.data(), w, h), aaf::const_image_view<glm::vec3>(nrm.data(), w, h), {}, {}};
            for (const auto mode : {aaf::bias_mode::none, aaf::bias_mode::constant, aaf::bias_mode::slope_scaled, aaf::bias_mode::normal_offset,
                                    aaf::bias_mode::receiver_plane, aaf::bias_mode::automatic})
                for (int kernel = 0; kernel < 7; ++kernel) {
                    aaf::lookup_settings<float> s;
                    s.bias.mode = mode, s.bias.constant = 0.01f, s.frame_seed = 7;
                    switch (kernel) {
                        case 0: s.filter = aaf::shadow_filter::hard; break;
                        case 1: break;  // the 4×4 grid, radius 2
                        case 2: s.pcf.radius = 1.3f; break;
                        case 3: s.pcf.taps = 9; break;
                        case 4: s.pcf.pattern = aaf::pcf_pattern::rotated_poisson, s.pcf.radius = 2.5f; break;
                        case 5: s.pcf.bilinear = true; break;
                        default: s.filter = aaf::shadow_filter::pcss, s.pcss.light_width = 5.0f, s.pcss.light_angle = 0.5f; break;
                    }
                    const aaf::shadow_map_sampler<float> sampler(map, s);
                    std::vector<float> out(w * h, -1.0f);
                    aaf::shadow_lookup(map, gb, s, aaf::image_view<float>(out.data(), w, h));
                    std::size_t differ = 0, partial = 0;
                    for (std::size_t y = 0; y < h; ++y)
                        for (std::size_t x = 0; x < w; ++x) {
                            const std::size_t k = y * w + x;
                            const float expected = sampler.visibility(pos[k], nrm[k], aaf::pixel_key({}, x, y, 0, s.light_index, s.frame_seed));
                            differ += std::bit_cast<std::uint32_t>(out[k]) == std::bit_cast<std::uint32_t>(expected) ? 0 : 1;
                            partial += out[k] > 0.0f && out[k] < 1.0f ? 1 : 0;
                        }
                    INFO(aaf::to_string(projection) << ", " << aaf::to_string(format) << ", bias " << aaf::to_string(mode) << ", kernel " << kernel);
                    CHECK(differ == 0);
                    if (kernel != 0) CHECK(partial > w * h / (kernel == 6 ? 40 : 10));  // penumbrae are compared, not a uniform frame
                }
        }
}
