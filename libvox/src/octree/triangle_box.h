// Triangle / axis-aligned box overlap by the separating-axis theorem (Akenine-Möller 2001):
// the 3 box normals, the triangle normal and the 9 edge cross products. Closed sets: a triangle
// touching the box's boundary overlaps it. Double precision, with a separation margin of 1e-9
// relative to the quantities compared, so that rounding never splits a touching contact
// differently between a cube and its children (coordinates of non-power-of-two scenes are not
// exact in leaf units). Degenerate (zero-area) triangles still work: a zero normal or zero cross
// product gives an axis that never separates.
#pragma once

#include <vox/base/math.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
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
            const double pa = e.z * a.y - e.y * a.z, pb = e.z * b.y - e.y * b.z,
                         pd = e.z * d.y - e.y * d.z;
            const double rad = h * (std::abs(e.z) + std::abs(e.y));
            if (separated(std::min({pa, pb, pd}), std::max({pa, pb, pd}), rad,
                          std::abs(pa) + std::abs(pb) + std::abs(pd)))
                return false;
        }
        {
            const double pa = -e.z * a.x + e.x * a.z, pb = -e.z * b.x + e.x * b.z,
                         pd = -e.z * d.x + e.x * d.z;
            const double rad = h * (std::abs(e.z) + std::abs(e.x));
            if (separated(std::min({pa, pb, pd}), std::max({pa, pb, pd}), rad,
                          std::abs(pa) + std::abs(pb) + std::abs(pd)))
                return false;
        }
        {
            const double pa = e.y * a.x - e.x * a.y, pb = e.y * b.x - e.x * b.y,
                         pd = e.y * d.x - e.x * d.y;
            const double rad = h * (std::abs(e.y) + std::abs(e.x));
            if (separated(std::min({pa, pb, pd}), std::max({pa, pb, pd}), rad,
                          std::abs(pa) + std::abs(pb) + std::abs(pd)))
                return false;
        }
    }
    return true;
}

