// SPDX-License-Identifier: MIT
// The examples' BVH (examples/common/bvh.hpp) against brute force: every query on thousands of random rays
// and segments per mesh, over the meshes in assets/meshes and synthetic ones (one triangle, a cube, a soup
// of 10k random triangles, degenerate input, pathological splits), the watertightness of shared edges and
// vertices, the tree's invariants, determinism across build threads, input validation and mesh loading.
//
// The brute-force reference loops over every input triangle with the same watertight test
// (aaf_examples::intersect_triangle), so distances must agree EXACTLY; only ties (equal t) may name a
// different triangle.

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <tuple>
#include <utility>
#include <vector>

#include <glm/vector_relational.hpp>

#include <aaf/tracer.hpp>

#include "common/bvh.hpp"
#include "common/mesh_io.hpp"

using aaf_examples::bvh;
using aaf_examples::bvh_build_options;
using aaf_examples::triangle_mesh;

static_assert(aaf::span_tracer<bvh>);
static_assert(aaf::nearest_tracer<bvh>);
static_assert(aaf::boolean_tracer<bvh>);
static_assert(aaf::occlusion_tracer<bvh>);

namespace {

using vec3 = glm::vec3;
constexpr float inf = std::numeric_limits<float>::infinity();

std::string asset(const char* name) { return std::string(AAF_SOURCE_DIR) + "/assets/meshes/" + name; }

/// One test ray: a shadow segment {origin, direction (unit), length}; the primary ray uses
/// `primary_scale * direction` (non-unit on some rays) and t_max = length on odd rays, +inf otherwise.
struct test_ray {
    vec3 origin, direction;
    float length, primary_scale;
    bool primary_limited;
};

struct hit_record {
    float t;
    std::uint32_t id;
    aaf_examples::triangle_hit hit;
};

/// Brute force: every usable input triangle, the same watertight test, all hits in (0, inf), input order.
void all_hits(const triangle_mesh& m, const vec3& origin, const vec3& direction, std::vector<hit_record>& out) {
    out.clear();
    const aaf_examples::watertight_ray r = aaf_examples::make_watertight_ray(origin, direction);
    for (std::uint32_t i = 0; i < m.triangles.size(); ++i) {
        const glm::uvec3 t = m.triangles[i];
        const vec3 &p0 = m.vertices[t.x], &p1 = m.vertices[t.y], &p2 = m.vertices[t.z];
        if (!aaf_examples::usable_triangle(p0, p1, p2)) continue;
        aaf_examples::triangle_hit h;
        if (aaf_examples::intersect_triangle(r, p0, p1, p2, 0.0f, inf, h)) out.push_back({h.t, i, h});
    }
}

/// Random rays in and around the mesh's bounding box (enlarged by half its size): a quarter uniform on
/// the sphere from random origins, a quarter also with short segments, a quarter aimed at random points
/// of random triangles and a quarter aimed exactly at vertices and edge midpoints.
std::vector<test_ray> make_rays(const triangle_mesh& m, std::size_t n, std::uint32_t seed) {
    vec3 lo(inf), hi(-inf);
    for (const glm::uvec3& t : m.triangles)
        for (int k = 0; k < 3; ++k)
            if (std::isfinite(m.vertices[t[k]].x + m.vertices[t[k]].y + m.vertices[t[k]].z))
                lo = glm::min(lo, m.vertices[t[k]]), hi = glm::max(hi, m.vertices[t[k]]);
    const vec3 ext = glm::max(hi - lo, vec3(1e-3f * glm::length(hi - lo)));
    const float diag = glm::length(ext);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u01(0.0f, 1.0f);
    std::uniform_int_distribution<std::size_t> pick(0, m.triangles.size() - 1);
    std::vector<test_ray> rays;
    while (rays.size() < n) {
        const std::size_t kind = rays.size() % 4;
        const vec3 origin = lo - 0.25f * ext + vec3(u01(rng), u01(rng), u01(rng)) * 1.5f * ext;
        vec3 target, d;
        if (kind < 2) {
            const float z = 2.0f * u01(rng) - 1.0f, phi = 6.2831853f * u01(rng), s = std::sqrt(std::max(0.0f, 1.0f - z * z));
            d = glm::normalize(vec3(s * std::cos(phi), s * std::sin(phi), z));
            target = origin + diag * d;
        } else {
            const glm::uvec3 t = m.triangles[pick(rng)];
            const vec3 &a = m.vertices[t.x], &b = m.vertices[t.y], &c = m.vertices[t.z];
            if (kind == 2) {
                float b1 = u01(rng), b2 = u01(rng);
                if (b1 + b2 > 1.0f) b1 = 1.0f - b1, b2 = 1.0f - b2;
                target = (1.0f - b1 - b2) * a + b1 * b + b2 * c;
            } else {
                const int which = static_cast<int>(rays.size() / 4 % 6);
                target = which < 3 ? m.vertices[t[which]] : 0.5f * (m.vertices[t[which - 3]] + m.vertices[t[(which - 2) % 3]]);
            }
        }
        if (kind >= 2) {
            if (!std::isfinite(target.x + target.y + target.z) || target == origin) continue;
            d = glm::normalize(target - origin);
        }
        const float dist = kind < 2 ? diag : glm::length(target - origin);
        const float length = kind == 1 ? 0.1f * diag * u01(rng) : dist * (0.5f + u01(rng));
        const float scale = rays.size() % 3 == 0 ? std::exp2(8.0f * u01(rng) - 4.0f) : 1.0f;
        rays.push_back({origin, d, length, scale, rays.size() % 2 == 1});
    }
    return rays;
}

struct agreement {
    std::size_t rays = 0, primary_hits = 0, segment_hits = 0, span_extents = 0, ties = 0;
    std::vector<std::string> mismatches;  // the first few, with the ray
    void add(const agreement& o) {
        rays += o.rays, primary_hits += o.primary_hits, segment_hits += o.segment_hits, span_extents += o.span_extents;
        ties += o.ties;
        for (const std::string& s : o.mismatches)
            if (mismatches.size() < 10) mismatches.push_back(s);
    }
};

std::string describe(const test_ray& r, const char* what, double got, double expected) {
    char buf[400];
    std::snprintf(buf, sizeof buf, "%s: got %.9g expected %.9g for origin (%.9g, %.9g, %.9g) direction (%.9g, %.9g, %.9g) length %.9g",
                  what, got, expected, static_cast<double>(r.origin.x), static_cast<double>(r.origin.y),
                  static_cast<double>(r.origin.z), static_cast<double>(r.direction.x), static_cast<double>(r.direction.y),
                  static_cast<double>(r.direction.z), static_cast<double>(r.length));
    return buf;
}

/// Every query of `b` against brute force on `rays`, split over two threads (Catch2 asserts afterwards).
agreement compare(const bvh& b, const triangle_mesh& m, const std::vector<test_ray>& rays) {
    const auto run = [&](std::size_t first, std::size_t last, agreement& out) {
        std::vector<hit_record> hits;
        const auto fail = [&](const test_ray& r, const char* what, double got, double expected) {
            if (out.mismatches.size() < 10) out.mismatches.push_back(describe(r, what, got, expected));
        };
        for (std::size_t i = first; i < last; ++i) {
            const test_ray& r = rays[i];
            ++out.rays;
            // Primary ray: nearest in (0, t_max), possibly with a non-unit direction.
            const vec3 pd = r.primary_scale * r.direction;
            const float t_max = r.primary_limited ? r.length : inf;
            all_hits(m, r.origin, pd, hits);
            const hit_record* ref = nullptr;
            for (const hit_record& h : hits)
                if (h.t < t_max && (ref == nullptr || h.t < ref->t)) ref = &h;
            const aaf_examples::ray_hit got = b.nearest_hit(r.origin, pd, t_max);
            if (ref == nullptr) {
                if (got.hit()) fail(r, "nearest_hit found a triangle where brute force has none", got.t, inf);
            } else if (!got.hit() || got.t != ref->t) {
                fail(r, "nearest_hit t", got.t, ref->t);
            } else {
                ++out.primary_hits;
                const auto same = std::find_if(hits.begin(), hits.end(), [&](const hit_record& h) { return h.id == got.triangle; });
                if (same == hits.end() || same->t != got.t) fail(r, "nearest_hit triangle (not hit at that t)", got.triangle, ref->id);
                else {
                    if (got.triangle != ref->id) ++out.ties;
                    if (got.barycentrics != glm::vec2(same->hit.b1, same->hit.b2)) fail(r, "nearest_hit barycentrics", got.barycentrics.x, same->hit.b1);
                    const glm::uvec3 t = m.triangles[got.triangle];
                    const vec3 n(glm::normalize(glm::cross(glm::dvec3(m.vertices[t.y] - m.vertices[t.x]),
                                                           glm::dvec3(m.vertices[t.z] - m.vertices[t.x]))));
                    if (std::abs(glm::length(got.normal) - 1.0f) > 1e-5f || glm::dot(got.normal, n) < 0.9999f)
                        fail(r, "nearest_hit normal . reference", glm::dot(got.normal, n), 1.0);
                }
            }
            // Shadow segment: nearest and farthest in (0, length), any hit.
            if (r.primary_scale != 1.0f) all_hits(m, r.origin, r.direction, hits);
            float nearest = inf, farthest = -inf;
            for (const hit_record& h : hits)
                if (h.t < r.length) nearest = std::min(nearest, h.t), farthest = std::max(farthest, h.t);
            const aaf::shadow_segment<float> s{r.origin, r.direction, r.length};
            const aaf::occluder_span<float> span = b.occluder_span(s);
            const float near = b.nearest_occluder(s);
            const bool any = b.occluded(s);
            if (nearest <= farthest) ++out.segment_hits;
            if (nearest < farthest) ++out.span_extents;
            if (span.nearest != nearest || span.farthest != farthest) {
                fail(r, "occluder_span.nearest", span.nearest, nearest);
                fail(r, "occluder_span.farthest", span.farthest, farthest);
            }
            if (near != nearest) fail(r, "nearest_occluder", near, nearest);
            if (any != (nearest <= farthest)) fail(r, "occluded", any, nearest <= farthest);
        }
    };
    agreement a, c;
    std::thread second(run, rays.size() / 2, rays.size(), std::ref(c));
    run(0, rays.size() / 2, a);
    second.join();
    a.add(c);
    return a;
}

/// The tree's invariants: every node reached once, children after their parent and inside its bounds,
/// leaves within the size limit and bounding their triangles, every kept triangle in exactly one leaf.
void check_structure(const bvh& b, const triangle_mesh& m, unsigned max_leaf) {
    const auto nodes = b.nodes();
    const auto ids = b.triangle_ids();
    REQUIRE(b.triangle_count() + b.dropped_triangles() == m.triangles.size());
    REQUIRE(ids.size() == b.triangle_count());
    REQUIRE(b.depth() <= bvh::max_depth);
    std::vector<int> node_seen(nodes.size(), 0), slot_seen(ids.size(), 0);
    std::vector<std::pair<std::uint32_t, unsigned>> stack{{0u, 0u}};
    unsigned deepest = 0;
    bool ok = true;
    while (!stack.empty() && ok) {
        const auto [i, depth] = stack.back();
        stack.pop_back();
        const aaf_examples::bvh_node& n = nodes[i];
        ok = ++node_seen[i] == 1;
        if (n.count == 0) {
            ok = ok && n.index > i && n.index + 1 < nodes.size();
            for (std::uint32_t c = n.index; ok && c <= n.index + 1; ++c) {
                ok = glm::all(glm::lessThanEqual(n.lo, nodes[c].lo)) && glm::all(glm::lessThanEqual(nodes[c].hi, n.hi));
                stack.push_back({c, depth + 1});
            }
        } else {
            deepest = std::max(deepest, depth);
            ok = ok && n.count <= max_leaf && n.index + n.count <= ids.size();
            for (std::uint32_t s = n.index; ok && s < n.index + n.count; ++s) {
                ok = ++slot_seen[s] == 1;
                for (int k = 0; k < 3 && ok; ++k) {
                    const vec3 p = m.vertices[m.triangles[ids[s]][k]];
                    ok = glm::all(glm::lessThanEqual(n.lo, p)) && glm::all(glm::lessThanEqual(p, n.hi));
                }
            }
        }
    }
    REQUIRE(ok);
    REQUIRE(std::count(node_seen.begin(), node_seen.end(), 1) == static_cast<std::ptrdiff_t>(nodes.size()));
    REQUIRE(std::count(slot_seen.begin(), slot_seen.end(), 1) == static_cast<std::ptrdiff_t>(ids.size()));
    REQUIRE(std::set<std::uint32_t>(ids.begin(), ids.end()).size() == ids.size());
    REQUIRE(deepest == b.depth());

    // The wide tree the nearest and any-hit queries walk: every wide node reached once, its used lanes inside
    // nothing but real boxes and its unused lanes empty, the leaves exactly the binary tree's (each triangle
    // slot once, inside its lane's box).
    const auto wide = b.wide_nodes();
    std::vector<int> wide_seen(wide.size(), 0), wide_slot_seen(ids.size(), 0);
    std::vector<std::uint32_t> wide_stack{0u};
    while (!wide_stack.empty() && ok) {
        const bvh::wide_node& w = wide[wide_stack.back()];
        ok = ++wide_seen[wide_stack.back()] == 1;
        wide_stack.pop_back();
        for (unsigned lane = 0; lane < bvh::wide_lanes && ok; ++lane) {
            const vec3 lo(w.box[0][lane], w.box[1][lane], w.box[2][lane]), hi(w.box[3][lane], w.box[4][lane], w.box[5][lane]);
            if (lo.x > hi.x) {  // unused lane: empty box, no children
                ok = w.count[lane] == 0 && w.index[lane] == 0 && glm::all(glm::greaterThan(lo, hi));
                continue;
            }
            if (w.count[lane] == 0) {
                ok = w.index[lane] > 0 && w.index[lane] < wide.size();
                if (ok) wide_stack.push_back(w.index[lane]);
                continue;
            }
            ok = w.count[lane] <= max_leaf && w.index[lane] + w.count[lane] <= ids.size();
            for (std::uint32_t s = w.index[lane]; ok && s < w.index[lane] + w.count[lane]; ++s) {
                ok = ++wide_slot_seen[s] == 1;
                for (int k = 0; k < 3 && ok; ++k) {
                    const vec3 p = m.vertices[m.triangles[ids[s]][k]];
                    ok = glm::all(glm::lessThanEqual(lo, p)) && glm::all(glm::lessThanEqual(p, hi));
                }
            }
        }
    }
    REQUIRE(ok);
    REQUIRE(std::count(wide_seen.begin(), wide_seen.end(), 1) == static_cast<std::ptrdiff_t>(wide.size()));
    REQUIRE(std::count(wide_slot_seen.begin(), wide_slot_seen.end(), 1) == static_cast<std::ptrdiff_t>(ids.size()));
}

/// Builds, checks the structure and compares `n_rays` random rays with brute force.
agreement check_mesh(const triangle_mesh& m, std::size_t n_rays, std::uint32_t seed, bvh_build_options options = {}) {
    const bvh b(m.vertices, m.triangles, options);
    check_structure(b, m, options.max_leaf_size);
    const agreement a = compare(b, m, make_rays(m, n_rays, seed));
    INFO(a.rays << " rays: " << a.primary_hits << " primary hits (" << a.ties << " ties on another triangle), "
                << a.segment_hits << " occluded segments, " << a.span_extents << " with farthest > nearest");
    for (const std::string& s : a.mismatches) UNSCOPED_INFO(s);
    CHECK(a.mismatches.empty());
    std::printf("bvh vs brute force: %zu triangles, %zu rays, %zu primary hits, %zu ties, %zu occluded segments, "
                "%zu spans, %zu mismatches\n",
                m.triangles.size(), a.rays, a.primary_hits, a.ties, a.segment_hits, a.span_extents, a.mismatches.size());
    return a;
}

triangle_mesh cube(float h = 1.0f) {
    triangle_mesh m;
    for (int i = 0; i < 8; ++i) m.vertices.push_back({i & 1 ? h : -h, i & 2 ? h : -h, i & 4 ? h : -h});
    m.triangles = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                   {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
    return m;
}

/// An icosahedron subdivided `levels` times onto the unit sphere, vertices shared (a closed mesh).
triangle_mesh icosphere(int levels) {
    const float p = 1.6180340f;
    triangle_mesh m;
    for (const vec3 v : {vec3(-1, p, 0), vec3(1, p, 0), vec3(-1, -p, 0), vec3(1, -p, 0), vec3(0, -1, p), vec3(0, 1, p),
                         vec3(0, -1, -p), vec3(0, 1, -p), vec3(p, 0, -1), vec3(p, 0, 1), vec3(-p, 0, -1), vec3(-p, 0, 1)})
        m.vertices.push_back(glm::normalize(v));
    m.triangles = {{0, 11, 5}, {0, 5, 1}, {0, 1, 7}, {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                   {3, 9, 4}, {3, 4, 2}, {3, 2, 6}, {3, 6, 8}, {3, 8, 9}, {4, 9, 5}, {2, 4, 11}, {6, 2, 10}, {8, 6, 7}, {9, 8, 1}};
    for (int l = 0; l < levels; ++l) {
        std::map<std::pair<unsigned, unsigned>, unsigned> midpoints;
        const auto mid = [&](unsigned a, unsigned b) {
            const auto key = std::minmax(a, b);
            const auto [it, fresh] = midpoints.try_emplace({key.first, key.second}, static_cast<unsigned>(m.vertices.size()));
            if (fresh) m.vertices.push_back(glm::normalize(m.vertices[a] + m.vertices[b]));
            return it->second;
        };
        std::vector<glm::uvec3> next;
        for (const glm::uvec3 t : m.triangles) {
            const unsigned a = mid(t.x, t.y), b = mid(t.y, t.z), c = mid(t.z, t.x);
            next.insert(next.end(), {{t.x, a, c}, {t.y, b, a}, {t.z, c, b}, {a, b, c}});
        }
        m.triangles = std::move(next);
    }
    return m;
}

/// The closed box [0, n]³, each face an n×n grid of unit squares cut into two triangles (alternating
/// diagonals): integer vertices, so grid points, edge midpoints and diagonal points are exact floats.
triangle_mesh grid_box(unsigned n) {
    triangle_mesh m;
    std::map<std::tuple<unsigned, unsigned, unsigned>, unsigned> index;
    const auto vertex = [&](unsigned x, unsigned y, unsigned z) {
        const auto [it, fresh] = index.try_emplace({x, y, z}, static_cast<unsigned>(m.vertices.size()));
        if (fresh) m.vertices.push_back(vec3(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z)));
        return it->second;
    };
    for (unsigned axis = 0; axis < 3; ++axis)
        for (unsigned side = 0; side < 2; ++side)
            for (unsigned i = 0; i < n; ++i)
                for (unsigned j = 0; j < n; ++j) {
                    const auto at = [&](unsigned a, unsigned b) {
                        glm::uvec3 p;
                        p[static_cast<int>(axis)] = side * n, p[static_cast<int>((axis + 1) % 3)] = a, p[static_cast<int>((axis + 2) % 3)] = b;
                        return vertex(p.x, p.y, p.z);
                    };
                    const unsigned q00 = at(i, j), q10 = at(i + 1, j), q01 = at(i, j + 1), q11 = at(i + 1, j + 1);
                    if ((i + j) % 2 == 0) m.triangles.insert(m.triangles.end(), {{q00, q10, q11}, {q00, q11, q01}});
                    else m.triangles.insert(m.triangles.end(), {{q00, q10, q01}, {q10, q11, q01}});
                }
    return m;
}

/// 10k small random triangles in [-1.05, 1.05]³ (a dense soup: rays cross many separate subtrees).
triangle_mesh random_soup(std::uint32_t seed) {
    triangle_mesh m;
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    for (unsigned i = 0; i < 10000; ++i) {
        const vec3 c(u(rng), u(rng), u(rng));
        for (int k = 0; k < 3; ++k) m.vertices.push_back(c + 0.05f * vec3(u(rng), u(rng), u(rng)));
        m.triangles.push_back({3 * i, 3 * i + 1, 3 * i + 2});
    }
    return m;
}

}  // namespace

// -------------------------------------------------------------------------------------------------------------
// The repository's meshes.

TEST_CASE("bvh matches brute force on the Stanford bunny", "[bvh][mesh]") {
    const triangle_mesh m = aaf_examples::load_triangles(asset("bun_zipper.ply"));
    REQUIRE(m.triangles.size() == 69451);
    const agreement a = check_mesh(m, 1500, 1);
    CHECK(a.primary_hits > 500);
    CHECK(a.span_extents > 200);
}

TEST_CASE("bvh matches brute force on the plant (thin fronds), also with one triangle per leaf", "[bvh][mesh]") {
    const triangle_mesh m = aaf_examples::load_triangles(asset("plant.obj"));
    REQUIRE(m.triangles.size() == 14370);
    CHECK(check_mesh(m, 3000, 2).primary_hits > 500);
    check_mesh(m, 1000, 3, {1, 2});
}

TEST_CASE("bvh matches brute force on the bench (thin parallel slats), also with 8 triangles per leaf", "[bvh][mesh]") {
    const triangle_mesh m = aaf_examples::load_triangles(asset("bench.obj"));  // bench.mtl's texture is absent
    REQUIRE(m.triangles.size() == 2516);
    CHECK(check_mesh(m, 4000, 4).primary_hits > 1000);
    check_mesh(m, 2000, 5, {8, 1});
}

TEST_CASE("bvh matches brute force on the window blinds and the Cornell box", "[bvh][mesh]") {
    const triangle_mesh blinds = aaf_examples::load_triangles(asset("window-blinds.obj"));
    REQUIRE(blinds.triangles.size() == 1252);
    CHECK(check_mesh(blinds, 4000, 6).primary_hits > 1000);
    const triangle_mesh box = aaf_examples::load_triangles(asset("CornellBox-Original.obj"));
    REQUIRE(box.triangles.size() == 36);
    CHECK(check_mesh(box, 4000, 7).primary_hits > 2000);  // a closed room: most rays hit
}

TEST_CASE("the build does not depend on the number of build threads", "[bvh][determinism]") {
    const triangle_mesh m = aaf_examples::load_triangles(asset("bun_zipper.ply"));
    const bvh one(m.vertices, m.triangles, {4, 1}), two(m.vertices, m.triangles, {4, 2}), four(m.vertices, m.triangles, {4, 4});
    for (const bvh* other : {&two, &four}) {
        REQUIRE(other->nodes().size() == one.nodes().size());
        CHECK(std::equal(one.nodes().begin(), one.nodes().end(), other->nodes().begin(), [](const auto& a, const auto& b) {
            return a.lo == b.lo && a.hi == b.hi && a.index == b.index && a.count == b.count;
        }));
        CHECK(std::equal(one.triangle_ids().begin(), one.triangle_ids().end(), other->triangle_ids().begin()));
    }
    check_structure(four, m, 4);
}

// -------------------------------------------------------------------------------------------------------------
// Synthetic meshes.

TEST_CASE("bvh matches brute force on a single triangle", "[bvh][synthetic]") {
    triangle_mesh m;
    m.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    m.triangles = {{0, 1, 2}};
    CHECK(check_mesh(m, 2000, 8).primary_hits > 200);
    const bvh b(m.vertices, m.triangles);
    const aaf_examples::ray_hit h = b.nearest_hit({0.25f, 0.5f, 2.0f}, {0, 0, -0.5f});  // non-unit direction
    REQUIRE(h.hit());
    CHECK(h.t == 4.0f);
    CHECK(h.triangle == 0);
    CHECK(h.barycentrics.x == Approx(0.25f));
    CHECK(h.barycentrics.y == Approx(0.5f));
    CHECK(h.normal == vec3(0, 0, 1));
    CHECK_FALSE(b.nearest_hit({0.25f, 0.5f, 2.0f}, {0, 0, -0.5f}, 4.0f).hit());  // t_max is exclusive
    CHECK_FALSE(b.nearest_hit({0.25f, 0.5f, 2.0f}, {0, 0, 0.5f}).hit());         // behind the origin
}

TEST_CASE("bvh on a cube: axis-aligned rays through vertices, edges and faces, origins on the face planes", "[bvh][synthetic]") {
    const triangle_mesh m = cube();
    CHECK(check_mesh(m, 4000, 9).primary_hits > 1000);
    const bvh b(m.vertices, m.triangles);
    std::vector<test_ray> rays;
    const float coords[] = {-1.5f, -1.0f, -0.5f, 0.0f, 0.5f, 1.0f, 1.5f};
    for (int axis = 0; axis < 3; ++axis)
        for (const float sign : {-1.0f, 1.0f})
            for (const float x : coords)
                for (const float y : coords)
                    for (const float start : {-3.0f, -1.0f, 0.0f}) {  // outside, on the face plane, inside
                        vec3 o, d(0);
                        o[axis] = sign * start, o[(axis + 1) % 3] = x, o[(axis + 2) % 3] = y;
                        d[axis] = sign;  // from the start side across the cube
                        rays.push_back({o, d, 8.0f, 1.0f, false});
                        if (std::abs(x) <= 1.0f && std::abs(y) <= 1.0f && start == -3.0f) {
                            // Through the closed cube, also along its edges: enters at 2, leaves at 4.
                            const aaf::occluder_span<float> s = b.occluder_span({o, d, 8.0f});
                            CHECK(s.nearest == 2.0f);
                            CHECK(s.farthest == 4.0f);
                        }
                    }
    const agreement a = compare(b, m, rays);
    for (const std::string& s : a.mismatches) UNSCOPED_INFO(s);
    CHECK(a.mismatches.empty());
}

TEST_CASE("bvh matches brute force on 10k random triangles", "[bvh][synthetic]") {
    const agreement a = check_mesh(random_soup(10), 2000, 11);
    CHECK(a.primary_hits > 600);
    CHECK(a.span_extents > 300);
}

TEST_CASE("degenerate and non-finite triangles are dropped and counted; the rest still matches", "[bvh][synthetic]") {
    triangle_mesh m = grid_box(4);  // 192 good triangles
    const auto v = [&](vec3 p) { m.vertices.push_back(p); return static_cast<unsigned>(m.vertices.size() - 1); };
    const unsigned a = v({0.5f, 0.5f, 0.5f}), b = v({1.5f, 1.5f, 1.5f}), c = v({2.5f, 2.5f, 2.5f});
    const unsigned nan = v({std::nanf(""), 1, 1}), infinite = v({inf, 1, 1});
    m.triangles.insert(m.triangles.end(), {{a, a, b}, {a, b, b}, {a, a, a}, {a, b, c}, {a, b, nan}, {infinite, a, b}});
    // A sliver: non-zero area, kept.
    const unsigned s0 = v({0.5f, 1.0f, 1.0f}), s1 = v({3.5f, 1.0f, 1.0f}), s2 = v({2.0f, 1.0f + 1e-6f, 1.0f});
    m.triangles.push_back({s0, s1, s2});
    const bvh tree(m.vertices, m.triangles);
    CHECK(tree.dropped_triangles() == 6);
    CHECK(tree.triangle_count() == 193);
    CHECK(check_mesh(m, 3000, 12).mismatches.empty());
}

TEST_CASE("pathological inputs keep the tree within its depth bound", "[bvh][synthetic]") {
    triangle_mesh same, spread;
    for (unsigned i = 0; i < 3000; ++i) {  // 3000 copies of one triangle: no SAH split exists
        same.vertices.insert(same.vertices.end(), {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}});
        same.triangles.push_back({3 * i, 3 * i + 1, 3 * i + 2});
    }
    for (unsigned i = 0; i < 3000; ++i) {  // exponentially spread: the SAH peels off a few at a time
        const float x = std::exp2(static_cast<float>(i) / 50.0f), s = 1e-3f * x;
        spread.vertices.insert(spread.vertices.end(), {{x, 0, 0}, {x + s, 0, 0}, {x, s, s}});
        spread.triangles.push_back({3 * i, 3 * i + 1, 3 * i + 2});
    }
    for (const unsigned leaf : {1u, 4u}) {
        const bvh a(same.vertices, same.triangles, {leaf, 2}), b(spread.vertices, spread.triangles, {leaf, 2});
        CHECK(a.depth() <= bvh::max_depth);
        CHECK(b.depth() <= bvh::max_depth);
        check_structure(a, same, leaf);
        check_structure(b, spread, leaf);
    }
    CHECK(check_mesh(same, 300, 13, {1, 2}).mismatches.empty());
    CHECK(check_mesh(spread, 2000, 14, {1, 2}).mismatches.empty());
}

