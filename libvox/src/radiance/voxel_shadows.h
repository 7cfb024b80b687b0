// Shadow rays through the solid voxels of level 0 (Gui et al. 2019, 2.2: "trace a ray from the
// voxel towards the light; a solid voxel on the way occludes it").
#pragma once

#include <vox/base/math.h>

#include <array>
#include <cstdint>
#include <span>
#include <vector>

namespace vox::detail {

/// Occupancy of level 0 as a bit grid, with an 8³-block summary to skip empty space.
class SolidGrid {
public:
    SolidGrid(std::uint32_t depth, std::span<const std::array<std::uint32_t, 3>> cells);

    [[nodiscard]] bool solid(std::int64_t x, std::int64_t y, std::int64_t z) const noexcept;
    /// Whether a solid cell other than the one holding @p origin lies on the segment from @p origin
    /// along unit @p dir up to @p maxT (all in level-0 cell units; the grid is [0, 2^depth]³).
    [[nodiscard]] bool occluded(Vec3d origin, Vec3d dir, double maxT) const noexcept;

private:
    [[nodiscard]] bool blockEmpty(std::int64_t x, std::int64_t y, std::int64_t z) const noexcept;
    std::uint32_t resolution_;
    std::uint32_t blocksPerAxis_;
    std::vector<std::uint64_t> bits_;
    std::vector<std::uint8_t> blocks_;
};

}  // namespace vox::detail
