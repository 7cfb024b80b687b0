// The corridor scenes of the Lightcuts experiments (Corridor1 and Corridor2 of the many-light
// clustering paper's Table 1): a long, closed corridor lit by 30 ceiling lamps, with partition
// walls, open doors, pillars and crates that occlude, and, in the moving variant, two more lights
// that travel along it from frame to frame.
#pragma once

#include "gltf_builder.h"

#include <array>
#include <cstddef>
#include <filesystem>

namespace vox::scenes {

/// Facts about the generated corridor that tests (and the Lightcuts acceptance) assert against.
/// Interior x ∈ [-30, 30] (the corridor's axis), y ∈ [0, 3] (floor to ceiling), z ∈ [-1.5, 1.5];
/// walls, floor and ceiling are 0.2 thick outside it.
struct CorridorFacts {
    static constexpr int kLamps =
        30;  ///< static point lights, one every kLampSpacing along the ceiling
    static constexpr int kMovingLights =
        2;  ///< corridor-moving only: a lantern and a searchlight, flagged dynamic
    static constexpr float kLength = 60.0f, kWidth = 3.0f, kHeight = 3.0f, kWall = 0.2f;
    static constexpr float kLampSpacing = 2.0f;  ///< lamps at x = -29, -27, …, 29, z = 0
    static constexpr float kLampHeight = 2.8f;   ///< 0.2 below the ceiling, under a housing
    /// ∛100 × 2.8 m: where a lamp's illuminance on the floor (I·h/d³) is 1 % of its peak I/h²
    /// beneath it. Lamps further apart than 2 × 13 m do not overlap: the forest splits.
    static constexpr float kLampRange = 13.0f;
    static constexpr float kLampMinIntensity = 30.0f, kLampMaxIntensity = 60.0f;  ///< candela
    /// Partition walls across the corridor, each with a centred 1.2 m × 2.2 m doorway and an
    /// open door leaf; the moving lights pass through the doorways.
    static constexpr std::array<float, 4> kPartitions{-18.0f, -6.0f, 6.0f, 18.0f};
    static constexpr std::size_t kBoxes =
        80;  ///< shell 6, partitions 12, doors 4, pillars 20, lamp housings 30, crates 8
    static constexpr std::size_t kTriangles = 12 * kBoxes;
    static constexpr std::array<float, 3> kBoundsMin{-30.2f, -0.2f, -1.7f};
    static constexpr std::array<float, 3> kBoundsMax{30.2f, 3.2f, 1.7f};

    /// The moving lights' light (and node) names, in the order they are written after the lamps.
    static constexpr std::array<const char*, 2> kMovingNames{"MovingLantern", "MovingSearchlight"};
    static constexpr float kLanternHeight = 1.5f;
    static constexpr float kLanternRange = 7.0f;  ///< ∛100 × 1.5 m
    static constexpr float kSearchlightHeight = 2.0f;
    static constexpr float kSearchlightRange = 9.3f;  ///< ∛100 × 2.0 m
};

/// Facts about the LED-strip corridor (corridor_strips): the corridor's geometry (lamp housings
/// included) lit instead of by the 30 lamps by two strips of small point lights under the
/// ceiling, every kStripSpacing along x at z = ±kStripOffset, leaving out the places where a
/// partition wall stands. Many ranged lights of similar weight reach every point (about 80 on
/// the floor), with partitions, doors, pillars and crates in the way.
struct CorridorStripFacts {
    static constexpr float kStripSpacing = 0.1f;  ///< lights at x = -29.95, -29.85, …, 29.95
    static constexpr int kSlots = 600;            ///< positions per strip before the gaps
    static constexpr float kStripOffset = 1.0f;   ///< the strips run at z = ±1
    static constexpr float kStripHeight = 2.5f;
    /// No light within this of a partition's centre plane (the partitions are 0.2 thick).
    static constexpr float kPartitionGap = 0.12f;
    static constexpr int kLights = 1184;  ///< 2 × (600 − 4 partitions × 2 slots in the gap)
    static constexpr float kStripRange = 4.0f;
    static constexpr float kMinIntensity = 1.0f, kMaxIntensity = 2.5f;  ///< candela
};

/// Where moving light @p light (0: lantern, 1: searchlight) is at @p frame ≥ 0. Both move at a
/// constant speed along the corridor's axis (z = 0), the lantern +3 m per frame from x = -25, the
/// searchlight -2 m per frame from x = 22, turning back at x = ±28.
[[nodiscard]] std::array<double, 3> corridorMovingLightPosition(int light, int frame);

/// Writes "corridor.gltf" (+ .bin, or "corridor.glb") into @p directory: the corridor with its 30
/// static lamps. Returns the scene file's path.
std::filesystem::path writeCorridor(const std::filesystem::path& directory,
                                    BufferStorage storage = BufferStorage::External);

/// Writes "corridor_strips.gltf" (or .glb): the corridor's geometry with its CorridorStripFacts
/// lights instead of the lamps. Returns the scene file's path.
std::filesystem::path writeCorridorStrips(const std::filesystem::path& directory,
                                          BufferStorage storage = BufferStorage::External);

/// Writes "corridor_moving_f<frame>.gltf" (or .glb): the same corridor and lamps (same bytes for
/// them in every frame) plus the two moving lights at their positions at @p frame (≥ 0).
std::filesystem::path writeCorridorMoving(const std::filesystem::path& directory, int frame,
                                          BufferStorage storage = BufferStorage::External);

}  // namespace vox::scenes