// -------------------------------------------------------------------------------------------------------------
// Watertightness: rays exactly through shared edges and vertices never slip through.

TEST_CASE("watertight: rays through every shared edge midpoint and vertex of an icosphere hit", "[bvh][watertight]") {
    const triangle_mesh m = icosphere(3);  // 1280 triangles, 642 vertices
    const bvh b(m.vertices, m.triangles);
    std::set<std::pair<unsigned, unsigned>> edges;
    for (const glm::uvec3 t : m.triangles)
        for (int k = 0; k < 3; ++k) edges.insert(std::minmax(t[k], t[(k + 1) % 3]));
    REQUIRE(edges.size() == 1920);
    std::vector<vec3> targets(m.vertices);
    for (const auto& [a, c] : edges) targets.push_back(0.5f * (m.vertices[a] + m.vertices[c]));
    std::size_t misses = 0, checked = 0;
    std::vector<test_ray> rays;
    for (const vec3& p : targets)
        for (const float distance : {3.0f, 1.7f, 25.0f}) {
            const vec3 origin = distance * p;  // outside, on the line through the centre and the target
            const vec3 d = glm::normalize(-origin);
            const float to_centre = glm::length(origin);
            ++checked;
            const aaf::occluder_span<float> s = b.occluder_span({origin, d, 2.0f * to_centre});
            if (!b.nearest_hit(origin, d).hit() || !b.occluded({origin, d, to_centre}) || !(s.nearest < s.farthest)) ++misses;
            if (!b.nearest_hit(vec3(0), -d).hit()) ++misses;  // and from the centre outwards
            rays.push_back({origin, d, 2.0f * to_centre, 1.0f, false});
        }
    CHECK(checked == 3 * (642 + 1920));
    CHECK(misses == 0);
    const agreement a = compare(b, m, rays);
    for (const std::string& s : a.mismatches) UNSCOPED_INFO(s);
    CHECK(a.mismatches.empty());
}

