#include "corridor.h"

#include "scene_kit.h"
#include "shapes.h"

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace vox::scenes {
namespace {

using Facts = CorridorFacts;

constexpr std::uint64_t kSeed = 0x436F727269646F72ull;  // "Corridor"
constexpr int kTurnLo = -28, kTurnHi = 28;              // where the moving lights turn back

/// Position along [kTurnLo, kTurnHi] of something that starts at @p start and moves @p speed
/// per frame, bouncing at the ends; @p direction receives +1 or -1, the way it moves.
int pingPong(int start, int speed, int frame, int& direction) {
    const long long length = kTurnHi - kTurnLo;
    const long long unfolded =
        static_cast<long long>(start - kTurnLo) + static_cast<long long>(speed) * frame;
    long long m = unfolded % (2 * length);
    if (m < 0) m += 2 * length;
    const int sign = speed < 0 ? -1 : 1;
    if (m < length) {
        direction = sign;
        return kTurnLo + static_cast<int>(m);
    }
    direction = -sign;
    return kTurnHi - static_cast<int>(m - length);
}

struct Mover {
    int start, speed;
    double height;
};
constexpr Mover kMovers[2] = {{-25, 3, Facts::kLanternHeight}, {22, -2, Facts::kSearchlightHeight}};

/// The static corridor: geometry and, with @p lamps, the 30 lamps, appended to @p roots.
void addCorridor(GltfBuilder& gltf, std::vector<int>& roots, bool lamps = true) {
    SceneRng rng(kSeed);
    const int floorMaterial = gltf.addMaterial({"Floor", {0.35f, 0.33f, 0.30f, 1}});
    const int ceilingMaterial = gltf.addMaterial({"Ceiling", {0.85f, 0.85f, 0.84f, 1}});
    const int wallMaterial = gltf.addMaterial({"Wall", {0.75f, 0.73f, 0.70f, 1}});
    const int partitionMaterial = gltf.addMaterial({"Partition", {0.60f, 0.62f, 0.65f, 1}});
    const int doorMaterial = gltf.addMaterial({"Door", {0.45f, 0.30f, 0.18f, 1}});
    const int pillarMaterial = gltf.addMaterial({"Pillar", {0.50f, 0.50f, 0.50f, 1}});
    const int housingMaterial = gltf.addMaterial({"LampHousing", {0.30f, 0.30f, 0.32f, 1}});
    const int crateMaterial = gltf.addMaterial({"Crate", {0.55f, 0.40f, 0.22f, 1}});

    constexpr float hx = Facts::kLength / 2, hz = Facts::kWidth / 2, h = Facts::kHeight,
                    t = Facts::kWall;
    auto part = [&](const char* name, int material, auto&& fill) {
        GltfBuilder::Primitive primitive;
        primitive.material = material;
        fill(primitive);
        roots.push_back(gltf.addNode({name, gltf.addMesh(name, {primitive})}));
    };
    part("Floor", floorMaterial, [&](auto& p) {
        appendBox(p, {-hx - t, -t, -hz - t}, {hx + t, 0, hz + t});
    });
    part("Ceiling", ceilingMaterial, [&](auto& p) {
        appendBox(p, {-hx - t, h, -hz - t}, {hx + t, h + t, hz + t});
    });
    part("Walls", wallMaterial, [&](auto& p) {
        appendBox(p, {-hx - t, 0, -hz - t}, {hx + t, h, -hz});
        appendBox(p, {-hx - t, 0, hz}, {hx + t, h, hz + t});
        appendBox(p, {-hx - t, 0, -hz}, {-hx, h, hz});
        appendBox(p, {hx, 0, -hz}, {hx + t, h, hz});
    });
    constexpr float doorHalfWidth = 0.6f, doorHeight = 2.2f, half = 0.1f;
    part("Partitions", partitionMaterial, [&](auto& p) {
        for (float x : Facts::kPartitions) {
            appendBox(p, {x - half, 0, -hz}, {x + half, h, -doorHalfWidth});
            appendBox(p, {x - half, 0, doorHalfWidth}, {x + half, h, hz});
            appendBox(p, {x - half, doorHeight, -doorHalfWidth}, {x + half, h, doorHalfWidth});
        }
    });
    // Open door leaves, perpendicular to their partition along the doorway's edge, alternating
    // hinge side and the way they open.
    part("Doors", doorMaterial, [&](auto& p) {
        for (std::size_t k = 0; k < Facts::kPartitions.size(); ++k) {
            const float x = Facts::kPartitions[k];
            const bool even = k % 2 == 0;
            const float x0 = even ? x + half : x - half - 1.1f,
                        x1 = even ? x + half + 1.1f : x - half;
            const float z0 = even ? doorHalfWidth : -doorHalfWidth - 0.05f,
                        z1 = even ? doorHalfWidth + 0.05f : -doorHalfWidth;
            appendBox(p, {x0, 0, z0}, {x1, doorHeight - 0.05f, z1});
        }
    });
    part("Pillars", pillarMaterial, [&](auto& p) {
        for (float x : {-26.0f, -22.0f, -14.0f, -10.0f, -2.0f, 2.0f, 10.0f, 14.0f, 22.0f, 26.0f}) {
            appendBox(p, {x - 0.2f, 0, -hz}, {x + 0.2f, h, -hz + 0.35f});
            appendBox(p, {x - 0.2f, 0, hz - 0.35f}, {x + 0.2f, h, hz});
        }
    });
    part("LampHousings", housingMaterial, [&](auto& p) {
        for (int i = 0; i < Facts::kLamps; ++i) {
            const float x = -hx + Facts::kLampSpacing * (static_cast<float>(i) + 0.5f);
            appendBox(p, {x - 0.2f, h - 0.1f, -0.2f}, {x + 0.2f, h, 0.2f});
        }
    });
    part("Crates", crateMaterial, [&](auto& p) {
        for (float x : {-28.5f, -20.0f, -12.0f, -4.0f, 4.0f, 12.0f, 20.0f, 28.5f}) {
            const float size = static_cast<float>(rng.steps(0.5, 0.1, 4));
            const float z0 = rng.below(2) ? hz - 0.05f - size : -hz + 0.05f;
            appendBox(p, {x - size / 2, 0, z0}, {x + size / 2, size, z0 + size});
        }
    });

    if (!lamps) return;
    // The lamps: a mix of colour temperatures and intensities, all with the same range.
    static constexpr std::array<std::array<float, 3>, 3> colors{
        {{1.0f, 0.85f, 0.66f}, {1.0f, 0.95f, 0.88f}, {0.86f, 0.92f, 1.0f}}};
    for (int i = 0; i < Facts::kLamps; ++i) {
        const double x = -hx + Facts::kLampSpacing * (i + 0.5);
        const std::string name =
            "CeilingLamp_" + std::string(i < 10 ? "0" : "") + std::to_string(i);
        const auto& color = colors[static_cast<std::size_t>(rng.below(3))];
        const float intensity = static_cast<float>(rng.steps(Facts::kLampMinIntensity, 10, 4));
        const int light = gltf.addLight({name, "point", color, intensity, Facts::kLampRange});
        roots.push_back(gltf.addNode({name, -1, light, {x, Facts::kLampHeight, 0}}));
    }
}

std::filesystem::path fileIn(const std::filesystem::path& directory, const std::string& stem,
                             BufferStorage storage) {
    return directory / (stem + (storage == BufferStorage::Glb ? ".glb" : ".gltf"));
}

}  // namespace

std::array<double, 3> corridorMovingLightPosition(int light, int frame) {
    if (light < 0 || light > 1)
        throw std::invalid_argument("corridor: moving light " + std::to_string(light) +
                                    " does not exist");
    if (frame < 0) throw std::invalid_argument("corridor: frame must not be negative");
    int direction = 0;
    const Mover& m = kMovers[light];
    return {static_cast<double>(pingPong(m.start, m.speed, frame, direction)), m.height, 0.0};
}

std::filesystem::path writeCorridor(const std::filesystem::path& directory, BufferStorage storage) {
    std::filesystem::create_directories(directory);
    GltfBuilder gltf;
    std::vector<int> roots;
    addCorridor(gltf, roots);
    gltf.setSceneRoots(roots);
    const auto file = fileIn(directory, "corridor", storage);
    gltf.write(file, storage);
    return file;
}

std::filesystem::path writeCorridorStrips(const std::filesystem::path& directory,
                                          BufferStorage storage) {
    using Strips = CorridorStripFacts;
    std::filesystem::create_directories(directory);
    GltfBuilder gltf;
    std::vector<int> roots;
    addCorridor(gltf, roots, false);
    SceneRng rng(kSeed ^ 0x5374726970ull);  // "Strip"
    LightPalette palette(gltf);
    static constexpr std::array<std::array<float, 3>, 2> colors{
        {{1.0f, 0.86f, 0.70f}, {0.92f, 0.95f, 1.0f}}};
    const int intensitySteps =
        static_cast<int>((Strips::kMaxIntensity - Strips::kMinIntensity) / 0.5f) + 1;
    int written = 0;
    for (int row = 0; row < 2; ++row)
        for (int k = 0; k < Strips::kSlots; ++k) {
            const double x = quantize(-Facts::kLength / 2 + Strips::kStripSpacing * (k + 0.5));
            bool inPartition = false;
            for (float partition : Facts::kPartitions)
                inPartition = inPartition || std::abs(x - partition) < Strips::kPartitionGap;
            if (inPartition) continue;
            const int tint = rng.below(static_cast<int>(colors.size()));
            const float intensity =
                static_cast<float>(rng.steps(Strips::kMinIntensity, 0.5, intensitySteps));
            const int light = palette(
                {"Strip." + std::to_string(tint) + "." + std::to_string(intensity).substr(0, 3),
                 "point", colors[static_cast<std::size_t>(tint)], intensity, Strips::kStripRange});
            const std::string name = "StripLight_" + std::to_string(row) + "_" + std::to_string(k);
            roots.push_back(gltf.addNode(
                {name,
                 -1,
                 light,
                 {x, Strips::kStripHeight, row ? Strips::kStripOffset : -Strips::kStripOffset}}));
            ++written;
        }
    if (written != Strips::kLights)
        throw std::logic_error("corridor strips: " + std::to_string(written) + " lights, not " +
                               std::to_string(Strips::kLights));
    gltf.setSceneRoots(roots);
    const auto file = fileIn(directory, "corridor_strips", storage);
    gltf.write(file, storage);
    return file;
}

std::filesystem::path writeCorridorMoving(const std::filesystem::path& directory, int frame,
                                          BufferStorage storage) {
    if (frame < 0) throw std::invalid_argument("corridor: frame must not be negative");
    std::filesystem::create_directories(directory);
    GltfBuilder gltf;
    std::vector<int> roots;
    addCorridor(gltf, roots);

    // A lantern carried along the corridor.
    const int lantern = gltf.addLight(
        {Facts::kMovingNames[0], "point", {1.0f, 0.75f, 0.45f}, 40.0f, Facts::kLanternRange});
    GltfBuilder::NodeDesc lanternNode{Facts::kMovingNames[0], -1, lantern,
                                      corridorMovingLightPosition(0, frame)};
    lanternNode.dynamic = true;
    roots.push_back(gltf.addNode(lanternNode));

    // A searchlight on a cart, aimed 30 degrees down in the direction it travels.
    int direction = 0;
    pingPong(kMovers[1].start, kMovers[1].speed, frame, direction);
    const int searchlight = gltf.addLight({Facts::kMovingNames[1],
                                           "spot",
                                           {0.9f, 0.95f, 1.0f},
                                           150.0f,
                                           Facts::kSearchlightRange,
                                           0.3f,
                                           0.5f});
    GltfBuilder::NodeDesc searchNode{Facts::kMovingNames[1], -1, searchlight,
                                     corridorMovingLightPosition(1, frame),
                                     rotationFromMinusZ({direction * std::sqrt(3.0), -1.0, 0.0})};
    searchNode.dynamic = true;
    roots.push_back(gltf.addNode(searchNode));

    gltf.setSceneRoots(roots);
    const auto file = fileIn(directory, "corridor_moving_f" + std::to_string(frame), storage);
    gltf.write(file, storage);
    return file;
}

}  // namespace vox::scenes
