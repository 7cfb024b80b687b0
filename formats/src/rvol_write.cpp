// The .rvol writer (docs/rvol-format.md): cuts every level into node-centred bricks with shared
// faces, encodes the non-empty ones, and writes header, level table, brick directory, brick data
// and attribute layers through an AtomicFile.
#include <vox/formats/atomic_file.h>
#include <vox/formats/checksum.h>
#include <vox/base/error.h>
#include <vox/formats/rvol_io.h>

#include "rvol_internal.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace vox::rvol {

using detail::store;

std::array<std::uint8_t, kHeaderBytes> encodeHeader(const Header& h) {
    namespace o = detail::hdr;
    std::array<std::uint8_t, kHeaderBytes> out{};
    std::uint8_t* p = out.data();
    std::copy(kMagic.begin(), kMagic.end(), p);
    store<std::uint16_t>(p + o::kVersionMajor, h.versionMajor);
    store<std::uint16_t>(p + o::kVersionMinor, h.versionMinor);
    store<std::uint32_t>(p + o::kHeaderBytes, kHeaderBytes);
    store<std::uint32_t>(p + o::kDepth, h.depth);
    store<std::uint32_t>(p + o::kLevelCount, h.levelCount);
    store<std::uint32_t>(p + o::kBrickTexels, h.brickTexels);
    store<std::uint32_t>(p + o::kTexelFormat, h.texelFormat);
    store<std::uint32_t>(p + o::kFlags, h.flags);
    for (int i = 0; i < 3; ++i) store<double>(p + o::kOrigin + 8 * i, h.origin[i]);
    store<double>(p + o::kSize, h.size);
    for (int i = 0; i < 6; ++i) store<float>(p + o::kSceneBounds + 4 * i, h.sceneBounds[i]);
    store<std::uint32_t>(p + o::kBounces, h.bake.bounces);
    store<float>(p + o::kShadowAperture, h.bake.shadowApertureDegrees);
    store<float>(p + o::kAoLambda, h.bake.aoLambda);
    store<std::uint32_t>(p + o::kAttenuation, h.bake.attenuation);
    store<std::uint32_t>(p + o::kLights, h.bake.lights);
    store<std::uint32_t>(p + o::kGatherRays, h.bake.gatherRays);
    store<std::uint64_t>(p + o::kBrickCount, h.brickCount);
    store<std::uint64_t>(p + o::kStaticVoxels, h.staticVoxelCount);
    store<std::uint64_t>(p + o::kDynamicVoxels, h.dynamicVoxelCount);
    store<std::uint64_t>(p + o::kLevelTableOffset, h.levelTableOffset);
    store<std::uint64_t>(p + o::kLevelTableBytes, h.levelTableBytes);
    store<std::uint32_t>(p + o::kLevelTableChecksum, h.levelTableChecksum);
    store<std::uint32_t>(p + o::kDirectoryChecksum, h.directoryChecksum);
    store<std::uint64_t>(p + o::kDirectoryOffset, h.directoryOffset);
    store<std::uint64_t>(p + o::kDirectoryBytes, h.directoryBytes);
    store<std::uint64_t>(p + o::kBrickDataOffset, h.brickDataOffset);
    store<std::uint64_t>(p + o::kBrickDataBytes, h.brickDataBytes);
    store<std::uint64_t>(p + o::kStaticOffset, h.staticAttributesOffset);
    store<std::uint64_t>(p + o::kStaticBytes, h.staticAttributesBytes);
    store<std::uint64_t>(p + o::kDynamicOffset, h.dynamicAttributesOffset);
    store<std::uint64_t>(p + o::kDynamicBytes, h.dynamicAttributesBytes);
    store<std::uint32_t>(p + o::kStaticChecksum, h.staticAttributesChecksum);
    store<std::uint32_t>(p + o::kDynamicChecksum, h.dynamicAttributesChecksum);
    store<std::uint64_t>(p + o::kFileBytes, h.fileBytes);
    store<std::uint32_t>(p + o::kChecksum, crc32c(p, o::kChecksum));
    return out;
}