namespace child_mask {

/// Slots (bit 0 of a slot: +x, bit 1: +y, bit 2: +z) by the sign of their centre's offset along
/// two axes.
struct SlotPair {
    std::uint32_t pp, mm, pm, mp;  ///< (+,+), (−,−), (+,−), (−,+)
};
inline constexpr SlotPair kYZ{0xC0, 0x03, 0x0C, 0x30};  // bits 1 and 2
inline constexpr SlotPair kXZ{0xA0, 0x05, 0x0A, 0x50};  // bits 0 and 2
inline constexpr SlotPair kXY{0x88, 0x11, 0x22, 0x44};  // bits 0 and 1

[[nodiscard]] inline std::uint32_t bit(bool b) { return static_cast<std::uint32_t>(b); }

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
/// zero, and no comparison sees that sign. What changes is the order of work: all 13 axes and
/// all 8 children, without branches (they mispredict more than the work they skip costs), and
/// one comparison per child and axis instead of two: every centre projects within ±r ≤ grow
/// (|((±x) + (±y)) + (±z)| never exceeds (|x| + |y|) + |z| in rounded arithmetic either), so
/// where the triangle's projection reaches 0 on one side, that side's bound holds for all.
///
/// The nine edge axes are skipped where every child left holds a vertex of the triangle (as the
/// rounded vertices a, b, d below; closed boxes): such a child meets the triangle, so the two
/// overlap on every axis exactly, and with every coordinate within h of the centre the rounding
/// of the projections (≲ 2⁻⁵¹ of the child's radius) stays far below the separation margin (10⁻⁹
/// of it). The plane axis is always evaluated: its normal comes from the unrounded vertices.
[[nodiscard]] inline std::uint32_t childOverlapMask(const BoxTestTriangle& tri, Vec3d c, double h) {
    using child_mask::bit;
    const double q = 0.5 * h;  // children's half-extent; their centres are c ± q per axis
    const Vec3d a = tri.v0 - c, b = tri.v1 - c, d = tri.v2 - c;
    std::uint32_t mask = 0xFF;
    // Box normals: separated(lo ± q, hi ± q, q, magnitude) for the two halves.
    bool inside = true;      // the triangle's bounding box lies in the cube
    int splits = 0;          // axes on which both halves are kept
    bool splitSpans = true;  // on those, lo ≤ 0 ≤ hi
    // The axis helpers always inline: called out of line (as GCC decides for some callers), they
    // cost a tenth more.
    const auto boxAxis = [&](double pa, double pb, double pd, std::uint32_t lowHalf)
        __attribute__((always_inline)) {
        const double lo = std::min(std::min(pa, pb), pd);
        const double hi = std::max(std::max(pa, pb), pd);
        const double magnitude = std::max(std::abs(lo), std::abs(hi));
        const double margin = 1e-9 * (q + magnitude);
        const bool lowSeparated = (lo + q > q + margin) | (hi + q < -q - margin);
        const bool highSeparated = (lo - q > q + margin) | (hi - q < -q - margin);
        mask &= (lowSeparated ? ~lowHalf : 0xFFu) & (highSeparated ? lowHalf : 0xFFu);
        inside = inside & (lo >= -h) & (hi <= h);
        const bool split = !(lowSeparated || highSeparated);
        splits += split;
        splitSpans = splitSpans & ((!split) | ((lo <= 0) & (hi >= 0)));
    };
    boxAxis(a.x, b.x, d.x, 0x55);  // slots with the axis bit clear
    boxAxis(a.y, b.y, d.y, 0x33);
    boxAxis(a.z, b.z, d.z, 0x0F);
    // Triangle plane: child s's centre projects at ((±ax) + (±ay)) + (±az), the eight values
    // ±v7, ±v3, ±v6, ±v5 (slots 7/0, 3/4, 6/1, 5/2). With s ≥ 0 only s − grow can exclude a
    // child, else only s + grow: keep where ±cp ≥ bound.
    {
        const Vec3d& n = tri.normal;
        const double s = dot(n, a);
        const double ax = q * n.x, ay = q * n.y, az = q * n.z;
        const double r = std::abs(ax) + std::abs(ay) + std::abs(az);
        const double grow = r + 1e-9 * (r + std::abs(s));
        const bool up = s >= 0;
        const double bound = up ? s - grow : -(s + grow);
        const double t1 = ax + ay, t2 = ay - ax;  // partial sums of slots x+y+ and x−y+
        const double v7 = t1 + az, v3 = t1 - az, v6 = t2 + az, v5 = az - t2;
        const double w7 = up ? v7 : -v7, w3 = up ? v3 : -v3, w6 = up ? v6 : -v6, w5 = up ? v5 : -v5;
        mask &= bit(w7 >= bound) << 7 | bit(-w7 >= bound) | bit(w3 >= bound) << 3 |
                bit(-w3 >= bound) << 4 | bit(w6 >= bound) << 6 | bit(-w6 >= bound) << 1 |
                bit(w5 >= bound) << 5 | bit(-w5 >= bound) << 2;
    }
    // A triangle inside the cube that the box axes leave in one child, or in two across one
    // mid-plane it reaches on both sides, has a vertex in each: the edge axes cannot separate
    // those (see above), the common case where triangles are small.
    if (inside & (splits <= 1) & splitSpans) return mask;
    // Edge × axis, in leaf units relative to c: e × x = (0, e.z, −e.y), e × y = (−e.z, 0, e.x),
    // e × z = (e.y, −e.x, 0); the centres are ±(u1 + u2), ±(u1 − u2). Where the projection spans
    // 0 every centre is inside (bound −∞); above 0 only pmin − grow can exclude, below only
    // pmax + grow.
    const auto edgeAxis = [&](double pa, double pb, double pd, double u1, double u2,
                              child_mask::SlotPair pair) __attribute__((always_inline)) {
        const double pmin = std::min(std::min(pa, pb), pd), pmax = std::max(std::max(pa, pb), pd);
        const double r = std::abs(u1) + std::abs(u2);
        const double grow = r + 1e-9 * (r + (std::abs(pa) + std::abs(pb) + std::abs(pd)));
        const bool up = pmin > 0;
        const double bound =
            up ? pmin - grow
               : (pmax < 0 ? -(pmax + grow) : -std::numeric_limits<double>::infinity());
        const double w0 = u1 + u2, v0 = u1 - u2;
        const double w = up ? w0 : -w0, v = up ? v0 : -v0;
        mask &= (w >= bound ? pair.pp : 0u) | (-w >= bound ? pair.mm : 0u) |
                (v >= bound ? pair.pm : 0u) | (-v >= bound ? pair.mp : 0u);
    };
    for (const Vec3d e : {b - a, d - b, a - d}) {
        edgeAxis(e.z * a.y - e.y * a.z, e.z * b.y - e.y * b.z, e.z * d.y - e.y * d.z, q * e.z,
                 q * -e.y, child_mask::kYZ);
        edgeAxis(e.x * a.z - e.z * a.x, e.x * b.z - e.z * b.x, e.x * d.z - e.z * d.x, q * -e.z,
                 q * e.x, child_mask::kXZ);
        edgeAxis(e.y * a.x - e.x * a.y, e.y * b.x - e.x * b.y, e.y * d.x - e.x * d.y, q * e.y,
                 q * -e.x, child_mask::kXY);
    }
    return mask;
}

namespace clip_detail {

template <int Axis>
[[nodiscard]] inline double coordinate(const Vec3d& p) {
    if constexpr (Axis == 0)
        return p.x;
    else if constexpr (Axis == 1)
        return p.y;
    else
        return p.z;
}

/// Sutherland–Hodgman of the polygon @p in (@p n vertices) against the face of [−½, ½]³ on
/// @p Axis at side @p Side (±1), keeping side·p[axis] ≤ ½, into @p out; returns the new count,
/// or n with nothing written where no vertex lies beyond the face (the pass would copy the
/// polygon unchanged), @p clipped telling which.
template <int Axis, int Side>
inline std::size_t clipFace(const Vec3d* in, std::size_t n, Vec3d* out, std::size_t capacity,
                            bool& clipped) {
    std::array<double, 12> distance;
    bool beyond = false;
    for (std::size_t i = 0; i < n; ++i) {
        distance[i] = double(Side) * coordinate<Axis>(in[i]) - 0.5;
        beyond |= distance[i] > 0;
    }
    clipped = beyond;
    if (!beyond) return n;
    std::size_t m = 0;
    for (std::size_t i = 0; i < n && m + 2 <= capacity; ++i) {
        const std::size_t j = i + 1 == n ? 0 : i + 1;
        const double dp = distance[i], dq = distance[j];
        if (dp <= 0) out[m++] = in[i];
        if ((dp < 0 && dq > 0) || (dp > 0 && dq < 0))
            out[m++] = in[i] + (in[j] - in[i]) * (dp / (dp - dq));
    }
    return m;
}

}  // namespace clip_detail

/// True if @p p lies in the closed cube [−½, ½]³.
[[nodiscard]] inline bool insideUnitCube(const Vec3d& p) {
    return std::abs(p.x) <= 0.5 && std::abs(p.y) <= 0.5 && std::abs(p.z) <= 0.5;
}

/// Clips the triangle @p p0 @p p1 @p p2 to the cube [−½, ½]³ (Sutherland–Hodgman: faces −x, +x,
/// −y, +y, −z, +z in turn), writing the polygon to @p out (12 vertices of room, which 9 never
/// exceed; @p scratch likewise); returns its vertex count.
inline std::size_t clipTriangleToUnitCube(const Vec3d& p0, const Vec3d& p1, const Vec3d& p2,
                                          Vec3d* out, Vec3d* scratch) {
    out[0] = p0;
    out[1] = p1;
    out[2] = p2;
    if (insideUnitCube(p0) && insideUnitCube(p1) && insideUnitCube(p2))
        return 3;  // common for fine triangles in coarse voxels
    constexpr std::size_t kRoom = 12;
    Vec3d* a = out;
    Vec3d* b = scratch;
    std::size_t n = 3;
    // One pass per face in the reference order, each only where a vertex of the polygon so far
    // lies beyond it.
    const auto pass = [&](auto clip) {
        bool clipped = false;
        const std::size_t m = clip(a, n, b, kRoom, clipped);
        if (clipped) {
            n = m;
            std::swap(a, b);
        }
        return n > 0;
    };
    if (!pass(clip_detail::clipFace<0, -1>) || !pass(clip_detail::clipFace<0, 1>) ||
        !pass(clip_detail::clipFace<1, -1>) || !pass(clip_detail::clipFace<1, 1>) ||
        !pass(clip_detail::clipFace<2, -1>) || !pass(clip_detail::clipFace<2, 1>))
        return 0;
    if (a != out)
        for (std::size_t i = 0; i < n; ++i) {
            const Vec3d v = a[i];
            asm("" ::: "memory");  // keeps this a short loop, not a library call per triangle
            out[i] = v;
        }
    return n;
}

/// Clips a triangle to the cube [−½, ½]³ (Sutherland–Hodgman), appending the polygon to @p out.
inline void clipToUnitCube(const std::array<Vec3d, 3>& triangle, std::vector<Vec3d>& out,
                           std::array<Vec3d, 12>& bufferA, std::array<Vec3d, 12>& bufferB) {
    const std::size_t n = clipTriangleToUnitCube(triangle[0], triangle[1], triangle[2],
                                                 bufferA.data(), bufferB.data());
    out.insert(out.end(), bufferA.begin(), bufferA.begin() + static_cast<std::ptrdiff_t>(n));
}

namespace clip_detail {

/// Room for one polygon: a triangle cut by a cube's six faces has at most 9 vertices.
inline constexpr std::size_t kPolygonRoom = 12;

/// A polygon in a scratch buffer or in CubeFragments; whole: it is the polygon it was split from.
struct Part {
    const Vec3d* v = nullptr;
    std::size_t n = 0;
    bool whole = true;
};

/// Room for either side of a split polygon: every vertex and every crossing (a convex polygon has
/// two crossings; one made slightly non-convex by rounding may have more), before it is cut back
/// to kPolygonRoom.
inline constexpr std::size_t kSplitRoom = 2 * kPolygonRoom;

/// One Sutherland–Hodgman pass of @p in against the plane p[Axis] = 0 that keeps both sides: a
/// vertex on the plane goes to both, an edge crossing it strictly adds its cut point (on the plane
/// exactly) to both; either side keeps at most its first kPolygonRoom vertices. A side that the
/// pass would leave unchanged (no vertex strictly beyond the plane) is @p in itself, not a copy.
/// The buffers have kSplitRoom vertices of room.
template <int Axis>
inline void splitAtMidPlane(const Part& in, Vec3d* lowBuffer, Vec3d* highBuffer, Part& low,
                            Part& high) {
    std::array<double, kPolygonRoom> d;
    double lowest = std::numeric_limits<double>::infinity(), highest = -lowest;
    for (std::size_t i = 0; i < in.n; ++i) {
        d[i] = coordinate<Axis>(in.v[i]);
        lowest = std::min(lowest, d[i]);
        highest = std::max(highest, d[i]);
    }
    if (!(lowest < 0 && highest > 0)) {
        // Every vertex on one side or on the plane: that side is the polygon, the other what lies
        // on the plane (a touching edge or vertex; nothing if none does).
        const bool above = highest > 0;
        Part& same = above ? high : low;
        Part& other = above ? low : high;
        same = in;
        Vec3d* out = above ? lowBuffer : highBuffer;
        std::size_t m = 0;
        if ((above ? lowest : highest) == 0)
            for (std::size_t i = 0; i < in.n; ++i)
                if (d[i] == 0) out[m++] = in.v[i];
        other = {out, m, m == in.n && in.whole};
        return;
    }
    std::size_t nl = 0, nh = 0;
    for (std::size_t i = 0; i < in.n; ++i) {
        const std::size_t j = i + 1 == in.n ? 0 : i + 1;
        const double dp = d[i], dq = d[j];
        // Stored always, kept where on the side (fewer branches than testing first).
        lowBuffer[nl] = in.v[i];
        nl += dp <= 0;
        highBuffer[nh] = in.v[i];
        nh += dp >= 0;
        if ((dp < 0 && dq > 0) || (dp > 0 && dq < 0)) {
            Vec3d cut = in.v[i] + (in.v[j] - in.v[i]) * (dp / (dp - dq));
            if constexpr (Axis == 0)
                cut.x = 0;
            else if constexpr (Axis == 1)
                cut.y = 0;
            else
                cut.z = 0;
            lowBuffer[nl++] = cut;
            highBuffer[nh++] = cut;
        }
    }
    // Rounding can make a cut polygon slightly non-convex; the bound keeps it in its room.
    low = {lowBuffer, std::min(nl, kPolygonRoom), false};
    high = {highBuffer, std::min(nh, kPolygonRoom), false};
}

/// Writes the fan areas of polygon @p p (@p n vertices) to @p fan (fan[j] = 0.5·|(p[j−1] − p[0]) ×
/// (p[j] − p[0])| from j = 2, 0 before) and returns their sum in order.
inline double fanAreas(const Vec3d* p, std::size_t n, double* fan) {
    fan[0] = 0;
    fan[1] = 0;
    double sum = 0;
    for (std::size_t i = 2; i < n; ++i) {
        const double a = 0.5 * length(cross(p[i - 1] - p[0], p[i] - p[0]));
        fan[i] = a;
        sum += a;
    }
    return sum;
}

}  // namespace clip_detail

/// The polygons that the triangles of a list cut out of one cube, in the cube's local frame
/// ([−½, ½]³, reached by (p − c)·toLocal), with their fan areas: what the contour fit and the
/// attribute filter both read, so that a voxel that needs both has its fragments once. They come
/// from clipping the triangles to the cube (clip), or from the fragments of the cube's parent,
/// split by its mid-planes (splitInto).
class CubeFragments {
public:
    /// Every polygon's vertices, one polygon after another.
    [[nodiscard]] std::span<const Vec3d> points() const {
        return {points_.data(), begin_[entries_]};
    }
    /// Entry @p entry's polygon (its list entry's).
    [[nodiscard]] std::span<const Vec3d> polygon(std::size_t entry) const {
        return {points_.data() + begin_[entry], points_.data() + begin_[entry + 1]};
    }
    /// Per point j from a polygon's third vertex on: 0.5·|(p[j−1] − p[0]) × (p[j] − p[0])|, the
    /// area of its fan triangle (p[0], p[j−1], p[j]); 0 for the first two. Indexed like points().
    [[nodiscard]] const double* fanArea(std::size_t entry) const {
        return fanArea_.data() + begin_[entry];
    }
    /// Entry @p entry's polygon area: the sum of its fan areas in order.
    [[nodiscard]] double area(std::size_t entry) const { return area_[entry]; }
    /// Entries so far.
    [[nodiscard]] std::size_t size() const { return entries_; }

