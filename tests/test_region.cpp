// SPDX-License-Identifier: MIT
// Frame regions: tiles rendered with region_halo's halo reproduce the full frame bit for bit, for every
// guide and offset mode; the halo's size per stage; the region's validation; and the halo's cost.

#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <deque>
#include <random>
#include <vector>

#include <aaf/filter.hpp>
#include <aaf/pipeline.hpp>
#include <aaf/region.hpp>

#include "support/analytic_scene.hpp"
#include "support/helpers.hpp"

using namespace aaf_test;

namespace {

/// Two occluders at different heights (wide and narrow penumbrae), a block of tilted normals and two object
/// IDs, so that every guide rejects some neighbours.
struct tile_scene {
    analytic_scene<float> sc;
    aaf::image<glm::vec3> positions, normals;
    aaf::image<float> pixel_size;
    aaf::image<std::uint32_t> ids;

    tile_scene(std::size_t w, std::size_t h) {
        sc.width = w, sc.height = h;
        sc.occluders = {{-0.6f, 0.6f, -0.3f, 0.3f, 1.0f}, {0.2f, 1.4f, 0.1f, 0.5f, 2.2f}, {-1.5f, -0.9f, 0.6f, 1.6f, 0.3f}};
        positions.reset(w, h), normals.reset(w, h), pixel_size.reset(w, h), ids.reset(w, h);
        const glm::vec3 tilted = glm::normalize(glm::vec3(0.5f, 1.0f, 0.2f));
        for (std::size_t y = 0; y < h; ++y)
            for (std::size_t x = 0; x < w; ++x) {
                positions(x, y) = sc.position(x, y);
                normals(x, y) = (x * 3 > w && x * 2 < w && y * 2 > h) ? tilted : glm::vec3(0, 1, 0);
                // A pixel size that varies, so that β/d does too.
                pixel_size(x, y) = sc.pixel_size() * (1.0f + 0.25f * static_cast<float>((x + 2 * y) % 5));
                ids(x, y) = x + y < (w + h) / 2 ? 1u : 2u;
            }
        positions(w / 3, h / 4) = glm::vec3(std::numeric_limits<float>::quiet_NaN());  // a sky pixel
    }
};

/// A copy of `src`'s pixels in `r`: the tile renders from buffers of its own, as large as the plan says.
template <class U>
aaf::image<U> crop(const aaf::image<U>& src, const aaf::pixel_rect& r) {
    aaf::image<U> out(r.width, r.height);
    for (std::size_t y = 0; y < r.height; ++y)
        for (std::size_t x = 0; x < r.width; ++x) out(x, y) = src(r.x + x, r.y + y);
    return out;
}

struct frame_images {
    aaf::image<float> visibility, shaded;
    aaf::frame_report report;
};

template <bool Ids, class Exec = aaf::sequential_executor>
frame_images render(const tile_scene& s, const aaf::pixel_rect& r, const aaf::frame_region& region,
                    const aaf::frame_settings<float>& settings, Exec&& exec = {}) {
    const auto positions = crop(s.positions, r), normals = crop(s.normals, r);
    const auto pixel_size = crop(s.pixel_size, r);
    const auto ids = crop(s.ids, r);
    frame_images f{aaf::image<float>(r.width, r.height), aaf::image<float>(r.width, r.height), {}};
    aaf::frame_workspace<float> ws;
    span_tracer<float> tracer{&s.sc};
    if constexpr (Ids) {
        const aaf::gbuffer<float, aaf::const_image_view<std::uint32_t>> gb{positions.cview(), normals.cview(),
                                                                           pixel_size.cview(), ids.cview(), region};
        f.report = aaf::render_frame(gb, s.sc.area_light(), tracer, {f.visibility.view(), f.shaded.view()}, ws, settings, exec);
    } else {
        const aaf::gbuffer<float> gb{positions.cview(), normals.cview(), pixel_size.cview(), {}, region};
        f.report = aaf::render_frame(gb, s.sc.area_light(), tracer, {f.visibility.view(), f.shaded.view()}, ws, settings, exec);
    }
    return f;
}

/// Random cuts of [0, n): widths from 1 to n, at least one of width 1 when n > 2.
std::vector<std::size_t> random_cuts(std::size_t n, std::mt19937& rng) {
    std::vector<std::size_t> cuts{0};
    const std::size_t one_at = std::uniform_int_distribution<std::size_t>(1, n - 2)(rng);  // a 1-pixel tile there
    for (std::size_t at = 0; at < n;) {
        std::size_t width = std::uniform_int_distribution<std::size_t>(1, n / 2)(rng);
        if (std::uniform_int_distribution<int>(0, 3)(rng) == 0) width = 1;
        if (at < one_at && at + width > one_at) width = one_at - at;
        if (at == one_at) width = 1;
        at = std::min(n, at + width);
        cuts.push_back(at);
    }
    return cuts;
}

bool same_bits(float a, float b) { return std::memcmp(&a, &b, sizeof a) == 0; }

/// Renders `s` in random tiles and counts the tile pixels whose visibility or shaded value differs in any
/// bit from the full frame's.
template <bool Ids>
std::size_t differing_pixels(const tile_scene& s, const aaf::frame_settings<float>& settings, std::uint32_t seed,
                             std::size_t halo_override = std::size_t(-1), bool key_by_frame = true) {
    const std::size_t w = s.sc.width, h = s.sc.height;
    aaf::thread_pool pool(2);
    const frame_images full = render<Ids>(s, {0, 0, w, h}, {}, settings, pool);
    std::mt19937 rng(seed);
    const auto xs = random_cuts(w, rng), ys = random_cuts(h, rng);
    const std::size_t halo = halo_override != std::size_t(-1) ? halo_override : aaf::region_halo(settings);
    std::size_t differ = 0;
    for (std::size_t j = 0; j + 1 < ys.size(); ++j)
        for (std::size_t i = 0; i + 1 < xs.size(); ++i) {
            const aaf::pixel_rect tile{xs[i], ys[j], xs[i + 1] - xs[i], ys[j + 1] - ys[j]};
            aaf::region_plan plan = aaf::plan_region(tile, w, h, halo);
            if (!key_by_frame) plan.region = {};
            const frame_images t = render<Ids>(s, plan.buffers, plan.region, settings);
            for (std::size_t y = 0; y < tile.height; ++y)
                for (std::size_t x = 0; x < tile.width; ++x) {
                    const std::size_t fx = tile.x + x, fy = tile.y + y, bx = plan.tile.x + x, by = plan.tile.y + y;
                    if (!same_bits(t.visibility(bx, by), full.visibility(fx, fy)) || !same_bits(t.shaded(bx, by), full.shaded(fx, fy)))
                        ++differ;
                }
        }
    return differ;
}

}  // namespace

