// voxelizeSurface (libvox/src/octree/voxelize_surface.cpp): the leaf set must be exactly the
// leaf cubes a triangle touches (closed cubes), checked against an independent brute force that
// clips each triangle against every leaf cube; the per-level masks must be consistent; the result
// must not depend on the thread count; deep octrees stay sparse; bad input is rejected;
// error-bounded, leaf-depth voxels inherit their parents' slabs and voxels whose colour varies
// stop only within half the contour error.
#include <vox/base/error.h>
#include <vox/formats/esvo.h>
#include <vox/import.h>
#include <vox/octree.h>
#include <vox/scene.h>
#include <vox/util/parallel.h>

#include "octree/contours.h"
#include "test_support.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <set>
#include <vector>

namespace {

using vox::Vec3d;
using vox::Vec3f;

using Triangle = std::array<Vec3f, 3>;

/// One mesh holding @p triangles (unshared vertices, face normals), material 0.
vox::Mesh makeMesh(const std::vector<Triangle>& triangles, bool dynamic = false) {
    vox::Mesh mesh;
    mesh.name = dynamic ? "dynamic" : "static";
    mesh.material = 0;
    mesh.dynamic = dynamic;
    for (const Triangle& t : triangles) {
        Vec3f n = vox::normalize(vox::cross(t[1] - t[0], t[2] - t[0]));
        if (n == Vec3f{0, 0, 0}) n = {0, 0, 1};
        for (const Vec3f& p : t) {
            mesh.indices.push_back(static_cast<std::uint32_t>(mesh.positions.size()));
            mesh.positions.push_back(p);
            mesh.normals.push_back(n);
        }
    }
    return mesh;
}

vox::Scene makeScene(const std::vector<Triangle>& triangles) {
    vox::Scene scene;
    scene.materials.push_back(vox::Material{});
    scene.meshes.push_back(makeMesh(triangles));
    return scene;
}

vox::SparseOctree voxelize(const vox::Scene& scene, std::uint32_t depth,
                           bool includeDynamic = false) {
    vox::SurfaceVoxelizeOptions options;
    options.depth = depth;
    options.includeDynamic = includeDynamic;
    return vox::voxelizeSurface(scene, options);
}

using Key = std::uint64_t;  // x | y << 21 | z << 42
Key key(std::uint64_t x, std::uint64_t y, std::uint64_t z) { return x | (y << 21) | (z << 42); }
std::string keyText(Key k) {
    return "(" + std::to_string(k & 0x1FFFFF) + "," + std::to_string((k >> 21) & 0x1FFFFF) + "," +
           std::to_string(k >> 42) + ")";
}

/// Structural checks, then the leaf coordinates decoded from the per-level masks: the children of
/// level-l voxels are the level-(l+1) voxels in order, slot bit 0 = +x, bit 1 = +y, bit 2 = +z.
std::set<Key> decodeLeaves(const vox::SparseOctree& octree) {
    std::set<Key> leaves;
    EXPECT_EQ(octree.masks.size(), octree.leafDepth);
    EXPECT_EQ(octree.voxelsPerLevel.size(), octree.leafDepth + 1);
    if (octree.masks.size() != octree.leafDepth ||
        octree.voxelsPerLevel.size() != octree.leafDepth + 1)
        return leaves;
    std::vector<std::array<std::uint32_t, 3>> level{{0, 0, 0}};
    for (std::uint32_t l = 0; l < octree.leafDepth; ++l) {
        const auto& masks = octree.masks[l];
        EXPECT_EQ(masks.size(), level.size()) << "level " << l;
        EXPECT_EQ(octree.voxelsPerLevel[l], level.size()) << "level " << l;
        if (masks.size() != level.size()) return leaves;
        std::vector<std::array<std::uint32_t, 3>> next;
        for (std::size_t i = 0; i < masks.size(); ++i) {
            EXPECT_NE(masks[i], 0) << "empty interior voxel at level " << l << " index " << i
                                   << " at " << keyText(key(level[i][0], level[i][1], level[i][2]));
            for (std::uint32_t slot = 0; slot < 8; ++slot)
                if (masks[i] & (1u << slot))
                    next.push_back({2 * level[i][0] + (slot & 1u),
                                    2 * level[i][1] + ((slot >> 1) & 1u),
                                    2 * level[i][2] + (slot >> 2)});
        }
        level = std::move(next);
    }
    EXPECT_EQ(octree.voxelsPerLevel[octree.leafDepth], level.size());
    for (const auto& v : level) {
        const Key k = key(v[0], v[1], v[2]);
        EXPECT_TRUE(leaves.insert(k).second) << "leaf listed twice " << keyText(k);
    }
    return leaves;
}

// ---- independent overlap test: Sutherland–Hodgman clipping against a closed box ---------------

/// True if the triangle (in leaf units) intersects the closed box [lo, hi] (per axis), found by
/// clipping the triangle polygon against the six half-spaces and checking something is left.
bool clipOverlaps(const std::array<Vec3d, 3>& tri, const Vec3d& lo, const Vec3d& hi) {
    std::vector<Vec3d> poly(tri.begin(), tri.end()), out;
    for (int axis = 0; axis < 3 && !poly.empty(); ++axis)
        for (int side = 0; side < 2 && !poly.empty(); ++side) {
            const double plane = side == 0 ? lo[axis] : hi[axis];
            const auto inside = [&](const Vec3d& p) {
                return side == 0 ? p[axis] >= plane : p[axis] <= plane;
            };
            out.clear();
            for (std::size_t i = 0; i < poly.size(); ++i) {
                const Vec3d& a = poly[i];
                const Vec3d& b = poly[(i + 1) % poly.size()];
                const bool ina = inside(a), inb = inside(b);
                if (ina) out.push_back(a);
                if (ina != inb) {
                    const double s = (plane - a[axis]) / (b[axis] - a[axis]);
                    Vec3d p = a + (b - a) * s;
                    p[axis] = plane;  // exactly on the plane despite rounding
                    out.push_back(p);
                }
            }
            poly.swap(out);
        }
    return !poly.empty();
}

/// The scene's triangles in leaf units of a cube computed here (not by the library): minimum
/// corner at the bounds' minimum, edge the longest extent.
struct LeafFrame {
    Vec3d origin;
    double size = 1;
    std::uint32_t depth = 0;
    [[nodiscard]] Vec3d toLeaf(Vec3f p) const {
        const double scale = std::ldexp(1.0, static_cast<int>(depth)) / size;
        return {(double(p.x) - origin.x) * scale, (double(p.y) - origin.y) * scale,
                (double(p.z) - origin.z) * scale};
    }
};

LeafFrame frameFor(const std::vector<Triangle>& triangles, std::uint32_t depth) {
    Vec3d lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
    for (const Triangle& t : triangles)
        for (const Vec3f& p : t)
            for (int a = 0; a < 3; ++a) {
                lo[a] = std::min(lo[a], double(p[a]));
                hi[a] = std::max(hi[a], double(p[a]));
            }
    LeafFrame f;
    f.origin = lo;
    f.size = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z});
    if (!(f.size > 0)) f.size = 1;
    f.depth = depth;
    return f;
}

