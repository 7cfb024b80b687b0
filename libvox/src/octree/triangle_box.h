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
#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

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

namespace child_mask {

/// Slots (bit 0 of a slot: +x, bit 1: +y, bit 2: +z) by the sign of their centre's offset along
/// two axes: kBoth[axis pair][s1][s2] (s = 1: the + side).
struct SlotPair {
    std::uint32_t pp, mm, pm, mp;  ///< (+,+), (−,−), (+,−), (−,+)
};
inline constexpr SlotPair kYZ{0xC0, 0x03, 0x0C, 0x30};  // bits 1 and 2
inline constexpr SlotPair kXZ{0xA0, 0x05, 0x0A, 0x50};  // bits 0 and 2
inline constexpr SlotPair kXY{0x88, 0x11, 0x22, 0x44};  // bits 0 and 1

/// The slots of @p pair whose centre projection σ1·u1 + σ2·u2 (σ: ±1 by the slot's bits) lies in
/// [low, high]. The four sums are those the three-term sum ((±u0) + (±u1)) + (±u2) of
/// childOverlapMask's reference form gives when one of its terms is zero: negating an operand or a
/// sum is exact, so ±(u1 + u2) and ±(u1 − u2) are the values it rounds to.
[[nodiscard]] inline std::uint32_t keepPair(double u1, double u2, double low, double high, SlotPair pair) {
    const double w = u1 + u2, v = u1 - u2;
    std::uint32_t keep = 0;
    keep |= ((w >= low) & (w <= high)) ? pair.pp : 0u;
    keep |= ((-w >= low) & (-w <= high)) ? pair.mm : 0u;
    keep |= ((v >= low) & (v <= high)) ? pair.pm : 0u;
    keep |= ((-v >= low) & (-v <= high)) ? pair.mp : 0u;
    return keep;
}

}  // namespace child_mask

