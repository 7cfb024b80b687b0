// Per-voxel colour and normal filtering (libvox/src/octree/voxel_attributes.cpp through
// voxelizeSurface): area weighting over triangle fragments, texture footprints the size of the
// voxel, vertex colours, interpolated normals, and the attribute criterion of refinement.
#include <vox/formats/esvo_attributes.h>
#include <vox/octree.h>
#include <vox/texture.h>

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <map>
#include <tuple>

namespace {

using Key =
    std::tuple<std::uint32_t, std::uint32_t, std::uint32_t, std::uint32_t>;  // level, x, y, z

/// Every voxel's attributes by position: level l's voxels are the children of level l−1's, in
/// order.
std::map<Key, std::uint64_t> attributesByPosition(const vox::SparseOctree& octree) {
    std::map<Key, std::uint64_t> out;
    std::vector<std::array<std::uint32_t, 3>> level{{0, 0, 0}};
    for (std::uint32_t l = 0; l <= octree.leafDepth; ++l) {
        EXPECT_EQ(octree.attributes[l].size(), level.size());
        std::vector<std::array<std::uint32_t, 3>> next;
        for (std::size_t i = 0; i < level.size(); ++i) {
            out[{l, level[i][0], level[i][1], level[i][2]}] = octree.attributes[l][i];
            if (l == octree.leafDepth) continue;
            const std::uint32_t mask = octree.masks[l][i];
            for (std::uint32_t s = 0; s < 8; ++s)
                if (mask & (1u << s))
                    next.push_back({2 * level[i][0] + (s & 1u), 2 * level[i][1] + ((s >> 1) & 1u),
                                    2 * level[i][2] + (s >> 2)});
        }
        level = std::move(next);
    }
    return out;
}

vox::Vec3f rgb(std::uint64_t value) {
    const auto c = static_cast<std::uint32_t>(value);
    return {float(vox::esvo::colorChannel(c, 0)), float(vox::esvo::colorChannel(c, 1)),
            float(vox::esvo::colorChannel(c, 2))};
}
vox::esvo::Vec3 normalOf(std::uint64_t value) {
    return vox::esvo::decodeUnitNormal(static_cast<std::uint32_t>(value >> 32));
}
float srgb8(float linear) { return std::round(255.0f * vox::linearToSrgb(linear)); }

/// A quad [x0,x1]×[0,1] in the plane z = 0 with material @p material; normals +z unless given.
void addQuad(vox::Scene& scene, float x0, float x1, std::uint32_t material,
             vox::Vec3f n0 = {0, 0, 1}, vox::Vec3f n1 = {0, 0, 1}) {
    vox::Mesh mesh;
    mesh.material = material;
    mesh.positions = {{x0, 0, 0}, {x1, 0, 0}, {x1, 1, 0}, {x0, 1, 0}};
    mesh.normals = {n0, n1, n1, n0};
    mesh.uvs = {{{0, 1}, {1, 1}, {1, 0}, {0, 0}}};
    mesh.indices = {0, 1, 2, 0, 2, 3};
    scene.meshes.push_back(mesh);
}

/// The unit quad under a 64² sRGB checkerboard of black and white squares @p squareTexels wide.
vox::Scene checkerQuad(int squareTexels) {
    std::vector<std::uint8_t> pixels(64 * 64);
    for (int y = 0; y < 64; ++y)
        for (int x = 0; x < 64; ++x)
            pixels[std::size_t(y) * 64 + std::size_t(x)] =
                ((x / squareTexels + y / squareTexels) % 2) ? 255 : 0;
    vox::Scene scene;
    scene.textures.emplace_back("checker", 64, 64, 1, pixels, vox::ColorSpace::SRGB);
    vox::Material material;
    material.baseColorTexture.texture = 0;
    scene.materials = {material};
    addQuad(scene, 0, 1, 0);
    return scene;
}

vox::SparseOctree voxelize(const vox::Scene& scene, std::uint32_t depth, bool contours = false,
                           double contourError = 0, double colorError = 0) {
    vox::SurfaceVoxelizeOptions options;
    options.depth = depth;
    options.attributes = true;
    options.contours = contours;
    options.contourError = contourError;
    options.colorError = colorError;
    return vox::voxelizeSurface(scene, options);
}

}  // namespace

