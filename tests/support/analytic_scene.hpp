// SPDX-License-Identifier: MIT
#pragma once
// An analytic test scene: a rectangular light parallel to a receiver plane, with axis-aligned rectangular
// occluders parallel to both. The visible fraction of the light at every receiver point is exact: the
// light's area minus the area of the union of the occluders' projections (from the receiver point onto
// the light plane) inside it. Used as the oracle for the sampler, statistics and the whole pipeline.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include <array>

#include <aaf/area_light.hpp>
#include <aaf/gather.hpp>
#include <aaf/image.hpp>
#include <aaf/tracer.hpp>

namespace aaf_test {

template <class T>
using vec3 = glm::vec<3, T>;

/// Axis-aligned rectangle in the xz-plane at height y.
template <class T>
struct rect {
    T x0, x1, z0, z1, y;
};

/// Receiver: the plane y = 0, seen straight from above by an orthographic camera covering
/// [x_min, x_min + extent] × [z_min, z_min + extent] with width×height pixels.
template <class T>
struct analytic_scene {
    rect<T> light{-0.75, 0.75, -0.75, 0.75, 3};
    std::vector<rect<T>> occluders{{-0.6, 0.6, -0.3, 0.3, 1}};
    T x_min = -2, z_min = -2, extent = 4;
    std::size_t width = 64, height = 64;

    [[nodiscard]] aaf::area_light<T> area_light() const {
        // corner + edges with cross(edge_u, edge_v) pointing down, towards the receiver.
        return {{light.x0, light.y, light.z0}, {light.x1 - light.x0, 0, 0}, {0, 0, light.z1 - light.z0}, false};
    }
    [[nodiscard]] T pixel_size() const { return extent / static_cast<T>(width); }
    [[nodiscard]] vec3<T> position(std::size_t x, std::size_t y) const {
        const T px = x_min + (static_cast<T>(x) + T(0.5)) * pixel_size();
        const T pz = z_min + (static_cast<T>(y) + T(0.5)) * extent / static_cast<T>(height);
        return {px, 0, pz};
    }

    /// Exact visible fraction of the light (uniform weighting) from receiver point p (on y = 0).
    [[nodiscard]] double exact_visibility(const vec3<T>& p) const {
        const auto D = [](T v) { return static_cast<double>(v); };
        const double H = D(light.y), px = D(p.x), pz = D(p.z);
        std::vector<std::array<double, 4>> boxes;  // projections clipped to the light
        for (const rect<T>& o : occluders) {
            if (!(D(o.y) > 0 && D(o.y) < H)) continue;
            const double s = H / D(o.y);
            double a0 = px + (D(o.x0) - px) * s, a1 = px + (D(o.x1) - px) * s;
            double b0 = pz + (D(o.z0) - pz) * s, b1 = pz + (D(o.z1) - pz) * s;
            a0 = std::max(a0, D(light.x0)), a1 = std::min(a1, D(light.x1));
            b0 = std::max(b0, D(light.z0)), b1 = std::min(b1, D(light.z1));
            if (a0 < a1 && b0 < b1) boxes.push_back({a0, a1, b0, b1});
        }
        // Exact union area by coordinate compression (a handful of boxes).
        std::vector<double> xs, zs;
        for (auto& b : boxes) xs.insert(xs.end(), {b[0], b[1]}), zs.insert(zs.end(), {b[2], b[3]});
        std::sort(xs.begin(), xs.end());
        std::sort(zs.begin(), zs.end());
        double covered = 0;
        for (std::size_t i = 0; i + 1 < xs.size(); ++i)
            for (std::size_t j = 0; j + 1 < zs.size(); ++j) {
                const double cx = 0.5 * (xs[i] + xs[i + 1]), cz = 0.5 * (zs[j] + zs[j + 1]);
                for (auto& b : boxes)
                    if (cx > b[0] && cx < b[1] && cz > b[2] && cz < b[3]) {
                        covered += (xs[i + 1] - xs[i]) * (zs[j + 1] - zs[j]);
                        break;
                    }
            }
        const double area = (D(light.x1) - D(light.x0)) * (D(light.z1) - D(light.z0));
        return 1.0 - covered / area;
    }

