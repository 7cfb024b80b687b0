#include <vox/formats/error.h>
#include <vox/image_io.h>
#include <vox/texture.h>

#include "gltf_builder.h"
#include "test_support.h"

#include <cmath>

using vox::ColorSpace;
using vox::Texture;
using vox::Vec4f;
using vox::WrapMode;

namespace {

Texture linearRow(std::vector<std::uint8_t> values) {
    const int width = static_cast<int>(values.size());
    return Texture("row", width, 1, 1, values, ColorSpace::Linear);
}

}  // namespace

TEST(Texture, SrgbTransferFunctionMatchesTheStandard) {
    EXPECT_NEAR(vox::srgbToLinear(0.5f), 0.2140f, 1e-4f);
    EXPECT_NEAR(vox::srgbToLinear(0.04f), 0.04f / 12.92f, 1e-7f);
    EXPECT_FLOAT_EQ(vox::srgbToLinear(1.0f), 1.0f);
    for (float v : {0.0f, 0.001f, 0.2f, 0.5f, 0.9f, 1.0f}) EXPECT_NEAR(vox::linearToSrgb(vox::srgbToLinear(v)), v, 1e-5f);
}

TEST(Texture, MipChainHalvesEachSideDownToOneTexel) {
    const std::vector<std::uint8_t> pixels(5 * 3 * 3, 100);
    const Texture t("t", 5, 3, 3, pixels, ColorSpace::Linear);
    ASSERT_EQ(t.levelCount(), 3);
    EXPECT_EQ(t.levelWidth(1), 2);
    EXPECT_EQ(t.levelHeight(1), 1);
    EXPECT_EQ(t.levelWidth(2), 1);
    EXPECT_EQ(t.levelHeight(2), 1);
    EXPECT_EQ(t.memoryBytes(), (5 * 3 + 2 * 1 + 1) * 4u);
}

TEST(Texture, SrgbCheckerboardAveragesInLinearSpace) {
    // Black and white in sRGB average to linear 0.5 (sRGB 188), not to sRGB 128 (linear 0.216).
    const std::vector<std::uint8_t> pixels = {0, 0, 0, 255, 255, 255, 255, 255, 255, 0, 0, 0};
    const Texture t("checker", 2, 2, 3, pixels, ColorSpace::SRGB);
    const Vec4f mean = t.texel(1, 0, 0);
    EXPECT_NEAR(mean.x, 0.5f, 0.005f);
    EXPECT_NEAR(mean.y, 0.5f, 0.005f);
    EXPECT_FLOAT_EQ(mean.w, 1.0f);
}

TEST(Texture, OddSizesAreAreaWeighted) {
    // 3 texels into 1: every texel covers a third of the result.
    const Texture t = linearRow({0, 90, 180});
    EXPECT_NEAR(t.texel(1, 0, 0).x, 90.0f / 255.0f, 0.5f / 255.0f);
    // 5 into 2: the middle texel is split between both results.
    const Texture u = linearRow({0, 0, 250, 100, 100});
    EXPECT_NEAR(u.texel(1, 0, 0).x, (0 + 0 + 0.5f * 250) / 2.5f / 255.0f, 0.5f / 255.0f);
    EXPECT_NEAR(u.texel(1, 1, 0).x, (0.5f * 250 + 100 + 100) / 2.5f / 255.0f, 0.5f / 255.0f);
}

TEST(Texture, ChannelsExpandToRgba) {
    const Texture grey("g", 1, 1, 1, std::vector<std::uint8_t>{51}, ColorSpace::Linear);
    const Vec4f g = grey.texel(0, 0, 0);
    EXPECT_FLOAT_EQ(g.x, 51.0f / 255.0f);
    EXPECT_EQ(g.x, g.y);
    EXPECT_EQ(g.x, g.z);
    EXPECT_EQ(g.w, 1.0f);
    const Texture greyAlpha("ga", 1, 1, 2, std::vector<std::uint8_t>{51, 102}, ColorSpace::Linear);
    EXPECT_FLOAT_EQ(greyAlpha.texel(0, 0, 0).x, 51.0f / 255.0f);
    EXPECT_FLOAT_EQ(greyAlpha.texel(0, 0, 0).w, 102.0f / 255.0f);
}

TEST(Texture, FineLookupIsBilinearBetweenTexelCentres) {
    const Texture t = linearRow({0, 255, 0, 255});
    EXPECT_FLOAT_EQ(t.sample({0.375f, 0.5f}, 0.0f).x, 1.0f);        // centre of texel 1
    EXPECT_FLOAT_EQ(t.sample({0.125f, 0.5f}, 0.0f).x, 0.0f);        // centre of texel 0
    EXPECT_NEAR(t.sample({0.25f, 0.5f}, 0.0f).x, 0.5f, 1e-6f);      // half-way
    EXPECT_NEAR(t.sample({0.3125f, 0.5f}, 0.0f).x, 0.75f, 1e-6f);   // three quarters
}