namespace {

[[noreturn]] void inconsistent(const std::string& what) {
    throw std::invalid_argument("writeRvol: " + what);
}

void checkVolume(const Volume& v) {
    if (v.depth > kMaxDepth)
        inconsistent("depth " + std::to_string(v.depth) + " above " + std::to_string(kMaxDepth));
    if (!std::isfinite(v.origin[0]) || !std::isfinite(v.origin[1]) || !std::isfinite(v.origin[2]) ||
        !std::isfinite(v.size) || !(v.size > 0))
        inconsistent("root cube origin or size not finite, or size not positive");
    if (v.levels.size() != v.depth + 1)
        inconsistent("expected " + std::to_string(v.depth + 1) + " levels, got " +
                     std::to_string(v.levels.size()));
    for (std::uint32_t l = 0; l <= v.depth; ++l) {
        const Level& level = v.levels[l];
        const std::string where = "level " + std::to_string(l) + ": ";
        if (level.resolution != levelResolution(v.depth, l))
            inconsistent(where + "resolution is not 2^(depth - level)");
        if (level.channels != levelChannels(l)) inconsistent(where + "wrong channel count");
        const std::uint32_t blocksPerAxis = (level.resolution + kBlockCells - 1) / kBlockCells;
        for (std::size_t b = 0; b < level.blocks.size(); ++b) {
            if (b > 0 && level.blocks[b] <= level.blocks[b - 1])
                inconsistent(where + "blocks not in strictly ascending Morton order");
            const auto c = demorton3(level.blocks[b]);
            if (c[0] >= blocksPerAxis || c[1] >= blocksPerAxis || c[2] >= blocksPerAxis ||
                morton3(c[0], c[1], c[2]) != level.blocks[b])
                inconsistent(where + "block outside the level");
        }
        if (level.texels.size() != level.blocks.size() * level.channels * kBlockTexels)
            inconsistent(where + "texel count is not blocks x channels x 512");
    }
    const std::uint32_t resolution = levelResolution(v.depth, 0);
    for (const auto* voxels : {&v.staticVoxels, &v.dynamicVoxels}) {
        std::uint64_t previous = 0;
        for (std::size_t i = 0; i < voxels->size(); ++i) {
            const VoxelAttributes& a = (*voxels)[i];
            if (a.x >= resolution || a.y >= resolution || a.z >= resolution)
                inconsistent("voxel attributes outside level 0");
            const std::uint64_t code = morton3(a.x, a.y, a.z);
            if (i > 0 && code <= previous)
                inconsistent("voxel attributes not in strictly ascending Morton order");
            previous = code;
        }
    }
}

/// clamp(v, 0, 1), NaN → 0 (as encodeUnorm8 clamps).
float clamp01(float v) noexcept { return v > 0 ? std::min(v, 1.0f) : 0.0f; }

/// Whether level 0 can take the binary-opacity layout without changing a decoded texel: every
/// texel of a cell inside the level encodes its opacity as A8 0 or 255, and every texel of A8 0
/// has RGB9E5 word 0 (there a = 0 must mean "empty": a zero word). Texels of cells outside every
/// block are zero, which qualifies.
bool binaryOpacityFits(const Level& level) noexcept {
    const std::uint32_t res = level.resolution;
    for (std::size_t b = 0; b < level.blocks.size(); ++b) {
        const auto block = demorton3(level.blocks[b]);
        for (std::uint32_t i = 0; i < kBlockTexels; ++i) {
            const std::uint32_t x = block[0] * kBlockCells + i % kBlockCells,
                                y = block[1] * kBlockCells + i / kBlockCells % kBlockCells,
                                z = block[2] * kBlockCells + i / (kBlockCells * kBlockCells);
            if (x >= res || y >= res || z >= res) continue;  // not stored
            const Texel& t = level.texels[Level::texelIndex(b, level.channels, 0, x, y, z)];
            const std::uint8_t alpha = encodeUnorm8(t.a);
            if (alpha != 0 && alpha != 255) return false;
            if (alpha == 0 && encodeRgb9e5(t.r, t.g, t.b) != 0) return false;
        }
    }
    return true;
}

/// One level's stored bricks.
struct EncodedLevel {
    LevelEntry entry;
    std::vector<BrickEntry> directory;
    std::vector<std::uint8_t> data;
};

/// Cuts @p level into bricks of @p n texels per edge sharing their faces and encodes those with a
/// non-zero byte, in ascending Morton order of their coordinates, each packed (packBrick). @p
/// binaryOpacity: level 0 in the binary-opacity layout (binaryOpacityFits(level) holds).
EncodedLevel encodeLevel(const Level& level, std::uint32_t n, bool binaryOpacity) {
    EncodedLevel out;
    const std::uint32_t step = n - 1, res = level.resolution, channels = level.channels;
    const std::uint32_t perAxis = bricksPerAxis(res, n);
    // Only level 0 (one channel) has a binary-opacity layout.
    const bool binary = binaryOpacity && channels == 1;
    out.entry = {
        res, channels, perAxis, static_cast<std::uint32_t>(brickBytes(n, channels, binary)),
        0,   0,        0};

    // Candidate bricks: those overlapping a stored block. Brick b covers cells b·s … b·s + s
    // (s = N − 1), so it meets block cells 8B … 8B + 7 when ⌈8B/s⌉ − 1 ≤ b ≤ ⌊(8B + 7)/s⌋.
    std::vector<std::uint64_t> candidates;
    for (std::uint64_t code : level.blocks) {
        const auto block = demorton3(code);
        std::array<std::uint32_t, 3> lo{}, hi{};
        for (int a = 0; a < 3; ++a) {
            const std::uint32_t first = block[a] * kBlockCells;
            lo[a] = first == 0 ? 0 : (first + step - 1) / step - 1;
            hi[a] = std::min((first + kBlockCells - 1) / step, perAxis - 1);
        }
        for (std::uint32_t z = lo[2]; z <= hi[2]; ++z)
            for (std::uint32_t y = lo[1]; y <= hi[1]; ++y)
                for (std::uint32_t x = lo[0]; x <= hi[0]; ++x)
                    candidates.push_back(morton3(x, y, z));
    }
    std::sort(candidates.begin(), candidates.end());
    candidates.erase(std::unique(candidates.begin(), candidates.end()), candidates.end());

    const std::uint32_t planes = alphaPlanes(channels, binary);
    std::vector<std::uint8_t> brick(out.entry.denseBrickBytes);
    for (std::uint64_t code : candidates) {
        const auto b = demorton3(code);
        std::fill(brick.begin(), brick.end(), std::uint8_t{0});
        bool nonZero = false;
        // The block of the previous texel: a brick spans at most two blocks per axis.
        std::uint64_t lastBlockCode = ~std::uint64_t{0};
        std::int64_t lastBlock = -1;
        for (std::uint32_t k = 0; k < n; ++k)
            for (std::uint32_t j = 0; j < n; ++j)
                for (std::uint32_t i = 0; i < n; ++i) {
                    const std::uint32_t x = b[0] * step + i, y = b[1] * step + j,
                                        z = b[2] * step + k;
                    if (x >= res || y >= res || z >= res) continue;  // past the level: zero
                    const std::uint64_t blockCode =
                        morton3(x / kBlockCells, y / kBlockCells, z / kBlockCells);
                    if (blockCode != lastBlockCode) {
                        lastBlockCode = blockCode;
                        lastBlock = level.findBlock(x, y, z);
                    }
                    if (lastBlock < 0) continue;
                    const std::size_t t = (std::size_t{k} * n + j) * n + i;
                    const auto texel = [&](std::uint32_t c) -> const Texel& {
                        return level.texels[Level::texelIndex(static_cast<std::size_t>(lastBlock),
                                                              channels, c, x, y, z)];
                    };
                    for (std::uint32_t c = 0; c < channels; ++c) {
                        const Texel& v = texel(c);
                        std::uint32_t rgb = encodeRgb9e5(v.r, v.g, v.b);
                        // Binary opacity: the word carries the opacity too, so a solid cell (A8
                        // 255; binaryOpacityFits left only 255, or 0 with word 0) whose radiance
                        // encodes to 0 takes the smallest non-zero word.
                        if (binary && rgb == 0 && encodeUnorm8(v.a) != 0) rgb = kSolidBlackWord;
                        store<std::uint32_t>(brick.data() + rgbPlaneOffset(n, c) + 4 * t, rgb);
                        nonZero = nonZero || rgb != 0;
                    }
                    for (std::uint32_t p = 0; p < planes; ++p) {
                        // Level 0: the channel's opacity; above: the mean of the axis' ± channels
                        // (equal in a baked volume: compositing's opacity is symmetric).
                        const float a =
                            channels == 1
                                ? texel(0).a
                                : 0.5f * (clamp01(texel(2 * p).a) + clamp01(texel(2 * p + 1).a));
                        const std::uint8_t alpha = encodeUnorm8(a);
                        brick[alphaPlaneOffset(n, channels, p) + t] = alpha;
                        nonZero = nonZero || alpha != 0;
                    }
                }
        if (!nonZero) continue;  // empty space: absent bricks read as zero
        // Stored sparse: the thin surfaces leave most texels of a brick, and some planes, zero.
        const PackedBrick packed = packBrick(brick, n, channels, binary);
        out.directory.push_back({static_cast<std::uint16_t>(b[0]), static_cast<std::uint16_t>(b[1]),
                                 static_cast<std::uint16_t>(b[2]), packed.planes, packed.texels,
                                 crc32c(packed.bytes.data(), packed.bytes.size())});
        out.data.insert(out.data.end(), packed.bytes.begin(), packed.bytes.end());
    }
    out.entry.brickCount = static_cast<std::uint32_t>(out.directory.size());
    out.entry.dataBytes = out.data.size();
    return out;
}

std::vector<std::uint8_t> encodeLayer(const std::vector<VoxelAttributes>& voxels) {
    std::vector<std::uint8_t> out(voxels.size() * kAttributeRecordBytes);
    std::uint8_t* p = out.data();
    for (const VoxelAttributes& v : voxels) {
        const AttributeRecord r = encodeAttributes(v);
        store<std::uint32_t>(p, r.morton);
        std::copy(r.albedoCoverage.begin(), r.albedoCoverage.end(), p + 4);
        store<std::uint32_t>(p + 8, r.normalOcclusion);
        store<std::uint32_t>(p + 12, r.emission);
        p += kAttributeRecordBytes;
    }
    return out;
}

}  // namespace