TEST(VoxelAttributes, ColourIsTheAreaWeightedMeanOfTheFragmentsInLinearSpace) {
    // Red on x ∈ [0, 0.625], blue on [0.625, 1]: the level-1 voxels with x ∈ [0.5, 1] hold red and
    // blue in the ratio 1 : 3, the root 5 : 3. An unweighted mean of the two would be 1 : 1.
    vox::Scene scene;
    scene.materials = {{"red", {1, 0, 0, 1}}, {"blue", {0, 0, 1, 1}}};
    addQuad(scene, 0, 0.625f, 0);
    addQuad(scene, 0.625f, 1, 1);
    const vox::SparseOctree octree = voxelize(scene, 3);
    const auto voxels = attributesByPosition(octree);
    const vox::Vec3f mixed = rgb(voxels.at({1, 1, 0, 0}));
    EXPECT_NEAR(mixed.x, srgb8(0.25f), 1.0f);
    EXPECT_NEAR(mixed.y, 0.0f, 0.5f);
    EXPECT_NEAR(mixed.z, srgb8(0.75f), 1.0f);
    const vox::Vec3f root = rgb(octree.attributes[0][0]);
    EXPECT_NEAR(root.x, srgb8(0.625f), 1.0f);
    EXPECT_NEAR(root.z, srgb8(0.375f), 1.0f);
    EXPECT_EQ(rgb(voxels.at({1, 0, 0, 0})).x, 255.0f);
    EXPECT_EQ(rgb(voxels.at({1, 0, 0, 0})).z, 0.0f);
    // Leaves on one side of the colour boundary are pure.
    for (const auto& [key, value] : voxels)
        if (std::get<0>(key) == 3 && std::get<1>(key) >= 5) {
            EXPECT_EQ(rgb(value).x, 0.0f) << "leaf x " << std::get<1>(key);
        }
    EXPECT_EQ(static_cast<std::uint32_t>(octree.attributes[3][0]) >> 24, 255u) << "full coverage";
}

TEST(VoxelAttributes, TexturesAreFilteredOverTheVoxelsFootprint) {
    // A 64² sRGB checkerboard of 8-texel squares across the unit quad: at depth 3 each leaf covers
    // one square (black or white); at depth 1 each covers 4×4 squares, whose mean is linear 0.5 —
    // a point sample would still say black or white.
    const vox::Scene scene = checkerQuad(8);
    for (const auto& [key, value] : attributesByPosition(voxelize(scene, 3)))
        if (std::get<0>(key) == 3) {
            const float v = rgb(value).x;
            EXPECT_TRUE(v <= 8.0f || v >= 247.0f)
                << "leaf " << std::get<1>(key) << "," << std::get<2>(key) << ": " << v;
        }
    for (const auto& [key, value] : attributesByPosition(voxelize(scene, 1)))
        if (std::get<0>(key) == 1) {
            EXPECT_NEAR(rgb(value).x, srgb8(0.5f), 3.0f);
        }
}

TEST(VoxelAttributes, VertexColoursMultiplyTheBaseColour) {
    vox::Scene scene;
    scene.materials = {{"red", {1, 0, 0, 1}}};
    addQuad(scene, 0, 1, 0);
    scene.meshes[0].colors.assign(4, vox::Vec4f{0.5f, 1, 1, 1});
    for (const auto& [key, value] : attributesByPosition(voxelize(scene, 2))) {
        EXPECT_NEAR(rgb(value).x, srgb8(0.5f), 1.0f);
        EXPECT_EQ(rgb(value).y, 0.0f);
    }
}

