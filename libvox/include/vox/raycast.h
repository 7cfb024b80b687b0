/// @file raycast.h
/// @brief The CPU reference ray caster for .esvo octrees (after Laine & Karras, section 6):
/// PUSH/ADVANCE/POP over the octree placed at [1,2]³ with mirrored axes, a stack per scale,
/// POP by the highest differing bit, and a level-of-detail cut by the voxel's projected size.
/// It walks the blocks an esvo::EsvoPool holds, following far pointers across slices, and stops
/// at the finest loaded level where deeper slices are not loaded. renderEsvo() can add the beam
/// optimisation (section 6.2): a conservative coarse pass of cones through pixel-block corners
/// that gives every pixel's ray a start distance, leaving the image bit for bit the same.
#pragma once

#include <vox/formats/esvo_reader.h>
#include <vox/base/camera.h>
#include <vox/base/math.h>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <vector>

namespace vox {

struct CastOptions {
    /// Stop where a voxel is smaller than this many radians as seen along the ray (the pixel
    /// footprint); 0 disables the level-of-detail cut.
    double lodAngle = 0;
    std::uint32_t maxLevel =
        std::numeric_limits<std::uint32_t>::max();  ///< treat this level as leaves
    double tMax = std::numeric_limits<double>::infinity();
    bool contours = true;  ///< intersect voxels' contours (off: cubes only)
    /// Beam optimisation, fine pass: the traversal's active span starts at this distance instead
    /// of 0, so the ray skips the empty space before it. Whenever tStart is strictly below the
    /// distance at which the ray hits with tStart = 0 (or the ray misses), the result (hit, t,
    /// level, normal) is bitwise the same; only the iterations drop. A coarse cast (beamRadius)
    /// gives such a start for every ray of its beam.
    float tStart = 0;
    /// Beam optimisation, coarse pass: > 0 turns cast() into a conservative cone trace for the
    /// rays with the same origin whose unit directions lie within this distance (the chord, about
    /// the angle in radians) of this ray's. Each voxel is treated as its cube dilated by
    /// beamRadius·t at distance t (plus the fine caster's rounding), contours are ignored, and
    /// the cast stops at the first dilated voxel where a fine ray with the same lodAngle and
    /// maxLevel could stop. CastHit::t is then a start distance strictly below the hit distance
    /// of every ray of the beam (+inf and hit = false if none of them can hit); normal is 0 and
    /// iterations counts the nodes expanded.
    double beamRadius = 0;
    /// Look up the colour and shading normal of the voxel hit (CastHit::color, shadingNormal),
    /// inheriting from ancestors where the file omits a value. Ignored for files without them.
    bool attributes = false;
};

struct CastHit {
    bool hit = false;
    float t = std::numeric_limits<float>::infinity();  ///< distance along the ray, world units
    std::uint32_t level = 0;                           ///< level of the voxel hit
    std::uint32_t iterations = 0;                      ///< loop iterations the traversal took
    Vec3f normal{0, 0, 0};         ///< world normal of the cube face the ray entered
    bool hasAttributes = false;    ///< color and shadingNormal hold the surface's attributes
    std::uint32_t color = 0;       ///< esvo::packColor word: sRGB-encoded RGB, coverage in alpha
    Vec3f shadingNormal{0, 0, 0};  ///< unit world shading normal (the filtered one, not the face's)
};

namespace detail {
struct TraversalStart;
struct TraversalStop;
struct LaneCaster;
}  // namespace detail

/// Casts rays against the slices an EsvoPool has loaded. Thread-safe; the pool must not change
/// while rays are cast.
class EsvoRayCaster {
public:
    explicit EsvoRayCaster(const esvo::EsvoPool& pool);
    [[nodiscard]] CastHit cast(const Ray& ray, const CastOptions& options) const;
    /// Casts @p count rays with the same options except the start distance: ray i starts at
    /// max(options.tStart, tStarts[i]) (@p tStarts may be null). hits[i] is bit for bit what
    /// cast() returns for ray i; where the CPU allows, eight rays are traversed at a time.
    /// options.beamRadius must be 0.
    void castMany(const Ray* rays, const float* tStarts, std::size_t count,
                  const CastOptions& options, CastHit* hits) const;
    /// World size of a leaf voxel's edge.
    [[nodiscard]] double leafVoxelSize() const noexcept { return leafSize_; }
    [[nodiscard]] std::uint32_t leafDepth() const noexcept {
        return pool_.reader().header().leafDepth;
    }

private:
    friend struct detail::LaneCaster;
    [[nodiscard]] CastHit castBeam(const Ray& ray, const CastOptions& options) const;
    /// cast()'s prologue: false if the ray misses the root cube (or starts past its span).
    [[nodiscard]] bool start(const Ray& ray, const CastOptions& options,
                             detail::TraversalStart& s) const;
    /// cast()'s epilogue for a hit: the entry face's normal and the attributes, which read the
    /// traversal stack's parent words at stackParent[scale · stackStride].
    [[nodiscard]] CastHit finish(const detail::TraversalStart& s, const detail::TraversalStop& stop,
                                 const CastOptions& options, const std::uint32_t* stackParent,
                                 std::size_t stackStride) const;

