#include "light_grid.h"

#include "scene_kit.h"

#include <cstdint>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

namespace vox::scenes {
namespace {

using Facts = LightGridFacts;

constexpr std::uint64_t kSeed = 0x4C69676874477264ull;  // "LightGrd"

}  // namespace

std::filesystem::path writeLightGrid(const std::filesystem::path& directory, BufferStorage storage,
                                     int lightsPerSide) {
    if (lightsPerSide < 1)
        throw std::invalid_argument("light grid: lights per side must be at least 1");
    std::filesystem::create_directories(directory);
    SceneRng rng(kSeed);
    GltfBuilder gltf;
    std::vector<int> roots;

    const int floorMaterial = gltf.addMaterial({"Floor", {0.60f, 0.60f, 0.58f, 1}});
    static constexpr std::array<std::array<float, 4>, 4> cubeColors{{{0.73f, 0.73f, 0.73f, 1},
                                                                     {0.63f, 0.20f, 0.15f, 1},
                                                                     {0.20f, 0.45f, 0.25f, 1},
                                                                     {0.25f, 0.35f, 0.60f, 1}}};
    std::vector<int> cubeMaterials;
    for (std::size_t i = 0; i < cubeColors.size(); ++i)
        cubeMaterials.push_back(gltf.addMaterial({"Cube" + std::to_string(i), cubeColors[i]}));

    GltfBuilder::Primitive floor;
    floor.material = floorMaterial;
    appendBox(floor, {-Facts::kFloorHalfSize, -Facts::kFloorThickness, -Facts::kFloorHalfSize},
              {Facts::kFloorHalfSize, 0, Facts::kFloorHalfSize});
    roots.push_back(gltf.addNode({"Floor", gltf.addMesh("Floor", {floor})}));

    // The cubes, one primitive per material; heights in 0.25 steps, the middle four as tall as
    // the scene gets so that its bounds do not depend on the draw.
    std::vector<GltfBuilder::Primitive> cubes(cubeMaterials.size());
    for (std::size_t i = 0; i < cubes.size(); ++i) cubes[i].material = cubeMaterials[i];
    const int heightSteps =
        static_cast<int>((Facts::kMaxCubeHeight - Facts::kMinCubeHeight) / 0.25f) + 1;
    for (int i = 0; i < Facts::kCubesPerSide; ++i)
        for (int j = 0; j < Facts::kCubesPerSide; ++j) {
            const float cx =
                Facts::kCubePitch * (static_cast<float>(i) - (Facts::kCubesPerSide - 1) / 2.0f);
            const float cz =
                Facts::kCubePitch * (static_cast<float>(j) - (Facts::kCubesPerSide - 1) / 2.0f);
            const bool middle = (i == 3 || i == 4) && (j == 3 || j == 4);
            const float height =
                middle ? Facts::kMaxCubeHeight
                       : static_cast<float>(rng.steps(Facts::kMinCubeHeight, 0.25, heightSteps));
            auto& primitive =
                cubes[static_cast<std::size_t>(rng.below(static_cast<int>(cubes.size())))];
            const float s = Facts::kCubeSize / 2;
            appendBox(primitive, {cx - s, 0, cz - s}, {cx + s, height, cz + s});
        }
    roots.push_back(gltf.addNode({"Cubes", gltf.addMesh("Cubes", cubes)}));

    // The lights: five tints, three intensities, one range; definitions shared between nodes.
    struct Tint {
        const char* name;
        std::array<float, 3> color;
    };
    static constexpr std::array<Tint, 5> tints{{{"warm", {1.0f, 0.82f, 0.62f}},
                                                {"neutral", {1.0f, 0.96f, 0.90f}},
                                                {"cool", {0.82f, 0.90f, 1.0f}},
                                                {"amber", {1.0f, 0.65f, 0.30f}},
                                                {"teal", {0.55f, 0.95f, 0.90f}}}};
    LightPalette palette(gltf);
    const double spacing =
        double(Facts::kLightSpacing) * Facts::kLightsPerSide / double(lightsPerSide);
    for (int i = 0; i < lightsPerSide; ++i)
        for (int j = 0; j < lightsPerSide; ++j) {
            const double x = spacing * (i - (lightsPerSide - 1) / 2.0);
            const double z = spacing * (j - (lightsPerSide - 1) / 2.0);
            const Tint& tint =
                tints[static_cast<std::size_t>(rng.below(static_cast<int>(tints.size())))];
            const float intensity = static_cast<float>(rng.steps(Facts::kMinIntensity, 5, 3));
            const int light = palette({"GridLight." + std::string(tint.name) + "." +
                                           std::to_string(static_cast<int>(intensity)),
                                       "point", tint.color, intensity, Facts::kLightRange});
            char name[40];
            std::snprintf(name, sizeof name, "GridLight_%02d_%02d", i, j);
            roots.push_back(gltf.addNode({name, -1, light, {x, Facts::kLightHeight, z}}));
        }

    gltf.setSceneRoots(roots);
    const std::string stem = lightsPerSide == Facts::kLightsPerSide
                                 ? std::string("light_grid")
                                 : "light_grid_" + std::to_string(lightsPerSide * lightsPerSide);
    const std::filesystem::path file =
        directory / (stem + (storage == BufferStorage::Glb ? ".glb" : ".gltf"));
    gltf.write(file, storage);
    return file;
}

}  // namespace vox::scenes
