// The compressed attribute block (libvox/src/octree/attribute_encode.h over the decoders of
// vox/formats/esvo_attributes.h): the cube-face normal and axis codes round-trip within their
// precision, exactly representable colour blocks come out exact, smooth normal blocks decode
// within a fraction of a degree, unused slots change nothing, and the colour encoder is at
// least as good as stb_dxt's high-quality mode on real texture tiles (both decoded by ours) —
// at every AttributeEffort (the ...ByEffort tests); and the faster efforts, whose early exits
// skip searches, stay close to Best's error.
#include "octree/attribute_encode.h"

#include <vox/formats/esvo_attributes.h>
#include <vox/texture.h>

#include "attribute_corpus.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <numbers>
#include <random>
#include <string>
#include <thread>
#include <utility>
#include <vector>

namespace {

namespace esvo = vox::esvo;
using esvo::Vec3;
using vox::corpus::angle;
using vox::corpus::ColorBlock;
using vox::corpus::normalised;
using vox::corpus::randomCone;
using vox::corpus::randomDirection;
using vox::corpus::randomMask;
using vox::detail::AttributeEffort;

constexpr double kDegree = std::numbers::pi / 180.0;

struct NormalErrors {
    double mean = 0, max = 0;
};

/// Angular errors of the used slots of an encoded normal block, as decodeBlockNormal decodes them.
NormalErrors normalErrors(const std::array<Vec3, 16>& normals, std::uint32_t mask,
                          const std::array<std::uint32_t, 4>& words) {
    const esvo::CompressedBlock block{0, 0, words[0], words[1], words[2], words[3]};
    NormalErrors e;
    unsigned count = 0;
    for (unsigned s = 0; s < 16; ++s) {
        if (!((mask >> s) & 1u)) continue;
        const double a = angle(normals[s], esvo::decodeBlockNormal(block.data(), s));
        e.mean += a;
        e.max = std::max(e.max, a);
        ++count;
    }
    if (count) e.mean /= count;
    return e;
}

/// Normals of a sphere of radius @p radius (voxels) at the 16 child-voxel centres of two
/// adjacent 2×2×2 descriptors (a 4×2×2 box along @p longAxis) near a random surface point.
std::array<Vec3, 16> spherePatch(std::mt19937& rng, double radius, unsigned longAxis) {
    const Vec3 d = randomDirection(rng);
    std::array<Vec3, 16> normals{};
    for (unsigned s = 0; s < 16; ++s) {
        const unsigned child = s & 7, descriptor = s >> 3;
        std::array<double, 3> offset{(child & 1) - 0.5, ((child >> 1) & 1) - 0.5,
                                     ((child >> 2) & 1) - 0.5};
        offset[longAxis] = offset[longAxis] + 2.0 * descriptor - 1.0;
        normals[s] = normalised(radius * d[0] + offset[0], radius * d[1] + offset[1],
                                radius * d[2] + offset[2]);
    }
    return normals;
}

// ---- colour corpus ----------------------------------------------------------------------------

/// Random colours around a random line (gradients with noise) and uniformly random blocks.
std::vector<ColorBlock> syntheticBlocks(std::mt19937& rng, std::size_t count) {
    std::uniform_int_distribution<int> byte(0, 255);
    std::uniform_real_distribution<double> unit(0, 1);
    std::vector<ColorBlock> blocks;
    for (std::size_t i = 0; i < count; ++i) {
        ColorBlock b;
        const int kind = static_cast<int>(i % 3);
        std::array<double, 3> a{}, z{};
        for (unsigned ch = 0; ch < 3; ++ch) a[ch] = byte(rng), z[ch] = byte(rng);
        const double noise = kind == 0 ? 0 : 12.0;
        std::normal_distribution<double> jitter(0, noise > 0 ? noise : 1);
        for (unsigned s = 0; s < 16; ++s) {
            const double t = kind == 0 ? (s % 4 + s / 4) / 6.0 : unit(rng);
            std::array<std::uint32_t, 3> c{};
            for (unsigned ch = 0; ch < 3; ++ch) {
                double v = kind == 2
                               ? byte(rng)
                               : a[ch] + t * (z[ch] - a[ch]) + (noise > 0 ? jitter(rng) : 0.0);
                c[ch] = static_cast<std::uint32_t>(std::clamp(std::lround(v), 0l, 255l));
            }
            b.colors[s] = esvo::packColor(c[0], c[1], c[2]);
        }
        blocks.push_back(b);
    }
    return blocks;
}

/// The tests that must hold whatever the effort run once per effort.
class ByEffort : public ::testing::TestWithParam<AttributeEffort> {};

std::string effortName(const ::testing::TestParamInfo<AttributeEffort>& info) {
    return info.param == AttributeEffort::Fast   ? "Fast"
           : info.param == AttributeEffort::Best ? "Best"
                                                 : "Default";
}

}  // namespace

