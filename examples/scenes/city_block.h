// A city of 20 × 20 blocks at night with exactly 10 000 punctual lights, for many-light
// clustering (Lightcuts with a light forest) at scale: street lamps (spots pointing down) on both
// sides of every street, lit windows and neon signs (points) on the facades, and floodlights
// (spots pointing up) at the foot of the tallest towers. Buildings are boxes of varied heights,
// taller towards the centre, on sidewalk slabs over a ground plane.
#pragma once

#include "gltf_builder.h"

#include <array>
#include <cstddef>
#include <filesystem>

namespace vox::scenes {

/// Facts about the generated city that tests (and the Lightcuts acceptance) assert against.
/// Every light has a finite range (see kCutoffIlluminance), so that far-apart lights never
/// overlap and a light forest splits into many independent trees.
struct CityBlockFacts {
    static constexpr int kBlocksPerSide = 20;
    static constexpr int kBlocks = kBlocksPerSide * kBlocksPerSide;  ///< 400
    static constexpr float kLotSize = 40.0f;                         ///< a block's lot, square
    static constexpr float kStreetWidth = 12.0f;  ///< 2 m sidewalk + 8 m road + 2 m sidewalk
    static constexpr float kSidewalkWidth = 2.0f, kSidewalkHeight = 0.15f;
    /// Half the width of a city of @p blocksPerSide lots and blocksPerSide + 1 streets (the outer
    /// ones included) per side.
    static constexpr float halfExtent(int blocksPerSide) {
        return (static_cast<float>(blocksPerSide) * kLotSize +
                static_cast<float>(blocksPerSide + 1) * kStreetWidth) /
               2;
    }
    /// The default city spans x, z ∈ [-526, 526] (halfExtent(kBlocksPerSide)).
    static constexpr float kHalfExtent =
        (kBlocksPerSide * kLotSize + (kBlocksPerSide + 1) * kStreetWidth) / 2;
    /// Largest city writeCityBlock makes: 80 × 80 blocks, 4.17 km across.
    static constexpr int kMaxBlocksPerSide = 80;
    static constexpr float kGroundThickness = 0.2f;
    static constexpr float kFloorHeight = 3.5f;
    static constexpr int kMaxFloors = 30;
    static constexpr float kMaxBuildingHeight = kMaxFloors * kFloorHeight + 0.5f;  ///< 105.5 m

    // The split of the 10 000 lights (light names start with these prefixes, then ".").
    static constexpr int kStreetLamps =
        kBlocks * 4 * 2;  ///< 3 200 spots: 2 per side of every block, on its sidewalk
    static constexpr int kNeonSigns = kBlocks;  ///< 400 points: one per block, ground floor
    static constexpr int kFloodlights =
        40 * 4;  ///< 160 spots: one per facade of the 40 tallest buildings
    static constexpr int kWindows =
        6240;  ///< points: lit windows chosen among all buildings' upper floors
    static constexpr int kLights = kStreetLamps + kNeonSigns + kFloodlights + kWindows;
    static_assert(kLights == 10000);
    static constexpr const char* kStreetLampPrefix = "StreetLamp";
    static constexpr const char* kWindowPrefix = "Window";
    static constexpr const char* kNeonPrefix = "Neon";
    static constexpr const char* kFloodlightPrefix = "Floodlight";

    /// Street lamps: heads 8 m above the road, 1.1 m out over it, cones pointing straight down.
    static constexpr float kLampHeight = 8.0f;
    static constexpr float kLampInnerCone = 0.6f, kLampOuterCone = 1.0f;  ///< radians
    static constexpr float kLampMaxIntensity = 2400.0f;  ///< candela (1 600, 2 000 or 2 400)
    /// Everything a lamp's cone reaches above the ground lies within h / cos(outer) = 14.81 m;
    /// beyond that its contribution is zero (well under 1 % of its peak, which ∛100 · h = 37 m
    /// would already give).
    static constexpr float kStreetLampRange = 14.9f;
    /// One cut-off for every other light: 1 % of the brightest street lamp's peak illuminance on
    /// the road (2 400 cd / (8 m)²). Window, neon and floodlight ranges are where I / d² falls
    /// to it, √(I / 0.375), rounded up to 0.1 m: 7.4 – 11 m (windows), 17.9 – 22 m (neon),
    /// 89.5 m (floodlights).
    static constexpr float kCutoffIlluminance =
        kLampMaxIntensity / (100 * kLampHeight * kLampHeight);  ///< 0.375 lx

    /// Each street lamp is a node with a lamp-post mesh (pole and arm, 24 triangles); other
    /// geometry: a ground box, 400 sidewalk slabs and 1 – 4 buildings per block (boxes).
    static constexpr std::size_t kLampPostTriangles = 24;
    static constexpr std::size_t kTriangleBudget = 200000;
};

static_assert(CityBlockFacts::halfExtent(CityBlockFacts::kBlocksPerSide) ==
              CityBlockFacts::kHalfExtent);

/// Writes "city_block.gltf" (+ .bin, or "city_block.glb") into @p directory; returns its path.
/// @p blocksPerSide (1 … kMaxBlocksPerSide) other than kBlocksPerSide makes a city of that many
/// blocks per side, as wide as CityBlockFacts::halfExtent says, with the street lamps and neon
/// signs of every block and the windows and floodlights of the default city per block (rounded
/// down; at least one floodlit building); the facts' counts hold for the default only.
/// @throws std::invalid_argument for a block count out of range.
std::filesystem::path writeCityBlock(const std::filesystem::path& directory,
                                     BufferStorage storage = BufferStorage::External,
                                     int blocksPerSide = CityBlockFacts::kBlocksPerSide);

}  // namespace vox::scenes
