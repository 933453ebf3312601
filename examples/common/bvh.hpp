// SPDX-License-Identifier: MIT
#pragma once
// A tiny CPU BVH over triangles for aaf's examples, tests and benchmarks: binned-SAH build, a watertight
// ray–triangle test, nearest-hit queries for primary rays and the three shadow queries of aaf's tracer
// contract (occluder_span, nearest_occluder, occluded). Header-only; every query is const, noexcept and
// safe to call from many threads at once.
//
// Input: an indexed mesh, `vertices` (positions) and `triangles` (three indices per triangle). Triangle
// indices reported by queries are positions in that `triangles` span. Triangles with a non-finite vertex
// or exactly zero area (see `usable_triangle`) are dropped and counted; bad indices or an empty mesh throw.
//
// Layout: 32-byte nodes, the two children of a node stored next to each other, the triangles copied into
// leaf order (three vertices each) so a leaf is one contiguous read. The nearest-hit and any-hit queries
// traverse an 8-wide copy of the tree instead (the binary tree collapsed, Wald et al. 2008 "Getting Rid of
// Packets", Dammertz et al. 2008 "Shallow Bounding Volume Hierarchies"): 256-byte nodes holding their eight
// children's boxes side by side, tested four at a time with SSE, and leaves referenced from their parent's
// lane, so a ray loads about a third as many nodes and no leaf node at all, and the lanes it enters are
// prefetched as soon as they are known. Traversal is memory-latency bound (a profile of the binary traversal
// spent most of its time waiting for node and triangle loads), which is what this buys back; 8 lanes measured
// ~15 % faster than 4 (benchmarks/bench_bvh.cpp, BM_tracers). AAF_EXAMPLES_BVH_LANES (4, 8, ...) overrides.
//
// Robustness: the triangle test is Woop, Benthin & Wald, "Watertight Ray/Triangle Intersection", JCGT 2(1)
// 2013, with the 2D edge functions evaluated in double. Products of two floats are exact in double, so the
// edge function of an edge shared by two triangles is bit-for-bit the negation of its neighbour's, whether or
// not the compiler fuses multiply-adds (GCC does at -O2 -march=native even with -std=c++20; the all-float
// version of the paper then leaks rays through shared edges). The box test is conservative (Ize 2013,
// "Robust BVH Ray Traversal": the exit distance is scaled by 1 + 2γ₃), so a node holding a hit is never culled.

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdint>
#include <exception>
#include <limits>
#include <span>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#if defined(__SSE2__) || defined(_M_X64)
#include <immintrin.h>
#define AAF_EXAMPLES_BVH_SSE 1
#endif
#ifndef AAF_EXAMPLES_BVH_LANES
#define AAF_EXAMPLES_BVH_LANES 8  // a multiple of 4
#endif

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <aaf/tracer.hpp>

namespace aaf_examples {

// ---------------------------------------------------------------------------------------------------------
// The watertight ray–triangle test, usable on its own (the tests' brute-force reference uses it).

/// A ray prepared for `intersect_triangle`: the shear that maps its direction onto +z (Woop et al. §3).
struct watertight_ray {
    glm::vec3 origin{0};          ///< ray origin
    int kx = 0, ky = 1, kz = 2;   ///< kz: dominant axis of the direction; kx, ky: the others, winding kept
    float sx = 0, sy = 0, sz = 1; ///< shear (sx, sy) and scale (sz) constants
};

/// Prepares the ray `origin + t * direction`; `direction` must be finite and non-zero (any length).
[[nodiscard]] inline watertight_ray make_watertight_ray(const glm::vec3& origin, const glm::vec3& direction) noexcept {
    watertight_ray r;
    r.origin = origin;
    const glm::vec3 a = glm::abs(direction);
    r.kz = a.x > a.y ? (a.x > a.z ? 0 : 2) : (a.y > a.z ? 1 : 2);
    r.kx = (r.kz + 1) % 3;
    r.ky = (r.kx + 1) % 3;
    if (direction[r.kz] < 0.0f) std::swap(r.kx, r.ky);  // keep the winding, so the sign test is consistent
    r.sx = direction[r.kx] / direction[r.kz];
    r.sy = direction[r.ky] / direction[r.kz];
    r.sz = 1.0f / direction[r.kz];
    return r;
}

/// A ray–triangle hit: distance and barycentrics, hit point = (1 - b1 - b2) p0 + b1 p1 + b2 p2.
struct triangle_hit {
    float t = 0;   ///< distance in units of the ray direction's length
    float b1 = 0;  ///< barycentric weight of p1
    float b2 = 0;  ///< barycentric weight of p2
};

/// Watertight test (Woop et al. 2013): true, with `hit` filled, iff the ray meets the triangle at a distance
/// t in the OPEN interval (t_lo, t_hi). Both faces count. A ray through a shared edge or vertex of a mesh
/// hits at least one of the triangles around it; an edge-on or zero-area triangle is never hit.
[[nodiscard]] inline bool intersect_triangle(const watertight_ray& r, const glm::vec3& p0, const glm::vec3& p1,
                                             const glm::vec3& p2, float t_lo, float t_hi, triangle_hit& hit) noexcept {
    const glm::vec3 a = p0 - r.origin, b = p1 - r.origin, c = p2 - r.origin;
    // Shear into ray space. s·w is exact in double, so each vertex maps to the same floats in every
    // triangle that uses it, whatever the compiler does with multiply-adds.
    const auto shear = [](float u, float s, float w) noexcept {
        return static_cast<float>(static_cast<double>(u) - static_cast<double>(s) * static_cast<double>(w));
    };
    const float ax = shear(a[r.kx], r.sx, a[r.kz]), ay = shear(a[r.ky], r.sy, a[r.kz]);
    const float bx = shear(b[r.kx], r.sx, b[r.kz]), by = shear(b[r.ky], r.sy, b[r.kz]);
    const float cx = shear(c[r.kx], r.sx, c[r.kz]), cy = shear(c[r.ky], r.sy, c[r.kz]);
    // Scaled barycentrics = 2D edge functions. Float products are exact in double: U of an edge is exactly
    // -U of the same edge seen from the neighbouring triangle, and U == 0 only on the (sheared) edge itself.
    const auto d = [](float x) noexcept { return static_cast<double>(x); };
    const double u = d(cx) * d(by) - d(cy) * d(bx);
    const double v = d(ax) * d(cy) - d(ay) * d(cx);
    const double w = d(bx) * d(ay) - d(by) * d(ax);
    if ((u < 0 || v < 0 || w < 0) && (u > 0 || v > 0 || w > 0)) return false;
    const double det = u + v + w;
    if (det == 0) return false;
    const double t_scaled = d(r.sz) * (u * d(a[r.kz]) + v * d(b[r.kz]) + w * d(c[r.kz]));
    const float t = static_cast<float>(t_scaled / det);
    if (!(t > t_lo && t < t_hi)) return false;
    hit = {t, static_cast<float>(v / det), static_cast<float>(w / det)};
    return true;
}

/// The triangles the BVH keeps: finite vertices and a non-zero cross product of the edges (exact test).
[[nodiscard]] inline bool usable_triangle(const glm::vec3& p0, const glm::vec3& p1, const glm::vec3& p2) noexcept {
    const auto finite = [](const glm::vec3& p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z); };
    if (!finite(p0) || !finite(p1) || !finite(p2)) return false;
    const glm::dvec3 e1(p1 - p0), e2(p2 - p0);  // float differences; their products are exact in double
    return glm::cross(e1, e2) != glm::dvec3(0.0);
}

