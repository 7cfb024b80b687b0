#include "contours.h"

#include <vox/formats/esvo.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace vox::detail {
namespace {

/// std::lround for the small finite values here (|x| < 2⁵²): half away from zero, inline.
/// Truncation toward zero is exact, and so is the fraction x − trunc(x).
long roundHalfAway(double x) {
    const auto t = static_cast<long>(x);
    const double f = x - static_cast<double>(t);
    return t + (f >= 0.5 ? 1 : 0) - (f <= -0.5 ? 1 : 0);
}

/// Quantises a direction to the contour's integer normal (largest component ±31).
std::array<int, 3> quantiseNormal(Vec3d m) {
    const double largest = std::max({std::abs(m.x), std::abs(m.y), std::abs(m.z)});
    if (!(largest > 0)) return {0, 0, 0};
    return {static_cast<int>(roundHalfAway(31 * m.x / largest)),
            static_cast<int>(roundHalfAway(31 * m.y / largest)),
            static_cast<int>(roundHalfAway(31 * m.z / largest))};
}

/// Fragment areas (in the cube's local frame) above which a scale-invariant quantisation holds
/// for the fragment's area-weighted normal: far from subnormal products.
constexpr double kNormalArea = 1e-100;

/// Encodes the slab along @p n covering every point; 0 if it cannot be represented.
/// @p norm: std::sqrt(double(|n|²)).
std::uint32_t encodeSlab(const std::array<int, 3>& n, double norm, std::span<const Vec3d> points,
                         double& thickness) {
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const Vec3d& p : points) {
        const double v = n[0] * p.x + n[1] * p.y + n[2] * p.z;
        lo = std::min(lo, v);
        hi = std::max(hi, v);
    }
    constexpr double step = esvo::Contour::kStep;
    const auto position =
        static_cast<int>(std::clamp<long>(roundHalfAway(0.5 * (lo + hi) / step), -64, 63));
    // Conservative: the half thickness reaches both ends from the quantised position, with a
    // little room for the ray caster's float arithmetic.
    const double reach = std::max(hi - position * step, position * step - lo) + 1e-4;
    const double t = std::ceil(2 * reach / step);
    if (t > 127) return 0;
    esvo::Contour c{n[0], n[1], n[2], position, static_cast<unsigned>(t)};
    thickness = c.thickness * step / norm;
    return c.encode();
}

double pointTriangleDistance(Vec3d p, Vec3d a, Vec3d b, Vec3d c) {
    // Ericson, Real-Time Collision Detection 5.1.5.
    const Vec3d ab = b - a, ac = c - a, ap = p - a;
    const double d1 = dot(ab, ap), d2 = dot(ac, ap);
    if (d1 <= 0 && d2 <= 0) return length(p - a);
    const Vec3d bp = p - b;
    const double d3 = dot(ab, bp), d4 = dot(ac, bp);
    if (d3 >= 0 && d4 <= d3) return length(p - b);
    const double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) return length(p - (a + ab * (d1 / (d1 - d3))));
    const Vec3d cp = p - c;
    const double d5 = dot(ab, cp), d6 = dot(ac, cp);
    if (d6 >= 0 && d5 <= d6) return length(p - c);
    const double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) return length(p - (a + ac * (d2 / (d2 - d6))));
    const double va = d3 * d6 - d5 * d4;
    if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0)
        return length(p - (b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)))));
    const double denom = 1.0 / (va + vb + vc);
    return length(p - (a + ab * (vb * denom) + ac * (vc * denom)));
}

}  // namespace

QuantisedNormal quantiseDirection(Vec3d direction, bool checkScaleInvariance) {
    QuantisedNormal q;
    q.n = quantiseNormal(direction);
    q.norm = std::sqrt(double(q.n[0] * q.n[0] + q.n[1] * q.n[1] + q.n[2] * q.n[2]));
    if (!checkScaleInvariance) return q;
    const double largest =
        std::max({std::abs(direction.x), std::abs(direction.y), std::abs(direction.z)});
    q.scaleInvariant = largest > 0;
    for (const double v : {direction.x, direction.y, direction.z}) {
        const double scaled = std::abs(31 * v / largest);
        q.scaleInvariant = q.scaleInvariant && std::abs(scaled - std::floor(scaled) - 0.5) > 1e-9;
    }
    return q;
}