/// Brute force over every leaf cube of the root cube (or of [from, to) per axis): the cubes,
/// grown by @p grow leaf units on every side, that some triangle overlaps.
std::set<Key> bruteForce(const std::vector<Triangle>& triangles, const LeafFrame& frame,
                         double grow, std::array<std::uint32_t, 3> from = {0, 0, 0},
                         std::array<std::uint32_t, 3> to = {0, 0, 0}) {
    const std::uint32_t n = 1u << frame.depth;
    if (to == std::array<std::uint32_t, 3>{0, 0, 0}) to = {n, n, n};
    std::vector<std::array<Vec3d, 3>> leafTris;
    for (const Triangle& t : triangles)
        leafTris.push_back({frame.toLeaf(t[0]), frame.toLeaf(t[1]), frame.toLeaf(t[2])});
    std::set<Key> result;
    for (std::uint32_t z = from[2]; z < to[2]; ++z)
        for (std::uint32_t y = from[1]; y < to[1]; ++y)
            for (std::uint32_t x = from[0]; x < to[0]; ++x) {
                const Vec3d lo{x - grow, y - grow, z - grow},
                    hi{x + 1 + grow, y + 1 + grow, z + 1 + grow};
                for (const auto& t : leafTris)
                    if (clipOverlaps(t, lo, hi)) {
                        result.insert(key(x, y, z));
                        break;
                    }
            }
    return result;
}

/// The octree's leaves must contain every cube the triangles overlap even when shrunk by @p eps,
/// and no cube they miss even when grown by @p eps; and they must equal the brute force on the
/// exact cubes (closed: touching counts). Returns how many cubes lie within @p eps of a triangle
/// without overlapping the shrunk cube (touching cubes, e.g. on the root cube's far face).
std::size_t expectExactLeaves(const std::vector<Triangle>& triangles,
                              const vox::SparseOctree& octree, double eps) {
    const LeafFrame frame = frameFor(triangles, octree.leafDepth);
    EXPECT_EQ(octree.cube.origin, frame.origin);
    EXPECT_EQ(octree.cube.size, frame.size);
    const std::set<Key> leaves = decodeLeaves(octree);
    const std::set<Key> must = bruteForce(triangles, frame, -eps);
    const std::set<Key> may = bruteForce(triangles, frame, eps);
    std::size_t missing = 0, extra = 0;
    for (Key k : must)
        if (!leaves.count(k) && ++missing <= 10) ADD_FAILURE() << "leaf missing at " << keyText(k);
    for (Key k : leaves)
        if (!may.count(k) && ++extra <= 10)
            ADD_FAILURE() << "leaf where no triangle is, at " << keyText(k);
    EXPECT_EQ(missing, 0u);
    EXPECT_EQ(extra, 0u);
    EXPECT_FALSE(must.empty());
    const std::set<Key> exact = bruteForce(triangles, frame, 0.0);
    EXPECT_TRUE(leaves == exact) << leaves.size() << " leaves, brute force on closed cubes "
                                 << exact.size();
    return may.size() - must.size();
}