/// The children of the closed cube with centre @p c and half-extent @p h that @p tri overlaps,
/// as a slot mask (bit 0 of a slot: +x half, bit 1: +y, bit 2: +z). The same test as
/// triangleOverlapsCube for each child, sharing the triangle's projections among the eight.
///
/// Child s's centre projects onto axis A at q·(±A.x ± A.y ± A.z); its radius is q·|A|₁. The child
/// is not separated on A while that centre lies within the triangle's projection grown by the
/// radius and the margin (the same comparison as separated(), solved for the centre). Every
/// quantity is evaluated exactly as in the straightforward form (one projection per axis and
/// child, axes in the order box, plane, edges; tests/test_triangle_box.cpp keeps it): terms that
/// are products with a zero axis component are left out, which changes no value but the sign of a
/// zero, and no comparison sees that sign.
///
/// The nine edge axes are not evaluated where they cannot separate any child still in the mask:
/// a child that holds a vertex of the triangle (as the rounded vertices a, b, d below; closed
/// boxes) meets it, so the two overlap on every axis exactly, and with every coordinate within
/// 1024·h of the centre the rounding of the projections (≲ 2¹²·2⁻⁵³ of the child's radius) stays
/// far below the separation margin (10⁻⁹ of it): no edge axis can separate that child. Only the
/// plane axis is always evaluated, as its normal comes from the unrounded vertices.
[[nodiscard]] inline std::uint32_t childOverlapMask(const BoxTestTriangle& tri, Vec3d c, double h) {
    const double q = 0.5 * h;  // children's half-extent; their centres are c ± q per axis
    const Vec3d a = tri.v0 - c, b = tri.v1 - c, d = tri.v2 - c;
    std::uint32_t mask = 0xFF;
    static constexpr std::uint32_t kLowHalf[3] = {0x55, 0x33, 0x0F};  // slots with the axis bit clear
    bool near = true;  // every coordinate within 1024·h of the centre
    // Box normals; separated(lo ± q, hi ± q, q, magnitude) for the two halves, without branches.
    const auto boxAxis = [&](double pa, double pb, double pd, std::uint32_t lowHalf) {
        const double lo = std::min(std::min(pa, pb), pd);
        const double hi = std::max(std::max(pa, pb), pd);
        const double magnitude = std::max(std::abs(lo), std::abs(hi));
        const double margin = 1e-9 * (q + magnitude);
        const bool lowSeparated = (lo + q > q + margin) | (hi + q < -q - margin);
        const bool highSeparated = (lo - q > q + margin) | (hi - q < -q - margin);
        mask &= (lowSeparated ? ~lowHalf : 0xFFu) & (highSeparated ? lowHalf : 0xFFu);
        near = near & (magnitude <= 1024 * h);
    };
    boxAxis(a.x, b.x, d.x, kLowHalf[0]);
    boxAxis(a.y, b.y, d.y, kLowHalf[1]);
    boxAxis(a.z, b.z, d.z, kLowHalf[2]);
    if (mask == 0) return 0;
    // Triangle plane: child s's centre projects at ((±ax) + (±ay)) + (±az).
    const Vec3d& n = tri.normal;
    const double s = dot(n, a);
    const double ax = q * n.x, ay = q * n.y, az = q * n.z;
    const double planeR = std::abs(ax) + std::abs(ay) + std::abs(az);
    const double planeGrow = planeR + 1e-9 * (planeR + std::abs(s));
    const double planeLow = s - planeGrow, planeHigh = s + planeGrow;
    std::uint32_t certain = 0;  // children holding a vertex
    if ((mask & (mask - 1)) == 0) {
        // One child left (common where triangles are small): its centre and its vertices alone.
        const std::uint32_t slot = static_cast<std::uint32_t>(__builtin_ctz(mask));
        const double cp = ((slot & 1u ? ax : -ax) + (slot & 2u ? ay : -ay)) + (slot & 4u ? az : -az);
        if (!(cp >= planeLow && cp <= planeHigh)) return 0;
        if (near) {
            const auto inChild = [&](const Vec3d& p) {
                return std::abs(p.x) <= h && std::abs(p.y) <= h && std::abs(p.z) <= h && (slot & 1u ? p.x >= 0 : p.x <= 0) &&
                       (slot & 2u ? p.y >= 0 : p.y <= 0) && (slot & 4u ? p.z >= 0 : p.z <= 0);
            };
            if (inChild(a) || inChild(b) || inChild(d)) return mask;
        }
    } else {
        // The eight centres: ±v7, ±v3, ±v6, ±v5 (slots 7/0, 3/4, 6/1, 5/2).
        const double t1 = ax + ay, t2 = ay - ax;  // partial sums of slots x+y+ and x−y+
        const double v7 = t1 + az, v3 = t1 - az, v6 = t2 + az, v5 = az - t2;
        const auto in = [&](double v) { return static_cast<std::uint32_t>((v >= planeLow) & (v <= planeHigh)); };
        mask &= in(v7) << 7 | in(-v7) | in(v3) << 3 | in(-v3) << 4 | in(v6) << 6 | in(-v6) << 1 | in(v5) << 5 | in(-v5) << 2;
        if (mask == 0) return 0;
        if (near) {
            for (const Vec3d& p : {a, b, d}) {
                const bool inCube = (std::abs(p.x) <= h) & (std::abs(p.y) <= h) & (std::abs(p.z) <= h);
                const std::uint32_t xs = (p.x <= 0 ? 0x55u : 0u) | (p.x >= 0 ? 0xAAu : 0u);
                const std::uint32_t ys = (p.y <= 0 ? 0x33u : 0u) | (p.y >= 0 ? 0xCCu : 0u);
                const std::uint32_t zs = (p.z <= 0 ? 0x0Fu : 0u) | (p.z >= 0 ? 0xF0u : 0u);
                certain |= inCube ? xs & ys & zs : 0u;
            }
            if ((mask & ~certain) == 0) return mask;
        }
    }
    // Edge × axis, in leaf units relative to c: e × x = (0, e.z, −e.y), e × y = (−e.z, 0, e.x),
    // e × z = (e.y, −e.x, 0). An axis whose grown interval holds every centre (all within ±r)
    // removes nothing.
    const auto axisTest = [&](double pa, double pb, double pd, double u1, double u2, child_mask::SlotPair pair) {
        const double r = std::abs(u1) + std::abs(u2);
        const double grow = r + 1e-9 * (r + (std::abs(pa) + std::abs(pb) + std::abs(pd)));
        const double low = std::min(std::min(pa, pb), pd) - grow, high = std::max(std::max(pa, pb), pd) + grow;
        if (low <= -r && high >= r) return;
        mask &= child_mask::keepPair(u1, u2, low, high, pair);
    };
    const auto edgeAxes = [&](Vec3d e) {
        axisTest(e.z * a.y - e.y * a.z, e.z * b.y - e.y * b.z, e.z * d.y - e.y * d.z, q * e.z, q * -e.y, child_mask::kYZ);
        axisTest(e.x * a.z - e.z * a.x, e.x * b.z - e.z * b.x, e.x * d.z - e.z * d.x, q * -e.z, q * e.x, child_mask::kXZ);
        axisTest(e.y * a.x - e.x * a.y, e.y * b.x - e.x * b.y, e.y * d.x - e.x * d.y, q * e.y, q * -e.x, child_mask::kXY);
    };
    edgeAxes(b - a);
    if ((mask & ~certain) == 0) return mask;
    edgeAxes(d - b);
    if ((mask & ~certain) == 0) return mask;
    edgeAxes(a - d);
    return mask;
}

