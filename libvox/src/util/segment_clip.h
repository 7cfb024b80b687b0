// Clipping a ray segment to an axis-aligned cube, shared by the voxel walks of the shadow rays
// (the bake's solid grid and the tiled bake's scene occupancy), which must sample the same
// points.
#pragma once

#include <vox/base/math.h>

#include <algorithm>
#include <cstdint>
#include <limits>
#include <utility>

namespace vox::detail {

/// Narrows [@p t0, @p t1] to the part of origin + t·dir inside [0, size)³ on every axis (slab
/// test; an axis with dir 0 keeps the segment only if origin lies in [0, size) on it). Returns
/// false when nothing is left (t0 ≥ t1 after clipping).
inline bool clipSegmentToCube(const Vec3d& origin, const Vec3d& dir, double size, double& t0,
                              double& t1) {
    for (int axis = 0; axis < 3; ++axis) {
        if (dir[axis] == 0) {
            if (origin[axis] < 0 || origin[axis] >= size) return false;
            continue;
        }
        double a = (0 - origin[axis]) / dir[axis], b = (size - origin[axis]) / dir[axis];
        if (a > b) std::swap(a, b);
        t0 = std::max(t0, a);
        t1 = std::min(t1, b);
    }
    return t0 < t1;
}

/// The ray parameter at which origin + t·dir leaves the cube [lo, lo + size) (each axis), for the
/// voxel walks' next step; +inf if dir is 0.
inline double exitOfCube(const Vec3d& origin, const Vec3d& dir, const std::int64_t (&lo)[3],
                         std::int64_t size) {
    double exit = std::numeric_limits<double>::infinity();
    for (int axis = 0; axis < 3; ++axis) {
        if (dir[axis] > 0)
            exit = std::min(exit, (double(lo[axis] + size) - origin[axis]) / dir[axis]);
        else if (dir[axis] < 0)
            exit = std::min(exit, (double(lo[axis]) - origin[axis]) / dir[axis]);
    }
    return exit;
}

}  // namespace vox::detail