/// Uniform in [0, 1) from the engine's bits (std::mt19937's output is the same everywhere, the
/// standard distributions' is not).
float unit(std::mt19937& rng) { return static_cast<float>(rng() >> 8) * 0x1p-24f; }

Vec3f randomPoint(std::mt19937& rng, Vec3f centre, float radius) {
    const auto u = [&] { return 2.0f * unit(rng) - 1.0f; };
    const float x = u(), y = u(), z = u();
    return {centre.x + radius * x, centre.y + radius * y, centre.z + radius * z};
}

/// A mix of triangle shapes: big ones across the cube, small ones, slivers, axis-aligned ones and
/// one degenerate (collinear) triangle.
std::vector<Triangle> randomTriangles(std::uint32_t seed, int count) {
    std::mt19937 rng(seed);
    std::vector<Triangle> tris;
    for (int i = 0; i < count; ++i) {
        const float cx = unit(rng), cy = unit(rng), cz = unit(rng);
        const Vec3f c{cx, cy, cz};
        switch (i % 5) {
            case 0:  // large
                tris.push_back({randomPoint(rng, {0.5f, 0.5f, 0.5f}, 0.5f),
                                randomPoint(rng, {0.5f, 0.5f, 0.5f}, 0.5f),
                                randomPoint(rng, {0.5f, 0.5f, 0.5f}, 0.5f)});
                break;
            case 1:  // small, about a leaf voxel or less at depth 4-5
                tris.push_back({randomPoint(rng, c, 0.03f), randomPoint(rng, c, 0.03f),
                                randomPoint(rng, c, 0.03f)});
                break;
            case 2: {  // sliver
                const Vec3f a = randomPoint(rng, c, 0.3f), b = randomPoint(rng, c, 0.3f);
                tris.push_back({a, b, a + (b - a) * 0.5f + Vec3f{0.004f, -0.003f, 0.002f}});
                break;
            }
            case 3: {  // axis-aligned: constant coordinate along a random axis
                Triangle t{randomPoint(rng, c, 0.25f), randomPoint(rng, c, 0.25f),
                           randomPoint(rng, c, 0.25f)};
                const int axis = static_cast<int>(rng() % 3);
                t[1][axis] = t[2][axis] = t[0][axis];
                tris.push_back(t);
                break;
            }
            default: {  // medium
                tris.push_back({randomPoint(rng, c, 0.15f), randomPoint(rng, c, 0.15f),
                                randomPoint(rng, c, 0.15f)});
                break;
            }
        }
    }
    const Vec3f a = randomPoint(rng, {0.5f, 0.5f, 0.5f}, 0.4f),
                b = randomPoint(rng, {0.5f, 0.5f, 0.5f}, 0.4f);
    tris.push_back({a, b, a + (b - a) * 0.25f});  // degenerate: a segment
    return tris;
}

/// Tiny triangles at (0,0,0) and (1,1,1) that pin the root cube to the unit cube.
std::vector<Triangle> unitCubeAnchors() {
    const float d = std::ldexp(1.0f, -22);  // below a leaf even at depth 20
    return {Triangle{Vec3f{0, 0, 0}, Vec3f{d, 0, 0}, Vec3f{0, d, 0}},
            Triangle{Vec3f{1, 1, 1}, Vec3f{1 - d, 1, 1}, Vec3f{1, 1 - d, 1}}};
}

}  // namespace

// (a) exactness against the brute force, on random triangles.
TEST(VoxelizeSurface, LeavesAreExactlyTheCubesTrianglesTouch) {
    struct Case {
        std::uint32_t seed;
        int count;
        std::uint32_t depth;
    };
    std::size_t ambiguous = 0, leafTotal = 0;
    for (const Case c : {Case{1, 1, 4}, Case{2, 3, 5}, Case{3, 10, 4}, Case{4, 10, 5},
                         Case{5, 25, 5}, Case{6, 40, 4}}) {
        SCOPED_TRACE("seed " + std::to_string(c.seed) + ", depth " + std::to_string(c.depth));
        const std::vector<Triangle> tris = randomTriangles(c.seed, c.count);
        const vox::SparseOctree octree = voxelize(makeScene(tris), c.depth);
        EXPECT_EQ(octree.leafDepth, c.depth);
        ambiguous += expectExactLeaves(tris, octree, 1e-9);
        leafTotal += octree.voxelsPerLevel.back();
    }
    std::printf("exactness: %zu leaves checked, %zu of them only touched by a triangle\n",
                leafTotal, ambiguous);
    EXPECT_GT(leafTotal, 1000u);
}

