// SPDX-License-Identifier: MIT
#pragma once
// The gather: for every visible point of the user's G-buffer, integrate the diffusion profile against the
// light-space map's E·F_t around the point's projection (FORMULAS.md §5.3), with the write-up's three fixes.
//
// For a pixel with surface point x_o and normal n_o:
//  1. x'_o = x_o − ε_g(n_o − ω_l(ω_l·n_o))     (fix 1, shrink; `fix_shrink`)
//     x'_o −= ε_c n_o                          (fix 2, cube-map intrusion; `fix_intrude`, cube maps only)
//     x'_o is where the centre sample reads the map (centre-first sampling only; profile sampling has no centre
//     sample, and the fixes do not apply to it). Distances to the profile are still measured from x_o.
//     DEPARTURES (docs/DEVIATIONS.md): the write-up evaluates the profile at x'_o and centres the whole disc on it.
//     Evaluating at x'_o moves the point ε_g·sin²θ into the medium (several z_r at one texel: a 57°-lit slab came
//     out 9 % dark); centring profile-sampled discs on x'_o put the density's peak beside R_d's (+17 % and
//     high variance on the same slab). Both measured with tests/test_subsurface_gather.cpp's flat-slab case.
//  2. N samples in a disc of radius R perpendicular to the light's ray through x_o (the centre sample through
//     x'_o), either centre-first with
//     equal areas (the write-up's order: sample 0 at the centre, then a golden-angle spiral, rotated per pixel)
//     or with radii drawn from R_d (radius_sampler). Each sample's light ray finds a texel; its surface point
//     is the texel's point, or (`tangent_plane`) the ray's intersection with the texel's tangent plane.
//  3. Weight: R_d(|x_s − x'_o|)/π (or the directional dipole S_d) × E·F_t × the sample's area on the surface
//     (the disc cell's area carried along the light's rays onto the surface, so it includes the obliquity
//     1/|n_i·ω_l| and, for a point light, the rays' divergence).
//  4. Fix 3 (`fix_bias`, centre-first sampling): the centre sample's depth difference to x_o along the light's ray
//     is reduced by ε_b (derived from the slope of the surface the map saw there and the depth precision): depth
//     differences within the texel's slope and the stored depth's precision are noise, and at R_d's peak noise of
//     a fraction of z_r shows as acne. Only the centre: further samples' depth differences are real distance.
//  5. Banding fix (`exact_centre`, centre-first sampling only): the centre sample's cell, a disc of radius
//     R/√N, is integrated in closed form (dipole::disc_integral) instead of point-sampled (see docs/SUBSURFACE.md).
//
// The result is the subsurface radiance before the exit Fresnel factor: L_o = F_t(ω_o)·result for the Jensen
// profile (which carries its 1/π), and likewise T₂₁(ω_o)·result for the directional dipole.

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "../executor.hpp"
#include "../image_view.hpp"
#include "../region.hpp"
#include "../sampler.hpp"
#include "dipole.hpp"
#include "directional_dipole.hpp"
#include "epsilons.hpp"
#include "light_map.hpp"
#include "material.hpp"
#include "profile_batch.hpp"