INSTANTIATE_TEST_SUITE_P(AttributeEncode, ByEffort,
                         ::testing::Values(AttributeEffort::Fast, AttributeEffort::Default,
                                           AttributeEffort::Best),
                         effortName);

TEST(AttributeEncode, CubeFaceNormalRoundTripsWithinItsPrecision) {
    std::vector<Vec3> directions;
    for (int axis = 0; axis < 3; ++axis)
        for (float sign : {-1.0f, 1.0f}) {
            Vec3 n{};
            n[axis] = sign;
            directions.push_back(n);
        }
    for (float x : {-1.0f, 0.0f, 1.0f})
        for (float y : {-1.0f, 0.0f, 1.0f})
            for (float z : {-1.0f, 0.0f, 1.0f})
                if (x != 0 || y != 0 || z != 0) directions.push_back(normalised(x, y, z));
    std::mt19937 rng(1);
    for (int i = 0; i < 200000; ++i) directions.push_back(randomDirection(rng));
    double worst = 0;
    for (const Vec3& n : directions) {
        const std::uint32_t code = esvo::encodeNormal(n);
        worst = std::max(worst, angle(n, esvo::decodeNormal(code)));
        const Vec3 unit = esvo::decodeUnitNormal(code);
        EXPECT_NEAR(std::sqrt(unit[0] * unit[0] + unit[1] * unit[1] + unit[2] * unit[2]), 1.0,
                    1e-6);
    }
    EXPECT_LT(worst,
              std::ldexp(1.0, -13));  // the bound esvo_attributes.h states (tighter than 2^-12)
    // The axes themselves are exact.
    for (unsigned i = 0; i < 6; ++i)
        EXPECT_EQ(esvo::decodeNormal(esvo::encodeNormal(directions[i])), directions[i]);
}

TEST(AttributeEncode, AxisCodeRoundTrips) {
    // Every decoded axis is re-encoded to the same vector.
    for (std::uint32_t bits = 0; bits < 0x10000u; ++bits) {
        const Vec3 a = esvo::decodeAxis(bits);
        ASSERT_EQ(esvo::decodeAxis(esvo::encodeAxis(a)), a) << bits;
    }
    // Arbitrary vectors within range: within half a step of the chosen exponent per component.
    std::mt19937 rng(2);
    std::uniform_real_distribution<float> component(-1, 1);
    std::uniform_int_distribution<int> exponent(-12, 4);
    for (int i = 0; i < 20000; ++i) {
        const float scale = std::ldexp(1.0f, exponent(rng));
        const Vec3 a{component(rng) * scale, component(rng) * scale, component(rng) * scale};
        const std::uint32_t bits = esvo::encodeAxis(a);
        const float step = std::ldexp(1.0f, static_cast<int>(bits >> 12) - 13);
        const Vec3 d = esvo::decodeAxis(bits);
        for (unsigned c = 0; c < 3; ++c)
            ASSERT_LE(std::fabs(d[c] - a[c]), 0.5f * step * 1.0001f) << i;
        // and the exponent is the smallest whose range (−8 … 7 steps) holds every component.
        if ((bits >> 12) > 0) {
            const float finer = 0.5f * step;
            EXPECT_TRUE(std::max({a[0], a[1], a[2]}) > 7.5f * finer ||
                        std::min({a[0], a[1], a[2]}) < -8.5f * finer)
                << i;
        }
    }
}

TEST(AttributeEncode, EmptyMaskGivesZeroBlockWithValidBase) {
    std::array<std::uint64_t, 16> values{};
    for (unsigned s = 0; s < 16; ++s)
        values[s] = 0x12345678u | (std::uint64_t{esvo::encodeNormal({1, 2, 3})} << 32);
    const esvo::CompressedBlock block = vox::detail::encodeCompressedBlock(values, 0);
    EXPECT_EQ(block[0], 0u);
    EXPECT_EQ(block[1], 0u);
    EXPECT_EQ(block[3], 0u);
    EXPECT_EQ(block[4], 0u);
    EXPECT_EQ(block[5], 0u);
    EXPECT_EQ(esvo::decodeUnitNormal(block[2]), (Vec3{0, 0, 1}));
    EXPECT_EQ(esvo::decodeBlockNormal(block.data(), 3), (Vec3{0, 0, 1}));
}

TEST_P(ByEffort, RepresentableColourBlocksAreExact) {
    const AttributeEffort effort = GetParam();
    std::mt19937 rng(3);
    std::uniform_int_distribution<std::uint32_t> code(0, 0xFFFF);
    for (int i = 0; i < 2000; ++i) {
        const std::uint32_t mask = randomMask(rng, 1 + static_cast<unsigned>(i % 16));
        const std::uint32_t a = esvo::expandRgb565(code(rng)), b = esvo::expandRgb565(code(rng));
        std::array<std::uint32_t, 16> colors{};
        for (unsigned s = 0; s < 16; ++s) colors[s] = (i % 2 == 0 || (rng() & 1)) ? a : b;
        const auto words = vox::detail::encodeColorBlock(colors, mask, effort);
        ASSERT_EQ(vox::detail::colorBlockError(colors, mask, words[0], words[1]), 0u) << i;
        const esvo::CompressedBlock block{words[0], words[1], 0, 0, 0, 0};
        for (unsigned s = 0; s < 16; ++s) {
            if ((mask >> s) & 1u)
                ASSERT_EQ(esvo::decodeBlockColor(block.data(), s), colors[s] | 0xFF000000u);
            else
                ASSERT_EQ(esvo::blockIndex(words[1], s), 0u);
        }
    }
}