TEST_CASE("region_halo is the filter's max_radius plus the spreading radius", "[region]") {
    aaf::frame_settings<float> s;
    CHECK(aaf::region_halo(s) == 34);
    CHECK(aaf::region_halo_extent(s).filter == 24);
    CHECK(aaf::region_halo_extent(s).spread == 10);
    s.filter.spread_slopes = false;
    CHECK(aaf::region_halo(s) == 24);
    s.filter.max_radius = 3;
    CHECK(aaf::region_halo(s) == 3);
}

TEST_CASE("plan_region grows a tile by the halo and clips it to the frame", "[region]") {
    const aaf::region_plan p = aaf::plan_region({10, 0, 16, 16}, 40, 30, 34);
    CHECK(p.buffers.x == 0);
    CHECK(p.buffers.y == 0);
    CHECK(p.buffers.width == 40);
    CHECK(p.buffers.height == 30);
    CHECK(p.tile.x == 10);
    CHECK(p.tile.y == 0);
    CHECK(p.region.origin_x == 0);
    CHECK(p.region.frame_width == 40);
    const aaf::region_plan q = aaf::plan_region({100, 50, 8, 8}, 640, 480, 4);
    CHECK(q.buffers.x == 96);
    CHECK(q.buffers.y == 46);
    CHECK(q.buffers.width == 16);
    CHECK(q.buffers.height == 16);
    CHECK(q.tile.x == 4);
    CHECK(q.tile.y == 4);
    CHECK(q.region.origin_x == 96);
    CHECK(q.region.origin_y == 46);
    CHECK(q.region.frame_height == 480);
}

