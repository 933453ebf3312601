// SPDX-License-Identifier: MIT
// libFuzzer harness: the subsurface family (include/aaf/subsurface/) with fuzzed materials, light-space maps
// (built through a fuzz-driven tracer, or filled texel by texel as a renderer's own buffers), gather settings
// and visible points, in float; plus the profiles on their own (the vectorised sum, the directional dipole).
//
// Input, front to back: material (σ_a, σ_s′ per channel, η); map kind (orthographic / cube), projection; how
// the map is made (built: light power, tracer answers, normals; or filled: up to 6×6 texels per face of
// positions, normals, E·F_t); gather settings (more than 64 samples is beyond the harness's budget); up to 3
// visible points; radii for the profiles.
//
// Invariants (any violation aborts):
// * every entry point either returns or throws aaf::invalid_argument; nothing else escapes;
// * a gather that throws leaves `out` untouched;
// * a gather's output is never NaN, and is >= 0 when every map texel's E·F_t channel is >= 0 or non-finite
//   (the documented domain: E·F_t >= 0);
// * a built map's E·F_t is never NaN and never negative;
// * weighted_profile_sum over finite radii >= 0 and weights in [0, 1] is finite, >= 0 and within 1e-9 relative
//   (plus 1e-300) of the scalar sum; the directional dipole is finite and >= 0 for finite input.

#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <numbers>
#include <vector>

#include <aaf/subsurface.hpp>

#include "fuzz_input.hpp"