TEST_P(ByEffort, SingleColourBlocksAreOptimal) {
    const AttributeEffort effort = GetParam();
    // Brute force over every endpoint pair, per channel (channels are independent for one colour).
    const auto bestChannel = [](int value, int bits) {
        const auto expand = [bits](int c) {
            return bits == 5 ? (c << 3) | (c >> 2) : (c << 2) | (c >> 4);
        };
        int best = 1 << 20;
        for (int a = 0; a < (1 << bits); ++a)
            for (int b = 0; b < (1 << bits); ++b)
                for (int entry : {expand(a), (2 * expand(a) + expand(b) + 1) / 3})
                    best = std::min(best, (entry - value) * (entry - value));
        return best;
    };
    std::array<std::array<int, 256>, 2> best{};
    for (int v = 0; v < 256; ++v) best[0][v] = bestChannel(v, 5), best[1][v] = bestChannel(v, 6);
    std::mt19937 rng(4);
    std::uniform_int_distribution<std::uint32_t> byte(0, 255);
    for (int i = 0; i < 3000; ++i) {
        const std::uint32_t r = byte(rng), g = byte(rng), b = byte(rng);
        std::array<std::uint32_t, 16> colors{};
        colors.fill(esvo::packColor(r, g, b));
        const std::uint32_t mask = randomMask(rng, 1 + static_cast<unsigned>(i % 16));
        const auto words = vox::detail::encodeColorBlock(colors, mask, effort);
        const std::uint64_t expected =
            static_cast<std::uint64_t>(std::popcount(mask)) *
            static_cast<std::uint64_t>(best[0][r] + best[1][g] + best[0][b]);
        ASSERT_EQ(vox::detail::colorBlockError(colors, mask, words[0], words[1]), expected)
            << r << ' ' << g << ' ' << b;
    }
}

TEST_P(ByEffort, UnusedSlotsChangeNothing) {
    const AttributeEffort effort = GetParam();
    std::mt19937 rng(5);
    std::uniform_int_distribution<std::uint32_t> word;
    for (int i = 0; i < 500; ++i) {
        const std::uint32_t mask = randomMask(rng, 1 + static_cast<unsigned>(i % 15));
        std::array<std::uint64_t, 16> values{};
        for (auto& v : values)
            v = (word(rng) & 0xFFFFFFu) |
                (std::uint64_t{esvo::encodeNormal(randomDirection(rng))} << 32);
        const esvo::CompressedBlock block =
            vox::detail::encodeCompressedBlock(values, mask, effort);
        for (unsigned s = 0; s < 16; ++s) {
            if ((mask >> s) & 1u) continue;
            EXPECT_EQ(esvo::blockIndex(block[1], s), 0u);
            EXPECT_EQ(esvo::blockIndex(block[3], s), 0u);
            EXPECT_EQ(esvo::blockIndex(block[5], s), 0u);
            values[s] = word(rng) | (std::uint64_t{esvo::encodeNormal(randomDirection(rng))} << 32);
        }
        ASSERT_EQ(vox::detail::encodeCompressedBlock(values, mask, effort), block) << i;
        ASSERT_EQ(vox::detail::encodeCompressedBlock(values, mask | 0xFFFF0000u, effort), block)
            << "bits above 15 are ignored";
    }
}

TEST_P(ByEffort, EqualNormalsKeepTheCubeFacePrecision) {
    const AttributeEffort effort = GetParam();
    std::mt19937 rng(6);
    for (int i = 0; i < 2000; ++i) {
        const Vec3 n = i < 6 ? Vec3{float(i == 0) - float(i == 1), float(i == 2) - float(i == 3),
                                    float(i == 4) - float(i == 5)}
                             : randomDirection(rng);
        std::array<Vec3, 16> normals{};
        normals.fill(n);
        const std::uint32_t mask = randomMask(rng, 1 + static_cast<unsigned>(i % 16));
        const auto words = vox::detail::encodeNormalBlock(normals, mask, effort);
        ASSERT_LT(normalErrors(normals, mask, words).max, 0.01 * kDegree) << i;
        ASSERT_LE(normalErrors(normals, mask, words).max,
                  angle(n, esvo::decodeNormal(esvo::encodeNormal(n))) + 2e-6)
            << i;
    }
}

