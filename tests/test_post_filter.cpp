// The post-process filter (libvox/src/render/post_filter.cpp, Laine & Karras 6.3) on synthetic
// images whose blur can be predicted: no blur below a pixel, blending across a colour edge,
// none across a silhouette, and the radius shrinking to a finer neighbour's.
#include <vox/raycast.h>

#include <gtest/gtest.h>

namespace {

constexpr int kSize = 64;

std::size_t at(int x, int y) { return std::size_t(y) * kSize + std::size_t(x); }

/// Red left of column @p edge, blue right of it.
std::vector<vox::Vec3f> twoColours(int edge) {
    std::vector<vox::Vec3f> image(kSize * kSize);
    for (int y = 0; y < kSize; ++y)
        for (int x = 0; x < kSize; ++x)
            image[at(x, y)] = x < edge ? vox::Vec3f{1, 0, 0} : vox::Vec3f{0, 0, 1};
    return image;
}

}  // namespace

TEST(PostFilter, RadiiOfAPixelOrLessLeaveTheImageAlone) {
    const auto image = twoColours(32);
    const auto out =
        vox::postProcessFilter(image, std::vector<float>(kSize * kSize, 1.0f), kSize, kSize);
    EXPECT_EQ(out, image);
}

TEST(PostFilter, BlendsAcrossAColourEdgeWithinTheRadiusOnly) {
    const auto image = twoColours(32);
    const auto out =
        vox::postProcessFilter(image, std::vector<float>(kSize * kSize, 6.0f), kSize, kSize);
    // At the edge both colours mix, the nearer one weighing more; 8 pixels away nothing changes.
    const vox::Vec3f left = out[at(31, 32)], right = out[at(32, 32)];
    EXPECT_GT(left.z, 0.1f);
    EXPECT_GT(left.x, left.z);
    EXPECT_GT(right.x, 0.1f);
    EXPECT_GT(right.z, right.x);
    EXPECT_NEAR(left.x + left.z, 1.0f, 1e-5f) << "a weighted mean";
    EXPECT_EQ(out[at(23, 32)], image[at(23, 32)]);
    EXPECT_EQ(out[at(40, 32)], image[at(40, 32)]);
    // Symmetric about the edge.
    EXPECT_NEAR(out[at(30, 32)].z, out[at(33, 32)].x, 1e-5f);
    EXPECT_NEAR(left.z, right.x, 1e-5f);
}

TEST(PostFilter, StopsAtSilhouettesAndAtFinerVoxels) {
    // Left half: misses (radius 0). Right half: blurred with radius 6 — but never across the miss.
    auto image = twoColours(32);
    std::vector<float> radius(kSize * kSize, 6.0f);
    for (int y = 0; y < kSize; ++y)
        for (int x = 0; x < 32; ++x) radius[at(x, y)] = 0.0f;
    // A stripe of red in the blue half: blended where the radius allows.
    for (int y = 0; y < kSize; ++y)
        for (int x = 48; x < 52; ++x) image[at(x, y)] = {1, 0, 0};
    auto out = vox::postProcessFilter(image, radius, kSize, kSize);
    EXPECT_EQ(out[at(32, 20)], image[at(32, 20)]) << "next to the silhouette: its own colour";
    EXPECT_EQ(out[at(10, 20)], image[at(10, 20)]) << "misses are left alone";
    EXPECT_GT(out[at(47, 20)].x, 0.05f) << "the stripe bleeds into its neighbours";
    // The same stripe among voxels of 1.5 pixels: a pixel with a large radius next to them
    // shrinks to theirs and stays almost as it is.
    for (int y = 0; y < kSize; ++y)
        for (int x = 44; x < 64; ++x) radius[at(x, y)] = 1.5f;
    out = vox::postProcessFilter(image, radius, kSize, kSize);
    EXPECT_EQ(out[at(43, 20)].x, 0.0f) << "shrunk before reaching the stripe";
}