namespace {

namespace ss = aaf::subsurface;

struct fuzz_tracer {
    float answers[8] = {};
    [[nodiscard]] float nearest_occluder(const aaf::shadow_segment<float>& s) const noexcept {
        const std::uint32_t h = std::bit_cast<std::uint32_t>(s.origin.x) * 0x9e3779b9u ^ std::bit_cast<std::uint32_t>(s.direction.y) * 0x85ebca6bu ^
                                std::bit_cast<std::uint32_t>(s.origin.z);
        return answers[(h ^ (h >> 15)) % 8u];
    }
};

template <class Projection>
void run(aaf_fuzz::reader& in, const Projection& proj, const ss::material<float>& mat) {
    using vec3 = glm::vec3;
    const bool build = in.flag();
    ss::light_map<Projection> owned;
    std::vector<vec3> P[6], N[6], E[6];
    ss::light_map_view<Projection> view;
    bool nonnegative = true;
    if (build) {
        fuzz_tracer tracer;
        for (float& a : tracer.answers) a = in.value(1.0f);
        const ss::map_light<float> light{in.vec3(vec3(1))};
        const float eta = in.value(1.3f);
        const bool reconstruct = in.flag();
        const vec3 fixed_normal = in.vec3(vec3(0, 1, 0));
        try {
            if (reconstruct) owned = ss::build_light_map(proj, light, eta, tracer, ss::reconstruct_normals{});
            else owned = ss::build_light_map(proj, light, eta, tracer, [&](const vec3&) { return fixed_normal; });
        } catch (const aaf::invalid_argument&) {
            return;
        }
        for (int f = 0; f < Projection::faces(); ++f) {
            const auto& img = owned.irradiance[std::size_t(f)];
            for (std::size_t i = 0; i < proj.width * proj.height; ++i)
                for (int c = 0; c < 3; ++c) {
                    AAF_FUZZ_CHECK(!std::isnan(img.data()[i][c]));
                    AAF_FUZZ_CHECK(!(img.data()[i][c] < 0));
                }
        }
        view = owned.view();
    } else {
        const std::size_t w = proj.width, h = proj.height;
        if (w * h > 36) return;  // the harness's budget for filled maps
        view.projection = proj;
        for (int f = 0; f < Projection::faces(); ++f) {
            const auto k = std::size_t(f);
            P[k].resize(w * h), N[k].resize(w * h), E[k].resize(w * h);
            for (std::size_t i = 0; i < w * h; ++i) {
                const auto t = proj.texel_ray(f, {float(i % w) + 0.5f, float(i / w) + 0.5f});
                P[k][i] = in.vec3(t.origin + 1.0f * t.direction);
                N[k][i] = in.vec3(-t.direction);
                E[k][i] = in.vec3(vec3(0.5f));
                for (int c = 0; c < 3; ++c) nonnegative = nonnegative && !(E[k][i][c] < 0);
            }
            view.faces[k] = {{P[k].data(), w, h}, {N[k].data(), w, h}, {E[k].data(), w, h}, {}};
        }
    }
    ss::gather_settings<float> s;
    s.samples = in.count(16);
    if (s.samples > 64) return;
    s.radius = in.value(-1.0f);
    s.sampling = static_cast<ss::disc_sampling>(in.below(2));
    s.profile = static_cast<ss::profile_model>(in.below(2));
    s.boundary = static_cast<ss::boundary_term>(in.below(2));
    s.tangent_plane = in.flag();
    s.exact_centre = in.flag();
    s.fix_shrink = in.flag();
    s.fix_intrude = in.flag();
    s.fix_bias = in.flag();
    s.vector_profile = in.flag();
    s.shrink_epsilon = in.value(-1.0f);
    s.intrude_epsilon = in.value(-1.0f);
    s.bias_epsilon = in.value(-1.0f);
    const std::size_t n = 1 + in.below(3);
    std::vector<vec3> pts(n), nrm(n), out(n, vec3(-7.0f));
    for (std::size_t i = 0; i < n; ++i) {
        const auto t = proj.texel_ray(0, {0.5f * float(proj.width), 0.5f * float(proj.height)});
        pts[i] = in.vec3(t.origin + 1.0f * t.direction);
        nrm[i] = in.vec3(-t.direction);
    }
    const ss::visible_points<float> vp{{pts.data(), n, 1}, {nrm.data(), n, 1}};
    try {
        (void)ss::gather_subsurface(vp, view, mat, s, aaf::image_view<vec3>(out.data(), n, 1));
    } catch (const aaf::invalid_argument&) {
        for (const vec3& o : out) AAF_FUZZ_CHECK(o == vec3(-7.0f));
        return;
    }
    for (const vec3& o : out)
        for (int c = 0; c < 3; ++c) {
            if (std::isnan(o[c])) {  // what the replay needs to see before the abort
                std::fprintf(stderr, "material sa %g %g %g ssp %g %g %g eta %g; samples %u radius %g sampling %d profile %d boundary %d "
                             "tangent %d exact %d fixes %d%d%d vector %d eps %g %g %g; built %d faces %d size %zux%zu\n",
                             double(mat.sigma_a.x), double(mat.sigma_a.y), double(mat.sigma_a.z), double(mat.sigma_s_prime.x),
                             double(mat.sigma_s_prime.y), double(mat.sigma_s_prime.z), double(mat.eta), s.samples, double(s.radius),
                             int(s.sampling), int(s.profile), int(s.boundary), s.tangent_plane, s.exact_centre, s.fix_shrink, s.fix_intrude,
                             s.fix_bias, s.vector_profile, double(s.shrink_epsilon), double(s.intrude_epsilon), double(s.bias_epsilon), build,
                             Projection::faces(), proj.width, proj.height);
                for (std::size_t i = 0; i < n; ++i)
                    std::fprintf(stderr, "point %g %g %g normal %g %g %g out %g %g %g\n", double(pts[i].x), double(pts[i].y), double(pts[i].z),
                                 double(nrm[i].x), double(nrm[i].y), double(nrm[i].z), double(out[i].x), double(out[i].y), double(out[i].z));
                for (int f = 0; f < Projection::faces(); ++f)
                    for (std::size_t i = 0; i < proj.width * proj.height; ++i) {
                        const vec3 q = view.faces[std::size_t(f)].positions.empty() ? vec3(0) : view.faces[std::size_t(f)].positions(i % proj.width, i / proj.width);
                        const vec3 nn = view.faces[std::size_t(f)].normals(i % proj.width, i / proj.width);
                        const vec3 e = view.faces[std::size_t(f)].irradiance(i % proj.width, i / proj.width);
                        std::fprintf(stderr, "texel %d/%zu p %g %g %g n %g %g %g E %g %g %g\n", f, i, double(q.x), double(q.y), double(q.z),
                                     double(nn.x), double(nn.y), double(nn.z), double(e.x), double(e.y), double(e.z));
                    }
            }
            AAF_FUZZ_CHECK(!std::isnan(o[c]));
            if (nonnegative) AAF_FUZZ_CHECK(!(o[c] < 0));
        }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    aaf_fuzz::reader in(data, size);
    ss::material<float> mat = ss::presets::marble();
    for (int c = 0; c < 3; ++c) {
        mat.sigma_a[c] = in.value(mat.sigma_a[c]);
        mat.sigma_s_prime[c] = in.value(mat.sigma_s_prime[c]);
    }
    mat.eta = in.value(mat.eta);
    bool valid = true;
    try {
        ss::validate(mat, "fuzz");
    } catch (const aaf::invalid_argument&) {
        valid = false;
    }
    if (valid) {
        // The profiles on their own: the vectorised sum against the scalar one, and the directional dipole.
        const ss::rgb_dipole d(mat);
        const std::size_t n = in.below(20);
        std::vector<double> r(n), w(n);
        for (std::size_t i = 0; i < n; ++i) {
            r[i] = std::abs(double(in.value(1.0f)));
            w[i] = std::abs(double(in.value(0.5f)));
            if (!std::isfinite(r[i])) r[i] = 0;
            if (!(w[i] <= 1)) w[i] = 1;
        }
        const glm::dvec3 v = ss::weighted_profile_sum(d, r.data(), w.data(), w.data(), w.data(), n);
        glm::dvec3 scalar(0), subnormal_slack(0);
        for (std::size_t i = 0; i < n; ++i) {
            scalar += w[i] * d.profile(r[i]);
            // Where e^{−σd} is subnormal (σd > 708) neither sum holds it relatively: std::exp and the vector exp
            // (simd_exp.hpp) each to a step of 2^−1074 plus 2 ulp of 2^−1022. Allow 64 steps times the factor z(1 + σd)/d³
            // it is multiplied by; where e^{−σd} is normal this is ≤ 2^−46 of the term, inside the 1e-9.
            for (int c = 0; c < 3; ++c) {
                const ss::dipole& ch = d.channel[c];
                const auto factor = [&](double z) {
                    const double dd = std::sqrt(r[i] * r[i] + z * z);
                    return std::isinf(dd) ? 0.0 : z * (1 + ch.sigma_tr * dd) / (dd * dd * dd);
                };
                subnormal_slack[c] += w[i] * ch.alpha_prime / (4 * std::numbers::pi) * (factor(ch.z_r) + factor(ch.z_v)) * 0x1p-1068;
            }
        }
        for (int c = 0; c < 3; ++c) {
            AAF_FUZZ_CHECK(std::isfinite(v[c]) && v[c] >= 0);
            AAF_FUZZ_CHECK(std::abs(v[c] - scalar[c]) <= 1e-9 * scalar[c] + subnormal_slack[c] + 1e-300);
        }
        const ss::rgb_directional_dipole dd(mat);
        const glm::dvec3 xi(in.vec3(glm::vec3(0))), ni(in.vec3(glm::vec3(0, 0, 1))), wl(in.vec3(glm::vec3(0, 0, 1)));
        const glm::dvec3 xo(in.vec3(glm::vec3(1, 0, 0))), no(in.vec3(glm::vec3(0, 0, 1)));
        const bool finite = std::isfinite(glm::dot(xi, xi) + glm::dot(ni, ni) + glm::dot(wl, wl) + glm::dot(xo, xo) + glm::dot(no, no));
        const auto unit = [](const glm::dvec3& x) { return std::abs(glm::length(x) - 1) < 1e-6; };
        if (finite && unit(ni) && unit(wl) && unit(no)) {
            const glm::dvec3 sd = dd.evaluate(xi, ni, wl, xo, no);
            for (int c = 0; c < 3; ++c) AAF_FUZZ_CHECK(std::isfinite(sd[c]) && sd[c] >= 0);
        }
    }
    const std::size_t res = 1 + in.below(6);
    if (in.flag()) {
        ss::cube_projection<float> p = ss::cube_projection<float>::around(in.vec3(glm::vec3(0, 3, 0)), in.value(10.0f), res);
        run(in, p, mat);
    } else {
        ss::orthographic_projection<float> p;
        p.origin = in.vec3(glm::vec3(0, 3, 0));
        p.forward = in.vec3(glm::vec3(0, -1, 0));
        p.right = in.vec3(glm::vec3(1, 0, 0));
        p.up = in.vec3(glm::vec3(0, 0, -1));
        p.half_width = in.value(1.0f);
        p.half_height = in.value(1.0f);
        p.far = in.value(10.0f);
        p.width = 1 + in.below(6);
        p.height = 1 + in.below(6);
        run(in, p, mat);
    }
    return 0;
}