TEST_P(ByEffort, SmoothNormalBlocksDecodeWithinAFractionOfADegree) {
    const AttributeEffort effort = GetParam();
    std::mt19937 rng(7);
    // Radius 24 voxels: a 4×2×2 block spans about 10°; smaller radii (more curvature) less
    // strictly.
    for (const double radius : {24.0, 64.0, 400.0}) {
        double sum = 0, worst = 0;
        int count = 0;
        for (int i = 0; i < 1000; ++i) {
            const auto normals = spherePatch(rng, radius, static_cast<unsigned>(i % 3));
            const std::uint32_t mask = i % 2 ? 0xFFFFu : randomMask(rng, 8);
            const NormalErrors e =
                normalErrors(normals, mask, vox::detail::encodeNormalBlock(normals, mask, effort));
            sum += e.mean;
            worst = std::max(worst, e.max);
            ++count;
        }
        std::printf("sphere radius %g: mean %.3f°, max %.3f°\n", radius, sum / count / kDegree,
                    worst / kDegree);
        EXPECT_LT(sum / count, 0.5 * kDegree * 24.0 / radius) << radius;
        EXPECT_LT(worst, 2.0 * kDegree * std::sqrt(24.0 / radius)) << radius;
    }
    // Random normals in a 10° cone (half-angle 5°, no structure): still well under a degree on
    // average.
    double sum = 0, worst = 0;
    for (int i = 0; i < 1000; ++i) {
        const auto normals = randomCone(rng, 5 * kDegree);
        const NormalErrors e = normalErrors(
            normals, 0xFFFFu, vox::detail::encodeNormalBlock(normals, 0xFFFFu, effort));
        sum += e.mean;
        worst = std::max(worst, e.max);
    }
    // (16 unstructured directions against a 4×4 lattice: the format, not the search, limits this.)
    std::printf("random 5° cone: mean %.3f°, max %.3f°\n", sum / 1000 / kDegree, worst / kDegree);
    EXPECT_LT(sum / 1000, 0.75 * kDegree);
    EXPECT_LT(worst, 3 * kDegree);
}

TEST_P(ByEffort, WidelySpreadNormalsStaySane) {
    const AttributeEffort effort = GetParam();
    std::mt19937 rng(8);
    double sum = 0;
    for (int i = 0; i < 500; ++i) {
        std::array<Vec3, 16> normals{};
        for (auto& n : normals) n = randomDirection(rng);  // the whole sphere
        if (i % 2) normals[1] = Vec3{-normals[0][0], -normals[0][1], -normals[0][2]};
        const std::uint32_t mask = i % 3 ? 0xFFFFu : randomMask(rng, 4);
        const auto words = vox::detail::encodeNormalBlock(normals, mask, effort);
        const esvo::CompressedBlock block{0, 0, words[0], words[1], words[2], words[3]};
        for (unsigned s = 0; s < 16; ++s) {
            const Vec3 d = esvo::decodeBlockNormal(block.data(), s);
            ASSERT_TRUE(std::isfinite(d[0]) && std::isfinite(d[1]) && std::isfinite(d[2]));
            ASSERT_NEAR(std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]), 1.0, 1e-5);
        }
        sum += normalErrors(normals, mask, words).mean;
    }
    // 16 decoded directions cannot cover the sphere, but they should serve it far better than one.
    std::printf("directions over the whole sphere: mean %.2f°\n", sum / 500 / kDegree);
    EXPECT_LT(sum / 500, 30 * kDegree);
}

/// A block whose used slots (a random set, at least one per direction) cycle through
/// @p directions in random order; the unused slots hold random directions. Returns the largest
/// angular error of the used slots.
double patternMaxError(std::mt19937& rng, const std::vector<Vec3>& directions,
                       AttributeEffort effort) {
    std::array<unsigned, 16> slots{};
    for (unsigned i = 0; i < 16; ++i) slots[i] = i;
    std::shuffle(slots.begin(), slots.end(), rng);
    const unsigned used =
        static_cast<unsigned>(directions.size() + rng() % (17 - directions.size()));
    std::array<Vec3, 16> normals{};
    std::uint32_t mask = 0;
    for (unsigned i = 0; i < 16; ++i) {
        normals[slots[i]] = i < used ? directions[i % directions.size()] : randomDirection(rng);
        if (i < used) mask |= 1u << slots[i];
    }
    return normalErrors(normals, mask, vox::detail::encodeNormalBlock(normals, mask, effort)).max;
}

/// The 6 axis directions ±x, ±y, ±z.
Vec3 axisDirection(unsigned axis, bool negative) {
    Vec3 d{};
    d[axis] = negative ? -1.0f : 1.0f;
    return d;
}

Vec3 sum(const Vec3& a, const Vec3& b) {
    return normalised(double(a[0]) + b[0], double(a[1]) + b[1], double(a[2]) + b[2]);
}

