// The .rvol radiance volume format (formats/src/rvol*.cpp, docs/rvol-format.md): Morton codes and
// the in-memory levels; the RGB9E5, A8, sRGB8 and octahedral encodings; round trips of synthetic
// volumes; the node-centred brick geometry with shared faces; sampling equal to trilinear
// interpolation of the in-memory level; deterministic output; corrupted files rejected with
// InvalidDataError and never a crash.
#include <vox/formats/checksum.h>
#include <vox/base/error.h>
#include <vox/formats/rvol.h>
#include <vox/formats/rvol_io.h>

#include "test_support.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <random>
#include <set>
#include <thread>
#include <tuple>
#include <vector>

namespace fs = std::filesystem;
namespace rvol = vox::rvol;
using vox::test::ScratchDir;

// The tests below were laid out for bricks of 4 texels (the writer's default is 5).
const vox::rvol::RvolWriteOptions kFourTexels{4, true};

namespace {

template <typename T>
T load(const std::uint8_t* p) {
    T v;
    std::memcpy(&v, p, sizeof v);
    return v;
}
template <typename T>
void store(std::uint8_t* p, T v) {
    std::memcpy(p, &v, sizeof v);
}

std::vector<std::uint8_t> readBytes(const fs::path& file) {
    std::ifstream in(file, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// A texel whose every component RGB9E5 and A8 store exactly (mantissa · 2^(e − 24), k/255), or
/// zero with probability @p zeroChance.
rvol::Texel representableTexel(std::mt19937& rng, double zeroChance = 0.3) {
    if (std::uniform_real_distribution<double>(0, 1)(rng) < zeroChance) return {};
    std::uniform_int_distribution<int> mantissa(0, 511), exponent(8, 22), alpha(0, 255);
    const int e = exponent(rng) - 24;
    return {std::ldexp(static_cast<float>(mantissa(rng)), e),
            std::ldexp(static_cast<float>(mantissa(rng)), e),
            std::ldexp(static_cast<float>(mantissa(rng)), e),
            static_cast<float>(alpha(rng)) / 255.0f};
}

/// Any texel: RGB in [0, 40), alpha in [0, 1].
rvol::Texel anyTexel(std::mt19937& rng, double zeroChance = 0.3) {
    if (std::uniform_real_distribution<double>(0, 1)(rng) < zeroChance) return {};
    std::uniform_real_distribution<float> rgb(0, 40), alpha(0, 1);
    return {rgb(rng), rgb(rng), rgb(rng), alpha(rng)};
}

/// A volume of @p depth with random sparse blocks (each present with @p blockChance, each of its
/// cells inside the level non-zero at random, at least one per block), and random static and
/// dynamic voxels. As in a baked volume, the ± channels of an axis have the same opacity (the
/// format stores it once per axis).
rvol::Volume makeVolume(std::uint32_t depth, std::uint32_t seed, bool representable = true,
                        double blockChance = 0.35) {
    std::mt19937 rng(seed);
    rvol::Volume v;
    v.depth = depth;
    v.origin = {-1.5, 0.25, 2.0};
    v.size = 3.0;
    v.sceneBounds = {-1.4f, 0.3f, 2.1f, 1.2f, 3.0f, 4.5f};
    v.bake = {2, 3.5f, 8.0f, 1, 7};
    for (std::uint32_t l = 0; l <= depth; ++l) {
        rvol::Level level;
        level.resolution = 1u << (depth - l);
        level.channels = l == 0 ? 1 : rvol::kDirections;
        const std::uint32_t blocksPerAxis =
            (level.resolution + rvol::kBlockCells - 1) / rvol::kBlockCells;
        std::vector<std::uint64_t> codes;
        for (std::uint32_t z = 0; z < blocksPerAxis; ++z)
            for (std::uint32_t y = 0; y < blocksPerAxis; ++y)
                for (std::uint32_t x = 0; x < blocksPerAxis; ++x)
                    if (blocksPerAxis == 1 ||
                        std::uniform_real_distribution<double>(0, 1)(rng) < blockChance)
                        codes.push_back(rvol::morton3(x, y, z));
        std::sort(codes.begin(), codes.end());
        level.blocks = codes;
        level.texels.assign(codes.size() * level.channels * rvol::kBlockTexels, rvol::Texel{});
        for (std::size_t b = 0; b < codes.size(); ++b) {
            const auto block = rvol::demorton3(codes[b]);
            bool any = false;
            for (std::uint32_t i = 0; i < rvol::kBlockTexels; ++i) {
                const std::uint32_t x = block[0] * 8 + i % 8, y = block[1] * 8 + i / 8 % 8,
                                    z = block[2] * 8 + i / 64;
                if (x >= level.resolution || y >= level.resolution || z >= level.resolution)
                    continue;  // stays zero
                for (std::uint32_t c = 0; c < level.channels; ++c) {
                    rvol::Texel t = representable ? representableTexel(rng) : anyTexel(rng);
                    if (!any && i == 0 && c == 0 && t == rvol::Texel{})
                        t = {0.5f, 0.25f, 1.0f, 1.0f};  // no empty block
                    if (c % 2 == 1)
                        t.a =
                            level.texels[rvol::Level::texelIndex(b, level.channels, c - 1, x, y, z)]
                                .a;  // NegX = PosX …
                    any = any || t != rvol::Texel{};
                    level.texels[rvol::Level::texelIndex(b, level.channels, c, x, y, z)] = t;
                }
            }
        }
        v.levels.push_back(std::move(level));
    }
    const std::uint32_t res = 1u << depth;
    for (auto* voxels : {&v.staticVoxels, &v.dynamicVoxels}) {
        std::set<std::uint64_t> used;
        std::uniform_int_distribution<std::uint32_t> cell(0, res - 1);
        std::uniform_real_distribution<float> unit(0, 1), signedUnit(-1, 1), emission(0, 20);
        for (int i = 0; i < (voxels == &v.staticVoxels ? 60 : 25); ++i)
            used.insert(rvol::morton3(cell(rng), cell(rng), cell(rng)));
        for (std::uint64_t code : used) {
            rvol::VoxelAttributes a;
            const auto c = rvol::demorton3(code);
            a.x = c[0], a.y = c[1], a.z = c[2];
            a.albedo = {unit(rng), unit(rng), unit(rng)};
            a.coverage = unit(rng);
            std::array<float, 3> n{signedUnit(rng), signedUnit(rng), signedUnit(rng)};
            const float len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
            a.normal = len > 0.01f ? std::array<float, 3>{n[0] / len, n[1] / len, n[2] / len}
                                   : std::array<float, 3>{0, 0, 1};
            a.emission = code % 3 == 0
                             ? std::array<float, 3>{emission(rng), emission(rng), emission(rng)}
                             : std::array<float, 3>{0, 0, 0};
            a.occlusion = unit(rng);
            voxels->push_back(a);
        }
    }
    return v;
}

/// Trilinear interpolation of @p channel of @p level at world @p p, straight from the in-memory
/// level: the reference that RvolReader::sample must reproduce.
rvol::Texel trilinear(const rvol::Volume& v, std::uint32_t l, std::uint32_t channel,
                      const std::array<double, 3>& p) {
    const rvol::Level& level = v.levels[l];
    std::array<std::uint32_t, 3> i0{};
    std::array<double, 3> f{};
    for (int a = 0; a < 3; ++a) {
        const double u = std::clamp((p[a] - v.origin[a]) / v.cellSize(l) - 0.5, 0.0,
                                    double(level.resolution - 1));
        i0[a] = level.resolution == 1
                    ? 0
                    : std::min(static_cast<std::uint32_t>(u), level.resolution - 2);
        f[a] = u - i0[a];
    }
    double sum[4] = {0, 0, 0, 0};
    for (std::uint32_t corner = 0; corner < 8; ++corner) {
        const std::uint32_t d[3] = {corner & 1u, (corner >> 1) & 1u, (corner >> 2) & 1u};
        double w = 1;
        for (int a = 0; a < 3; ++a) w *= d[a] ? f[a] : 1 - f[a];
        if (w == 0) continue;
        const rvol::Texel t = level.at(i0[0] + d[0], i0[1] + d[1], i0[2] + d[2], channel);
        sum[0] += w * t.r, sum[1] += w * t.g, sum[2] += w * t.b, sum[3] += w * t.a;
    }
    return {float(sum[0]), float(sum[1]), float(sum[2]), float(sum[3])};
}

/// The largest error RGB9E5 may make on (r, g, b): half a mantissa step of the shared exponent
/// (at most max/511.5, or 2^-25 near zero), plus float rounding.
float rgb9e5Tolerance(const rvol::Texel& t) {
    const float m = std::max({t.r, t.g, t.b});
    return std::max(m / 511.5f, 0x1p-25f) * 1.0001f;
}

void expectTexelNear(const rvol::Texel& got, const rvol::Texel& want, float rgbTolerance,
                     float alphaTolerance, const std::string& what) {
    EXPECT_NEAR(got.r, want.r, rgbTolerance) << what;
    EXPECT_NEAR(got.g, want.g, rgbTolerance) << what;
    EXPECT_NEAR(got.b, want.b, rgbTolerance) << what;
    EXPECT_NEAR(got.a, want.a, alphaTolerance) << what;
}

enum class Outcome { Valid, Invalid };

/// Opens, validates and reads all of @p file. InvalidDataError must name the file; any other
/// exception type fails the test (it propagates).
Outcome openAndValidate(const fs::path& file) {
    try {
        const rvol::RvolReader reader(file);
        (void)rvol::validateRvol(reader);
        return Outcome::Valid;
    } catch (const vox::InvalidDataError& e) {
        EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
        EXPECT_EQ(e.exitCode(), vox::ExitCode::InvalidData);
        return Outcome::Invalid;
    }
}

/// Recomputes every checksum of a file (bricks, directory, level table, attribute layers,
/// header) from its header's offsets, so that only structural checks can catch an edit. Parts
/// the (possibly edited) header places outside the file are left alone.
void fixChecksums(std::vector<std::uint8_t>& bytes) {
    std::uint8_t* h = bytes.data();
    const auto inside = [&](std::uint64_t offset, std::uint64_t size) {
        return offset <= bytes.size() && size <= bytes.size() - offset;
    };
    const auto crcAt = [&](std::size_t field, std::uint64_t offset, std::uint64_t size) {
        if (inside(offset, size)) store<std::uint32_t>(h + field, vox::crc32c(h + offset, size));
    };
    const auto levelCount = load<std::uint32_t>(h + 16);
    const auto n = load<std::uint32_t>(h + 20);
    const auto directoryOffset = load<std::uint64_t>(h + 160);
    const auto directoryBytes = load<std::uint64_t>(h + 168);
    if (levelCount <= 11 && n <= rvol::kMaxBrickTexels && inside(directoryOffset, directoryBytes))
        for (std::uint32_t l = 0; l < levelCount; ++l) {
            const std::uint8_t* e = h + 256 + 32 * l;
            const auto channels = load<std::uint32_t>(e + 4), count = load<std::uint32_t>(e + 16),
                       first = load<std::uint32_t>(e + 20);
            std::uint64_t offset = load<std::uint64_t>(e + 24);
            if (channels > 6) continue;
            for (std::uint32_t i = 0; i < count; ++i) {
                const std::uint64_t entry = directoryOffset + 16 * (std::uint64_t{first} + i);
                if (!inside(entry, 16)) break;
                // The brick's stored size from its entry's plane bits and texel count.
                const std::uint32_t planes = load<std::uint16_t>(h + entry + 6),
                                    rgb = planes & ((1u << channels) - 1);
                const std::uint64_t size = rvol::storedBrickBytes(
                    n, static_cast<std::uint32_t>(std::popcount(rgb)),
                    static_cast<std::uint32_t>(std::popcount(planes >> channels)),
                    load<std::uint32_t>(h + entry + 8));
                crcAt(entry + 12, offset, size);
                offset += size;
            }
        }
    if (levelCount <= 11) crcAt(152, 256, 32 * levelCount);
    crcAt(156, directoryOffset, directoryBytes);
    crcAt(224, load<std::uint64_t>(h + 192), load<std::uint64_t>(h + 200));
    crcAt(228, load<std::uint64_t>(h + 208), load<std::uint64_t>(h + 216));
    crcAt(252, 0, 252);
}

/// @p bytes (a valid file read by @p reader) with brick @p index of @p level replaced by
/// @p brick, laid out again (every later brick, level and section moved, offsets and checksums
/// made right): a file whose only fault is in that brick's texels.
std::vector<std::uint8_t> withBrick(const std::vector<std::uint8_t>& bytes,
                                    const rvol::RvolReader& reader, std::uint32_t level,
                                    std::uint32_t index, const rvol::PackedBrick& brick) {
    const rvol::Header& h = reader.header();
    std::vector<std::uint8_t> out(bytes.begin(),
                                  bytes.begin() + static_cast<std::ptrdiff_t>(h.brickDataOffset));
    for (std::uint32_t l = 0; l < h.levelCount; ++l) {
        out.resize(rvol::alignSection(out.size()), 0);
        store<std::uint64_t>(out.data() + 256 + 32 * l + 24, out.size());
        for (std::uint32_t i = 0; i < reader.level(l).brickCount; ++i) {
            std::vector<std::uint8_t> stored = reader.readStoredBrick(l, i);
            if (l == level && i == index) {
                stored = brick.bytes;
                const std::uint64_t entry =
                    h.directoryOffset + 16 * (reader.level(l).firstBrick + i);
                store<std::uint16_t>(out.data() + entry + 6, brick.planes);
                store<std::uint32_t>(out.data() + entry + 8, brick.texels);
            }
            out.insert(out.end(), stored.begin(), stored.end());
        }
    }
    const std::uint64_t dataEnd = out.size();
    store<std::uint64_t>(out.data() + 184, dataEnd - h.brickDataOffset);
    out.resize(rvol::alignSection(out.size()), 0);
    store<std::uint64_t>(out.data() + 192, out.size());
    out.insert(out.end(), bytes.begin() + static_cast<std::ptrdiff_t>(h.staticAttributesOffset),
               bytes.begin() +
                   static_cast<std::ptrdiff_t>(h.staticAttributesOffset + h.staticAttributesBytes));
    out.resize(rvol::alignSection(out.size()), 0);
    store<std::uint64_t>(out.data() + 208, out.size());
    out.insert(out.end(), bytes.begin() + static_cast<std::ptrdiff_t>(h.dynamicAttributesOffset),
               bytes.end());
    store<std::uint64_t>(out.data() + 232, out.size());
    fixChecksums(out);
    return out;
}

/// withBrick with brick @p index of @p level's dense planes edited by @p edit, then packed.
template <typename Edit>
std::vector<std::uint8_t> withEditedBrick(const std::vector<std::uint8_t>& bytes,
                                          const rvol::RvolReader& reader, std::uint32_t level,
                                          std::uint32_t index, Edit&& edit) {
    std::vector<std::uint8_t> dense = reader.readBrickBytes(level, index);
    edit(dense);
    return withBrick(
        bytes, reader, level, index,
        rvol::packBrick(dense, reader.header().brickTexels, reader.level(level).channels,
                        reader.header().binaryLevel0Opacity()));
}

}  // namespace

// ---- model ------------------------------------------------------------------------------------

TEST(Rvol, MortonCodesInterleaveXFirst) {
    EXPECT_EQ(rvol::morton3(1, 0, 0), 1u);
    EXPECT_EQ(rvol::morton3(0, 1, 0), 2u);
    EXPECT_EQ(rvol::morton3(0, 0, 1), 4u);
    EXPECT_EQ(
        rvol::morton3(3, 5, 6),
        427u);  // x = 011, y = 101, z = 110: 0b110'101'011 (bit i of x, y, z at 3i, 3i+1, 3i+2)
    EXPECT_EQ(rvol::morton3(0x1FFFFF, 0x1FFFFF, 0x1FFFFF), (std::uint64_t{1} << 63) - 1);
    std::mt19937 rng(5);
    std::uniform_int_distribution<std::uint32_t> coord(0, 0x1FFFFF);
    for (int i = 0; i < 1000; ++i) {
        const std::uint32_t x = coord(rng), y = coord(rng), z = coord(rng);
        std::uint64_t expected = 0;
        for (int b = 0; b < 21; ++b)
            expected |= std::uint64_t{(x >> b) & 1u} << (3 * b) |
                        std::uint64_t{(y >> b) & 1u} << (3 * b + 1) |
                        std::uint64_t{(z >> b) & 1u} << (3 * b + 2);
        ASSERT_EQ(rvol::morton3(x, y, z), expected);
        ASSERT_EQ(rvol::demorton3(expected), (std::array<std::uint32_t, 3>{x, y, z}));
    }
}

TEST(Rvol, LevelFindsBlocksAndCells) {
    rvol::Level level;
    level.resolution = 32;
    level.channels = 2;
    level.blocks = {rvol::morton3(0, 0, 0), rvol::morton3(1, 2, 0), rvol::morton3(3, 3, 3)};
    std::sort(level.blocks.begin(), level.blocks.end());
    level.texels.assign(level.blocks.size() * 2 * rvol::kBlockTexels, {});
    const std::int64_t b = level.findBlock(9, 17, 5);
    ASSERT_GE(b, 0);
    EXPECT_EQ(level.blocks[static_cast<std::size_t>(b)], rvol::morton3(1, 2, 0));
    level.texels[rvol::Level::texelIndex(static_cast<std::size_t>(b), 2, 1, 9, 17, 5)] = {1, 2, 3,
                                                                                          0.5f};
    EXPECT_EQ(level.at(9, 17, 5, 1), (rvol::Texel{1, 2, 3, 0.5f}));
    EXPECT_EQ(level.at(9, 17, 5, 0), rvol::Texel{});
    EXPECT_EQ(level.at(10, 17, 5, 1), rvol::Texel{});
    EXPECT_EQ(level.findBlock(8, 0, 0), -1);          // block (1,0,0) absent
    EXPECT_EQ(level.findBlock(31, 31, 31), 2);        // block (3,3,3)
    EXPECT_EQ(level.findBlock(32, 0, 0), -1);         // outside the level
    EXPECT_EQ(level.at(9, 17, 5, 2), rvol::Texel{});  // no such channel
}

// ---- encodings --------------------------------------------------------------------------------

TEST(Rvol, Rgb9e5FollowsOpenGl) {
    const auto word = [](std::uint32_t r, std::uint32_t g, std::uint32_t b, std::uint32_t e) {
        return r | g << 9 | b << 18 | e << 27;
    };
    EXPECT_EQ(rvol::encodeRgb9e5(0, 0, 0), 0u);
    EXPECT_EQ(rvol::decodeRgb9e5(0), (std::array<float, 3>{0, 0, 0}));
    // 1.0: ⌊log2 1⌋ = 0, exponent 16, mantissa 1 · 2^(24 − 16) = 256.
    EXPECT_EQ(rvol::encodeRgb9e5(1, 1, 1), word(256, 256, 256, 16));
    EXPECT_EQ(rvol::decodeRgb9e5(word(256, 256, 256, 16)), (std::array<float, 3>{1, 1, 1}));
    // The largest value, 511 · 2^7, and everything above it (infinity too) clamps to it.
    EXPECT_EQ(rvol::encodeRgb9e5(65408, 0, 0), word(511, 0, 0, 31));
    EXPECT_EQ(rvol::encodeRgb9e5(1e9f, INFINITY, 65408), word(511, 511, 511, 31));
    EXPECT_EQ(rvol::decodeRgb9e5(word(511, 0, 0, 31))[0], 65408.0f);
    EXPECT_EQ(rvol::kRgb9e5Max, 65408.0f);
    // Negative and NaN are zero.
    EXPECT_EQ(rvol::encodeRgb9e5(-3, NAN, 0), 0u);
    // Tiny values: the smallest step is 2^-24 (exponent 0, mantissa 1); halves round up.
    EXPECT_EQ(rvol::encodeRgb9e5(0x1p-24f, 0, 0), word(1, 0, 0, 0));
    EXPECT_EQ(rvol::encodeRgb9e5(0x1p-25f, 0, 0), word(1, 0, 0, 0));
    EXPECT_EQ(rvol::encodeRgb9e5(0x1.fp-26f, 0, 0), 0u);
    EXPECT_EQ(rvol::encodeRgb9e5(0x1p-16f, 0, 0), word(256, 0, 0, 0));  // still exponent 0
    EXPECT_EQ(rvol::decodeRgb9e5(word(1, 0, 0, 0))[0], 0x1p-24f);
    // Rounding to nearest: 1 + 2^-9 is half a step (2^-8) above 1 and rounds up; 1 + 2^-10 rounds
    // down.
    EXPECT_EQ(rvol::encodeRgb9e5(1 + 0x1p-9f, 0, 0), word(257, 0, 0, 16));
    EXPECT_EQ(rvol::encodeRgb9e5(1 + 0x1p-10f, 0, 0), word(256, 0, 0, 16));
    // A maximum that rounds up to 2^9 moves to the next exponent: 511.5/256 → 2.0.
    EXPECT_EQ(rvol::encodeRgb9e5(511.5f / 256, 0, 0), word(256, 0, 0, 17));
    // Shared exponent: smaller channels lose precision relative to the largest.
    EXPECT_EQ(rvol::encodeRgb9e5(4, 1, 0.5f), word(256, 64, 32, 18));
    EXPECT_EQ(rvol::encodeRgb9e5(1, 0.001f, 0), word(256, 0, 0, 16));  // 0.001 · 256 = 0.256 → 0
    EXPECT_EQ(rvol::encodeRgb9e5(1, 0.003f, 0), word(256, 1, 0, 16));  // 0.768 → 1

    std::mt19937 rng(11);
    std::uniform_real_distribution<float> value(0, 1000);
    std::uniform_int_distribution<std::uint32_t> any;
    for (int i = 0; i < 20000; ++i) {
        // Error at most half a step of the chosen exponent.
        const float r = value(rng), g = value(rng) * 0.01f, b = std::ldexp(value(rng), -20);
        const std::uint32_t w = rvol::encodeRgb9e5(r, g, b);
        const float halfStep = std::ldexp(0.5f, static_cast<int>(w >> 27) - 24);
        const auto d = rvol::decodeRgb9e5(w);
        ASSERT_LE(std::abs(d[0] - r), halfStep) << r;
        ASSERT_LE(std::abs(d[1] - g), halfStep) << g;
        ASSERT_LE(std::abs(d[2] - b), halfStep) << b;
        // Relative to the largest channel: at most max/511.5 (a maximum of 511.5 steps rounds up
        // to the next exponent, whose half step is 1/511.5 of it).
        const float m = std::max({r, g, b});
        ASSERT_LE(std::abs(d[0] - r), m / 511.5f);
        ASSERT_LE(std::abs(d[1] - g), m / 511.5f);
        // Every decoded value encodes back to itself.
        const auto e = rvol::decodeRgb9e5(any(rng));
        ASSERT_EQ(rvol::decodeRgb9e5(rvol::encodeRgb9e5(e[0], e[1], e[2])), e);
    }
}

TEST(Rvol, Unorm8AndSrgb8) {
    EXPECT_EQ(rvol::encodeUnorm8(0), 0);
    EXPECT_EQ(rvol::encodeUnorm8(1), 255);
    EXPECT_EQ(rvol::encodeUnorm8(0.5f), 128);  // 127.5 rounds up
    EXPECT_EQ(rvol::encodeUnorm8(0.2f), 51);
    EXPECT_EQ(rvol::encodeUnorm8(2), 255);
    EXPECT_EQ(rvol::encodeUnorm8(-1), 0);
    EXPECT_EQ(rvol::encodeUnorm8(NAN), 0);
    for (int k = 0; k < 256; ++k)
        EXPECT_EQ(rvol::encodeUnorm8(rvol::decodeUnorm8(static_cast<std::uint8_t>(k))), k);

    EXPECT_EQ(rvol::encodeSrgb8(0), 0);
    EXPECT_EQ(rvol::encodeSrgb8(1), 255);
    EXPECT_EQ(rvol::encodeSrgb8(0.5f), 188);  // 1.055 · 0.5^(1/2.4) − 0.055 = 0.7354
    EXPECT_EQ(rvol::encodeSrgb8(0.002f), 7);  // linear segment: 12.92 · 0.002 · 255 = 6.59
    EXPECT_NEAR(rvol::decodeSrgb8(188), 0.5029f, 1e-4f);
    EXPECT_NEAR(rvol::decodeSrgb8(10), 10 / 255.0f / 12.92f, 1e-7f);
    for (int k = 0; k < 256; ++k)
        EXPECT_EQ(rvol::encodeSrgb8(rvol::decodeSrgb8(static_cast<std::uint8_t>(k))), k) << k;
}

TEST(Rvol, OctahedralNormals) {
    // Axes are exact; q = round(2047·c) + 2048.
    EXPECT_EQ(rvol::encodeOctahedral({0, 0, 1}), 2048u | 2048u << 12);
    EXPECT_EQ(rvol::encodeOctahedral({1, 0, 0}), 4095u | 2048u << 12);
    EXPECT_EQ(rvol::encodeOctahedral({0, -1, 0}), 2048u | 1u << 12);
    EXPECT_EQ(rvol::encodeOctahedral({0, 0, -1}),
              4095u | 4095u << 12);  // folded to the corner (1, 1)
    EXPECT_EQ(rvol::encodeOctahedral({0, 0, 0}), 2048u | 2048u << 12);  // degenerate: +z
    for (const std::array<float, 3>& axis :
         {std::array<float, 3>{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}})
        EXPECT_EQ(rvol::decodeOctahedral(rvol::encodeOctahedral(axis)), axis);
    // Bits 24–31 are ignored (the occlusion byte shares the word).
    EXPECT_EQ(rvol::decodeOctahedral(0xAB000000u | rvol::encodeOctahedral({0, 1, 0})),
              (std::array<float, 3>{0, 1, 0}));

    std::mt19937 rng(3);
    std::normal_distribution<float> gauss;
    double worst = 0;
    for (int i = 0; i < 100000; ++i) {
        std::array<float, 3> n{gauss(rng), gauss(rng), gauss(rng)};
        const float len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        for (float& c : n) c /= len;
        const auto d = rvol::decodeOctahedral(rvol::encodeOctahedral(n));
        ASSERT_NEAR(d[0] * d[0] + d[1] * d[1] + d[2] * d[2], 1.0f, 1e-5f);
        const double dot =
            std::min(1.0, double(d[0]) * n[0] + double(d[1]) * n[1] + double(d[2]) * n[2]);
        worst = std::max(worst, std::acos(dot));
    }
    std::printf("octahedral 12+12: worst angular error %.4f degrees\n",
                worst * 180 / 3.14159265358979);
    EXPECT_LT(worst * 180 / 3.14159265358979, 0.08);
}

// ---- brick geometry ---------------------------------------------------------------------------

TEST(Rvol, BricksShareFacesAndEmptyOnesAreNotStored) {
    // Depth 3: level 0 has 8 cells per axis, 4-texel bricks step 3 cells: brick b holds cells
    // 3b … 3b + 3, so 3 bricks per axis, the last holding cells 6, 7 and two zero texels.
    ScratchDir dir;
    rvol::Volume v = makeVolume(3, 1);
    for (rvol::Level& level : v.levels) level.blocks.clear(), level.texels.clear();
    rvol::Level& l0 = v.levels[0];
    l0.blocks = {0};
    l0.texels.assign(rvol::kBlockTexels, {});
    const rvol::Texel a{0.5f, 1.0f, 2.0f, 128 / 255.0f}, b{3.0f, 0.0f, 0.25f, 1.0f};
    l0.texels[rvol::Level::texelIndex(0, 1, 0, 3, 0, 0)] =
        a;  // on the face shared by bricks 0 and 1
    l0.texels[rvol::Level::texelIndex(0, 1, 0, 7, 7, 7)] = b;  // inside the last brick only
    const rvol::RvolWriteResult result = rvol::writeRvol(dir / "v.rvol", v, kFourTexels);
    EXPECT_EQ(result.bricks, 3u);
    EXPECT_EQ(result.bricksPerLevel, (std::vector<std::uint64_t>{3, 0, 0, 0}));

    const rvol::RvolReader reader(dir / "v.rvol");
    const rvol::LevelEntry& e = reader.level(0);
    EXPECT_EQ(e.resolution, 8u);
    EXPECT_EQ(e.bricksPerAxis, 3u);
    EXPECT_EQ(e.denseBrickBytes, 320u);  // 64 texels × (4 + 1) bytes
    const auto bricks = reader.bricks(0);
    ASSERT_EQ(bricks.size(), 3u);
    // Morton order: (0,0,0) = 0, (1,0,0) = 1, (2,2,2) = 56.
    EXPECT_EQ(bricks[0].morton(), 0u);
    EXPECT_EQ(bricks[1].morton(), 1u);
    EXPECT_EQ(bricks[2].morton(), 56u);
    EXPECT_EQ(reader.findBrick(0, 2, 2, 2), 2);
    EXPECT_EQ(reader.findBrick(0, 0, 1, 0), -1);
    // Bricks 0 and 1 hold one texel each: an 8-byte mask, a word, an opacity padded to 4.
    EXPECT_EQ(reader.bricks(0)[0].texels, 1u);
    EXPECT_EQ(reader.bricks(0)[0].planes, 0b11u);
    EXPECT_EQ(reader.storedBrickSize(0, 0), 16u);
    EXPECT_EQ(reader.brickOffset(0, 2), e.dataOffset + 32);
    EXPECT_EQ(e.dataOffset % 64, 0u);

    const auto texelAt = [](std::uint32_t i, std::uint32_t j, std::uint32_t k) {
        return (k * 4 + j) * 4 + i;
    };
    const std::vector<rvol::Texel> b0 = reader.readBrick(0, 0), b1 = reader.readBrick(0, 1),
                                   b2 = reader.readBrick(0, 2);
    for (std::uint32_t t = 0; t < 64; ++t) {
        EXPECT_EQ(b0[t], t == texelAt(3, 0, 0) ? a : rvol::Texel{})
            << t;  // cell 3 is brick 0's last texel …
        EXPECT_EQ(b1[t], t == texelAt(0, 0, 0) ? a : rvol::Texel{}) << t;  // … and brick 1's first
        EXPECT_EQ(b2[t], t == texelAt(1, 1, 1) ? b : rvol::Texel{}) << t;  // cell 7 = 6 + 1
    }
    // Stored: the occupancy mask (texel 3), the texel's word, its opacity, zero padding.
    const std::vector<std::uint8_t> stored = reader.readStoredBrick(0, 0);
    EXPECT_EQ(rvol::encodeRgb9e5(0.5f, 1.0f, 2.0f), 0x8C010040u);
    EXPECT_EQ(stored, (std::vector<std::uint8_t>{0x08, 0, 0, 0, 0, 0, 0, 0, 0x40, 0x00, 0x01, 0x8C,
                                                 128, 0, 0, 0}));
    // Expanded: per channel the RGB9E5 plane, then the A8 plane.
    const std::vector<std::uint8_t> raw = reader.readBrickBytes(0, 0);
    ASSERT_EQ(raw.size(), 320u);
    EXPECT_EQ(load<std::uint32_t>(raw.data() + 4 * texelAt(3, 0, 0)),
              rvol::encodeRgb9e5(0.5f, 1.0f, 2.0f));
    EXPECT_EQ(raw[256 + texelAt(3, 0, 0)], 128);
    std::vector<std::uint8_t> rest = raw;  // everything else is zero
    std::fill_n(rest.begin() + 4 * texelAt(3, 0, 0), 4, 0);
    rest[256 + texelAt(3, 0, 0)] = 0;
    EXPECT_TRUE(std::all_of(rest.begin(), rest.end(), [](std::uint8_t byte) { return byte == 0; }));

    // Sampling across the shared face is continuous, and the cell centre gives the texel.
    const double cell = v.cellSize(0);
    const auto world = [&](double ux, double uy, double uz) {
        return std::array<double, 3>{v.origin[0] + (ux + 0.5) * cell,
                                     v.origin[1] + (uy + 0.5) * cell,
                                     v.origin[2] + (uz + 0.5) * cell};
    };
    EXPECT_EQ(reader.sample(0, 0, world(3, 0, 0)), a);
    const rvol::Texel left = reader.sample(0, 0, world(3 - 1e-9, 0, 0)),
                      right = reader.sample(0, 0, world(3 + 1e-9, 0, 0));
    EXPECT_NEAR(left.r, a.r, 1e-6);
    EXPECT_NEAR(right.r, a.r, 1e-6);
    const rvol::Texel half =
        reader.sample(0, 0, world(3.5, 0, 0));  // halfway to the zero cell 4, in brick 1
    EXPECT_NEAR(half.g, 0.5f, 1e-6);
    EXPECT_NEAR(reader.sample(0, 0, world(2.75, 0, 0)).b, 1.5f,
                1e-6);  // brick 0, 3/4 of the way to cell 3
    EXPECT_EQ(reader.sample(0, 0, world(0, 4, 0)), rvol::Texel{});  // brick (0,1,0) not stored
    // Outside the cube: clamped to the edge cells.
    EXPECT_EQ(reader.sample(0, 0, world(100, 100, 100)), b);
    EXPECT_EQ(reader.sample(0, 0, world(3, -50, -50)), a);
    EXPECT_EQ(rvol::validateRvol(reader).nonZeroTexelsPerLevel,
              (std::vector<std::uint64_t>{2, 0, 0, 0}));
}

TEST(Rvol, PackedBricksRoundTripAndStoreOnlyOccupiedTexelsOfNonZeroPlanes) {
    // packBrick keeps the texels with a non-zero byte in some plane (the occupancy mask) of the
    // planes with a non-zero byte; expandBrick gives the dense planes back exactly.
    std::mt19937 rng(77);
    for (std::uint32_t n : {2u, 3u, 4u, 5u, 8u})
        for (std::uint32_t channels : {1u, 6u})
            for (bool binary : {false, true}) {
                SCOPED_TRACE(std::to_string(n) + " texels, " + std::to_string(channels) +
                             " channels, binary " + std::to_string(binary));
                const std::uint32_t n3 = n * n * n, alpha = rvol::alphaPlanes(channels, binary),
                                    planes = channels + alpha;
                for (int trial = 0; trial < 40; ++trial) {
                    std::vector<std::uint8_t> dense(rvol::brickBytes(n, channels, binary), 0);
                    // Sparse texels, some planes left all zero.
                    const double fill = std::uniform_real_distribution<double>(0, 0.6)(rng);
                    std::uint32_t usedPlanes =
                        std::uniform_int_distribution<std::uint32_t>(0, (1u << planes) - 1)(rng);
                    if (trial == 0) usedPlanes = 0;  // an all-zero brick
                    std::vector<bool> occupied(n3, false);
                    std::uint16_t wantPlanes = 0;
                    for (std::uint32_t t = 0; t < n3; ++t) {
                        if (std::uniform_real_distribution<double>(0, 1)(rng) >= fill) continue;
                        for (std::uint32_t p = 0; p < planes; ++p) {
                            if ((usedPlanes & 1u << p) == 0 || rng() % 2) continue;
                            const std::uint32_t value = rng() | 1u << (rng() % 8);  // not zero
                            if (p < channels)
                                store<std::uint32_t>(
                                    dense.data() + rvol::rgbPlaneOffset(n, p) + 4 * t, value);
                            else
                                dense[rvol::alphaPlaneOffset(n, channels, p - channels) + t] =
                                    static_cast<std::uint8_t>(value | 1);
                            occupied[t] = true;
                            wantPlanes = static_cast<std::uint16_t>(wantPlanes | 1u << p);
                        }
                    }
                    const auto wantTexels = static_cast<std::uint32_t>(
                        std::count(occupied.begin(), occupied.end(), true));
                    const rvol::PackedBrick packed = rvol::packBrick(dense, n, channels, binary);
                    EXPECT_EQ(packed.planes, wantPlanes);
                    EXPECT_EQ(packed.texels, wantTexels);
                    if (wantTexels == 0) {
                        EXPECT_TRUE(packed.bytes.empty());
                        continue;
                    }
                    const auto rgb = static_cast<std::uint32_t>(
                                   std::popcount(wantPlanes & ((1u << channels) - 1u))),
                               a8 = static_cast<std::uint32_t>(std::popcount(
                                   static_cast<std::uint32_t>(wantPlanes) >> channels));
                    ASSERT_EQ(packed.bytes.size(), rvol::storedBrickBytes(n, rgb, a8, wantTexels));
                    EXPECT_EQ(packed.bytes.size() % 4, 0u);
                    // The mask: bit t of byte t/8 for each occupied texel.
                    for (std::uint32_t t = 0; t < n3; ++t)
                        EXPECT_EQ((packed.bytes[t / 8] >> (t % 8)) & 1u, occupied[t] ? 1u : 0u);
                    // The first stored plane's first value is the first occupied texel's.
                    const auto first = static_cast<std::uint32_t>(
                        std::find(occupied.begin(), occupied.end(), true) - occupied.begin());
                    const std::uint64_t mask = rvol::brickMaskBytes(n);
                    const std::uint32_t p0 =
                        static_cast<std::uint32_t>(std::countr_zero(unsigned{wantPlanes}));
                    if (p0 < channels)
                        EXPECT_EQ(load<std::uint32_t>(packed.bytes.data() + mask),
                                  load<std::uint32_t>(dense.data() + rvol::rgbPlaneOffset(n, p0) +
                                                      4 * first));
                    else
                        EXPECT_EQ(
                            packed.bytes[mask],
                            dense[rvol::alphaPlaneOffset(n, channels, p0 - channels) + first]);
                    EXPECT_EQ(rvol::expandBrick(packed.bytes, n, channels, binary, packed.planes,
                                                packed.texels),
                              dense);
                    // A wrong entry or mask is refused, never misread.
                    EXPECT_THROW((void)rvol::expandBrick(packed.bytes, n, channels, binary,
                                                         packed.planes, packed.texels + 1),
                                 std::invalid_argument);
                    EXPECT_THROW((void)rvol::expandBrick(packed.bytes, n, channels, binary,
                                                         static_cast<std::uint16_t>(1u << planes),
                                                         packed.texels),
                                 std::invalid_argument);
                    std::vector<std::uint8_t> flipped = packed.bytes;
                    const std::uint32_t t = rng() % n3;
                    flipped[t / 8] ^= static_cast<std::uint8_t>(1u << (t % 8));
                    EXPECT_THROW((void)rvol::expandBrick(flipped, n, channels, binary,
                                                         packed.planes, packed.texels),
                                 std::invalid_argument);
                    if (n3 % 32 != 0) {  // a mask bit past the brick's texels
                        flipped = packed.bytes;
                        flipped[n3 / 8] ^= static_cast<std::uint8_t>(1u << (n3 % 8));
                        flipped[first / 8] ^= static_cast<std::uint8_t>(1u << (first % 8));
                        EXPECT_THROW((void)rvol::expandBrick(flipped, n, channels, binary,
                                                             packed.planes, packed.texels),
                                     std::invalid_argument);
                    }
                }
            }
    EXPECT_EQ(rvol::brickMaskBytes(2), 4u);
    EXPECT_EQ(rvol::brickMaskBytes(4), 8u);
    EXPECT_EQ(rvol::brickMaskBytes(5), 16u);
    EXPECT_EQ(rvol::storedBrickBytes(5, 6, 3, 40), 16u + 6 * 4 * 40 + 120);
    EXPECT_EQ(rvol::storedBrickBytes(5, 1, 0, 26), 16u + 104);
    EXPECT_EQ(rvol::storedBrickBytes(4, 1, 1, 2), 8u + 8 + 4);
}

TEST(Rvol, WorkedExampleOfTheSpec) {
    // docs/rvol-format.md, "Worked example": the same volume gives the bytes the spec lists.
    ScratchDir dir;
    rvol::Volume v;
    v.depth = 1;
    v.size = 2;
    v.sceneBounds = {0.1f, 0.0f, 0.1f, 1.9f, 1.0f, 1.9f};
    v.bake = {2, 0, 8, 1, 1};
    rvol::Level l0{2, 1, {0}, std::vector<rvol::Texel>(rvol::kBlockTexels)};
    l0.texels[0] = {0.5f, 0, 0, 0.5f};
    l0.texels[1] = {0, 1, 0, 1};
    rvol::Level l1{1, 6, {0}, std::vector<rvol::Texel>(6 * rvol::kBlockTexels)};
    for (std::uint32_t c = 0; c < 6; ++c)
        l1.texels[rvol::Level::texelIndex(0, 6, c, 0, 0, 0)] = {0.125f, 0.25f, 0, 0.375f};
    l1.texels[rvol::Level::texelIndex(0, 6, 0, 0, 0, 0)] = {0.125f, 0.125f, 0, 0.25f};
    l1.texels[rvol::Level::texelIndex(0, 6, 1, 0, 0, 0)] = {0, 0.25f, 0, 0.25f};
    v.levels = {l0, l1};
    rvol::VoxelAttributes a;
    a.x = 1;
    a.albedo = {0.5f, 0.5f, 0.5f};
    a.coverage = 1;
    a.normal = {0, 1, 0};
    a.occlusion = 0.25f;
    v.staticVoxels = {a};
    EXPECT_EQ(rvol::writeRvol(dir / "ex.rvol", v, kFourTexels).fileBytes, 576u);
    const std::vector<std::uint8_t> b = readBytes(dir / "ex.rvol");
    ASSERT_EQ(b.size(), 576u);

    // The whole file, byte for byte, as the spec lists it (every byte not set here is zero).
    std::vector<std::uint8_t> want(576, 0);
    std::uint8_t* w = want.data();
    // Header.
    std::memcpy(w, "RVOL", 4);
    store<std::uint16_t>(w + 4, 4);  // version 4.1
    store<std::uint16_t>(w + 6, 1);
    store<std::uint32_t>(w + 8, 256);
    store<std::uint32_t>(w + 12, 1);  // depth
    store<std::uint32_t>(w + 16, 2);  // levels
    store<std::uint32_t>(w + 20, 4);  // N
    store<std::uint32_t>(w + 24, 2);  // texel format 2
    store<std::uint32_t>(w + 28, 1);  // flags: static layer written
    store<double>(w + 56, 2.0);       // size (origin 0)
    for (int i = 0; i < 6; ++i) store<float>(w + 64 + 4 * i, v.sceneBounds[i]);
    EXPECT_EQ(load<std::uint32_t>(w + 64), 0x3DCCCCCDu);  // 0.1f
    EXPECT_EQ(load<std::uint32_t>(w + 76), 0x3FF33333u);  // 1.9f
    store<std::uint32_t>(w + 88, 2);                      // bounces
    store<float>(w + 96, 8.0f);                           // λ (aperture 0)
    store<std::uint32_t>(w + 100, 1);                     // attenuation
    store<std::uint32_t>(w + 104, 1);                     // lights
    store<std::uint64_t>(w + 112, 2);                     // bricks
    store<std::uint64_t>(w + 120, 1);                     // static voxels (0 dynamic)
    store<std::uint64_t>(w + 136, 256);
    store<std::uint64_t>(w + 144, 64);
    store<std::uint32_t>(w + 152, 0xF2C01D53u);  // level table checksum
    store<std::uint32_t>(w + 156, 0x3BDFB28Eu);  // directory checksum
    store<std::uint64_t>(w + 160, 320);
    store<std::uint64_t>(w + 168, 32);
    store<std::uint64_t>(w + 176, 384);
    store<std::uint64_t>(w + 184, 100);
    store<std::uint64_t>(w + 192, 512);
    store<std::uint64_t>(w + 200, 16);
    store<std::uint64_t>(w + 208, 576);          // dynamic layer, 0 bytes
    store<std::uint32_t>(w + 224, 0x1F01AA95u);  // static layer checksum (dynamic: 0)
    store<std::uint64_t>(w + 232, 576);
    store<std::uint32_t>(w + 252, 0x80B68279u);  // header checksum
    // Level table: resolution, channels, bricks per axis, dense brick bytes, bricks, first entry,
    // data offset.
    for (const auto& [at, entry, offset] :
         {std::tuple{256, std::array<std::uint32_t, 6>{2, 1, 1, 320, 1, 0}, 384},
          std::tuple{288, std::array<std::uint32_t, 6>{1, 6, 1, 1728, 1, 1}, 448}}) {
        for (int i = 0; i < 6; ++i) store<std::uint32_t>(w + at + 4 * i, entry[i]);
        store<std::uint64_t>(w + at + 24, static_cast<std::uint64_t>(offset));
    }
    // Directory: bricks (0,0,0) of both levels: plane bits, texels, checksum.
    store<std::uint16_t>(w + 320 + 6, 0b11);  // RGB9E5 and A8 planes
    store<std::uint32_t>(w + 320 + 8, 2);
    store<std::uint32_t>(w + 320 + 12, 0xF256514Bu);
    store<std::uint16_t>(w + 336 + 6, 0x1FF);  // six RGB9E5 and three A8 planes
    store<std::uint32_t>(w + 336 + 8, 1);
    store<std::uint32_t>(w + 336 + 12, 0x4A31860Au);
    // Level 0's brick (20 bytes): the 8-byte mask (texels 0 and 1), their words, their opacities
    // and two bytes of padding.
    w[384] = 0b11;
    store<std::uint32_t>(w + 392, 0x78000100u);  // red (0.5, 0, 0)
    store<std::uint32_t>(w + 396, 0x80020000u);  // green (0, 1, 0)
    w[400] = 128;
    w[401] = 255;
    // Level 1's brick (36 bytes): the mask (texel 0), the word of PosX … NegZ, the opacities of
    // the x, y and z axes and one byte of padding.
    w[448] = 1;
    for (std::uint32_t c = 0; c < 6; ++c)
        store<std::uint32_t>(w + 456 + 4 * c, c == 0   ? 0x68020100u
                                              : c == 1 ? 0x70020000u
                                                       : 0x70020080u);
    w[480] = 64;
    w[481] = 96;
    w[482] = 96;
    // Static layer: Morton code 1, albedo sRGB 188 ×3 and coverage 255, normal +y with
    // occlusion 64.
    store<std::uint32_t>(w + 512, 1);
    store<std::uint32_t>(w + 516, 0xFFBCBCBCu);
    store<std::uint32_t>(w + 520, 0x40FFF800u);
    const auto mismatch = std::mismatch(b.begin(), b.end(), want.begin());
    EXPECT_TRUE(mismatch.first == b.end())
        << "first difference at byte " << (mismatch.first - b.begin());

    const rvol::RvolReader reader(dir / "ex.rvol");
    EXPECT_EQ(rvol::validateRvol(reader).paddingBytes, 152u);
    const rvol::Texel t = reader.sample(0, 0, {1.0, 0.5, 0.5});
    EXPECT_FLOAT_EQ(t.g, 0.5f);
    EXPECT_FLOAT_EQ(t.a, (128 / 255.0f + 1) / 2);
    const rvol::Texel along = reader.sampleDirectional(1, {1, 1, 1}, {0.6, 0.8, 0});
    const rvol::Texel against = reader.sampleDirectional(1, {1, 1, 1}, {-0.6, 0.8, 0});
    EXPECT_NEAR(along.r, 0.122811f, 1e-6f);
    EXPECT_NEAR(along.g, 0.201410f, 1e-6f);
    EXPECT_NEAR(along.a, 0.325493f, 1e-6f);
    EXPECT_NEAR(against.r, 0.078599f, 1e-6f);  // NegX instead of PosX: other light …
    EXPECT_NEAR(against.g, 0.245622f, 1e-6f);
    EXPECT_EQ(against.a, along.a);  // … the same opacity
}

TEST(Rvol, OpacityIsStoredOncePerAxis) {
    // Front-to-back compositing's opacity a_f + (1 − a_f)·a_b is symmetric in front and back, so
    // the ± channels of an axis always have the same opacity: bricks of levels ≥ 1 hold six
    // RGB9E5 planes and three A8 planes (x, y, z), level 0's one RGB9E5 and one A8 plane.
    EXPECT_EQ(rvol::brickBytes(4, 6), 6u * 256 + 3 * 64);
    EXPECT_EQ(rvol::brickBytes(4, 6), 1728u);  // 1.x: 6 × 320 = 1920
    EXPECT_EQ(rvol::brickBytes(4, 1), 320u);   // unchanged
    EXPECT_EQ(rvol::brickBytes(5, 6),
              6u * 500 + 3 * 128);  // 125 opacities padded to 128; 1.x: 6 × 628 = 3768
    EXPECT_EQ(rvol::brickBytes(5, 1), 628u);
    EXPECT_EQ(rvol::brickBytes(3, 6), 6u * 108 + 3 * 28);
    EXPECT_EQ(rvol::alphaPlanes(1), 1u);
    EXPECT_EQ(rvol::alphaPlanes(6), 3u);
    // Binary level-0 opacity (3.0) drops level 0's A8 plane only.
    EXPECT_EQ(rvol::alphaPlanes(1, true), 0u);
    EXPECT_EQ(rvol::alphaPlanes(6, true), 3u);
    EXPECT_EQ(rvol::brickBytes(5, 1, true), 500u);
    EXPECT_EQ(rvol::brickBytes(4, 1, true), 256u);
    EXPECT_EQ(rvol::brickBytes(3, 1, true), 108u);
    EXPECT_EQ(rvol::brickBytes(5, 6, true), rvol::brickBytes(5, 6));
    EXPECT_EQ(rvol::alphaPlaneOf(static_cast<std::uint32_t>(rvol::Direction::NegX)), 0u);
    EXPECT_EQ(rvol::alphaPlaneOf(static_cast<std::uint32_t>(rvol::Direction::PosY)), 1u);
    EXPECT_EQ(rvol::alphaPlaneOf(static_cast<std::uint32_t>(rvol::Direction::NegZ)), 2u);
    EXPECT_EQ(rvol::alphaPlaneOffset(4, 6, 2), 6u * 256 + 2 * 64);

    ScratchDir dir;
    rvol::Volume v = makeVolume(2, 3);
    // Level 1 (2 cells per axis, one brick): cell (1,0,0) with a different radiance per channel
    // and one opacity per axis; cell (0,1,0) with PosX and NegX opacities that differ (no bake
    // makes that): stored as their mean.
    rvol::Level& l1 = v.levels[1];
    l1.blocks = {0};
    l1.texels.assign(6 * rvol::kBlockTexels, {});
    const float axisAlpha[3] = {51 / 255.0f, 153 / 255.0f, 1.0f};
    for (std::uint32_t c = 0; c < 6; ++c)
        l1.texels[rvol::Level::texelIndex(0, 6, c, 1, 0, 0)] = {float(c + 1), 0.5f * float(c),
                                                                0.25f, axisAlpha[c / 2]};
    l1.texels[rvol::Level::texelIndex(0, 6, 0, 0, 1, 0)] = {1, 0, 0, 0.2f};
    l1.texels[rvol::Level::texelIndex(0, 6, 1, 0, 1, 0)] = {0, 1, 0, 0.6f};
    const rvol::RvolWriteResult result = rvol::writeRvol(dir / "v.rvol", v, kFourTexels);
    const rvol::RvolReader reader(dir / "v.rvol");
    const rvol::LevelEntry& e = reader.level(1);
    EXPECT_EQ(e.channels, 6u);
    EXPECT_EQ(e.denseBrickBytes, 1728u);
    ASSERT_EQ(e.brickCount, 1u);
    EXPECT_EQ(reader.level(0).denseBrickBytes, 320u);
    EXPECT_EQ(result.radianceBytes,
              reader.level(0).dataBytes + reader.level(1).dataBytes + reader.level(2).dataBytes);
    EXPECT_EQ(reader.level(1).dataBytes, reader.storedBrickSize(1, 0));
    EXPECT_EQ(result.radianceBytes, rvol::validateRvol(reader).radianceBytes);

    // Expanded: RGB9E5 planes of PosX … NegZ at 256·c, then the x, y, z A8 planes at
    // 1536 + 64·p.
    const std::vector<std::uint8_t> raw = reader.readBrickBytes(1, 0);
    ASSERT_EQ(raw.size(), 1728u);
    const std::size_t t = 1, u = 4;  // texels (1,0,0) and (0,1,0)
    for (std::uint32_t c = 0; c < 6; ++c)
        EXPECT_EQ(load<std::uint32_t>(raw.data() + 256 * c + 4 * t),
                  rvol::encodeRgb9e5(float(c + 1), 0.5f * float(c), 0.25f))
            << c;
    for (std::uint32_t p = 0; p < 3; ++p)
        EXPECT_EQ(raw[1536 + 64 * p + t], rvol::encodeUnorm8(axisAlpha[p])) << p;
    EXPECT_EQ(raw[1536 + u], 102);  // (0.2 + 0.6)/2 = 0.4 → 102
    EXPECT_EQ(raw[1536 + 64 + u], 0);
    EXPECT_EQ(raw[1536 + 128 + u], 0);

    // Decoded: each ± pair reads the same opacity and its own radiance.
    const std::vector<rvol::Texel> texels = reader.readBrick(1, 0);
    ASSERT_EQ(texels.size(), 6u * 64);
    for (std::uint32_t a = 0; a < 3; ++a) {
        const rvol::Texel pos = texels[2 * a * 64 + t], neg = texels[(2 * a + 1) * 64 + t];
        EXPECT_EQ(pos.a, neg.a) << "axis " << a;
        EXPECT_EQ(pos.a, axisAlpha[a]) << "axis " << a;
        EXPECT_EQ(pos.r, float(2 * a + 1));
        EXPECT_EQ(neg.r, float(2 * a + 2));
    }
    EXPECT_EQ(texels[u], (rvol::Texel{1, 0, 0, 102 / 255.0f}));
    EXPECT_EQ(texels[64 + u], (rvol::Texel{0, 1, 0, 102 / 255.0f}));

    // Sampled at the cell's centre, and directionally: +x and −x see the same opacity, not the
    // same light.
    const double cell = v.cellSize(1);
    const std::array<double, 3> p{v.origin[0] + 1.5 * cell, v.origin[1] + 0.5 * cell,
                                  v.origin[2] + 0.5 * cell};
    const rvol::Texel posX = reader.sample(1, 0, p), negX = reader.sample(1, 1, p);
    EXPECT_EQ(posX.a, negX.a);
    EXPECT_FLOAT_EQ(posX.a, 0.2f);
    EXPECT_FLOAT_EQ(posX.r, 1);
    EXPECT_FLOAT_EQ(negX.r, 2);
    const rvol::Texel along = reader.sampleDirectional(1, p, {0.6, 0.8, 0}),
                      against = reader.sampleDirectional(1, p, {-0.6, -0.8, 0});
    EXPECT_FLOAT_EQ(along.a, against.a);
    // 1 − Π (1 − a)^(|d_a| / Σ|d|), not the d²-weighted mean 0.36·0.2 + 0.64·0.6 = 0.456.
    EXPECT_NEAR(along.a, 1 - std::pow(0.8, 0.6 / 1.4) * std::pow(0.4, 0.8 / 1.4), 1e-6);
    EXPECT_NE(along.r, against.r);

    // readVolume: the cell whose opacities differed comes back with their mean in both channels;
    // writing it again gives the same file.
    const rvol::Volume back = reader.readVolume();
    EXPECT_EQ(back.levels[1].at(1, 0, 0, 3), (rvol::Texel{4, 1.5f, 0.25f, 153 / 255.0f}));
    EXPECT_EQ(back.levels[1].at(0, 1, 0, 0), (rvol::Texel{1, 0, 0, 102 / 255.0f}));
    EXPECT_EQ(back.levels[1].at(0, 1, 0, 1), (rvol::Texel{0, 1, 0, 102 / 255.0f}));
    rvol::writeRvol(dir / "again.rvol", back, kFourTexels);
    EXPECT_TRUE(readBytes(dir / "again.rvol") == readBytes(dir / "v.rvol"));
    EXPECT_NO_THROW((void)rvol::validateRvol(reader));

    // decodeBrick takes 1 or 6 channels and exactly brickBytes.
    EXPECT_THROW((void)rvol::decodeBrick(raw, 4, 2), std::invalid_argument);
    EXPECT_THROW((void)rvol::decodeBrick(std::vector<std::uint8_t>(1920), 4, 6),
                 std::invalid_argument);  // 1.x's size
    EXPECT_EQ(rvol::decodeBrick(raw, 4, 6), texels);
}

// ---- binary level-0 opacity
// ----------------------------------------------------------------------

namespace {

/// makeVolume with level 0 as a bake makes it: every non-zero cell solid (opacity 1), every third
/// of them black (radiance 0); empty cells stay (0, 0, 0, 0). Levels ≥ 1 keep fractional opacities.
rvol::Volume makeBinaryVolume(std::uint32_t depth, std::uint32_t seed) {
    rvol::Volume v = makeVolume(depth, seed);
    std::size_t solid = 0;
    for (rvol::Texel& t : v.levels[0].texels)
        if (t != rvol::Texel{})
            t = solid++ % 3 == 0 ? rvol::Texel{0, 0, 0, 1} : rvol::Texel{t.r, t.g, t.b, 1};
    return v;
}

/// What a reader returns for @p v written with binary level-0 opacity: solid black cells hold the
/// smallest RGB9E5 value, (2^-24, 0, 0), the decoded kSolidBlackWord.
rvol::Volume decodedBinary(rvol::Volume v) {
    for (rvol::Texel& t : v.levels[0].texels)
        if (t == rvol::Texel{0, 0, 0, 1}) t = {0x1p-24f, 0, 0, 1};
    return v;
}

}  // namespace

TEST(Rvol, BinaryLevel0OpacityWorkedExampleOfTheSpec) {
    // docs/rvol-format.md, "Worked example", second file: level 0 with binary opacity (N = 5, the
    // writer's defaults): a solid black cell and an opaque green one.
    ScratchDir dir;
    rvol::Volume v;
    v.depth = 1;
    v.size = 2;
    v.bake = {1, 0, 8, 1, 1};
    rvol::Level l0{2, 1, {0}, std::vector<rvol::Texel>(rvol::kBlockTexels)};
    l0.texels[0] = {0, 0, 0, 1};  // cell (0,0,0): solid black
    l0.texels[1] = {0, 1, 0, 1};  // cell (1,0,0): opaque green
    v.levels = {l0, rvol::Level{1, 6, {}, {}}};
    const rvol::RvolWriteResult result = rvol::writeRvol(dir / "ex.rvol", v);
    EXPECT_TRUE(result.binaryLevel0Opacity);
    EXPECT_EQ(result.fileBytes, 448u);
    EXPECT_EQ(result.radianceBytes, 24u);
    EXPECT_EQ(result.paddingBytes, 448u - 256 - 64 - 16 - 24);
    const std::vector<std::uint8_t> b = readBytes(dir / "ex.rvol");
    ASSERT_EQ(b.size(), 448u);

    std::vector<std::uint8_t> want(448, 0);
    std::uint8_t* w = want.data();
    std::memcpy(w, "RVOL", 4);
    store<std::uint16_t>(w + 4, 4);  // version 4.1
    store<std::uint16_t>(w + 6, 1);
    store<std::uint32_t>(w + 8, 256);
    store<std::uint32_t>(w + 12, 1);  // depth
    store<std::uint32_t>(w + 16, 2);  // levels
    store<std::uint32_t>(w + 20, 5);  // N
    store<std::uint32_t>(w + 24, 2);  // texel format 2
    store<std::uint32_t>(w + 28, 3);  // flags: static layer written (empty), binary level-0 opacity
    store<double>(w + 56, 2.0);
    store<std::uint32_t>(w + 88, 1);   // bounces
    store<float>(w + 96, 8.0f);        // λ
    store<std::uint32_t>(w + 100, 1);  // attenuation
    store<std::uint32_t>(w + 104, 1);  // lights
    store<std::uint64_t>(w + 112, 1);  // bricks (no voxels)
    store<std::uint64_t>(w + 136, 256);
    store<std::uint64_t>(w + 144, 64);
    store<std::uint32_t>(w + 152, 0x37A6E885u);  // level table checksum
    store<std::uint32_t>(w + 156, 0xC37DDDADu);  // directory checksum
    store<std::uint64_t>(w + 160, 320);
    store<std::uint64_t>(w + 168, 16);
    store<std::uint64_t>(w + 176, 384);
    store<std::uint64_t>(w + 184, 64);   // level 0's 24 bytes, the gap to level 1's (empty) data
    store<std::uint64_t>(w + 192, 448);  // static layer, 0 bytes
    store<std::uint64_t>(w + 208, 448);  // dynamic layer, 0 bytes
    store<std::uint64_t>(w + 232, 448);
    store<std::uint32_t>(w + 252, 0xC5FB5385u);  // header checksum
    for (const auto& [at, entry, offset] :
         {std::tuple{256, std::array<std::uint32_t, 6>{2, 1, 1, 500, 1, 0}, 384},
          std::tuple{288, std::array<std::uint32_t, 6>{1, 6, 1, 3384, 0, 1}, 448}}) {
        for (int i = 0; i < 6; ++i) store<std::uint32_t>(w + at + 4 * i, entry[i]);
        store<std::uint64_t>(w + at + 24, static_cast<std::uint64_t>(offset));
    }
    // Brick (0,0,0) of level 0: the RGB9E5 plane only, two texels.
    store<std::uint16_t>(w + 320 + 6, 1);
    store<std::uint32_t>(w + 320 + 8, 2);
    store<std::uint32_t>(w + 320 + 12, 0xA348AB3Cu);
    // Level 0's brick (24 bytes): the 16-byte mask (texels 0 and 1), their words.
    w[384] = 0b11;
    store<std::uint32_t>(w + 400,
                         rvol::kSolidBlackWord);  // solid black: the smallest non-zero word
    store<std::uint32_t>(w + 404, 0x80020000u);   // green (0, 1, 0)
    EXPECT_EQ(rvol::kSolidBlackWord, 1u);
    EXPECT_EQ(rvol::encodeRgb9e5(0x1p-24f, 0, 0), rvol::kSolidBlackWord);
    const auto mismatch = std::mismatch(b.begin(), b.end(), want.begin());
    EXPECT_TRUE(mismatch.first == b.end())
        << "first difference at byte " << (mismatch.first - b.begin());

    const rvol::RvolReader reader(dir / "ex.rvol");
    EXPECT_EQ(rvol::validateRvol(reader).paddingBytes, 88u);
    const std::vector<rvol::Texel> texels = reader.readBrick(0, 0);
    EXPECT_EQ(texels[0], (rvol::Texel{0x1p-24f, 0, 0, 1}));  // solid, radiance ≈ 6e-8
    EXPECT_EQ(texels[1], (rvol::Texel{0, 1, 0, 1}));
    EXPECT_EQ(texels[5], rvol::Texel{});  // cell (0,1,0): empty
    // Halfway between the black and the green cell; halfway between the black cell and empty space.
    const rvol::Texel between = reader.sample(0, 0, {1.0, 0.5, 0.5}),
                      edge = reader.sample(0, 0, {0.5, 1.0, 0.5});
    EXPECT_EQ(between, (rvol::Texel{0x1p-25f, 0.5f, 0, 1}));
    EXPECT_EQ(edge, (rvol::Texel{0x1p-25f, 0, 0, 0.5f}));
    EXPECT_EQ(reader.sampleDirectional(0, {0.5, 1.0, 0.5}, {0, 1, 0}), edge);
}

TEST(Rvol, BinaryLevel0OpacityIsChosenOnlyWhenEveryOpacityIs0Or1) {
    ScratchDir dir;
    const auto write = [&](const rvol::Volume& v, rvol::RvolWriteOptions options = {}) {
        const rvol::RvolWriteResult result = rvol::writeRvol(dir / "v.rvol", v, options);
        const rvol::RvolReader reader(dir / "v.rvol");
        const bool binary = (reader.header().flags & rvol::kFlagBinaryLevel0Opacity) != 0;
        EXPECT_EQ(binary, result.binaryLevel0Opacity);
        EXPECT_EQ(binary, reader.header().binaryLevel0Opacity());
        EXPECT_EQ(reader.header().versionMajor, 4u);
        EXPECT_EQ(reader.level(0).denseBrickBytes,
                  rvol::brickBytes(options.brickTexels, 1, binary));
        EXPECT_EQ(reader.level(1).denseBrickBytes,
                  rvol::brickBytes(options.brickTexels, 6));  // unchanged above level 0
        const rvol::RvolReport report = rvol::validateRvol(reader);
        EXPECT_EQ(report.radianceBytes, result.radianceBytes);
        EXPECT_EQ(report.paddingBytes, result.paddingBytes);
        return std::pair{binary, result};
    };
    const rvol::Volume v = makeBinaryVolume(4, 12);
    const auto [binary, result] = write(v);
    EXPECT_TRUE(binary);
    // At N = 5, 500 bytes per dense level-0 brick instead of 628; stored, each level-0 brick
    // saves its M opacities (padded to 4), M the texels of its mask, the same in both layouts.
    std::uint64_t opacityBytes = 0;
    {
        const rvol::RvolReader reader(dir / "v.rvol");
        EXPECT_EQ(reader.level(0).denseBrickBytes, 500u);
        EXPECT_EQ(reader.readBrickBytes(0, 0).size(), 500u);
        for (const rvol::BrickEntry& e : reader.bricks(0)) opacityBytes += (e.texels + 3) / 4 * 4;
    }
    rvol::RvolWriteOptions a8;
    a8.binaryLevel0Opacity = false;
    const auto [notAsked, withA8] = write(v, a8);
    EXPECT_FALSE(notAsked);
    EXPECT_EQ(withA8.bricksPerLevel, result.bricksPerLevel);
    EXPECT_EQ(withA8.radianceBytes - result.radianceBytes, opacityBytes);
    EXPECT_EQ(withA8.bricks, result.bricks);
    {  // The A8 layout reads black solid cells back as (0, 0, 0, 1); the binary one (below) as
       // (2^-24, 0, 0, 1).
        const rvol::Volume back = rvol::RvolReader(dir / "v.rvol").readVolume();
        EXPECT_TRUE(back.levels[0].texels == v.levels[0].texels);
        write(v);
        EXPECT_TRUE(rvol::RvolReader(dir / "v.rvol").readVolume().levels[0].texels ==
                    decodedBinary(v).levels[0].texels);
    }

    const auto withCell = [&](rvol::Texel t) {
        rvol::Volume w = v;
        w.levels[0].texels[rvol::Level::texelIndex(0, 1, 0, 1, 2, 3)] = t;
        return w;
    };
    EXPECT_FALSE(write(withCell({1, 1, 1, 0.5f})).first);  // a fractional opacity
    EXPECT_FALSE(write(withCell({1, 0, 0, 0}))
                     .first);  // radiance without opacity: a word ≠ 0 would read as solid
    EXPECT_FALSE(write(withCell({0, 0, 0, 0.01f})).first);  // A8 3
    EXPECT_TRUE(write(withCell({1e-9f, 0, 0, 0})).first);   // encodes to word 0 and A8 0: empty
    EXPECT_TRUE(
        write(withCell({0, 0, 0, 0.999f})).first);  // A8 255, as the A8 layout stores it: solid
    EXPECT_TRUE(write(withCell({0.5f, 0, 0, 1.5f})).first);  // clamped to 1
    // Fractional opacities of levels ≥ 1 do not matter (makeVolume has them); other brick sizes.
    for (std::uint32_t n : {2u, 3u, 4u, 8u}) EXPECT_TRUE(write(v, {n, true}).first) << n;
    // A volume with nothing at level 0 qualifies trivially.
    rvol::Volume empty = v;
    empty.levels[0].blocks.clear();
    empty.levels[0].texels.clear();
    EXPECT_TRUE(write(empty).first);
    // The spec's first worked example has opacity 128/255 at level 0: the A8 layout.
}

TEST(Rvol, BinaryLevel0OpacityRoundTripsAndSamplesAsTrilinear) {
    ScratchDir dir;
    for (std::uint32_t n : {2u, 3u, 4u, 5u, 6u}) {
        SCOPED_TRACE("brick texels " + std::to_string(n));
        const rvol::Volume v = makeBinaryVolume(5, 300 + n), expected = decodedBinary(v);
        const fs::path file = dir / "v.rvol";
        const rvol::RvolWriteResult result = rvol::writeRvol(file, v, {n, true});
        ASSERT_TRUE(result.binaryLevel0Opacity);
        EXPECT_EQ(result.headerBytes + result.levelTableBytes + result.directoryBytes +
                      result.radianceBytes + result.attributeBytes + result.paddingBytes,
                  result.fileBytes);
        const rvol::RvolReader reader(file);
        EXPECT_EQ(reader.header().flags,
                  rvol::kFlagStaticAttributes | rvol::kFlagBinaryLevel0Opacity);
        EXPECT_EQ(reader.level(0).denseBrickBytes, 4u * n * n * n);
        const rvol::RvolReport report = rvol::validateRvol(reader);
        EXPECT_EQ(report.radianceBytes, result.radianceBytes);
        EXPECT_EQ(report.bricksPerLevel, result.bricksPerLevel);

        // Level 0's words: 0 for empty cells, kSolidBlackWord for solid black ones, the radiance
        // otherwise; decoded with opacity 1 for every non-zero word.
        const std::uint32_t step = n - 1;
        std::uint64_t black = 0, empty = 0, solid = 0;
        for (std::uint32_t i = 0; i < reader.level(0).brickCount; ++i) {
            const rvol::BrickEntry& e = reader.bricks(0)[i];
            const std::vector<std::uint8_t> raw = reader.readBrickBytes(0, i);
            const std::vector<rvol::Texel> texels = reader.readBrick(0, i);
            ASSERT_EQ(texels.size(), std::size_t{n} * n * n);
            EXPECT_EQ(rvol::decodeBrick(raw, n, 1, true), texels);
            EXPECT_THROW((void)rvol::decodeBrick(raw, n, 1),
                         std::invalid_argument);  // the A8 layout's size differs
            for (std::uint32_t k = 0; k < n; ++k)
                for (std::uint32_t j = 0; j < n; ++j)
                    for (std::uint32_t ii = 0; ii < n; ++ii) {
                        const std::size_t t = (std::size_t{k} * n + j) * n + ii;
                        const rvol::Texel cell =
                            v.levels[0].at(e.x * step + ii, e.y * step + j, e.z * step + k, 0);
                        const std::uint32_t word = load<std::uint32_t>(raw.data() + 4 * t);
                        if (cell == rvol::Texel{}) {
                            ASSERT_EQ(word, 0u);
                            ASSERT_EQ(texels[t], rvol::Texel{});
                            ++empty;
                        } else if (cell == rvol::Texel{0, 0, 0, 1}) {
                            ASSERT_EQ(word, rvol::kSolidBlackWord);
                            ASSERT_EQ(texels[t].a, 1.0f);
                            ASSERT_LE(std::max({texels[t].r, texels[t].g, texels[t].b}),
                                      6e-8f);  // 2^-24 ≈ 5.96e-8
                            ++black;
                        } else {
                            ASSERT_EQ(word, rvol::encodeRgb9e5(cell.r, cell.g, cell.b));
                            ASSERT_EQ(texels[t], cell);
                            ++solid;
                        }
                    }
        }
        EXPECT_GT(black, 50u);
        EXPECT_GT(empty, 50u);
        EXPECT_GT(solid, 50u);

        // readVolume gives the volume back (solid black as (2^-24, 0, 0, 1)); the same cells count
        // as non-zero.
        const rvol::Volume back = reader.readVolume();
        for (std::uint32_t l = 0; l <= v.depth; ++l) {
            EXPECT_EQ(back.levels[l].blocks, v.levels[l].blocks) << "level " << l;
            EXPECT_TRUE(back.levels[l].texels == expected.levels[l].texels) << "level " << l;
        }

        // Trilinear sampling at level 0 interpolates the implicit opacities like stored ones.
        std::mt19937 rng(n);
        std::uniform_real_distribution<double> inside(-0.05, 1.05);
        for (std::uint32_t l = 0; l <= 2; ++l)
            for (int i = 0; i < 400; ++i) {
                std::array<double, 3> p{};
                for (int a = 0; a < 3; ++a) p[a] = v.origin[a] + v.size * inside(rng);
                if (i % 4 == 0)  // on cell centres and brick faces
                    for (int a = 0; a < 3; ++a)
                        p[a] =
                            v.origin[a] +
                            (std::floor(inside(rng) * v.levels[l].resolution / step) * step + 0.5) *
                                v.cellSize(l);
                for (std::uint32_t c = 0; c < v.levels[l].channels; ++c) {
                    const rvol::Texel want = trilinear(expected, l, c, p),
                                      got = reader.sample(l, c, p);
                    const float tol = std::max({want.r, want.g, want.b, 1e-3f}) * 2e-6f;
                    ASSERT_NEAR(got.r, want.r, tol) << "level " << l;
                    ASSERT_NEAR(got.g, want.g, tol);
                    ASSERT_NEAR(got.b, want.b, tol);
                    ASSERT_NEAR(got.a, want.a, 2e-6f);
                    if (l == 0) {
                        ASSERT_EQ(reader.sampleDirectional(0, p, {0.3, -0.4, 0.5}), got);
                    }
                }
            }

        // Deterministic, and reading and writing again gives the same file.
        const std::vector<std::uint8_t> bytes = readBytes(file);
        rvol::writeRvol(dir / "again.rvol", v, {n, true});
        EXPECT_TRUE(readBytes(dir / "again.rvol") == bytes);
        rvol::writeRvol(dir / "again.rvol", back, {n, true});
        EXPECT_TRUE(readBytes(dir / "again.rvol") == bytes);
    }
}

// ---- round trips ------------------------------------------------------------------------------

TEST(Rvol, RoundTripIsExactForRepresentableTexels) {
    ScratchDir dir;
    for (std::uint32_t n : {2u, 3u, 4u, 5u}) {
        SCOPED_TRACE("brick texels " + std::to_string(n));
        const rvol::Volume v = makeVolume(5, 100 + n);
        const fs::path file = dir / ("v" + std::to_string(n) + ".rvol");
        const rvol::RvolWriteResult result = rvol::writeRvol(file, v, {n, true});
        EXPECT_EQ(result.fileBytes, fs::file_size(file));
        EXPECT_EQ(result.headerBytes + result.levelTableBytes + result.directoryBytes +
                      result.radianceBytes + result.attributeBytes + result.paddingBytes,
                  result.fileBytes);
        EXPECT_EQ(result.staticVoxels, v.staticVoxels.size());
        EXPECT_EQ(result.dynamicVoxels, v.dynamicVoxels.size());

        const rvol::RvolReader reader(file);
        const rvol::Header& h = reader.header();
        EXPECT_EQ(h.depth, 5u);
        EXPECT_EQ(h.levelCount, 6u);
        EXPECT_EQ(h.brickTexels, n);
        EXPECT_EQ(h.origin, v.origin);
        EXPECT_EQ(h.size, v.size);
        EXPECT_EQ(h.sceneBounds, v.sceneBounds);
        EXPECT_EQ(h.bake.lights, 7u);
        EXPECT_EQ(h.bake.shadowApertureDegrees, 3.5f);
        EXPECT_EQ(h.flags, rvol::kFlagStaticAttributes);
        EXPECT_EQ(h.brickCount, result.bricks);
        for (std::uint32_t l = 0; l <= 5; ++l) {
            EXPECT_EQ(reader.level(l).channels, l == 0 ? 1u : 6u);
            // Level 0: an RGB9E5 and an A8 plane; above: six RGB9E5 planes and three A8 planes.
            EXPECT_EQ(reader.level(l).denseBrickBytes,
                      (l == 0 ? 1 : 6) * rvol::rgbPlaneBytes(n) +
                          (l == 0 ? 1 : 3) * rvol::alphaPlaneBytes(n));
            EXPECT_EQ(reader.level(l).brickCount, result.bricksPerLevel[l]);
        }

        const rvol::RvolReport report = rvol::validateRvol(reader);
        EXPECT_EQ(report.bricksPerLevel, result.bricksPerLevel);
        EXPECT_EQ(report.radianceBytes, result.radianceBytes);
        EXPECT_EQ(report.paddingBytes, result.paddingBytes);
        EXPECT_EQ(report.headerBytes + report.levelTableBytes + report.directoryBytes +
                      report.radianceBytes + report.staticAttributeBytes +
                      report.dynamicAttributeBytes + report.paddingBytes,
                  report.fileBytes);
        // Distinct non-zero cells equal the in-memory count.
        for (std::uint32_t l = 0; l <= 5; ++l) {
            const rvol::Level& level = v.levels[l];
            std::uint64_t cells = 0;
            for (std::uint32_t z = 0; z < level.resolution; ++z)
                for (std::uint32_t y = 0; y < level.resolution; ++y)
                    for (std::uint32_t x = 0; x < level.resolution; ++x) {
                        bool any = false;
                        for (std::uint32_t c = 0; c < level.channels; ++c)
                            any = any || level.at(x, y, z, c) != rvol::Texel{};
                        cells += any;
                    }
            EXPECT_EQ(report.nonZeroTexelsPerLevel[l], cells) << "level " << l;
        }

        // Texels round-trip exactly; blocks are those with a non-zero cell, as generated.
        const rvol::Volume back = reader.readVolume();
        ASSERT_EQ(back.levels.size(), v.levels.size());
        for (std::uint32_t l = 0; l <= 5; ++l) {
            EXPECT_EQ(back.levels[l].resolution, v.levels[l].resolution);
            EXPECT_EQ(back.levels[l].channels, v.levels[l].channels);
            EXPECT_EQ(back.levels[l].blocks, v.levels[l].blocks) << "level " << l;
            EXPECT_TRUE(back.levels[l].texels == v.levels[l].texels) << "level " << l;
        }
        EXPECT_EQ(back.origin, v.origin);
        EXPECT_EQ(back.size, v.size);
        EXPECT_EQ(back.depth, v.depth);
        EXPECT_EQ(back.bake.bounces, v.bake.bounces);
        EXPECT_EQ(back.bake.aoLambda, v.bake.aoLambda);

        // Attributes within their encodings' precision.
        for (const bool dynamic : {false, true}) {
            const auto& original = dynamic ? v.dynamicVoxels : v.staticVoxels;
            const auto& got = dynamic ? back.dynamicVoxels : back.staticVoxels;
            ASSERT_EQ(got.size(), original.size());
            for (std::size_t i = 0; i < got.size(); ++i) {
                const rvol::VoxelAttributes &a = got[i], &o = original[i];
                EXPECT_EQ(std::tie(a.x, a.y, a.z), std::tie(o.x, o.y, o.z));
                for (int c = 0; c < 3; ++c) {
                    EXPECT_NEAR(a.albedo[c], o.albedo[c],
                                0.0046f);  // half an sRGB8 step, × the curve's slope ≤ 2.3
                    EXPECT_NEAR(
                        a.emission[c], o.emission[c],
                        std::max({o.emission[0], o.emission[1], o.emission[2]}) / 511.5f + 1e-6f);
                }
                EXPECT_NEAR(a.coverage, o.coverage, 0.5f / 255 + 1e-6f);
                EXPECT_NEAR(a.occlusion, o.occlusion, 0.5f / 255 + 1e-6f);
                const float dot = a.normal[0] * o.normal[0] + a.normal[1] * o.normal[1] +
                                  a.normal[2] * o.normal[2];
                EXPECT_GT(dot, std::cos(0.08f * 3.14159265f / 180));
            }
        }
    }
}

TEST(Rvol, ArbitraryTexelsRoundTripWithinEncodingPrecision) {
    ScratchDir dir;
    const rvol::Volume v = makeVolume(4, 7, false);
    rvol::writeRvol(dir / "v.rvol", v, kFourTexels);
    const rvol::RvolReader reader(dir / "v.rvol");
    const rvol::Volume back = reader.readVolume();
    std::uint64_t compared = 0, inexact = 0;
    for (std::uint32_t l = 0; l <= v.depth; ++l) {
        const rvol::Level &a = v.levels[l], &b = back.levels[l];
        for (std::uint32_t z = 0; z < a.resolution; ++z)
            for (std::uint32_t y = 0; y < a.resolution; ++y)
                for (std::uint32_t x = 0; x < a.resolution; ++x)
                    for (std::uint32_t c = 0; c < a.channels; ++c) {
                        const rvol::Texel want = a.at(x, y, z, c), got = b.at(x, y, z, c);
                        expectTexelNear(got, want, rgb9e5Tolerance(want), 0.5f / 255 + 1e-7f,
                                        "level " + std::to_string(l) + " cell " +
                                            std::to_string(x) + "," + std::to_string(y) + "," +
                                            std::to_string(z) + " channel " + std::to_string(c));
                        ++compared;
                        inexact += got != want;
                    }
    }
    EXPECT_GT(compared, 5000u);
    EXPECT_GT(inexact, compared / 10);  // the values really were quantised
}

TEST(Rvol, OutputIsDeterministic) {
    ScratchDir dir;
    const rvol::Volume v = makeVolume(5, 42);
    const rvol::Volume copy = v;
    rvol::writeRvol(dir / "a.rvol", v, kFourTexels);
    rvol::writeRvol(dir / "b.rvol", copy, kFourTexels);
    const auto a = readBytes(dir / "a.rvol");
    EXPECT_GT(a.size(), 10000u);
    EXPECT_TRUE(a == readBytes(dir / "b.rvol"));
    EXPECT_TRUE(std::equal(rvol::kMagic.begin(), rvol::kMagic.end(), a.begin()));
    // Reading and writing again gives the same file: the encodings are idempotent.
    rvol::writeRvol(dir / "c.rvol", rvol::RvolReader(dir / "a.rvol").readVolume(), kFourTexels);
    EXPECT_TRUE(a == readBytes(dir / "c.rvol"));
    EXPECT_EQ(dir.files(),
              (std::vector<std::string>{"a.rvol", "b.rvol", "c.rvol"}));  // no temporaries left
}

TEST(Rvol, StaticAttributesCanBeLeftOut) {
    ScratchDir dir;
    const rvol::Volume v = makeVolume(3, 9);
    const auto result = rvol::writeRvol(dir / "v.rvol", v, {4, false});
    EXPECT_EQ(result.staticVoxels, 0u);
    EXPECT_EQ(result.attributeBytes, 16 * v.dynamicVoxels.size());
    const rvol::RvolReader reader(dir / "v.rvol");
    EXPECT_EQ(reader.header().flags & rvol::kFlagStaticAttributes, 0u);
    EXPECT_TRUE(reader.readAttributes(false).empty());
    EXPECT_EQ(reader.readAttributes(true).size(), v.dynamicVoxels.size());
    EXPECT_NO_THROW((void)rvol::validateRvol(reader));
}

TEST(Rvol, EmptyVolume) {
    ScratchDir dir;
    rvol::Volume v = makeVolume(2, 1);
    for (rvol::Level& level : v.levels) level.blocks.clear(), level.texels.clear();
    v.staticVoxels.clear();
    v.dynamicVoxels.clear();
    const auto result = rvol::writeRvol(dir / "v.rvol", v, kFourTexels);
    EXPECT_EQ(result.bricks, 0u);
    const rvol::RvolReader reader(dir / "v.rvol");
    EXPECT_EQ(rvol::validateRvol(reader).bricks, 0u);
    EXPECT_EQ(reader.sample(0, 0, {0, 1, 2}), rvol::Texel{});
    EXPECT_TRUE(reader.readVolume().levels[0].blocks.empty());
    EXPECT_EQ(result.fileBytes,
              384u);  // header 256, level table 3 × 32 = 96 → 352, padded to 384, nothing else
}

// ---- sampling ---------------------------------------------------------------------------------

TEST(Rvol, SampleEqualsTrilinearInterpolationOfTheLevel) {
    ScratchDir dir;
    for (std::uint32_t n : {2u, 3u, 4u, 6u}) {
        SCOPED_TRACE("brick texels " + std::to_string(n));
        const rvol::Volume v = makeVolume(5, 200 + n);
        const fs::path file = dir / "v.rvol";
        rvol::writeRvol(file, v, {n, true});
        const rvol::RvolReader reader(file);
        std::mt19937 rng(n);
        std::uniform_real_distribution<double> inside(-0.05, 1.05);
        for (std::uint32_t l = 0; l <= v.depth; ++l) {
            const std::uint32_t res = v.levels[l].resolution, step = n - 1;
            std::vector<std::array<double, 3>> points;
            for (int i = 0; i < 300; ++i)
                points.push_back({v.origin[0] + v.size * inside(rng),
                                  v.origin[1] + v.size * inside(rng),
                                  v.origin[2] + v.size * inside(rng)});
            // Exactly on brick boundaries and cell centres, and just either side of a boundary.
            std::uniform_int_distribution<std::uint32_t> brick(0, reader.level(l).bricksPerAxis);
            for (int i = 0; i < 100; ++i) {
                std::array<double, 3> p{};
                const double eps = (i % 3 - 1) * 1e-7;
                for (int a = 0; a < 3; ++a)
                    p[a] = v.origin[a] + ((brick(rng) * step) + 0.5 + eps) * v.cellSize(l);
                points.push_back(p);
            }
            for (const auto& p : points)
                for (std::uint32_t c = 0; c < v.levels[l].channels; ++c) {
                    const rvol::Texel want = trilinear(v, l, c, p), got = reader.sample(l, c, p);
                    const float tol = std::max({want.r, want.g, want.b, want.a, 1e-3f}) * 2e-6f;
                    ASSERT_NEAR(got.r, want.r, tol)
                        << "level " << l << " channel " << c << " res " << res;
                    ASSERT_NEAR(got.g, want.g, tol);
                    ASSERT_NEAR(got.b, want.b, tol);
                    ASSERT_NEAR(got.a, want.a, 2e-6f);
                }
        }
    }
}

TEST(Rvol, SampleOfQuantisedTexelsIsWithinPrecision) {
    ScratchDir dir;
    const rvol::Volume v = makeVolume(4, 31, false);
    rvol::writeRvol(dir / "v.rvol", v, kFourTexels);
    const rvol::RvolReader reader(dir / "v.rvol");
    std::mt19937 rng(1);
    std::uniform_real_distribution<double> inside(0, 1);
    for (int i = 0; i < 2000; ++i) {
        const std::array<double, 3> p{v.origin[0] + v.size * inside(rng),
                                      v.origin[1] + v.size * inside(rng),
                                      v.origin[2] + v.size * inside(rng)};
        const std::uint32_t l = static_cast<std::uint32_t>(i % (v.depth + 1)),
                            c = static_cast<std::uint32_t>(i % v.levels[l].channels);
        const rvol::Texel want = trilinear(v, l, c, p), got = reader.sample(l, c, p);
        // A convex combination of texels each off by at most 40/511.5 and 0.5/255.
        expectTexelNear(got, want, 40 / 511.5f * 1.0001f, 0.5f / 255 + 1e-6f,
                        "sample " + std::to_string(i));
    }
}

TEST(Rvol, DirectionalSamplesBlendColourBySquaredCosinesAndMultiplyTransmittances) {
    ScratchDir dir;
    rvol::Volume v = makeVolume(3, 2);
    // Level 1 (4 cells): every cell of channel c holds (c + 1, 10·(c + 1), 0.5, (axis + 1)/10)
    // exactly, axis = c/2 (the ± channels of an axis share their opacity).
    rvol::Level& l1 = v.levels[1];
    l1.blocks = {0};
    l1.texels.assign(6 * rvol::kBlockTexels, {});
    for (std::uint32_t c = 0; c < 6; ++c)
        for (std::uint32_t z = 0; z < 4; ++z)
            for (std::uint32_t y = 0; y < 4; ++y)
                for (std::uint32_t x = 0; x < 4; ++x)
                    l1.texels[rvol::Level::texelIndex(0, 6, c, x, y, z)] = {
                        float(c + 1), float(10 * (c + 1)), 0.5f, (c / 2 + 1) / 10.0f};
    rvol::writeRvol(dir / "v.rvol", v, kFourTexels);
    const rvol::RvolReader reader(dir / "v.rvol");
    const std::array<double, 3> p{v.origin[0] + 1.3, v.origin[1] + 0.7, v.origin[2] + 2.2};
    const auto channelValue = [&](std::uint32_t c) { return reader.sample(1, c, p); };
    // Decoded values of the constant channels (alpha quantised to 8 bits).
    EXPECT_NEAR(channelValue(0).r, 1, 1e-6);
    EXPECT_NEAR(channelValue(static_cast<std::uint32_t>(rvol::Direction::NegY)).g, 40, 1e-5);
    // The spec's directional sample: colour blended by d_a²/|d|², opacity 1 − Π (1 −
    // a)^(|d_a|/Σ|d|), the colour rescaled to that opacity.
    const auto expectMix = [&](std::array<double, 3> d,
                               std::array<std::pair<rvol::Direction, double>, 3> mix) {
        double r = 0, blend = 0, transmittance = 1;
        const double sumAbs = std::abs(d[0]) + std::abs(d[1]) + std::abs(d[2]);
        for (const auto& [channel, w] : mix) {
            const auto c = static_cast<std::uint32_t>(channel);
            r += w * channelValue(c).r;
            blend += w * channelValue(c).a;
            transmittance *= std::pow(1 - double(channelValue(c).a), std::abs(d[c / 2]) / sumAbs);
        }
        const double a = 1 - transmittance;
        r *= blend > 0 ? a / blend : 0.0;
        const rvol::Texel t = reader.sampleDirectional(1, p, d);
        EXPECT_NEAR(t.r, r, 1e-5) << d[0] << "," << d[1] << "," << d[2];
        EXPECT_NEAR(t.a, a, 1e-6);
    };
    using D = rvol::Direction;
    expectMix({1, 0, 0}, {{{D::PosX, 1}, {D::PosY, 0}, {D::PosZ, 0}}});
    expectMix({-1, 0, 0}, {{{D::NegX, 1}, {D::PosY, 0}, {D::PosZ, 0}}});
    expectMix({0, 0, -2}, {{{D::NegZ, 1}, {D::PosY, 0}, {D::PosX, 0}}});  // not unit: normalised
    expectMix({0, -0.6, 0.8}, {{{D::NegY, 0.36}, {D::PosZ, 0.64}, {D::PosX, 0}}});
    const double s = 1 / std::sqrt(3.0);
    expectMix({-s, s, -s}, {{{D::NegX, 1 / 3.0}, {D::PosY, 1 / 3.0}, {D::NegZ, 1 / 3.0}}});
    // PosX → r = 1, NegZ → r = 6: a cone along +x must not see the −z channel.
    EXPECT_NEAR(reader.sampleDirectional(1, p, {1, 0, 0}).r, 1, 1e-6);
    EXPECT_NEAR(reader.sampleDirectional(1, p, {0, 0, -1}).r, 6, 1e-6);
    EXPECT_EQ(reader.sampleDirectional(1, p, {0, 0, 0}), rvol::Texel{});
    // Level 0 is isotropic: every direction gives channel 0.
    EXPECT_EQ(reader.sampleDirectional(0, p, {0, -1, 0}), reader.sample(0, 0, p));
    EXPECT_THROW((void)reader.sample(0, 1, p), std::out_of_range);
    EXPECT_THROW((void)reader.sample(4, 0, p), std::out_of_range);
}

TEST(Rvol, SamplingIsThreadSafeWithASmallCache) {
    ScratchDir dir;
    const rvol::Volume v = makeVolume(5, 77);
    rvol::writeRvol(dir / "v.rvol", v, kFourTexels);
    const rvol::RvolReader reader(dir / "v.rvol");
    reader.setCacheBytes(20000);  // a handful of bricks: constant eviction
    std::vector<std::array<double, 3>> points;
    std::mt19937 rng(4);
    std::uniform_real_distribution<double> inside(0, 1);
    for (int i = 0; i < 4000; ++i)
        points.push_back({v.origin[0] + 3 * inside(rng), v.origin[1] + 3 * inside(rng),
                          v.origin[2] + 3 * inside(rng)});
    std::vector<rvol::Texel> expected;
    for (std::size_t i = 0; i < points.size(); ++i)
        expected.push_back(trilinear(v, i % 3, i % 3 == 0 ? 0 : i % 6, points[i]));
    std::vector<std::thread> threads;
    std::vector<int> mismatches(4, 0);
    for (int t = 0; t < 4; ++t)
        threads.emplace_back([&, t] {
            for (std::size_t i = static_cast<std::size_t>(t); i < points.size() * 4; i += 3) {
                const std::size_t k = i % points.size();
                const rvol::Texel got =
                    reader.sample(static_cast<std::uint32_t>(k % 3),
                                  k % 3 == 0 ? 0 : static_cast<std::uint32_t>(k % 6), points[k]);
                const float tol =
                    std::max({expected[k].r, expected[k].g, expected[k].b, 1e-3f}) * 2e-6f;
                if (std::abs(got.r - expected[k].r) > tol ||
                    std::abs(got.a - expected[k].a) > 2e-6f)
                    ++mismatches[t];
            }
        });
    for (auto& t : threads) t.join();
    EXPECT_EQ(mismatches, (std::vector<int>{0, 0, 0, 0}));
}

// ---- errors -----------------------------------------------------------------------------------

namespace {

/// Every single-bit flip of @p good's header, level table, directory and the padding after them,
/// a spread of flips in its bricks and attribute records, truncations and an appended byte: each
/// rejected as InvalidData (a corrupt file written next to @p good).
void expectCorruptionsRejected(const fs::path& good) {
    const std::vector<std::uint8_t> bytes = readBytes(good);
    ASSERT_EQ(openAndValidate(good), Outcome::Valid);
    const rvol::RvolReader reader(good);
    const rvol::Header& h = reader.header();
    ASSERT_GT(h.brickCount, 10u);
    ASSERT_GT(h.staticVoxelCount, 10u);
    const fs::path bad = good.parent_path() / "bad.rvol";
    std::uint64_t tried = 0;
    const auto expectInvalid = [&](const std::vector<std::uint8_t>& data, const std::string& what) {
        // Removed first: rewriting a truncated file in place makes ext4 flush it on close
        // (auto_da_alloc).
        fs::remove(bad);
        vox::test::writeBinary(bad, data);
        ++tried;
        EXPECT_EQ(openAndValidate(bad), Outcome::Invalid) << what;
    };
    // One bit flipped: every byte of the header, level table, directory and the padding after
    // them; a spread of bytes of the bricks and the attribute records (every byte of the file
    // is covered by a checksum or by the zero-padding check).
    for (std::uint64_t i = 0; i < bytes.size(); i += i < h.brickDataOffset ? 1 : 29) {
        std::vector<std::uint8_t> data = bytes;
        data[i] ^= static_cast<std::uint8_t>(1u << (i % 8));
        expectInvalid(data, "byte " + std::to_string(i) + " flipped");
    }
    for (std::uint64_t i = h.staticAttributesOffset - 1; i < bytes.size();
         i += 5) {  // every attribute record, and the gap before it
        std::vector<std::uint8_t> data = bytes;
        data[i] ^= 0x80;
        expectInvalid(data, "attribute byte " + std::to_string(i) + " flipped");
    }
    std::printf("%llu corrupted variants of a %zu-byte file\n",
                static_cast<unsigned long long>(tried), bytes.size());
    EXPECT_GT(tried, 1500u);
    // Truncated (inside the header, level table, directory, bricks, attributes; a byte short) and
    // appended to.
    for (std::uint64_t size :
         {std::uint64_t{0}, std::uint64_t{4}, std::uint64_t{255}, std::uint64_t{256},
          std::uint64_t{300}, h.directoryOffset + 5, h.brickDataOffset + 1000,
          h.staticAttributesOffset + 16, std::uint64_t{bytes.size() - 1}})
        expectInvalid(std::vector<std::uint8_t>(bytes.begin(),
                                                bytes.begin() + static_cast<std::ptrdiff_t>(size)),
                      "truncated to " + std::to_string(size));
    std::vector<std::uint8_t> appended = bytes;
    appended.push_back(0);
    expectInvalid(appended, "a byte appended");
    expectInvalid(std::vector<std::uint8_t>(4096, 0x41), "not an .rvol file");
}

}  // namespace

TEST(Rvol, CorruptedFilesAreInvalidData) {
    ScratchDir dir;
    rvol::writeRvol(dir / "good.rvol", makeVolume(4, 5), kFourTexels);
    ASSERT_EQ(rvol::RvolReader(dir / "good.rvol").header().flags & rvol::kFlagBinaryLevel0Opacity,
              0u);  // fractional opacities: A8
    expectCorruptionsRejected(dir / "good.rvol");
}

TEST(Rvol, BinaryLevel0OpacityCorruptionIsInvalidData) {
    ScratchDir dir;
    const fs::path good = dir / "good.rvol";
    ASSERT_TRUE(rvol::writeRvol(good, makeBinaryVolume(4, 5), kFourTexels).binaryLevel0Opacity);
    expectCorruptionsRejected(good);

    // Structural edits behind valid checksums.
    const std::vector<std::uint8_t> bytes = readBytes(good);
    const rvol::RvolReader reader(good);
    const rvol::LevelEntry& l0 = reader.level(0);
    ASSERT_EQ(l0.denseBrickBytes, 256u);
    const fs::path bad = dir / "bad.rvol";
    const auto rejectedWith = [&](std::vector<std::uint8_t> data, const std::string& expected) {
        fixChecksums(data);
        vox::test::writeBinary(bad, data);
        try {
            const rvol::RvolReader r(bad);
            (void)rvol::validateRvol(r);
            ADD_FAILURE() << "accepted; expected: " << expected;
        } catch (const vox::InvalidDataError& e) {
            EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
        }
    };
    {  // The flag cleared (or set on an A8 file): level 0's brick size no longer matches.
        std::vector<std::uint8_t> data = bytes;
        data[28] &= static_cast<std::uint8_t>(~rvol::kFlagBinaryLevel0Opacity);
        rejectedWith(data, "level table, level 0: bricks per axis or brick size wrong");
    }
    {  // A shared face's word changed in one brick only (a solid cell made empty, or the reverse).
        bool found = false;
        for (std::uint32_t i = 0; i < l0.brickCount && !found; ++i) {
            const rvol::BrickEntry& b = reader.bricks(0)[i];
            if (reader.findBrick(0, b.x + 1u, b.y, b.z) < 0) continue;
            const std::uint64_t texel = 3 + 4 * (1 + 4 * 2);  // (3, 1, 2): on the +x face
            rejectedWith(withEditedBrick(
                             bytes, reader, 0, i,
                             [&](std::vector<std::uint8_t>& dense) { dense[4 * texel] ^= 0x01; }),
                         "shared face with brick (" + std::to_string(b.x + 1) + "," +
                             std::to_string(b.y) + "," + std::to_string(b.z) +
                             ") differs (channel 0)");
            found = true;
        }
        EXPECT_TRUE(found);
    }
    {  // A brick's stored bytes made all zero: its mask no longer holds its entry's texels.
        std::vector<std::uint8_t> data = bytes;
        std::fill_n(data.begin() + static_cast<std::ptrdiff_t>(reader.brickOffset(0, 0)),
                    reader.storedBrickSize(0, 0), 0);
        rejectedWith(data, "level 0, brick 0");
    }
    {  // A non-zero word (a solid cell) on a face towards a brick that is not stored.
        bool found = false;
        for (std::uint32_t i = 0; i < l0.brickCount && !found; ++i) {
            const rvol::BrickEntry& b = reader.bricks(0)[i];
            if (b.x + 1u >= l0.bricksPerAxis || reader.findBrick(0, b.x + 1u, b.y, b.z) >= 0)
                continue;
            const std::uint64_t texel = 3 + 4 * (1 + 4 * 2);
            rejectedWith(withEditedBrick(bytes, reader, 0, i,
                                         [&](std::vector<std::uint8_t>& dense) {
                                             store<std::uint32_t>(dense.data() + 4 * texel,
                                                                  rvol::kSolidBlackWord);
                                         }),
                         "which is not stored, is not zero");
            found = true;
        }
        EXPECT_TRUE(found);
    }
}

TEST(Rvol, ErrorMessagesSayWhere) {
    ScratchDir dir;
    const fs::path good = dir / "good.rvol";
    rvol::writeRvol(good, makeVolume(4, 5), kFourTexels);
    const std::vector<std::uint8_t> bytes = readBytes(good);
    const rvol::RvolReader reader(good);
    const rvol::Header& h = reader.header();
    const fs::path bad = dir / "bad.rvol";
    const auto message = [&](const std::vector<std::uint8_t>& data) -> std::string {
        vox::test::writeBinary(bad, data);
        try {
            const rvol::RvolReader r(bad);
            (void)rvol::validateRvol(r);
        } catch (const vox::InvalidDataError& e) {
            return e.what();
        }
        return "accepted";
    };
    const auto flipped = [&](std::uint64_t at) {
        std::vector<std::uint8_t> data = bytes;
        data[at] ^= 0x10;
        return data;
    };
    EXPECT_EQ(message(flipped(40)), bad.string() + ": header: checksum mismatch");
    EXPECT_EQ(message(flipped(h.levelTableOffset + 3)),
              bad.string() + ": level table: checksum mismatch");
    EXPECT_EQ(message(flipped(h.directoryOffset + 13)),
              bad.string() + ": brick directory: checksum mismatch");
    const rvol::LevelEntry& l1 = reader.level(1);
    const rvol::BrickEntry& b = reader.bricks(1)[2];
    EXPECT_EQ(message(flipped(reader.brickOffset(1, 2) + 9)),
              bad.string() + ": level 1, brick 2 (" + std::to_string(b.x) + "," +
                  std::to_string(b.y) + "," + std::to_string(b.z) + "), file offset " +
                  std::to_string(l1.dataOffset + reader.storedBrickSize(1, 0) +
                                 reader.storedBrickSize(1, 1)) +
                  ": checksum mismatch");
    EXPECT_EQ(message(flipped(h.staticAttributesOffset + 16 * 3 + 5)),
              bad.string() + ": static attribute layer: checksum mismatch");
    EXPECT_EQ(message(flipped(h.dynamicAttributesOffset + 1)),
              bad.string() + ": dynamic attribute layer: checksum mismatch");
    EXPECT_EQ(message(std::vector<std::uint8_t>(bytes.begin(), bytes.end() - 1)),
              bad.string() + ": header says " + std::to_string(bytes.size()) +
                  " bytes but the file has " + std::to_string(bytes.size() - 1) +
                  " (truncated or appended to)");
    // Files of 1.x (one A8 plane per channel), 2.x (always an A8 plane at level 0) and 3.x (dense
    // bricks of a fixed size) are rejected by their version, never misread.
    std::vector<std::uint8_t> version = bytes;
    for (const std::uint8_t major : {1, 2, 3, 5}) {
        version[4] = major;
        EXPECT_EQ(message(version),
                  bad.string() + ": unsupported .rvol version " + std::to_string(major) + "." +
                      std::to_string(vox::rvol::kVersionMinor) + " (this reader reads 4.x)");
    }
    // Any minor of the reader's major is accepted (the header checksum made right).
    version = bytes;
    version[6] = 7;
    store<std::uint32_t>(version.data() + 252, vox::crc32c(version.data(), 252));
    EXPECT_EQ(message(version), "accepted");
}

TEST(Rvol, StructuralCorruptionIsCaughtBehindValidChecksums) {
    ScratchDir dir;
    const fs::path good = dir / "good.rvol";
    rvol::writeRvol(good, makeVolume(4, 5), kFourTexels);
    const std::vector<std::uint8_t> bytes = readBytes(good);
    const rvol::RvolReader reader(good);
    const rvol::Header& h = reader.header();
    const fs::path bad = dir / "bad.rvol";
    const auto rejectedWith = [&](std::vector<std::uint8_t> data, const std::string& expected) {
        fixChecksums(data);
        vox::test::writeBinary(bad, data);
        try {
            const rvol::RvolReader r(bad);
            (void)rvol::validateRvol(r);
            ADD_FAILURE() << "accepted; expected: " << expected;
        } catch (const vox::InvalidDataError& e) {
            EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
        }
    };
    {  // The fix-up leaves a good file as it is.
        std::vector<std::uint8_t> same = bytes;
        fixChecksums(same);
        EXPECT_TRUE(same == bytes);
    }
    const rvol::LevelEntry& l0 = reader.level(0);
    ASSERT_GT(l0.brickCount, 3u);
    {  // Two directory entries swapped: no longer in Morton order.
        std::vector<std::uint8_t> data = bytes;
        std::swap_ranges(data.begin() + static_cast<std::ptrdiff_t>(h.directoryOffset),
                         data.begin() + static_cast<std::ptrdiff_t>(h.directoryOffset + 16),
                         data.begin() + static_cast<std::ptrdiff_t>(h.directoryOffset + 16));
        rejectedWith(data, "not in strictly ascending Morton order");
    }
    {  // A brick coordinate past the level.
        std::vector<std::uint8_t> data = bytes;
        const std::uint64_t last = h.directoryOffset + 16 * (l0.brickCount - 1);
        store<std::uint16_t>(data.data() + last + 4, static_cast<std::uint16_t>(l0.bricksPerAxis));
        rejectedWith(data, "outside the level's");
    }
    {  // Plane bits of a plane level 0 does not have (an A8 file: RGB9E5 and A8 only).
        std::vector<std::uint8_t> data = bytes;
        data[h.directoryOffset + 6] |= 0b100;
        rejectedWith(data, "brick directory: level 0, entry 0: plane bits 7 not 1");
        data = bytes;
        store<std::uint16_t>(data.data() + h.directoryOffset + 6, 0);  // no plane stored
        rejectedWith(data, "plane bits 0 not 1");
    }
    {  // No texels, or more than a brick has.
        std::vector<std::uint8_t> data = bytes;
        store<std::uint32_t>(data.data() + h.directoryOffset + 8, 0);
        rejectedWith(data, "brick directory: level 0, entry 0: 0 texels, not 1 … 64");
        store<std::uint32_t>(data.data() + h.directoryOffset + 8, 65);
        rejectedWith(data, "65 texels, not 1 … 64");
    }
    {  // Non-canonical stored bricks, their sizes kept: an unused plane, a mask texel zero in
       // every plane, non-zero padding.
        const std::uint32_t n = h.brickTexels;
        bool plane = false, texel = false, padding = false;
        for (std::uint32_t i = 0; i < l0.brickCount; ++i) {
            const rvol::BrickEntry& b = reader.bricks(0)[i];
            const std::vector<std::uint8_t> stored = reader.readStoredBrick(0, i);
            const std::uint64_t offset = reader.brickOffset(0, i), mask = rvol::brickMaskBytes(n);
            if (!plane && b.planes == 0b11) {
                // The A8 plane's values zeroed where every texel has a non-zero word.
                const rvol::PackedBrick rgbOnly = rvol::packBrick(
                    [&] {
                        std::vector<std::uint8_t> dense = reader.readBrickBytes(0, i);
                        std::fill(dense.begin() + 4 * 64, dense.end(), 0);
                        return dense;
                    }(),
                    n, 1);
                if (rgbOnly.texels == b.texels) {
                    std::vector<std::uint8_t> data = bytes;
                    std::fill_n(data.begin() + static_cast<std::ptrdiff_t>(
                                                   offset + mask + 4 * std::uint64_t{b.texels}),
                                b.texels, 0);
                    rejectedWith(data, "a stored plane is all zero (plane bits 3, planes 1");
                    plane = true;
                }
            }
            if (!texel && b.texels >= 2 && b.planes == 0b11) {
                // The first mask texel's word and opacity zeroed, the others left.
                std::vector<std::uint8_t> data = bytes;
                std::fill_n(data.begin() + static_cast<std::ptrdiff_t>(offset + mask), 4, 0);
                data[offset + mask + 4 * std::uint64_t{b.texels}] = 0;
                const rvol::PackedBrick check =
                    rvol::packBrick(rvol::expandBrick({data.data() + offset, stored.size()}, n, 1,
                                                      false, b.planes, b.texels),
                                    n, 1);
                if (check.planes == b.planes) {
                    rejectedWith(data, "occupancy mask holds a texel that is zero in every plane");
                    texel = true;
                }
            }
            if (!padding && b.texels % 4 != 0) {
                std::vector<std::uint8_t> data = bytes;
                data[offset + stored.size() - 1] = 1;
                rejectedWith(
                    data, "level 0, brick " + std::to_string(i) + " (" + std::to_string(b.x) + "," +
                              std::to_string(b.y) + "," + std::to_string(b.z) + "), file offset " +
                              std::to_string(offset) + ": padding after the A8 planes is not zero");
                padding = true;
            }
        }
        EXPECT_TRUE(plane && texel && padding);
    }
    {  // One texel of a shared face changed in only one of the two bricks.
        bool found = false;
        for (std::uint32_t i = 0; i < l0.brickCount && !found; ++i) {
            const rvol::BrickEntry& b = reader.bricks(0)[i];
            if (reader.findBrick(0, b.x + 1u, b.y, b.z) < 0) continue;
            const std::uint64_t texel = 3 + 4 * (1 + 4 * 2);  // (3, 1, 2): on the +x face
            rejectedWith(withEditedBrick(
                             bytes, reader, 0, i,
                             [&](std::vector<std::uint8_t>& dense) { dense[4 * texel] ^= 0x01; }),
                         "shared face with brick (" + std::to_string(b.x + 1) + "," +
                             std::to_string(b.y) + "," + std::to_string(b.z) + ") differs");
            found = true;
        }
        EXPECT_TRUE(found);
    }
    {  // One opacity of a shared face changed in only one of two level-1 bricks (the x axis' A8
       // plane).
        bool found = false;
        const rvol::LevelEntry& l1 = reader.level(1);
        for (std::uint32_t i = 0; i < l1.brickCount && !found; ++i) {
            const rvol::BrickEntry& b = reader.bricks(1)[i];
            if (reader.findBrick(1, b.x + 1u, b.y, b.z) < 0) continue;
            const std::uint64_t texel = 3 + 4 * (1 + 4 * 2);  // (3, 1, 2): on the +x face
            rejectedWith(withEditedBrick(bytes, reader, 1, i,
                                         [&](std::vector<std::uint8_t>& dense) {
                                             dense[rvol::alphaPlaneOffset(4, 6, 0) + texel] ^= 0x01;
                                         }),
                         "shared face with brick (" + std::to_string(b.x + 1) + "," +
                             std::to_string(b.y) + "," + std::to_string(b.z) +
                             ") differs (x-axis A8 plane)");
            found = true;
        }
        EXPECT_TRUE(found);
    }
    {  // A brick's stored bytes made all zero.
        std::vector<std::uint8_t> data = bytes;
        std::fill_n(data.begin() + static_cast<std::ptrdiff_t>(reader.brickOffset(0, 0)),
                    reader.storedBrickSize(0, 0), 0);
        const rvol::BrickEntry& b = reader.bricks(0)[0];
        rejectedWith(data, "level 0, brick 0 (" + std::to_string(b.x) + "," + std::to_string(b.y) +
                               "," + std::to_string(b.z) + "), file offset " +
                               std::to_string(reader.brickOffset(0, 0)) +
                               ": occupancy mask does not hold the entry's texels");
    }
    {  // Two attribute records swapped.
        std::vector<std::uint8_t> data = bytes;
        const auto at = data.begin() + static_cast<std::ptrdiff_t>(h.staticAttributesOffset);
        std::swap_ranges(at, at + 16, at + 16);
        rejectedWith(data, "static attribute layer, record 1, file offset " +
                               std::to_string(h.staticAttributesOffset + 16) +
                               ": Morton codes not strictly ascending");
    }
    {  // A Morton code outside level 0 (depth 4: 12 bits).
        std::vector<std::uint8_t> data = bytes;
        store<std::uint32_t>(
            data.data() + h.dynamicAttributesOffset + 16 * (h.dynamicVoxelCount - 1), 1u << 12);
        rejectedWith(data, "outside level 0");
    }
    {  // Padding between sections.
        std::vector<std::uint8_t> data = bytes;
        ASSERT_GT(h.directoryOffset, h.levelTableOffset + h.levelTableBytes);
        data[h.directoryOffset - 1] = 0xFF;
        rejectedWith(data, "padding at file offset " + std::to_string(h.directoryOffset - 1) +
                               " is not zero");
    }
    {  // A header claiming far more than the file holds: rejected before any allocation.
        std::vector<std::uint8_t> data = bytes;
        store<std::uint64_t>(data.data() + 112, std::uint64_t{1} << 60);  // brickCount
        store<std::uint64_t>(data.data() + 168, std::uint64_t{16} << 60);
        rejectedWith(data, "brick directory misplaced");
        data = bytes;
        store<std::uint64_t>(data.data() + 120, std::uint64_t{1} << 40);  // static voxels
        rejectedWith(data, "static attribute layer misplaced");
        data = bytes;
        store<std::uint32_t>(data.data() + 12, 11);  // depth 11
        rejectedWith(data, "depth 11 above 10");
        data = bytes;
        store<std::uint32_t>(data.data() + 20, 1);  // 1-texel bricks
        rejectedWith(data, "brick size 1 outside 2..32");
        data = bytes;
        store<std::uint32_t>(data.data() + 24, 1);  // 1.x's texel format: an A8 plane per channel
        rejectedWith(data, "header: unknown texel format 1");
        data = bytes;
        store<std::uint32_t>(data.data() + 256 + 32 + 16,
                             l0.brickCount + 1);  // level 1 claims a brick more
        rejectedWith(data, "level table");
    }
}

TEST(Rvol, StoredBrickPaddingMustBeZero) {
    // N = 3: a stored brick ends with its A8 planes' M opacities each, padded to a multiple of 4.
    ScratchDir dir;
    const fs::path good = dir / "good.rvol", bad = dir / "bad.rvol";
    rvol::writeRvol(good, makeVolume(3, 8), {3, true});
    const std::vector<std::uint8_t> bytes = readBytes(good);
    const rvol::RvolReader reader(good);
    ASSERT_EQ(openAndValidate(good), Outcome::Valid);
    EXPECT_EQ(reader.level(0).denseBrickBytes, 108u + 28);
    EXPECT_EQ(reader.level(1).denseBrickBytes, 6u * 108 + 3 * 28);
    EXPECT_EQ(rvol::brickMaskBytes(3), 4u);
    for (std::uint32_t level : {0u, 1u}) {
        SCOPED_TRACE("level " + std::to_string(level));
        bool found = false;
        for (std::uint32_t i = 0; i < reader.level(level).brickCount && !found; ++i) {
            const rvol::BrickEntry& b = reader.bricks(level)[i];
            const std::uint32_t alpha = static_cast<std::uint32_t>(std::popcount(
                static_cast<std::uint32_t>(b.planes >> reader.level(level).channels)));
            if (alpha * b.texels % 4 == 0) continue;  // no padding
            std::vector<std::uint8_t> data = bytes;
            data[reader.brickOffset(level, i) + reader.storedBrickSize(level, i) - 1] = 1;
            fixChecksums(data);
            vox::test::writeBinary(bad, data);
            try {
                const rvol::RvolReader r(bad);
                (void)rvol::validateRvol(r);
                ADD_FAILURE() << "accepted";
            } catch (const vox::InvalidDataError& e) {
                EXPECT_NE(std::string(e.what()).find(
                              "level " + std::to_string(level) + ", brick " + std::to_string(i) +
                              " (" + std::to_string(b.x) + "," + std::to_string(b.y) + "," +
                              std::to_string(b.z) + "), file offset " +
                              std::to_string(reader.brickOffset(level, i)) +
                              ": padding after the A8 planes is not zero"),
                          std::string::npos)
                    << e.what();
            }
            found = true;
        }
        EXPECT_TRUE(found);
    }
}

TEST(Rvol, MissingFileIsIoError) {
    ScratchDir dir;
    try {
        const rvol::RvolReader reader(dir / "missing.rvol");
        ADD_FAILURE() << "opened a file that does not exist";
    } catch (const vox::IoError& e) {
        EXPECT_NE(std::string(e.what()).find("missing.rvol"), std::string::npos) << e.what();
    }
    EXPECT_THROW(rvol::RvolReader{dir.path()}, vox::IoError);
}

TEST(Rvol, WriterRejectsBadOptionsAndInconsistentVolumes) {
    ScratchDir dir;
    const rvol::Volume v = makeVolume(3, 1);
    EXPECT_THROW(rvol::writeRvol(dir / "x.rvol", v, {1, true}), vox::UsageError);
    EXPECT_THROW(rvol::writeRvol(dir / "x.rvol", v, {33, true}), vox::UsageError);
    rvol::Volume w = v;
    w.levels.pop_back();
    EXPECT_THROW(rvol::writeRvol(dir / "x.rvol", w, {}), std::invalid_argument);
    w = v;
    w.levels[1].channels = 1;
    EXPECT_THROW(rvol::writeRvol(dir / "x.rvol", w, {}), std::invalid_argument);
    w = v;
    w.levels[0].texels.pop_back();
    EXPECT_THROW(rvol::writeRvol(dir / "x.rvol", w, {}), std::invalid_argument);
    w = v;
    std::swap(w.staticVoxels[0], w.staticVoxels[1]);
    EXPECT_THROW(rvol::writeRvol(dir / "x.rvol", w, {}), std::invalid_argument);
    w = v;
    w.size = 0;
    EXPECT_THROW(rvol::writeRvol(dir / "x.rvol", w, {}), std::invalid_argument);
    EXPECT_TRUE(dir.files().empty());
}