ContourFit fitContour(std::span<const std::uint32_t> list,
                      const std::vector<BoxTestTriangle>& triangles, Vec3d c, double h,
                      ContourScratch& scratch) {
    scratch.fragments.clip(list, triangles, c, fitContourScale(h));
    return fitContour(scratch.fragments, list, triangles);
}

ContourFit fitContour(const CubeFragments& fragments, std::span<const std::uint32_t> list,
                      const std::vector<BoxTestTriangle>& triangles, TriangleNormals normals) {
    Vec3d mean{0, 0, 0};
    struct Candidate {
        double area;
        std::uint32_t triangle;
        Vec3d normal;
    };
    std::array<Candidate, 3> largest{};
    std::size_t weighed = 0;  // entries in the mean
    for (std::size_t entry = 0; entry < list.size(); ++entry) {
        const std::uint32_t t = list[entry];
        // Fragment area (fan) weighs the triangle's unit normal.
        const double area = fragments.area(entry);
        if (area <= 0) continue;
        const BoxTestTriangle& tri = triangles[t];
        const double nl = normals.length ? normals.length[t] : length(tri.normal);
        if (!(nl > 0)) continue;
        const Vec3d unit = normals.unit ? normals.unit[t] : tri.normal * (1.0 / nl);
        mean = mean + unit * area;
        ++weighed;
        if (area > largest[2].area) {
            std::size_t i = 2;
            for (; i > 0 && area > largest[i - 1].area; --i) largest[i] = largest[i - 1];
            largest[i] = {area, t, unit};
        }
    }
    ContourFit best;
    const std::span<const Vec3d> points = fragments.points();
    if (points.empty()) return best;
    double bestRatio = 0.9;  // a contour must cut at least 10 % off the cube along its normal
    // A quantised normal met before gives the same slab and ratio again, which cannot beat itself.
    std::array<std::array<int, 3>, 4> tried;
    std::size_t triedCount = 0;
    const auto consider = [&](const QuantisedNormal& q) {
        const auto& n = q.n;
        if (n[0] == 0 && n[1] == 0 && n[2] == 0) return;
        for (std::size_t i = 0; i < triedCount; ++i)
            if (tried[i] == n) return;
        tried[triedCount++] = n;
        double thickness = 0;
        const std::uint32_t encoded = encodeSlab(n, q.norm, points, thickness);
        if (!encoded) return;
        const double extent = (std::abs(n[0]) + std::abs(n[1]) + std::abs(n[2])) / q.norm;
        const double ratio = thickness / extent;
        if (ratio < bestRatio) {
            bestRatio = ratio;
            best = {encoded, thickness};
        }
    };
    const auto quantiseFragment =
        [&](const Candidate& cand) {  // what quantiseDirection(cand.normal) gives
            return normals.quantised ? normals.quantised[cand.triangle]
                                     : quantiseDirection(cand.normal);
        };
    // One fragment's mean is its normal times its area, which quantises as the normal does where
    // that is scale-invariant.
    const bool oneFragment = weighed == 1 && normals.quantised &&
                             normals.quantised[largest[0].triangle].scaleInvariant &&
                             largest[0].area > kNormalArea;
    consider(oneFragment ? quantiseFragment(largest[0]) : quantiseDirection(mean));
    // The mean normal is enough for smooth patches; edges and corners need the others.
    for (const Candidate& cand : largest)
        if (cand.area > 0 && bestRatio > 0.1) consider(quantiseFragment(cand));
    return best;
}

std::uint32_t carryContour(std::uint32_t encoded, std::uint32_t slot, double& thickness) {
    return ContourCarrier(encoded)(slot, thickness);
}