TEST(Texture, FootprintSelectsTheMatchingMipLevel) {
    const Texture t = linearRow({0, 255, 0, 255});  // levels: 4, 2 (0.5, 0.5), 1 (0.5)
    // A footprint as wide as the whole texture averages everything.
    // (0.5 is stored as 128/255: 8-bit levels round half up.)
    EXPECT_NEAR(t.sample({0.375f, 0.5f}, 1.0f).x, 0.5f, 1.0f / 255.0f);
    // Two texels wide: level 1, whose texels are both 0.5.
    EXPECT_NEAR(t.sample({0.375f, 0.5f}, 0.5f).x, 0.5f, 1.0f / 255.0f);
    // Between one and two texels: a blend of level 0 (1.0 here) and level 1 (0.5).
    const float between = t.sample({0.375f, 0.5f}, 1.5f / 4.0f).x;
    EXPECT_GT(between, 0.55f);
    EXPECT_LT(between, 0.95f);
}

TEST(Texture, WrapModes) {
    const Texture t = linearRow({0, 85, 170, 255});
    const float at025 = t.sample({0.375f, 0.5f}, 0.0f).x;
    EXPECT_FLOAT_EQ(t.sample({1.375f, 0.5f}, 0.0f, WrapMode::Repeat).x, at025);
    EXPECT_FLOAT_EQ(t.sample({-0.625f, 0.5f}, 0.0f, WrapMode::Repeat).x, at025);
    EXPECT_FLOAT_EQ(t.sample({5.0f, 0.5f}, 0.0f, WrapMode::ClampToEdge).x, 1.0f);
    EXPECT_FLOAT_EQ(t.sample({-3.0f, 0.5f}, 0.0f, WrapMode::ClampToEdge).x, 0.0f);
    // Mirrored: 1.375 reflects to 0.625.
    EXPECT_FLOAT_EQ(t.sample({1.375f, 0.5f}, 0.0f, WrapMode::MirroredRepeat).x, t.sample({0.625f, 0.5f}, 0.0f).x);
    // Huge or non-finite coordinates stay defined.
    for (float u : {1e9f, -1e12f, std::nanf(""), INFINITY}) {
        const Vec4f v = t.sample({u, 0.5f}, 0.0f);
        EXPECT_TRUE(std::isfinite(v.x) && v.x >= 0 && v.x <= 1) << u;
    }
}

TEST(Texture, IntegratingFarOutPolygonsStaysDefined) {
    const Texture t = linearRow({0, 85, 170, 255});
    const std::vector<vox::Vec2f> near = {{0.3f, 0.4f}, {0.45f, 0.4f}, {0.3f, 0.6f}};
    // Whole periods away (exactly representable): the same texels, the same area weights.
    std::vector<vox::Vec2f> shifted = near;
    for (auto& uv : shifted) uv.x += 1024.0f;
    EXPECT_FLOAT_EQ(t.integrate(shifted).x, t.integrate(near).x);
    // Beyond float's integers the texel index is not exact (and overflowed int before): the
    // polygon is point-sampled at its mean, finite and inside the image's range.
    for (float u : {3e7f, 1e9f, -1e12f, 1e30f, -3e38f}) {
        const std::vector<vox::Vec2f> far = {{u, 0.4f}, {u, 0.5f}, {u, 0.6f}};
        for (WrapMode mode : {WrapMode::Repeat, WrapMode::MirroredRepeat, WrapMode::ClampToEdge}) {
            const Vec4f v = t.integrate(far, mode, mode);
            EXPECT_TRUE(std::isfinite(v.x) && v.x >= 0 && v.x <= 1) << u;
            EXPECT_FLOAT_EQ(v.x, t.sample({u, 0.5f}, 0.0f, mode, mode).x) << u;
        }
    }
}

TEST(Texture, DecodesPngFromMemoryExactly) {
    const std::vector<std::uint8_t> pixels = {10, 20, 30, 40, 50, 60, 70, 80, 90, 200, 210, 220};
    const auto png = vox::encodePng(2, 2, 3, pixels);
    const Texture t = vox::decodeTexture(png, "container.glb", "image 0", "image/png", ColorSpace::Linear);
    ASSERT_EQ(t.width(), 2);
    ASSERT_EQ(t.height(), 2);
    EXPECT_FLOAT_EQ(t.texel(0, 1, 1).x, 200.0f / 255.0f);  // row 1 is the second row of the file
    EXPECT_FLOAT_EQ(t.texel(0, 1, 0).z, 60.0f / 255.0f);
    EXPECT_EQ(t.name(), "image 0");
}

TEST(Texture, LoadingErrorsAreTyped) {
    vox::test::ScratchDir dir;
    EXPECT_THROW((void)vox::loadTexture(dir / "missing.png", ColorSpace::SRGB), vox::IoError);
    vox::test::writeText(dir / "garbage.png", "this is not an image at all");
    EXPECT_THROW((void)vox::loadTexture(dir / "garbage.png", ColorSpace::SRGB), vox::InvalidDataError);
    const std::vector<std::uint8_t> junk = {1, 2, 3, 4, 5};
    EXPECT_THROW((void)vox::decodeTexture(junk, "x.glb", "image 3", "image/png", ColorSpace::SRGB), vox::InvalidDataError);
}