namespace clip_detail {

template <int Axis>
[[nodiscard]] inline double coordinate(const Vec3d& p) {
    if constexpr (Axis == 0) return p.x;
    else if constexpr (Axis == 1) return p.y;
    else return p.z;
}

/// Sutherland–Hodgman of the polygon @p in (@p n vertices) against the face of [−½, ½]³ on
/// @p Axis at side @p Side (±1), keeping side·p[axis] ≤ ½, into @p out; returns the new count.
template <int Axis, int Side>
inline std::size_t clipFace(const Vec3d* in, std::size_t n, Vec3d* out, std::size_t capacity) {
    std::array<double, 12> distance;
    for (std::size_t i = 0; i < n; ++i) distance[i] = double(Side) * coordinate<Axis>(in[i]) - 0.5;
    std::size_t m = 0;
    for (std::size_t i = 0; i < n && m + 2 <= capacity; ++i) {
        const std::size_t j = i + 1 == n ? 0 : i + 1;
        const double dp = distance[i], dq = distance[j];
        if (dp <= 0) out[m++] = in[i];
        if ((dp < 0 && dq > 0) || (dp > 0 && dq < 0)) out[m++] = in[i] + (in[j] - in[i]) * (dp / (dp - dq));
    }
    return m;
}

/// The bounding box of @p n points.
inline void bounds(const Vec3d* p, std::size_t n, Vec3d& lo, Vec3d& hi) {
    lo = hi = p[0];
    for (std::size_t i = 1; i < n; ++i) {
        lo = {std::min(lo.x, p[i].x), std::min(lo.y, p[i].y), std::min(lo.z, p[i].z)};
        hi = {std::max(hi.x, p[i].x), std::max(hi.y, p[i].y), std::max(hi.z, p[i].z)};
    }
}

}  // namespace clip_detail

/// True if @p p lies in the closed cube [−½, ½]³.
[[nodiscard]] inline bool insideUnitCube(const Vec3d& p) { return std::abs(p.x) <= 0.5 && std::abs(p.y) <= 0.5 && std::abs(p.z) <= 0.5; }