// Voxels along the edge where two walls meet (of a box, a room) have children with either wall's
// normal and, where both walls cross the child, their average: normals 90° apart in one block.
TEST_P(ByEffort, NormalsWhereTwoWallsMeetDecodeWithinTwoDegrees) {
    const AttributeEffort effort = GetParam();
    std::mt19937 rng(11);
    double worst = 0;
    for (unsigned a = 0; a < 3; ++a)
        for (unsigned b = 0; b < 3; ++b) {
            if (a == b) continue;
            for (unsigned signs = 0; signs < 4; ++signs) {
                const Vec3 wall0 = axisDirection(a, signs & 1u),
                           wall1 = axisDirection(b, (signs & 2u) != 0);
                for (int repeat = 0; repeat < 4; ++repeat) {
                    worst = std::max(
                        worst, patternMaxError(rng, {wall0, wall1, sum(wall0, wall1)}, effort));
                    worst = std::max(worst, patternMaxError(rng, {wall0, wall1}, effort));
                }
            }
        }
    std::printf("edges of axis-aligned walls: max %.3f°\n", worst / kDegree);
    EXPECT_LT(worst, 2 * kDegree);
}

// Voxels at the corner where three walls meet: the three walls' normals and their average.
TEST_P(ByEffort, NormalsWhereThreeWallsMeetDecodeWithinAFewDegrees) {
    const AttributeEffort effort = GetParam();
    std::mt19937 rng(12);
    double worst = 0;
    for (unsigned signs = 0; signs < 8; ++signs) {
        const Vec3 x = axisDirection(0, signs & 1u), y = axisDirection(1, (signs & 2u) != 0),
                   z = axisDirection(2, (signs & 4u) != 0);
        const Vec3 corner = normalised(double(x[0]), double(y[1]), double(z[2]));
        for (int repeat = 0; repeat < 8; ++repeat) {
            worst = std::max(worst, patternMaxError(rng, {x, y, z, corner}, effort));
            worst = std::max(worst, patternMaxError(rng, {x, y, z}, effort));
        }
    }
    std::printf("corners of axis-aligned walls: max %.3f°\n", worst / kDegree);
    EXPECT_LT(worst, 3 * kDegree);
}

// Thin sheets (a wall one voxel thick) give both of their sides' normals, 180° apart, in one
// block: neither may come out flipped.
TEST_P(ByEffort, BothSidesOfAThinSheetKeepTheirSide) {
    const AttributeEffort effort = GetParam();
    std::mt19937 rng(13);
    double worst = 0;
    for (unsigned axis = 0; axis < 3; ++axis) {
        // Four slots each side (the others unused), and random patterns.
        std::array<Vec3, 16> normals{};
        for (unsigned s = 0; s < 16; ++s) normals[s] = axisDirection(axis, s >= 4);
        const std::uint32_t mask = 0xFFu;
        worst = std::max(
            worst,
            normalErrors(normals, mask, vox::detail::encodeNormalBlock(normals, mask, effort)).max);
        for (int repeat = 0; repeat < 8; ++repeat)
            worst = std::max(
                worst, patternMaxError(rng, {axisDirection(axis, false), axisDirection(axis, true)},
                                       effort));
    }
    for (int i = 0; i < 300; ++i) {
        const Vec3 d = randomDirection(rng);
        worst = std::max(worst, patternMaxError(rng, {d, Vec3{-d[0], -d[1], -d[2]}}, effort));
    }
    std::printf("sheets: max %.3f°\n", worst / kDegree);
    EXPECT_LT(worst, 2 * kDegree);
}

// Any two directions (one lattice line through both), at any angle.
TEST_P(ByEffort, AnyTwoDirectionsDecodeWithinTwoDegrees) {
    const AttributeEffort effort = GetParam();
    std::mt19937 rng(14);
    double worst = 0, sum = 0;
    for (int i = 0; i < 1000; ++i) {
        const double e = patternMaxError(rng, {randomDirection(rng), randomDirection(rng)}, effort);
        worst = std::max(worst, e);
        sum += e;
    }
    std::printf("two random directions: mean of block max %.3f°, max %.3f°\n", sum / 1000 / kDegree,
                worst / kDegree);
    EXPECT_LT(worst, 2 * kDegree);
    EXPECT_LT(sum / 1000, 0.5 * kDegree);
}

