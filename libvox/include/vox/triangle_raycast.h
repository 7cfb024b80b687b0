/// @file triangle_raycast.h
/// @brief A BVH triangle ray caster: the reference the octree renders are compared against
/// (geometric truth in the tests, the peer in bench/).
#pragma once

#include <vox/raycast.h>
#include <vox/scene.h>

#include <cstdint>
#include <vector>

namespace vox {

/// Casts rays against a scene's triangles (world units) through a bounding volume hierarchy.
class TriangleRayCaster {
public:
    /// @p includeDynamic: also the meshes flagged dynamic (voxelizeSurface leaves them out by
    /// default). @p scene must outlive the caster: hits are shaded from its materials.
    explicit TriangleRayCaster(const Scene& scene, bool includeDynamic = false);
    /// Nearest hit; CastHit::level is 0, iterations counts BVH nodes visited. The hit's colour and
    /// shading normal come from the material (as the voxel filter evaluates it), textures
    /// filtered over @p footprintAngle × t (a pixel's footprint; 0: finest mip level).
    [[nodiscard]] CastHit cast(const Ray& ray, double tMax = std::numeric_limits<double>::infinity(), double footprintAngle = 0) const;
    [[nodiscard]] std::size_t triangleCount() const noexcept { return triangles_.size(); }

private:
    struct Triangle {
        Vec3f v0, e1, e2;
    };
    struct Node {
        float lo[3], hi[3];
        std::uint32_t first;  // leaf: first triangle; inner: right child (left child is this + 1)
        std::uint32_t count;  // leaf: triangle count; inner: 0
    };
    std::uint32_t build(std::uint32_t first, std::uint32_t count, std::vector<Vec3f>& centroids);
    const Scene& scene_;
    std::vector<Triangle> triangles_;
    std::vector<std::uint64_t> sources_;  // per triangle: mesh << 32 | triangle in mesh
    std::vector<Node> nodes_;
};

/// One primary ray per pixel against the triangles, in parallel, into the same buffers as renderEsvo.
[[nodiscard]] RenderBuffers renderTriangles(const TriangleRayCaster& caster, const PinholeCamera& camera);

}  // namespace vox
