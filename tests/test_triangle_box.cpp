// The triangle/box kernels of the surface voxelizer (libvox/src/octree/triangle_box.h) against
// the straightforward forms they replaced, kept here verbatim as references: the all-children mask
// must equal the reference mask bit for bit, and away from the rounding margin (or exactly on a
// shared boundary: closed cubes, touching counts) the eight single-cube tests too; the clipper
// must give the reference polygon coordinate for coordinate, and the contour fit on shared
// fragments the reference fit. These are what keep the voxelizer's output byte-identical. A
// voxel's fragments split from its parent's must equal its triangles clipped directly within
// rounding (the split cuts in coarser frames; docs/internals/esvo-writer.md).
#include "octree/contours.h"
#include "octree/triangle_box.h"
#include "scene/surface_shading.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <span>
#include <vector>

#include <vox/formats/esvo.h>

namespace reference {

using vox::Vec3d;
using vox::detail::BoxTestTriangle;
using vox::detail::separated;
namespace esvo = vox::esvo;

/// The children of the closed cube with centre @p c and half-extent @p h that @p tri overlaps,
/// as a slot mask (bit 0 of a slot: +x half, bit 1: +y, bit 2: +z). The same test as
/// triangleOverlapsCube for each child, sharing the triangle's projections among the eight.
[[nodiscard]] inline std::uint32_t childOverlapMask(const BoxTestTriangle& tri, Vec3d c, double h) {
    const double q = 0.5 * h;  // children's half-extent; their centres are c ± q per axis
    const Vec3d a = tri.v0 - c, b = tri.v1 - c, d = tri.v2 - c;
    std::uint32_t mask = 0xFF;
    static constexpr std::uint32_t kLowHalf[3] = {0x55, 0x33,
                                                  0x0F};  // slots with the axis bit clear
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
            const double cp =
                (slot & 1u ? ax : -ax) + (slot & 2u ? ay : -ay) + (slot & 4u ? az : -az);
            if (cp < low || cp > high) mask &= ~(1u << slot);
        }
    };
    const double s = dot(tri.normal, a);
    testAxis(tri.normal, s, s, std::abs(s));
    const Vec3d edges[3] = {b - a, d - b, a - d};
    for (const Vec3d& e : edges) {
        if (mask == 0) return 0;
        for (const Vec3d axisVector :
             {Vec3d{0, e.z, -e.y}, Vec3d{-e.z, 0, e.x}, Vec3d{e.y, -e.x, 0}}) {
            const double pa = dot(axisVector, a), pb = dot(axisVector, b), pd = dot(axisVector, d);
            testAxis(axisVector, std::min({pa, pb, pd}), std::max({pa, pb, pd}),
                     std::abs(pa) + std::abs(pb) + std::abs(pd));
        }
    }
    return mask;
}

/// Clips a triangle to the cube [−½, ½]³ (Sutherland–Hodgman), appending the polygon to @p out.
inline void clipToUnitCube(const std::array<Vec3d, 3>& triangle, std::vector<Vec3d>& out,
                           std::array<Vec3d, 12>& bufferA, std::array<Vec3d, 12>& bufferB) {
    bool inside = true;
    for (const Vec3d& p : triangle)
        inside = inside && std::abs(p.x) <= 0.5 && std::abs(p.y) <= 0.5 && std::abs(p.z) <= 0.5;
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
                if ((dp < 0 && dq > 0) || (dp > 0 && dq < 0))
                    b[m++] = p + (q - p) * (dp / (dp - dq));
            }
            n = m;
            std::swap(a, b);
            if (n == 0) break;
        }
    out.insert(out.end(), a, a + n);
}

struct ClipScratch {
    std::vector<Vec3d> points;
    std::array<Vec3d, 12> clipA{}, clipB{};
};

using vox::detail::ContourFit;

