#include "bumpy_sphere.h"

#include <cmath>

namespace vox::scenes {

std::filesystem::path writeBumpySphere(const std::filesystem::path& directory, int rings,
                                       int segments, bool bumps) {
    std::filesystem::create_directories(directory);
    constexpr double kPi = 3.14159265358979323846;
    GltfBuilder::Primitive p;
    p.material = 0;
    const auto radius = [bumps](double theta, double phi) {
        if (!bumps) return 1.0;
        return 1.0 + 0.08 * std::sin(7 * theta) * std::cos(5 * phi) +
               0.03 * std::sin(23 * theta + 3 * phi) + 0.015 * std::cos(41 * phi - 13 * theta);
    };
    // Poles as single vertices, rings in between: no degenerate triangles.
    p.positions = {0, static_cast<float>(radius(0, 0)), 0};
    for (int r = 1; r < rings; ++r) {
        const double theta = kPi * r / rings;
        for (int s = 0; s < segments; ++s) {
            const double phi = 2 * kPi * s / segments;
            const double rad = radius(theta, phi);
            p.positions.push_back(static_cast<float>(rad * std::sin(theta) * std::cos(phi)));
            p.positions.push_back(static_cast<float>(rad * std::cos(theta)));
            p.positions.push_back(static_cast<float>(rad * std::sin(theta) * std::sin(phi)));
        }
    }
    p.positions.push_back(0);
    p.positions.push_back(static_cast<float>(-radius(kPi, 0)));
    p.positions.push_back(0);
    const auto ring = [&](int r, int s) {
        return static_cast<std::uint32_t>(1 + (r - 1) * segments + (s % segments));
    };
    const auto south = static_cast<std::uint32_t>(1 + (rings - 1) * segments);
    for (int s = 0; s < segments; ++s)
        p.indices.insert(p.indices.end(), {0, ring(1, s + 1), ring(1, s)});
    for (int r = 1; r + 1 < rings; ++r)
        for (int s = 0; s < segments; ++s) {
            p.indices.insert(p.indices.end(), {ring(r, s), ring(r, s + 1), ring(r + 1, s)});
            p.indices.insert(p.indices.end(), {ring(r, s + 1), ring(r + 1, s + 1), ring(r + 1, s)});
        }
    for (int s = 0; s < segments; ++s)
        p.indices.insert(p.indices.end(), {south, ring(rings - 1, s), ring(rings - 1, s + 1)});
    GltfBuilder gltf;
    gltf.addMaterial({"Clay", {0.7f, 0.6f, 0.5f, 1}});
    const char* name = bumps ? "BumpySphere" : "Sphere";
    const int mesh = gltf.addMesh(name, {p});
    gltf.setSceneRoots({gltf.addNode({name, mesh})});
    const auto file = directory / (bumps ? "bumpy_sphere.glb" : "sphere.glb");
    gltf.write(file, BufferStorage::Glb);
    return file;
}

}  // namespace vox::scenes
