#include <vox/base/error.h>
#include <vox/image_io.h>
#include <vox/texture.h>

#include "gltf_builder.h"
#include "test_support.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <array>
#include <cstdio>
#include <limits>
#include <random>
#include <span>

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

namespace reference {

// The mean of @p t over @p polygon (texture coordinates) on level @p level, Repeat wrapping,
// each texel weighted by the area of the polygon inside it: the polygon cut into rows and each
// row into texels by Sutherland–Hodgman passes, areas by the shoelace formula, all in double and
// relative to the grid's corner (as Texture::integrate computed them in float and absolute texel
// coordinates before the edge coverage, which lost the areas of small pieces).
using Polygon = std::vector<std::array<double, 2>>;

std::pair<Polygon, Polygon> cut(const Polygon& in, int axis, double limit) {
    Polygon below, above;
    for (std::size_t i = 0; i < in.size(); ++i) {
        const auto& p = in[i];
        const auto& q = in[(i + 1) % in.size()];
        const double dp = p[axis] - limit, dq = q[axis] - limit;
        if (dp <= 0) below.push_back(p);
        if (dp >= 0) above.push_back(p);
        if ((dp > 0 && dq < 0) || (dp < 0 && dq > 0)) {
            const double t = dp / (dp - dq);
            const std::array<double, 2> c{p[0] + (q[0] - p[0]) * t, p[1] + (q[1] - p[1]) * t};
            below.push_back(c);
            above.push_back(c);
        }
    }
    return {below, above};
}

double area(const Polygon& polygon) {
    double twice = 0;
    for (std::size_t i = 0; i < polygon.size(); ++i) {
        const auto& p = polygon[i];
        const auto& q = polygon[(i + 1) % polygon.size()];
        twice += p[0] * q[1] - q[0] * p[1];
    }
    return 0.5 * std::abs(twice);
}

Vec4f integrateByCutting(const Texture& t, int level, std::span<const vox::Vec2f> uvs) {
    const int width = t.levelWidth(level), height = t.levelHeight(level);
    double lox = 1e300, loy = 1e300;
    for (const auto& uv : uvs) {
        lox = std::min(lox, double(uv.x) * width);
        loy = std::min(loy, double(uv.y) * height);
    }
    const int x0 = static_cast<int>(std::floor(lox)), y0 = static_cast<int>(std::floor(loy));
    Polygon rest;
    for (const auto& uv : uvs)
        rest.push_back({double(uv.x) * width - x0, double(uv.y) * height - y0});
    const auto wrap = [](int i, int n) { return ((i % n) + n) % n; };
    Vec4f sum{0, 0, 0, 0};
    double total = 0;
    for (int y = 0; !rest.empty() && y < 64; ++y) {
        auto [row, above] = cut(rest, 1, y + 1);
        rest = above;
        for (int x = 0; !row.empty() && x < 64; ++x) {
            auto [piece, right] = cut(row, 0, x + 1);
            row = right;
            const double a = area(piece);
            sum = sum +
                  t.texel(level, wrap(x0 + x, width), wrap(y0 + y, height)) * static_cast<float>(a);
            total += a;
        }
    }
    return sum * static_cast<float>(1.0 / total);
}

}  // namespace reference

TEST(Texture, SrgbTransferFunctionMatchesTheStandard) {
    EXPECT_NEAR(vox::srgbToLinear(0.5f), 0.2140f, 1e-4f);
    EXPECT_NEAR(vox::srgbToLinear(0.04f), 0.04f / 12.92f, 1e-7f);
    EXPECT_FLOAT_EQ(vox::srgbToLinear(1.0f), 1.0f);
    for (float v : {0.0f, 0.001f, 0.2f, 0.5f, 0.9f, 1.0f})
        EXPECT_NEAR(vox::linearToSrgb(vox::srgbToLinear(v)), v, 1e-5f);
}