// ---------------------------------------------------------------------------------------------------------
// The BVH.

/// One BVH node, 32 bytes. Interior (count == 0): children at `index` and `index + 1`. Leaf: triangles
/// [index, index + count) in leaf order.
struct bvh_node {
    glm::vec3 lo{0};         ///< bounds, minimum corner
    std::uint32_t index = 0; ///< first child (interior) or first triangle (leaf)
    glm::vec3 hi{0};         ///< bounds, maximum corner
    std::uint32_t count = 0; ///< triangles in the leaf; 0 for an interior node
};
static_assert(sizeof(bvh_node) == 32);

/// Build settings.
struct bvh_build_options {
    unsigned max_leaf_size = 4;  ///< at most this many triangles per leaf (1..16); SAH may stop earlier
    unsigned threads = 2;        ///< threads building at once, the caller's included (0 or 1 = serial)
};

/// The nearest hit of a primary ray.
struct ray_hit {
    static constexpr std::uint32_t no_triangle = 0xffffffffu;  ///< `triangle` on a miss
    float t = std::numeric_limits<float>::infinity();  ///< distance in units of the direction's length; +inf on a miss
    std::uint32_t triangle = no_triangle;               ///< index into the `triangles` given to the build
    glm::vec2 barycentrics{0};                          ///< (b1, b2): weights of the triangle's 2nd and 3rd vertex
    glm::vec3 normal{0};                                ///< unit geometric normal, cross(v1 - v0, v2 - v0), not flipped
    /// True when something was hit.
    [[nodiscard]] bool hit() const noexcept { return triangle != no_triangle; }
};

/// A bounding volume hierarchy over an indexed triangle mesh; an aaf tracer (span, nearest and boolean).
class bvh {
public:
    static constexpr unsigned max_depth = 63;  ///< deepest leaf (root = 0); bounds the traversal stack

    /// Builds the BVH (binned SAH, 32 bins on each axis). Throws std::invalid_argument when the mesh has no
    /// triangles, an index is out of range, or no triangle is usable; unusable triangles are dropped.
    bvh(std::span<const glm::vec3> vertices, std::span<const glm::uvec3> triangles, const bvh_build_options& options = {});

    /// Nearest hit of the ray origin + t·direction with 0 < t < t_max (direction of any non-zero length).
    [[nodiscard]] ray_hit nearest_hit(const glm::vec3& origin, const glm::vec3& direction,
                                      float t_max = std::numeric_limits<float>::infinity()) const noexcept;
    /// aaf contract: nearest and farthest hit with 0 < t < length (the nearest-hit traversal, which sets aside
    /// the subtrees it prunes, then a farthest-hit search of those subtrees only); a miss is a default span;
    /// an invalid segment (non-finite, zero direction, NaN length) gives NaN, which aaf drops as a failed sample.
    [[nodiscard]] aaf::occluder_span<float> occluder_span(const aaf::shadow_segment<float>& segment) const noexcept;
    /// aaf contract: nearest hit with 0 < t < length, aaf::no_occluder on a miss, NaN for an invalid segment.
    [[nodiscard]] float nearest_occluder(const aaf::shadow_segment<float>& segment) const noexcept;
    /// Any hit with 0 < t < length (stops at the first one found); false for an invalid segment.
    [[nodiscard]] bool occluded(const aaf::shadow_segment<float>& segment) const noexcept;

    /// Triangles in the BVH (after dropping unusable ones).
    [[nodiscard]] std::size_t triangle_count() const noexcept { return ids_.size(); }
    /// Input triangles dropped as unusable (non-finite vertex or zero area).
    [[nodiscard]] std::size_t dropped_triangles() const noexcept { return dropped_; }
    /// Depth of the deepest leaf (the root is at depth 0).
    [[nodiscard]] unsigned depth() const noexcept { return depth_; }
    /// The nodes; the root is nodes()[0].
    [[nodiscard]] std::span<const bvh_node> nodes() const noexcept { return nodes_; }
    /// Input index of each triangle in leaf order (what a leaf's [index, index + count) refers to).
    [[nodiscard]] std::span<const std::uint32_t> triangle_ids() const noexcept { return ids_; }

