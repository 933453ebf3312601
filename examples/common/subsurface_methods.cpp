// SPDX-License-Identifier: MIT
#include "common/subsurface_methods.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include <aaf/region.hpp>
#include <aaf/subsurface.hpp>

namespace aaf_examples {

namespace {

namespace ss = aaf::subsurface;

constexpr float scene_diagonal_mm = 300;  ///< the scene's bounding-box diagonal, in the material's mm
constexpr float exposure = 3;             ///< displayable = min(1, exposure · mean radiance)
constexpr std::size_t map_resolution = 512;

/// The material of a method (Jensen 2001's presets, aaf::subsurface::presets).
enum class material_choice { marble, skim_milk };
/// Where a method's directional light comes from.
enum class light_choice {
    area_normal,  ///< along the scene's area light's normal (the quantity's reference)
    side,         ///< perpendicular to the camera's view direction (horizontal, from the camera's right)
    back,         ///< from behind the object towards the camera, level and tilted 19° down: thin parts glow
};
/// A variant of the quantity: its material and light.
struct look {
    material_choice material = material_choice::marble;
    light_choice light = light_choice::area_normal;
    [[nodiscard]] bool is_default() const { return material == material_choice::marble && light == light_choice::area_normal; }
};

/// The translucent setting every method shares: material in scene units, light direction, bounds.
struct setup {
    ss::material<float> mat;
    glm::vec3 travel{0, -1, 0};  ///< the light's travel direction (= −ω_l)
    glm::vec3 center{0};
    float radius = 1;
};

setup make_setup(const scene& s, look k = {}) {
    glm::vec3 lo(std::numeric_limits<float>::infinity()), hi(-lo);
    for (const glm::vec3& v : s.vertices) lo = glm::min(lo, v), hi = glm::max(hi, v);
    setup u;
    const float diag = glm::length(hi - lo);
    u.center = 0.5f * (lo + hi);
    u.radius = std::max(0.5f * diag, 1e-6f);
    // One scene unit is scene_diagonal_mm / diag mm long.
    const ss::material<float> mm = k.material == material_choice::skim_milk ? ss::presets::skim_milk<float>() : ss::presets::marble<float>();
    u.mat = mm.in_units(scene_diagonal_mm / std::max(diag, 1e-6f));
    glm::vec3 view = s.view.target - s.view.position;
    if (!(glm::length(view) > 0)) view = glm::vec3(0, 0, -1);
    view = glm::normalize(view);
    const glm::vec3 up = glm::length(s.view.up) > 0 ? glm::normalize(s.view.up) : glm::vec3(0, 1, 0);
    if (k.light == light_choice::back) {
        // Travelling towards the camera, level with the ground and tilted down by atan(0.35) ≈ 19°: straight
        // along −view the light would travel upwards for a camera looking down, lighting the floor's underside
        // and leaving the object in its shadow. Level, it crosses thin parts (the ears) which then glow.
        glm::vec3 level = -view - glm::dot(-view, up) * up;
        u.travel = glm::length(level) > 1e-3f ? glm::normalize(glm::normalize(level) - 0.35f * up) : -view;
        return u;
    }
    if (k.light == light_choice::side) {  // travelling right to left across the picture
        glm::vec3 right = glm::cross(view, up);
        if (!(glm::length(right) > 1e-6f)) right = glm::cross(view, std::abs(view.y) < 0.9f ? glm::vec3(0, 1, 0) : glm::vec3(1, 0, 0));
        u.travel = -glm::normalize(right);
        return u;
    }
    glm::vec3 n = s.light.normal();
    if (!(glm::length(n) > 0)) n = glm::normalize(u.center - s.light.center());
    if (glm::dot(n, u.center - s.light.center()) < 0) n = -n;  // travel from the light towards the scene
    u.travel = glm::normalize(n);
    return u;
}

float displayable(const glm::dvec3& L) {
    const double v = double(exposure) * (L.x + L.y + L.z) / 3.0;
    return std::isfinite(v) ? static_cast<float>(std::clamp(v, 0.0, 1.0)) : 0.0f;
}

enum class variant { no_fixes, bias_only, all_fixes, all_fixes_banding, profile };

ss::gather_settings<float> settings_of(variant v, std::uint32_t samples, std::uint32_t seed) {
    ss::gather_settings<float> g;
    g.samples = std::max<std::uint32_t>(samples, 1);
    g.frame_seed = seed;
    if (v == variant::profile) return g;  // the library's default: profile sampling, all fixes
    g.sampling = ss::disc_sampling::centre_first;
    const bool fixes = v == variant::all_fixes || v == variant::all_fixes_banding;
    g.fix_shrink = g.fix_intrude = fixes;
    g.fix_bias = v != variant::no_fixes;
    g.exact_centre = g.tangent_plane = v == variant::all_fixes_banding;
    return g;
}

method_output render_gather(const render_inputs& in, variant v, std::uint32_t samples, look k = {}) {
    const std::size_t w = in.g.positions.width(), h = in.g.positions.height();
    const setup u = make_setup(in.s, k);
    method_output out;
    const auto t0 = clock_type::now();
    const auto proj = ss::orthographic_projection<float>::looking_along(u.travel, u.center, u.radius, map_resolution);
    const auto map = ss::build_light_map(proj, ss::map_light<float>{glm::vec3(1)}, u.mat.eta, in.tracer, ss::reconstruct_normals{}, in.pool);
    const double map_ms = ms_since(t0);
    aaf::image<glm::vec3> L(w, h);
    const ss::gather_stats st = ss::gather_subsurface(ss::visible_points<float>{in.g.positions.cview(), in.g.normals.cview()}, map.view(),
                                                      u.mat, settings_of(v, samples, in.seed), L.view(), in.pool);
    aaf::image<float> img(w, h, 0.0f);
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x)
            if (std::isfinite(in.g.positions(x, y).x)) img(x, y) = displayable(glm::dvec3(L(x, y)));
    out.total_ms = ms_since(t0);
    out.image = std::move(img);
    out.rays = map_resolution * map_resolution;  // the map's rays; the gather traces none (it reads the map)
    out.memory_bytes = 3 * map_resolution * map_resolution * sizeof(glm::vec3) + w * h * sizeof(glm::vec3);
    out.stages_ms = {{"map", map_ms}, {"gather", out.total_ms - map_ms}};
    out.point_settings = {{"samples", samples}, {"disc_samples", st.samples}, {"outside", st.outside}};
    return out;
}

/// The map-free Monte Carlo estimate (ss::reference_subsurface) with `samples` surface samples per pixel:
/// radii drawn from R_d in the plane through x_o perpendicular to the light, each carried to the surface
/// along the light's ray (the nearest hit through the BVH: the lit surface), density · |n·ω_l| per unit
/// area there. Every lit surface point is reached by exactly one plane point, so within the disc of the
/// gather's radius this is unbiased for the integral the gather approximates; no texels, no epsilons.
method_output render_reference(const render_inputs& in, std::uint32_t samples, std::uint32_t seed, std::uint32_t pass, look k = {}) {
    const std::size_t w = in.g.positions.width(), h = in.g.positions.height();
    const setup u = make_setup(in.s, k);
    const ss::rgb_dipole d(u.mat);
    const ss::radius_sampler S(d, ss::default_gather_radius(d));
    const glm::vec3 wl = -u.travel;
    glm::vec3 b1, b2;
    ss::detail::basis(wl, b1, b2);
    ss::reference_light<float> light;
    light.direction = wl;
    light.far = 4 * u.radius;
    const std::uint32_t n = std::max<std::uint32_t>(samples, 1);
    method_output out;
    const auto t0 = clock_type::now();
    aaf::image<float> img(w, h, 0.0f);
    const aaf::frame_region region{};
    in.pool.parallel_for(h, [&](std::size_t y0, std::size_t y1) {
      for (std::size_t y = y0; y < y1; ++y)
        for (std::size_t x = 0; x < w; ++x) {
            const glm::vec3 p = in.g.positions(x, y), np = in.g.normals(x, y);
            if (!std::isfinite(p.x) || !std::isfinite(np.x)) continue;
            const auto sampler = [&](float a, float b) {
                ss::surface_sample<float> s;
                const double rho = S.radius(int(a * 3) % 3, std::fmod(double(a) * 3.0, 1.0)), phi = 2 * std::numbers::pi * double(b);
                const glm::vec3 q = p + float(rho * std::cos(phi)) * b1 + float(rho * std::sin(phi)) * b2;
                const glm::vec3 o = q - glm::dot(q - u.center, wl) * wl + 2 * u.radius * wl;  // outside the bounds
                const ray_hit hit = in.tracer.nearest_hit(o, u.travel);
                if (!hit.hit()) return s;  // pdf 0: dropped
                glm::vec3 nn = hit.normal;
                if (glm::dot(nn, wl) < 0) nn = -nn;
                s.position = o + hit.t * u.travel;
                s.normal = nn;
                s.pdf = float(S.pdf_area(rho)) * std::abs(glm::dot(nn, wl));
                return s;
            };
            const glm::dvec3 L = ss::reference_subsurface(p, np, u.mat, ss::profile_model::dipole, ss::boundary_term::classical, light,
                                                          in.tracer, sampler, n, aaf::pixel_key(region, x, y, pass, 0, seed));
            img(x, y) = displayable(L);
        }
    });
    out.total_ms = ms_since(t0);
    out.image = std::move(img);
    std::uint64_t surface = 0;
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) surface += std::isfinite(in.g.positions(x, y).x) ? 1 : 0;
    out.rays = surface * n * 2;  // a light ray to find each sample's point and a shadow ray from it
    out.stages_ms = {{"rays", out.total_ms}};
    return out;
}

}  // namespace

