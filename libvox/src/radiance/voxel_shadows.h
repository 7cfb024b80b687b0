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

/// Shadow rays of nearby voxels decided together. A cluster's voxels are grouped by aligned
/// blocks of the grid at two sizes (4 and 2 cells) and by the axis direction their normal is
/// closest to. For a group and a light, one test decides the rays of every member at once where
/// it can:
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
    /// One cluster of voxels (e.g. of the direct light): its groups, and what their tests
    /// decided per light and side. Used by one thread at a time.
    class Verdicts {
    public:
        /// The groups of the voxels @p members (indices into the cells of @p groups): only
        /// these voxels may be asked about with it.
        Verdicts(const ShadowRayGroups& groups, std::span<const std::uint32_t> members);

    private:
        friend class ShadowRayGroups;
        struct Group {
            // Per side (+1, −1), over the members whose origin cell is empty on that side: their
            // ray origins, and where their rays end relative to the light (side × normal).
            static constexpr double kInf = std::numeric_limits<double>::infinity();
            std::array<Vec3d, 2> originLo{Vec3d{kInf, kInf, kInf}, Vec3d{kInf, kInf, kInf}};
            std::array<Vec3d, 2> originHi{Vec3d{-kInf, -kInf, -kInf}, Vec3d{-kInf, -kInf, -kInf}};
            std::array<Vec3d, 2> endLo = originLo, endHi = originHi;
        };
        /// The groups of member voxel @p voxel, coarsest first (indices into groups_).
        [[nodiscard]] const std::array<std::uint32_t, kLevels>& groupsOf(std::size_t voxel);
        /// The verdict slot of group @p group for light @p light on side @p side (0: +1,
        /// 1: −1); 0 until set.
        [[nodiscard]] std::uint8_t& at(std::uint32_t group, std::uint32_t light, std::size_t side);

        std::vector<Group> groups_;
        // (voxel, its groups), ascending by voxel; the last one asked about, as a point's
        // queries come together.
        std::vector<std::pair<std::uint32_t, std::array<std::uint32_t, kLevels>>> members_;
        std::size_t last_ = 0;
        std::vector<std::uint32_t> rowOf_;  // per light: 1 + its row, 0: none yet
        std::vector<std::uint8_t> rows_;    // per row: 2 sides × the groups
    };

    /// @p cells: the voxels; @p normals: their mean normals (the rays leave the voxel centre one
    /// normal along it, on the side facing the light); @p lights: the light positions in cell
    /// units (non-finite for lights without one).
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
    const SolidGrid& grid_;
    std::span<const std::array<std::uint32_t, 3>> cells_;
    std::vector<Vec3f> normals_;
    std::vector<Vec3d> lights_;
    std::vector<std::uint8_t> originEmpty_;  // per voxel: bit 0 side +1, bit 1 side −1
};

}  // namespace vox::detail