    /// One node of the wide tree: the boxes of up to wide_lanes children, structure of arrays (box[k] holds the
    /// minimum, box[3 + k] the maximum on axis k, one lane per child). A lane with count > 0 is a leaf,
    /// triangles [index, index + count) in leaf order; count == 0 is an inner node (wide_nodes()[index]), or an
    /// unused lane, whose box is empty (+inf, -inf), so that no ray enters it.
    static constexpr unsigned wide_lanes = AAF_EXAMPLES_BVH_LANES;  ///< children per wide node
    static_assert(wide_lanes % 4 == 0 && wide_lanes <= 32, "AAF_EXAMPLES_BVH_LANES: a multiple of 4 up to 32");
    struct alignas(64) wide_node {
        std::array<std::array<float, wide_lanes>, 6> box;
        std::array<std::uint32_t, wide_lanes> index;
        std::array<std::uint32_t, wide_lanes> count;
    };
    static_assert(sizeof(wide_node) == 32 * wide_lanes);
    /// The wide tree the nearest-hit and any-hit queries traverse; its root is wide_nodes()[0].
    [[nodiscard]] std::span<const wide_node> wide_nodes() const noexcept { return wide_; }

private:
    struct triangle_vertices { glm::vec3 p0, p1, p2; };
    struct traversal_ray { watertight_ray w; glm::vec3 inv_dir; std::array<bool, 3> negative; };
    enum class query { nearest, farthest, any };
    class builder;

    static bool prepare(const glm::vec3& origin, const glm::vec3& direction, traversal_ray& r) noexcept;
    static bool overlaps(const bvh_node& n, const traversal_ray& r, float t_lo, float t_hi, float& t_in, float& t_out) noexcept;
    template <query Q>
    bool traverse(const traversal_ray& r, float t_lo, float t_hi, triangle_hit& best, std::uint32_t& slot,
                  std::uint32_t start = 0) const noexcept;
    /// As traverse<Q> over the whole tree, through the wide nodes (nearest and any only).
    template <query Q>
    bool traverse_wide(const traversal_ray& r, float t_lo, float t_hi, triangle_hit& best, std::uint32_t& slot) const noexcept;
    /// The box tests of a wide node's lanes: bit i of the result is set when lane i overlaps (t_lo, t_hi)
    /// under the same conservative test as overlaps(); t_in[i] is its entry distance.
    static unsigned overlaps_wide(const wide_node& n, const traversal_ray& r, float t_lo, float t_hi, float* t_in) noexcept;
    /// Builds wide_ from nodes_: the binary node `b` becomes a wide node whose lanes are its descendants (the
    /// inner child with the largest surface opened until there are wide_lanes). Returns its index in wide_.
    std::uint32_t collapse(std::uint32_t b);
    struct span_entry { std::uint32_t node; float t_in, t_out; };
    static constexpr unsigned deferred_capacity = 8;  ///< subtrees set aside by occluder_span's first pass (more: searched at once)

    std::vector<bvh_node> nodes_;
    std::vector<wide_node> wide_;          // the same tree, wide_lanes-wide
    std::vector<triangle_vertices> tris_;  // leaf order
    std::vector<std::uint32_t> ids_;       // leaf order -> input triangle index
    std::size_t dropped_ = 0;
    unsigned depth_ = 0;
};

// ---------------------------------------------------------------------------------------------------------
// Build: binned SAH over triangle centroids, depth-first. While a build thread is spare, the right half of
// a large split is built on it into its own node array and spliced in after the left half: the same
// layout as the serial build, so the result does not depend on `threads`.

class bvh::builder {
public:
    static constexpr int bins = 32;

    std::span<const glm::vec3> lo, hi, centroid;  // per kept triangle
    std::span<std::uint32_t> order;               // permuted in place; leaves are ranges of it
    unsigned max_leaf = 4;
    std::atomic<unsigned>* spare_threads = nullptr;  // threads that may still be started