namespace {

/// Quantises a direction to the contour's integer normal (largest component ±31).
std::array<int, 3> quantiseNormal(Vec3d m) {
    const double largest = std::max({std::abs(m.x), std::abs(m.y), std::abs(m.z)});
    if (!(largest > 0)) return {0, 0, 0};
    return {static_cast<int>(std::lround(31 * m.x / largest)),
            static_cast<int>(std::lround(31 * m.y / largest)),
            static_cast<int>(std::lround(31 * m.z / largest))};
}

/// Encodes the slab along @p n covering every point; 0 if it cannot be represented.
std::uint32_t encodeSlab(const std::array<int, 3>& n, std::span<const Vec3d> points,
                         double& thickness) {
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const Vec3d& p : points) {
        const double v = n[0] * p.x + n[1] * p.y + n[2] * p.z;
        lo = std::min(lo, v);
        hi = std::max(hi, v);
    }
    constexpr double step = esvo::Contour::kStep;
    const auto position =
        static_cast<int>(std::clamp<long>(std::lround(0.5 * (lo + hi) / step), -64, 63));
    // Conservative: the half thickness reaches both ends from the quantised position, with a
    // little room for the ray caster's float arithmetic.
    const double reach = std::max(hi - position * step, position * step - lo) + 1e-4;
    const double t = std::ceil(2 * reach / step);
    if (t > 127) return 0;
    esvo::Contour c{n[0], n[1], n[2], position, static_cast<unsigned>(t)};
    thickness = c.thickness * step / std::sqrt(double(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]));
    return c.encode();
}

}  // namespace

ContourFit fitContour(std::span<const std::uint32_t> list,
                      const std::vector<BoxTestTriangle>& triangles, Vec3d c, double h,
                      ClipScratch& scratch) {
    auto& points = scratch.points;
    points.clear();
    const double toLocal = 0.5 / h;
    Vec3d mean{0, 0, 0};
    struct Candidate {
        double area;
        Vec3d normal;
    };
    std::array<Candidate, 3> largest{};
    for (std::uint32_t t : list) {
        const BoxTestTriangle& tri = triangles[t];
        const std::size_t before = points.size();
        clipToUnitCube({(tri.v0 - c) * toLocal, (tri.v1 - c) * toLocal, (tri.v2 - c) * toLocal},
                       points, scratch.clipA, scratch.clipB);
        // Fragment area (fan) weighs the triangle's unit normal.
        double area = 0;
        for (std::size_t i = before + 2; i < points.size(); ++i)
            area += 0.5 * length(cross(points[i - 1] - points[before], points[i] - points[before]));
        const double nl = length(tri.normal);
        if (!(nl > 0) || area <= 0) continue;
        const Vec3d unit = tri.normal * (1.0 / nl);
        mean = mean + unit * area;
        if (area > largest[2].area) {
            std::size_t i = 2;
            for (; i > 0 && area > largest[i - 1].area; --i) largest[i] = largest[i - 1];
            largest[i] = {area, unit};
        }
    }
    ContourFit best;
    if (points.empty()) return best;
    double bestRatio = 0.9;  // a contour must cut at least 10 % off the cube along its normal
    const auto consider = [&](Vec3d direction) {
        const auto n = quantiseNormal(direction);
        if (n[0] == 0 && n[1] == 0 && n[2] == 0) return;
        double thickness = 0;
        const std::uint32_t encoded = encodeSlab(n, points, thickness);
        if (!encoded) return;
        const double extent = (std::abs(n[0]) + std::abs(n[1]) + std::abs(n[2])) /
                              std::sqrt(double(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]));
        const double ratio = thickness / extent;
        if (ratio < bestRatio) {
            bestRatio = ratio;
            best = {encoded, thickness};
        }
    };
    consider(mean);
    // The mean normal is enough for smooth patches; edges and corners need the others.
    for (const Candidate& cand : largest)
        if (cand.area > 0 && bestRatio > 0.1) consider(cand.normal);
    return best;
}

