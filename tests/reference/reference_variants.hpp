// SPDX-License-Identifier: MIT
#pragma once
// Plain, deliberately slow reference implementations of the peers in include/aaf/variants/ (the guided
// à-trous filter and the joint bilateral filter), written from their published definitions rather than
// from the library's code: every tap's weight is the product of its factors evaluated directly in double,
// the à-trous kernel is the dilated 5×5 B3 spline written out as h(i)h(j) at offsets (i, j)·2^it, and each
// iteration reads a whole copy of the previous one. Conventions shared with the library (and documented
// there): the centre tap has no edge stop; a non-finite neighbour or one whose guides are non-finite is
// skipped; a non-finite centre averages its neighbours without the luminance stop, or keeps its value.

#include <cmath>
#include <cstdint>
#include <optional>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <aaf/image.hpp>

namespace aaf_ref {

/// What the references read: any guide may be absent.
struct variant_inputs {
    const aaf::image<float>* value = nullptr;
    const aaf::image<float>* variance = nullptr;  ///< null: no luminance stop
    const aaf::image<float>* pixel_size = nullptr;
    const aaf::image<glm::vec3>* normals = nullptr;
    const aaf::image<glm::vec3>* positions = nullptr;
    const aaf::image<std::uint32_t>* ids = nullptr;
    double normal_power = 128, plane_sigma = 1;
};

/// The G-buffer edge-stop weight of neighbour (nx, ny) of centre (x, y) at pixel distance r; nullopt when
/// the neighbour is rejected outright.
inline std::optional<double> edge_weight(const variant_inputs& in, std::size_t x, std::size_t y, std::size_t nx, std::size_t ny, double r) {
    if (in.ids && (*in.ids)(x, y) != (*in.ids)(nx, ny)) return std::nullopt;
    double w = 1;
    if (in.normals) {
        const glm::dvec3 a((*in.normals)(x, y)), b((*in.normals)(nx, ny));
        const double c = glm::dot(a, b);
        if (!std::isfinite(c)) return std::nullopt;
        if (in.normal_power > 0) w *= c > 0 ? std::pow(std::min(c, 1.0), in.normal_power) : 0.0;
    }
    if (in.positions) {
        const glm::dvec3 n((*in.normals)(x, y)), p((*in.positions)(x, y)), q((*in.positions)(nx, ny));
        const double dist = std::abs(glm::dot(n, q - p));
        if (!std::isfinite(dist)) return std::nullopt;
        const double d = (*in.pixel_size)(x, y);
        if (std::isfinite(in.plane_sigma) && d > 0 && std::isfinite(d)) w *= std::exp(-dist / (in.plane_sigma * d * r));
    }
    return w;
}

/// The centre's guides are finite.
inline bool centre_valid(const variant_inputs& in, std::size_t x, std::size_t y) {
    const auto finite = [](const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); };
    if (in.normals && !finite((*in.normals)(x, y))) return false;
    if (in.positions && !finite((*in.positions)(x, y))) return false;
    return true;
}