TEST_CASE("watertight: axis-aligned rays exactly through grid vertices, edges and diagonals of a closed box hit", "[bvh][watertight]") {
    const unsigned n = 8;
    const triangle_mesh m = grid_box(n);
    const bvh b(m.vertices, m.triangles);
    std::size_t rays = 0, bad = 0;
    for (int axis = 0; axis < 3; ++axis)
        for (const float sign : {1.0f, -1.0f})
            for (unsigned i = 0; i <= 4 * n; ++i)
                for (unsigned j = 0; j <= 4 * n; ++j) {  // quarter steps: vertices, edge midpoints, diagonals
                    vec3 o, d(0);
                    o[axis] = sign > 0 ? -5.0f : static_cast<float>(n) + 5.0f;
                    o[(axis + 1) % 3] = 0.25f * static_cast<float>(i), o[(axis + 2) % 3] = 0.25f * static_cast<float>(j);
                    d[axis] = sign;
                    ++rays;
                    const aaf::occluder_span<float> s = b.occluder_span({o, d, 100.0f});
                    const aaf_examples::ray_hit h = b.nearest_hit(o, d);
                    if (s.nearest != 5.0f || s.farthest != 5.0f + static_cast<float>(n) || !h.hit() || h.t != 5.0f ||
                        !b.occluded({o, d, 5.5f}) || b.occluded({o, d, 5.0f}))
                        ++bad;
                }
    CHECK(rays == 6 * 33 * 33);
    CHECK(bad == 0);
}