std::uint32_t carryContour(std::uint32_t encoded, std::uint32_t slot, double& thickness) {
    if (encoded == 0) return 0;
    esvo::Contour c = esvo::Contour::decode(encoded);
    // Positions are in steps of 0.75, the offsets Σ n·(½ − bit) in steps of 0.5: only whole steps
    // survive exactly; round the position outward by widening the slab instead.
    const double offset = 0.5 * ((slot & 1u ? -c.nx : c.nx) + (slot & 2u ? -c.ny : c.ny) +
                                 (slot & 4u ? -c.nz : c.nz));
    const double centre = 2 * c.position * esvo::Contour::kStep + offset;
    const double half = c.thickness * esvo::Contour::kStep;  // doubled, then halved
    const long position = std::lround(centre / esvo::Contour::kStep);
    const double reach = half + std::abs(centre - position * esvo::Contour::kStep);
    const double t = std::ceil(2 * reach / esvo::Contour::kStep - 1e-9);
    if (position < -64 || position > 63 || t > 127) return 0;
    c.position = static_cast<int>(position);
    c.thickness = static_cast<unsigned>(t);
    thickness = c.thickness * esvo::Contour::kStep /
                std::sqrt(double(c.nx * c.nx + c.ny * c.ny + c.nz * c.nz));
    return c.encode();
}

}  // namespace reference

namespace {

using vox::Vec3d;
using vox::detail::BoxTestTriangle;

/// Random triangles around a cube of centre @p c and half-extent @p h, of many kinds: generic,
/// small inside, large through it, slivers and needles, degenerate, and with coordinates snapped
/// to the cube's grid of quarter-extents (vertices, edges and faces on the children's boundaries).
class TriangleSource {
public:
    explicit TriangleSource(std::uint32_t seed) : rng_(seed) {}

