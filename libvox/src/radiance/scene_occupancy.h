// The whole scene's static occupancy at the finest level of a tiled bake, for the shadow rays that
// leave a tile's kept box: a cell is solid where a static triangle touches its closed cube, the
// voxelizer's own test (octree/triangle_box.h) on the voxelizer's own leaf coordinates, so that a
// tile's ray sees exactly the cells the single-volume bake's ray sees. Nothing is stored per cell:
// the triangles are binned in coarse cells and the fine cells a ray crosses are tested on the fly.
#pragma once

#include "../octree/triangle_box.h"
#include "voxel_shadows.h"

#include <vox/base/math.h>
#include <vox/octree.h>
#include <vox/scene.h>

#include <array>
#include <cstdint>
#include <optional>
#include <vector>

namespace vox {

class SceneOccupancy {
public:
    /// The static triangles of @p scene in the leaf units of @p cube at @p depth (the cube is
    /// [0, 2^depth]³), binned in the cells of level @p binDepth (≤ depth, ≤ 10).
    SceneOccupancy(const Scene& scene, const RootCube& cube, std::uint32_t depth,
                   std::uint32_t binDepth);

    /// Whether a solid cell other than @p skip lies on the points origin + t·dir, t in [@p t0,
    /// @p t1] (leaf units, unit @p dir): SolidGrid::occluded's walk over the whole scene's grid.
    [[nodiscard]] bool occluded(Vec3d origin, Vec3d dir, double t0, double t1,
                                std::array<std::int64_t, 3> skip) const;
    /// Whether a static triangle touches leaf cell (@p x, @p y, @p z).
    [[nodiscard]] bool solid(std::int64_t x, std::int64_t y, std::int64_t z) const;

private:
    /// The triangles of the bin holding leaf cell @p c, as a range of binTriangles_.
    [[nodiscard]] std::pair<std::size_t, std::size_t> binOf(const std::int64_t c[3]) const;
    [[nodiscard]] bool cellSolid(const std::int64_t c[3],
                                 std::pair<std::size_t, std::size_t> range) const;

    std::uint32_t depth_, binDepth_, shift_;
    std::vector<detail::BoxTestTriangle> triangles_;
    std::optional<detail::SolidGrid> bins_;  // which bins hold a triangle: empty space skipped
    std::vector<std::uint64_t> binCodes_;    // Morton codes of the non-empty bins, ascending
    std::vector<std::size_t> binStart_;      // per non-empty bin, into binTriangles_ (+ end)
    std::vector<std::uint32_t> binTriangles_;
};

}  // namespace vox