/// Clips the triangle @p p0 @p p1 @p p2 to the cube [−½, ½]³ (Sutherland–Hodgman: faces −x, +x,
/// −y, +y, −z, +z in turn), writing the polygon to @p out (12 vertices of room, which 9 never
/// exceed; @p scratch likewise); returns its vertex count. A face that no vertex of the polygon so far lies beyond
/// (side·p[axis] − ½ > 0 exactly where p[axis] is beyond ±½) is skipped: its pass would copy the
/// polygon unchanged.
inline std::size_t clipTriangleToUnitCube(const Vec3d& p0, const Vec3d& p1, const Vec3d& p2, Vec3d* out, Vec3d* scratch) {
    out[0] = p0;
    out[1] = p1;
    out[2] = p2;
    if (insideUnitCube(p0) && insideUnitCube(p1) && insideUnitCube(p2)) return 3;  // common for fine triangles in coarse voxels
    constexpr std::size_t kRoom = 12;
    Vec3d* a = out;
    Vec3d* b = scratch;
    std::size_t n = 3;
    Vec3d lo, hi;
    clip_detail::bounds(a, n, lo, hi);
    const auto pass = [&](auto clip) {
        n = clip(a, n, b, kRoom);
        std::swap(a, b);
        if (n > 0) clip_detail::bounds(a, n, lo, hi);
        return n > 0;
    };
    // Faces in the reference order; each pass only where a vertex lies beyond.
    if (lo.x < -0.5 && !pass(clip_detail::clipFace<0, -1>)) return 0;
    if (hi.x > 0.5 && !pass(clip_detail::clipFace<0, 1>)) return 0;
    if (lo.y < -0.5 && !pass(clip_detail::clipFace<1, -1>)) return 0;
    if (hi.y > 0.5 && !pass(clip_detail::clipFace<1, 1>)) return 0;
    if (lo.z < -0.5 && !pass(clip_detail::clipFace<2, -1>)) return 0;
    if (hi.z > 0.5 && !pass(clip_detail::clipFace<2, 1>)) return 0;
    if (a != out)
        for (std::size_t i = 0; i < n; ++i) {
            const Vec3d v = a[i];
            asm("" ::: "memory");  // keeps this a short loop, not a library call per triangle
            out[i] = v;
        }
    return n;
}

/// Clips a triangle to the cube [−½, ½]³ (Sutherland–Hodgman), appending the polygon to @p out.
inline void clipToUnitCube(const std::array<Vec3d, 3>& triangle, std::vector<Vec3d>& out, std::array<Vec3d, 12>& bufferA,
                           std::array<Vec3d, 12>& bufferB) {
    const std::size_t n = clipTriangleToUnitCube(triangle[0], triangle[1], triangle[2], bufferA.data(), bufferB.data());
    out.insert(out.end(), bufferA.begin(), bufferA.begin() + static_cast<std::ptrdiff_t>(n));
}

/// The polygons that the triangles of a list cut out of one cube, in the cube's local frame
/// ([−½, ½]³, reached by (p − c)·toLocal), with their fan areas: what the contour fit and the
/// attribute filter both read, so that a voxel that needs both clips its triangles once.
class CubeFragments {
public:
    /// Every polygon's vertices, one polygon after another.
    [[nodiscard]] std::span<const Vec3d> points() const { return {points_.data(), pointCount_}; }
    /// Entry @p entry's polygon (its list entry's).
    [[nodiscard]] std::span<const Vec3d> polygon(std::size_t entry) const {
        return {points_.data() + begin_[entry], points_.data() + begin_[entry + 1]};
    }
    /// Per point j from a polygon's third vertex on: 0.5·|(p[j−1] − p[0]) × (p[j] − p[0])|, the area
    /// of its fan triangle (p[0], p[j−1], p[j]); 0 for the first two. Indexed like points().
    [[nodiscard]] const double* fanArea(std::size_t entry) const { return fanArea_.data() + begin_[entry]; }
    /// Entry @p entry's polygon area: the sum of its fan areas in order.
    [[nodiscard]] double area(std::size_t entry) const { return area_[entry]; }
    /// True if these are the fragments of @p c at @p scale (for a list the caller vouches for).
    [[nodiscard]] bool of(Vec3d c, double scale) const { return valid_ && centre_ == c && toLocal_ == scale; }

