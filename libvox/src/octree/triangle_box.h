// Triangle / axis-aligned box overlap by the separating-axis theorem (Akenine-Möller 2001):
// the 3 box normals, the triangle normal and the 9 edge cross products. Closed sets: a triangle
// touching the box's boundary overlaps it. Double precision, with a separation margin of 1e-9
// relative to the quantities compared, so that rounding never splits a touching contact
// differently between a cube and its children (coordinates of non-power-of-two scenes are not
// exact in leaf units). Degenerate (zero-area) triangles still work: a zero normal or zero cross
// product gives an axis that never separates.
#pragma once

#include <vox/math.h>

#include <algorithm>
#include <array>
#include <vector>
#include <cmath>
#include <cstdint>

namespace vox::detail {

/// True if [lo, hi] lies beyond [−r, r] by more than the rounding margin.
[[nodiscard]] inline bool separated(double lo, double hi, double r, double magnitude) {
    const double margin = 1e-9 * (r + magnitude);
    return lo > r + margin || hi < -r - margin;
}

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
        if (separated(lo, hi, h, std::max(std::abs(lo), std::abs(hi)))) return false;
    }
    // Triangle plane.
    const Vec3d& n = tri.normal;
    const double r = h * (std::abs(n.x) + std::abs(n.y) + std::abs(n.z));
    const double s = dot(n, a);
    if (separated(s, s, r, std::abs(s))) return false;
    // Edge × axis.
    const Vec3d edges[3] = {b - a, d - b, a - d};
    for (const Vec3d& e : edges) {
        // e × x = (0, e.z, −e.y), e × y = (−e.z, 0, e.x), e × z = (e.y, −e.x, 0)
        {
            const double pa = e.z * a.y - e.y * a.z, pb = e.z * b.y - e.y * b.z, pd = e.z * d.y - e.y * d.z;
            const double rad = h * (std::abs(e.z) + std::abs(e.y));
            if (separated(std::min({pa, pb, pd}), std::max({pa, pb, pd}), rad, std::abs(pa) + std::abs(pb) + std::abs(pd))) return false;
        }
        {
            const double pa = -e.z * a.x + e.x * a.z, pb = -e.z * b.x + e.x * b.z, pd = -e.z * d.x + e.x * d.z;
            const double rad = h * (std::abs(e.z) + std::abs(e.x));
            if (separated(std::min({pa, pb, pd}), std::max({pa, pb, pd}), rad, std::abs(pa) + std::abs(pb) + std::abs(pd))) return false;
        }
        {
            const double pa = e.y * a.x - e.x * a.y, pb = e.y * b.x - e.x * b.y, pd = e.y * d.x - e.x * d.y;
            const double rad = h * (std::abs(e.y) + std::abs(e.x));
            if (separated(std::min({pa, pb, pd}), std::max({pa, pb, pd}), rad, std::abs(pa) + std::abs(pb) + std::abs(pd))) return false;
        }
    }
    return true;
}

