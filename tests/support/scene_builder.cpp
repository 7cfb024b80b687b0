#include "scene_builder.h"

#include <array>

namespace vox::test {

namespace {}  // namespace

std::uint32_t addMaterial(Scene& scene, Vec3f albedo, Vec3f emission) {
    Material m;
    m.baseColorFactor = {albedo.x, albedo.y, albedo.z, 1};
    m.emissiveFactor = emission;
    scene.materials.push_back(m);
    return static_cast<std::uint32_t>(scene.materials.size() - 1);
}

void addQuad(Scene& scene, Vec3d corner, Vec3d u, Vec3d v, std::uint32_t material) {
    Mesh mesh;
    mesh.material = material;
    mesh.positions = {vec3Cast<float>(corner), vec3Cast<float>(corner + u),
                      vec3Cast<float>(corner + u + v), vec3Cast<float>(corner + v)};
    const Vec3f n = vec3Cast<float>(normalize(cross(u, v)));
    mesh.normals = {n, n, n, n};
    mesh.indices = {0, 1, 2, 0, 2, 3};
    scene.meshes.push_back(std::move(mesh));
}

void addBox(Scene& scene, Vec3d lo, Vec3d hi, std::uint32_t material, bool inward) {
    const Vec3d e = hi - lo;
    const Vec3d x{e.x, 0, 0}, y{0, e.y, 0}, z{0, 0, e.z};
    // Outward fronts: −x, +x, −y, +y, −z, +z.
    const std::array<std::array<Vec3d, 3>, 6> faces{
        {{lo, z, y}, {lo + x, y, z}, {lo, x, z}, {lo + y, z, x}, {lo, y, x}, {lo + z, x, y}}};
    for (const auto& [corner, u, v] : faces) {
        if (inward)
            addQuad(scene, corner, v, u, material);
        else
            addQuad(scene, corner, u, v, material);
    }
}

}  // namespace vox::test