    /// Clips the triangles @p list of @p triangles to the cube of centre @p c, scaled by @p scale
    /// (1 / the cube's edge, a power of two).
    /// @p normalLength: null, or per triangle length(normal) (BoxTestTriangle::normal): then the
    /// area of a triangle inside the cube whose vertices' offsets from @p c are exact is
    /// 0.5·scale²·|normal|, which is what the fan formula gives bit for bit: its edges are then
    /// exactly scale·(v1 − v0) and scale·(v2 − v0) as rounded for the normal, and a power-of-two
    /// scale passes through products, differences and the square root unchanged. The offsets are
    /// exact (Sterbenz: v within [c/2, 2c]) for every triangle inside a cube of half-extent h
    /// whose centre has every coordinate ≥ 3h: its rounded offsets are within h, so the exact ones
    /// within h + ulp(h), and c − 1.01·h ≥ c/2, c + 1.01·h ≤ 2c.
    void clip(std::span<const std::uint32_t> list, const std::vector<BoxTestTriangle>& triangles, Vec3d c, double scale,
              const double* normalLength = nullptr) {
        clip(list, triangles.data(), c, scale, normalLength);
    }
    void clip(std::span<const std::uint32_t> list, const BoxTestTriangle* triangles, Vec3d c, double scale,
              const double* normalLength = nullptr) {
        centre_ = c;
        toLocal_ = scale;
        valid_ = true;
        // Room for the largest polygons (9 vertices) without a check per vertex; never shrunk.
        const std::size_t room = 12 * list.size() + 12;
        if (points_.size() < room) {
            points_.resize(room);
            fanArea_.resize(room);
        }
        if (begin_.size() < list.size() + 1) {
            begin_.resize(list.size() + 1);
            area_.resize(list.size() + 1);
        }
        Vec3d* points = points_.data();
        double* fan = fanArea_.data();
        const double h3 = 1.5 / scale;  // 3h
        const bool shortcut = normalLength != nullptr && c.x >= h3 && c.y >= h3 && c.z >= h3;
        const double halfScale2 = 0.5 * scale * scale;
        std::size_t count = 0;
        for (std::size_t entry = 0; entry < list.size(); ++entry) {
            const std::uint32_t t = list[entry];
            const BoxTestTriangle& tri = triangles[t];
            begin_[entry] = static_cast<std::uint32_t>(count);
            const Vec3d p0 = (tri.v0 - c) * scale, p1 = (tri.v1 - c) * scale, p2 = (tri.v2 - c) * scale;
            Vec3d* out = points + count;
            fan[count] = 0;
            fan[count + 1] = 0;
            if (insideUnitCube(p0) && insideUnitCube(p1) && insideUnitCube(p2)) {  // as clipTriangleToUnitCube: unclipped
                out[0] = p0;
                out[1] = p1;
                out[2] = p2;
                const double a = shortcut ? normalLength[t] * halfScale2 : 0.5 * length(cross(p1 - p0, p2 - p0));
                fan[count + 2] = a;
                area_[entry] = a;
                count += 3;
                continue;
            }
            const std::size_t n = clipTriangleToUnitCube(p0, p1, p2, out, clipB_.data());  // room is 12 per triangle
            double sum = 0;
            for (std::size_t i = 2; i < n; ++i) {
                const double a = 0.5 * length(cross(out[i - 1] - out[0], out[i] - out[0]));
                fan[count + i] = a;
                sum += a;
            }
            area_[entry] = sum;
            count += n;
        }
        begin_[list.size()] = static_cast<std::uint32_t>(count);
        pointCount_ = count;
    }

private:
    std::vector<Vec3d> points_;
    std::vector<double> fanArea_;
    std::vector<std::uint32_t> begin_;  // per list entry: its polygon's first point; one more entry: the end
    std::vector<double> area_;
    std::size_t pointCount_ = 0;
    Vec3d centre_{0, 0, 0};
    double toLocal_ = 0;
    bool valid_ = false;
    std::array<Vec3d, 12> clipB_{};  // clipping ping-pong buffer (zeroed once, not per triangle)
};

}  // namespace vox::detail
