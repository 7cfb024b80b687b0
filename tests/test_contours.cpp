// Contour fitting, encoding and carrying (libvox/src/octree/contours.h): the slab must contain the
// geometry it bounds after quantisation, a carried slab must contain its parent's part in the
// child, and the shape error must measure cube ∩ slab.
#include "octree/contours.h"

#include <vox/formats/esvo.h>

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace {

using vox::Vec3d;
using vox::detail::BoxTestTriangle;

/// Is voxel-local point @p u inside the slab of @p encoded (with the ray caster's tolerance)?
bool insideSlab(std::uint32_t encoded, Vec3d u, double slack = 1e-9) {
    const vox::esvo::Contour c = vox::esvo::Contour::decode(encoded);
    const double v = c.nx * u.x + c.ny * u.y + c.nz * u.z;
    return std::abs(v - c.position * vox::esvo::Contour::kStep) <=
           0.5 * c.thickness * vox::esvo::Contour::kStep + slack;
}

TEST(Contours, EncodeDecodeRoundTripsEveryField) {
    for (const vox::esvo::Contour c :
         {vox::esvo::Contour{31, -5, 0, -64, 127}, vox::esvo::Contour{-31, 31, -32, 63, 0},
          vox::esvo::Contour{0, 0, 31, 0, 1}}) {
        const auto d = vox::esvo::Contour::decode(c.encode());
        EXPECT_EQ(d.nx, c.nx);
        EXPECT_EQ(d.ny, c.ny);
        EXPECT_EQ(d.nz, c.nz);
        EXPECT_EQ(d.position, c.position);
        EXPECT_EQ(d.thickness, c.thickness);
    }
    // Bit positions from the reference layout: thickness 25-31, position 18-24, nx 12-17, ny 6-11,
    // nz 0-5.
    EXPECT_EQ((vox::esvo::Contour{1, 0, 0, 0, 0}.encode()), 1u << 12);
    EXPECT_EQ((vox::esvo::Contour{0, 0, 0, 1, 0}.encode()), 1u << 18);
    EXPECT_EQ((vox::esvo::Contour{0, 0, 0, 0, 1}.encode()), 1u << 25);
}

TEST(Contours, FittedSlabContainsEveryFragmentAfterQuantisation) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> coord(-1.5, 1.5);
    vox::detail::ContourScratch scratch;
    int fitted = 0;
    for (int trial = 0; trial < 2000; ++trial) {
        // A few triangles around a cube of centre 0 and half-extent 1 (local u = p / 2).
        std::vector<BoxTestTriangle> tris;
        const Vec3d base{coord(rng), coord(rng), coord(rng)};
        const Vec3d n = vox::normalize(Vec3d{coord(rng), coord(rng), coord(rng)});
        for (int t = 0; t < 3; ++t) {
            // Nearly coplanar triangles: the case contours are for.
            const auto onPlane = [&] {
                Vec3d p{coord(rng), coord(rng), coord(rng)};
                p = p - n * (vox::dot(p - base, n) - 0.02 * coord(rng));
                return p;
            };
            tris.push_back(vox::detail::prepareBoxTest(onPlane(), onPlane(), onPlane()));
        }
        std::vector<std::uint32_t> list;
        for (std::uint32_t t = 0; t < tris.size(); ++t)
            if (vox::detail::triangleOverlapsCube(tris[t], {0, 0, 0}, 1.0)) list.push_back(t);
        if (list.empty()) continue;
        const auto fit = vox::detail::fitContour(list, tris, {0, 0, 0}, 1.0, scratch);
        if (!fit.encoded) continue;
        ++fitted;
        const auto c = vox::esvo::Contour::decode(fit.encoded);
        EXPECT_EQ(std::max({std::abs(c.nx), std::abs(c.ny), std::abs(c.nz)}), 31);
        // Every point of every triangle inside the cube lies in the slab: sample them.
        for (std::uint32_t t : list)
            for (int i = 0; i <= 20; ++i)
                for (int j = 0; i + j <= 20; ++j) {
                    const BoxTestTriangle& tri = tris[t];
                    const Vec3d p =
                        tri.v0 + (tri.v1 - tri.v0) * (i / 20.0) + (tri.v2 - tri.v0) * (j / 20.0);
                    if (std::abs(p.x) > 1 || std::abs(p.y) > 1 || std::abs(p.z) > 1) continue;
                    ASSERT_TRUE(insideSlab(fit.encoded, p * 0.5)) << "trial " << trial;
                }
        // The slab must be thin for nearly coplanar geometry (±0.02 of a plane in a cube of 2).
        EXPECT_LT(fit.thickness, 0.2) << "trial " << trial;
    }
    EXPECT_GT(fitted, 500);
}

