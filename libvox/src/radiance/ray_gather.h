// Bounce light gathered by rays against the scene's triangles (RadianceBakeOptions::BounceGather::
// Rays): each static voxel casts a stratified, cosine-distributed set of rays over the hemisphere
// of its mean normal from a point of its own surface, and each ray reads the radiance that the
// level-0 voxel holding its hit leaves. Slower than cones, and it does not leak through thin walls
// or read light beyond the volume's cube; the cones still give the ambient occlusion.
#pragma once

#include <vox/base/math.h>
#include <vox/octree.h>
#include <vox/scene.h>
#include <vox/triangle_raycast.h>
#include <vox/util/progress.h>

#include <cstdint>
#include <span>
#include <vector>

namespace vox::detail {

class RayGather {
public:
    /// @p leaves: the bake's static level-0 voxels in ascending Morton order of their cells, in a
    /// grid of cells of edge @p cell from @p origin with 2^@p depth cells per axis. @p strata: the
    /// rays per voxel are strata², ≥ 1. The scene and the leaves must outlive the gather.
    RayGather(const Scene& scene, std::span<const LeafMaterial> leaves, Vec3d origin, double cell,
              std::uint32_t depth, std::uint32_t strata);

    /// Per leaf, the irradiance its rays gather from @p radiance (per leaf, what it leaves in every
    /// direction): π times the rays' mean. A ray that hits nothing, the back of a triangle, or
    /// where no leaf is, gathers nothing. Same inputs, same result, whatever the thread count. The
    /// first call remembers where each ray hit (up to a fixed number of bytes), and later calls
    /// read that instead of tracing again.
    /// @p progress, if given, advances by one per leaf.
    [[nodiscard]] std::vector<Vec3f> gather(std::span<const Vec3f> radiance,
                                            Progress* progress = nullptr);

private:
    /// Sets leaf @p i's Morton code and ray origin.
    void placeOrigin(std::size_t i, double halfDiagonal);
    /// The leaf the ray from @p from along unit @p dir hits first, or kNone (also where it hits
    /// the back of a triangle).
    [[nodiscard]] std::uint32_t trace(Vec3d from, Vec3d dir) const;
    /// The leaf holding world point @p p, or kNone.
    [[nodiscard]] std::uint32_t leafAt(Vec3d p) const noexcept;
    static constexpr std::uint32_t kNone = 0xFFFFFFFFu;

    std::span<const LeafMaterial> leaves_;
    TriangleRayCaster caster_;
    Vec3d origin_;
    double cell_;
    std::int64_t cells_;
    std::vector<std::uint64_t> codes_;  ///< per leaf: morton3 of its cell (ascending)
    std::vector<Vec3d> from_;           ///< per leaf: where its rays start
    std::vector<Vec3d> pattern_;        ///< the rays' directions about +z
    std::vector<std::uint32_t> hits_;   ///< per leaf and ray: the leaf hit (kNone: none)
    bool hitsCached_ = false;
};

}  // namespace vox::detail