    BoxTestTriangle next(Vec3d c, double h) {
        const int kind = static_cast<int>(rng_() % 8);
        const auto around = [&](double spread) {
            return Vec3d{c.x + spread * h * u(), c.y + spread * h * u(), c.z + spread * h * u()};
        };
        const auto snapped = [&](int steps) {
            const auto k = [&] { return static_cast<int>(rng_() % (2 * steps + 1)) - steps; };
            return Vec3d{c.x + h * k() / 2.0, c.y + h * k() / 2.0, c.z + h * k() / 2.0};
        };
        Vec3d p0, p1, p2;
        switch (kind) {
            case 0:
                p0 = around(1.5);
                p1 = around(1.5);
                p2 = around(1.5);
                break;  // generic
            case 1: {   // small
                const Vec3d base = around(1.1);
                const double s = 0.3 * h * std::abs(u());
                p0 = base;
                p1 = base + Vec3d{s * u(), s * u(), s * u()};
                p2 = base + Vec3d{s * u(), s * u(), s * u()};
                break;
            }
            case 2:
                p0 = around(6);
                p1 = around(6);
                p2 = around(6);
                break;  // large
            case 3: {   // sliver / needle
                p0 = around(1.5);
                p1 = around(1.5);
                const double t = 0.5 + 0.5 * u(), off = std::pow(10.0, -3 - 10 * std::abs(u())) * h;
                p2 = p0 + (p1 - p0) * t + Vec3d{off * u(), off * u(), off * u()};
                break;
            }
            case 4:
                p0 = snapped(3);
                p1 = snapped(3);
                p2 = snapped(3);
                break;  // on the grid
            case 5:
                p0 = snapped(2);
                p1 = snapped(4);
                p2 = around(1.5);
                break;  // partly on it
            case 6: {   // degenerate
                p0 = around(1.5);
                p1 = rng_() % 2 ? p0 : around(1.5);
                p2 = p0 + (p1 - p0) * u();
                break;
            }
            default: {  // next to a boundary, by a hair
                p0 = snapped(2);
                p1 = snapped(2);
                p2 = snapped(2);
                const double hair =
                    h * std::pow(10.0, -6 - 8 * std::abs(u())) * (rng_() % 2 ? 1 : -1);
                const int axis = static_cast<int>(rng_() % 3);
                p0[axis] += hair;
                p1[axis] += hair;
                p2[axis] += hair;
                break;
            }
        }
        return vox::detail::prepareBoxTest(p0, p1, p2);
    }
    /// A cube centre of a node at one of many levels: leaf units up to 2^12, so that the
    /// coordinates relative to it round.
    std::pair<Vec3d, double> cube() {
        const int level = static_cast<int>(rng_() % 12);
        const double h = std::ldexp(1.0, level);
        const auto centre = [&] {
            return (2.0 * static_cast<double>(rng_() % (1u << (12 - level))) + 1) * h;
        };
        return {{centre(), centre(), centre()}, h};
    }
    double u() { return std::uniform_real_distribution<double>(-1, 1)(rng_); }

private:
    std::mt19937_64 rng_;
};

TEST(TriangleBox, ChildOverlapMaskEqualsTheReferenceBitForBit) {
    TriangleSource source(1);
    long inside = 0;
    for (int trial = 0; trial < 2000000; ++trial) {
        const auto [c, h] = source.cube();
        const BoxTestTriangle tri = source.next(c, h);
        const std::uint32_t expected = reference::childOverlapMask(tri, c, h);
        ASSERT_EQ(vox::detail::childOverlapMask(tri, c, h), expected)
            << "trial " << trial << ": (" << tri.v0.x << " " << tri.v0.y << " " << tri.v0.z << ") ("
            << tri.v1.x << " " << tri.v1.y << " " << tri.v1.z << ") (" << tri.v2.x << " "
            << tri.v2.y << " " << tri.v2.z << ") c " << c.x << " " << c.y << " " << c.z << " h "
            << h;
        inside += expected != 0;
    }
    EXPECT_GT(inside, 500000);
}

TEST(TriangleBox, ChildOverlapMaskEqualsEightSingleCubeTests) {
    // Exactly representable coordinates (small dyadic numbers): no rounding anywhere, so touching
    // is exact and both tests must call it contact; generic random ones lie within the margin of
    // a boundary with negligible probability.
    TriangleSource source(2);
    long touching = 0;
    for (int trial = 0; trial < 300000; ++trial) {
        const Vec3d c{0, 0, 0};
        const double h = 1;
        const BoxTestTriangle tri = source.next(c, h);
        std::uint32_t expected = 0;
        for (std::uint32_t slot = 0; slot < 8; ++slot) {
            const Vec3d child{slot & 1u ? 0.5 : -0.5, slot & 2u ? 0.5 : -0.5,
                              slot & 4u ? 0.5 : -0.5};
            if (vox::detail::triangleOverlapsCube(tri, child, 0.5)) expected |= 1u << slot;
        }
        const std::uint32_t mask = vox::detail::childOverlapMask(tri, c, h);
        // Within the rounding margin the two forms may differ (their margins are relative to
        // different centres); outside it they may not.
        const auto nearBoundary = [&] {
            for (const Vec3d& v : {tri.v0, tri.v1, tri.v2})
                for (int axis = 0; axis < 3; ++axis)
                    for (double plane : {-1.0, -0.5, 0.0, 0.5, 1.0})
                        if (const double gap = std::abs(v[axis] - plane); gap > 0 && gap < 1e-5)
                            return true;
            return false;
        };
        if (mask != expected && nearBoundary()) continue;
        ASSERT_EQ(mask, expected) << "trial " << trial << ": (" << tri.v0.x << " " << tri.v0.y
                                  << " " << tri.v0.z << ") (" << tri.v1.x << " " << tri.v1.y << " "
                                  << tri.v1.z << ") (" << tri.v2.x << " " << tri.v2.y << " "
                                  << tri.v2.z << ")";
        touching += std::popcount(mask) > 1;
    }
    EXPECT_GT(touching, 10000);
}

TEST(TriangleBox, TouchingTrianglesMarkEveryChildTheyTouch) {
    const auto tri = [](Vec3d a, Vec3d b, Vec3d c) { return vox::detail::prepareBoxTest(a, b, c); };
    // A triangle in the mid-plane z = 0 touches all eight children (closed cubes).
    EXPECT_EQ(vox::detail::childOverlapMask(tri({-0.9, -0.9, 0}, {0.9, -0.9, 0}, {0, 0.9, 0}),
                                            {0, 0, 0}, 1),
              0xFFu);
    // A small one in the mid-plane x = 0 inside the y−, z− quarter touches slots 0 and 1.
    EXPECT_EQ(vox::detail::childOverlapMask(
                  tri({0, -0.5, -0.5}, {0, -0.25, -0.5}, {0, -0.5, -0.25}), {0, 0, 0}, 1),
              0x03u);
    // One whose vertex is the cube's centre touches every child that vertex belongs to: all eight
    // touch it, but a triangle leaving it into the +x+y+z octant only meets the others at a point.
    EXPECT_EQ(vox::detail::childOverlapMask(tri({0, 0, 0}, {0.5, 0.25, 0.25}, {0.25, 0.5, 0.25}),
                                            {0, 0, 0}, 1),
              0xFFu);
    // On the cube's outer face x = +1: the +x children only.
    EXPECT_EQ(vox::detail::childOverlapMask(tri({1, -0.5, -0.5}, {1, 0.5, -0.5}, {1, 0, 0.5}),
                                            {0, 0, 0}, 1),
              0xAAu);
    // Inside one child entirely, and split by one mid-plane.
    EXPECT_EQ(vox::detail::childOverlapMask(tri({0.1, 0.1, 0.1}, {0.9, 0.2, 0.3}, {0.4, 0.8, 0.9}),
                                            {0, 0, 0}, 1),
              0x80u);
    EXPECT_EQ(vox::detail::childOverlapMask(tri({-0.5, 0.1, 0.1}, {0.5, 0.2, 0.3}, {0.4, 0.8, 0.9}),
                                            {0, 0, 0}, 1),
              0xC0u);
    // Beyond the cube by a clear gap: none.
    EXPECT_EQ(
        vox::detail::childOverlapMask(tri({1.1, 0, 0}, {1.5, 0.2, 0}, {1.2, 0, 0.5}), {0, 0, 0}, 1),
        0u);
}

TEST(TriangleBox, ClipToUnitCubeEqualsTheReferenceCoordinateForCoordinate) {
    TriangleSource source(3);
    std::vector<Vec3d> got, expected;
    std::array<Vec3d, 12> a{}, b{}, ra{}, rb{};
    long clipped = 0;
    for (int trial = 0; trial < 1000000; ++trial) {
        const BoxTestTriangle tri = source.next({0, 0, 0}, 0.5);
        const std::array<Vec3d, 3> local{tri.v0, tri.v1, tri.v2};
        got.clear();
        expected.clear();
        vox::detail::clipToUnitCube(local, got, a, b);
        reference::clipToUnitCube(local, expected, ra, rb);
        ASSERT_EQ(got.size(), expected.size()) << "trial " << trial;
        for (std::size_t i = 0; i < got.size(); ++i)
            ASSERT_TRUE(got[i] == expected[i]) << "trial " << trial << " vertex " << i;
        clipped += got.size() != 3;
    }
    EXPECT_GT(clipped, 100000);
}

TEST(TriangleBox, ContourFitOnSharedFragmentsEqualsTheReference) {
    TriangleSource source(4);
    std::mt19937 rng(5);
    vox::detail::ContourScratch scratch;
    reference::ClipScratch referenceScratch;
    int fitted = 0;
    for (int trial = 0; trial < 20000; ++trial) {
        const auto [c, h] = source.cube();
        std::vector<BoxTestTriangle> tris;
        const int count = 1 + static_cast<int>(rng() % 12);
        // Nearly coplanar patches (where the candidates coincide) and random soups.
        const bool patch = rng() % 2;
        const Vec3d n = vox::normalize(Vec3d{source.u(), source.u(), source.u()});
        for (int t = 0; t < count; ++t) {
            BoxTestTriangle tri = source.next(c, h);
            if (patch) {
                // Explicit captures: clang 14 cannot capture structured bindings.
                const auto flatten = [&, centre = c, half = h](Vec3d p) {
                    return p - n * (vox::dot(p - centre, n) - 0.01 * half * source.u());
                };
                tri =
                    vox::detail::prepareBoxTest(flatten(tri.v0), flatten(tri.v1), flatten(tri.v2));
            }
            tris.push_back(tri);
        }
        std::vector<std::uint32_t> list;
        for (std::uint32_t t = 0; t < tris.size(); ++t)
            if (vox::detail::triangleOverlapsCube(tris[t], c, h)) list.push_back(t);
        const auto expected = reference::fitContour(list, tris, c, h, referenceScratch);
        const auto got = vox::detail::fitContour(list, tris, c, h, scratch);
        ASSERT_EQ(got.encoded, expected.encoded) << "trial " << trial;
        ASSERT_EQ(got.thickness, expected.thickness) << "trial " << trial;
        // The fragments as the builder shares them with the attribute filter.
        vox::detail::CubeFragments fragments;
        fragments.clip(list, tris, c, vox::detail::fitContourScale(h));
        const auto shared = vox::detail::fitContour(fragments, list, tris);
        ASSERT_EQ(shared.encoded, expected.encoded) << "trial " << trial;
        ASSERT_TRUE(std::ranges::equal(fragments.points(), referenceScratch.points))
            << "trial " << trial;
        // With per-triangle normal lengths, an unclipped triangle's area comes from them: bit for
        // bit the fan's.
        std::vector<double> lengths;
        for (const BoxTestTriangle& tri : tris) lengths.push_back(vox::length(tri.normal));
        vox::detail::CubeFragments withLengths;
        withLengths.clip(list, tris, c, vox::detail::fitContourScale(h), lengths.data());
        ASSERT_TRUE(std::ranges::equal(withLengths.points(), fragments.points()))
            << "trial " << trial;
        for (std::size_t entry = 0; entry < list.size(); ++entry) {
            ASSERT_EQ(withLengths.area(entry), fragments.area(entry)) << "trial " << trial;
            const auto polygon = fragments.polygon(entry);
            for (std::size_t i = 2; i < polygon.size(); ++i)
                ASSERT_EQ(withLengths.fanArea(entry)[i], fragments.fanArea(entry)[i]);
        }
        std::vector<Vec3d> units;
        for (std::size_t t = 0; t < tris.size(); ++t)
            units.push_back(lengths[t] > 0 ? tris[t].normal * (1.0 / lengths[t]) : Vec3d{0, 0, 0});
        const auto cached =
            vox::detail::fitContour(withLengths, list, tris, {lengths.data(), units.data()});
        ASSERT_EQ(cached.encoded, expected.encoded) << "trial " << trial;
        ASSERT_EQ(cached.thickness, expected.thickness) << "trial " << trial;
        // With the unit normals quantised per triangle too (and a lone fragment's mean taken from
        // them where that is scale-invariant): the same fit.
        std::vector<vox::detail::QuantisedNormal> quantised;
        for (const Vec3d& unit : units)
            quantised.push_back(vox::detail::quantiseDirection(unit, true));
        const auto quantisedOnce = vox::detail::fitContour(
            withLengths, list, tris, {lengths.data(), units.data(), quantised.data()});
        ASSERT_EQ(quantisedOnce.encoded, expected.encoded) << "trial " << trial;
        ASSERT_EQ(quantisedOnce.thickness, expected.thickness) << "trial " << trial;
        fitted += expected.encoded != 0;
    }
    EXPECT_GT(fitted, 2000);
}

TEST(TriangleBox, SplitFragmentsEqualDirectlyClippedOnesWithinRounding) {
    // The builder's fragments of a voxel come from its parent's, split by the parent's mid-planes
    // (CubeFragments::splitInto), two levels down here: each must be the triangle clipped to the
    // voxel's cube directly, up to rounding (the same boundary, whatever the order of its vertices,
    // their repeats or extra ones on an edge, and its area), or, both without area, a contact.
    TriangleSource source(8);
    std::mt19937 rng(9);
    constexpr double kTolerance = 1e-11;  // local units (the cube's edge is 1)
    // Every vertex of one on the other's boundary (a cut can leave an extra vertex on an edge).
    const auto onSegment = [&](Vec3d p, Vec3d a, Vec3d b) {
        const Vec3d ab = b - a;
        const double t = vox::dot(ab, ab) > 0
                             ? std::clamp(vox::dot(p - a, ab) / vox::dot(ab, ab), 0.0, 1.0)
                             : 0.0;
        return vox::length(p - (a + ab * t)) <= kTolerance;
    };
    const auto covers = [&](std::span<const Vec3d> from, std::span<const Vec3d> to) {
        return std::ranges::all_of(from, [&](Vec3d p) {
            for (std::size_t i = 0; i < to.size(); ++i)
                if (onSegment(p, to[i], to[(i + 1) % to.size()])) return true;
            return false;
        });
    };
    long compared = 0, cut = 0, contacts = 0;
    std::vector<std::array<vox::detail::CubeFragments, 8>> levels(2);
    for (int trial = 0; trial < 30000; ++trial) {
        const auto [c, h] = source.cube();
        std::vector<BoxTestTriangle> tris;
        for (int t = 0, count = 1 + static_cast<int>(rng() % 8); t < count; ++t)
            tris.push_back(source.next(c, h));
        std::vector<std::uint32_t> list;
        for (std::uint32_t t = 0; t < tris.size(); ++t)
            if (vox::detail::triangleOverlapsCube(tris[t], c, h)) list.push_back(t);
        vox::detail::CubeFragments parent;
        parent.clip(list, tris, c, vox::detail::fitContourScale(h));
        // Down to a random child and grandchild: compare every child of each.
        Vec3d centre = c;
        double half = h;
        vox::detail::CubeFragments* fragments = &parent;
        for (std::size_t depth = 0; depth < levels.size() && !list.empty(); ++depth) {
            std::array<std::vector<std::uint32_t>, 8> children;
            std::vector<std::uint32_t> masks;
            for (const std::uint32_t t : list) {
                masks.push_back(vox::detail::childOverlapMask(tris[t], centre, half));
                for (std::uint32_t slot = 0; slot < 8; ++slot)
                    if (masks.back() & (1u << slot)) children[slot].push_back(t);
            }
            for (std::uint32_t slot = 0; slot < 8; ++slot)
                levels[depth][slot].start(children[slot].size());
            for (std::size_t entry = 0; entry < list.size(); ++entry)
                if (masks[entry]) fragments->splitInto(entry, masks[entry], levels[depth]);
            const double q = 0.5 * half;
            for (std::uint32_t slot = 0; slot < 8; ++slot) {
                const Vec3d childCentre{centre.x + (slot & 1u ? q : -q),
                                        centre.y + (slot & 2u ? q : -q),
                                        centre.z + (slot & 4u ? q : -q)};
                vox::detail::CubeFragments direct;
                direct.clip(children[slot], tris, childCentre, vox::detail::fitContourScale(q));
                const vox::detail::CubeFragments& split = levels[depth][slot];
                ASSERT_EQ(split.size(), children[slot].size());
                for (std::size_t entry = 0; entry < children[slot].size(); ++entry) {
                    const auto a = split.polygon(entry), b = direct.polygon(entry);
                    ASSERT_NEAR(split.area(entry), direct.area(entry), kTolerance)
                        << "trial " << trial << " depth " << depth << " slot " << slot;
                    if (std::max(split.area(entry), direct.area(entry)) <= kTolerance) {
                        // A contact without area (a touching edge or vertex, or nothing within the
                        // box test's margin): its points may differ with the order of the cuts.
                        ++contacts;
                        continue;
                    }
                    ASSERT_TRUE(covers(a, b) && covers(b, a))
                        << "trial " << trial << " depth " << depth << " slot " << slot << " entry "
                        << entry;
                    ++compared;
                    cut += b.size() != 3;
                }
            }
            // On to a touched child.
            std::uint32_t slot = static_cast<std::uint32_t>(rng() % 8);
            for (int tries = 0; tries < 8 && children[slot].empty(); ++tries) slot = (slot + 1) % 8;
            const double quarter = 0.5 * half;
            centre = {centre.x + (slot & 1u ? quarter : -quarter),
                      centre.y + (slot & 2u ? quarter : -quarter),
                      centre.z + (slot & 4u ? quarter : -quarter)};
            half = quarter;
            list = children[slot];
            fragments = &levels[depth][slot];
        }
    }
    EXPECT_GT(compared, 200000);
    EXPECT_GT(cut, 50000);
    EXPECT_LT(contacts,
              compared);  // the source makes many touching and degenerate triangles on purpose
}

TEST(TriangleBox, LinearBarycentricsEqualTheProjectionsWithinRounding) {
    // The texture footprint's barycentric coordinates (BarycentricFrame::Linear, two dot products)
    // against the projection's (barycentric(), two divisions), for points of triangles of every
    // kind the source makes: inside and around them (clamped alike), and degenerate ones.
    TriangleSource source(10);
    double worst = 0;
    for (int trial = 0; trial < 200000; ++trial) {
        const auto [c, h] = source.cube();
        const BoxTestTriangle tri = source.next(c, h);
        const std::array<Vec3d, 3> corners{tri.v0, tri.v1, tri.v2};
        const vox::detail::BarycentricFrame frame(corners);
        const auto linear = frame.linear();
        const double a = 0.5 + 0.5 * source.u(), b = (1 - a) * (0.5 + 0.6 * source.u());
        const Vec3d p =
            tri.v0 * (1 - a - b) + tri.v1 * a + tri.v2 * b;  // slightly outside now and then
        const Vec3d expected = vox::detail::barycentric(corners, p), got = linear(p);
        ASSERT_EQ(frame(p).x, expected.x);  // the frame is barycentric() itself
        // Relative to the triangle's conditioning: its coordinates solve the normal equations
        // either way, accurate to about ε times the square of the ratio of its longest edge to its
        // height, and times the ratio of the coordinates' magnitude to its size (p is rounded
        // there).
        const double edge2 = std::max({vox::dot(tri.v1 - tri.v0, tri.v1 - tri.v0),
                                       vox::dot(tri.v2 - tri.v0, tri.v2 - tri.v0),
                                       vox::dot(tri.v2 - tri.v1, tri.v2 - tri.v1)});
        const double area2 = vox::dot(tri.normal, tri.normal);
        if (!(area2 > 1e-12 * edge2 * edge2))
            continue;  // degenerate or a needle: ill-conditioned either way
        const double magnitude =
            std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)}) / std::sqrt(edge2);
        const double tolerance =
            64 * std::numeric_limits<double>::epsilon() * (edge2 * edge2 / area2) * (1 + magnitude);
        for (int k = 0; k < 3; ++k) {
            ASSERT_NEAR(got[k], expected[k], tolerance) << "trial " << trial << " coordinate " << k;
            worst = std::max(worst, std::abs(got[k] - expected[k]) / tolerance);
        }
    }
    EXPECT_LT(worst, 1.0);
    // A degenerate triangle: the centroid either way.
    const vox::detail::BarycentricFrame flat({Vec3d{0, 0, 0}, Vec3d{1, 1, 1}, Vec3d{2, 2, 2}});
    EXPECT_EQ(flat.linear()(Vec3d{1, 1, 1}).x, 1.0 / 3);
}