    /// Builds the subtree over order[begin, end) into nodes[slot]; `deepest` grows to its deepest leaf.
    void build(std::vector<bvh_node>& nodes, std::uint32_t slot, std::uint32_t begin, std::uint32_t end,
               unsigned depth, unsigned& deepest) const {
        glm::vec3 blo(std::numeric_limits<float>::infinity()), bhi(-blo), clo(blo), chi(-blo);
        for (std::uint32_t i = begin; i < end; ++i) {
            const std::uint32_t p = order[i];
            blo = glm::min(blo, lo[p]), bhi = glm::max(bhi, hi[p]);
            clo = glm::min(clo, centroid[p]), chi = glm::max(chi, centroid[p]);
        }
        nodes[slot].lo = blo, nodes[slot].hi = bhi;
        const std::uint32_t count = end - begin;
        // Past this depth only median splits (which halve the count) still reach leaves by max_depth.
        const unsigned levels_left = static_cast<unsigned>(std::bit_width((count + max_leaf - 1) / max_leaf - 1));
        const bool median_only = depth + 1 + levels_left > max_depth;
        const split s = median_only ? split{} : best_split(begin, end, clo, chi, half_area(blo, bhi));
        if (count <= max_leaf && (s.axis < 0 || s.cost >= static_cast<float>(count))) {
            nodes[slot].index = begin, nodes[slot].count = count;
            deepest = std::max(deepest, depth);
            return;
        }
        std::uint32_t mid = begin;
        if (s.axis >= 0) {
            const binning b(clo[s.axis], chi[s.axis]);
            mid = static_cast<std::uint32_t>(
                std::partition(order.begin() + begin, order.begin() + end,
                               [&](std::uint32_t p) { return b(centroid[p][s.axis]) < s.bin; }) - order.begin());
        }
        if (mid == begin || mid == end) {  // no SAH split: object median on the widest centroid axis
            const glm::vec3 ext = chi - clo;
            const int axis = ext.x >= ext.y && ext.x >= ext.z ? 0 : (ext.y >= ext.z ? 1 : 2);
            mid = begin + count / 2;
            std::nth_element(order.begin() + begin, order.begin() + mid, order.begin() + end,
                             [&](std::uint32_t p, std::uint32_t q) { return centroid[p][axis] < centroid[q][axis]; });
        }
        const auto left = static_cast<std::uint32_t>(nodes.size());
        nodes.resize(nodes.size() + 2);
        nodes[slot].index = left, nodes[slot].count = 0;
        if (count < 4096 || !take_thread()) {
            build(nodes, left, begin, mid, depth + 1, deepest);
            build(nodes, left + 1, mid, end, depth + 1, deepest);
            return;
        }
        std::vector<bvh_node> right(1);
        unsigned right_deepest = 0;
        std::exception_ptr error;
        std::thread worker([&] {
            try {
                right.reserve(2 * static_cast<std::size_t>(end - mid));
                build(right, 0, mid, end, depth + 1, right_deepest);
            } catch (...) {
                error = std::current_exception();
            }
            spare_threads->fetch_add(1);  // another split may use it while this one waits for its left half
        });
        try {
            build(nodes, left, begin, mid, depth + 1, deepest);
        } catch (...) {
            worker.join();
            throw;
        }
        worker.join();
        if (error) std::rethrow_exception(error);
        // Splice: right[0] -> nodes[left + 1], right[i >= 1] -> nodes[base + i - 1].
        const auto base = static_cast<std::uint32_t>(nodes.size());
        for (bvh_node& n : right)
            if (n.count == 0) n.index += base - 1;
        nodes[left + 1] = right[0];
        nodes.insert(nodes.end(), right.begin() + 1, right.end());
        deepest = std::max(deepest, right_deepest);
    }

private:
    struct split {
        int axis = -1, bin = 0;  // left = bins [0, bin)
        float cost = std::numeric_limits<float>::infinity();
    };
    /// Maps a centroid coordinate to its bin; the same function bins and partitions.
    struct binning {
        float base, scale;
        binning(float c_lo, float c_hi) : base(c_lo), scale(static_cast<float>(bins) / (c_hi - c_lo)) {}
        int operator()(float c) const noexcept { return std::min(bins - 1, static_cast<int>((c - base) * scale)); }
    };
    bool take_thread() const noexcept {
        unsigned n = spare_threads->load();
        while (n > 0 && !spare_threads->compare_exchange_weak(n, n - 1)) {}
        return n > 0;
    }
    static float half_area(const glm::vec3& a, const glm::vec3& b) noexcept {
        const glm::vec3 d = b - a;
        return d.x * d.y + d.y * d.z + d.z * d.x;
    }

    /// The cheapest bin boundary on any axis, as SAH cost in triangle tests (a box pair costs one).
    split best_split(std::uint32_t begin, std::uint32_t end, const glm::vec3& clo, const glm::vec3& chi,
                     float parent_area) const {
        split best;
        const float inv_area = parent_area > 0.0f ? 1.0f / parent_area : 1.0f;
        for (int axis = 0; axis < 3; ++axis) {
            const float extent = chi[axis] - clo[axis];
            if (!(extent > 0.0f) || !std::isfinite(static_cast<float>(bins) / extent)) continue;
            const binning b(clo[axis], chi[axis]);
            struct bin_data {
                glm::vec3 lo{std::numeric_limits<float>::infinity()}, hi{-std::numeric_limits<float>::infinity()};
                std::uint32_t count = 0;
            };
            std::array<bin_data, bins> data{};
            for (std::uint32_t i = begin; i < end; ++i) {
                const std::uint32_t p = order[i];
                bin_data& d = data[static_cast<std::size_t>(b(centroid[p][axis]))];
                d.lo = glm::min(d.lo, lo[p]), d.hi = glm::max(d.hi, hi[p]), ++d.count;
            }
            std::array<float, bins> right_cost{};  // area * count of bins [k, bins)
            bin_data acc;
            for (int k = bins - 1; k > 0; --k) {
                const bin_data& d = data[static_cast<std::size_t>(k)];
                acc.lo = glm::min(acc.lo, d.lo), acc.hi = glm::max(acc.hi, d.hi), acc.count += d.count;
                right_cost[static_cast<std::size_t>(k)] = acc.count ? half_area(acc.lo, acc.hi) * static_cast<float>(acc.count) : -1.0f;
            }
            acc = {};
            for (int k = 1; k < bins; ++k) {
                const bin_data& d = data[static_cast<std::size_t>(k - 1)];
                acc.lo = glm::min(acc.lo, d.lo), acc.hi = glm::max(acc.hi, d.hi), acc.count += d.count;
                const float right = right_cost[static_cast<std::size_t>(k)];
                if (acc.count == 0 || right < 0.0f) continue;
                const float cost = 1.0f + (half_area(acc.lo, acc.hi) * static_cast<float>(acc.count) + right) * inv_area;
                if (cost < best.cost) best = {axis, k, cost};
            }
        }
        return best;
    }
};

