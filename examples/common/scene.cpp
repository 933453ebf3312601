// SPDX-License-Identifier: MIT
#include "common/scene.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <sstream>

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>
#include <glm/trigonometric.hpp>
#include <glm/mat3x3.hpp>
#include <glm/trigonometric.hpp>
#include <nlohmann/json.hpp>

#include "common/mesh_io.hpp"

namespace aaf_examples {

namespace {

using json = nlohmann::json;

/// A number as the user wrote it: 640, 12.5, -3 (not 640.000000).
std::string number_text(float v) {
    std::ostringstream o;
    o << v;
    return o.str();
}

bool finite(const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

/// Reads fields with messages that name the file and the JSON path of the field.
class reader {
public:
    explicit reader(const std::filesystem::path& file) : file_(file) {}

    [[noreturn]] void fail(const std::string& where, const std::string& what) const {
        throw scene_error("scene " + file_.string() + ": " + (where.empty() ? "" : "'" + where + "' ") + what);
    }

    const json& object(const json& parent, const std::string& key, const std::string& where) const {
        if (!parent.contains(key)) fail(where, "is missing");
        const json& v = parent.at(key);
        if (!v.is_object()) fail(where, "must be an object");
        return v;
    }

    float number(const json& parent, const std::string& key, const std::string& where, float fallback,
                 bool required = false) const {
        if (!parent.contains(key)) {
            if (required) fail(where, "is missing");
            return fallback;
        }
        const json& v = parent.at(key);
        if (!v.is_number()) fail(where, "must be a number");
        const double d = v.get<double>();
        if (!std::isfinite(d) || std::abs(d) > static_cast<double>(std::numeric_limits<float>::max()))
            fail(where, "must be a finite number");
        return static_cast<float>(d);
    }

    std::uint32_t count(const json& parent, const std::string& key, const std::string& where, std::uint32_t fallback) const {
        if (!parent.contains(key)) return fallback;
        const json& v = parent.at(key);
        if (!v.is_number_integer() || v.get<std::int64_t>() < 0 || v.get<std::int64_t>() > (1 << 24))
            fail(where, "must be an integer in [0, 16777216]");
        return static_cast<std::uint32_t>(v.get<std::int64_t>());
    }

    glm::vec3 vec3(const json& parent, const std::string& key, const std::string& where, const glm::vec3& fallback,
                   bool required = false) const {
        if (!parent.contains(key)) {
            if (required) fail(where, "is missing");
            return fallback;
        }
        const json& v = parent.at(key);
        if (!v.is_array() || v.size() != 3 || !v[0].is_number() || !v[1].is_number() || !v[2].is_number())
            fail(where, "must be an array of 3 numbers");
        const glm::vec3 out(v[0].get<float>(), v[1].get<float>(), v[2].get<float>());
        if (!finite(out)) fail(where, "must be finite");
        return out;
    }

    std::string string(const json& parent, const std::string& key, const std::string& where, const std::string& fallback,
                       bool required = false) const {
        if (!parent.contains(key)) {
            if (required) fail(where, "is missing");
            return fallback;
        }
        if (!parent.at(key).is_string()) fail(where, "must be a string");
        return parent.at(key).get<std::string>();
    }

    bool boolean(const json& parent, const std::string& key, const std::string& where, bool fallback) const {
        if (!parent.contains(key)) return fallback;
        if (!parent.at(key).is_boolean()) fail(where, "must be true or false");
        return parent.at(key).get<bool>();
    }

    const std::filesystem::path& file() const { return file_; }

private:
    std::filesystem::path file_;
};

glm::mat3 rotation_xyz(const glm::vec3& degrees) {
    const glm::vec3 r = glm::radians(degrees);
    const float cx = std::cos(r.x), sx = std::sin(r.x), cy = std::cos(r.y), sy = std::sin(r.y), cz = std::cos(r.z),
                sz = std::sin(r.z);
    const glm::mat3 rx(1, 0, 0, 0, cx, sx, 0, -sx, cx);  // column-major
    const glm::mat3 ry(cy, 0, -sy, 0, 1, 0, sy, 0, cy);
    const glm::mat3 rz(cz, sz, 0, -sz, cz, 0, 0, 0, 1);
    return rz * ry * rx;  // X first, then Y, then Z
}

/// Builds the light from either {center, size, normal} or {corner, edge_u, edge_v}.
aaf::area_light<float> read_light(const reader& in, const json& light) {
    aaf::area_light<float> l;
    if (light.contains("corner")) {
        l.corner = in.vec3(light, "corner", "light.corner", {}, true);
        l.edge_u = in.vec3(light, "edge_u", "light.edge_u", {}, true);
        l.edge_v = in.vec3(light, "edge_v", "light.edge_v", {}, true);
    } else {
        const glm::vec3 center = in.vec3(light, "center", "light.center", {}, true);
        const json& size = light.contains("size") ? light.at("size") : json();
        if (!size.is_array() || size.size() != 2 || !size[0].is_number() || !size[1].is_number())
            in.fail("light.size", "must be an array of 2 numbers [width, height]");
        const float w = size[0].get<float>(), h = size[1].get<float>();
        glm::vec3 n = in.vec3(light, "normal", "light.normal", {0, -1, 0});
        if (glm::length(n) == 0.0f) in.fail("light.normal", "must not be zero");
        n = glm::normalize(n);
        // Edges with cross(edge_u, edge_v) along n: u = helper × n, v = n × u. With helper = +z, a light
        // facing down has its width along +x and its height along +z, as one would read "size": [w, h].
        const glm::vec3 helper = std::abs(n.z) < 0.9f ? glm::vec3(0, 0, 1) : glm::vec3(0, 1, 0);
        const glm::vec3 u = glm::normalize(glm::cross(helper, n));
        const glm::vec3 v = glm::cross(n, u);
        l.edge_u = u * w;
        l.edge_v = v * h;
        l.corner = center - 0.5f * (l.edge_u + l.edge_v);
    }
    l.two_sided = in.boolean(light, "two_sided", "light.two_sided", false);
    return l;
}

std::filesystem::path resolve_mesh(const reader& in, const std::string& where, const std::string& file) {
    const std::filesystem::path rel(file);
    const std::filesystem::path next_to_scene = in.file().parent_path() / rel;
    if (std::filesystem::exists(next_to_scene)) return next_to_scene;
    if (const char* dir = std::getenv("AAF_SCENES_DIR")) {
        const std::filesystem::path alt = std::filesystem::path(dir) / rel.filename();
        if (std::filesystem::exists(alt)) return alt;
    }
    in.fail(where, "mesh file '" + file + "' not found (looked next to the scene file" +
                    std::string(std::getenv("AAF_SCENES_DIR") ? " and in AAF_SCENES_DIR" : "; set AAF_SCENES_DIR to look elsewhere") + ")");
}

}  // namespace

std::uint32_t scene::add_object(std::string object_name, const std::vector<glm::vec3>& object_vertices,
                                const std::vector<glm::uvec3>& object_triangles, float albedo) {
    const auto base = static_cast<std::uint32_t>(vertices.size());
    const auto id = static_cast<std::uint32_t>(objects.size());
    objects.push_back({std::move(object_name), static_cast<std::uint32_t>(triangles.size()),
                       static_cast<std::uint32_t>(object_triangles.size()), albedo});
    vertices.insert(vertices.end(), object_vertices.begin(), object_vertices.end());
    for (const glm::uvec3& t : object_triangles) {
        triangles.push_back(t + glm::uvec3(base));
        triangle_object.push_back(id);
    }
    return id;
}

std::uint32_t scene::add_box(std::string object_name, const glm::vec3& lo, const glm::vec3& hi, float albedo) {
    std::vector<glm::vec3> v(8);
    for (unsigned i = 0; i < 8; ++i) v[i] = {(i & 1) ? hi.x : lo.x, (i & 2) ? hi.y : lo.y, (i & 4) ? hi.z : lo.z};
    // Outward-facing faces: -x, +x, -y, +y, -z, +z.
    const std::vector<glm::uvec3> t = {{0, 4, 6}, {0, 6, 2}, {1, 3, 7}, {1, 7, 5}, {0, 1, 5}, {0, 5, 4},
                                       {2, 6, 7}, {2, 7, 3}, {0, 2, 3}, {0, 3, 1}, {4, 5, 7}, {4, 7, 6}};
    return add_object(std::move(object_name), v, t, albedo);
}

void scene::validate() const {
    const std::string where = "scene '" + name + "': ";
    if (triangles.empty()) throw scene_error(where + "has no triangles");
    if (width == 0 || height == 0 || width > max_image_side || height > max_image_side)
        throw scene_error(where + "image size " + std::to_string(width) + "x" + std::to_string(height) +
                          " is impossible (each side must be 1.." + std::to_string(max_image_side) + ")");
    if (!(light.area() > 0.0f) || !std::isfinite(light.area()))
        throw scene_error(where + "the light has zero area (its edges are zero or parallel)");
    if (!(view.fov_y_degrees > 0.0f && view.fov_y_degrees < 180.0f))
        throw scene_error(where + "camera fov_y must be in (0, 180) degrees");
    if (glm::length(view.target - view.position) == 0.0f || glm::length(glm::cross(view.target - view.position, view.up)) == 0.0f)
        throw scene_error(where + "camera looks nowhere (target equals position, or is along up)");
    if (aaf.initial_samples < 1 || aaf.max_samples < aaf.initial_samples || !(aaf.mu >= 1.0f))
        throw scene_error(where + "aaf settings need initial_samples >= 1, max_samples >= initial_samples, mu >= 1");
}

scene load_scene_file(const std::filesystem::path& file) {
    std::ifstream stream(file);
    if (!stream) throw scene_error("scene " + file.string() + ": cannot open the file");
    json root;
    try {
        root = json::parse(stream);
    } catch (const json::parse_error& e) {
        // nlohmann's message names the byte; keep only its own text, on one line.
        std::string what = e.what();
        std::replace(what.begin(), what.end(), '\n', ' ');
        throw scene_error("scene " + file.string() + ": malformed JSON: " + what);
    }
    const reader in(file);
    if (!root.is_object()) in.fail("", "must be a JSON object");

    scene s;
    s.name = in.string(root, "name", "name", file.stem().string());
    if (root.contains("image")) {
        const json& image = in.object(root, "image", "image");
        const float w = in.number(image, "width", "image.width", 640), h = in.number(image, "height", "image.height", 480);
        if (!(w >= 1 && h >= 1 && w <= max_image_side && h <= max_image_side) || w != std::floor(w) || h != std::floor(h))
            in.fail("image", "size " + number_text(w) + "x" + number_text(h) + " is impossible (whole numbers 1.." +
                                 std::to_string(max_image_side) + ")");
        s.width = static_cast<std::size_t>(w);
        s.height = static_cast<std::size_t>(h);
    }
    const json& cam = in.object(root, "camera", "camera");
    s.view.position = in.vec3(cam, "position", "camera.position", {}, true);
    s.view.target = in.vec3(cam, "target", "camera.target", {}, true);
    s.view.up = in.vec3(cam, "up", "camera.up", {0, 1, 0});
    s.view.fov_y_degrees = in.number(cam, "fov_y", "camera.fov_y", 40);

    const json& light = in.object(root, "light", "light");
    s.light = read_light(in, light);
    s.radiance = in.number(light, "radiance", "light.radiance", 1);
    if (!(s.light.area() > 0.0f)) in.fail("light", "has zero area (its size or edges are zero, or the edges are parallel)");

    float ground_y = 0;
    bool has_ground = false;
    if (root.contains("ground")) {
        const json& g = in.object(root, "ground", "ground");
        ground_y = in.number(g, "y", "ground.y", 0);
        const float half = in.number(g, "half_size", "ground.half_size", 2);
        if (!(half > 0)) in.fail("ground.half_size", "must be > 0");
        s.add_object("ground", {{-half, ground_y, -half}, {half, ground_y, -half}, {half, ground_y, half}, {-half, ground_y, half}},
                     {{0, 2, 1}, {0, 3, 2}}, in.number(g, "albedo", "ground.albedo", 0.8f));
        has_ground = true;
    }

    if (root.contains("meshes")) {
        const json& meshes = root.at("meshes");
        if (!meshes.is_array()) in.fail("meshes", "must be an array");
        for (std::size_t i = 0; i < meshes.size(); ++i) {
            const std::string at = "meshes[" + std::to_string(i) + "]";
            const json& m = meshes[i];
            if (!m.is_object()) in.fail(at, "must be an object");
            const std::string file_name = in.string(m, "file", at + ".file", "", true);
            const std::filesystem::path path = resolve_mesh(in, at + ".file", file_name);
            triangle_mesh mesh;
            try {
                mesh = load_triangles(path);
            } catch (const std::exception& e) {
                in.fail(at, e.what());
            }
            if (mesh.triangles.empty()) in.fail(at, "mesh " + path.string() + " has no triangles");
            const float scale = in.number(m, "scale", at + ".scale", 1);
            if (!(scale > 0)) in.fail(at + ".scale", "must be > 0");
            const glm::mat3 rot = rotation_xyz(in.vec3(m, "rotate_degrees", at + ".rotate_degrees", {0, 0, 0}));
            const glm::vec3 translate = in.vec3(m, "translate", at + ".translate", {0, 0, 0});
            for (glm::vec3& v : mesh.vertices) v = rot * (v * scale) + translate;
            glm::vec3 lo(std::numeric_limits<float>::infinity()), hi(-std::numeric_limits<float>::infinity());
            for (const glm::vec3& v : mesh.vertices) lo = glm::min(lo, v), hi = glm::max(hi, v);
            if (m.contains("fit_size")) {
                const float fit = in.number(m, "fit_size", at + ".fit_size", 1);
                const float extent = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z});
                if (!(fit > 0) || !(extent > 0)) in.fail(at + ".fit_size", "must be > 0 (and the mesh must have an extent)");
                const glm::vec3 centre = 0.5f * (lo + hi);
                for (glm::vec3& v : mesh.vertices) v = centre + (v - centre) * (fit / extent);
                lo = centre + (lo - centre) * (fit / extent);
                hi = centre + (hi - centre) * (fit / extent);
            }
            if (in.boolean(m, "place_on_ground", at + ".place_on_ground", false)) {
                const glm::vec3 shift(-0.5f * (lo.x + hi.x), (has_ground ? ground_y : 0.0f) - lo.y, -0.5f * (lo.z + hi.z));
                for (glm::vec3& v : mesh.vertices) v += shift;
            }
            s.add_object(in.string(m, "name", at + ".name", path.stem().string()), mesh.vertices, mesh.triangles,
                         in.number(m, "albedo", at + ".albedo", 0.7f));
        }
    }
    if (root.contains("boxes")) {
        const json& boxes = root.at("boxes");
        if (!boxes.is_array()) in.fail("boxes", "must be an array");
        for (std::size_t i = 0; i < boxes.size(); ++i) {
            const std::string at = "boxes[" + std::to_string(i) + "]";
            const glm::vec3 lo = in.vec3(boxes[i], "min", at + ".min", {}, true), hi = in.vec3(boxes[i], "max", at + ".max", {}, true);
            if (!(lo.x < hi.x && lo.y < hi.y && lo.z < hi.z)) in.fail(at, "needs min < max on every axis");
            s.add_box(in.string(boxes[i], "name", at + ".name", "box"), lo, hi, in.number(boxes[i], "albedo", at + ".albedo", 0.6f));
        }
    }
    if (root.contains("aaf")) {
        const json& a = in.object(root, "aaf", "aaf");
        s.aaf.mu = in.number(a, "mu", "aaf.mu", 2);
        s.aaf.initial_samples = in.count(a, "initial_samples", "aaf.initial_samples", 9);
        s.aaf.max_samples = in.count(a, "max_samples", "aaf.max_samples", 100);
    }
    if (s.triangles.empty()) in.fail("", "has no geometry (no ground, meshes or boxes)");
    try {
        s.validate();
    } catch (const scene_error& e) {
        in.fail("", std::string(e.what()).substr(std::string("scene '" + s.name + "': ").size()));
    }
    return s;
}

scene load_scene(std::string_view name_or_path, const std::filesystem::path& scenes_dir) {
    const std::string arg(name_or_path);
    const std::vector<std::string> builtins = builtin_scene_names();
    if (std::find(builtins.begin(), builtins.end(), arg) != builtins.end()) return builtin_scene(arg);
    const std::filesystem::path as_path(arg);
    if (as_path.extension() == ".json") return load_scene_file(as_path);
    const std::filesystem::path in_dir = scenes_dir / (arg + ".json");
    if (std::filesystem::exists(in_dir)) return load_scene_file(in_dir);
    std::ostringstream known;
    for (const std::string& b : builtins) known << b << ' ';
    if (std::filesystem::is_directory(scenes_dir))
        for (const auto& entry : std::filesystem::directory_iterator(scenes_dir))
            if (entry.path().extension() == ".json") known << entry.path().stem().string() << ' ';
    throw scene_error("no scene named '" + arg + "' (built in or in " + scenes_dir.string() + "); known: " + known.str() +
                      "— or give a path to a .json file");
}

}  // namespace aaf_examples