// (b) closed-cube semantics on exact boundaries: a quad in a voxel boundary plane marks the voxels
// on both sides; a triangle touching a cube only at a vertex marks that cube.
TEST(VoxelizeSurface, QuadOnVoxelBoundaryPlaneMarksBothSides) {
    for (int axis = 0; axis < 3; ++axis) {
        SCOPED_TRACE("plane normal axis " + std::to_string(axis));
        // Quad [0.25, 0.75]² at coordinate 0.5 along `axis`; depth 3: 0.125 voxels, so the plane
        // is the boundary between voxel 3 and 4 and the quad's edges lie on boundaries too.
        const auto point = [&](float a, float b) {
            Vec3f p;
            p[axis] = 0.5f;
            p[(axis + 1) % 3] = a;
            p[(axis + 2) % 3] = b;
            return p;
        };
        std::vector<Triangle> tris = unitCubeAnchors();
        tris.push_back({point(0.25f, 0.25f), point(0.75f, 0.25f), point(0.75f, 0.75f)});
        tris.push_back({point(0.25f, 0.25f), point(0.75f, 0.75f), point(0.25f, 0.75f)});
        const vox::SparseOctree octree = voxelize(makeScene(tris), 3);
        EXPECT_EQ(octree.cube.origin, (Vec3d{0, 0, 0}));
        EXPECT_EQ(octree.cube.size, 1.0);

        std::set<Key> expected{key(0, 0, 0), key(7, 7, 7)};
        for (std::uint32_t a = 1; a <= 6; ++a)
            for (std::uint32_t b = 1; b <= 6; ++b)
                for (std::uint32_t c : {3u, 4u}) {
                    std::array<std::uint32_t, 3> v{};
                    v[axis] = c;
                    v[(axis + 1) % 3] = a;
                    v[(axis + 2) % 3] = b;
                    expected.insert(key(v[0], v[1], v[2]));
                }
        EXPECT_EQ(expected.size(), 74u);
        EXPECT_EQ(decodeLeaves(octree), expected);
        EXPECT_EQ(octree.voxelsPerLevel.back(), 74u);
    }
}

TEST(VoxelizeSurface, GeometryOnTheFarFacesBelongsToTheLastVoxels) {
    for (int axis = 0; axis < 3; ++axis) {
        SCOPED_TRACE("far face across axis " + std::to_string(axis));
        // A quad covering the whole face at coordinate 1 (the cube is [0, 1]³ because of the
        // anchor at the origin): only the last layer of voxels holds it.
        const auto point = [&](float c, float a, float b) {
            Vec3f p;
            p[axis] = c;
            p[(axis + 1) % 3] = a;
            p[(axis + 2) % 3] = b;
            return p;
        };
        std::vector<Triangle> tris{unitCubeAnchors()[0]};
        tris.push_back({point(1, 0, 0), point(1, 1, 0), point(1, 1, 1)});
        tris.push_back({point(1, 0, 0), point(1, 1, 1), point(1, 0, 1)});
        const vox::SparseOctree octree = voxelize(makeScene(tris), 2);
        EXPECT_EQ(octree.cube.size, 1.0);
        std::set<Key> expected{key(0, 0, 0)};
        for (std::uint32_t a = 0; a < 4; ++a)
            for (std::uint32_t b = 0; b < 4; ++b) {
                std::array<std::uint32_t, 3> v{};
                v[axis] = 3;
                v[(axis + 1) % 3] = a;
                v[(axis + 2) % 3] = b;
                expected.insert(key(v[0], v[1], v[2]));
            }
        EXPECT_EQ(decodeLeaves(octree), expected);
    }
}