    /// Empties these fragments, with room for @p entries polygons appended in list order.
    void start(std::size_t entries) {
        if (entries >= entryRoom_) grow(entries);
        entries_ = 0;
        begin_[0] = 0;
    }

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
    void clip(std::span<const std::uint32_t> list, const std::vector<BoxTestTriangle>& triangles,
              Vec3d c, double scale, const double* normalLength = nullptr) {
        clip(list, triangles.data(), c, scale, normalLength);
    }
    void clip(std::span<const std::uint32_t> list, const BoxTestTriangle* triangles, Vec3d c,
              double scale, const double* normalLength = nullptr) {
        start(list.size());
        const double h3 = 1.5 / scale;  // 3h
        const bool shortcut = normalLength != nullptr && c.x >= h3 && c.y >= h3 && c.z >= h3;
        const double halfScale2 = 0.5 * scale * scale;
        for (const std::uint32_t t : list) {
            const BoxTestTriangle& tri = triangles[t];
            const Vec3d p0 = (tri.v0 - c) * scale, p1 = (tri.v1 - c) * scale,
                        p2 = (tri.v2 - c) * scale;
            Vec3d* out = points_.data() + begin_[entries_];
            if (insideUnitCube(p0) && insideUnitCube(p1) &&
                insideUnitCube(p2)) {  // as clipTriangleToUnitCube: unclipped
                out[0] = p0;
                out[1] = p1;
                out[2] = p2;
                double* fan = fanArea_.data() + begin_[entries_];
                fan[0] = 0;
                fan[1] = 0;
                fan[2] =
                    shortcut ? normalLength[t] * halfScale2 : 0.5 * length(cross(p1 - p0, p2 - p0));
                append(3, fan[2]);
                continue;
            }
            const std::size_t n =
                clipTriangleToUnitCube(p0, p1, p2, out, clipB_.data());  // room is 12 per triangle
            append(n, clip_detail::fanAreas(out, n, fanArea_.data() + begin_[entries_]));
        }
    }