method_family subsurface_methods() {
    method_family f;
    const std::vector<double> sweep{8, 16, 32, 64, 150, 300};
    // What every gather method of the family shares: a sample count as the knob, 150 by default (the write-up's).
    const auto gather_method = [&sweep](std::string name, std::string help) {
        method m;
        m.name = std::move(name);
        m.family = "subsurface";
        m.what = quantity::subsurface;
        m.knob = "samples";
        m.sweep = sweep;
        m.default_knob = 150;
        m.help = std::move(help);
        return m;
    };
    struct entry {
        const char* name;
        variant v;
        const char* help;
    };
    const entry entries[] = {
        {"sss_no_fixes", variant::no_fixes, "subsurface from a 512^2 light map, write-up's centre-first gather without fixes (marble, sky 0)"},
        {"sss_bias_only", variant::bias_only, "subsurface, centre-first gather with the depth bias (fix 3) only"},
        {"sss_all_fixes", variant::all_fixes, "subsurface, centre-first gather with the write-up's three fixes (shrink, intrude, bias)"},
        {"sss_all_fixes_banding", variant::all_fixes_banding,
         "subsurface, centre-first with the three fixes and aaf's banding fix (exact centre cell, tangent-plane points)"},
        {"sss_profile", variant::profile, "subsurface, aaf's default: radii drawn from R_d, all fixes"},
    };
    for (const entry& e : entries) {
        method m = gather_method(e.name, e.help);
        const ss::gather_settings<float> g = settings_of(e.v, 150, 0);
        m.settings = {{"material", "marble, scene diagonal = 300 mm"},
                      {"light", "directional along the area light's normal, irradiance 1"},
                      {"map", "orthographic 512^2"},
                      {"sampling", g.sampling == ss::disc_sampling::profile ? "profile" : "centre_first"},
                      {"fix_shrink", g.fix_shrink},
                      {"fix_intrude", g.fix_intrude},
                      {"fix_bias", g.fix_bias},
                      {"exact_centre", g.exact_centre},
                      {"tangent_plane", g.tangent_plane},
                      {"exposure", exposure}};
        const variant v = e.v;
        m.render = [v](const render_inputs& in, double knob) { return render_gather(in, v, static_cast<std::uint32_t>(std::lround(knob))); };
        f.methods.push_back(std::move(m));
    }
    // Variants of the material and the light (the translucent figures): aaf's default gather, each
    // judged against the map-free reference with the same material and light (own_reference), so aaf-render's
    // RMSE is honest and aaf-tradeoff, whose subsurface curves share the marble reference, leaves them out.
    struct variant_entry {
        const char* name;
        look k;
        const char* material;
        const char* light;
    };
    const variant_entry variants[] = {
        {"sss_profile_side", {material_choice::marble, light_choice::side}, "marble", "side"},
        {"sss_profile_back", {material_choice::marble, light_choice::back}, "marble", "back"},
        {"sss_profile_skim_milk", {material_choice::skim_milk, light_choice::area_normal}, "skim milk", "area light's normal"},
        {"sss_profile_skim_milk_side", {material_choice::skim_milk, light_choice::side}, "skim milk", "side"},
        {"sss_profile_skim_milk_back", {material_choice::skim_milk, light_choice::back}, "skim milk", "back"},
    };
    for (const variant_entry& e : variants) {
        method m = gather_method(e.name, std::string("sss_profile in ") + e.material + ", lit from the " + e.light +
                                             " (judged against its own reference with the same material and light; not in aaf-tradeoff)");
        const char* light_text = e.k.light == light_choice::side   ? "directional, perpendicular to the view direction (from the camera's right)"
                                 : e.k.light == light_choice::back ? "directional, from behind the object towards the camera, level, tilted 19 degrees down"
                                                                   : "directional along the area light's normal, irradiance 1";
        m.settings = {{"material", std::string(e.material) + ", scene diagonal = 300 mm"},
                      {"light", light_text},
                      {"map", "orthographic 512^2"},
                      {"sampling", "profile"},
                      {"exposure", exposure}};
        const look k = e.k;
        m.render = [k](const render_inputs& in, double knob) {
            return render_gather(in, variant::profile, static_cast<std::uint32_t>(std::lround(knob)), k);
        };
        m.own_reference = [k](const render_inputs& in, std::uint32_t samples, std::uint32_t seed) {
            return render_reference(in, samples, seed, 1000, k).image;
        };
        f.methods.push_back(std::move(m));
    }

    method mc;
    mc.name = "mc_subsurface";
    mc.family = "mc";
    mc.what = quantity::subsurface;
    mc.knob = "samples";
    mc.sweep = sweep;
    mc.doubling_sweep = true;
    mc.default_knob = 150;
    mc.help = "Monte Carlo subsurface without a map: R_d-distributed surface points found along the light's rays, shadow rays";
    mc.settings = {{"material", "marble, scene diagonal = 300 mm"}, {"exposure", exposure}};
    mc.render = [](const render_inputs& in, double knob) {
        return render_reference(in, static_cast<std::uint32_t>(std::lround(knob)), in.seed, 0);
    };
    f.methods.push_back(std::move(mc));

    quantity_reference r;
    r.what = quantity::subsurface;
    r.name = "subsurface";
    r.baseline_method = "mc_subsurface";
    r.render = [](const render_inputs& in, std::uint32_t samples, std::uint32_t seed) {
        method_output o = render_reference(in, samples, seed, 1000);
        return reference_output(std::move(o.image), o.total_ms);
    };
    f.references.push_back(std::move(r));
    return f;
}

}  // namespace aaf_examples