RvolWriteResult writeRvol(const std::filesystem::path& file, const Volume& volume,
                          const RvolWriteOptions& options) {
    if (options.brickTexels < kMinBrickTexels || options.brickTexels > kMaxBrickTexels)
        throw UsageError("brick size " + std::to_string(options.brickTexels) + " outside " +
                         std::to_string(kMinBrickTexels) + ".." + std::to_string(kMaxBrickTexels) +
                         " texels");
    checkVolume(volume);
    const std::uint32_t n = options.brickTexels;

    const bool binaryOpacity = options.binaryLevel0Opacity && binaryOpacityFits(volume.levels[0]);
    std::vector<EncodedLevel> levels;
    levels.reserve(volume.levels.size());
    for (const Level& level : volume.levels) levels.push_back(encodeLevel(level, n, binaryOpacity));
    const std::vector<std::uint8_t> staticLayer =
        options.staticAttributes ? encodeLayer(volume.staticVoxels) : std::vector<std::uint8_t>{};
    const std::vector<std::uint8_t> dynamicLayer = encodeLayer(volume.dynamicVoxels);

    // Layout: every section at the first multiple of 64 after the previous one.
    Header h;
    h.depth = volume.depth;
    h.levelCount = volume.depth + 1;
    h.brickTexels = n;
    h.flags = (options.staticAttributes ? kFlagStaticAttributes : 0) |
              (binaryOpacity ? kFlagBinaryLevel0Opacity : 0);
    h.origin = volume.origin;
    h.size = volume.size;
    h.sceneBounds = volume.sceneBounds;
    h.bake = volume.bake;
    h.levelTableOffset = kHeaderBytes;
    h.levelTableBytes = std::uint64_t{kLevelEntryBytes} * h.levelCount;
    h.directoryOffset = alignSection(h.levelTableOffset + h.levelTableBytes);
    std::uint64_t bricks = 0;
    for (EncodedLevel& level : levels) {
        if (bricks + level.entry.brickCount > 0xFFFFFFFFull)
            throw std::invalid_argument("writeRvol: more than 2^32 - 1 bricks");
        level.entry.firstBrick = static_cast<std::uint32_t>(bricks);
        bricks += level.entry.brickCount;
    }
    h.brickCount = bricks;
    h.directoryBytes = std::uint64_t{kBrickEntryBytes} * bricks;
    h.brickDataOffset = alignSection(h.directoryOffset + h.directoryBytes);
    std::uint64_t end = h.brickDataOffset;
    for (EncodedLevel& level : levels) {
        level.entry.dataOffset = alignSection(end);
        end = level.entry.dataOffset + level.data.size();
    }
    h.brickDataBytes = end - h.brickDataOffset;
    h.staticVoxelCount = options.staticAttributes ? volume.staticVoxels.size() : 0;
    h.staticAttributesOffset = alignSection(end);
    h.staticAttributesBytes = staticLayer.size();
    h.staticAttributesChecksum = crc32c(staticLayer.data(), staticLayer.size());
    h.dynamicVoxelCount = volume.dynamicVoxels.size();
    h.dynamicAttributesOffset = alignSection(h.staticAttributesOffset + h.staticAttributesBytes);
    h.dynamicAttributesBytes = dynamicLayer.size();
    h.dynamicAttributesChecksum = crc32c(dynamicLayer.data(), dynamicLayer.size());
    h.fileBytes = h.dynamicAttributesOffset + h.dynamicAttributesBytes;

    std::vector<std::uint8_t> levelTable(h.levelTableBytes, 0);
    for (std::size_t l = 0; l < levels.size(); ++l) {
        std::uint8_t* p = levelTable.data() + kLevelEntryBytes * l;
        const LevelEntry& e = levels[l].entry;
        store<std::uint32_t>(p + 0, e.resolution);
        store<std::uint32_t>(p + 4, e.channels);
        store<std::uint32_t>(p + 8, e.bricksPerAxis);
        store<std::uint32_t>(p + 12, e.denseBrickBytes);
        store<std::uint32_t>(p + 16, e.brickCount);
        store<std::uint32_t>(p + 20, e.firstBrick);
        store<std::uint64_t>(p + 24, e.dataOffset);
    }
    h.levelTableChecksum = crc32c(levelTable.data(), levelTable.size());
    std::vector<std::uint8_t> directory(h.directoryBytes, 0);
    {
        std::uint8_t* p = directory.data();
        for (const EncodedLevel& level : levels)
            for (const BrickEntry& e : level.directory) {
                store<std::uint16_t>(p + 0, e.x);
                store<std::uint16_t>(p + 2, e.y);
                store<std::uint16_t>(p + 4, e.z);
                store<std::uint16_t>(p + 6, e.planes);
                store<std::uint32_t>(p + 8, e.texels);
                store<std::uint32_t>(p + 12, e.checksum);
                p += kBrickEntryBytes;
            }
    }
    h.directoryChecksum = crc32c(directory.data(), directory.size());

    AtomicFile out(file);
    std::uint64_t written = 0, padding = 0;
    const std::array<std::uint8_t, kSectionAlignment> zeros{};
    const auto put = [&](std::uint64_t offset, const void* data, std::uint64_t size) {
        // The gap up to @p offset is zero (it is less than one alignment unit).
        padding += offset - written;
        out.write(zeros.data(), offset - written);
        out.write(data, size);
        written = offset + size;
    };
    const auto headerBytes = encodeHeader(h);
    put(0, headerBytes.data(), headerBytes.size());
    put(h.levelTableOffset, levelTable.data(), levelTable.size());
    put(h.directoryOffset, directory.data(), directory.size());
    for (const EncodedLevel& level : levels)
        put(level.entry.dataOffset, level.data.data(), level.data.size());
    put(h.staticAttributesOffset, staticLayer.data(), staticLayer.size());
    put(h.dynamicAttributesOffset, dynamicLayer.data(), dynamicLayer.size());
    out.commit();

    RvolWriteResult r;
    r.fileBytes = h.fileBytes;
    r.headerBytes = kHeaderBytes;
    r.levelTableBytes = h.levelTableBytes;
    r.directoryBytes = h.directoryBytes;
    for (const EncodedLevel& level : levels) {
        r.radianceBytes += level.data.size();
        r.bricksPerLevel.push_back(level.entry.brickCount);
    }
    r.attributeBytes = h.staticAttributesBytes + h.dynamicAttributesBytes;
    r.paddingBytes = padding;
    r.bricks = bricks;
    r.staticVoxels = h.staticVoxelCount;
    r.dynamicVoxels = h.dynamicVoxelCount;
    r.binaryLevel0Opacity = binaryOpacity;
    return r;
}

}  // namespace vox::rvol
