// Triangle / axis-aligned box overlap by the separating-axis theorem (Akenine-Möller 2001):
// the 3 box normals, the triangle normal and the 9 edge cross products. Closed sets: a triangle
// touching the box's boundary overlaps it. Double precision; degenerate (zero-area) triangles
// still work, because a zero normal or zero cross product gives an axis that never separates.
#pragma once

#include <vox/math.h>

#include <algorithm>
#include <cmath>

namespace vox::detail {

/// A triangle prepared for many box tests.
struct BoxTestTriangle {
    Vec3d v0, v1, v2;
    Vec3d normal;  ///< (v1 − v0) × (v2 − v0), unnormalised
};

[[nodiscard]] inline BoxTestTriangle prepareBoxTest(Vec3d v0, Vec3d v1, Vec3d v2) {
    return {v0, v1, v2, cross(v1 - v0, v2 - v0)};
}

/// True if @p tri intersects the closed box with centre @p c and half-extent @p h (all axes).
[[nodiscard]] inline bool triangleOverlapsCube(const BoxTestTriangle& tri, Vec3d c, double h) {
    const Vec3d a = tri.v0 - c, b = tri.v1 - c, d = tri.v2 - c;
    // Box normals: the triangle's bounding box against the box.
    for (int axis = 0; axis < 3; ++axis) {
        const double lo = std::min({a[axis], b[axis], d[axis]});
        const double hi = std::max({a[axis], b[axis], d[axis]});
        if (lo > h || hi < -h) return false;
    }
    // Triangle plane.
    const Vec3d& n = tri.normal;
    const double r = h * (std::abs(n.x) + std::abs(n.y) + std::abs(n.z));
    const double s = dot(n, a);
    if (s > r || s < -r) return false;
    // Edge × axis.
    const Vec3d edges[3] = {b - a, d - b, a - d};
    for (const Vec3d& e : edges) {
        // e × x = (0, e.z, −e.y), e × y = (−e.z, 0, e.x), e × z = (e.y, −e.x, 0)
        {
            const double pa = e.z * a.y - e.y * a.z, pb = e.z * b.y - e.y * b.z, pd = e.z * d.y - e.y * d.z;
            const double rad = h * (std::abs(e.z) + std::abs(e.y));
            if (std::min({pa, pb, pd}) > rad || std::max({pa, pb, pd}) < -rad) return false;
        }
        {
            const double pa = -e.z * a.x + e.x * a.z, pb = -e.z * b.x + e.x * b.z, pd = -e.z * d.x + e.x * d.z;
            const double rad = h * (std::abs(e.z) + std::abs(e.x));
            if (std::min({pa, pb, pd}) > rad || std::max({pa, pb, pd}) < -rad) return false;
        }
        {
            const double pa = e.y * a.x - e.x * a.y, pb = e.y * b.x - e.x * b.y, pd = e.y * d.x - e.x * d.y;
            const double rad = h * (std::abs(e.y) + std::abs(e.x));
            if (std::min({pa, pb, pd}) > rad || std::max({pa, pb, pd}) < -rad) return false;
        }
    }
    return true;
}

}  // namespace vox::detail