TEST_P(ByEffort, ColourBeatsStbDxtHighQuality) {
    const AttributeEffort effort = GetParam();
    std::mt19937 rng(9);
    const std::filesystem::path models = vox::test::assimpModels();
    const std::array<std::filesystem::path, 5> textures{
        models / "glTF/CesiumMilkTruck/CesiumMilkTruck.png", models / "OBJ/drkwood2.jpg",
        models / "IQM/Head.jpg", models / "3DS/CWALL02.jpg",
        models / "LWO/LWO2/MappingModes/earthSpherical.jpg"};
    std::vector<ColorBlock> corpus = vox::corpus::textureTiles(textures, 1200);
    ASSERT_GE(corpus.size(), 1000u) << "texture corpus missing: is assimp-testmodels installed?";
    const std::size_t tiles = corpus.size();
    const std::vector<ColorBlock> synthetic = syntheticBlocks(rng, 1500);
    corpus.insert(corpus.end(), synthetic.begin(), synthetic.end());
    // Partially used blocks (8 of 16 slots, as in voxel blocks).
    const std::size_t full = corpus.size();
    for (std::size_t i = 0; i < full; i += 2) {
        ColorBlock b = corpus[i];
        b.mask = randomMask(rng, 8);
        corpus.push_back(b);
    }
    std::array<std::uint64_t, 2> ours{}, stb{};  // [full, partial]
    std::uint64_t tileOurs = 0, tileStb = 0;
    for (std::size_t i = 0; i < corpus.size(); ++i) {
        const ColorBlock& b = corpus[i];
        const auto words = vox::detail::encodeColorBlock(b.colors, b.mask, effort);
        const auto stbWords = vox::corpus::stbEncode(b, true);
        const std::uint64_t e = vox::detail::colorBlockError(b.colors, b.mask, words[0], words[1]);
        const std::uint64_t es =
            vox::detail::colorBlockError(b.colors, b.mask, stbWords[0], stbWords[1]);
        ours[i >= full] += e;
        stb[i >= full] += es;
        if (i < tiles) tileOurs += e, tileStb += es;
    }
    EXPECT_LE(ours[0], stb[0]);
    EXPECT_LE(ours[1], stb[1]);
    EXPECT_LE(tileOurs, tileStb);
    std::printf(
        "summed squared error, ours vs stb_dxt HIGHQUAL: tiles %llu vs %llu, full %llu vs %llu, "
        "partial %llu vs %llu\n",
        static_cast<unsigned long long>(tileOurs), static_cast<unsigned long long>(tileStb),
        static_cast<unsigned long long>(ours[0]), static_cast<unsigned long long>(stb[0]),
        static_cast<unsigned long long>(ours[1]), static_cast<unsigned long long>(stb[1]));
}

TEST_P(ByEffort, IsDeterministic) {
    const AttributeEffort effort = GetParam();
    std::mt19937 rng(10);
    for (int i = 0; i < 200; ++i) {
        std::array<std::uint64_t, 16> values{};
        for (auto& v : values)
            v = (rng() & 0xFFFFFFu) |
                (std::uint64_t{esvo::encodeNormal(randomDirection(rng))} << 32);
        const std::uint32_t mask = randomMask(rng, 1 + static_cast<unsigned>(i % 16));
        EXPECT_EQ(vox::detail::encodeCompressedBlock(values, mask, effort),
                  vox::detail::encodeCompressedBlock(values, mask, effort));
    }
}

// The normal search keeps a thread's recent results: a block must encode alike whatever the
// thread encoded before it, and in a thread that encoded nothing yet.
TEST_P(ByEffort, DoesNotDependOnTheBlocksBefore) {
    const AttributeEffort effort = GetParam();
    std::mt19937 rng(12);
    std::vector<std::pair<std::array<std::uint64_t, 16>, std::uint32_t>> blocks;
    for (int i = 0; i < 120; ++i) {
        std::array<std::uint64_t, 16> values{};
        for (auto& v : values)
            v = (rng() & 0xFFFFFFu) |
                (std::uint64_t{esvo::encodeNormal(randomDirection(rng))} << 32);
        const std::uint32_t mask = randomMask(rng, 2 + static_cast<unsigned>(i % 15));
        blocks.emplace_back(values, mask);
        // The same normals in other slots, and the same slots with one normal changed.
        std::array<std::uint64_t, 16> moved{};
        std::uint32_t movedMask = 0;
        for (unsigned s = 0, t = 15; s < 16; ++s)
            if ((mask >> s) & 1u) {
                while (t > 0 && ((movedMask >> t) & 1u)) --t;
                moved[t] = values[s];
                movedMask |= 1u << t;
            }
        blocks.emplace_back(moved, movedMask);
        values[static_cast<unsigned>(std::countr_zero(mask))] ^= std::uint64_t{1} << 32;
        blocks.emplace_back(values, mask);
    }
    std::vector<esvo::CompressedBlock> forward;
    for (const auto& [values, mask] : blocks)
        forward.push_back(vox::detail::encodeCompressedBlock(values, mask, effort));
    std::vector<esvo::CompressedBlock> backward(blocks.size());
    std::thread([&] {
        for (std::size_t i = blocks.size(); i-- > 0;)
            backward[i] =
                vox::detail::encodeCompressedBlock(blocks[i].first, blocks[i].second, effort);
    }).join();
    for (std::size_t i = 0; i < blocks.size(); ++i) ASSERT_EQ(forward[i], backward[i]) << i;
}