TEST(VoxelAttributes, NormalsAreTheInterpolatedShadingNormals) {
    // Vertex normals (∓1, 0, 1)/√2 at x = 0 and 1 interpolate to n(x) ∝ (2x − 1, 0, 1). The level-1
    // voxel x ∈ [0, 0.5] is the mean of the unit normals over its area: with u = 2x − 1,
    // ∫ u/√(u²+1) du = 1 − √2 and ∫ 1/√(u²+1) du = asinh 1 over [−1, 0], normalised.
    vox::Scene scene;
    scene.materials = {{"grey", {0.5f, 0.5f, 0.5f, 1}}};
    const float s = 1.0f / std::sqrt(2.0f);
    addQuad(scene, 0, 1, 0, {-s, 0, s}, {s, 0, s});
    const auto voxels = attributesByPosition(voxelize(scene, 4));
    const auto left = normalOf(voxels.at({1, 0, 0, 0}));
    const double ex = 1 - std::sqrt(2.0), ez = std::asinh(1.0), k = 1 / std::hypot(ex, ez);
    EXPECT_NEAR(left[0], ex * k, 1e-3);
    EXPECT_NEAR(left[1], 0.0, 1e-3);
    EXPECT_NEAR(left[2], ez * k, 1e-3);
    const auto right = normalOf(voxels.at({1, 1, 1, 0}));
    EXPECT_NEAR(right[0], -ex * k, 1e-3);
    // A centroid sample of the level-1 voxel instead would give (−0.5, 0, 1)/√1.25: x −0.447.
    EXPECT_GT(left[0], -0.44f);
    // The root averages the whole quad: straight up.
    const auto root = normalOf(attributesByPosition(voxelize(scene, 4)).at({0, 0, 0, 0}));
    EXPECT_NEAR(root[2], 1.0f, 1e-3f);
}

TEST(VoxelAttributes, ThinSheetsKeepTheHeavierSidesNormalInsteadOfNoise) {
    // Two faces back to back in the same voxels: their normals cancel; the voxel keeps one side.
    vox::Scene scene;
    scene.materials = {{"grey", {0.5f, 0.5f, 0.5f, 1}}};
    addQuad(scene, 0, 1, 0);
    addQuad(scene, 0, 1, 0, {0, 0, -1}, {0, 0, -1});
    for (const auto& [key, value] : attributesByPosition(voxelize(scene, 2))) {
        const auto n = normalOf(value);
        EXPECT_NEAR(std::abs(n[2]), 1.0f, 1e-3f);
    }
}

TEST(VoxelAttributes, ColourVariationKeepsRefiningWhereGeometryWouldStop) {
    // A flat quad under a checkerboard of single texels, one per leaf at depth 6: contours alone
    // stop refining at level 5, whose voxels average 2×2 texels to grey; the colour criterion
    // refines every voxel to the leaves, each black or white.
    const vox::Scene scene = checkerQuad(1);
    const vox::SparseOctree geometric = voxelize(scene, 6, true, 2.0);
    const vox::SparseOctree attributed = voxelize(scene, 6, true, 2.0, 16.0);
    EXPECT_EQ(geometric.voxelsPerLevel[6], 0u);
    EXPECT_EQ(geometric.voxelsPerLevel[5], 32u * 32u);
    for (std::uint64_t v : geometric.attributes[5]) EXPECT_NEAR(rgb(v).x, srgb8(0.5f), 2.0f);
    ASSERT_EQ(attributed.voxelsPerLevel[6], 64u * 64u);
    for (std::uint64_t v : attributed.attributes[6]) {
        const float x = rgb(v).x;
        EXPECT_TRUE(x <= 1.0f || x >= 254.0f) << x;
    }
    // A colour bound above the whole range changes nothing.
    EXPECT_EQ(voxelize(scene, 6, true, 2.0, 255.0).voxelCount(), geometric.voxelCount());
}