// -------------------------------------------------------------------------------------------------------------
// The tracer contract's edges, aaf adapters, input validation, mesh loading.

TEST_CASE("bvh follows the tracer contract at its edges", "[bvh][contract]") {
    const triangle_mesh m = cube();
    const bvh b(m.vertices, m.triangles);
    const vec3 o(0, 0, -3), d(0, 0, 1);
    CHECK_FALSE(b.occluder_span({o, d, 2.0f}).hit());  // the hit at t = 2 is not inside (0, 2)
    CHECK(b.nearest_occluder({o, d, 2.0f}) == aaf::no_occluder<float>);
    CHECK_FALSE(b.occluded({o, d, 2.0f}));
    CHECK(b.occluded({o, d, 2.0001f}));
    CHECK_FALSE(b.occluded({o, d, 0.0f}));
    CHECK_FALSE(b.occluder_span({o, d, -1.0f}).hit());
    CHECK(b.occluder_span({vec3(0, 0, -1), d, 10.0f}).nearest == 2.0f);  // origin on a face: t = 0 does not count
    const float nan = std::nanf("");
    for (const aaf::shadow_segment<float>& bad : {aaf::shadow_segment<float>{vec3(nan, 0, 0), d, 1.0f},
                                                 aaf::shadow_segment<float>{o, vec3(0), 1.0f},
                                                 aaf::shadow_segment<float>{o, vec3(0, inf, 0), 1.0f},
                                                 aaf::shadow_segment<float>{o, d, nan}}) {
        CHECK(std::isnan(b.occluder_span(bad).nearest));
        CHECK(std::isnan(b.nearest_occluder(bad)));
        CHECK_FALSE(b.occluded(bad));
    }
    CHECK_FALSE(b.nearest_hit(o, vec3(0)).hit());
    // Through aaf's adapter for boolean tracers: the bisected distance brackets the true one.
    const aaf::bisecting_tracer<bvh> bisect{&b, 12};
    const aaf::occluder_span<float> s = bisect.occluder_span(aaf::shadow_segment<float>{o, d, 8.0f});
    CHECK(std::abs(s.nearest - 2.0f) <= 8.0f / 4096.0f);
}

