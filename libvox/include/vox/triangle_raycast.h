/// @file triangle_raycast.h
/// @brief A BVH triangle ray caster: the reference the octree renders are compared against
/// (geometric truth in the tests, the peer in bench/), and the rays of the path-traced radiance
/// reference (castSurface).
#pragma once

#include <vox/raycast.h>
#include <vox/scene.h>

#include <cstdint>
#include <limits>
#include <vector>

namespace vox {

/// The nearest triangle along a ray, unshaded: what a caller that shades or samples the surface
/// itself (the path-traced reference) needs. Intersection runs in single precision, so the hit
/// point is accurate to a few float ulps of the scene's coordinates; offset secondary rays
/// accordingly.
struct SurfaceHit {
    bool hit = false;
    double t =
        std::numeric_limits<double>::infinity();  ///< distance along the (unit) ray direction
    std::uint32_t mesh = 0;                       ///< index into Scene::meshes
    std::uint32_t triangle = 0;  ///< triangle within the mesh (indices 3·triangle … 3·triangle + 2)
    Vec3d barycentric{0, 0,
                      0};  ///< weights of the triangle's three corners at the hit, summing to 1
    /// Unit normal of the triangle's winding (counter-clockwise = front), not turned towards the
    /// ray: callers that treat surfaces as two-sided decide the side from dot(geometricNormal, d).
    Vec3d geometricNormal{0, 0, 0};
    std::uint32_t iterations = 0;  ///< BVH node boxes tested
};

/// Casts rays against a scene's triangles (world units) through a bounding volume hierarchy.
class TriangleRayCaster {
public:
    /// @p includeDynamic: also the meshes flagged dynamic (voxelizeSurface leaves them out by
    /// default). @p scene must outlive the caster: hits are shaded from its materials.
    explicit TriangleRayCaster(const Scene& scene, bool includeDynamic = false);
    /// Nearest hit; CastHit::level is 0, iterations counts BVH node boxes tested. The hit's colour
    /// and shading normal come from the material (as the voxel filter evaluates it), textures
    /// filtered over @p footprintAngle × t (a pixel's footprint; 0: finest mip level).
    [[nodiscard]] CastHit cast(const Ray& ray,
                               double tMax = std::numeric_limits<double>::infinity(),
                               double footprintAngle = 0) const;
    /// Nearest hit with t < @p tMax, without shading (the same traversal as cast()). Thread-safe.
    [[nodiscard]] SurfaceHit castSurface(
        const Ray& ray, double tMax = std::numeric_limits<double>::infinity()) const;
    [[nodiscard]] std::size_t triangleCount() const noexcept { return triangles_.size(); }

private:
    struct Triangle {
        Vec3f v0, e1, e2;
    };
    /// A node of the binary tree the build makes (and collapses into WideNodes).
    struct Node {
        float lo[3], hi[3];
        std::uint32_t first;  // leaf: first triangle; inner: right child (left child is this + 1)
        std::uint32_t count;  // leaf: triangle count; inner: 0
    };
    /// Up to eight children's boxes, one array per axis and bound with a lane per child, so that
    /// one ray tests all of them at once.
    struct alignas(32) WideNode {
        float lo[3][8], hi[3][8];
        std::uint32_t child[8];  // kLeafChild | packet, or a WideNode
        std::uint32_t count;     // children in use, the first ones
    };
    /// A leaf's triangles (at most four), one lane each; unused lanes have no area.
    struct alignas(16) TrianglePacket {
        float v0[3][4], e1[3][4], e2[3][4];
        std::uint32_t triangle[4];  // index into triangles_, or Nearest::kNone
    };
    static constexpr std::uint32_t kLeafChild = 0x80000000u;
    /// The BVH traversal cast() and castSurface() share: the nearest triangle (index into
    /// triangles_, or kNone) and its Möller–Trumbore t, u, v.
    struct Nearest {
        static constexpr std::uint32_t kNone = 0xFFFFFFFFu;
        std::uint32_t triangle = kNone;
        float t = 0, u = 0, v = 0;
        std::uint32_t iterations = 0;
    };
    [[nodiscard]] Nearest nearest(const Ray& ray, double tMax) const;
    /// nearest() with the children's boxes tested by @p Boxes (four lanes twice, or eight).
    template <class Boxes>
    [[nodiscard]] Nearest traverse(const Ray& ray, double tMax) const;
    /// traverse() with AVX2 boxes, built for AVX2 (called only where the CPU has it).
    [[nodiscard]] Nearest traverseAvx2(const Ray& ray, double tMax) const;
    /// Per triangle during the build: its centroid and bounds; order: the triangles as the
    /// leaves will hold them; nodes: the binary tree.
    struct BuildInput {
        std::vector<std::uint32_t> order;
        std::vector<Vec3f> centroids;
        std::vector<Bounds3f> bounds;
        std::vector<Node> nodes;
    };
    std::uint32_t build(std::uint32_t first, std::uint32_t count, std::uint32_t depth,
                        BuildInput& input);
    /// The WideNode standing for binary node @p node's subtree; returns its index.
    std::uint32_t collapse(const std::vector<Node>& nodes, std::uint32_t node);
    /// The child code of binary node @p node: a packet for a leaf, else collapse().
    std::uint32_t childCode(const std::vector<Node>& nodes, std::uint32_t node);
    const Scene& scene_;
    std::vector<Triangle> triangles_;
    std::vector<std::uint64_t> sources_;  // per triangle: mesh << 32 | triangle in mesh
    std::vector<WideNode> wide_;          // wide_[0] is the root
    std::vector<TrianglePacket> packets_;
    bool avx2_ = false;  // the CPU runs traverseAvx2
};

/// One primary ray per pixel against the triangles, in parallel, into the same buffers as
/// renderEsvo.
[[nodiscard]] RenderBuffers renderTriangles(const TriangleRayCaster& caster,
                                            const PinholeCamera& camera);

}  // namespace vox