namespace aaf {
inline namespace v0 {
namespace subsurface {

/// How the disc around the point of interest is sampled.
enum class disc_sampling {
    centre_first,  ///< the write-up's: centre, then an equal-area golden-angle spiral (rotated per pixel)
    profile,       ///< radii drawn from R_d (all three channels, balance heuristic), angles stratified
};

/// Which profile weights the samples.
enum class profile_model {
    dipole,              ///< Jensen 2001 R_d(r)/π (FORMULAS.md §5.1)
    directional_dipole,  ///< Frisvad, Hachisuka, Kjeldsen 2014 S_d (§5.2), with ω_i = ω_l at the sample
};

/// Settings of `gather_subsurface`. Negative epsilons and radius are derived (epsilons.hpp).
template <class T = float>
struct gather_settings {
    std::uint32_t samples = 150;                      ///< samples per pixel, [1, 65536]; the write-up found ~150 enough
    T radius = -1;                                    ///< disc radius R, world units; < 0: the radius holding 99 % of the least attenuated channel's total
    disc_sampling sampling = disc_sampling::profile;  ///< disc sample placement
    profile_model profile = profile_model::dipole;    ///< weighting profile
    boundary_term boundary = boundary_term::classical;  ///< A for the Jensen dipole
    bool tangent_plane = true;   ///< sample points on the texel's tangent plane (true) or the texel's point (false)
    bool exact_centre = true;    ///< centre-first only: the centre cell integrated in closed form
    bool fix_shrink = true;      ///< fix 1
    bool fix_intrude = true;     ///< fix 2 (cube maps only)
    bool fix_bias = true;        ///< fix 3
    /// Jensen profile: evaluate R_d for all of a pixel's samples at once on vectors (weighted_profile_sum,
    /// profile_batch.hpp; agrees to ~1e-13); false: one sample at a time (the scalar path, kept for comparison).
    bool vector_profile = true;
    T shrink_epsilon = -1;       ///< ε_g, world units ≥ 0; < 0: derived
    T intrude_epsilon = -1;      ///< ε_c, world units ≥ 0; < 0: derived
    T bias_epsilon = -1;         ///< ε_b, world units ≥ 0; < 0: derived
    frame_region region{};       ///< where the G-buffer sits in the full frame (sample keys)
    std::uint32_t light_index = 0;  ///< sample key's light
    std::uint32_t frame_seed = 0;   ///< sample key's frame seed
};

/// The user's G-buffer for the gather: world positions (non-finite = no surface) and unit normals.
template <class T = float>
struct visible_points {
    const_image_view<glm::vec<3, T>> positions;
    const_image_view<glm::vec<3, T>> normals;
};

/// What a gather measured (for benchmarks and the docs).
struct gather_stats {
    std::uint64_t samples = 0;        ///< disc samples evaluated
    std::uint64_t outside = 0;        ///< samples whose ray left the map or met an empty texel (contribute 0)
    std::uint64_t centre_exact = 0;   ///< pixels whose centre cell was integrated in closed form
};

namespace detail {

template <class T>
void validate_settings(const gather_settings<T>& s, const char* fn) {
    using aaf::detail::throw_invalid;
    if (s.samples < 1 || s.samples > 65536) throw_invalid(fn, "`settings.samples` must be in [1, 65536]");
    if (std::isnan(s.radius) || std::isinf(s.radius)) throw_invalid(fn, "`settings.radius` must be finite (< 0 = derived)");
    for (const T e : {s.shrink_epsilon, s.intrude_epsilon, s.bias_epsilon})
        if (!std::isfinite(e)) throw_invalid(fn, "`settings` epsilons must be finite (< 0 = derived)");
}

/// Two unit vectors perpendicular to unit `w`.
template <class T>
void basis(const glm::vec<3, T>& w, glm::vec<3, T>& b1, glm::vec<3, T>& b2) noexcept {
    const glm::vec<3, T> helper = std::abs(w.x) < T(0.6) ? glm::vec<3, T>(1, 0, 0) : glm::vec<3, T>(0, 1, 0);
    b1 = glm::normalize(glm::cross(helper, w));
    b2 = glm::cross(w, b1);
}

}  // namespace detail

/// The radius `gather_subsurface` uses when `settings.radius` < 0: 99 % of the least attenuated channel's
/// total diffuse reflectance lies within it.
inline double default_gather_radius(const rgb_dipole& d) {
    return std::max({d.channel[0].radius_of_fraction(0.99), d.channel[1].radius_of_fraction(0.99), d.channel[2].radius_of_fraction(0.99)});
}

/// The epsilons `gather_subsurface` uses at x_o (derived where the settings' value is negative, else the
/// settings' value): exposed for tests and debug views. The `bias` returned here takes its slope from n_o;
/// the gather derives the bias it applies from the normal of the centre texel it reads (the surface the map
/// saw), which equals n_o wherever x_o lies on the lit surface.
template <class Projection>
[[nodiscard]] gather_epsilons<typename light_map_view<Projection>::T> epsilons_at(
    const light_map_view<Projection>& map, const gather_settings<typename light_map_view<Projection>::T>& s, const rgb_dipole& d,
    const glm::vec<3, typename light_map_view<Projection>::T>& x_o, const glm::vec<3, typename light_map_view<Projection>::T>& n_o) {
    using T = typename light_map_view<Projection>::T;
    const T h = map.projection.footprint(x_o);
    const bool depth_face = map.faces[0].positions.empty();
    gather_epsilons<T> e = derive_epsilons<T>(x_o, h, map.projection.far, map.near_plane, depth_face ? map.depth_bits : 0u,
                                              d.max_sigma_tr(), glm::dot(n_o, map.projection.to_light(x_o)));
    if (s.shrink_epsilon >= T(0)) e.shrink = s.shrink_epsilon;
    if (s.intrude_epsilon >= T(0)) e.intrude = s.intrude_epsilon;
    if (s.bias_epsilon >= T(0)) e.bias = s.bias_epsilon;
    return e;
}

/// Gathers subsurface scattering for every pixel of `points` from `map` into `out` (RGB; see the header
/// comment for what it holds). Pixels without a surface (non-finite position or normal) get 0. A point whose
/// projection falls outside the map gets what its disc finds inside the map (0 when nothing): the map is where
/// light enters, so a point far from every lit texel receives no diffusion (docs/EXTREMES.md).
/// Throws aaf::invalid_argument before writing anything for: mismatched or empty buffers, an empty or invalid
/// map (no texels, face views of the wrong size, neither positions nor depth), invalid material or settings.
/// Rows run on `exec`; per-pixel randomness is keyed by aaf::pixel_key(settings.region, x, y, 0, light_index,
/// frame_seed), so tiles and thread counts do not change the result.
template <class Projection, class Exec = sequential_executor>
gather_stats gather_subsurface(const visible_points<typename light_map_view<Projection>::T>& points,
                               const light_map_view<Projection>& map,
                               const material<typename light_map_view<Projection>::T>& mat,
                               const gather_settings<typename light_map_view<Projection>::T>& s,
                               image_view<glm::vec<3, typename light_map_view<Projection>::T>> out, Exec&& exec = {}) {
    using T = typename light_map_view<Projection>::T;
    using vec3 = glm::vec<3, T>;
    using aaf::detail::throw_invalid;
    constexpr const char* fn = "subsurface::gather_subsurface";
    constexpr bool is_cube = Projection::faces() == 6;
    // ---- validation: everything before any write
    aaf::detail::require_nonempty(fn, "points.positions", points.positions);
    const std::size_t w = points.positions.width(), h = points.positions.height();
    aaf::detail::require_size(fn, "points.normals", points.normals, w, h);
    aaf::detail::require_size(fn, "out", out, w, h);
    validate(mat, fn);
    detail::validate_settings(s, fn);
    detail::require_projection(fn, map.projection);
    for (int f = 0; f < Projection::faces(); ++f) {
        const map_face<T>& face = map.faces[std::size_t(f)];
        const std::size_t mw = map.projection.width, mh = map.projection.height;
        if (face.positions.empty()) {
            if (is_cube || face.depth.empty())
                throw_invalid(fn, "`map.faces[" + std::to_string(f) + "]` has neither positions nor (orthographic) depth: an empty map");
            aaf::detail::require_size(fn, "map.faces[].depth", face.depth, mw, mh);
        } else {
            aaf::detail::require_size(fn, "map.faces[].positions", face.positions, mw, mh);
        }
        aaf::detail::require_size(fn, "map.faces[].normals", face.normals, mw, mh);
        aaf::detail::require_size(fn, "map.faces[].irradiance", face.irradiance, mw, mh);
    }
    if (!is_cube && map.faces[0].positions.empty() && !(map.near_plane >= T(0) && map.near_plane < map.projection.far))
        throw_invalid(fn, "`map.near_plane` must be in [0, projection.far) for a depth map");

    const rgb_dipole dip(mat, s.boundary);
    const rgb_directional_dipole ddip(mat);
    const double R = s.radius >= T(0) ? double(s.radius) : default_gather_radius(dip);
    const bool importance = s.sampling == disc_sampling::profile;
    radius_sampler sampler;
    if (importance) sampler = radius_sampler(dip, std::max(R, 1e-300));
    const std::uint32_t N = s.samples;
    // Centre-first: sample 0's cell is the disc of radius R/√N, the others share the annulus equally.
    const double cell_area = std::numbers::pi * R * R / N;
    const double rho_centre = R / std::sqrt(double(N));
    const Projection& proj = map.projection;

    std::atomic<std::uint64_t> n_samples{0}, n_outside{0}, n_exact{0};
    exec.parallel_for(h, [&](std::size_t y0, std::size_t y1) {
        std::vector<glm::vec<2, T>> uv(N);
        // A pixel's Jensen-profile samples, evaluated together after its disc (vector_profile): distance and
        // the three channels' weights E·F_t·area/π.
        const bool batch = s.vector_profile && s.profile == profile_model::dipole;
        std::vector<double> batch_r(batch ? N : 0), batch_w0(batch ? N : 0), batch_w1(batch ? N : 0), batch_w2(batch ? N : 0);
        std::uint64_t l_samples = 0, l_outside = 0, l_exact = 0;
        for (std::size_t y = y0; y < y1; ++y)
            for (std::size_t x = 0; x < w; ++x) {
                const vec3 p = points.positions(x, y), n = points.normals(x, y);
                if (!std::isfinite(p.x + p.y + p.z) || !std::isfinite(n.x + n.y + n.z)) {
                    out(x, y) = vec3(0);
                    continue;
                }
                const gather_epsilons<T> eps = epsilons_at(map, s, dip, p, n);
                // ---- fixes 1 and 2
                // The fixes relocate the centre sample only (centre-first sampling): the disc of the other samples
                // stays centred on x_o's own ray, so profile sampling's density stays centred on R_d's peak.
                vec3 xo = p;
                const vec3 wl = proj.to_light(p);
                if (!importance) {
                    if (s.fix_shrink) xo -= eps.shrink * (n - wl * glm::dot(wl, n));
                    if (is_cube && s.fix_intrude) xo -= eps.intrude * n;
                }
                vec3 b1, b2;
                detail::basis(wl, b1, b2);
                const sample_key key = pixel_key(s.region, x, y, 0, s.light_index, s.frame_seed);
                if (importance) generate_samples<T>(sample_pattern::stratified, key, uv);
                const double rotation = 2 * std::numbers::pi * aaf::detail::to_unit<double>(aaf::detail::key_hash(key));
                glm::dvec3 sum(0);
                std::size_t batched = 0;
                for (std::uint32_t i = 0; i < N; ++i) {
                    double rho, phi, area;  // area: the sample's share of the disc, in the disc plane
                    if (importance) {
                        // The channel from the first coordinate's thirds, the radius from what is left of it: each
                        // channel's u stays uniform. (Channel i % 3 with stratified points gave each channel every
                        // third stratum, a non-uniform u: −3.9 % on a skim-milk slab's blue channel, measured.)
                        const double u3 = 3 * double(uv[i].x);
                        const int channel = std::min(2, int(u3));
                        rho = sampler.radius(channel, u3 - channel);
                        phi = 2 * std::numbers::pi * double(uv[i].y);
                        const double pdf = sampler.pdf_area(rho);
                        if (!(pdf > 0) || !std::isfinite(pdf) || !std::isfinite(rho)) {  // underflowed tails: no estimate
                            ++l_samples;
                            continue;
                        }
                        area = 1 / (N * pdf);
                    } else {
                        rho = i == 0 ? 0.0 : R * std::sqrt((i + 0.5) / N);
                        phi = rotation + i * 2.399963229728653;  // golden angle
                        area = cell_area;
                    }
                    ++l_samples;
                    const vec3 ps = (i == 0 ? xo : p) + T(rho * std::cos(phi)) * b1 + T(rho * std::sin(phi)) * b2;
                    const map_point<T> m = proj.project(ps);
                    const map_texel<T> t = read_texel(map, m.face, texel_index(m.texel.x, proj.width), texel_index(m.texel.y, proj.height));
                    if (!t.valid || !(t.irradiance.x + t.irradiance.y + t.irradiance.z > T(0))) {
                        ++l_outside;
                        continue;
                    }
                    // The light's ray through the sample point, and where it meets the surface.
                    vec3 ray_dir;
                    if constexpr (is_cube) ray_dir = glm::normalize(ps - proj.light);
                    else ray_dir = proj.forward;
                    vec3 xs = t.position;
                    if (s.tangent_plane) {
                        const T denom = glm::dot(ray_dir, t.normal);
                        if (std::abs(denom) > T(1e-3)) {
                            const vec3 cand = ps + (glm::dot(t.position - ps, t.normal) / denom) * ray_dir;
                            // Keep the reconstruction within the texel's reach (grazing planes run away).
                            if (glm::length(cand - t.position) <= T(2) * proj.footprint(t.position)) xs = cand;
                        }
                    }
                    // Area on the surface: the cell carried along the rays (perpendicular area), then obliquity.
                    const T cos_i = std::max(std::abs(glm::dot(t.normal, ray_dir)), T(1e-6));
                    double jac = 1 / double(cos_i);
                    if constexpr (is_cube) {
                        const double dps = double(glm::length(ps - proj.light)), dxs = double(glm::length(xs - proj.light));
                        jac *= std::abs(double(glm::dot(ray_dir, -wl))) * (dxs / dps) * (dxs / dps);
                    }
                    // Distances from the point itself: the fixes move where the map is read, not the point whose
                    // scattering is computed (moving x_o by ε_g sin²θ into the medium would dim R_d's peak).
                    const vec3 d = xs - p;
                    double r = double(glm::length(d));
                    if (!importance && i == 0) {
                        // The centre sample: its depth difference to x_o is compared with the bias (fix 3), using the
                        // slope of the surface the map saw there (the classical slope-scaled bias is the map
                        // surface's slope, not the receiver's).
                        const T along = glm::dot(d, ray_dir);
                        T centre_bias = T(0);
                        if (s.fix_bias) {
                            centre_bias = s.bias_epsilon >= T(0)
                                       ? s.bias_epsilon
                                       : derive_epsilons<T>(p, proj.footprint(p), proj.far, map.near_plane,
                                                            map.faces[0].positions.empty() ? map.depth_bits : 0u, dip.max_sigma_tr(),
                                                            glm::dot(t.normal, wl)).bias;
                            if (is_cube && s.fix_intrude) centre_bias += eps.intrude;  // x'_o was moved that far on purpose
                        }
                        const double depth = std::max(0.0, double(std::abs(along)) - double(centre_bias));
                        if (s.exact_centre && s.profile == profile_model::dipole) {
                            // Banding fix: the centre cell in closed form, a disc of the cell's area on the surface
                            // (radius ρ_c/√cos) at the depth difference `depth` (FORMULAS.md §5.3's w_i), centred on x_o:
                            // fix 1 only chose which texel's E·F_t stands for x_o's cell. The depth its lateral shift
                            // adds on a tilted surface (≤ h·tan θ) is inside ε_b.
                            const glm::dvec3 W = dip.disc_integral(rho_centre * std::sqrt(jac), depth);
                            sum += glm::dvec3(t.irradiance) * W / std::numbers::pi;
                            ++l_exact;
                            continue;
                        }
                        const vec3 lateral = d - along * ray_dir;
                        r = std::sqrt(double(glm::dot(lateral, lateral)) + depth * depth);
                    }
                    // A texel point so far away that its distance or its area overflows (a caller's stray value): R_d
                    // and S_d decay faster than the area grows, so the limit is 0, not ∞·0 = NaN (fuzz finding).
                    if (!std::isfinite(r) || !std::isfinite(jac)) continue;
                    if (batch) {
                        const double wgt = area * jac / std::numbers::pi;
                        batch_r[batched] = r;
                        batch_w0[batched] = double(t.irradiance.x) * wgt;
                        batch_w1[batched] = double(t.irradiance.y) * wgt;
                        batch_w2[batched] = double(t.irradiance.z) * wgt;
                        ++batched;
                        continue;
                    }
                    glm::dvec3 f;
                    if (s.profile == profile_model::dipole) {
                        f = dip.profile(r) / std::numbers::pi;
                    } else {
                        f = ddip.evaluate(glm::dvec3(xs), glm::dvec3(t.normal), glm::dvec3(-ray_dir), glm::dvec3(p), glm::dvec3(n), false);
                    }
                    sum += glm::dvec3(t.irradiance) * f * (area * jac);
                }
                if (batched > 0)
                    sum += weighted_profile_sum(dip, batch_r.data(), batch_w0.data(), batch_w1.data(), batch_w2.data(), batched);
                out(x, y) = vec3(sum);
            }
        n_samples += l_samples;
        n_outside += l_outside;
        n_exact += l_exact;
    });
    return {n_samples.load(), n_outside.load(), n_exact.load()};
}

}  // namespace subsurface
}  // namespace v0
}  // namespace aaf