namespace {

/// occluder_span, nearest_occluder and occluded against brute force on segments that start strictly inside the
/// mesh's bounds and end exactly at one of the ray's hits or one float before it, for the nearest, the
/// farthest and a middle hit: the open interval (0, length) must drop a hit at t == length, and every
/// other hit before it must count. Segments ending one float AFTER a hit are only checked for agreement
/// between the three queries: the traversal clips boxes at length (scaled by the slab test's 1 + 2γ₃), and a
/// triangle's t can round a few ulps below its box's computed entry, so a hit within a few ulps of length
/// can be missed by all of them (a known limitation, counted in `late_misses`). Returns the number of
/// segments compared; mismatches go to `mismatches`.
std::size_t check_segment_ends(const bvh& b, const triangle_mesh& m, std::size_t n_rays, std::uint32_t seed,
                               std::vector<std::string>& mismatches, std::size_t& late_misses) {
    vec3 lo(inf), hi(-inf);
    for (const glm::uvec3& t : m.triangles)
        for (int k = 0; k < 3; ++k) lo = glm::min(lo, m.vertices[t[k]]), hi = glm::max(hi, m.vertices[t[k]]);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u01(0.0f, 1.0f);
    std::uniform_int_distribution<std::size_t> pick(0, m.triangles.size() - 1);
    std::vector<hit_record> hits;
    std::size_t segments = 0;
    for (std::size_t i = 0; i < n_rays; ++i) {
        const vec3 origin = lo + (0.05f + 0.9f * vec3(u01(rng), u01(rng), u01(rng))) * (hi - lo);
        vec3 d;
        if (i % 2 == 0) {  // at a random point of a random triangle (so most rays hit)
            const glm::uvec3 t = m.triangles[pick(rng)];
            float b1 = u01(rng), b2 = u01(rng);
            if (b1 + b2 > 1.0f) b1 = 1.0f - b1, b2 = 1.0f - b2;
            const vec3 target = (1.0f - b1 - b2) * m.vertices[t.x] + b1 * m.vertices[t.y] + b2 * m.vertices[t.z];
            if (target == origin) continue;
            d = glm::normalize(target - origin);
        } else {
            const float z = 2.0f * u01(rng) - 1.0f, phi = 6.2831853f * u01(rng), s = std::sqrt(std::max(0.0f, 1.0f - z * z));
            d = vec3(s * std::cos(phi), s * std::sin(phi), z);
        }
        all_hits(m, origin, d, hits);
        if (hits.empty()) continue;
        std::vector<float> ts;
        for (const hit_record& h : hits) ts.push_back(h.t);
        std::sort(ts.begin(), ts.end());
        for (const float end : {ts.front(), ts[ts.size() / 2], ts.back()})
            for (const float length : {end, std::nextafter(end, 0.0f), std::nextafter(end, inf)}) {
                float nearest = inf, farthest = -inf;
                for (const float t : ts)
                    if (t < length) nearest = std::min(nearest, t), farthest = std::max(farthest, t);
                const aaf::shadow_segment<float> seg{origin, d, length};
                const aaf::occluder_span<float> span = b.occluder_span(seg);
                const test_ray r{origin, d, length, 1.0f, false};
                ++segments;
                if (length > end) {  // one float after a hit: the three queries agree with each other
                    const bool same = span.nearest == b.nearest_occluder(seg) && span.hit() == b.occluded(seg);
                    if (!same && mismatches.size() < 10)
                        mismatches.push_back(describe(r, "occluder_span vs nearest_occluder", span.nearest, b.nearest_occluder(seg)));
                    if (span.nearest != nearest || span.farthest != farthest) ++late_misses;
                    continue;
                }
                if (span.nearest != nearest || span.farthest != farthest) {
                    if (mismatches.size() < 10) mismatches.push_back(describe(r, "occluder_span.nearest", span.nearest, nearest));
                    if (mismatches.size() < 10) mismatches.push_back(describe(r, "occluder_span.farthest", span.farthest, farthest));
                }
                if (b.nearest_occluder(seg) != nearest && mismatches.size() < 10)
                    mismatches.push_back(describe(r, "nearest_occluder", b.nearest_occluder(seg), nearest));
                if (b.occluded(seg) != (nearest <= farthest) && mismatches.size() < 10)
                    mismatches.push_back(describe(r, "occluded", b.occluded(seg), nearest <= farthest));
            }
    }
    return segments;
}

}  // namespace