TEST(Contours, CarriedSlabContainsTheParentSlabInsideTheChild) {
    std::mt19937 rng(11);
    std::uniform_int_distribution<int> component(-31, 31), position(-20, 20), thickness(0, 40);
    std::uniform_real_distribution<double> unit(-0.5, 0.5);
    int carried = 0;
    for (int trial = 0; trial < 3000; ++trial) {
        vox::esvo::Contour c{component(rng), component(rng), 31, position(rng),
                             static_cast<unsigned>(thickness(rng))};
        if (trial % 3 == 1) std::swap(c.nx, c.nz);
        const std::uint32_t parent = c.encode();
        for (std::uint32_t slot = 0; slot < 8; ++slot) {
            double t = 0;
            const std::uint32_t child = vox::detail::carryContour(parent, slot, t);
            if (!child) continue;
            ++carried;
            // Any point of the child cube inside the parent's slab is inside the carried slab.
            for (int k = 0; k < 40; ++k) {
                const Vec3d uc{unit(rng), unit(rng), unit(rng)};
                const Vec3d up{0.5 * uc.x + (slot & 1u ? 0.25 : -0.25),
                               0.5 * uc.y + (slot & 2u ? 0.25 : -0.25),
                               0.5 * uc.z + (slot & 4u ? 0.25 : -0.25)};
                if (insideSlab(parent, up)) {
                    ASSERT_TRUE(insideSlab(child, uc, 1e-9)) << trial << " slot " << slot;
                }
            }
        }
    }
    EXPECT_GT(carried, 10000);
}

TEST(Contours, ShapeWithinErrorAgreesWithShapeError) {
    // Random triangle soups in a cube, with their fitted slab and without: the bounded test is
    // shapeError <= bound, for bounds around the error itself.
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> coordinate(-1.5, 1.5);
    int agreed = 0, within = 0;
    for (int trial = 0; trial < 300; ++trial) {
        std::vector<BoxTestTriangle> tris;
        std::vector<std::uint32_t> list;
        const int count = 1 + trial % 6;
        for (int i = 0; i < count; ++i) {
            const Vec3d a{coordinate(rng), coordinate(rng), coordinate(rng)};
            tris.push_back(vox::detail::prepareBoxTest(
                a, a + Vec3d{coordinate(rng), coordinate(rng), 0.2 * coordinate(rng)},
                a + Vec3d{coordinate(rng), 0.2 * coordinate(rng), coordinate(rng)}));
            list.push_back(static_cast<std::uint32_t>(i));
        }
        vox::detail::ContourScratch scratch;
        const std::uint32_t slab =
            vox::detail::fitContour(list, tris, {0, 0, 0}, 1.0, scratch).encoded;
        for (const std::uint32_t encoded : {0u, slab}) {
            const double error = vox::detail::shapeError(encoded, list, tris, {0, 0, 0}, 1.0);
            for (const double bound : {0.5 * error, 0.999 * error, 1.001 * error, 2 * error}) {
                const bool expected = error <= bound;
                EXPECT_EQ(vox::detail::shapeWithinError(encoded, list, tris, {0, 0, 0}, 1.0, bound),
                          expected)
                    << trial << " error " << error << " bound " << bound;
                agreed += 1;
                within += expected;
            }
        }
    }
    EXPECT_GT(within, agreed / 4);
    EXPECT_LT(within, agreed);
}

TEST(Contours, ShapeErrorMeasuresCubeAndSlab) {
    // One big triangle on the plane z = 0.1 (leaf units) through a cube of centre 0, half 1.
    std::vector<BoxTestTriangle> tris{
        vox::detail::prepareBoxTest({-10, -10, 0.1}, {10, -10, 0.1}, {0, 10, 0.1})};
    const std::vector<std::uint32_t> list{0};
    // Cube alone: the far corners are 1.1 away.
    EXPECT_NEAR(vox::detail::shapeError(0, list, tris, {0, 0, 0}, 1.0), 1.1, 1e-9);
    vox::detail::ContourScratch scratch;
    const auto fit = vox::detail::fitContour(list, tris, {0, 0, 0}, 1.0, scratch);
    ASSERT_NE(fit.encoded, 0u);
    const auto c = vox::esvo::Contour::decode(fit.encoded);
    EXPECT_EQ(c.nx, 0);
    EXPECT_EQ(c.ny, 0);
    EXPECT_EQ(std::abs(c.nz), 31);
    // With the slab: within its thickness of the plane (thickness ≤ one 0.75 step of 31 units,
    // i.e. 2 × 0.75 / 31 of the edge of 2).
    const double error = vox::detail::shapeError(fit.encoded, list, tris, {0, 0, 0}, 1.0);
    EXPECT_LT(error, 2 * 2 * 0.75 / 31 + 1e-9);
}

}  // namespace