namespace {

/// Summed angular error (radians) of encodeNormalBlock at @p effort over @p blocks.
double summedNormalError(const std::vector<std::pair<std::array<Vec3, 16>, std::uint32_t>>& blocks,
                         AttributeEffort effort) {
    double sum = 0;
    for (const auto& [normals, mask] : blocks)
        sum += normalErrors(normals, mask, vox::detail::encodeNormalBlock(normals, mask, effort))
                   .mean *
               std::popcount(mask);
    return sum;
}

}  // namespace

// Default and Fast skip searches (fewer face-plane starts, fit on the codes; fewer and lighter
// 3-D searches; fewer colour starts and descent passes); on smooth, structured and unstructured
// blocks they stay close to Best, so that a shortcut that returned a much worse block than the
// search would find fails here. (Nearly flat blocks, where the early exits apply, are checked
// against their bound in EarlyExitsStayWithinTheirBound.)
TEST(AttributeEncode, FasterEffortsStayCloseToBest) {
    std::mt19937 rng(15);
    const auto ratioLimit = [](AttributeEffort e, double defaultLimit, double fastLimit) {
        return e == AttributeEffort::Fast ? fastLimit : defaultLimit;
    };
    // Normals: sphere patches from curved (radius 8) to nearly flat (radius 128), random cones.
    for (const double radius : {8.0, 24.0, 128.0}) {
        std::vector<std::pair<std::array<Vec3, 16>, std::uint32_t>> blocks;
        for (int i = 0; i < 400; ++i)
            blocks.emplace_back(spherePatch(rng, radius, static_cast<unsigned>(i % 3)),
                                i % 2 ? 0xFFFFu : randomMask(rng, 8));
        const double best = summedNormalError(blocks, AttributeEffort::Best);
        for (const AttributeEffort e : {AttributeEffort::Default, AttributeEffort::Fast}) {
            const double ratio = summedNormalError(blocks, e) / best;
            std::printf("sphere radius %g: %s / Best = %.4f\n", radius,
                        e == AttributeEffort::Fast ? "Fast" : "Default", ratio);
            EXPECT_LT(ratio, ratioLimit(e, 1.05, 1.25)) << radius;
        }
    }
    for (const double halfAngle : {2.0, 5.0, 20.0}) {
        std::vector<std::pair<std::array<Vec3, 16>, std::uint32_t>> blocks;
        for (int i = 0; i < 300; ++i)
            blocks.emplace_back(randomCone(rng, halfAngle * kDegree), 0xFFFFu);
        const double best = summedNormalError(blocks, AttributeEffort::Best);
        for (const AttributeEffort e : {AttributeEffort::Default, AttributeEffort::Fast}) {
            const double ratio = summedNormalError(blocks, e) / best;
            std::printf("random %g° cone: %s / Best = %.4f\n", halfAngle,
                        e == AttributeEffort::Fast ? "Fast" : "Default", ratio);
            EXPECT_LT(ratio, ratioLimit(e, 1.05, 1.25)) << halfAngle;
        }
    }
    // Colours: texture tiles and synthetic gradients, whole and half used.
    const std::filesystem::path models = vox::test::assimpModels();
    const std::array<std::filesystem::path, 3> textures{
        models / "glTF/CesiumMilkTruck/CesiumMilkTruck.png", models / "IQM/Head.jpg",
        models / "3DS/CWALL02.jpg"};
    std::vector<ColorBlock> corpus = vox::corpus::textureTiles(textures, 600);
    const std::vector<ColorBlock> synthetic = syntheticBlocks(rng, 600);
    corpus.insert(corpus.end(), synthetic.begin(), synthetic.end());
    for (std::size_t i = 0, n = corpus.size(); i < n; i += 2) {
        ColorBlock b = corpus[i];
        b.mask = randomMask(rng, 8);
        corpus.push_back(b);
    }
    std::array<std::uint64_t, 3> error{};
    for (const ColorBlock& b : corpus)
        for (const AttributeEffort e :
             {AttributeEffort::Fast, AttributeEffort::Default, AttributeEffort::Best}) {
            const auto words = vox::detail::encodeColorBlock(b.colors, b.mask, e);
            error[static_cast<unsigned>(e)] +=
                vox::detail::colorBlockError(b.colors, b.mask, words[0], words[1]);
        }
    const double best = static_cast<double>(error[static_cast<unsigned>(AttributeEffort::Best)]);
    const double defaultRatio =
                     static_cast<double>(error[static_cast<unsigned>(AttributeEffort::Default)]) /
                     best,
                 fastRatio =
                     static_cast<double>(error[static_cast<unsigned>(AttributeEffort::Fast)]) /
                     best;
    std::printf("colour summed squared error: Default / Best = %.4f, Fast / Best = %.4f\n",
                defaultRatio, fastRatio);
    EXPECT_LT(defaultRatio, 1.02);  // 0.09 dB
    EXPECT_LT(fastRatio, 1.04);
}

