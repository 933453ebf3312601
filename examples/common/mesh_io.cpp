// SPDX-License-Identifier: MIT
#include "common/mesh_io.hpp"

#include <stdexcept>
#include <string>

#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

namespace aaf_examples {

triangle_mesh load_triangles(const std::filesystem::path& path) {
    const auto fail = [&](const std::string& reason) {
        return std::runtime_error("cannot load " + path.string() + ": " + reason);
    };
    Assimp::Importer importer;
    const aiScene* scene = importer.ReadFile(
        path.string(), aiProcess_Triangulate | aiProcess_JoinIdenticalVertices | aiProcess_PreTransformVertices);
    if (scene == nullptr || (scene->mFlags & AI_SCENE_FLAGS_INCOMPLETE) != 0 || scene->mRootNode == nullptr)
        throw fail(importer.GetErrorString());

    triangle_mesh mesh;
    for (unsigned m = 0; m < scene->mNumMeshes; ++m) {  // pre-transformed: meshes are in world space
        const aiMesh& in = *scene->mMeshes[m];
        const auto base = static_cast<unsigned>(mesh.vertices.size());
        for (unsigned v = 0; v < in.mNumVertices; ++v)
            mesh.vertices.emplace_back(in.mVertices[v].x, in.mVertices[v].y, in.mVertices[v].z);
        for (unsigned f = 0; f < in.mNumFaces; ++f) {
            const aiFace& face = in.mFaces[f];
            if (face.mNumIndices != 3) continue;  // points and lines
            mesh.triangles.emplace_back(base + face.mIndices[0], base + face.mIndices[1], base + face.mIndices[2]);
        }
    }
    if (mesh.triangles.empty()) throw fail("the file holds no triangles");
    return mesh;
}

}  // namespace aaf_examples