inline bvh::bvh(std::span<const glm::vec3> vertices, std::span<const glm::uvec3> triangles, const bvh_build_options& options) {
    const std::string where = "aaf_examples::bvh: ";
    if (triangles.empty()) throw std::invalid_argument(where + "the mesh has no triangles");
    if (triangles.size() >= std::numeric_limits<std::uint32_t>::max())
        throw std::invalid_argument(where + "too many triangles (" + std::to_string(triangles.size()) + ")");
    if (options.max_leaf_size < 1 || options.max_leaf_size > 16)
        throw std::invalid_argument(where + "max_leaf_size is " + std::to_string(options.max_leaf_size) + ", not in 1..16");
    std::vector<glm::vec3> lo, hi, centroid;
    lo.reserve(triangles.size()), hi.reserve(triangles.size()), centroid.reserve(triangles.size());
    tris_.reserve(triangles.size()), ids_.reserve(triangles.size());
    for (std::size_t i = 0; i < triangles.size(); ++i) {
        for (int k = 0; k < 3; ++k)
            if (triangles[i][k] >= vertices.size())
                throw std::invalid_argument(where + "triangle " + std::to_string(i) + " uses vertex " +
                                            std::to_string(triangles[i][k]) + " but there are only " +
                                            std::to_string(vertices.size()) + " vertices");
        const glm::vec3 &p0 = vertices[triangles[i].x], &p1 = vertices[triangles[i].y], &p2 = vertices[triangles[i].z];
        if (!usable_triangle(p0, p1, p2)) {
            ++dropped_;
            continue;
        }
        tris_.push_back({p0, p1, p2});
        ids_.push_back(static_cast<std::uint32_t>(i));
        lo.push_back(glm::min(p0, glm::min(p1, p2)));
        hi.push_back(glm::max(p0, glm::max(p1, p2)));
        centroid.push_back(0.5f * (lo.back() + hi.back()));  // box centre: the split is on boxes anyway
    }
    if (tris_.empty())
        throw std::invalid_argument(where + "none of the " + std::to_string(triangles.size()) +
                                    " triangles is usable (all have zero area or a non-finite vertex)");

    std::vector<std::uint32_t> order(tris_.size());
    for (std::uint32_t i = 0; i < order.size(); ++i) order[i] = i;
    builder b;
    b.lo = lo, b.hi = hi, b.centroid = centroid, b.order = order;
    b.max_leaf = options.max_leaf_size;
    std::atomic<unsigned> spare_threads(std::max(1u, options.threads) - 1);
    b.spare_threads = &spare_threads;
    nodes_.reserve(2 * tris_.size());
    nodes_.resize(1);
    b.build(nodes_, 0, 0, static_cast<std::uint32_t>(order.size()), 0, depth_);
    nodes_.shrink_to_fit();
    wide_.reserve(nodes_.size() / (wide_lanes - 1) + 1);
    collapse(0);
    wide_.shrink_to_fit();

    std::vector<triangle_vertices> tris(tris_.size());  // into leaf order
    std::vector<std::uint32_t> ids(ids_.size());
    for (std::size_t i = 0; i < order.size(); ++i) tris[i] = tris_[order[i]], ids[i] = ids_[order[i]];
    tris_ = std::move(tris), ids_ = std::move(ids);
}

// ---------------------------------------------------------------------------------------------------------
// Queries.

inline bool bvh::prepare(const glm::vec3& origin, const glm::vec3& direction, traversal_ray& r) noexcept {
    for (int k = 0; k < 3; ++k)
        if (!std::isfinite(origin[k]) || !std::isfinite(direction[k])) return false;
    if (direction == glm::vec3(0.0f)) return false;
    r.w = make_watertight_ray(origin, direction);
    r.inv_dir = 1.0f / direction;  // ±inf for a zero component: see overlaps()
    for (int k = 0; k < 3; ++k) r.negative[static_cast<std::size_t>(k)] = std::signbit(direction[k]);
    return true;
}

#if defined(__GNUC__)
[[gnu::always_inline]]  // called three times per visited node: the call costs as much as the test
#endif
inline bool bvh::overlaps(const bvh_node& n, const traversal_ray& r, float t_lo, float t_hi, float& t_in, float& t_out) noexcept {
    constexpr float eps = 0.5f * std::numeric_limits<float>::epsilon();
    constexpr float robust = 1.0f + 2.0f * (3.0f * eps / (1.0f - 3.0f * eps));  // 1 + 2γ₃ (Ize 2013)
    // Slabs: near and far plane per axis from the direction's sign. For a zero component the distances are
    // ±inf, or NaN when the origin lies on the plane; the comparisons below ignore NaN, so a ray in a
    // box face's plane counts as inside the (closed) box.
    t_in = t_lo, t_out = t_hi;
    for (int k = 0; k < 3; ++k) {
        const bool neg = r.negative[static_cast<std::size_t>(k)];
        const float t_near = ((neg ? n.hi[k] : n.lo[k]) - r.w.origin[k]) * r.inv_dir[k];
        const float t_far = ((neg ? n.lo[k] : n.hi[k]) - r.w.origin[k]) * r.inv_dir[k];
        t_in = t_near > t_in ? t_near : t_in;
        t_out = t_far < t_out ? t_far : t_out;
    }
    t_out *= robust;
    return t_in <= t_out;
}

