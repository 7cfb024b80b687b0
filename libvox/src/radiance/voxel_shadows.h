// Shadow rays through the solid voxels of level 0 (Gui et al. 2019, 2.2: "trace a ray from the
// voxel towards the light; a solid voxel on the way occludes it").
#pragma once

#include <vox/base/math.h>
#include <vox/many_lights.h>

#include <array>
#include <cstdint>
#include <limits>
#include <span>
#include <utility>
#include <vector>

namespace vox::detail {

/// Occupancy of level 0 as a bit grid, with an 8³-block summary to skip empty space.
class SolidGrid {
public:
    SolidGrid(std::uint32_t depth, std::span<const std::array<std::uint32_t, 3>> cells);

    [[nodiscard]] bool solid(std::int64_t x, std::int64_t y, std::int64_t z) const noexcept;
    /// Whether a solid cell other than the one holding @p origin lies on the segment from @p origin
    /// along unit @p dir up to @p maxT (all in level-0 cell units; the grid is [0, 2^depth]³).
    /// @p hit, if given, receives the first such cell.
    [[nodiscard]] bool occluded(Vec3d origin, Vec3d dir, double maxT,
                                std::array<std::int64_t, 3>* hit = nullptr) const noexcept;
    /// Whether every cell whose closed cube meets the box [@p lo, @p hi] is solid (and in the
    /// grid).
    [[nodiscard]] bool allSolid(Vec3d lo, Vec3d hi) const noexcept;
    /// Whether the closed cube of some solid cell meets the box [@p lo, @p hi] (cell units).
    [[nodiscard]] bool anySolid(Vec3d lo, Vec3d hi) const noexcept;
    /// Whether no solid cell meets any segment from a point of the box [@p fromLo, @p fromHi] to a
    /// point of the box [@p toLo, @p toHi] (cell units): then occluded(a, (b − a) / |b − a|,
    /// |b − a|) is false for every such a whose cell is empty and every such b. Conservative: it
    /// may answer false where every segment is clear (the segments are covered by boxes, one per
    /// cell of length along the longest axis, padded against rounding).
    [[nodiscard]] bool beamClear(Vec3d fromLo, Vec3d fromHi, Vec3d toLo, Vec3d toHi) const noexcept;
    /// Whether every segment from a point a of the box [@p fromLo, @p fromHi] to a point b of
    /// [@p toLo, @p toHi] starts before layer @p layer along @p axis (the cells with that index on
    /// the axis), ends past it, and runs through it inside solid cells only: then occluded(a,
    /// (b − a) / |b − a|, |b − a|) is true for each (the segment spends at least a cell's length
    /// in solid cells, none of them its first). Conservative, as beamClear.
    [[nodiscard]] bool layerBlocks(Vec3d fromLo, Vec3d fromHi, Vec3d toLo, Vec3d toHi, int axis,
                                   std::int64_t layer) const noexcept;

private:
    [[nodiscard]] bool blockEmpty(std::int64_t x, std::int64_t y, std::int64_t z) const noexcept;
    std::uint32_t resolution_;
    std::uint32_t blocksPerAxis_;
    std::vector<std::uint64_t> bits_;
    std::vector<std::uint8_t> blocks_;
};

/// Shadow rays of nearby voxels decided together. The voxels are grouped by aligned blocks of the
/// grid at two sizes (4 and 2 cells) and by the axis direction their normal is closest to.
/// For a group and a light, one test decides the rays of every member at once where it can:
/// - *clear* (beamClear): no solid cell in a set of boxes holding every segment from a member's
///   ray origin towards the light;
/// - *blocked* (layerBlocks): every such segment crosses one layer of the grid (the layer, along
///   some axis, of the cell that stopped a member's own ray) where all the cells it can cross
///   are solid, for at least a cell's length.
/// Otherwise the voxel tries its next finer group, and at last traces its own ray. Both tests
/// are conservative, so the answer is exactly occluded()'s. A voxel whose ray starts in a solid
/// cell (which its ray ignores) never uses the groups, nor does a ray without a finite length.
class ShadowRayGroups {
    // Blocks of 4 and 2 cells: 8-cell blocks failed their tests more often than they answered
    // (docs/internals/lighting.md).
    static constexpr int kLevels = 2;

public:
    /// What the group tests decided for one cluster of voxels (e.g. of the direct light), per
    /// group of its voxels, light and side; one cluster at a time, on one thread.
    class Verdicts {
    public:
        /// For the voxels @p members of @p groups (indices into the cells). Holds, per light
        /// asked about, a slot for every group numbered between the members' first and last
        /// groups of each level: few beyond the members' own where they are an octree node's
        /// voxels (clusterVoxelPoints), whose groups are numbered contiguously.
        Verdicts(const ShadowRayGroups& groups, std::span<const std::uint32_t> members);
        /// The verdict slot of group @p group, a member's group of level @p level (0: the
        /// coarsest), for light @p light on side @p side (0: +1, 1: −1); 0 until set.
        [[nodiscard]] std::uint8_t& at(int level, std::uint32_t group, std::uint32_t light,
                                       std::size_t side);