TEST_CASE("random tilings with region_halo reproduce the full frame bit for bit in every guide and offset mode",
          "[region][tiles]") {
    const tile_scene s(34, 28);
    aaf::frame_settings<float> base;
    base.sampling.frame_seed = 7;
    base.filter.max_radius = 8;  // a halo of 18: a tile's buffers are smaller than the frame
    std::uint32_t seed = 1;
    for (const aaf::offset_space space : {aaf::offset_space::image, aaf::offset_space::light_plane}) {
        aaf::frame_settings<float> settings = base;
        settings.filter.space = space;
        const char* sname = space == aaf::offset_space::image ? "image" : "light_plane";
        SECTION(std::string("guides: none (normal threshold 180 degrees), offsets: ") + sname) {
            settings.filter.normal_threshold_degrees = 180;
            CHECK(differing_pixels<false>(s, settings, ++seed) == 0);
        }
        SECTION(std::string("guides: normals, offsets: ") + sname) {
            CHECK(differing_pixels<false>(s, settings, ++seed) == 0);
        }
        SECTION(std::string("guides: normals and IDs, offsets: ") + sname) {
            CHECK(differing_pixels<true>(s, settings, ++seed) == 0);
        }
        SECTION(std::string("guides: normals, IDs, distances in the adaptive pass, offsets: ") + sname) {
            settings.sampling.adaptive_query = aaf::shadow_query::distances;
            CHECK(differing_pixels<true>(s, settings, ++seed) == 0);
        }
        SECTION(std::string("no spreading, offsets: ") + sname) {
            settings.filter.spread_slopes = false;
            CHECK(differing_pixels<true>(s, settings, ++seed) == 0);
        }
    }
    SECTION("issue 13's one configuration: per-axis footprints, Sobol' samples, light_scale 0.9, the horizon rule") {
        aaf::frame_settings<float> settings = base;
        settings.filter.footprint = aaf::pixel_footprint::surface_axes;
        settings.sampling.pattern = aaf::sample_pattern::low_discrepancy;
        settings.formulas.light_scale = 0.9f;
        settings.filter.unfiltered_at_horizon = true;
        CHECK(differing_pixels<true>(s, settings, 77) == 0);
    }
    SECTION("the default settings (halo 34, wider than this frame)") {
        CHECK(differing_pixels<true>(s, aaf::frame_settings<float>{}, 99) == 0);
    }
}

TEST_CASE("tiles differ from the full frame without the halo or without frame keys", "[region][tiles]") {
    // The check above can fail: the same tilings without a halo, or keyed by buffer coordinates, differ.
    const tile_scene s(34, 28);
    aaf::frame_settings<float> settings;
    settings.filter.max_radius = 8;
    CHECK(differing_pixels<true>(s, settings, 3, 0) > 0);
    CHECK(differing_pixels<true>(s, settings, 3, aaf::region_halo(settings), false) > 0);
}

TEST_CASE("filter_visibility over a tile's buffers with max_radius of halo equals the full frame's, for every guide set",
          "[region][tiles]") {
    // The stage API alone: the filter reads max_radius pixels around a pixel and nothing else.
    const tile_scene s(34, 28);
    const std::size_t w = 34, h = 28;
    aaf::image<float> vis(w, h), beta(w, h);
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(0, 1);
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) vis(x, y) = u(rng), beta(x, y) = s.pixel_size(x, y) * 6 * u(rng);
    vis(5, 5) = std::numeric_limits<float>::quiet_NaN();
    aaf::filter_settings<float> fs;
    fs.max_radius = 9;
    const auto check = [&](const auto& make_guides, aaf::offset_space space) {
        fs.space = space;
        aaf::image<float> full(w, h);
        aaf::filter_visibility<float>(vis, beta, s.pixel_size, full.view(), make_guides(aaf::pixel_rect{0, 0, w, h}), fs,
                                      glm::vec3(0, -1, 0));
        std::mt19937 trng(11);
        const auto xs = random_cuts(w, trng), ys = random_cuts(h, trng);
        std::size_t differ = 0;
        for (std::size_t j = 0; j + 1 < ys.size(); ++j)
            for (std::size_t i = 0; i + 1 < xs.size(); ++i) {
                const aaf::pixel_rect tile{xs[i], ys[j], xs[i + 1] - xs[i], ys[j + 1] - ys[j]};
                const aaf::region_plan plan = aaf::plan_region(tile, w, h, fs.max_radius);
                const auto b = plan.buffers;
                const auto tv = crop(vis, b), tb = crop(beta, b), td = crop(s.pixel_size, b);
                aaf::image<float> out(b.width, b.height);
                aaf::filter_visibility<float>(tv, tb, td, out.view(), make_guides(b), fs, glm::vec3(0, -1, 0));
                for (std::size_t y = 0; y < tile.height; ++y)
                    for (std::size_t x = 0; x < tile.width; ++x)
                        differ += !same_bits(out(plan.tile.x + x, plan.tile.y + y), full(tile.x + x, tile.y + y));
            }
        return differ;
    };
    // Guide images cropped per call, kept alive (at stable addresses) until the end of the test.
    std::deque<aaf::image<glm::vec3>> keep3;
    std::deque<aaf::image<std::uint32_t>> keepi;
    const auto normals = [&](aaf::pixel_rect r) { return keep3.emplace_back(crop(s.normals, r)).cview(); };
    const auto positions = [&](aaf::pixel_rect r) { return keep3.emplace_back(crop(s.positions, r)).cview(); };
    const auto ids = [&](aaf::pixel_rect r) { return keepi.emplace_back(crop(s.ids, r)).cview(); };
    using v3 = aaf::const_image_view<glm::vec3>;
    using vi = aaf::const_image_view<std::uint32_t>;
    CHECK(check([&](aaf::pixel_rect) { return aaf::guides<>{}; }, aaf::offset_space::image) == 0);
    CHECK(check([&](aaf::pixel_rect r) { return aaf::guides<v3, aaf::no_guide, aaf::no_guide>{normals(r), {}, {}}; },
                aaf::offset_space::image) == 0);
    CHECK(check([&](aaf::pixel_rect r) { return aaf::guides<aaf::no_guide, vi, aaf::no_guide>{{}, ids(r), {}}; },
                aaf::offset_space::image) == 0);
    CHECK(check([&](aaf::pixel_rect r) { return aaf::guides<v3, vi, aaf::no_guide>{normals(r), ids(r), {}}; },
                aaf::offset_space::image) == 0);
    CHECK(check([&](aaf::pixel_rect r) { return aaf::guides<aaf::no_guide, aaf::no_guide, v3>{{}, {}, positions(r)}; },
                aaf::offset_space::light_plane) == 0);
    CHECK(check([&](aaf::pixel_rect r) { return aaf::guides<v3, vi, v3>{normals(r), ids(r), positions(r)}; },
                aaf::offset_space::light_plane) == 0);
    CHECK(check([&](aaf::pixel_rect r) { return aaf::guides<v3, vi, v3>{normals(r), ids(r), positions(r)}; },
                aaf::offset_space::tangent_plane) == 0);
}

