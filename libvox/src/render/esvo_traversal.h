// The state the ray caster's traversal starts from and stops in, shared by the one-ray loop
// (EsvoRayCaster::cast) and the eight-ray loop (esvo_raycast_avx2.cpp), so that both begin and
// finish a ray with the same code and differ only in how they run the loop between.
#pragma once

#include <vox/base/math.h>
#include <vox/raycast.h>

#include <cstddef>
#include <cstdint>

namespace vox::detail {

/// The traversal's finest scale: the octree lives in [1,2]³, whose floats have 23 fraction bits.
inline constexpr int kScaleMax = 23;

/// A ray in the octree's mirrored [1,2]³ frame, ready for the loop: t(x) = x·coef − bias along
/// each axis, with every direction component negative after mirroring.
struct TraversalStart {
    float px, py, pz;  ///< origin, octree coordinates (unmirrored)
    float dx, dy,
        dz;  ///< direction, octree coordinates (unmirrored), no component of magnitude below 2^-23
    float txCoef, tyCoef, tzCoef, txBias, tyBias, tzBias;
    float tMin, tMax;  ///< the active span inside the root cube
    int octantMask;    ///< the mirrored axes' bits are 0
    int idx;           ///< first child of the root, mirrored
    float posX, posY, posZ;
    float lodCoef;  ///< a pixel's footprint per unit t, root-cube units; 0: no level-of-detail cut
};

/// Where the loop stopped: at a hit voxel or outside the root.
struct TraversalStop {
    bool hit = false;
    float t = 0;    ///< the span start at the hit
    int scale = 0;  ///< scale of the hit voxel's parent's children
    float scaleExp2 = 0;
    float posX = 0, posY = 0, posZ = 0;  ///< the hit voxel's mirrored corner
    std::uint32_t parent = 0;            ///< word of the hit voxel's parent descriptor
    int hitSlot = 0;                     ///< the hit voxel's child slot, unmirrored
    std::uint32_t level = 0;
    float slabT = -1;  ///< where a contour last raised the span's start
    Vec3f slabNormal{0, 0, 0};
    std::uint32_t iterations = 0;
};

/// The eight-lane loop, for EsvoRayCaster::castMany.
struct LaneCaster {
    /// Whether this CPU and build can run cast().
    static bool available();
    /// castMany's contract; needs available(), a pool of fewer than 2^31 words and no beam.
    static void cast(const EsvoRayCaster& caster, const Ray* rays, const float* tStarts,
                     std::size_t count, const CastOptions& options, CastHit* hits);
};

}  // namespace vox::detail
