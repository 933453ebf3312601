// SPDX-License-Identifier: MIT
// The built-in scenes: procedural geometry after the paper's test scenes (FORMULAS.md §1.15), no files.
//
//   lattice    two crossed-bar grids over a plane, one low and one high: the same occluder casts a crisp
//              shadow pattern near the ground and a blurred one higher up (the paper's "Grids").
//   boxes      boxes standing on the ground (contact shadows: the penumbra shrinks to zero at the contact
//              line) and one floating box (a penumbra that is wide everywhere).
//   tentacles  thin tapered tubes rising from the ground and arching over it, so their penumbrae overlap
//              and cross (the paper's "Tentacles").
//
// Every scene: ground plane at y = 0, a downward-facing rectangular light (built as scene.cpp's read_light
// builds {center, size, normal: [0, -1, 0]}), 640×480, one object per logical part (the IDs are guides for
// the filter).
#include <array>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include <glm/geometric.hpp>

#include "common/scene.hpp"

namespace aaf_examples {

namespace {

/// A growing triangle list, turned into one object at the end.
struct mesh_builder {
    std::vector<glm::vec3> vertices;
    std::vector<glm::uvec3> triangles;

    /// An axis-aligned box, outward-facing triangles (the same layout as scene::add_box).
    void box(const glm::vec3& lo, const glm::vec3& hi) {
        const auto base = static_cast<unsigned>(vertices.size());
        for (unsigned i = 0; i < 8; ++i)
            vertices.emplace_back((i & 1) ? hi.x : lo.x, (i & 2) ? hi.y : lo.y, (i & 4) ? hi.z : lo.z);
        // clang-format off
        static constexpr std::array<std::array<unsigned, 3>, 12> faces = {{{0, 4, 6}, {0, 6, 2}, {1, 3, 7}, {1, 7, 5},
                                                                           {0, 1, 5}, {0, 5, 4}, {2, 6, 7}, {2, 7, 3},
                                                                           {0, 2, 3}, {0, 3, 1}, {4, 5, 7}, {4, 7, 6}}};
        // clang-format on
        for (const auto& f : faces) triangles.emplace_back(base + f[0], base + f[1], base + f[2]);
    }
};

/// The light as read_light builds {center, size: [w, h], normal: [0, -1, 0]}: edge_u (length w) along +x,
/// edge_v (length h) along +z, cross(edge_u, edge_v) pointing down.
aaf::area_light<float> downward_light(const glm::vec3& center, float w, float h) {
    aaf::area_light<float> l;
    l.edge_u = {w, 0, 0};
    l.edge_v = {0, 0, h};
    l.corner = center - 0.5f * (l.edge_u + l.edge_v);
    return l;
}

void add_ground(scene& s, float half, float albedo) {
    s.add_object("ground", {{-half, 0, -half}, {half, 0, -half}, {half, 0, half}, {-half, 0, half}},
                 {{0, 2, 1}, {0, 3, 2}}, albedo);
}

/// A square grid of crossed bars at height y: `bars` bars along x and `bars` along z (the z bars resting
/// on the x bars), spanning [x0, x1] × [z0, z1].
void add_lattice(scene& s, std::string name, float x0, float x1, float z0, float z1, float y, int bars, float width,
                 float albedo) {
    mesh_builder m;
    const float t = width;  // square cross-section
    for (int i = 0; i < bars; ++i) {
        const float f = (static_cast<float>(i) + 0.5f) / static_cast<float>(bars);
        const float z = z0 + f * (z1 - z0), x = x0 + f * (x1 - x0);
        m.box({x0, y, z - 0.5f * t}, {x1, y + t, z + 0.5f * t});          // along x
        m.box({x - 0.5f * t, y + t, z0}, {x + 0.5f * t, y + 2 * t, z1});  // along z, on top
    }
    s.add_object(std::move(name), m.vertices, m.triangles, albedo);
}

scene make_lattice() {
    scene s;
    s.name = "lattice";
    add_ground(s, 3.0f, 0.8f);
    // The same grid (pitch 0.25, bars 0.04 wide) at two heights. With the light 3 units up and 0.8 wide the
    // penumbra is ~0.07 under the low grid (the 0.21 gaps stay fully lit: a crisp pattern) and ~0.3 under
    // the high one (wider than a gap: a blurred pattern that never reaches full light), so the filter
    // must be narrow under the left grid and wide under the right one. The light sits behind the grids so
    // their shadows fall in front of them, towards the camera.
    add_lattice(s, "lattice_low", -1.6f, -0.1f, -0.9f, 0.6f, 0.25f, 6, 0.04f, 0.6f);
    add_lattice(s, "lattice_high", 0.1f, 1.6f, -0.9f, 0.6f, 0.8f, 6, 0.04f, 0.6f);
    s.light = downward_light({0, 3, -1.5f}, 0.8f, 0.8f);
    s.view = {{0.2f, 3.4f, 3.2f}, {0.2f, 0.1f, 0.3f}, {0, 1, 0}, 45};
    return s;
}

scene make_boxes() {
    scene s;
    s.name = "boxes";
    add_ground(s, 3.0f, 0.8f);
    // Standing boxes: their shadows start sharp at the contact line and widen with distance from it.
    s.add_box("box_tall", {-1.2f, 0, -0.8f}, {-0.85f, 1.1f, -0.45f}, 0.6f);
    s.add_box("box_wide", {-0.3f, 0, -0.9f}, {0.6f, 0.3f, -0.5f}, 0.6f);
    s.add_box("box_cube", {0.9f, 0, -0.3f}, {1.35f, 0.45f, 0.15f}, 0.6f);
    s.add_box("box_thin", {-0.9f, 0, 0.2f}, {-0.3f, 0.6f, 0.28f}, 0.6f);  // a thin wall: long, narrow contact
    // Floating: no contact, a penumbra of about one width all around its shadow.
    s.add_box("box_floating", {0.3f, 0.5f, 0.35f}, {0.75f, 0.65f, 0.8f}, 0.6f);
    s.light = downward_light({-0.6f, 3, -1.4f}, 1.0f, 1.0f);
    s.view = {{0.2f, 2.4f, 3.4f}, {0.1f, 0.2f, 0}, {0, 1, 0}, 42};
    return s;
}

/// The point of the cubic Bézier curve p0..p3 at parameter u.
glm::vec3 bezier(const std::array<glm::vec3, 4>& p, float u) {
    const float v = 1 - u;
    return v * v * v * p[0] + 3 * v * v * u * p[1] + 3 * v * u * u * p[2] + u * u * u * p[3];
}

/// A tube of radius r0 at the start tapering to r1 at the end around the curve, with rotation-minimising
/// frames (no twist), `rings` rings of `sides` vertices and a fan cap at the end. Returns nothing; appends.
void tube(mesh_builder& m, const std::array<glm::vec3, 4>& curve, float r0, float r1, int rings, int sides) {
    const auto base = static_cast<unsigned>(m.vertices.size());
    std::vector<glm::vec3> centres(static_cast<std::size_t>(rings) + 1);
    for (int i = 0; i <= rings; ++i)
        centres[static_cast<std::size_t>(i)] = bezier(curve, static_cast<float>(i) / rings);
    glm::vec3 tangent = glm::normalize(centres[1] - centres[0]);
    glm::vec3 normal =
        glm::normalize(glm::cross(tangent, std::abs(tangent.x) < 0.9f ? glm::vec3(1, 0, 0) : glm::vec3(0, 0, 1)));
    for (int i = 0; i <= rings; ++i) {
        const auto ui = static_cast<std::size_t>(i);
        const glm::vec3 next_tangent =
            glm::normalize(i < rings ? centres[ui + 1] - centres[ui] : centres[ui] - centres[ui - 1]);
        // Parallel transport: remove from the normal its component along the new tangent.
        normal = glm::normalize(normal - glm::dot(normal, next_tangent) * next_tangent);
        tangent = next_tangent;
        const glm::vec3 binormal = glm::cross(tangent, normal);
        const float f = static_cast<float>(i) / static_cast<float>(rings);
        const float r = r0 + (r1 - r0) * f;
        for (int k = 0; k < sides; ++k) {
            const float a = 2 * std::numbers::pi_v<float> * static_cast<float>(k) / static_cast<float>(sides);
            m.vertices.push_back(centres[ui] + r * (std::cos(a) * normal + std::sin(a) * binormal));
        }
    }
    const auto s = static_cast<unsigned>(sides);
    for (unsigned i = 0; i < static_cast<unsigned>(rings); ++i)
        for (unsigned k = 0; k < s; ++k) {
            const unsigned a = base + i * s + k, b = base + i * s + (k + 1) % s;
            m.triangles.emplace_back(a, b + s, b);
            m.triangles.emplace_back(a, a + s, b + s);
        }
    const auto tip = static_cast<unsigned>(m.vertices.size());
    m.vertices.push_back(centres.back() + r1 * tangent);  // a rounded-looking point closes the end
    const unsigned last = base + static_cast<unsigned>(rings) * s;
    for (unsigned k = 0; k < s; ++k) m.triangles.emplace_back(last + k, last + (k + 1) % s, tip);
}

scene make_tentacles() {
    scene s;
    s.name = "tentacles";
    add_ground(s, 3.0f, 0.8f);
    // Seven tubes (radius 0.045 tapering to 0.02, ~2 % of the 2.4-unit cluster) rooted on a circle, each
    // rising and arching over the middle and coming down near the ground on the far side, so their shadows
    // cross there: sharp where a tube is low, soft where it is high, overlapping penumbrae in between.
    constexpr int count = 7;
    for (int i = 0; i < count; ++i) {
        const float a = 2 * std::numbers::pi_v<float> * (static_cast<float>(i) + 0.3f) / count;
        const glm::vec3 out(std::cos(a), 0, std::sin(a));
        const glm::vec3 side(-out.z, 0, out.x);
        const float height = 0.45f + 0.15f * static_cast<float>(i % 3);  // 0.45, 0.6, 0.75
        const float lean = 0.3f * static_cast<float>((i % 2) * 2 - 1);   // alternately left and right
        const float tip_y = 0.06f + 0.12f * static_cast<float>((i + 1) % 3);
        const std::array<glm::vec3, 4> curve = {
            1.1f * out + glm::vec3(0, -0.02f, 0),                       // root, just below the ground
            1.1f * out + glm::vec3(0, 1.3f * height, 0),                // straight up
            0.2f * out + lean * side + glm::vec3(0, 1.3f * height, 0),  // over the middle
            -0.7f * out + 2 * lean * side + glm::vec3(0, tip_y, 0)};    // tip, near the ground
        mesh_builder m;
        tube(m, curve, 0.045f, 0.02f, 96, 12);
        s.add_object("tentacle_" + std::to_string(i), m.vertices, m.triangles, 0.65f);
    }
    s.light = downward_light({0.5f, 3, -1.0f}, 0.5f, 0.5f);
    s.view = {{0, 2.6f, 3.2f}, {0, 0.2f, 0.1f}, {0, 1, 0}, 45};
    return s;
}

struct builtin {
    const char* name;
    scene (*make)();
};
constexpr std::array<builtin, 3> builtins = {
    {{"lattice", make_lattice}, {"boxes", make_boxes}, {"tentacles", make_tentacles}}};

}  // namespace

std::vector<std::string> builtin_scene_names() {
    std::vector<std::string> names;
    for (const builtin& b : builtins) names.emplace_back(b.name);
    return names;
}

scene builtin_scene(std::string_view name) {
    for (const builtin& b : builtins)
        if (name == b.name) {
            scene s = b.make();
            s.width = 640, s.height = 480;
            s.validate();
            return s;
        }
    std::string known;
    for (const builtin& b : builtins) known += (known.empty() ? "" : ", ") + std::string(b.name);
    throw scene_error("no built-in scene '" + std::string(name) + "'; known: " + known);
}

}  // namespace aaf_examples