TEST_CASE("a region outside its frame, or with half a frame size, is an invalid_argument naming gbuffer.region",
          "[region][extremes]") {
    const tile_scene s(8, 8);
    const aaf::pixel_rect all{0, 0, 8, 8};
    const aaf::frame_settings<float> settings;
    CHECK_THAT(what_of([&] { render<false>(s, all, {4, 0, 10, 10}, settings); }),
               Catch::Contains("`gbuffer.region` places 8x8 buffers at (4, 0), outside the 10x10 frame"));
    CHECK_THAT(what_of([&] { render<false>(s, all, {0, 0, 10, 0}, settings); }),
               Catch::Contains("`gbuffer.region` gives one frame dimension but not the other"));
    CHECK_THAT(what_of([&] { render<false>(s, all, {0xFFFFFFFAu, 0, 0, 0}, settings); }),
               Catch::Contains("beyond 2^32 pixels"));
    CHECK_NOTHROW(render<false>(s, all, {2, 2, 10, 10}, settings));
}

TEST_CASE("the halo's cost at 16x16, 32x32 and 64x64 tiles (prints a table; docs/RESULTS.md)", "[.][halo_cost]") {
    // Not a check: the figures README.md quotes. A 256x256 frame of the tile scene, default settings.
    const tile_scene s(256, 256);
    const aaf::frame_settings<float> settings;
    const frame_images full = render<true>(s, {0, 0, 256, 256}, {}, settings);
    const std::size_t halo = aaf::region_halo(settings), m = aaf::region_halo_extent(settings).filter;
    std::printf("frame 256x256, default settings (halo %zu = max_radius %zu + spread_radius %zu): %llu rays\n", halo, m,
                halo - m, static_cast<unsigned long long>(full.report.rays()));
    std::printf("| tile | pixels in buffers / frame | initial rays / frame | adaptive rays / frame | all rays / frame | interior tile: buffer pixels / tile pixels |\n");
    for (const std::size_t t : {16u, 32u, 64u}) {
        std::uint64_t pixels = 0, initial = 0, adaptive = 0;
        for (std::size_t y = 0; y < 256; y += t)
            for (std::size_t x = 0; x < 256; x += t) {
                const aaf::region_plan plan = aaf::plan_region({x, y, t, t}, 256, 256, halo);
                const frame_images f = render<true>(s, plan.buffers, plan.region, settings);
                pixels += plan.buffers.width * plan.buffers.height;
                initial += f.report.initial_rays, adaptive += f.report.adaptive_rays;
            }
        const double inner = static_cast<double>((t + 2 * halo) * (t + 2 * halo)) / static_cast<double>(t * t);
        std::printf("| %zux%zu | %.2f | %.2f | %.2f | %.2f | %.1f |\n", t, t, static_cast<double>(pixels) / (256.0 * 256.0),
                    static_cast<double>(initial) / static_cast<double>(full.report.initial_rays),
                    static_cast<double>(adaptive) / static_cast<double>(full.report.adaptive_rays),
                    static_cast<double>(initial + adaptive) / static_cast<double>(full.report.rays()), inner);
    }
}
