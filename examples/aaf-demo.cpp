// SPDX-License-Identifier: MIT
// aaf-demo: renders the soft shadow of a lattice, a tilted bar and a box standing on the floor under a
// rectangular light, with an analytic box tracer (no meshes yet), and writes the noisy input, the aaf
// result, a converged reference, the error and the β / samples-per-pixel maps as PNGs.
//
//   aaf-demo [--out DIR] [--size WxH] [--reference-spp N] [--threads N] [--mu X]

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include <stb_image_write.h>

#include <aaf/aaf.hpp>

namespace {

using vec3 = glm::vec3;

/// An axis-aligned box; every occluder and the floor are boxes.
struct box {
    vec3 lo, hi;
    std::uint32_t id;
};

/// Slab test of a ray against a box: entry and exit distances, and the entry face's normal.
bool intersect(const box& b, const vec3& o, const vec3& inv_d, float& t0, float& t1, int& axis) {
    t0 = 0.0f;
    t1 = std::numeric_limits<float>::infinity();
    axis = -1;
    for (int a = 0; a < 3; ++a) {
        float n = (b.lo[a] - o[a]) * inv_d[a], f = (b.hi[a] - o[a]) * inv_d[a];
        if (n > f) std::swap(n, f);
        if (n > t0) t0 = n, axis = a;
        t1 = std::min(t1, f);
        if (t0 > t1) return false;
    }
    return true;
}

struct scene {
    std::vector<box> boxes;

    /// The tracer contract: nearest and farthest occluder along a shadow segment ("all hits").
    [[nodiscard]] aaf::occluder_span<float> occluder_span(const aaf::shadow_segment<float>& s) const {
        aaf::occluder_span<float> out{};
        const vec3 inv = 1.0f / s.direction;
        for (const box& b : boxes) {
            float t0, t1;
            int axis;
            if (!intersect(b, s.origin, inv, t0, t1, axis) || t0 >= s.length) continue;
            out.nearest = std::min(out.nearest, std::max(t0, 0.0f));
            out.farthest = std::max(out.farthest, std::min(t1, s.length));
        }
        return out;
    }

    /// Primary ray: nearest hit, its normal and object id.
    bool primary(const vec3& o, const vec3& d, float& t, vec3& n, std::uint32_t& id) const {
        const vec3 inv = 1.0f / d;
        t = std::numeric_limits<float>::infinity();
        for (const box& b : boxes) {
            float t0, t1;
            int axis;
            if (!intersect(b, o, inv, t0, t1, axis) || axis < 0 || t0 >= t) continue;
            t = t0;
            n = vec3(0);
            n[axis] = d[axis] > 0 ? -1.0f : 1.0f;
            id = b.id;
        }
        return std::isfinite(t);
    }
};

scene default_scene() {
    scene s;
    s.boxes.push_back({{-6, -0.1f, -6}, {6, 0, 6}, 0});  // floor
    std::uint32_t id = 1;
    for (int i = 0; i < 6; ++i) {  // lattice at two heights: penumbrae that overlap and widen
        const float x = -1.6f + 0.45f * static_cast<float>(i);
        s.boxes.push_back({{x, 1.2f, -1.6f}, {x + 0.12f, 1.28f, 0.2f}, id});
        s.boxes.push_back({{-1.7f, 0.7f, -1.4f + 0.4f * static_cast<float>(i)}, {0.6f, 0.76f, -1.3f + 0.4f * static_cast<float>(i)}, id + 1});
    }
    id += 2;
    s.boxes.push_back({{0.9f, 0.0f, 0.2f}, {1.6f, 0.9f, 0.9f}, id++});  // box on the floor: contact shadow
    s.boxes.push_back({{-0.2f, 1.6f, 0.6f}, {1.8f, 1.7f, 0.75f}, id++});  // a high bar: wide penumbra
    return s;
}

struct options {
    std::string out = "aaf-demo-output";
    std::size_t width = 480, height = 320;
    std::uint32_t reference_spp = 1024;
    std::size_t threads = 0;
    float mu = 2.0f;
};

[[noreturn]] void usage(int code) {
    std::fprintf(code ? stderr : stdout,
                 "usage: aaf-demo [--out DIR] [--size WxH] [--reference-spp N] [--threads N] [--mu X]\n"
                 "Renders a soft shadow with aaf and writes PNGs (noisy, filtered, reference, error, beta, spp).\n");
    std::exit(code);
}

options parse(int argc, char** argv) {
    options o;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        const auto next = [&]() -> std::string {
            if (i + 1 >= argc) usage(2);
            return argv[++i];
        };
        if (a == "--help" || a == "-h") usage(0);
        else if (a == "--out") o.out = next();
        else if (a == "--size") {
            const std::string v = next();
            if (std::sscanf(v.c_str(), "%zux%zu", &o.width, &o.height) != 2 || o.width == 0 || o.height == 0 ||
                o.width > 8192 || o.height > 8192) {
                std::fprintf(stderr, "aaf-demo: --size must be WxH with 1..8192 (got '%s')\n", v.c_str());
                std::exit(2);
            }
        } else if (a == "--reference-spp") o.reference_spp = static_cast<std::uint32_t>(std::stoul(next()));
        else if (a == "--threads") o.threads = std::stoul(next());
        else if (a == "--mu") o.mu = std::stof(next());
        else {
            std::fprintf(stderr, "aaf-demo: unknown option '%s'\n", a.c_str());
            usage(2);
        }
    }
    return o;
}

