#include "city_block.h"

#include "scene_kit.h"
#include "shapes.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <numeric>
#include <stdexcept>
#include <string>
#include <vector>

namespace vox::scenes {
namespace {

using Facts = CityBlockFacts;

constexpr std::uint64_t kSeed = 0x43697479426C6B73ull;  // "CityBlks"
constexpr float kPitch = Facts::kLotSize + Facts::kStreetWidth;
constexpr float kWindowOffset = 0.3f, kNeonOffset = 0.4f, kFloodlightOffset = 1.0f;

struct Building {
    float x0, z0, x1, z1;  ///< footprint
    int floors;
    int material;
    [[nodiscard]] float height() const {
        return static_cast<float>(floors) * Facts::kFloorHeight + 0.5f;
    }
};

/// A facade: the outward normal (±x or ±z), the plane's coordinate, and the extent along it.
struct Facade {
    int axis;    ///< 0: facing ±x, 2: facing ±z
    float sign;  ///< +1 or -1
    float plane, a0, a1;
};

std::array<Facade, 4> facades(const Building& b) {
    return {{{0, -1, b.x0, b.z0, b.z1},
             {0, 1, b.x1, b.z0, b.z1},
             {2, -1, b.z0, b.x0, b.x1},
             {2, 1, b.z1, b.x0, b.x1}}};
}

/// The point @p offset out from facade @p f, at @p along on it and height @p y.
std::array<double, 3> onFacade(const Facade& f, double along, double y, double offset) {
    const double out = quantize(f.plane + f.sign * offset);
    along = quantize(along);
    y = quantize(y);
    return f.axis == 0 ? std::array<double, 3>{out, y, along}
                       : std::array<double, 3>{along, y, out};
}

/// Range where I / d² falls to the city's cut-off illuminance, rounded up to 0.1 m.
float cutoffRange(float intensity) {
    return static_cast<float>(
        std::ceil(std::sqrt(double(intensity) / Facts::kCutoffIlluminance) * 10.0) / 10.0);
}

std::string label(const char* prefix, const char* variant, float intensity) {
    return std::string(prefix) + "." + variant + "." + std::to_string(static_cast<int>(intensity));
}

/// Parcels of a 40 m lot in lot coordinates (x0, z0, x1, z1) for layout @p layout.
std::vector<std::array<float, 4>> parcels(int layout, int variant) {
    constexpr float L = Facts::kLotSize, H = L / 2;
    switch (layout) {
        case 0:
            return {{0, 0, H, H}, {H, 0, L, H}, {0, H, H, L}, {H, H, L, L}};  // four
        case 1:
            return variant % 2 ? std::vector<std::array<float, 4>>{{0, 0, H, L}, {H, 0, L, L}}
                               // two halves
                               : std::vector<std::array<float, 4>>{{0, 0, L, H}, {0, H, L, L}};
        case 2:
            return {{0, 0, L, L}};  // one large building
        default:                    // a half and two quarters
            switch (variant % 4) {
                case 0:
                    return {{0, 0, H, L}, {H, 0, L, H}, {H, H, L, L}};
                case 1:
                    return {{H, 0, L, L}, {0, 0, H, H}, {0, H, H, L}};
                case 2:
                    return {{0, 0, L, H}, {0, H, H, L}, {H, H, L, L}};
                default:
                    return {{0, H, L, L}, {0, 0, H, H}, {H, 0, L, H}};
            }
    }
}

/// A lamp post (pole and arm) for a lamp whose street lies towards @p normal (outward from its
/// block), in the lamp node's frame: the node points -Z straight down, so that a world offset
/// (X, Y, Z) from the lamp is (X, -Z, Y) in it.
GltfBuilder::Primitive lampPost(int axis, float sign, int material) {
    GltfBuilder::Primitive p;
    p.material = material;
    auto box = [&](float u0, float u1, float v0, float v1, float y0, float y1) {
        // u: along the outward normal, v: along the street.
        float x0, x1, z0, z1;
        const float a = sign > 0 ? u0 : -u1, b = sign > 0 ? u1 : -u0;
        if (axis == 0) {
            x0 = a, x1 = b, z0 = v0, z1 = v1;
        } else {
            z0 = a, z1 = b, x0 = v0, x1 = v1;
        }
        appendBox(p, {x0, -z1, y0}, {x1, -z0, y1});
    };
    const float base = Facts::kSidewalkHeight - Facts::kLampHeight;
    box(-1.6f, -1.4f, -0.1f, 0.1f, base, 0.3f);   // pole on the sidewalk, 0.4 m from the curb
    box(-1.4f, 0.3f, -0.2f, 0.2f, 0.08f, 0.28f);  // arm and head, just above the lamp
    return p;
}

}  // namespace

std::filesystem::path writeCityBlock(const std::filesystem::path& directory,
                                     BufferStorage storage, int blocksPerSide) {
    if (blocksPerSide < 1 || blocksPerSide > Facts::kMaxBlocksPerSide)
        throw std::invalid_argument("city: blocks per side must be 1 to " +
                                    std::to_string(Facts::kMaxBlocksPerSide));
    std::filesystem::create_directories(directory);
    // Light counts scale with the blocks: the default city's per block, rounded down.
    const int blocks = blocksPerSide * blocksPerSide;
    const float halfExtent = Facts::halfExtent(blocksPerSide);
    const std::size_t windows =
        static_cast<std::size_t>(Facts::kWindows) * static_cast<std::size_t>(blocks) /
        static_cast<std::size_t>(Facts::kBlocks);
    const int floodlitBuildings = std::max(1, Facts::kFloodlights / 4 * blocks / Facts::kBlocks);
    SceneRng rng(kSeed);
    GltfBuilder gltf;
    gltf.setCompactJson(true);
    std::vector<int> roots;

    const int groundMaterial = gltf.addMaterial({"Asphalt", {0.08f, 0.08f, 0.09f, 1}});
    const int sidewalkMaterial = gltf.addMaterial({"Sidewalk", {0.45f, 0.44f, 0.42f, 1}});
    const int metalMaterial = gltf.addMaterial({"LampMetal", {0.25f, 0.27f, 0.30f, 1}});
    struct Facing {
        const char* name;
        std::array<float, 4> color;
    };
    static constexpr std::array<Facing, 6> facings{{{"Concrete", {0.55f, 0.55f, 0.53f, 1}},
                                                    {"Brick", {0.50f, 0.25f, 0.18f, 1}},
                                                    {"Sandstone", {0.72f, 0.62f, 0.45f, 1}},
                                                    {"Glass", {0.30f, 0.40f, 0.50f, 1}},
                                                    {"Render", {0.80f, 0.80f, 0.78f, 1}},
                                                    {"Granite", {0.20f, 0.20f, 0.22f, 1}}}};

    // Geometry: the ground, then unit boxes instanced (translated and scaled) per sidewalk slab
    // and per building, one mesh per material, which keeps the file small.
    GltfBuilder::Primitive ground;
    ground.material = groundMaterial;
    appendBox(ground, {-halfExtent, -Facts::kGroundThickness, -halfExtent},
              {halfExtent, 0, halfExtent});
    roots.push_back(gltf.addNode({"Ground", gltf.addMesh("Ground", {ground})}));
    const int sidewalkMesh =
        gltf.addMesh("Sidewalk", {boxPrimitive({0, 0, 0}, {1, 1, 1}, sidewalkMaterial)});
    std::vector<int> buildingMeshes;
    for (const Facing& f : facings)
        buildingMeshes.push_back(gltf.addMesh(
            std::string("Building") + f.name,
            {boxPrimitive({0, 0, 0}, {1, 1, 1}, gltf.addMaterial({f.name, f.color}))}));

    // Blocks and their buildings; taller towards the centre (a rational fall-off, so that no
    // transcendental function can change a height between platforms).
    std::vector<Building> buildings;
    std::vector<std::array<int, 2>> blockBuildings;  // [first, end) per block
    for (int bi = 0; bi < blocksPerSide; ++bi)
        for (int bj = 0; bj < blocksPerSide; ++bj) {
            const float lx =
                -halfExtent + Facts::kStreetWidth + kPitch * static_cast<float>(bi);
            const float lz =
                -halfExtent + Facts::kStreetWidth + kPitch * static_cast<float>(bj);
            char name[32];
            std::snprintf(name, sizeof name, "Sidewalk_%02d_%02d", bi, bj);
            const float sw = Facts::kSidewalkWidth;
            GltfBuilder::NodeDesc slab{name, sidewalkMesh, -1, {lx - sw, 0, lz - sw}};
            slab.scale = {Facts::kLotSize + 2 * sw, Facts::kSidewalkHeight,
                          Facts::kLotSize + 2 * sw};
            roots.push_back(gltf.addNode(slab));

            const double cx = lx + Facts::kLotSize / 2, cz = lz + Facts::kLotSize / 2;
            const double downtown = 1.0 / (1.0 + (cx * cx + cz * cz) / (200.0 * 200.0));
            const int pick = rng.below(9);
            const int layout = pick < 4 ? 0 : pick < 6 ? 1 : pick < 7 ? 2 : 3;
            const int first = static_cast<int>(buildings.size());
            for (const auto& parcel : parcels(layout, rng.below(4))) {
                const float setback = static_cast<float>(layout == 2 ? rng.steps(2.0, 0.5, 5)
                                                                     : rng.steps(1.0, 0.5, 5));
                const double scale = 0.4 + 0.1 * rng.below(7);
                const int floors =
                    std::min(Facts::kMaxFloors,
                             2 + static_cast<int>(downtown * 26.0 * scale) + rng.below(3));
                Building b{lx + parcel[0] + setback,
                           lz + parcel[1] + setback,
                           lx + parcel[2] - setback,
                           lz + parcel[3] - setback,
                           floors,
                           rng.below(static_cast<int>(facings.size()))};
                std::snprintf(name, sizeof name, "Building_%02d_%02d_%d", bi, bj,
                              static_cast<int>(buildings.size()) - first);
                GltfBuilder::NodeDesc node{name,
                                           buildingMeshes[static_cast<std::size_t>(b.material)],
                                           -1,
                                           {b.x0, 0, b.z0}};
                node.scale = {b.x1 - b.x0, b.height(), b.z1 - b.z0};
                roots.push_back(gltf.addNode(node));
                buildings.push_back(b);
            }
            blockBuildings.push_back({first, static_cast<int>(buildings.size())});
        }

    LightPalette palette(gltf);

    // Street lamps: two on each side of every block, on its sidewalk, their heads over the road;
    // sodium or LED per street, intensities mixed per lamp.
    {
        // [x-facing (vertical) streets, z-facing streets]
        std::array<std::vector<bool>, 2> sodium;
        for (auto& streets : sodium) {
            streets.resize(static_cast<std::size_t>(blocksPerSide) + 1);
            for (std::size_t s = 0; s < streets.size(); ++s) streets[s] = rng.below(2) == 0;
        }
        int lampPosts[2][2];
        for (int axis : {0, 1})
            for (int side : {0, 1})
                lampPosts[axis][side] =
                    gltf.addMesh(std::string("LampPost") + (side ? "+" : "-") + (axis ? "z" : "x"),
                                 {lampPost(axis * 2, side ? 1.0f : -1.0f, metalMaterial)});
        const float out = Facts::kSidewalkWidth + 1.1f;  // from the lot's edge to the lamp
        int count = 0;
        for (int bi = 0; bi < blocksPerSide; ++bi)
            for (int bj = 0; bj < blocksPerSide; ++bj) {
                const float lx =
                    -halfExtent + Facts::kStreetWidth + kPitch * static_cast<float>(bi);
                const float lz =
                    -halfExtent + Facts::kStreetWidth + kPitch * static_cast<float>(bj);
                for (int axis : {0, 1})
                    for (int side : {0, 1}) {
                        const int street = (axis == 0 ? bi : bj) + side;
                        const bool isSodium = sodium[static_cast<std::size_t>(axis)]
                                                    [static_cast<std::size_t>(street)];
                        for (float along : {10.0f, 30.0f}) {
                            const float intensity = static_cast<float>(rng.steps(1600, 400, 3));
                            const int light =
                                palette({label(Facts::kStreetLampPrefix,
                                               isSodium ? "sodium" : "led", intensity),
                                         "spot",
                                         isSodium ? std::array<float, 3>{1.0f, 0.72f, 0.38f}
                                                  : std::array<float, 3>{0.92f, 0.96f, 1.0f},
                                         intensity, Facts::kStreetLampRange, Facts::kLampInnerCone,
                                         Facts::kLampOuterCone});
                            const float edge = axis == 0
                                                   ? (side ? lx + Facts::kLotSize + out : lx - out)
                                                   : (side ? lz + Facts::kLotSize + out : lz - out);
                            const std::array<double, 3> at =
                                axis == 0 ? std::array<double, 3>{quantize(edge),
                                                                  Facts::kLampHeight, lz + along}
                                          : std::array<double, 3>{lx + along, Facts::kLampHeight,
                                                                  quantize(edge)};
                            char name[32];
                            std::snprintf(name, sizeof name, "StreetLamp_%04d", count++);
                            roots.push_back(gltf.addNode(
                                {name, lampPosts[axis][side], light, at, pointingDown()}));
                        }
                    }
            }
    }

    // Lit windows: exactly kWindows of all window slots on the upper floors (the ground floor
    // holds shops), drawn uniformly (selection sampling), so taller buildings get more.
    {
        struct Tint {
            const char* name;
            std::array<float, 3> color;
        };
        static constexpr std::array<Tint, 4> tints{{{"incandescent", {1.0f, 0.78f, 0.50f}},
                                                    {"warmwhite", {1.0f, 0.88f, 0.72f}},
                                                    {"fluorescent", {0.85f, 0.92f, 1.0f}},
                                                    {"tv", {0.60f, 0.70f, 1.0f}}}};
        std::vector<std::array<double, 3>> slots;
        for (const Building& b : buildings)
            for (const Facade& f : facades(b)) {
                const float width = f.a1 - f.a0;
                const int columns = std::max(1, static_cast<int>((width - 1.0f) / 3.5f));
                for (int floor = 1; floor < b.floors; ++floor)
                    for (int c = 0; c < columns; ++c)
                        slots.push_back(onFacade(f, f.a0 + width * (c + 0.5) / columns,
                                                 floor * double(Facts::kFloorHeight) + 1.7,
                                                 kWindowOffset));
            }
        if (slots.size() < windows) throw std::logic_error("city: too few window slots");
        std::size_t needed = windows, count = 0;
        for (std::size_t i = 0; i < slots.size() && needed > 0; ++i) {
            if (rng.next() % (slots.size() - i) >= needed) continue;
            --needed;
            const Tint& tint =
                tints[static_cast<std::size_t>(rng.below(static_cast<int>(tints.size())))];
            static constexpr std::array<double, 3> intensities{20.0, 30.0, 45.0};
            const float intensity = static_cast<float>(rng.pick<double>(intensities));
            const int light = palette({label(Facts::kWindowPrefix, tint.name, intensity), "point",
                                       tint.color, intensity, cutoffRange(intensity)});
            char name[32];
            std::snprintf(name, sizeof name, "Window_%04zu", count++);
            roots.push_back(gltf.addNode({name, -1, light, slots[i]}));
        }
    }

    // Neon signs: one per block, on a ground-floor facade of one of its buildings.
    {
        struct Tint {
            const char* name;
            std::array<float, 3> color;
        };
        static constexpr std::array<Tint, 6> tints{{{"pink", {1.0f, 0.10f, 0.60f}},
                                                    {"cyan", {0.10f, 0.90f, 1.0f}},
                                                    {"green", {0.20f, 1.0f, 0.30f}},
                                                    {"violet", {0.60f, 0.20f, 1.0f}},
                                                    {"red", {1.0f, 0.15f, 0.10f}},
                                                    {"yellow", {1.0f, 0.75f, 0.10f}}}};
        for (int block = 0; block < blocks; ++block) {
            const auto [first, end] = blockBuildings[static_cast<std::size_t>(block)];
            const Building& b = buildings[static_cast<std::size_t>(first + rng.below(end - first))];
            const Facade f = facades(b)[static_cast<std::size_t>(rng.below(4))];
            const double along = f.a0 + (f.a1 - f.a0) * (0.2 + 0.1 * rng.below(7));
            const Tint& tint =
                tints[static_cast<std::size_t>(rng.below(static_cast<int>(tints.size())))];
            const float intensity = rng.below(2) ? 180.0f : 120.0f;
            const int light = palette({label(Facts::kNeonPrefix, tint.name, intensity), "point",
                                       tint.color, intensity, cutoffRange(intensity)});
            char name[32];
            std::snprintf(name, sizeof name, "Neon_%03d", block);
            roots.push_back(gltf.addNode(
                {name, -1, light, onFacade(f, along, rng.steps(4.0, 0.5, 3), kNeonOffset)}));
        }
    }

    // Floodlights: at the foot of each facade of the tallest buildings, aimed up the facade.
    {
        std::vector<std::size_t> order(buildings.size());
        std::iota(order.begin(), order.end(), std::size_t{0});
        std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
            return buildings[a].floors > buildings[b].floors;
        });
        struct Tint {
            const char* name;
            std::array<float, 3> color;
        };
        static constexpr std::array<Tint, 3> tints{{{"white", {1.0f, 1.0f, 1.0f}},
                                                    {"cool", {0.80f, 0.90f, 1.0f}},
                                                    {"amber", {1.0f, 0.80f, 0.50f}}}};
        constexpr float intensity = 3000.0f;
        int count = 0;
        for (int k = 0; k < floodlitBuildings; ++k) {
            const Building& b = buildings[order[static_cast<std::size_t>(k)]];
            const Tint& tint =
                tints[static_cast<std::size_t>(rng.below(static_cast<int>(tints.size())))];
            const int light =
                palette({label(Facts::kFloodlightPrefix, tint.name, intensity), "spot", tint.color,
                         intensity, cutoffRange(intensity), 0.15f, 0.3f});
            for (const Facade& f : facades(b)) {
                std::array<double, 3> towards{0, 1, 0};
                towards[static_cast<std::size_t>(f.axis)] = -0.15 * f.sign;
                char name[32];
                std::snprintf(name, sizeof name, "Floodlight_%03d", count++);
                std::array<double, 4> rotation = rotationFromMinusZ(towards);
                for (double& c : rotation) c += 0.0;  // no negative zeros in the file
                roots.push_back(gltf.addNode(
                    {name, -1, light, onFacade(f, (f.a0 + f.a1) / 2.0, 0.6, kFloodlightOffset),
                     rotation}));
            }
        }
    }

    gltf.setSceneRoots(roots);
    const std::filesystem::path file =
        directory / (storage == BufferStorage::Glb ? "city_block.glb" : "city_block.gltf");
    gltf.write(file, storage);
    return file;
}

}  // namespace vox::scenes
