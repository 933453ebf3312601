// SPDX-License-Identifier: MIT
#pragma once
// The exact light-integrated sheared gather of FORMULAS.md §9.3, O(n²l²) per pixel, written directly in
// world space and double precision, as the oracle of the factored passes of include/aaf/variants/sheared.hpp:
//
//   I(p0) = Σ_p Σ_k a(Δx) L(ŷ_k) V_k / Σ_p Σ_k a(Δx) L(ŷ_k),   a = exp(−|Δx|²/2β²),
//
// over a square window of pixels p around p0, where ŷ_k is where the ray from p0 through the point at
// which p's sample ray k crosses the centre's occluder plane (height d2 = h0·c/(1+c) above the light)
// meets the light, and Δx is the offset of the two receivers projected onto the light plane. No guides,
// no shear test: the oracle is for scenes where every neighbour is accepted. With `cells` > 0 it is the
// per-cell form (sheared_normalization::per_cell): the mean visibility of each of cells × cells equal
// parts of the light, averaged over the parts that have samples.

#include <cmath>
#include <cstddef>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <aaf/image.hpp>
#include <aaf/variants/sheared.hpp>

namespace aaf_ref {

/// Exact gather at every centre pixel (NaN elsewhere), window radius `radius` pixels in x and y.
inline aaf::image<double> sheared_gather_exact(const aaf::image<glm::vec3>& positions, const aaf::area_light<float>& light,
                                               const aaf::light_sample_buffer<float>& samples,
                                               const aaf::image<aaf::shear<float>>& shears, std::size_t radius,
                                               std::size_t cells = 0) {
    using dvec3 = glm::dvec3;
    const std::size_t w = positions.width(), h = positions.height();
    aaf::image<double> out(w, h, std::nan(""));
    const dvec3 corner(light.corner), eu(light.edge_u), ev(light.edge_v);
    const dvec3 n = glm::normalize(glm::cross(eu, ev));
    const double g00 = glm::dot(eu, eu), g01 = glm::dot(eu, ev), g11 = glm::dot(ev, ev), det = g00 * g11 - g01 * g01;
    const auto height = [&](const dvec3& p) { return glm::dot(p - corner, n); };
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) {
            const aaf::shear<float> sh = shears(x, y);
            if (!sh.center) continue;
            const dvec3 p0(positions(x, y));
            const double h0 = height(p0);
            const double c = sh.c, d2 = h0 * c / (1 + c);
            const double beta = sh.beta;
            double num = 0, den = 0;
            std::vector<double> cn(cells * cells, 0.0), cd(cells * cells, 0.0);
            for (std::size_t yn = (y >= radius ? y - radius : 0); yn <= std::min(h - 1, y + radius); ++yn)
                for (std::size_t xn = (x >= radius ? x - radius : 0); xn <= std::min(w - 1, x + radius); ++xn) {
                    const dvec3 p(positions(xn, yn));
                    const dvec3 d = p0 - p;
                    const double along = glm::dot(d, n);
                    const double dist2 = glm::dot(d, d) - along * along;
                    const double a = std::isfinite(beta) ? std::exp(-dist2 / (2 * beta * beta)) : 1.0;
                    const double hp = height(p);
                    for (const auto& smp : samples.pixel(xn, yn)) {
                        if (smp.state == aaf::sample_state::unused) continue;
                        const dvec3 yl = corner + double(smp.u) * eu + double(smp.v) * ev;
                        const dvec3 o = yl + (p - yl) * (d2 / hp);           // crossing of the occluder plane
                        const dvec3 yc = p0 + (o - p0) * (h0 / (h0 - d2));   // the centre's ray through it, on the light
                        const dvec3 r = yc - corner;
                        const double ru = glm::dot(r, eu), rv = glm::dot(r, ev);
                        const double u = (g11 * ru - g01 * rv) / det, v = (g00 * rv - g01 * ru) / det;
                        if (!(u >= 0 && u <= 1 && v >= 0 && v <= 1)) continue;  // uniform emission profile
                        const double vis = smp.state == aaf::sample_state::visible ? 1.0 : 0.0;
                        if (cells != 0) {
                            const auto cu = std::min(cells - 1, static_cast<std::size_t>(u * double(cells)));
                            const auto cv = std::min(cells - 1, static_cast<std::size_t>(v * double(cells)));
                            cn[cv * cells + cu] += a * vis, cd[cv * cells + cu] += a;
                        } else {
                            den += a, num += a * vis;
                        }
                    }
                }
            for (std::size_t k = 0; k < cn.size(); ++k)  // per-cell means, equal-area cells of a uniform light
                if (cd[k] > 0) num += cn[k] / cd[k], den += 1;
            out(x, y) = den > 0 ? num / den : std::nan("");
        }
    return out;
}

}  // namespace aaf_ref