TEST_CASE("occluder_span: segments from inside the bounds ending exactly at, one float before and after a hit",
          "[bvh][contract]") {
    struct mesh_case { std::string name; triangle_mesh mesh; bvh_build_options options; std::size_t rays; };
    std::vector<mesh_case> cases;
    cases.push_back({"bunny", aaf_examples::load_triangles(asset("bun_zipper.ply")), {}, 200});
    cases.push_back({"plant, 1 per leaf", aaf_examples::load_triangles(asset("plant.obj")), {1, 2}, 600});
    cases.push_back({"bench", aaf_examples::load_triangles(asset("bench.obj")), {}, 1500});
    cases.push_back({"blinds", aaf_examples::load_triangles(asset("window-blinds.obj")), {}, 1500});
    cases.push_back({"Cornell box", aaf_examples::load_triangles(asset("CornellBox-Original.obj")), {}, 1500});
    // A dense soup: rays cross more separate subtrees than occluder_span keeps aside at once.
    cases.push_back({"soup, 1 per leaf", random_soup(12), {1, 2}, 600});
    for (const mesh_case& c : cases) {
        const bvh b(c.mesh.vertices, c.mesh.triangles, c.options);
        std::vector<std::string> mismatches;
        std::size_t late_misses = 0;
        const std::size_t segments = check_segment_ends(b, c.mesh, c.rays, 21, mismatches, late_misses);
        INFO(c.name << ": " << segments << " segments");
        for (const std::string& s : mismatches) UNSCOPED_INFO(s);
        CHECK(segments > 4 * c.rays);  // 9 per ray that hits: the rays aimed at a triangle, and some more
        CHECK(mismatches.empty());
        std::printf("segment ends, %s: %zu segments, %zu mismatches, %zu hits one float before length missed by all "
                    "queries (known)\n", c.name.c_str(), segments, mismatches.size(), late_misses);
    }
}