    [[nodiscard]] aaf::image<double> exact_image() const {
        aaf::image<double> img(width, height);
        for (std::size_t y = 0; y < height; ++y)
            for (std::size_t x = 0; x < width; ++x) img(x, y) = exact_visibility(position(x, y));
        return img;
    }

    /// Occluder hits along a segment: nearest and farthest distance (all-hits statistics).
    [[nodiscard]] aaf::occluder_span<T> span(const aaf::shadow_segment<T>& s) const {
        aaf::occluder_span<T> out{};
        for (const rect<T>& o : occluders) {
            if (s.direction.y == T(0)) continue;
            const T t = (o.y - s.origin.y) / s.direction.y;
            if (!(t > T(0) && t < s.length)) continue;
            const T hx = s.origin.x + t * s.direction.x, hz = s.origin.z + t * s.direction.z;
            if (hx < o.x0 || hx > o.x1 || hz < o.z0 || hz > o.z1) continue;
            out.nearest = std::min(out.nearest, t);
            out.farthest = std::max(out.farthest, t);
        }
        return out;
    }
};

/// The same scene through each shape of the tracer contract.
template <class T>
struct span_tracer {
    const analytic_scene<T>* scene;
    aaf::occluder_span<T> occluder_span(const aaf::shadow_segment<T>& s) const { return scene->span(s); }
};
template <class T>
struct nearest_tracer {
    const analytic_scene<T>* scene;
    T nearest_occluder(const aaf::shadow_segment<T>& s) const {
        const auto sp = scene->span(s);
        return sp.hit() ? sp.nearest : aaf::no_occluder<T>;
    }
};
template <class T>
struct boolean_tracer {
    const analytic_scene<T>* scene;
    bool occluded(const aaf::shadow_segment<T>& s) const { return scene->span(s).hit(); }
};
template <class T>
struct batch_tracer {
    const analytic_scene<T>* scene;
    mutable std::size_t batches = 0;  // not thread-safe: only for sequential tests
    void trace_batch(std::span<const aaf::shadow_segment<T>> in, std::span<aaf::occluder_span<T>> out) const {
        ++batches;
        for (std::size_t i = 0; i < in.size(); ++i) out[i] = scene->span(in[i]);
    }
};

/// G-buffer images for the scene (orthographic camera from above).
template <class T>
struct analytic_gbuffer {
    aaf::image<vec3<T>> positions, normals;
    aaf::image<T> pixel_size;
    aaf::image<std::uint32_t> ids;

    explicit analytic_gbuffer(const analytic_scene<T>& s)
        : positions(s.width, s.height), normals(s.width, s.height, vec3<T>(0, 1, 0)),
          pixel_size(s.width, s.height, s.pixel_size()), ids(s.width, s.height, 1u) {
        for (std::size_t y = 0; y < s.height; ++y)
            for (std::size_t x = 0; x < s.width; ++x) positions(x, y) = s.position(x, y);
    }
    [[nodiscard]] aaf::gbuffer<T> view() const { return {positions.cview(), normals.cview(), pixel_size.cview(), {}}; }
    [[nodiscard]] aaf::gbuffer<T, aaf::const_image_view<std::uint32_t>> view_with_ids() const {
        return {positions.cview(), normals.cview(), pixel_size.cview(), ids.cview()};
    }
    /// Tilts the left half's normals 80° about z: there the tangent planes of receivers near the light's
    /// footprint cut the light (area_light::straddles_horizon); elsewhere the whole light stays above.
    void tilt_left_half_to_horizon() {
        const T t = T(1.3962634);  // 80°
        for (std::size_t y = 0; y < normals.height(); ++y)
            for (std::size_t x = 0; x < normals.width() / 2; ++x) normals(x, y) = {std::sin(t), std::cos(t), T(0)};
    }
};

template <class A, class B>
double rmse(const A& a, const B& b) {
    double sum = 0;
    for (std::size_t y = 0; y < a.height(); ++y)
        for (std::size_t x = 0; x < a.width(); ++x) {
            const double d = static_cast<double>(a(x, y)) - static_cast<double>(b(x, y));
            sum += d * d;
        }
    return std::sqrt(sum / static_cast<double>(a.width() * a.height()));
}

}  // namespace aaf_test