TEST(VoxelizeSurface, TriangleTouchingCubesAtAVertexOrAFaceMarksThem) {
    // Vertex exactly on the corner (0.5, 0.5, 0.5) shared by the 8 voxels (3|4, 3|4, 3|4) at
    // depth 3; the rest of the triangle lies in the (−,−,−) direction.
    std::vector<Triangle> tris = unitCubeAnchors();
    tris.push_back({Vec3f{0.5f, 0.5f, 0.5f}, Vec3f{0.3f, 0.45f, 0.4f}, Vec3f{0.45f, 0.3f, 0.35f}});
    // Vertex on the face x = 0.75 of voxel (6, 1, 1) from the −x side, inside the face.
    tris.push_back(
        {Vec3f{0.75f, 0.15f, 0.2f}, Vec3f{0.65f, 0.14f, 0.19f}, Vec3f{0.66f, 0.2f, 0.15f}});
    const vox::SparseOctree octree = voxelize(makeScene(tris), 3);
    const std::set<Key> leaves = decodeLeaves(octree);
    for (std::uint32_t slot = 0; slot < 8; ++slot) {
        const Key k = key(3 + (slot & 1u), 3 + ((slot >> 1) & 1u), 3 + (slot >> 2));
        EXPECT_TRUE(leaves.count(k)) << "corner neighbour " << keyText(k) << " missing";
    }
    EXPECT_TRUE(leaves.count(key(6, 1, 1))) << "face neighbour missing";
    EXPECT_TRUE(leaves.count(key(5, 1, 1)));
    EXPECT_FALSE(leaves.count(key(6, 2, 1)));
    // And exactly the brute force's set (exact coordinates: no ambiguity allowed).
    const LeafFrame frame = frameFor(tris, 3);
    EXPECT_EQ(leaves, bruteForce(tris, frame, 0.0));
    // Shrinking the cubes must lose exactly the touching-only neighbours, e.g. (4, 4, 4).
    EXPECT_FALSE(bruteForce(tris, frame, -1e-9).count(key(4, 4, 4)));
}

// (c) voxelsPerLevel agrees with the masks.
TEST(VoxelizeSurface, VoxelsPerLevelMatchesMaskPopcounts) {
    for (std::uint32_t depth : {1u, 2u, 5u, 7u}) {
        SCOPED_TRACE("depth " + std::to_string(depth));
        const vox::SparseOctree octree = voxelize(makeScene(randomTriangles(42, 20)), depth);
        ASSERT_EQ(octree.voxelsPerLevel.size(), depth + 1);
        ASSERT_EQ(octree.masks.size(), depth);
        EXPECT_EQ(octree.voxelsPerLevel[0], 1u);
        EXPECT_EQ(octree.masks[0].size(), 1u);
        std::uint64_t total = 1;
        for (std::uint32_t l = 0; l < depth; ++l) {
            std::uint64_t children = 0;
            for (std::uint8_t m : octree.masks[l])
                children += static_cast<std::uint64_t>(std::popcount(m));
            EXPECT_EQ(octree.voxelsPerLevel[l + 1], children) << "level " << l + 1;
            EXPECT_EQ(octree.masks[l].size(), octree.voxelsPerLevel[l]) << "level " << l;
            total += children;
        }
        EXPECT_EQ(octree.voxelCount(), total);
        // Each level at most 8× the previous, and the surface keeps growing with depth.
        for (std::uint32_t l = 1; l <= depth; ++l) {
            EXPECT_LE(octree.voxelsPerLevel[l], 8 * octree.voxelsPerLevel[l - 1]);
            EXPECT_GE(octree.voxelsPerLevel[l], octree.voxelsPerLevel[l - 1]);
        }
    }
}

// (d) the thread count does not change the result.
TEST(VoxelizeSurface, ResultDoesNotDependOnThreadCount) {
    // Enough triangles and depth that the parallel binning and subtrees really split the work.
    std::vector<Triangle> tris = randomTriangles(7, 400);
    const vox::Scene scene = makeScene(tris);
    const vox::SparseOctree all = voxelize(scene, 8);
    vox::SparseOctree one;
    {
        vox::ThreadLimit limit(1);
        EXPECT_EQ(vox::ThreadLimit::active(), 1);
        one = voxelize(scene, 8);
    }
    const vox::SparseOctree again = voxelize(scene, 8);
    EXPECT_EQ(one.masks, all.masks);
    EXPECT_EQ(one.voxelsPerLevel, all.voxelsPerLevel);
    EXPECT_EQ(again.masks, all.masks);
    EXPECT_EQ(one.cube.origin, all.cube.origin);
    EXPECT_EQ(one.cube.size, all.cube.size);
    EXPECT_GT(all.voxelsPerLevel.back(), 10000u);
}