/// nearest: hits in (t_lo, t_hi), t_hi shrinks to each hit, near child first, stops when the stack's
/// entries all start beyond t_hi. farthest: t_lo grows to each hit, child with the later exit first.
/// any: returns at the first hit. Returns whether anything was hit; `best`/`slot` hold the answer.
/// Searches the subtree of node `start` (the whole tree by default).
template <bvh::query Q>
bool bvh::traverse(const traversal_ray& r, float t_lo, float t_hi, triangle_hit& best, std::uint32_t& slot,
                   std::uint32_t start) const noexcept {
    struct entry { std::uint32_t node; float key; };  // key: entry (nearest) or exit (farthest) distance
    std::array<entry, max_depth + 1> stack;  // one push per level at most
    unsigned top = 0;
    bool found = false;
    float t_in = 0, t_out = 0;
    if (!overlaps(nodes_[start], r, t_lo, t_hi, t_in, t_out)) return false;
    std::uint32_t current = start;
    for (;;) {
        const bvh_node& n = nodes_[current];
        if (n.count != 0) {
            for (std::uint32_t i = n.index; i < n.index + n.count; ++i) {
                const triangle_vertices& tri = tris_[i];
                if (!intersect_triangle(r.w, tri.p0, tri.p1, tri.p2, t_lo, t_hi, best)) continue;
                slot = i, found = true;
                if constexpr (Q == query::any) return true;
                else if constexpr (Q == query::nearest) t_hi = best.t;
                else t_lo = best.t;
            }
        } else {
            float in0, out0, in1, out1;
            const bool hit0 = overlaps(nodes_[n.index], r, t_lo, t_hi, in0, out0);
            const bool hit1 = overlaps(nodes_[n.index + 1], r, t_lo, t_hi, in1, out1);
            if (hit0 && hit1) {
                const bool second_first = Q == query::farthest ? out1 > out0 : in1 < in0;
                stack[top++] = second_first ? entry{n.index, Q == query::farthest ? out0 : in0}
                                            : entry{n.index + 1, Q == query::farthest ? out1 : in1};
                current = second_first ? n.index + 1 : n.index;
                continue;
            }
            if (hit0 || hit1) {
                current = hit0 ? n.index : n.index + 1;
                continue;
            }
        }
        for (;;) {  // pop the next node that can still change the answer
            if (top == 0) return found;
            const entry e = stack[--top];
            constexpr float eps = 0.5f * std::numeric_limits<float>::epsilon();
            constexpr float robust = 1.0f + 2.0f * (3.0f * eps / (1.0f - 3.0f * eps));
            if (Q == query::nearest ? e.key <= t_hi * robust : Q == query::farthest ? e.key >= t_lo : true) {
                current = e.node;
                break;
            }
        }
    }
}

inline std::uint32_t bvh::collapse(std::uint32_t b) {
    const auto w = static_cast<std::uint32_t>(wide_.size());
    wide_node& fresh = wide_.emplace_back();
    for (int k = 0; k < 3; ++k) fresh.box[static_cast<std::size_t>(k)].fill(std::numeric_limits<float>::infinity());
    for (int k = 3; k < 6; ++k) fresh.box[static_cast<std::size_t>(k)].fill(-std::numeric_limits<float>::infinity());
    fresh.index.fill(0), fresh.count.fill(0);
    std::array<std::uint32_t, wide_lanes> lanes{};
    unsigned n = 0;
    if (nodes_[b].count != 0) {  // a tree that is one leaf
        lanes[n++] = b;
    } else {
        lanes[n++] = nodes_[b].index, lanes[n++] = nodes_[b].index + 1;
        while (n < wide_lanes) {  // open the inner lane with the largest surface: the one most rays would enter
            int pick = -1;
            float largest = -1.0f;
            for (unsigned i = 0; i < n; ++i) {
                const bvh_node& c = nodes_[lanes[i]];
                const glm::vec3 d = c.hi - c.lo;
                const float area = d.x * d.y + d.y * d.z + d.z * d.x;
                if (c.count == 0 && area > largest) largest = area, pick = static_cast<int>(i);
            }
            if (pick < 0) break;
            const std::uint32_t opened = lanes[static_cast<std::size_t>(pick)];
            lanes[static_cast<std::size_t>(pick)] = nodes_[opened].index;
            lanes[n++] = nodes_[opened].index + 1;
        }
    }
    for (unsigned i = 0; i < n; ++i) {
        const bvh_node& c = nodes_[lanes[i]];
        for (int k = 0; k < 3; ++k) {
            wide_[w].box[static_cast<std::size_t>(k)][i] = c.lo[k];
            wide_[w].box[static_cast<std::size_t>(3 + k)][i] = c.hi[k];
        }
        if (c.count != 0) {
            wide_[w].index[i] = c.index, wide_[w].count[i] = c.count;
        } else {
            const std::uint32_t child = collapse(lanes[i]);  // may reallocate wide_: index afterwards
            wide_[w].index[i] = child;
        }
    }
    return w;
}

#if defined(__GNUC__)
[[gnu::always_inline]]
#endif
inline unsigned bvh::overlaps_wide(const wide_node& n, const traversal_ray& r, float t_lo, float t_hi, float* t_in) noexcept {
    constexpr float eps = 0.5f * std::numeric_limits<float>::epsilon();
    constexpr float robust = 1.0f + 2.0f * (3.0f * eps / (1.0f - 3.0f * eps));  // as in overlaps()
    // The same operations as overlaps(), lane by lane: (plane - origin) * inv_dir, rounded alike; a NaN
    // distance (origin in the plane of a zero direction component) leaves the running value unchanged.
#if defined(AAF_EXAMPLES_BVH_SSE)
    unsigned mask = 0;
    for (unsigned first = 0; first < wide_lanes; first += 4) {  // four lanes per SSE register
        __m128 in = _mm_set1_ps(t_lo), out = _mm_set1_ps(t_hi);
        for (int k = 0; k < 3; ++k) {
            const bool neg = r.negative[static_cast<std::size_t>(k)];
            const __m128 o = _mm_set1_ps(r.w.origin[k]), inv = _mm_set1_ps(r.inv_dir[k]);
            const __m128 lo = _mm_load_ps(n.box[static_cast<std::size_t>(k)].data() + first);
            const __m128 hi = _mm_load_ps(n.box[static_cast<std::size_t>(3 + k)].data() + first);
            const __m128 t_near = _mm_mul_ps(_mm_sub_ps(neg ? hi : lo, o), inv);
            const __m128 t_far = _mm_mul_ps(_mm_sub_ps(neg ? lo : hi, o), inv);
            in = _mm_max_ps(t_near, in);  // maxps returns its second operand when either is NaN
            out = _mm_min_ps(t_far, out);
        }
        out = _mm_mul_ps(out, _mm_set1_ps(robust));
        _mm_storeu_ps(t_in + first, in);
        mask |= static_cast<unsigned>(_mm_movemask_ps(_mm_cmple_ps(in, out))) << first;
    }
    return mask;
#else
    unsigned mask = 0;
    for (unsigned i = 0; i < wide_lanes; ++i) {
        float a = t_lo, b = t_hi;
        for (int k = 0; k < 3; ++k) {
            const bool neg = r.negative[static_cast<std::size_t>(k)];
            const float lo = n.box[static_cast<std::size_t>(k)][i], hi = n.box[static_cast<std::size_t>(3 + k)][i];
            const float t_near = ((neg ? hi : lo) - r.w.origin[k]) * r.inv_dir[k];
            const float t_far = ((neg ? lo : hi) - r.w.origin[k]) * r.inv_dir[k];
            a = t_near > a ? t_near : a;
            b = t_far < b ? t_far : b;
        }
        t_in[i] = a;
        if (a <= b * robust) mask |= 1u << i;
    }
    return mask;
#endif
}

