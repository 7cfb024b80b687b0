// The surface voxelizer in pieces, so that an octree can be built a part of space at a time:
// triangles are binned into the cells of a coarse level (the cell level), each cell's subtree is
// built on its own, and the subtrees of consecutive cells (in Morton order) are joined under a
// voxel of any level down to the cell level: the root for the whole octree, or a partition voxel
// for one partition of it. Joining is a tree reduction, so a voxel's values do not depend on
// which cells were built together.
#pragma once

#include "contours.h"
#include "voxel_attributes.h"
#include "../util/huge_pages.h"

#include <vox/octree.h>
#include <vox/util/progress.h>

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <vector>

namespace vox::detail {

/// The level the voxelizer bins triangles into for leaf depth @p depth: 4 (4096 cells to build
/// in parallel), or the default partition level where that is deeper (at most 10, so that cell
/// codes fit 32 bits), so that every partition is a run of whole cells.
[[nodiscard]] std::uint32_t cellLevel(std::uint32_t depth);

/// One cell's subtree, as built. Its arrays are copied into storage shared by the cells one
/// thread built in one SurfaceVoxelizer::buildCells call (on huge pages, rather than a vector per
/// cell and level: the cells' outputs are most of a build's fresh memory), which the last of those
/// cells frees.
struct CellSubtree {
    std::uint32_t code = 0;                        ///< Morton code of the cell at the cell level
    bool occupied = false;                         ///< false: rounding left no voxel in it
    std::shared_ptr<const HugePageArena> storage;  ///< where the arrays below are
    std::vector<std::span<const std::uint8_t>> masks;  ///< levels cell … depth − 1
    std::vector<std::span<const std::uint32_t>>
        contours;  ///< levels cell … depth (the cell's own entry empty)
    std::vector<std::span<const std::uint64_t>>
        attributes;  ///< levels cell … depth (the cell's own entry empty)
    std::vector<LeafMaterial> leafMaterials;
    AttributeSums sums;  ///< with attributes: the cell's
};

/// Voxels of one level given by their Morton codes (ascending) and attribute sums, and the
/// levels above them up to a root level: masks and sums per level, as SparseOctree orders them.
struct UpperLevels {
    std::vector<std::vector<std::uint8_t>> masks;  ///< [l − root] for levels root … level − 1
    std::vector<std::vector<AttributeSums>>
        sums;  ///< [l − root] for levels root … level (with sums)
    std::vector<std::vector<std::uint32_t>> codes;  ///< [l − root] for levels root … level
};
/// Groups @p codes of voxels at @p level by their ancestors up to @p rootLevel (all of them must
/// share the ancestor there). @p sums: empty, or one per code.
[[nodiscard]] UpperLevels buildUpperLevels(std::vector<std::uint32_t> codes,
                                           std::vector<AttributeSums> sums, std::uint32_t level,
                                           std::uint32_t rootLevel);

class SurfaceVoxelizer {
public:
    /// Prepares the selected triangles and bins them into the cells.
    /// @throws InvalidDataError if the scene has no (static) triangles; UsageError for a bad depth.
    SurfaceVoxelizer(const Scene& scene, const SurfaceVoxelizeOptions& options);

    [[nodiscard]] const RootCube& cube() const noexcept { return cube_; }
    [[nodiscard]] std::uint32_t depth() const noexcept { return depth_; }
    [[nodiscard]] std::uint32_t cellLevel() const noexcept { return cellLevel_; }
    /// Cells holding triangles, in Morton order.
    [[nodiscard]] std::size_t cellCount() const noexcept { return cells_.size(); }
    [[nodiscard]] std::uint32_t cellCode(std::size_t cell) const { return cells_[cell].code; }
    /// Triangles binned into the cell.
    [[nodiscard]] std::size_t cellTriangles(std::size_t cell) const {
        return cells_[cell].end - cells_[cell].begin;
    }
    /// The summed area of the cell's triangles in leaf voxels², each shared equally by the cells
    /// it was binned into: about its leaf count, for estimating a build's memory.
    [[nodiscard]] double cellArea(std::size_t cell) const { return cells_[cell].area; }

    /// Builds the subtrees of cells [first, last) in parallel.
    [[nodiscard]] std::vector<CellSubtree> buildCells(std::size_t first, std::size_t last,
                                                      Progress* progress) const;

    /// Joins the subtrees of consecutive cells that share their ancestor at @p rootLevel (≤ the
    /// cell level) into an octree whose level 0 is that ancestor (the whole octree for level 0;
    /// its cube is only set then). An empty octree (leafDepth 0) if no cell is occupied.
    /// @p rootSums: with attributes, receives the root's sums.
    [[nodiscard]] SparseOctree join(std::vector<CellSubtree>&& cells, std::uint32_t rootLevel,
                                    AttributeSums* rootSums = nullptr) const;

private:
    struct Cell {
        std::uint32_t code;
        std::size_t begin, end;  // range in pairs_
        double area;
    };
    const Scene& scene_;
    SurfaceVoxelizeOptions options_;
    RootCube cube_;
    std::uint32_t depth_ = 0, cellLevel_ = 0;
    std::vector<BoxTestTriangle> triangles_;
    // With contours, per triangle what the contour fit reads of its normal (TriangleNormals).
    std::vector<double> normalLengths_;
    std::vector<Vec3d> unitNormals_;
    std::vector<QuantisedNormal> quantisedNormals_;
    std::optional<AttributeSampler> sampler_;
    std::vector<std::uint64_t> pairs_;  // (cell Morton code << 32 | triangle), sorted
    std::vector<Cell> cells_;
};

}  // namespace vox::detail