    const esvo::EsvoPool& pool_;
    double a_[12];          // world → root cube [0,1]³, row-major 3×4
    double unitScale_ = 1;  // cube-root of |det|: world length → root-cube length
    double rowNorm_ = 1;  // largest row norm of the linear part: bounds |(A·v)_i| by rowNorm_·|v|
    double leafSize_ = 1;
};

/// What render() produced, one entry per pixel, row 0 at the top.
struct RenderBuffers {
    int width = 0, height = 0;
    std::vector<float> depth;   ///< distance along the ray; +inf where it missed
    std::vector<Vec3f> normal;  ///< world normals; 0 where it missed
    std::vector<std::uint32_t> iterations;
    std::vector<std::uint8_t> level;   ///< level hit; 0 where it missed
    std::vector<std::uint32_t> color;  ///< CastHit::color; 0 where it missed or there is none
    /// CastHit::shadingNormal (unit); the zero vector where the ray missed or there is none, which
    /// is what hasAttributes() tests (a colour word can legitimately be 0).
    std::vector<Vec3f> shadingNormal;
    std::uint64_t hits = 0;
    double seconds = 0;  ///< wall time of the casting, coarse pass included
    // Beam optimisation (renderEsvo with beam > 0); iterations above are the fine pass's.
    int beam = 0;                        ///< block size; 0: single pass
    std::uint64_t coarseRays = 0;        ///< block-corner rays cast by the coarse pass
    std::uint64_t coarseIterations = 0;  ///< nodes the coarse rays expanded, summed
    double coarseSeconds = 0;            ///< wall time of the coarse pass (part of seconds)
};

/// True where pixel @p i hit a voxel with colour and normal.
[[nodiscard]] inline bool hasAttributes(const RenderBuffers& buffers, std::size_t i) {
    const Vec3f& n = buffers.shadingNormal[i];
    return n.x != 0 || n.y != 0 || n.z != 0;
}

/// Phong shading under a headlight (a light at the eye) of every hit pixel with attributes:
/// ambient 0.1 + diffuse 0.9 × albedo, plus a white specular lobe (exponent 32, strength 0.25),
/// from RenderBuffers::color and shadingNormal and the camera's rays. Returns linear RGB per pixel
/// (black where the ray missed).
[[nodiscard]] std::vector<Vec3f> shadeHeadlight(const RenderBuffers& buffers,
                                                const PinholeCamera& camera);

/// Linear RGB per pixel of RenderBuffers::color (black where the ray missed).
[[nodiscard]] std::vector<Vec3f> albedoImage(const RenderBuffers& buffers);

/// The post-process filter's radius per pixel: half the edge of the voxel hit, in pixels at its
/// distance (0 where the ray missed). Half, so that the disc spans one voxel and turns the
/// blocks into a smooth ramp (the measurement behind it: docs/internals/esvo-writer.md).
[[nodiscard]] std::vector<float> filterRadii(const RenderBuffers& buffers,
                                             const EsvoRayCaster& caster,
                                             const PinholeCamera& camera);

/// Laine & Karras' post-process filter (section 6.3) that hides the blockiness of per-voxel
/// attributes: each pixel is blurred over a disc whose radius @p radius gives (in pixels, from
/// filterRadii; ≤ 1: no blur, 0 for misses), sampled by an ordered kernel
/// of 96 samples (point-symmetric pairs) up to 24 pixels out; walking outwards, the radius shrinks
/// to any neighbour's smaller one, so blur stops at silhouettes and at finer voxels, and each
/// sample's weight fades out over the last pixel of the radius.
[[nodiscard]] std::vector<Vec3f> postProcessFilter(const std::vector<Vec3f>& image,
                                                   const std::vector<float>& radius, int width,
                                                   int height);

/// Casts one primary ray per pixel through @p cast, in parallel (TBB).
[[nodiscard]] RenderBuffers renderPixels(const PinholeCamera& camera,
                                         const std::function<CastHit(const Ray&)>& cast);

/// Casts one primary ray per pixel against the octree, in parallel (TBB).
/// @p beam > 1 turns on the beam optimisation with beam × beam pixel blocks: a coarse pass casts
/// one cone (CastOptions::beamRadius) through every block corner, then each pixel's ray starts
/// (CastOptions::tStart) at the smallest start of its block's four corners. The buffers are
/// bitwise the same as without it except iterations. 0 (or 1): one pass. Throws UsageError for
/// a beam below 0 or above 64.
[[nodiscard]] RenderBuffers renderEsvo(const EsvoRayCaster& caster, const PinholeCamera& camera,
                                       const CastOptions& options, int beam = 0);

}  // namespace vox