template <bvh::query Q>
bool bvh::traverse_wide(const traversal_ray& r, float t_lo, float t_hi, triangle_hit& best, std::uint32_t& slot) const noexcept {
    static_assert(Q == query::nearest || Q == query::any, "the farthest-hit search walks the binary tree");
    constexpr float eps = 0.5f * std::numeric_limits<float>::epsilon();
    constexpr float robust = 1.0f + 2.0f * (3.0f * eps / (1.0f - 3.0f * eps));
    struct entry { std::uint32_t node; float t_in; };
    std::array<entry, (wide_lanes - 1) * (max_depth + 1)> stack;  // at most wide_lanes - 1 pushes per level
    unsigned top = 0;
    bool found = false;
    std::uint32_t current = 0;
    for (;;) {
        const wide_node& n = wide_[current];
        alignas(32) float t_in[wide_lanes];
        unsigned mask = overlaps_wide(n, r, t_lo, t_hi, t_in);
#if defined(AAF_EXAMPLES_BVH_SSE)
        // Ask for what the lanes hit now: the loads of triangles and nodes, not arithmetic, bound the traversal.
        for (unsigned m = mask; m != 0; m &= m - 1) {
            const auto lane = static_cast<unsigned>(std::countr_zero(m));
            const char* p = n.count[lane] != 0 ? reinterpret_cast<const char*>(&tris_[n.index[lane]])
                                               : reinterpret_cast<const char*>(&wide_[n.index[lane]]);
            for (unsigned line = 0; line < (n.count[lane] != 0 ? 2u : sizeof(wide_node) / 64); ++line)
                _mm_prefetch(p + 64 * line, _MM_HINT_T0);
        }
#endif
        // The lanes hit, nearest entry first (insertion sort of at most wide_lanes).
        std::array<unsigned, wide_lanes> order;
        unsigned hits = 0;
        for (; mask != 0; mask &= mask - 1) {
            const auto lane = static_cast<unsigned>(std::countr_zero(mask));
            unsigned j = hits++;
            for (; j > 0 && t_in[order[j - 1]] > t_in[lane]; --j) order[j] = order[j - 1];
            order[j] = lane;
        }
        // Leaves now, in order (each hit shrinks t_hi for the lanes after it); inner lanes onto the stack,
        // farthest first, the nearest one visited next.
        std::array<entry, wide_lanes> inner;
        unsigned n_inner = 0;
        for (unsigned j = 0; j < hits; ++j) {
            const unsigned lane = order[j];
            if (Q == query::nearest && !(t_in[lane] <= t_hi * robust)) break;  // so are the lanes after it
            if (n.count[lane] == 0) {
                inner[n_inner++] = {n.index[lane], t_in[lane]};
                continue;
            }
            for (std::uint32_t i = n.index[lane]; i < n.index[lane] + n.count[lane]; ++i) {
                const triangle_vertices& tri = tris_[i];
                if (!intersect_triangle(r.w, tri.p0, tri.p1, tri.p2, t_lo, t_hi, best)) continue;
                slot = i, found = true;
                if constexpr (Q == query::any) return true;
                else t_hi = best.t;
            }
        }
        if (n_inner > 0) {
            for (unsigned j = n_inner - 1; j > 0; --j) stack[top++] = inner[j];
            if (Q == query::any || inner[0].t_in <= t_hi * robust) {
                current = inner[0].node;
                continue;
            }
        }
        for (;;) {  // pop the next node that can still change the answer
            if (top == 0) return found;
            const entry e = stack[--top];
            if (Q == query::any || e.t_in <= t_hi * robust) {
                current = e.node;
                break;
            }
        }
    }
}

inline ray_hit bvh::nearest_hit(const glm::vec3& origin, const glm::vec3& direction, float t_max) const noexcept {
    ray_hit out;
    traversal_ray r;
    triangle_hit h;
    std::uint32_t slot = 0;
    if (!prepare(origin, direction, r) || !traverse_wide<query::nearest>(r, 0.0f, t_max, h, slot)) return out;
    const triangle_vertices& tri = tris_[slot];
    out.t = h.t, out.triangle = ids_[slot], out.barycentrics = {h.b1, h.b2};
    out.normal = glm::vec3(glm::normalize(glm::cross(glm::dvec3(tri.p1 - tri.p0), glm::dvec3(tri.p2 - tri.p0))));
    return out;
}

