// The many-light example scenes (corridor, moving-light corridor, light grid, city block): what
// the Lightcuts work relies on: light counts, dynamic flags, positions, ranges, determinism.
#include <vox/import.h>

#include "city_block.h"
#include "corridor.h"
#include "light_grid.h"
#include "test_support.h"

#include <cmath>
#include <fstream>
#include <iterator>
#include <map>
#include <set>

using vox::scenes::BufferStorage;
using vox::scenes::CityBlockFacts;
using vox::scenes::CorridorFacts;
using vox::scenes::LightGridFacts;

namespace {

std::string readBytes(const std::filesystem::path& file) {
    std::ifstream in(file, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// Every file in @p a has the same bytes in @p b, and both hold the same files.
void expectSameFiles(const vox::test::ScratchDir& a, const vox::test::ScratchDir& b) {
    ASSERT_EQ(a.files(), b.files());
    ASSERT_FALSE(a.files().empty());
    for (const std::string& name : a.files())
        EXPECT_TRUE(readBytes(a / name) == readBytes(b / name)) << name;
}

void expectInside(const vox::Light& light, const vox::Bounds3f& bounds, float above = 0.0f) {
    EXPECT_GE(light.position.x, bounds.min.x) << light.name;
    EXPECT_LE(light.position.x, bounds.max.x) << light.name;
    EXPECT_GE(light.position.y, bounds.min.y) << light.name;
    EXPECT_LE(light.position.y, bounds.max.y + above) << light.name;
    EXPECT_GE(light.position.z, bounds.min.z) << light.name;
    EXPECT_LE(light.position.z, bounds.max.z) << light.name;
}

void expectBounds(const vox::Bounds3f& bounds, std::array<float, 3> min, std::array<float, 3> max) {
    EXPECT_FLOAT_EQ(bounds.min.x, min[0]);
    EXPECT_FLOAT_EQ(bounds.min.y, min[1]);
    EXPECT_FLOAT_EQ(bounds.min.z, min[2]);
    EXPECT_FLOAT_EQ(bounds.max.x, max[0]);
    EXPECT_FLOAT_EQ(bounds.max.y, max[1]);
    EXPECT_FLOAT_EQ(bounds.max.z, max[2]);
}

bool sameLight(const vox::Light& a, const vox::Light& b) {
    return a.name == b.name && a.type == b.type && a.color == b.color &&
           a.intensity == b.intensity && a.range == b.range &&
           a.innerConeAngle == b.innerConeAngle && a.outerConeAngle == b.outerConeAngle &&
           a.position == b.position && a.direction == b.direction && a.dynamic == b.dynamic;
}

std::string prefixOf(const std::string& name) { return name.substr(0, name.find('.')); }

}  // namespace

TEST(ExampleScenes, CorridorHas30StaticCeilingLampsWithFiniteRanges) {
    vox::test::ScratchDir dir;
    const vox::Scene scene = vox::importScene(vox::scenes::writeCorridor(dir.path()));
    EXPECT_TRUE(scene.warnings.empty());
    EXPECT_EQ(scene.triangleCount(), CorridorFacts::kTriangles);
    EXPECT_EQ(scene.dynamicTriangleCount(), 0u);
    const vox::Bounds3f bounds = scene.bounds();
    expectBounds(bounds, CorridorFacts::kBoundsMin, CorridorFacts::kBoundsMax);
    ASSERT_EQ(scene.lights.size(), static_cast<std::size_t>(CorridorFacts::kLamps));
    std::set<float> intensities;
    std::set<std::array<float, 3>> colors;
    for (std::size_t i = 0; i < scene.lights.size(); ++i) {
        const vox::Light& light = scene.lights[i];
        EXPECT_EQ(light.type, vox::Light::Type::Point);
        EXPECT_FALSE(light.dynamic);
        EXPECT_FLOAT_EQ(light.range, CorridorFacts::kLampRange);
        // The range is where the floor illuminance I·h/d³ is 1 % of the peak I/h² beneath.
        EXPECT_NEAR(std::pow(CorridorFacts::kLampHeight / light.range, 3.0f), 0.01f, 0.0005f);
        EXPECT_GE(light.intensity, CorridorFacts::kLampMinIntensity);
        EXPECT_LE(light.intensity, CorridorFacts::kLampMaxIntensity);
        EXPECT_FLOAT_EQ(light.position.x,
                        -CorridorFacts::kLength / 2 +
                            CorridorFacts::kLampSpacing * (static_cast<float>(i) + 0.5f));
        EXPECT_FLOAT_EQ(light.position.y, CorridorFacts::kLampHeight);
        EXPECT_FLOAT_EQ(light.position.z, 0.0f);
        expectInside(light, bounds);
        intensities.insert(light.intensity);
        colors.insert({light.color.x, light.color.y, light.color.z});
    }
    EXPECT_GE(intensities.size(), 3u);
    EXPECT_GE(colors.size(), 2u);
    // The two ends do not overlap: a light forest splits the corridor.
    EXPECT_GT(scene.lights.back().position.x - scene.lights.front().position.x,
              2 * CorridorFacts::kLampRange);
}

TEST(ExampleScenes, MovingCorridorAddsTwoDynamicLightsThatMoveBetweenFrames) {
    vox::test::ScratchDir dir;
    const vox::Scene still = vox::importScene(vox::scenes::writeCorridor(dir.path()));
    std::vector<vox::Scene> frames;
    for (int frame : {0, 1}) {
        const auto file = vox::scenes::writeCorridorMoving(dir.path(), frame);
        EXPECT_EQ(file.filename(), "corridor_moving_f" + std::to_string(frame) + ".gltf");
        frames.push_back(vox::importScene(file));
    }
    for (int frame : {0, 1}) {
        const vox::Scene& scene = frames[static_cast<std::size_t>(frame)];
        EXPECT_TRUE(scene.warnings.empty());
        ASSERT_EQ(scene.lights.size(),
                  static_cast<std::size_t>(CorridorFacts::kLamps + CorridorFacts::kMovingLights));
        const vox::Bounds3f bounds = scene.bounds();
        int dynamic = 0;
        for (const vox::Light& light : scene.lights) {
            dynamic += light.dynamic;
            expectInside(light, bounds);
        }
        EXPECT_EQ(dynamic, CorridorFacts::kMovingLights);
        // The static part is the still corridor's, light for light and triangle for triangle.
        for (std::size_t i = 0; i < still.lights.size(); ++i)
            EXPECT_TRUE(sameLight(scene.lights[i], still.lights[i])) << i;
        ASSERT_EQ(scene.meshes.size(), still.meshes.size());
        for (std::size_t m = 0; m < still.meshes.size(); ++m) {
            EXPECT_EQ(scene.meshes[m].positions, still.meshes[m].positions);
            EXPECT_EQ(scene.meshes[m].indices, still.meshes[m].indices);
        }
        for (int k = 0; k < CorridorFacts::kMovingLights; ++k) {
            const vox::Light& mover =
                scene.lights[static_cast<std::size_t>(CorridorFacts::kLamps + k)];
            EXPECT_TRUE(mover.dynamic);
            EXPECT_EQ(mover.name, CorridorFacts::kMovingNames[static_cast<std::size_t>(k)]);
            const auto at = vox::scenes::corridorMovingLightPosition(k, frame);
            EXPECT_FLOAT_EQ(mover.position.x, static_cast<float>(at[0]));
            EXPECT_FLOAT_EQ(mover.position.y, static_cast<float>(at[1]));
            EXPECT_FLOAT_EQ(mover.position.z, static_cast<float>(at[2]));
        }
        const vox::Light& lantern = scene.lights[CorridorFacts::kLamps];
        EXPECT_EQ(lantern.type, vox::Light::Type::Point);
        EXPECT_FLOAT_EQ(lantern.range, CorridorFacts::kLanternRange);
        const vox::Light& searchlight = scene.lights[CorridorFacts::kLamps + 1];
        EXPECT_EQ(searchlight.type, vox::Light::Type::Spot);
        EXPECT_FLOAT_EQ(searchlight.range, CorridorFacts::kSearchlightRange);
        EXPECT_NEAR(searchlight.direction.y, -0.5f, 1e-5f);  // 30 degrees down
        EXPECT_LT(searchlight.direction.x, 0.0f);            // the way it travels in frames 0 and 1
    }
    for (int k = 0; k < CorridorFacts::kMovingLights; ++k) {
        const auto i = static_cast<std::size_t>(CorridorFacts::kLamps + k);
        EXPECT_NE(frames[0].lights[i].position.x, frames[1].lights[i].position.x) << k;
    }
    // Later frames bounce between the corridor's ends.
    for (int frame = 0; frame < 100; ++frame)
        for (int k = 0; k < 2; ++k)
            EXPECT_LE(std::abs(vox::scenes::corridorMovingLightPosition(k, frame)[0]), 28.0);
}

TEST(ExampleScenes, LightGridHas256EqualRangeLightsAboveTheCubes) {
    vox::test::ScratchDir dir;
    const vox::Scene scene = vox::importScene(vox::scenes::writeLightGrid(dir.path()));
    EXPECT_TRUE(scene.warnings.empty());
    EXPECT_EQ(scene.triangleCount(), LightGridFacts::kTriangles);
    const vox::Bounds3f bounds = scene.bounds();
    expectBounds(bounds, LightGridFacts::kBoundsMin, LightGridFacts::kBoundsMax);
    ASSERT_EQ(scene.lights.size(), static_cast<std::size_t>(LightGridFacts::kLights));
    std::set<std::pair<float, float>> cells;
    std::set<float> intensities;
    for (const vox::Light& light : scene.lights) {
        EXPECT_EQ(light.type, vox::Light::Type::Point);
        EXPECT_FALSE(light.dynamic);
        EXPECT_FLOAT_EQ(light.range, LightGridFacts::kLightRange);
        EXPECT_FLOAT_EQ(light.position.y, LightGridFacts::kLightHeight);
        EXPECT_GT(light.range, LightGridFacts::kLightHeight);  // reaches the floor
        expectInside(light, bounds, LightGridFacts::kLightHeight - LightGridFacts::kMaxCubeHeight);
        EXPECT_FLOAT_EQ(std::fmod(light.position.x + 15.0f, LightGridFacts::kLightSpacing), 0.0f);
        EXPECT_FLOAT_EQ(std::fmod(light.position.z + 15.0f, LightGridFacts::kLightSpacing), 0.0f);
        cells.insert({light.position.x, light.position.z});
        intensities.insert(light.intensity);
    }
    EXPECT_EQ(cells.size(), static_cast<std::size_t>(LightGridFacts::kLights));
    EXPECT_EQ(intensities.size(), 3u);
}

TEST(ExampleScenes, CityBlockHas10000LightsSplitAsDocumented) {
    vox::test::ScratchDir dir;
    const vox::Scene scene = vox::importScene(vox::scenes::writeCityBlock(dir.path()));
    EXPECT_TRUE(scene.warnings.empty());
    EXPECT_LT(scene.triangleCount(), CityBlockFacts::kTriangleBudget);
    const vox::Bounds3f bounds = scene.bounds();
    EXPECT_FLOAT_EQ(bounds.min.x, -CityBlockFacts::kHalfExtent);
    EXPECT_FLOAT_EQ(bounds.max.z, CityBlockFacts::kHalfExtent);
    EXPECT_FLOAT_EQ(bounds.min.y, -CityBlockFacts::kGroundThickness);
    EXPECT_LE(bounds.max.y, CityBlockFacts::kMaxBuildingHeight);
    EXPECT_GT(bounds.max.y, 50.0f);
    ASSERT_EQ(scene.lights.size(), static_cast<std::size_t>(CityBlockFacts::kLights));

    std::map<std::string, int> counts;
    const float lampReach = CityBlockFacts::kLampHeight / std::cos(CityBlockFacts::kLampOuterCone);
    for (const vox::Light& light : scene.lights) {
        const std::string kind = prefixOf(light.name);
        ++counts[kind];
        EXPECT_FALSE(light.dynamic);
        expectInside(light, bounds);
        EXPECT_GT(light.position.y, 0.0f) << light.name;
        ASSERT_GT(light.range, 0.0f) << light.name;
        if (kind == CityBlockFacts::kStreetLampPrefix) {
            EXPECT_EQ(light.type, vox::Light::Type::Spot);
            EXPECT_FLOAT_EQ(light.range, CityBlockFacts::kStreetLampRange);
            EXPECT_GE(light.range, lampReach);
            EXPECT_FLOAT_EQ(light.position.y, CityBlockFacts::kLampHeight);
            EXPECT_NEAR(light.direction.y, -1.0f, 1e-6f);
            EXPECT_FLOAT_EQ(light.outerConeAngle, CityBlockFacts::kLampOuterCone);
        } else {
            // Where I / d² falls to the city's cut-off, rounded up to 0.1 m.
            const float reach = std::sqrt(light.intensity / CityBlockFacts::kCutoffIlluminance);
            EXPECT_GE(light.range, reach - 1e-4f) << light.name;
            EXPECT_LE(light.range, reach + 0.1f) << light.name;
            if (kind == CityBlockFacts::kFloodlightPrefix) {
                EXPECT_EQ(light.type, vox::Light::Type::Spot);
                EXPECT_GT(light.direction.y, 0.9f);
            } else {
                EXPECT_EQ(light.type, vox::Light::Type::Point) << light.name;
            }
        }
    }
    EXPECT_EQ(counts[CityBlockFacts::kStreetLampPrefix], CityBlockFacts::kStreetLamps);
    EXPECT_EQ(counts[CityBlockFacts::kWindowPrefix], CityBlockFacts::kWindows);
    EXPECT_EQ(counts[CityBlockFacts::kNeonPrefix], CityBlockFacts::kNeonSigns);
    EXPECT_EQ(counts[CityBlockFacts::kFloodlightPrefix], CityBlockFacts::kFloodlights);
    EXPECT_EQ(counts.size(), 4u);

    // Each street lamp hangs under the head of its post, which stands on the sidewalk; no light
    // is inside a building.
    std::vector<vox::Bounds3f> buildings;
    std::size_t lamp = 0;
    for (const vox::Mesh& mesh : scene.meshes) {
        vox::Bounds3f box;
        for (const vox::Vec3f& p : mesh.positions) box.add(p);
        if (mesh.name.starts_with("Building_")) buildings.push_back(box);
        if (!mesh.name.starts_with("StreetLamp_")) continue;
        ASSERT_LT(lamp, scene.lights.size());
        const vox::Light& light = scene.lights[lamp++];
        EXPECT_EQ(prefixOf(light.name), CityBlockFacts::kStreetLampPrefix);
        EXPECT_NEAR(box.min.y, CityBlockFacts::kSidewalkHeight, 1e-4f) << mesh.name;
        EXPECT_GT(box.max.y, light.position.y) << mesh.name;
        EXPECT_TRUE(light.position.x > box.min.x && light.position.x < box.max.x &&
                    light.position.z > box.min.z && light.position.z < box.max.z)
            << mesh.name;
    }
    EXPECT_EQ(lamp, static_cast<std::size_t>(CityBlockFacts::kStreetLamps));
    EXPECT_GE(buildings.size(), static_cast<std::size_t>(CityBlockFacts::kBlocks));
    std::size_t inside = 0;
    for (const vox::Light& light : scene.lights)
        for (const vox::Bounds3f& b : buildings)
            inside += light.position.x > b.min.x && light.position.x < b.max.x &&
                      light.position.y < b.max.y && light.position.z > b.min.z &&
                      light.position.z < b.max.z;
    EXPECT_EQ(inside, 0u);

    // Finite ranges keep the overlap local: on average a light's range overlaps a few dozen
    // others of the 10 000, which is what lets a light forest split into independent trees.
    std::size_t overlaps = 0;
    for (std::size_t i = 0; i < scene.lights.size(); ++i)
        for (std::size_t j = i + 1; j < scene.lights.size(); ++j) {
            const vox::Vec3f d = scene.lights[i].position - scene.lights[j].position;
            const float reach = scene.lights[i].range + scene.lights[j].range;
            overlaps += vox::dot(d, d) < reach * reach;
        }
    const double meanOverlaps =
        2.0 * static_cast<double>(overlaps) / static_cast<double>(scene.lights.size());
    EXPECT_LT(meanOverlaps, 100.0);
    RecordProperty("mean_overlaps", std::to_string(meanOverlaps));
}

TEST(ExampleScenes, CityOfOtherSizesScalesItsExtentAndLights) {
    vox::test::ScratchDir dir;
    constexpr int kSide = 3, kBlocks = kSide * kSide;
    const vox::Scene scene = vox::importScene(vox::scenes::writeCityBlock(dir.path(), {}, kSide));
    const vox::Bounds3f bounds = scene.bounds();
    EXPECT_FLOAT_EQ(bounds.max.x, (3 * 40.0f + 4 * 12.0f) / 2);
    EXPECT_FLOAT_EQ(bounds.min.z, -CityBlockFacts::halfExtent(kSide));
    std::map<std::string, int> counts;
    for (const vox::Light& light : scene.lights) {
        ++counts[prefixOf(light.name)];
        expectInside(light, bounds);
    }
    EXPECT_EQ(counts[CityBlockFacts::kStreetLampPrefix], kBlocks * 8);
    EXPECT_EQ(counts[CityBlockFacts::kNeonPrefix], kBlocks);
    EXPECT_EQ(counts[CityBlockFacts::kWindowPrefix], 6240 * kBlocks / 400);  // 140
    EXPECT_EQ(counts[CityBlockFacts::kFloodlightPrefix], 4);  // one building, four facades
    EXPECT_THROW(vox::scenes::writeCityBlock(dir.path(), {}, 0), std::invalid_argument);
    EXPECT_THROW(vox::scenes::writeCityBlock(dir.path(), {}, CityBlockFacts::kMaxBlocksPerSide + 1),
                 std::invalid_argument);
}

TEST(ExampleScenes, GenerationIsByteIdenticalAcrossRuns) {
    vox::test::ScratchDir a, b;
    for (const vox::test::ScratchDir* dir : {&a, &b})
        for (auto storage : {BufferStorage::External, BufferStorage::Glb}) {
            vox::scenes::writeCorridor(dir->path(), storage);
            for (int frame : {0, 1}) vox::scenes::writeCorridorMoving(dir->path(), frame, storage);
            vox::scenes::writeLightGrid(dir->path(), storage);
            vox::scenes::writeCityBlock(dir->path(), storage);
        }
    expectSameFiles(a, b);
    // The two frames differ only in the moving lights; the still corridor is a different file.
    EXPECT_NE(readBytes(a / "corridor_moving_f0.gltf"), readBytes(a / "corridor_moving_f1.gltf"));
    EXPECT_EQ(readBytes(a / "corridor_moving_f0.bin"), readBytes(a / "corridor_moving_f1.bin"));
    EXPECT_EQ(readBytes(a / "corridor.bin"), readBytes(a / "corridor_moving_f0.bin"));
}