// (e) depth 16 on one small triangle: sparse (about k² leaves for k leaves across), and exact.
TEST(VoxelizeSurface, Depth16SmallTriangleIsSparseAndExact) {
    const std::uint32_t depth = 16;
    const float leaf = std::ldexp(1.0f, -static_cast<int>(depth));
    // Right triangle with legs of k = 48 leaves in a plane of constant z (not on a boundary),
    // starting off-grid.
    const float k = 48;
    const Vec3f corner{0.40625f + 0.37f * leaf, 0.53125f + 0.61f * leaf, 0.5f + 0.3f * leaf};
    std::vector<Triangle> tris = unitCubeAnchors();
    tris.push_back({corner, corner + Vec3f{k * leaf, 0, 0}, corner + Vec3f{0, k * leaf, 0}});
    const vox::SparseOctree octree = voxelize(makeScene(tris), depth);
    ASSERT_EQ(octree.leafDepth, depth);
    const std::uint64_t leaves = octree.voxelsPerLevel.back();
    std::printf("depth 16: %llu leaves, %llu voxels in all\n",
                static_cast<unsigned long long>(leaves),
                static_cast<unsigned long long>(octree.voxelCount()));
    // 2 anchor leaves plus roughly k²/2 + k cells of a single z layer; a dense grid would be 2^48.
    EXPECT_GE(leaves, static_cast<std::uint64_t>(k * k / 2));
    EXPECT_LE(leaves, static_cast<std::uint64_t>(k * k / 2 + 4 * k));
    for (std::uint32_t l = 0; l <= depth; ++l)
        EXPECT_LE(octree.voxelsPerLevel[l], leaves + 2) << "level " << l;

    // Exact, by brute force over the triangle's neighbourhood plus the two anchor cubes.
    const LeafFrame frame = frameFor(tris, depth);
    const Vec3d c = frame.toLeaf(corner);
    const std::array<std::uint32_t, 3> from{static_cast<std::uint32_t>(c.x) - 2,
                                            static_cast<std::uint32_t>(c.y) - 2,
                                            static_cast<std::uint32_t>(c.z) - 2};
    const std::array<std::uint32_t, 3> to{from[0] + static_cast<std::uint32_t>(k) + 5,
                                          from[1] + static_cast<std::uint32_t>(k) + 5, from[2] + 5};
    const std::vector<Triangle> mainTri{tris.back()};
    std::set<Key> expected = bruteForce(mainTri, frame, 0.0, from, to);
    const std::set<Key> shrunk = bruteForce(mainTri, frame, -1e-9, from, to);
    EXPECT_EQ(expected, shrunk);  // nothing grazes a cube
    const std::uint32_t last = (1u << depth) - 1;
    expected.insert(key(0, 0, 0));
    expected.insert(key(last, last, last));
    EXPECT_EQ(decodeLeaves(octree), expected);
}

TEST(VoxelizeSurface, Depth20IsTheDeepestAllowed) {
    std::vector<Triangle> tris = unitCubeAnchors();
    const float leaf = std::ldexp(1.0f, -20);
    const Vec3f c{0.25f + 0.5f * leaf, 0.75f + 0.5f * leaf, 0.5f + 0.5f * leaf};
    tris.push_back({c, c + Vec3f{3 * leaf, 0, 0}, c + Vec3f{0, 0, 3 * leaf}});
    const vox::SparseOctree octree = voxelize(makeScene(tris), 20);
    const std::set<Key> leaves = decodeLeaves(octree);
    const std::uint64_t x0 = (1u << 18), y0 = 3u * (1u << 18), z0 = (1u << 19);
    // Legs of 3 leaves from a leaf centre, in the plane y = y0 + 0.5: the cells (i, y0, j) with
    // i + j <= 3 (10), plus (1, 3), (2, 2), (3, 1) whose corners the hypotenuse passes through
    // exactly (closed cubes).
    std::set<Key> expected{key(0, 0, 0), key((1u << 20) - 1, (1u << 20) - 1, (1u << 20) - 1)};
    for (std::uint64_t i = 0; i <= 3; ++i)
        for (std::uint64_t j = 0; i + j <= 3; ++j) expected.insert(key(x0 + i, y0, z0 + j));
    for (std::uint64_t i = 1; i <= 3; ++i) expected.insert(key(x0 + i, y0, z0 + 4 - i));
    EXPECT_EQ(expected.size(), 15u);
    EXPECT_EQ(leaves, expected);
}

// (f) dynamic meshes, empty scenes, bad depths.
TEST(VoxelizeSurface, DynamicMeshesAreExcludedUnlessIncluded) {
    const std::vector<Triangle> staticTris{
        {Vec3f{0.1f, 0.2f, 0.05f}, Vec3f{1, 0, 0.3f}, Vec3f{0, 1, 0.55f}}};
    const std::vector<Triangle> dynamicTris{
        {Vec3f{2, 2.1f, 2}, Vec3f{3, 2.2f, 2.05f}, Vec3f{2.1f, 3, 2.5f}}};
    vox::Scene scene = makeScene(staticTris);
    scene.meshes.push_back(makeMesh(dynamicTris, true));

    const vox::SparseOctree staticOnly = voxelize(scene, 5);
    const vox::SparseOctree reference = voxelize(makeScene(staticTris), 5);
    EXPECT_EQ(staticOnly.masks, reference.masks);
    EXPECT_EQ(staticOnly.cube.origin, reference.cube.origin);
    EXPECT_EQ(staticOnly.cube.size, 1.0);  // the dynamic mesh does not widen the cube either

    const vox::SparseOctree withDynamic = voxelize(scene, 5, true);
    std::vector<Triangle> both = staticTris;
    both.insert(both.end(), dynamicTris.begin(), dynamicTris.end());
    const vox::SparseOctree bothStatic = voxelize(makeScene(both), 5);
    EXPECT_EQ(withDynamic.masks, bothStatic.masks);
    EXPECT_EQ(withDynamic.cube.size, 3.0);
    EXPECT_GT(withDynamic.voxelsPerLevel.back(), staticOnly.voxelsPerLevel.back() / 8);
    expectExactLeaves(both, withDynamic, 1e-9);

    // Only dynamic triangles: nothing to voxelize unless they are included.
    vox::Scene dynamicOnly;
    dynamicOnly.materials.push_back(vox::Material{});
    dynamicOnly.meshes.push_back(makeMesh(dynamicTris, true));
    EXPECT_THROW((void)voxelize(dynamicOnly, 5), vox::InvalidDataError);
    EXPECT_EQ(voxelize(dynamicOnly, 5, true).masks, voxelize(makeScene(dynamicTris), 5).masks);
}