    /// Appends to @p children[s], for every child slot s in @p mask (bit 0 of a slot: the +x
    /// half, bit 1: +y, bit 2: +z), the part of entry @p entry's polygon inside child s's cube,
    /// in that child's local frame: the polygon split by this cube's three mid-planes
    /// (clip_detail::splitAtMidPlane, x, then y, then z) and mapped by p ↦ 2p ∓ ½. The children
    /// in @p mask must have been started. A part the planes leave whole keeps this
    /// polygon's fan areas × 4 (exact); a cut part's are computed afresh.
    ///
    /// The same polygon as clipping the triangle to the child's cube directly, but with its cuts
    /// made in the ancestors' frames and the mapping rounded (2p ∓ ½ is exact only for |2p| ≥ ¼),
    /// so its coordinates can differ by a few units in the last place of the coarsest frame that
    /// cut them (docs/internals/esvo-writer.md, "Fragments from the parent's").
    void splitInto(std::size_t entry, std::uint32_t mask, std::array<CubeFragments, 8>& children) {
        using clip_detail::Part;
        const Part whole{points_.data() + begin_[entry], begin_[entry + 1] - begin_[entry], true};
        const double* fan = fanArea_.data() + begin_[entry];
        const double area = area_[entry];
        Part halves[2], quarters[2], eighths[2];
        clip_detail::splitAtMidPlane<0>(whole, split_[0].data(), split_[1].data(), halves[0],
                                        halves[1]);
        for (std::uint32_t x = 0; x < 2; ++x) {
            if (!(mask & (x ? 0xAAu : 0x55u))) continue;
            clip_detail::splitAtMidPlane<1>(halves[x], split_[2].data(), split_[3].data(),
                                            quarters[0], quarters[1]);
            for (std::uint32_t y = 0; y < 2; ++y) {
                if (!(mask & ((x ? 0xAAu : 0x55u) & (y ? 0xCCu : 0x33u)))) continue;
                clip_detail::splitAtMidPlane<2>(quarters[y], split_[4].data(), split_[5].data(),
                                                eighths[0], eighths[1]);
                for (std::uint32_t z = 0; z < 2; ++z) {
                    const std::uint32_t slot = x | y << 1 | z << 2;
                    if (mask & (1u << slot)) children[slot].appendPart(eighths[z], slot, fan, area);
                }
            }
        }
    }

private:
    /// Room for the largest polygons of @p entries entries without a check per vertex; never
    /// shrunk.
    void grow(std::size_t entries) {
        const std::size_t room = clip_detail::kPolygonRoom * (entries + 1);
        points_.resize(room);
        fanArea_.resize(room);
        begin_.resize(entries + 1);
        area_.resize(entries + 1);
        entryRoom_ = entries + 1;
    }
    /// Closes the entry whose @p n points (and fan areas) were written at the end: its area @p
    /// area.
    void append(std::size_t n, double area) {
        area_[entries_] = area;
        begin_[entries_ + 1] = begin_[entries_] + static_cast<std::uint32_t>(n);
        ++entries_;
    }
    /// Appends @p part of a parent's polygon (parent frame) in child @p slot, mapped to this
    /// frame; a whole part takes the parent's fan areas @p parentFan × 4 and area @p parentArea
    /// × 4.
    void appendPart(const clip_detail::Part& part, std::uint32_t slot, const double* parentFan,
                    double parentArea) {
        static constexpr std::array<Vec3d, 8> kOffsets{{{-0.5, -0.5, -0.5},
                                                        {0.5, -0.5, -0.5},
                                                        {-0.5, 0.5, -0.5},
                                                        {0.5, 0.5, -0.5},
                                                        {-0.5, -0.5, 0.5},
                                                        {0.5, -0.5, 0.5},
                                                        {-0.5, 0.5, 0.5},
                                                        {0.5, 0.5, 0.5}}};
        const Vec3d offset = kOffsets[slot];
        Vec3d* out = points_.data() + begin_[entries_];
        double* fan = fanArea_.data() + begin_[entries_];
        for (std::size_t i = 0; i < part.n; ++i) out[i] = part.v[i] * 2.0 - offset;
        if (part.whole) {
            for (std::size_t i = 0; i < part.n; ++i) fan[i] = 4 * parentFan[i];
            append(part.n, 4 * parentArea);
        } else {
            append(part.n, clip_detail::fanAreas(out, part.n, fan));
        }
    }

    std::vector<Vec3d> points_;
    std::vector<double> fanArea_;
    std::vector<std::uint32_t>
        begin_;  // per entry: its polygon's first point; one more entry: the end
    std::vector<double> area_;
    std::size_t entries_ = 0;
    std::size_t entryRoom_ = 0;      // entries there is room for, and one more (begin_'s size)
    std::array<Vec3d, 12> clipB_{};  // clipping ping-pong buffer (zeroed once, not per triangle)
    std::array<std::array<Vec3d, clip_detail::kSplitRoom>, 6>
        split_{};  // splitInto's parts: x, y and z halves (zeroed once)
};

}  // namespace vox::detail