TEST(VoxelAttributes, NormalBoundStopsWhereTheVoxelsNormalStandsForItsSurface) {
    // Vertex normals (∓1, 0, 1)/√2 at x = 0 and 1: the shading normal's angle is atan(2x − 1),
    // turning by 2 rad per unit at x = ½ and by 1 at the sides. With a bound of 0.8° on the
    // normal's RMS deviation inside a voxel, 1/32-wide voxels (level 5) hold 1.03° in the middle
    // and 0.52° at the sides: refinement goes one level further in the middle. Geometry alone
    // (a flat quad) stops at level 5, the first below the voxelizer's cells.
    vox::Scene scene;
    scene.materials = {{"grey", {0.5f, 0.5f, 0.5f, 1}}};
    const float s = 1.0f / std::sqrt(2.0f);
    addQuad(scene, 0, 1, 0, {-s, 0, s}, {s, 0, s});
    vox::SurfaceVoxelizeOptions options;
    options.depth = 9;
    options.attributes = true;
    options.contours = true;
    options.contourError = 2;
    const vox::SparseOctree geometric = vox::voxelizeSurface(scene, options);
    EXPECT_GT(geometric.voxelsPerLevel[5], 0u);
    EXPECT_EQ(geometric.voxelsPerLevel[6], 0u);
    options.normalErrorDegrees = 0.8;
    const vox::SparseOctree bounded = vox::voxelizeSurface(scene, options);
    EXPECT_GT(bounded.voxelCount(), geometric.voxelCount());

    // The true RMS angle between the shading normal over x ∈ [a, b] and the voxel's mean normal.
    const auto trueRmsDegrees = [](double a, double b) {
        constexpr int kSamples = 512;
        double mx = 0, mz = 0;
        for (int i = 0; i < kSamples; ++i) {
            const double u = 2 * (a + (b - a) * (i + 0.5) / kSamples) - 1;
            mx += u / std::hypot(u, 1.0), mz += 1 / std::hypot(u, 1.0);
        }
        const double mean = std::atan2(mx, mz);
        double squares = 0;
        for (int i = 0; i < kSamples; ++i) {
            const double d = std::atan(2 * (a + (b - a) * (i + 0.5) / kSamples) - 1) - mean;
            squares += d * d;
        }
        return std::sqrt(squares / kSamples) * 180 / 3.14159265358979323846;
    };
    // Every leaf above the leaf depth by position; each within the bound, up to the estimate's
    // linearisation.
    std::map<std::uint32_t, std::uint32_t> levelAtX;  // leaf x (in 1/512) → its level
    std::vector<std::array<std::uint32_t, 4>> voxels{{0, 0, 0, 0}};  // level, x, y, z
    for (std::uint32_t l = 0; l < bounded.leafDepth; ++l) {
        std::vector<std::array<std::uint32_t, 4>> next;
        for (std::size_t i = 0; i < voxels.size(); ++i) {
            const std::uint32_t mask = bounded.masks[l][i];
            const auto [level, x, y, z] = voxels[i];
            if (mask == 0) {
                const double w = std::ldexp(1.0, -static_cast<int>(level));
                EXPECT_LE(trueRmsDegrees(x * w, (x + 1) * w), 0.8 * 1.15)
                    << "level " << level << " x " << x;
                levelAtX[x << (9 - level)] = level;
                continue;
            }
            for (std::uint32_t slot = 0; slot < 8; ++slot)
                if (mask & (1u << slot))
                    next.push_back({l + 1, 2 * x + (slot & 1u), 2 * y + ((slot >> 1) & 1u),
                                    2 * z + (slot >> 2)});
        }
        voxels = std::move(next);
    }
    EXPECT_EQ(levelAtX.at(0), 5u) << "the sides";
    EXPECT_EQ(levelAtX.at(256), 6u) << "the middle";
}