TEST(VoxelizeSurface, NoTrianglesIsInvalidData) {
    vox::Scene empty;
    empty.materials.push_back(vox::Material{});
    EXPECT_THROW((void)voxelize(empty, 5), vox::InvalidDataError);
    empty.meshes.push_back(makeMesh({}));
    EXPECT_THROW((void)voxelize(empty, 5), vox::InvalidDataError);
    // The message names the scene's source file when there is one.
    empty.sourceFiles.push_back("models/empty.gltf");
    try {
        (void)voxelize(empty, 5);
        ADD_FAILURE() << "no exception";
    } catch (const vox::InvalidDataError& e) {
        EXPECT_NE(std::string(e.what()).find("empty.gltf"), std::string::npos) << e.what();
        EXPECT_EQ(e.exitCode(), vox::ExitCode::InvalidData);
    }
}

TEST(VoxelizeSurface, DepthOutsideOneToTwentyIsAUsageError) {
    const vox::Scene scene = makeScene(randomTriangles(9, 3));
    EXPECT_THROW((void)voxelize(scene, 0), vox::UsageError);
    EXPECT_THROW((void)voxelize(scene, 21), vox::UsageError);
    EXPECT_THROW((void)voxelize(scene, 1000), vox::UsageError);
    const vox::SparseOctree one = voxelize(scene, 1);
    EXPECT_EQ(one.leafDepth, 1u);
    ASSERT_EQ(one.masks.size(), 1u);
    EXPECT_NE(one.masks[0][0], 0);
    expectExactLeaves(randomTriangles(9, 3), one, 1e-9);
}

// Every voxel above the leaf level must have children: a mask of 0 means "leaf" to the .esvo
// writer and the ray caster, so an empty interior voxel becomes a solid coarse cube.
// The triangle's plane z = y/2 passes exactly through voxel edges (y = 2j, z = j in leaf units,
// e.g. the edge y = 4, z = 2 at depth 3); the root cube's edge (1.5 or 3, set by the tiny anchor
// triangle) makes the scale to leaf units inexact, so the separating-axis test's rounding can
// accept a coarse voxel that merely touches the triangle and reject all of its children.
TEST(VoxelizeSurface, InteriorVoxelsAlwaysHaveChildren) {
    struct Case {
        float cubeEdge;
        std::uint32_t depth;
    };
    for (const Case c :
         {Case{1.5f, 3}, Case{1.5f, 4}, Case{3.0f, 4}, Case{3.0f, 5}, Case{1.5f, 8}}) {
        SCOPED_TRACE("cube edge " + std::to_string(c.cubeEdge) + ", depth " +
                     std::to_string(c.depth));
        const float S = c.cubeEdge;
        const std::vector<Triangle> tris{
            {Vec3f{0, 0, 0}, Vec3f{1, 0, 0}, Vec3f{0, 1, 0.5f}},
            {Vec3f{S, S, S}, Vec3f{S - 1e-4f, S, S}, Vec3f{S, S - 1e-4f, S}}};
        const vox::SparseOctree octree = voxelize(makeScene(tris), c.depth);
        std::size_t empty = 0;
        for (std::uint32_t l = 0; l < c.depth; ++l)
            for (std::uint8_t m : octree.masks[l]) empty += m == 0;
        EXPECT_EQ(empty, 0u) << "voxels above the leaf level without children";
    }
}