/// The guided à-trous filter: `iterations` passes, SVGF's luminance stop when `in.variance` is set.
inline aaf::image<double> atrous(const variant_inputs& in, unsigned iterations, double luminance_sigma, double eps) {
    const std::size_t w = in.value->width(), h = in.value->height();
    const double hk[5] = {1.0 / 16, 1.0 / 4, 3.0 / 8, 1.0 / 4, 1.0 / 16};
    aaf::image<double> cur(w, h), var(w, h);
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) {
            cur(x, y) = (*in.value)(x, y);
            var(x, y) = in.variance ? double((*in.variance)(x, y)) : 0.0;
        }
    for (unsigned it = 0; it < iterations; ++it) {
        const long step = 1L << it;
        // The centre's variance for the luminance stop: 3×3 (1 2 1)² Gaussian over finite, same-ID neighbours.
        aaf::image<double> pre(w, h);
        for (std::size_t y = 0; y < h; ++y)
            for (std::size_t x = 0; x < w; ++x) {
                double s = 0, ws = 0;
                for (long j = -1; j <= 1; ++j)
                    for (long i = -1; i <= 1; ++i) {
                        const long nx = long(x) + i, ny = long(y) + j;
                        if (nx < 0 || ny < 0 || nx >= long(w) || ny >= long(h)) continue;
                        if (in.ids && (*in.ids)(nx, ny) != (*in.ids)(x, y)) continue;
                        if (!std::isfinite(var(nx, ny))) continue;
                        const double k = (i == 0 ? 2.0 : 1.0) * (j == 0 ? 2.0 : 1.0);
                        s += k * var(nx, ny), ws += k;
                    }
                pre(x, y) = ws > 0 ? s / ws : 0.0;
            }
        aaf::image<double> next(w, h), next_var(w, h);
        for (std::size_t y = 0; y < h; ++y)
            for (std::size_t x = 0; x < w; ++x) {
                const double c = cur(x, y);
                const bool lum = in.variance && std::isfinite(c) && std::isfinite(luminance_sigma);
                const double scale = lum ? luminance_sigma * std::sqrt(std::max(pre(x, y), 0.0)) + eps : 0.0;
                double s = 0, ws = 0, vs = 0;
                for (long j = -2; j <= 2; ++j)
                    for (long i = -2; i <= 2; ++i) {
                        const long nx = long(x) + i * step, ny = long(y) + j * step;
                        if (nx < 0 || ny < 0 || nx >= long(w) || ny >= long(h)) continue;
                        const double v = cur(nx, ny);
                        if (!std::isfinite(v)) continue;
                        double wt = hk[i + 2] * hk[j + 2];
                        if (i != 0 || j != 0) {
                            if (!centre_valid(in, x, y)) continue;
                            const auto e = edge_weight(in, x, y, nx, ny, double(step) * std::sqrt(double(i * i + j * j)));
                            if (!e) continue;
                            wt *= *e;
                            if (lum) wt *= std::exp(-std::abs(c - v) / scale);
                        }
                        if (!(wt > 0)) continue;
                        s += wt * v, ws += wt, vs += wt * wt * var(nx, ny);
                    }
                next(x, y) = ws > 0 ? s / ws : c;
                next_var(x, y) = ws > 0 ? vs / (ws * ws) : var(x, y);
            }
        cur = std::move(next);
        var = std::move(next_var);
    }
    return cur;
}

/// The joint bilateral filter: Gaussian of standard deviation `sigma` px over a (2r+1)² window, r = ⌈truncation·sigma⌉.
inline aaf::image<double> bilateral(const variant_inputs& in, double sigma, double truncation) {
    const std::size_t w = in.value->width(), h = in.value->height();
    const long r = long(std::ceil(float(truncation) * float(sigma)));  // the window is a discrete decision: in float, as the library
    aaf::image<double> out(w, h);
    for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) {
            const double c = (*in.value)(x, y);
            double s = 0, ws = 0;
            for (long j = -r; j <= r; ++j)
                for (long i = -r; i <= r; ++i) {
                    const long nx = long(x) + i, ny = long(y) + j;
                    if (nx < 0 || ny < 0 || nx >= long(w) || ny >= long(h)) continue;
                    const double v = (*in.value)(nx, ny);
                    if (!std::isfinite(v)) continue;
                    double wt = 1;
                    if (i != 0 || j != 0) {
                        if (!centre_valid(in, x, y)) continue;
                        const double d = std::sqrt(double(i * i + j * j));
                        const auto e = edge_weight(in, x, y, nx, ny, d);
                        if (!e) continue;
                        wt = std::exp(-d * d / (2 * sigma * sigma)) * *e;
                    }
                    if (!(wt > 0)) continue;
                    s += wt * v, ws += wt;
                }
            out(x, y) = ws > 0 ? s / ws : c;
        }
    return out;
}

}  // namespace aaf_ref