namespace {

/// The vertices of cube ∩ slab (@p encoded may be 0: the cube) in the cube's local frame
/// [−½, ½]³: cube corners inside the slab, and where the cube's edges cross the slab's two planes.
/// Plain arrays rather than Vec3d, whose members are zeroed on construction (this runs for every
/// voxel a stop is tested at).
struct ShapeVertices {
    double p[8 + 24][3];
    std::size_t count = 0;
};
void shapeVertices(std::uint32_t encoded, ShapeVertices& out) {
    out.count = 0;
    const esvo::Contour contour = esvo::Contour::decode(encoded);
    const double n[3] = {double(contour.nx), double(contour.ny), double(contour.nz)};
    const double centre = contour.position * esvo::Contour::kStep,
                 half = 0.5 * contour.thickness * esvo::Contour::kStep;
    for (int k = 0; k < 8; ++k) {
        const double x = k & 1 ? 0.5 : -0.5, y = k & 2 ? 0.5 : -0.5, z = k & 4 ? 0.5 : -0.5;
        if (encoded == 0 || std::abs(n[0] * x + n[1] * y + n[2] * z - centre) <= half + 1e-9) {
            double* q = out.p[out.count++];
            q[0] = x, q[1] = y, q[2] = z;
        }
    }
    if (encoded == 0) return;
    for (int axis = 0; axis < 3; ++axis) {
        // Points of the edge: p + s·e_axis, s ∈ [−½, ½].
        if (n[axis] == 0) continue;
        const int u = (axis + 1) % 3, v = (axis + 2) % 3;
        const double inverse = 1 / n[axis];
        for (int k = 0; k < 4; ++k) {
            double p[3] = {0, 0, 0};
            p[u] = k & 1 ? 0.5 : -0.5;
            p[v] = k & 2 ? 0.5 : -0.5;
            const double along = n[0] * p[0] + n[1] * p[1] + n[2] * p[2];
            for (const double plane : {centre - half, centre + half}) {
                const double t = (plane - along) * inverse;
                if (t < -0.5 || t > 0.5) continue;
                double* q = out.p[out.count++];
                q[0] = p[0], q[1] = p[1], q[2] = p[2];
                q[axis] = t;
            }
        }
    }
}

}  // namespace

double shapeError(std::uint32_t encoded, std::span<const std::uint32_t> list,
                  const std::vector<BoxTestTriangle>& triangles, Vec3d c, double h) {
    ShapeVertices vertices;
    shapeVertices(encoded, vertices);
    double error = 0;
    const double toLeaf = 2 * h;
    for (std::size_t i = 0; i < vertices.count; ++i) {
        const Vec3d p{c.x + vertices.p[i][0] * toLeaf, c.y + vertices.p[i][1] * toLeaf,
                      c.z + vertices.p[i][2] * toLeaf};
        double nearest = std::numeric_limits<double>::infinity();
        for (std::uint32_t t : list)
            nearest = std::min(nearest, pointTriangleDistance(p, triangles[t].v0, triangles[t].v1,
                                                              triangles[t].v2));
        error = std::max(error, nearest);
    }
    return error;
}

bool shapeWithinError(std::uint32_t encoded, std::span<const std::uint32_t> list,
                      const std::vector<BoxTestTriangle>& triangles, Vec3d c, double h,
                      double bound) {
    ShapeVertices vertices;
    shapeVertices(encoded, vertices);
    const double toLeaf = 2 * h;
    std::size_t hint =
        0;  // the entry of the triangle that was near the last vertex: often near the next
    for (std::size_t i = 0; i < vertices.count; ++i) {
        const Vec3d p{c.x + vertices.p[i][0] * toLeaf, c.y + vertices.p[i][1] * toLeaf,
                      c.z + vertices.p[i][2] * toLeaf};
        const auto near = [&](std::size_t entry) {
            const BoxTestTriangle& t = triangles[list[entry]];
            // Outside the triangle's bounds grown by the bound, no point of it is within the bound.
            for (int axis = 0; axis < 3; ++axis)
                if (p[axis] < std::min({t.v0[axis], t.v1[axis], t.v2[axis]}) - bound ||
                    p[axis] > std::max({t.v0[axis], t.v1[axis], t.v2[axis]}) + bound)
                    return false;
            return pointTriangleDistance(p, t.v0, t.v1, t.v2) <= bound;
        };
        if (hint < list.size() && near(hint)) continue;
        bool found = false;
        for (std::size_t entry = 0; entry < list.size() && !found; ++entry)
            if (entry != hint && near(entry)) {
                hint = entry;
                found = true;
            }
        if (!found) return false;
    }
    return true;
}

}  // namespace vox::detail