// The faster efforts keep the face-plane fit of the first start where it fits within 0.05°
// (Default) or 0.1° (Fast) per normal, and stop the 3-D search within 0.02°: on nearly flat
// blocks, where they apply, no block may decode worse than Best's by more than those bounds (a
// bound measured on the face plane's metric, so a little margin).
TEST(AttributeEncode, EarlyExitsStayWithinTheirBound) {
    std::mt19937 rng(16);
    double worst = 0;
    for (const double radius : {300.0, 1000.0, 4000.0}) {
        for (int i = 0; i < 600; ++i) {
            const auto normals = spherePatch(rng, radius, static_cast<unsigned>(i % 3));
            const std::uint32_t mask = i % 2 ? 0xFFFFu : randomMask(rng, 8);
            const auto rms = [&](AttributeEffort e) {
                const esvo::CompressedBlock block = [&] {
                    const auto w = vox::detail::encodeNormalBlock(normals, mask, e);
                    return esvo::CompressedBlock{0, 0, w[0], w[1], w[2], w[3]};
                }();
                double sum = 0;
                for (unsigned s = 0; s < 16; ++s)
                    if ((mask >> s) & 1u)
                        sum += std::pow(angle(normals[s], esvo::decodeBlockNormal(block.data(), s)),
                                        2);
                return std::sqrt(sum / std::popcount(mask));
            };
            const double best = rms(AttributeEffort::Best);
            for (const AttributeEffort e : {AttributeEffort::Default, AttributeEffort::Fast}) {
                const double bound = (e == AttributeEffort::Fast ? 0.1 : 0.05) * kDegree;
                const double excess = rms(e) - std::max(best, bound);
                worst = std::max(worst, excess);
                ASSERT_LT(excess, 0.25 * bound) << radius << ' ' << i;
            }
        }
    }
    std::printf("nearly flat blocks: largest RMS beyond max(Best, bound) %.4f°\n", worst / kDegree);
}

// Where the CPU has AVX-512, encodeNormalBlock's nearest-lattice kernels run sixteen lattice
// points a vector; they must give the SSE2 kernels' bits on every kind of block: smooth patches
// from curved to flat, cones narrow to wide, edges, corners and sheets (few directions, the 3-D
// search), random directions, with full and partial masks, at every effort. Each run is in a
// thread of its own, so that neither sees the other's cached searches.
TEST_P(ByEffort, Avx512KernelsGiveTheSameBlocks) {
    const bool before = vox::detail::encoderAvx512();
    if (!vox::detail::setEncoderAvx512(true)) GTEST_SKIP() << "no AVX-512F on this CPU";
    const AttributeEffort effort = GetParam();
    std::mt19937 rng(21);
    std::vector<std::pair<std::array<Vec3, 16>, std::uint32_t>> blocks;
    const auto mask = [&](int i) {
        return i % 3 == 0 ? 0xFFFFu : randomMask(rng, 1 + static_cast<unsigned>(i % 16));
    };
    for (const double radius : {6.0, 24.0, 128.0, 1000.0})
        for (int i = 0; i < 150; ++i)
            blocks.emplace_back(spherePatch(rng, radius, static_cast<unsigned>(i % 3)), mask(i));
    for (const double halfAngle : {1.0, 5.0, 20.0, 60.0})
        for (int i = 0; i < 150; ++i)
            blocks.emplace_back(randomCone(rng, halfAngle * kDegree), mask(i));
    for (int i = 0; i < 300;
         ++i) {  // two to four directions (edges, corners, sheets) and random ones
        std::array<Vec3, 4> directions{};
        for (auto& d : directions) d = randomDirection(rng);
        if (i % 4 == 0) directions = {Vec3{1, 0, 0}, Vec3{0, 1, 0}, Vec3{0, 0, 1}, Vec3{0, -1, 0}};
        const unsigned count = 2 + static_cast<unsigned>(i % 3);
        std::array<Vec3, 16> normals{};
        for (unsigned s = 0; s < 16; ++s)
            normals[s] = i % 5 == 4 ? randomDirection(rng) : directions[rng() % count];
        blocks.emplace_back(normals, mask(i));
    }
    const auto encodeAll = [&] {
        std::vector<std::array<std::uint32_t, 4>> words(blocks.size());
        std::thread([&] {
            for (std::size_t i = 0; i < blocks.size(); ++i)
                words[i] =
                    vox::detail::encodeNormalBlock(blocks[i].first, blocks[i].second, effort);
        }).join();
        return words;
    };
    const auto wide = encodeAll();
    vox::detail::setEncoderAvx512(false);
    EXPECT_FALSE(vox::detail::encoderAvx512());
    const auto narrow = encodeAll();
    vox::detail::setEncoderAvx512(before);
    std::size_t differing = 0;
    for (std::size_t i = 0; i < blocks.size(); ++i) differing += wide[i] != narrow[i];
    EXPECT_EQ(differing, 0u) << "of " << blocks.size() << " blocks";
}