    private:
        // Each level's range of the members' group indices, and where its slots start.
        std::array<std::uint32_t, kLevels> first_{}, offset_{};
        std::size_t rowSize_ = 0;           // slots per light: 2 sides × the levels' ranges
        std::vector<std::uint32_t> rowOf_;  // per light: 1 + its row, 0: none yet
        std::vector<std::uint8_t> rows_;
    };

    /// @p cells: the voxels; @p normals: their mean normals (the rays leave the voxel centre one
    /// normal along it, on the side facing the light); @p lights: the light positions in cell
    /// units (non-finite for lights without one). Throws UsageError unless every cell lies below
    /// 1024 on each axis (a volume of depth ≤ 10).
    ShadowRayGroups(const SolidGrid& grid, std::span<const std::array<std::uint32_t, 3>> cells,
                    std::vector<Vec3f> normals, std::vector<Vec3d> lights);

    /// The origin of voxel @p voxel's shadow ray on @p side (+1: along its normal, −1: against).
    [[nodiscard]] Vec3d origin(std::size_t voxel, int side) const noexcept;
    /// Whether voxel @p voxel's shadow ray on @p side towards light @p light (unit direction
    /// @p dir, length @p maxT, in cell units) is occluded: grid.occluded(origin(voxel, side), dir,
    /// maxT), answered by the voxel's groups where they can (their verdicts kept in @p verdicts,
    /// those of a cluster the voxel is a member of; @p counts counts the group tests run and the
    /// rays they answered).
    [[nodiscard]] bool occluded(std::size_t voxel, std::uint32_t light, int side, Vec3d dir,
                                double maxT, Verdicts& verdicts,
                                SharedVisibilityStats& counts) const;

private:
    struct Group {
        // Per side (+1, −1), over the members whose origin cell is empty on that side: their ray
        // origins, and where their rays end relative to the light (side × normal); in float,
        // rounded outwards, as the groups take as much memory as the voxels. Empty: +∞ … −∞.
        static constexpr float kInf = std::numeric_limits<float>::infinity();
        std::array<Vec3f, 2> originLo{Vec3f{kInf, kInf, kInf}, Vec3f{kInf, kInf, kInf}};
        std::array<Vec3f, 2> originHi{Vec3f{-kInf, -kInf, -kInf}, Vec3f{-kInf, -kInf, -kInf}};
        std::array<Vec3f, 2> endLo = originLo, endHi = originHi;
    };
    const SolidGrid& grid_;
    std::span<const std::array<std::uint32_t, 3>> cells_;
    std::vector<Vec3f> normals_;
    std::vector<Vec3d> lights_;
    std::vector<Group> groups_;
    std::vector<std::array<std::uint32_t, kLevels>> groupOf_;  // per voxel, coarsest first
    std::vector<std::uint8_t> originEmpty_;  // per voxel: bit 0 side +1, bit 1 side −1
};

}  // namespace vox::detail