TEST(Texture, SrgbCodeIsTheRoundedTransferFunction) {
    const auto direct = [](float v) {
        return static_cast<int>(std::lround(255.0f * vox::linearToSrgb(std::clamp(v, 0.0f, 1.0f))));
    };
    // Around every step of the code (where a table off by one would show) and evenly over [0, 1].
    int steps = 0;
    for (std::uint32_t bits = 0; bits <= std::bit_cast<std::uint32_t>(1.0f);
         bits += 1 + (bits >> 12)) {
        const float v = std::bit_cast<float>(bits),
                    next = std::bit_cast<float>(bits + 1 + (bits >> 12));
        ASSERT_EQ(vox::srgbCode(v), direct(v)) << v;
        if (next <= 1.0f && direct(next) != direct(v)) {
            steps += direct(next) - direct(v);
            for (std::uint32_t b = bits; b <= bits + 1 + (bits >> 12); ++b)
                ASSERT_EQ(vox::srgbCode(std::bit_cast<float>(b)), direct(std::bit_cast<float>(b)));
        }
    }
    EXPECT_EQ(steps, 255);
    // srgbCode looks its code up by buckets of 1/4096 and takes at most one step from a bucket's
    // first code: no bucket may hold two steps.
    for (int b = 0; b < 4096; ++b)
        ASSERT_LE(direct(std::nextafter(static_cast<float>(b + 1) / 4096.0f, 0.0f)) -
                      direct(static_cast<float>(b) / 4096.0f),
                  1)
            << b;
    EXPECT_EQ(vox::srgbCode(-1.0f), 0);
    EXPECT_EQ(vox::srgbCode(0.5f), 188);
    EXPECT_EQ(vox::srgbCode(2.0f), 255);
    EXPECT_EQ(vox::srgbCode(std::numeric_limits<float>::infinity()), 255);
    EXPECT_EQ(vox::srgbCode(std::numeric_limits<float>::quiet_NaN()),
              direct(std::numeric_limits<float>::quiet_NaN()) & 255);
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
    EXPECT_FLOAT_EQ(t.sample({0.375f, 0.5f}, 0.0f).x, 1.0f);       // centre of texel 1
    EXPECT_FLOAT_EQ(t.sample({0.125f, 0.5f}, 0.0f).x, 0.0f);       // centre of texel 0
    EXPECT_NEAR(t.sample({0.25f, 0.5f}, 0.0f).x, 0.5f, 1e-6f);     // half-way
    EXPECT_NEAR(t.sample({0.3125f, 0.5f}, 0.0f).x, 0.75f, 1e-6f);  // three quarters
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
    EXPECT_FLOAT_EQ(t.sample({1.375f, 0.5f}, 0.0f, WrapMode::MirroredRepeat).x,
                    t.sample({0.625f, 0.5f}, 0.0f).x);
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

TEST(Texture, IntegrateWeightsEveryTexelByTheAreaItCovers) {
    // A 4×4 linear texture, texel (x, y) = 10·(4y + x): the mean over a polygon is the texels
    // weighted by the areas they cover, computed here by hand.
    std::vector<std::uint8_t> pixels(16);
    for (int i = 0; i < 16; ++i) pixels[i] = static_cast<std::uint8_t>(10 * i);
    const Texture t("grid", 4, 4, 1, pixels, ColorSpace::Linear);
    const auto value = [](int x, int y) {
        return 10.0f * static_cast<float>(4 * (y & 3) + (x & 3)) / 255.0f;
    };
    // Inside one texel: that texel.
    const std::vector<vox::Vec2f> inside = {{0.30f, 0.55f}, {0.45f, 0.55f}, {0.30f, 0.70f}};
    EXPECT_FLOAT_EQ(t.integrate(inside).x, value(1, 2));
    // An axis-aligned square over texel units [0.5, 2.5] × [1.5, 3]: columns 0, 1, 2 cover 0.5, 1,
    // 0.5 and rows 1, 2 cover 0.5, 1.
    const std::vector<vox::Vec2f> square = {
        {0.125f, 0.375f}, {0.625f, 0.375f}, {0.625f, 0.75f}, {0.125f, 0.75f}};
    float sum = 0, area = 0;
    for (int y = 1; y <= 2; ++y)
        for (int x = 0; x <= 2; ++x) {
            const float a = (x == 1 ? 1.0f : 0.5f) * (y == 2 ? 1.0f : 0.5f);
            sum += a * value(x, y);
            area += a;
        }
    EXPECT_NEAR(t.integrate(square).x, sum / area, 1e-6f);
    // A right triangle over texel units (0,0), (2,0), (0,2): texels (0,0) full, (1,0) and (0,1)
    // half each; across the right edge (u from 0.875 to 1.375) it wraps to column 0 and 1.
    const std::vector<vox::Vec2f> triangle = {{0.0f, 0.0f}, {0.5f, 0.0f}, {0.0f, 0.5f}};
    EXPECT_NEAR(t.integrate(triangle).x,
                (value(0, 0) + 0.5f * value(1, 0) + 0.5f * value(0, 1)) / 2.0f, 1e-6f);
    const std::vector<vox::Vec2f> wrapped = {
        {0.875f, 0.25f}, {1.375f, 0.25f}, {1.375f, 0.5f}, {0.875f, 0.5f}};
    EXPECT_NEAR(t.integrate(wrapped).x,
                (0.5f * value(3, 1) + value(0, 1) + 0.5f * value(1, 1)) / 2.0f, 1e-6f);
    // A sliver without area: the point sample at its centre.
    const std::vector<vox::Vec2f> sliver = {{0.1f, 0.1f}, {0.6f, 0.1f}, {0.35f, 0.1f}};
    EXPECT_FLOAT_EQ(t.integrate(sliver).x, t.sample({0.35f, 0.1f}, 0.0f).x);
}

TEST(Texture, IntegrateGivesTheTexelsMeanSquareWithTheSameWeights) {
    // The 4×4 grid of the test above: the mean square over a polygon is the texels' squares
    // weighted by the areas they cover; inside one texel and for a point sample, the value².
    std::vector<std::uint8_t> pixels(16);
    for (int i = 0; i < 16; ++i) pixels[i] = static_cast<std::uint8_t>(10 * i);
    const Texture t("grid", 4, 4, 1, pixels, ColorSpace::Linear);
    const auto value = [](int x, int y) {
        return 10.0f * static_cast<float>(4 * (y & 3) + (x & 3)) / 255.0f;
    };
    vox::Vec4f square{-1, -1, -1, -1};
    const std::vector<vox::Vec2f> inside = {{0.30f, 0.55f}, {0.45f, 0.55f}, {0.30f, 0.70f}};
    EXPECT_FLOAT_EQ(t.integrate(inside, vox::WrapMode::Repeat, vox::WrapMode::Repeat, 8, &square).x,
                    value(1, 2));
    EXPECT_FLOAT_EQ(square.x, value(1, 2) * value(1, 2));
    const std::vector<vox::Vec2f> quad = {
        {0.125f, 0.375f}, {0.625f, 0.375f}, {0.625f, 0.75f}, {0.125f, 0.75f}};
    float sum = 0, squares = 0, area = 0;
    for (int y = 1; y <= 2; ++y)
        for (int x = 0; x <= 2; ++x) {
            const float a = (x == 1 ? 1.0f : 0.5f) * (y == 2 ? 1.0f : 0.5f);
            sum += a * value(x, y);
            squares += a * value(x, y) * value(x, y);
            area += a;
        }
    const vox::Vec4f mean =
        t.integrate(quad, vox::WrapMode::Repeat, vox::WrapMode::Repeat, 8, &square);
    EXPECT_NEAR(mean.x, sum / area, 1e-6f);
    EXPECT_NEAR(square.x, squares / area, 1e-6f);
    EXPECT_GT(square.x - mean.x * mean.x, 0.001f) << "the variance of six different texels";
    const std::vector<vox::Vec2f> sliver = {{0.1f, 0.1f}, {0.6f, 0.1f}, {0.35f, 0.1f}};
    const float point =
        t.integrate(sliver, vox::WrapMode::Repeat, vox::WrapMode::Repeat, 8, &square).x;
    EXPECT_FLOAT_EQ(square.x, point * point);
}

TEST(Texture, IntegrateEqualsCuttingThePolygonIntoTexelsWithinRounding) {
    // Random convex polygons spanning up to 8 texels of textures of 64² and 2048² random texels
    // (texel coordinates up to 2048, where float products of absolute coordinates are coarse):
    // the edge coverage's mean against the cutting's, in double.
    std::mt19937 random(7);
    std::uniform_int_distribution<int> byte(0, 255);
    for (const int size : {64, 2048}) {
        std::vector<std::uint8_t> pixels(static_cast<std::size_t>(size) * size * 4);
        for (auto& p : pixels) p = static_cast<std::uint8_t>(byte(random));
        const Texture t("noise", size, size, 4, pixels, ColorSpace::SRGB);
        std::uniform_real_distribution<float> unit(0.0f, 1.0f), angle(0.0f, 6.2831853f);
        int compared = 0;
        for (int trial = 0; trial < 20000; ++trial) {
            const float extent = (0.5f + 7.5f * unit(random)) / static_cast<float>(size),
                        cx = unit(random), cy = unit(random);
            std::vector<vox::Vec2f> polygon;
            const float a0 = angle(random);
            const int sides = 3 + trial % 7;
            for (int k = 0; k < sides; ++k) {
                const float a = a0 + 6.2831853f * (static_cast<float>(k) + 0.8f * unit(random)) /
                                         static_cast<float>(sides);
                polygon.push_back(
                    {cx + 0.5f * extent * std::cos(a), cy + 0.5f * extent * std::sin(a)});
            }
            if (trial % 2) std::reverse(polygon.begin(), polygon.end());  // either orientation
            // The level integrate picks: the finest on which the polygon spans at most 8 texels.
            float lox = polygon[0].x, hix = lox, loy = polygon[0].y, hiy = loy;
            for (const auto& p : polygon)
                lox = std::min(lox, p.x), hix = std::max(hix, p.x), loy = std::min(loy, p.y),
                hiy = std::max(hiy, p.y);
            int level = 0;
            while (level + 1 < t.levelCount() &&
                   std::max(double(hix - lox) * t.levelWidth(level),
                            double(hiy - loy) * t.levelHeight(level)) > 8)
                ++level;
            const Vec4f got = t.integrate(polygon),
                        expected = reference::integrateByCutting(t, level, polygon);
            for (int c = 0; c < 4; ++c)
                ASSERT_NEAR(got[c], expected[c], 2e-6f) << size << " " << trial << " channel " << c;
            ++compared;
        }
        EXPECT_EQ(compared, 20000);
    }
}

TEST(Texture, DecodesPngFromMemoryExactly) {
    const std::vector<std::uint8_t> pixels = {10, 20, 30, 40, 50, 60, 70, 80, 90, 200, 210, 220};
    const auto png = vox::encodePng(2, 2, 3, pixels);
    const Texture t =
        vox::decodeTexture(png, "container.glb", "image 0", "image/png", ColorSpace::Linear);
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
    EXPECT_THROW((void)vox::loadTexture(dir / "garbage.png", ColorSpace::SRGB),
                 vox::InvalidDataError);
    const std::vector<std::uint8_t> junk = {1, 2, 3, 4, 5};
    EXPECT_THROW((void)vox::decodeTexture(junk, "x.glb", "image 3", "image/png", ColorSpace::SRGB),
                 vox::InvalidDataError);
}
