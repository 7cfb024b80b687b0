// Bounce light gathered by rays against the scene's triangles (RadianceBakeOptions::BounceGather::
// Rays): each static voxel casts a stratified, cosine-distributed set of rays over the hemisphere
// of its mean normal from a point of its own surface, and each ray reads the radiance that the
// level-0 voxel holding its hit leaves on the side it hits. Slower than cones, and it does not leak
// through thin walls or read light beyond the volume's cube; the cones still give the ambient
// occlusion.
#pragma once

#include <vox/base/math.h>
#include <vox/octree.h>
#include <vox/scene.h>
#include <vox/triangle_raycast.h>
#include <vox/util/progress.h>

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace vox::detail {

/// The bytes of kept ray hits a gather may hold by default.
inline constexpr std::size_t kRayGatherHitBudget = std::size_t{512} << 20;

/// Sets the bytes of kept ray hits that gathers tracing from now on may hold (beyond them every
/// bounce traces again, and BounceGather::Auto picks cones; a gather's light is the same either
/// way); returns the budget before. For tests.
std::size_t setRayGatherHitBudget(std::size_t bytes) noexcept;

class RayGather {
public:
    /// @p leaves: the bake's static level-0 voxels in ascending Morton order of their cells, in a
    /// grid of cells of edge @p cell from @p origin with 2^@p depth cells per axis; fewer than
    /// 2^31 of them. @p strata: the rays per voxel are strata², ≥ 1. The scene and the leaves must
    /// outlive the gather.
    RayGather(const Scene& scene, std::span<const LeafMaterial> leaves, Vec3d origin, double cell,
              std::uint32_t depth, std::uint32_t strata);

    /// Whether the hits of @p rays rays from each of @p leaves leaves fit in the bytes a gather
    /// keeps them in, so that it traces them once (else it traces them again for every bounce).
    [[nodiscard]] static bool keepsHits(std::size_t leaves, std::uint32_t rays) noexcept;

    /// A leaf that rays reach on both sides, and the unit normal of each side as the rays saw it.
    struct TwoSidedLeaf {
        std::uint32_t leaf = 0;
        Vec3d front{0, 0, 1};  ///< the side of the triangles facing along the leaf's mean normal
        Vec3d back{0, 0, -1};  ///< the side of those facing away from it
    };

    /// Traces every voxel's rays (remembering each ray's hit where that fits in a fixed number of
    /// bytes, so that gather() only reads them) and returns, in ascending order of leaf, the
    /// leaves that some ray reaches on their back side: on a triangle that faces away from the
    /// leaf's mean normal (both sides of a thin wall in one voxel). Each side's normal is the
    /// normalised sum of the normals of the triangles the rays hit on it (the mean normal, or its
    /// opposite, where they cancel or none was hit). Then traces those leaves' back sides' own
    /// rays, about the back's normal. Call once, before gather(). Same result whatever the thread
    /// count. @p progress, if given, advances by one per leaf.
    [[nodiscard]] std::vector<TwoSidedLeaf> trace(Progress* progress = nullptr);

    /// The irradiance the rays gather (π times the mean of what they read), per leaf about its
    /// mean normal, and per leaf trace() returned (in its order) on its back side.
    struct Irradiance {
        std::vector<Vec3f> leaves;
        std::vector<Vec3f> backs;
    };

    /// A ray reads @p front[j] where it reaches leaf j's front side (a triangle facing along the
    /// leaf's mean normal or across it) and @p back[j] where it reaches its back side (read only
    /// at the leaves trace() returned; @p back may be empty when it returned none). A ray that
    /// hits nothing, the back of a triangle, or where no leaf is, reads nothing. Requires
    /// trace(). Same inputs, same result, whatever the thread count. @p progress, if given,
    /// advances by one per leaf.
    [[nodiscard]] Irradiance gather(std::span<const Vec3f> front, std::span<const Vec3f> back,
                                    Progress* progress = nullptr) const;

private:
    /// Where rays about unit @p n start for leaf @p v: where the line along @p n through the
    /// cell's centre first meets a surface inside the cell, or outside it on @p n's side of the
    /// centre, else the centre; just off it along @p n.
    [[nodiscard]] Vec3d rayOrigin(const LeafMaterial& v, Vec3d n) const;
    /// Per leaf, whether a ray reached its back side, and the fixed-point sums of the hit
    /// triangles' normals on its front (x, y, z) and back (x, y, z): integer sums do not depend
    /// on the order the threads add in.
    struct NormalSums {
        std::atomic<bool> reachedFromBehind{false};
        std::array<std::atomic<std::int64_t>, 6> sums{};
        /// Adds unit @p normal to the front's sums (@p back false) or the back's.
        void add(bool back, Vec3d normal);
    };
    /// Traces the rays of entries [@p first, @p last) (the next after those traced before),
    /// keeping their hits with @p keep, and where @p seen is given, records each hit on a back
    /// side in seen[leaf] (reached from behind, its normal), and with @p fronts each hit on a
    /// front side too.
    void traceEntries(std::size_t first, std::size_t last, bool keep, NormalSums* seen, bool fronts,
                      Progress* progress);
    /// Adds to @p seen the normals of the kept hits on the front sides of the leaves reached from
    /// behind (traceEntries without fronts records only the backs: the sums of every leaf's
    /// front cost a cache miss per hit, and only two-sided leaves need them).
    void sumTwoSidedFronts(NormalSums* seen) const;
    /// What the ray from @p from along unit @p dir reaches first: a leaf index, with kBackSide set
    /// where the triangle hit faces away from that leaf's mean normal; kNone where it hits nothing,
    /// the back of a triangle, or no leaf. @p normal, if given, receives the triangle's normal.
    [[nodiscard]] std::uint32_t castRay(Vec3d from, Vec3d dir, Vec3d* normal = nullptr) const;
    /// Entry @p e's rays, in the pattern's order: what castRay answers for each, kept or traced
    /// again. @p out holds one per ray.
    void entryHits(std::size_t e, std::span<std::uint32_t> out) const;
    /// Keeps castRay's answer @p hit for entry @p e's k-th ray (into zeroed words).
    void keepHit(std::size_t e, std::size_t k, std::uint32_t hit);
    /// A castRay answer as the hitBits_ bits kept, and back.
    [[nodiscard]] std::uint64_t pack(std::uint32_t hit) const noexcept;
    [[nodiscard]] std::uint32_t unpack(std::uint64_t code) const noexcept;
    /// The words of entry @p e's kept hits.
    [[nodiscard]] const std::uint64_t* entryWords(std::size_t e) const;
    /// The k-th ray's direction of the pattern in @p frame.
    [[nodiscard]] Vec3d direction(const OrthonormalFrame& frame, std::size_t k) const;
    /// The leaf holding world point @p p, or kNone.
    [[nodiscard]] std::uint32_t leafAt(Vec3d p) const noexcept;
    static constexpr std::uint32_t kNone = 0xFFFFFFFFu;
    static constexpr std::uint32_t kBackSide = 0x80000000u;

    std::span<const LeafMaterial> leaves_;
    TriangleRayCaster caster_;
    Vec3d origin_;
    double cell_;
    std::int64_t cells_;
    std::vector<std::uint64_t> codes_;  ///< per leaf: morton3 of its cell (ascending)
    /// Where leafAt searches: the leaves whose codes have top bits b (codes >> bucketShift_) are
    /// codes_[bucketStart_[b], bucketStart_[b + 1]); about one leaf per bucket.
    std::vector<std::uint32_t> bucketStart_;
    unsigned bucketShift_ = 0;
    /// Per entry (a gather's set of rays): each leaf's front, then each two-sided leaf's back.
    std::vector<Vec3d> from_;        ///< where its rays start
    std::vector<Vec3d> normal_;      ///< what they are cosine-distributed about (a leaf's:
                                     ///< its mean normal, which castRay reads: compact, unlike
                                     ///< leaves_)
    std::vector<Vec3d> pattern_;     ///< the rays' directions about +z
    unsigned hitBits_ = 0;           ///< bits of a kept hit: the leaf's, then the side's
    std::uint64_t noLeaf_ = 0;       ///< the leaf bits all set: no leaf hit
    std::size_t wordsPerEntry_ = 0;  ///< 64-bit words holding one entry's kept hits
    /// Per entry and ray, castRay's answer, for the first keptEntries_ entries (the rest are
    /// traced again): the leaves' entries, and the back sides'.
    std::vector<std::uint64_t> leafHitWords_, backHitWords_;
    std::size_t keptEntries_ = 0;
    bool traced_ = false;
};

}  // namespace vox::detail
