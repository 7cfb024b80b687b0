// The light-grid scene of the Lightcuts experiments (the Cubes scene of the many-light clustering
// paper's Table 1): 16 × 16 point lights spread evenly above 8 × 8 cubes of varying heights on a
// floor, all with the same small range so that each light overlaps only its neighbours.
#pragma once

#include "gltf_builder.h"

#include <array>
#include <cstddef>
#include <filesystem>

namespace vox::scenes {

/// Facts about the generated grid that tests (and the Lightcuts acceptance) assert against.
struct LightGridFacts {
    static constexpr int kLightsPerSide = 16;
    static constexpr int kLights = kLightsPerSide * kLightsPerSide;  ///< 256
    static constexpr float kLightSpacing = 2.0f;  ///< lights at x, z = -15, -13, …, 15
    static constexpr float kLightHeight = 4.0f;
    /// The same for every light (as in the paper): a floor point is within range of about 7
    /// lights (a disc of 3 m radius), a 3 m tall cube's top of about 19; lights more than 10 m
    /// apart never overlap, so the light forest splits into many small trees.
    static constexpr float kLightRange = 5.0f;
    static constexpr float kMinIntensity = 20.0f, kMaxIntensity = 30.0f;  ///< candela
    static constexpr int kCubesPerSide = 8;
    static constexpr int kCubes = kCubesPerSide * kCubesPerSide;  ///< 64
    static constexpr float kCubePitch = 4.0f,
                           kCubeSize = 2.0f;  ///< centres at x, z = -14, -10, …, 14
    static constexpr float kMinCubeHeight = 0.5f, kMaxCubeHeight = 3.0f;
    static constexpr float kFloorHalfSize = 17.0f, kFloorThickness = 0.2f;
    static constexpr std::size_t kTriangles = 12 * (1 + kCubes);
    /// Scene bounds (geometry only; the lights are above them, at kLightHeight).
    static constexpr std::array<float, 3> kBoundsMin{-kFloorHalfSize, -kFloorThickness,
                                                     -kFloorHalfSize};
    static constexpr std::array<float, 3> kBoundsMax{kFloorHalfSize, kMaxCubeHeight,
                                                     kFloorHalfSize};
};

/// Writes "light_grid.gltf" (+ .bin, or "light_grid.glb") into @p directory; returns its path.
/// With @p lightsPerSide other than LightGridFacts::kLightsPerSide the lights are that many per
/// side over the same span (spacing kLightSpacing × kLightsPerSide / lightsPerSide), with the
/// same height and range, and the file is "light_grid_<lights>.gltf": 32 gives 1024 lights 1 m
/// apart, about 28 of which reach a floor point. The geometry is the same for every count.
std::filesystem::path writeLightGrid(const std::filesystem::path& directory,
                                     BufferStorage storage = BufferStorage::External,
                                     int lightsPerSide = LightGridFacts::kLightsPerSide);

}  // namespace vox::scenes