void write_gray(const std::string& path, const aaf::image<float>& img) {
    std::vector<unsigned char> px(img.size());
    for (std::size_t i = 0; i < img.size(); ++i) {
        // Display gamma 2.2 so penumbrae look as they would on screen.
        const float v = std::clamp(img.data()[i], 0.0f, 1.0f);
        px[i] = static_cast<unsigned char>(std::lround(255.0 * std::pow(static_cast<double>(v), 1.0 / 2.2)));
    }
    if (!stbi_write_png(path.c_str(), static_cast<int>(img.width()), static_cast<int>(img.height()), 1, px.data(),
                        static_cast<int>(img.width())))
        throw std::runtime_error("cannot write " + path);
}

void write_rgb(const std::string& path, const aaf::image<aaf::rgb8>& img) {
    if (!stbi_write_png(path.c_str(), static_cast<int>(img.width()), static_cast<int>(img.height()), 3, img.data(),
                        static_cast<int>(img.width() * 3)))
        throw std::runtime_error("cannot write " + path);
}

}  // namespace

int main(int argc, char** argv) try {
    const options opt = parse(argc, argv);
    const std::size_t w = opt.width, h = opt.height;
    const scene sc = default_scene();
    aaf::area_light<float> light{{-0.6f, 3.0f, -0.6f}, {1.2f, 0.0f, 0.0f}, {0.0f, 0.0f, 1.2f}};
    if (glm::dot(light.normal(), vec3(0, -1, 0)) < 0) std::swap(light.edge_u, light.edge_v);  // face the floor

    // G-buffer from a pinhole camera.
    const vec3 eye{0.0f, 4.2f, 5.2f}, target{0.0f, 0.4f, -0.3f};
    const float tan_half_fov = std::tan(0.5f * 50.0f * 3.14159265f / 180.0f);
    const vec3 fwd = glm::normalize(target - eye), right = glm::normalize(glm::cross(fwd, vec3(0, 1, 0))),
               up = glm::cross(right, fwd);
    const float aspect = static_cast<float>(w) / static_cast<float>(h);
    const float nan = std::numeric_limits<float>::quiet_NaN();
    aaf::image<vec3> positions(w, h, vec3(nan)), normals(w, h, vec3(nan));
    aaf::image<float> pixel_size(w, h, 0.0f), albedo(w, h, 0.0f);
    aaf::image<std::uint32_t> ids(w, h, 0u);
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) {
            const float sx = (2.0f * (static_cast<float>(x) + 0.5f) / static_cast<float>(w) - 1.0f) * tan_half_fov * aspect;
            const float sy = (1.0f - 2.0f * (static_cast<float>(y) + 0.5f) / static_cast<float>(h)) * tan_half_fov;
            const vec3 d = glm::normalize(fwd + sx * right + sy * up);
            float t = 0.0f;
            vec3 n{0.0f};
            std::uint32_t id = 0;
            if (!sc.primary(eye, d, t, n, id)) continue;
            positions(x, y) = eye + t * d;
            normals(x, y) = n;
            ids(x, y) = id;
            pixel_size(x, y) = aaf::pinhole_pixel_size(t, tan_half_fov, static_cast<std::uint32_t>(h));
            albedo(x, y) = id == 0 ? 0.9f : 0.6f;
        }
    const aaf::gbuffer<float, aaf::const_image_view<std::uint32_t>> gb{positions.cview(), normals.cview(),
                                                                       pixel_size.cview(), ids.cview()};

    aaf::thread_pool pool(opt.threads);
    aaf::frame_settings<float> settings;
    settings.formulas.mu = opt.mu;
    aaf::frame_workspace<float> ws;
    aaf::image<float> filtered(w, h), irradiance(w, h);
    const aaf::frame_report report = aaf::render_frame(gb, light, sc, {filtered.view(), irradiance.view()}, ws, settings, pool);

    // Converged reference: plain stratified Monte Carlo with many samples, in chunks for a progress line.
    aaf::image<aaf::occlusion_stats<float>> ref_stats(w, h);
    aaf::sampling_settings ref_sampling;
    ref_sampling.max_samples = std::max(opt.reference_spp, 1u);
    const std::uint32_t chunk = 256;
    const auto t_ref = std::chrono::steady_clock::now();
    for (std::uint32_t done = 0, pass = 0; done < opt.reference_spp; done += chunk, ++pass) {
        const std::uint32_t n = std::min(chunk, opt.reference_spp - done);
        aaf::gather_occlusion(gb, light, sc, ref_sampling, 100 + pass, n, ref_stats.view(), {}, pool);
        const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_ref).count();
        const double frac = static_cast<double>(done + n) / opt.reference_spp;
        std::fprintf(stderr, "\rreference %3.0f%%  ETA %5.1f s ", 100.0 * frac, elapsed / frac - elapsed);
    }
    std::fprintf(stderr, "\n");
    aaf::image<float> reference(w, h), noisy(w, h);
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) {
            const bool surface = std::isfinite(positions(x, y).x);
            const float r = ref_stats(x, y).visibility(), n = ws.raw_visibility(x, y);
            reference(x, y) = !surface ? 1.0f : std::isfinite(r) ? r : 0.0f;
            noisy(x, y) = !surface ? 1.0f : std::isfinite(n) ? n : 0.0f;
        }

    // Pictures.
    std::filesystem::create_directories(opt.out);
    // Display: albedo × (ambient + direct), direct = visibility × unshadowed irradiance relative to the floor's
    // right under the light (surfaces closer to the light saturate).
    const float e_floor = aaf::unshadowed_irradiance(light, light.center() * vec3(1, 0, 1), vec3(0, 1, 0), 1.0f);
    aaf::image<float> irradiance_norm(w, h, 0.0f);
    for (std::size_t i = 0; i < irradiance_norm.size(); ++i)
        if (std::isfinite(positions.data()[i].x))
            irradiance_norm.data()[i] =
                std::min(1.0f, aaf::unshadowed_irradiance(light, positions.data()[i], normals.data()[i], 1.0f) / e_floor);
    const auto shade = [&](const aaf::image<float>& vis) {
        aaf::image<float> img(w, h, 0.12f);
        for (std::size_t i = 0; i < img.size(); ++i)
            if (std::isfinite(positions.data()[i].x))
                img.data()[i] = albedo.data()[i] * (0.08f + 0.92f * irradiance_norm.data()[i] * vis.data()[i]);
        return img;
    };
    write_gray(opt.out + "/noisy.png", shade(noisy));
    write_gray(opt.out + "/filtered.png", shade(filtered));
    write_gray(opt.out + "/reference.png", shade(reference));
    write_gray(opt.out + "/visibility_filtered.png", filtered);
    aaf::image<aaf::rgb8> rgb(w, h);
    const double rmse_filtered = aaf::difference_image<float>(filtered.cview(), reference.cview(), rgb.view(), 0.1);
    write_rgb(opt.out + "/error.png", rgb);
    const double rmse_noisy = aaf::difference_image<float>(noisy.cview(), reference.cview(), rgb.view(), 0.1);
    aaf::image<float> beta_px(w, h, std::numeric_limits<float>::quiet_NaN());
    aaf::image<float> spp(w, h);
    for (std::size_t i = 0; i < beta_px.size(); ++i) {
        const float b = ws.filter_width.data()[i], d = pixel_size.data()[i];
        if (b > 0 && d > 0) beta_px.data()[i] = b / d;
        spp.data()[i] = static_cast<float>(ws.stats.data()[i].samples);
    }
    const aaf::heat_range beta_range = aaf::heat_map<float>(beta_px.cview(), rgb.view());
    write_rgb(opt.out + "/beta.png", rgb);
    const aaf::heat_range spp_range = aaf::heat_map<float>(spp.cview(), rgb.view());
    write_rgb(opt.out + "/spp.png", rgb);

    // Summary.
    const double pixels = static_cast<double>(w * h);
    std::printf("aaf-demo %zux%zu, %zu threads, light sigma %.3f\n", w, h, pool.size(), static_cast<double>(light.sigma()));
    std::printf("  %-28s %10s\n", "stage", "ms");
    std::printf("  %-28s %10.1f\n", "initial samples", report.initial_ms);
    std::printf("  %-28s %10.1f\n", "slopes, spreading, beta, n", report.formulas_ms);
    std::printf("  %-28s %10.1f\n", "adaptive samples", report.adaptive_ms);
    std::printf("  %-28s %10.1f\n", "filter", report.filter_ms);
    std::printf("  %-28s %10.1f\n", "frame total", report.total_ms);
    std::printf("  shadow rays per pixel      %.2f (initial %.2f, adaptive %.2f)\n", static_cast<double>(report.rays()) / pixels,
                static_cast<double>(report.initial_rays) / pixels, static_cast<double>(report.adaptive_rays) / pixels);
    std::printf("  RMSE vs %u-spp reference: unfiltered %.4f, aaf %.4f\n", opt.reference_spp, rmse_noisy, rmse_filtered);
    std::printf("  beta %.1f..%.1f px, samples per pixel %.0f..%.0f\n", beta_range.lo, beta_range.hi, spp_range.lo, spp_range.hi);
    std::printf("pictures in %s/: noisy.png filtered.png reference.png error.png beta.png spp.png\n",
                std::filesystem::absolute(opt.out).string().c_str());
    return 0;
} catch (const std::exception& e) {
    std::fprintf(stderr, "aaf-demo: %s\n", e.what());
    return 1;
}