// Contour economy: error-bounded, a voxel at the leaf depth relies on the slab its parent hands
// down and stores a contour of its own only where none is carried; with full refinement it
// still stores one wherever its fit is much thinner. Counted below parents whose own contour
// carries down to the child (the builder's carry rule, detail::carryContour): none in the first
// build, many in the second.
TEST(VoxelizeSurface, ErrorBoundedLeafDepthVoxelsInheritTheirParentsSlab) {
    const vox::Scene scene = vox::importScene(vox::test::assimpModels() / "OBJ/WusonOBJ.obj");
    const auto ownBelowACarriedSlab = [&](double contourError) {
        vox::SurfaceVoxelizeOptions options;
        options.depth = 8;
        options.contours = true;
        options.contourError = contourError;
        const vox::SparseOctree octree = vox::voxelizeSurface(scene, options);
        const std::uint32_t leafLevel = options.depth;
        EXPECT_EQ(octree.contours.size(), leafLevel + 1);
        // The children of level leafLevel − 1's voxels are level leafLevel's, in order.
        std::uint64_t child = 0, own = 0, belowCarried = 0;
        const auto& parents = octree.masks[leafLevel - 1];
        for (std::size_t p = 0; p < parents.size(); ++p) {
            for (std::uint32_t slot = 0; slot < 8; ++slot) {
                if (!(parents[p] & (1u << slot))) continue;
                const std::uint32_t contour = octree.contours[leafLevel][child++];
                if (contour == 0) continue;
                ++own;
                double thickness = 0;
                belowCarried +=
                    vox::detail::carryContour(octree.contours[leafLevel - 1][p], slot, thickness) !=
                    0;
            }
        }
        EXPECT_EQ(child, octree.voxelsPerLevel[leafLevel]);
        EXPECT_GT(own, 0u) << "leaf-depth voxels with no carried slab fit their own";
        return belowCarried;
    };
    EXPECT_EQ(ownBelowACarriedSlab(vox::kDefaultContourError), 0u);
    EXPECT_GT(ownBelowACarriedSlab(0), 1000u);
}

namespace {

/// A quarter of a cylinder of radius 0.5 (axis y, 64 × 16 quads, smooth normals), coloured by
/// a texture that ramps from sRGB 40 up to 200 and back around it (@p ramp), or plain grey.
vox::Scene rampedCylinder(bool ramp) {
    vox::Scene scene;
    std::vector<std::uint8_t> pixels(256 * 4);
    for (int x = 0; x < 256; ++x)
        for (int y = 0; y < 4; ++y)
            pixels[std::size_t(y) * 256 + std::size_t(x)] =
                static_cast<std::uint8_t>(ramp ? 40 + 160 * (255 - std::abs(2 * x - 255)) / 255
                                               : 120);
    scene.textures.emplace_back("ramp", 256, 4, 1, pixels, vox::ColorSpace::SRGB);
    vox::Material material;
    material.baseColorTexture.texture = 0;
    scene.materials = {material};
    vox::Mesh mesh;
    mesh.uvs.resize(1);
    constexpr int kAround = 64, kAlong = 16;
    for (int j = 0; j <= kAlong; ++j)
        for (int i = 0; i <= kAround; ++i) {
            const float a = 1.5707964f * float(i) / kAround;
            mesh.positions.push_back({0.5f * std::cos(a), float(j) / kAlong, 0.5f * std::sin(a)});
            mesh.normals.push_back({std::cos(a), 0, std::sin(a)});
            mesh.uvs[0].push_back({float(i) / kAround, 0.5f});
        }
    for (int j = 0; j < kAlong; ++j)
        for (int i = 0; i < kAround; ++i) {
            const auto v = [&](int di, int dj) {
                return static_cast<std::uint32_t>((j + dj) * (kAround + 1) + i + di);
            };
            mesh.indices.insert(mesh.indices.end(), {v(0, 0), v(1, 0), v(1, 1)});
            mesh.indices.insert(mesh.indices.end(), {v(0, 0), v(1, 1), v(0, 1)});
        }
    scene.meshes.push_back(mesh);
    return scene;
}

vox::SparseOctree errorBounded(const vox::Scene& scene, double colorError) {
    vox::SurfaceVoxelizeOptions options;
    options.depth = 7;
    options.contours = true;
    options.attributes = true;
    options.contourError = vox::kDefaultContourError;
    options.colorError = colorError;
    options.normalErrorDegrees = 0;
    return vox::voxelizeSurface(scene, options);
}

}  // namespace

// Where a voxel's colour deviates by more than half the colour bound, it stops only where its
// slab lies within half the contour error: the ramp (a voxel's deviation grows with its size, a
// few sRGB steps at the levels where the cylinder's slabs stop) refines further than grey under
// a bound of 12, and exactly as far as grey under a bound of 60, which no voxel's deviation
// reaches half of.
TEST(VoxelizeSurface, VaryingColourStopsOnlyWithinHalfTheContourError) {
    const vox::SparseOctree grey = errorBounded(rampedCylinder(false), vox::kDefaultColorError);
    const vox::SparseOctree ramp = errorBounded(rampedCylinder(true), vox::kDefaultColorError);
    const vox::SparseOctree rampLoose = errorBounded(rampedCylinder(true), 60);
    EXPECT_GT(grey.voxelsPerLevel[7], 0u) << "the cylinder refines to the leaf depth somewhere";
    EXPECT_EQ(rampLoose.masks, grey.masks);
    EXPECT_GT(ramp.voxelCount(), grey.voxelCount() * 11 / 10);
}