TEST_CASE("bvh rejects unusable input with a clear message", "[bvh][errors]") {
    const std::vector<vec3> v = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    const auto message = [&](std::vector<glm::uvec3> t, bvh_build_options o = {}) {
        try {
            const bvh b(v, t, o);
        } catch (const std::invalid_argument& e) {
            return std::string(e.what());
        }
        return std::string("no exception");
    };
    CHECK(message({}) == "aaf_examples::bvh: the mesh has no triangles");
    CHECK(message({{0, 1, 2}, {0, 1, 7}}) == "aaf_examples::bvh: triangle 1 uses vertex 7 but there are only 3 vertices");
    CHECK_THAT(message({{0, 0, 1}, {2, 2, 2}}), Catch::Contains("none of the 2 triangles is usable"));
    CHECK_THAT(message({{0, 1, 2}}, {0, 1}), Catch::Contains("max_leaf_size is 0"));
    CHECK_THAT(message({{0, 1, 2}}, {17, 1}), Catch::Contains("max_leaf_size is 17"));
}

TEST_CASE("load_triangles reports a missing or meshless file", "[mesh_io][errors]") {
    const std::string missing = asset("no-such-mesh.obj");
    try {
        (void)aaf_examples::load_triangles(missing);
        FAIL("no exception");
    } catch (const std::runtime_error& e) {
        CHECK_THAT(std::string(e.what()), Catch::StartsWith("cannot load " + missing + ": "));
    }
    CHECK_THROWS_AS(aaf_examples::load_triangles(std::string(AAF_SOURCE_DIR) + "/assets/README.md"), std::runtime_error);
}