inline aaf::occluder_span<float> bvh::occluder_span(const aaf::shadow_segment<float>& s) const noexcept {
    traversal_ray r;
    if (!prepare(s.origin, s.direction, r) || std::isnan(s.length)) return {std::numeric_limits<float>::quiet_NaN(), 0.0f};
    constexpr float eps = 0.5f * std::numeric_limits<float>::epsilon();
    constexpr float robust = 1.0f + 2.0f * (3.0f * eps / (1.0f - 3.0f * eps));  // as in overlaps()
    const float length = s.length;
    float t_min = std::numeric_limits<float>::infinity(), t_max = -std::numeric_limits<float>::infinity();
    // Pass 1 is the nearest-hit traversal (the same nodes in the same order, near child first), except that
    // every hit in (0, length) also raises t_max, and a subtree it prunes because it starts beyond t_min is
    // set aside (deferred) when it may still end beyond t_max. Pass 2 searches only the deferred subtrees for
    // the farthest hit, largest exit first, instead of the whole tree again. A deferred subtree holds no hit
    // below t_min (the pruning test is the nearest query's own, conservative one), so the two passes see
    // every hit that can be the nearest or the farthest.
    std::array<span_entry, deferred_capacity> deferred;
    unsigned n_deferred = 0;
    const auto defer = [&](std::uint32_t node, float t_in, float t_out) noexcept {
        if (!(t_out >= t_max)) return;  // t_max only grows: nothing in there can be the farthest
        if (n_deferred < deferred_capacity) {
            deferred[n_deferred++] = {node, t_in, t_out};
        } else {  // no room (rare): search it now, as pass 2 would later
            triangle_hit h;
            std::uint32_t slot = 0;
            if (traverse<query::farthest>(r, t_max, length, h, slot, node)) t_max = h.t;
        }
    };
    std::array<span_entry, max_depth + 1> stack;  // one push per level at most
    unsigned top = 0;
    float t_in = 0, t_out = 0;
    if (!overlaps(nodes_[0], r, 0.0f, length, t_in, t_out)) return {};
    std::uint32_t current = 0;
    for (bool more = true; more;) {
        const bvh_node& n = nodes_[current];
        if (n.count != 0) {
            for (std::uint32_t i = n.index; i < n.index + n.count; ++i) {
                const triangle_vertices& tri = tris_[i];
                triangle_hit h;
                if (!intersect_triangle(r.w, tri.p0, tri.p1, tri.p2, 0.0f, length, h)) continue;
                t_min = std::min(t_min, h.t), t_max = std::max(t_max, h.t);
            }
        } else {
            float in0, out0, in1, out1;
            bool hit0 = overlaps(nodes_[n.index], r, 0.0f, length, in0, out0);
            bool hit1 = overlaps(nodes_[n.index + 1], r, 0.0f, length, in1, out1);
            // Same as overlaps() with t_hi = t_min: t_in <= min(t_far, t_min) * robust.
            const float limit = t_min * robust;
            if (hit0 && !(in0 <= limit)) defer(n.index, in0, out0), hit0 = false;
            if (hit1 && !(in1 <= limit)) defer(n.index + 1, in1, out1), hit1 = false;
            if (hit0 && hit1) {
                const bool second_first = in1 < in0;
                stack[top++] = second_first ? span_entry{n.index, in0, out0} : span_entry{n.index + 1, in1, out1};
                current = second_first ? n.index + 1 : n.index;
                continue;
            }
            if (hit0 || hit1) {
                current = hit0 ? n.index : n.index + 1;
                continue;
            }
        }
        for (more = false; top > 0;) {  // pop the next node that may hold a nearer hit; defer the others
            const span_entry e = stack[--top];
            if (e.t_in <= t_min * robust) {
                current = e.node, more = true;
                break;
            }
            defer(e.node, e.t_in, e.t_out);
        }
    }
    if (!(t_min <= t_max)) return {};
    // Pass 2: the deferred subtree with the largest exit first, until none can hold a hit beyond t_max; in
    // each, traverse<query::farthest> inlined (hits in (t_max, length), child with the later exit first).
    while (n_deferred > 0) {
        unsigned pick = 0;
        for (unsigned i = 1; i < n_deferred; ++i)
            if (deferred[i].t_out > deferred[pick].t_out) pick = i;
        if (!(deferred[pick].t_out >= t_max)) break;
        current = deferred[pick].node;
        deferred[pick] = deferred[--n_deferred];
        for (bool more = true; more;) {
            const bvh_node& n = nodes_[current];
            if (n.count != 0) {
                for (std::uint32_t i = n.index; i < n.index + n.count; ++i) {
                    const triangle_vertices& tri = tris_[i];
                    triangle_hit h;
                    if (intersect_triangle(r.w, tri.p0, tri.p1, tri.p2, t_max, length, h)) t_max = h.t;
                }
            } else {
                float in0, out0, in1, out1;
                const bool hit0 = overlaps(nodes_[n.index], r, t_max, length, in0, out0);
                const bool hit1 = overlaps(nodes_[n.index + 1], r, t_max, length, in1, out1);
                if (hit0 && hit1) {
                    const bool second_first = out1 > out0;
                    stack[top++] = second_first ? span_entry{n.index, in0, out0} : span_entry{n.index + 1, in1, out1};
                    current = second_first ? n.index + 1 : n.index;
                    continue;
                }
                if (hit0 || hit1) {
                    current = hit0 ? n.index : n.index + 1;
                    continue;
                }
            }
            for (more = false; top > 0;) {
                const span_entry e = stack[--top];
                if (e.t_out >= t_max) {
                    current = e.node, more = true;
                    break;
                }
            }
        }
    }
    return {t_min, t_max};
}

inline float bvh::nearest_occluder(const aaf::shadow_segment<float>& s) const noexcept {
    traversal_ray r;
    if (!prepare(s.origin, s.direction, r) || std::isnan(s.length)) return std::numeric_limits<float>::quiet_NaN();
    triangle_hit h;
    std::uint32_t slot = 0;
    return traverse_wide<query::nearest>(r, 0.0f, s.length, h, slot) ? h.t : aaf::no_occluder<float>;
}

inline bool bvh::occluded(const aaf::shadow_segment<float>& s) const noexcept {
    traversal_ray r;
    triangle_hit h;
    std::uint32_t slot = 0;
    return prepare(s.origin, s.direction, r) && !std::isnan(s.length) && traverse_wide<query::any>(r, 0.0f, s.length, h, slot);
}

}  // namespace aaf_examples