TEST(TriangleBox, CarryContourEqualsTheReference) {
    std::mt19937 rng(6);
    std::uniform_int_distribution<int> component(-32, 31), position(-64, 63), thickness(0, 127);
    for (int trial = 0; trial < 200000; ++trial) {
        const vox::esvo::Contour c{component(rng), component(rng), component(rng), position(rng),
                                   static_cast<unsigned>(thickness(rng))};
        const std::uint32_t encoded = trial % 50 == 0 ? 0u : c.encode();
        for (std::uint32_t slot = 0; slot < 8; ++slot) {
            double expectedThickness = -1, thicknessOut = -1;
            const std::uint32_t expected =
                reference::carryContour(encoded, slot, expectedThickness);
            ASSERT_EQ(vox::detail::carryContour(encoded, slot, thicknessOut), expected)
                << trial << " slot " << slot;
            ASSERT_EQ(thicknessOut, expectedThickness) << trial << " slot " << slot;
        }
    }
    // Every position and thickness for normals at the ends of the range.
    for (const std::array<int, 3> n : {std::array<int, 3>{31, 0, 0},
                                       {-32, 31, -32},
                                       {31, 31, 31},
                                       {-32, -32, -32},
                                       {0, 0, -32},
                                       {17, -5, 31},
                                       {-31, 30, 1},
                                       {1, 1, 31},
                                       {0, -1, 0},
                                       {-7, 31, -13}}) {
        for (int p = -64; p <= 63; ++p)
            for (unsigned t = 0; t <= 127; ++t) {
                const std::uint32_t encoded = vox::esvo::Contour{n[0], n[1], n[2], p, t}.encode();
                for (std::uint32_t slot = 0; slot < 8; ++slot) {
                    double expectedThickness = -1, thicknessOut = -1;
                    const std::uint32_t expected =
                        reference::carryContour(encoded, slot, expectedThickness);
                    ASSERT_EQ(vox::detail::carryContour(encoded, slot, thicknessOut), expected)
                        << p << " " << t << " slot " << slot;
                    ASSERT_EQ(thicknessOut, expectedThickness);
                }
            }
    }
}

}  // namespace
