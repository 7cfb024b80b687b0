// The attribute filter's error moments (libvox/src/octree/voxel_attributes.cpp): the builder
// filters the voxels whose error it never reads without them, which must leave every other sum
// bit for bit as the full filter computes it.
#include "octree/triangle_box.h"
#include "octree/voxel_attributes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <vector>

namespace {

using vox::Vec3d;

/// The unit square in z = 0 under a 64² sRGB checkerboard of 2-texel squares, its vertex
/// normals turning from (−1, 0, 1)/√2 at x = 0 to (1, 0, 1)/√2 at x = 1 (smooth shading).
vox::Scene checkerSquare() {
    std::vector<std::uint8_t> pixels(64 * 64);
    for (int y = 0; y < 64; ++y)
        for (int x = 0; x < 64; ++x)
            pixels[std::size_t(y) * 64 + std::size_t(x)] = ((x / 2 + y / 2) % 2) ? 255 : 0;
    vox::Scene scene;
    scene.textures.emplace_back("checker", 64, 64, 1, pixels, vox::ColorSpace::SRGB);
    vox::Material material;
    material.baseColorTexture.texture = 0;
    scene.materials = {material};
    const float s = 1.0f / std::sqrt(2.0f);
    vox::Mesh mesh;
    mesh.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
    mesh.normals = {{-s, 0, s}, {s, 0, s}, {s, 0, s}, {-s, 0, s}};
    mesh.uvs = {{{0, 1}, {1, 1}, {1, 0}, {0, 0}}};
    mesh.indices = {0, 1, 2, 0, 2, 3};
    scene.meshes.push_back(mesh);
    return scene;
}

}  // namespace

TEST(AttributeSampler, FilteringWithoutErrorMomentsLeavesEveryOtherSumAsIs) {
    const vox::Scene scene = checkerSquare();
    // Leaf units of depth 4: the square spans [0, 16]².
    const auto leaf = [](vox::Vec3f p) { return Vec3d{16.0 * p.x, 16.0 * p.y, 16.0 * p.z}; };
    const vox::Mesh& mesh = scene.meshes[0];
    std::vector<vox::detail::BoxTestTriangle> triangles;
    std::vector<vox::detail::TriangleSource> sources;
    for (std::uint32_t t = 0; t < 2; ++t) {
        triangles.push_back(
            vox::detail::prepareBoxTest(leaf(mesh.positions[mesh.indices[3 * t]]),
                                        leaf(mesh.positions[mesh.indices[3 * t + 1]]),
                                        leaf(mesh.positions[mesh.indices[3 * t + 2]])));
        sources.push_back({0, t});
    }
    const vox::detail::AttributeSampler sampler(scene, triangles, sources, true);
    vox::detail::AttributeScratch scratch;
    const std::vector<std::uint32_t> list{0, 1};
    // Cubes of edge 4 and 2 across the diagonal (both triangles) and beside it (one).
    for (const auto& [c, h] : {std::pair{Vec3d{6, 6, 0}, 2.0}, std::pair{Vec3d{9, 9, 0.5}, 1.0},
                               std::pair{Vec3d{13, 3, 0.25}, 1.0}}) {
        vox::detail::CubeFragments fragments;
        fragments.clip(list, triangles, c, vox::detail::AttributeSampler::filterScale(h));
        const vox::detail::AttributeSums full = sampler.filter(fragments, list, c, h, scratch);
        const vox::detail::AttributeSums lean =
            sampler.filter(fragments, list, c, h, scratch, {}, false);
        // The full filter sees the checker's variance and the normals' turn inside the cube.
        EXPECT_GT(full.colorSquares.x * full.weight, full.color.x * full.color.x);
        EXPECT_GT(full.normalSpread, 0.0);
        EXPECT_GT(full.error().color, 10.0);
        EXPECT_EQ(lean.normalSpread, 0.0);
        EXPECT_EQ(lean.colorSquares.x + lean.colorSquares.y + lean.colorSquares.z, 0.0);
        EXPECT_EQ(lean.facetWeight, 0.0);
        EXPECT_EQ(lean.weight, full.weight);
        EXPECT_EQ(lean.color, full.color);
        EXPECT_EQ(lean.alpha, full.alpha);
        EXPECT_EQ(lean.normal, full.normal);
        EXPECT_EQ(lean.emission, full.emission);
        EXPECT_EQ(lean.normalMoments, full.normalMoments);
        EXPECT_EQ(lean.dominantNormal, full.dominantNormal);
        EXPECT_EQ(lean.dominantWeight, full.dominantWeight);
        EXPECT_EQ(lean.pack(), full.pack());
    }
}
