// SPDX-License-Identifier: MIT
#pragma once
// Scenes for the examples: a world-space triangle soup with per-object albedo and IDs, a rectangular area
// light, a pinhole camera and the image size, read from a JSON scene file or built in by name.
//
// Scene file (JSON; paths relative to the file; every field but "light" and "camera" optional):
//   {
//     "name": "bunny",
//     "image":  {"width": 640, "height": 480},
//     "camera": {"position": [x, y, z], "target": [x, y, z], "up": [0, 1, 0], "fov_y": 40},
//     "light":  {"center": [x, y, z], "size": [w, h], "normal": [0, -1, 0], "radiance": 1}
//            or {"corner": [x, y, z], "edge_u": [x, y, z], "edge_v": [x, y, z], "radiance": 1},
//     "ground": {"y": 0, "half_size": 2, "albedo": 0.8},
//     "meshes": [{"file": "../assets/meshes/bun_zipper.ply", "name": "bunny", "albedo": 0.7,
//                 "scale": 1, "rotate_degrees": [x, y, z], "translate": [x, y, z],
//                 "fit_size": 1.0, "place_on_ground": true}],
//     "boxes":  [{"min": [x, y, z], "max": [x, y, z], "albedo": 0.6, "name": "box"}],
//     "aaf":    {"mu": 2, "initial_samples": 9, "max_samples": 100}
//   }
// Mesh transforms apply in the order scale, rotate (X, then Y, then Z), translate; then "fit_size" scales
// the mesh so its largest extent is that size and "place_on_ground" centres it in x and z on the origin
// and sets its lowest point on the ground's y. A mesh file that is not found next to the scene file is
// also looked for in the folder named by the environment variable AAF_SCENES_DIR (where optional large
// meshes such as the sports car live).

#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <glm/vec3.hpp>

#include <aaf/area_light.hpp>

namespace aaf_examples {

/// Every problem with a scene: one line naming the file and what is wrong.
class scene_error : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

/// One object of a scene: a contiguous range of the scene's triangles.
struct scene_object {
    std::string name;
    std::uint32_t first_triangle = 0;  ///< index into scene::triangles
    std::uint32_t triangle_count = 0;
    float albedo = 0.7f;               ///< diffuse reflectance in [0, 1]
};

/// A pinhole camera.
struct camera {
    glm::vec3 position{0, 1, 3};
    glm::vec3 target{0};
    glm::vec3 up{0, 1, 0};
    float fov_y_degrees = 40;  ///< vertical field of view, in (0, 180)
};

/// The pipeline settings a scene may suggest (the renderer's flags override them).
struct scene_aaf_settings {
    float mu = 2;
    std::uint32_t initial_samples = 9;
    std::uint32_t max_samples = 100;
};

struct scene {
    std::string name;
    std::vector<glm::vec3> vertices;
    std::vector<glm::uvec3> triangles;
    std::vector<std::uint32_t> triangle_object;  ///< object index of each triangle (its ID in the G-buffer)
    std::vector<scene_object> objects;
    aaf::area_light<float> light{};
    float radiance = 1;
    camera view{};
    std::size_t width = 640, height = 480;
    scene_aaf_settings aaf{};

    /// Appends a triangle mesh as a new object; returns its index.
    std::uint32_t add_object(std::string name, const std::vector<glm::vec3>& vertices,
                             const std::vector<glm::uvec3>& triangles, float albedo);
    /// Appends an axis-aligned box (12 triangles) as a new object.
    std::uint32_t add_box(std::string name, const glm::vec3& lo, const glm::vec3& hi, float albedo);
    /// Checks what the renderer relies on; throws scene_error naming the problem.
    void validate() const;
};

/// Largest image side the examples accept.
inline constexpr std::size_t max_image_side = 16384;

/// Reads a JSON scene file (format above). Throws scene_error for a missing or malformed file, a missing or
/// ill-typed field, an unreadable or empty mesh, a zero-area light or an impossible image size.
[[nodiscard]] scene load_scene_file(const std::filesystem::path& file);

/// The scenes built into the examples, by name (procedural geometry, no files).
[[nodiscard]] std::vector<std::string> builtin_scene_names();
/// Builds a built-in scene; throws scene_error for an unknown name (listing the known ones).
[[nodiscard]] scene builtin_scene(std::string_view name);

/// A built-in name, or a path to a .json file, or the name of a file in `scenes_dir` ("bunny" →
/// scenes_dir/bunny.json). Throws scene_error when none matches.
[[nodiscard]] scene load_scene(std::string_view name_or_path, const std::filesystem::path& scenes_dir);

}  // namespace aaf_examples
