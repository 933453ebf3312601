// SPDX-License-Identifier: MIT
#pragma once
// Mesh loading for the examples, tests and benchmarks: any format assimp reads (OBJ, PLY, glTF, ...) as one
// indexed triangle list in world space. No hand-written parsers.

#include <filesystem>
#include <vector>

#include <glm/vec3.hpp>

namespace aaf_examples {

/// An indexed triangle mesh, ready for `bvh`.
struct triangle_mesh {
    std::vector<glm::vec3> vertices;    ///< positions, in the file's units, node transforms applied
    std::vector<glm::uvec3> triangles;  ///< three indices into `vertices` per triangle, the file's winding
};

/// Loads every mesh of a scene file as one triangle list: polygons triangulated, node transforms applied,
/// identical vertices joined; points and lines are skipped, materials and textures ignored (a missing
/// texture is not an error). Throws std::runtime_error("cannot load <path>: <reason>") when the file cannot
/// be read or holds no triangles.
[[nodiscard]] triangle_mesh load_triangles(const std::filesystem::path& path);

}  // namespace aaf_examples