/// The children of the closed cube with centre @p c and half-extent @p h that @p tri overlaps,
/// as a slot mask (bit 0 of a slot: +x half, bit 1: +y, bit 2: +z). The same test as
/// triangleOverlapsCube for each child, sharing the triangle's projections among the eight.
[[nodiscard]] inline std::uint32_t childOverlapMask(const BoxTestTriangle& tri, Vec3d c, double h) {
    const double q = 0.5 * h;  // children's half-extent; their centres are c ± q per axis
    const Vec3d a = tri.v0 - c, b = tri.v1 - c, d = tri.v2 - c;
    std::uint32_t mask = 0xFF;
    static constexpr std::uint32_t kLowHalf[3] = {0x55, 0x33, 0x0F};  // slots with the axis bit clear
    for (int axis = 0; axis < 3; ++axis) {
        const double lo = std::min({a[axis], b[axis], d[axis]});
        const double hi = std::max({a[axis], b[axis], d[axis]});
        const double magnitude = std::max(std::abs(lo), std::abs(hi));
        if (separated(lo + q, hi + q, q, magnitude)) mask &= ~kLowHalf[axis];
        if (separated(lo - q, hi - q, q, magnitude)) mask &= kLowHalf[axis];
        if (mask == 0) return 0;
    }
    // Child s's centre projects onto axis A at q·(±A.x ± A.y ± A.z); its radius is q·|A|₁. The
    // child is not separated on A while that centre lies within the triangle's projection grown
    // by the radius and the margin (the same comparison as separated(), solved for the centre).
    const auto testAxis = [&](Vec3d axisVector, double pmin, double pmax, double magnitude) {
        const double ax = q * axisVector.x, ay = q * axisVector.y, az = q * axisVector.z;
        const double r = std::abs(ax) + std::abs(ay) + std::abs(az);
        const double grow = r + 1e-9 * (r + magnitude);
        const double low = pmin - grow, high = pmax + grow;
        for (std::uint32_t bits = mask; bits; bits &= bits - 1) {
            const auto slot = static_cast<std::uint32_t>(__builtin_ctz(bits));
            const double cp = (slot & 1u ? ax : -ax) + (slot & 2u ? ay : -ay) + (slot & 4u ? az : -az);
            if (cp < low || cp > high) mask &= ~(1u << slot);
        }
    };
    const double s = dot(tri.normal, a);
    testAxis(tri.normal, s, s, std::abs(s));
    const Vec3d edges[3] = {b - a, d - b, a - d};
    for (const Vec3d& e : edges) {
        if (mask == 0) return 0;
        for (const Vec3d axisVector : {Vec3d{0, e.z, -e.y}, Vec3d{-e.z, 0, e.x}, Vec3d{e.y, -e.x, 0}}) {
            const double pa = dot(axisVector, a), pb = dot(axisVector, b), pd = dot(axisVector, d);
            testAxis(axisVector, std::min({pa, pb, pd}), std::max({pa, pb, pd}), std::abs(pa) + std::abs(pb) + std::abs(pd));
        }
    }
    return mask;
}

/// Clips a triangle to the cube [−½, ½]³ (Sutherland–Hodgman), appending the polygon to @p out.
inline void clipToUnitCube(const std::array<Vec3d, 3>& triangle, std::vector<Vec3d>& out, std::array<Vec3d, 12>& bufferA,
                    std::array<Vec3d, 12>& bufferB) {
    bool inside = true;
    for (const Vec3d& p : triangle) inside = inside && std::abs(p.x) <= 0.5 && std::abs(p.y) <= 0.5 && std::abs(p.z) <= 0.5;
    if (inside) {  // common for fine triangles in coarse voxels
        out.insert(out.end(), triangle.begin(), triangle.end());
        return;
    }
    Vec3d* a = bufferA.data();
    Vec3d* b = bufferB.data();
    std::size_t n = 3;
    std::copy(triangle.begin(), triangle.end(), a);
    for (int axis = 0; axis < 3 && n > 0; ++axis)
        for (double side : {-1.0, 1.0}) {
            // Keep side·p[axis] ≤ ½.
            std::size_t m = 0;
            for (std::size_t i = 0; i < n && m + 2 <= bufferA.size(); ++i) {
                const Vec3d& p = a[i];
                const Vec3d& q = a[i + 1 == n ? 0 : i + 1];
                const double dp = side * p[axis] - 0.5, dq = side * q[axis] - 0.5;
                if (dp <= 0) b[m++] = p;
                if ((dp < 0 && dq > 0) || (dp > 0 && dq < 0)) b[m++] = p + (q - p) * (dp / (dp - dq));
            }
            n = m;
            std::swap(a, b);
            if (n == 0) break;
        }
    out.insert(out.end(), a, a + n);
}

}  // namespace vox::detail
