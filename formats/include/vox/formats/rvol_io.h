/// @file rvol_io.h
/// @brief Writing, reading and validating .rvol radiance volume files (docs/rvol-format.md): the
/// header, level table and brick directory layouts, the texel and attribute encodings (RGB9E5,
/// A8, sRGB8, octahedral normals), the writer, a reader that samples bricks the way a GPU's
/// trilinear filter does, and the validator. All multi-byte values are little-endian.
#pragma once

#include <vox/formats/rvol.h>
#include <vox/formats/rvol_sampler.h>

#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>
#include <vector>

namespace vox {
class ReadOnlyFile;  // vox/formats/read_only_file.h
}  // namespace vox

namespace vox::rvol {

// ---- constants ------------------------------------------------------------------------------

inline constexpr std::array<std::uint8_t, 4> kMagic{'R', 'V', 'O', 'L'};
/// The format version this library reads and writes, 4.1 (docs/rvol-format.md, "Versions"; the
/// earlier versions: docs/internals/rvol-writer.md).
inline constexpr std::uint16_t kVersionMajor = 4;  ///< readers reject other majors
inline constexpr std::uint16_t kVersionMinor = 1;  ///< readers accept any minor of their major
inline constexpr std::uint32_t kHeaderBytes = 256;
inline constexpr std::uint32_t kLevelEntryBytes = 32;
inline constexpr std::uint32_t kBrickEntryBytes = 16;
inline constexpr std::uint32_t kAttributeRecordBytes = 16;
inline constexpr std::uint32_t kSectionAlignment =
    64;  ///< file offset alignment of every section and level
/// Deepest level-0 grid: the attribute records' 32-bit Morton codes hold 10 bits per axis.
inline constexpr std::uint32_t kMaxDepth = 10;
inline constexpr std::uint32_t kMinBrickTexels = 2;
inline constexpr std::uint32_t kMaxBrickTexels = 32;
/// Texel format 2 (the only one of 2.x … 4.x): per channel an RGB9E5 plane (GL_RGB9_E5), then
/// the A8 opacity planes (GL_R8): one per axis (x, y, z) at levels ≥ 1, shared by the axis' ±
/// channels; at level 0 one, or none with kFlagBinaryLevel0Opacity. In 4.x a brick stores of
/// these planes only the texels of its occupancy mask, and only the planes that are not all zero
/// (packBrick, expandBrick). Readers reject any other value.
inline constexpr std::uint32_t kTexelFormatRgb9e5AxisA8 = 2;
/// Header flags.
inline constexpr std::uint32_t kFlagStaticAttributes =
    1;  ///< the static attribute layer was written
/// Level-0 bricks are their RGB9E5 plane only (4·N³ bytes, no A8 plane), the opacity implicit: a
/// word ≠ 0 is opacity 1, a word = 0 opacity 0 (docs/rvol-format.md, "Level 0 with binary
/// opacity"). The writer sets it when every level-0 opacity is 0 or 1 (RvolWriteOptions).
inline constexpr std::uint32_t kFlagBinaryLevel0Opacity = 2;
/// In the binary-opacity layout, the word of a solid cell whose radiance encodes to 0 (black): the
/// smallest non-zero RGB9E5 word, red mantissa 1 with exponent 0, i.e. (2^-24, 0, 0) ≈ (6e-8, 0,
/// 0), far below any visible radiance. Decoded as that value (what GL_RGB9_E5 gives a GPU).
inline constexpr std::uint32_t kSolidBlackWord = 0x00000001;

// ---- texel and attribute encodings ----------------------------------------------------------

/// Largest value RGB9E5 holds: (2^9 − 1)/2^9 · 2^(31 − 15) = 65408.
inline constexpr float kRgb9e5Max = 65408.0f;

/// Encodes linear RGB to GL_RGB9_E5 exactly as OpenGL specifies (EXT_texture_shared_exponent):
/// each channel clamped to [0, 65408] (NaN → 0), a shared exponent with bias 15 chosen from the
/// largest channel, 9-bit mantissas rounded to nearest (halves up). Red in bits 0–8, green 9–17,
/// blue 18–26, exponent 27–31.
[[nodiscard]] std::uint32_t encodeRgb9e5(float r, float g, float b) noexcept;
/// Decodes GL_RGB9_E5: channel = mantissa · 2^(exponent − 24). Every word is valid.
[[nodiscard]] std::array<float, 3> decodeRgb9e5(std::uint32_t packed) noexcept;
/// round(255 · clamp(v, 0, 1)) (NaN → 0): opacity, coverage and occlusion.
[[nodiscard]] std::uint8_t encodeUnorm8(float v) noexcept;
[[nodiscard]] inline float decodeUnorm8(std::uint8_t v) noexcept {
    return static_cast<float>(v) / 255.0f;
}
/// Linear [0, 1] → 8-bit sRGB, round(255 · srgb(clamp(v, 0, 1))) (NaN → 0).
[[nodiscard]] std::uint8_t encodeSrgb8(float linear) noexcept;
/// 8-bit sRGB → linear.
[[nodiscard]] float decodeSrgb8(std::uint8_t srgb) noexcept;
/// Octahedral encoding of a direction in 24 bits: u in bits 0–11, v in bits 12–23, each a 12-bit
/// snorm (q = round(2047·c) + 2048). Any vector; zero or non-finite ones encode as +z.
[[nodiscard]] std::uint32_t encodeOctahedral(const std::array<float, 3>& n) noexcept;
/// Decodes the low 24 bits of @p packed to a unit vector.
[[nodiscard]] std::array<float, 3> decodeOctahedral(std::uint32_t packed) noexcept;

// ---- geometry -------------------------------------------------------------------------------

/// Cells per axis of @p level in a volume of @p depth (2^(depth − level)).
[[nodiscard]] constexpr std::uint32_t levelResolution(std::uint32_t depth,
                                                      std::uint32_t level) noexcept {
    return 1u << (depth - level);
}
/// Channels of @p level: 1 at level 0, kDirections above.
[[nodiscard]] constexpr std::uint32_t levelChannels(std::uint32_t level) noexcept {
    return level == 0 ? 1u : kDirections;
}
/// Bricks per axis covering the cell centres 0 … resolution − 1 with bricks of @p brickTexels
/// texels that share a face: max(1, ⌈(resolution − 1)/(brickTexels − 1)⌉).
[[nodiscard]] constexpr std::uint32_t bricksPerAxis(std::uint32_t resolution,
                                                    std::uint32_t brickTexels) noexcept {
    const std::uint32_t step = brickTexels - 1;
    return resolution <= 1 ? 1u : (resolution - 1 + step - 1) / step;
}
/// Bytes of one RGB9E5 plane of a brick: N³ 32-bit words.
[[nodiscard]] constexpr std::uint64_t rgbPlaneBytes(std::uint32_t brickTexels) noexcept {
    return 4 * std::uint64_t{brickTexels} * brickTexels * brickTexels;
}
/// Bytes of one A8 plane of a brick: N³ bytes padded to a multiple of 4.
[[nodiscard]] constexpr std::uint64_t alphaPlaneBytes(std::uint32_t brickTexels) noexcept {
    return (std::uint64_t{brickTexels} * brickTexels * brickTexels + 3) / 4 * 4;
}
/// A8 planes of a brick of @p channels channels: 1 for level 0's isotropic channel (0 when
/// @p binaryOpacity: a file with kFlagBinaryLevel0Opacity), one per axis (3) for the six
/// directional channels, whose ± pair shares its opacity (front-to-back compositing's opacity
/// a_f + (1 − a_f)·a_b is symmetric in front and back); @p binaryOpacity does not change those.
[[nodiscard]] constexpr std::uint32_t alphaPlanes(std::uint32_t channels,
                                                  bool binaryOpacity = false) noexcept {
    return channels == 1 ? (binaryOpacity ? 0u : 1u) : channels / 2;
}
/// The A8 plane holding the opacity of @p channel: channel/2 (PosX, NegX → 0 (x); PosY, NegY → 1
/// (y); PosZ, NegZ → 2 (z); level 0's channel 0 → 0).
[[nodiscard]] constexpr std::uint32_t alphaPlaneOf(std::uint32_t channel) noexcept {
    return channel / 2;
}
/// Byte offset in a brick of @p channel's RGB9E5 plane: channel · 4N³.
[[nodiscard]] constexpr std::uint64_t rgbPlaneOffset(std::uint32_t brickTexels,
                                                     std::uint32_t channel) noexcept {
    return channel * rgbPlaneBytes(brickTexels);
}
/// Byte offset in a brick of @p channels channels of A8 plane @p plane: after every RGB9E5 plane.
[[nodiscard]] constexpr std::uint64_t alphaPlaneOffset(std::uint32_t brickTexels,
                                                       std::uint32_t channels,
                                                       std::uint32_t plane) noexcept {
    return channels * rgbPlaneBytes(brickTexels) + plane * alphaPlaneBytes(brickTexels);
}
/// Bytes of a brick of @p channels channels: the RGB9E5 planes then the A8 planes (N = 4: 320 at
/// level 0, 256 with @p binaryOpacity, 6·256 + 3·64 = 1728 above; N = 5: 628, 500, 3384).
/// @p binaryOpacity: the file has kFlagBinaryLevel0Opacity (it changes level 0's bricks only).
[[nodiscard]] constexpr std::uint64_t brickBytes(std::uint32_t brickTexels, std::uint32_t channels,
                                                 bool binaryOpacity = false) noexcept {
    return alphaPlaneOffset(brickTexels, channels, alphaPlanes(channels, binaryOpacity));
}
/// Bytes of a stored brick's occupancy mask: one bit per texel (N³ bits), padded to a multiple of
/// 4 bytes.
[[nodiscard]] constexpr std::uint64_t brickMaskBytes(std::uint32_t brickTexels) noexcept {
    return (std::uint64_t{brickTexels} * brickTexels * brickTexels + 31) / 32 * 4;
}
/// Bytes of a stored brick: the mask, @p rgbPlanes RGB9E5 planes of @p texels words each, then
/// @p alphaPlanes A8 planes of @p texels bytes each, padded to a multiple of 4.
[[nodiscard]] constexpr std::uint64_t storedBrickBytes(std::uint32_t brickTexels,
                                                       std::uint32_t rgbPlanes,
                                                       std::uint32_t alphaPlanes,
                                                       std::uint64_t texels) noexcept {
    return brickMaskBytes(brickTexels) + 4 * rgbPlanes * texels +
           (alphaPlanes * texels + 3) / 4 * 4;
}
/// The first multiple of kSectionAlignment at or after @p offset.
[[nodiscard]] constexpr std::uint64_t alignSection(std::uint64_t offset) noexcept {
    return (offset + kSectionAlignment - 1) / kSectionAlignment * kSectionAlignment;
}

// ---- header, level table, directory ---------------------------------------------------------

/// The 256-byte file header (docs/rvol-format.md, "Header").
struct Header {
    std::uint16_t versionMajor = kVersionMajor;
    std::uint16_t versionMinor = kVersionMinor;
    std::uint32_t depth = 0;
    std::uint32_t levelCount = 1;   ///< depth + 1
    std::uint32_t brickTexels = 4;  ///< N, texels per brick edge
    std::uint32_t texelFormat = kTexelFormatRgb9e5AxisA8;
    std::uint32_t flags = 0;                ///< kFlagStaticAttributes, kFlagBinaryLevel0Opacity
    std::array<double, 3> origin{0, 0, 0};  ///< world position of the root cube's minimum corner
    double size = 1;                        ///< root cube edge, world units
    std::array<float, 6> sceneBounds{};     ///< min xyz, max xyz (world)
    BakeInfo bake;
    std::uint64_t brickCount = 0;
    std::uint64_t staticVoxelCount = 0;
    std::uint64_t dynamicVoxelCount = 0;
    std::uint64_t levelTableOffset = 0, levelTableBytes = 0;
    std::uint32_t levelTableChecksum = 0;
    std::uint32_t directoryChecksum = 0;
    std::uint64_t directoryOffset = 0, directoryBytes = 0;
    std::uint64_t brickDataOffset = 0, brickDataBytes = 0;
    std::uint64_t staticAttributesOffset = 0, staticAttributesBytes = 0;
    std::uint64_t dynamicAttributesOffset = 0, dynamicAttributesBytes = 0;
    std::uint32_t staticAttributesChecksum = 0;
    std::uint32_t dynamicAttributesChecksum = 0;
    std::uint64_t fileBytes = 0;

    [[nodiscard]] double cellSize(std::uint32_t level) const noexcept {
        return size / double(levelResolution(depth, level));
    }
    /// Level-0 bricks are stored without their A8 plane (kFlagBinaryLevel0Opacity).
    [[nodiscard]] bool binaryLevel0Opacity() const noexcept {
        return (flags & kFlagBinaryLevel0Opacity) != 0;
    }
};

/// One entry of the level table (docs/rvol-format.md, "Level table").
struct LevelEntry {
    std::uint32_t resolution = 0;  ///< cells per axis
    std::uint32_t channels = 0;    ///< 1 at level 0, 6 above
    std::uint32_t bricksPerAxis = 0;
    /// Bytes of each brick of the level expanded to its dense planes (brickBytes()): what
    /// readBrickBytes returns and a GPU atlas holds; stored bricks are smaller.
    std::uint32_t denseBrickBytes = 0;
    std::uint32_t brickCount = 0;  ///< bricks stored
    std::uint32_t firstBrick = 0;  ///< index of the level's first entry in the brick directory
    std::uint64_t dataOffset = 0;  ///< file offset of the level's first brick
    std::uint64_t dataBytes = 0;   ///< not stored: the sum of the level's stored brick sizes
};

/// One brick directory entry (docs/rvol-format.md, "Brick directory").
struct BrickEntry {
    std::uint16_t x = 0, y = 0, z = 0;  ///< brick coordinates in the level
    /// Bit p: plane p is stored (planes 0 … channels − 1 RGB9E5, then the A8 planes); the
    /// others are all zero.
    std::uint16_t planes = 0;
    std::uint32_t texels = 0;    ///< texels of the occupancy mask (1 … N³)
    std::uint32_t checksum = 0;  ///< CRC-32C of the brick's stored bytes
    [[nodiscard]] std::uint64_t morton() const noexcept { return morton3(x, y, z); }
};

/// Serialises the header (with its checksum) into 256 bytes.
[[nodiscard]] std::array<std::uint8_t, kHeaderBytes> encodeHeader(const Header& header);

/// One encoded attribute record (docs/rvol-format.md, "Attribute layers").
struct AttributeRecord {
    std::uint32_t morton = 0;                      ///< morton3(x, y, z) of the level-0 cell
    std::array<std::uint8_t, 4> albedoCoverage{};  ///< sRGB8 R, G, B, linear coverage
    std::uint32_t normalOcclusion = 0;  ///< octahedral normal (bits 0–23), occlusion (24–31)
    std::uint32_t emission = 0;         ///< RGB9E5
};
[[nodiscard]] AttributeRecord encodeAttributes(const VoxelAttributes& voxel) noexcept;
[[nodiscard]] VoxelAttributes decodeAttributes(const AttributeRecord& record) noexcept;

// ---- writing --------------------------------------------------------------------------------

struct RvolWriteOptions {
    /// N, texels per brick edge, kMinBrickTexels … kMaxBrickTexels; default 5 (4 cells per brick
    /// and axis; why: docs/internals/rvol-writer.md).
    std::uint32_t brickTexels = 5;
    bool staticAttributes =
        true;  ///< write the static attribute layer (the dynamic one is always written)
    /// Store level 0 in the binary-opacity layout (kFlagBinaryLevel0Opacity, 4·N³ instead of
    /// 4·N³ + ⌈N³/4⌉·4 bytes per brick) when the volume allows it without changing a decoded
    /// texel: every level-0 texel's opacity encodes as A8 0 or 255, and every texel of A8 0 has
    /// RGB9E5 word 0. Solid cells whose radiance encodes to 0 are stored as kSolidBlackWord. False:
    /// always the A8 layout.
    bool binaryLevel0Opacity = true;
};

/// What writeRvol wrote. The byte counts add up to fileBytes.
struct RvolWriteResult {
    std::uint64_t fileBytes = 0;
    std::uint64_t headerBytes = 0;
    std::uint64_t levelTableBytes = 0;
    std::uint64_t directoryBytes = 0;
    std::uint64_t radianceBytes = 0;   ///< brick data (bricks × their size, all levels)
    std::uint64_t attributeBytes = 0;  ///< static + dynamic attribute layers
    std::uint64_t paddingBytes = 0;    ///< alignment gaps between sections and levels
    std::uint64_t bricks = 0;
    std::vector<std::uint64_t> bricksPerLevel;
    std::uint64_t staticVoxels = 0, dynamicVoxels = 0;  ///< records written
    bool binaryLevel0Opacity =
        false;  ///< level 0 was stored in the binary-opacity layout (kFlagBinaryLevel0Opacity)
};

/// Writes @p volume to @p file atomically (AtomicFile). The same volume and options give the same
/// bytes. Level 0 takes the binary-opacity layout when RvolWriteOptions::binaryLevel0Opacity
/// allows and the volume qualifies (see there). Each axis' A8 plane at levels ≥ 1 holds the mean
/// of its two channels' opacities (each clamped to [0, 1] first); they are equal for volumes the
/// bake produces, so a volume whose ± opacities differ reads back with both replaced by their mean.
/// Expects a consistent volume: depth ≤ kMaxDepth; levels[l] with resolution 2^(depth − l) and
/// levelChannels(l) channels, blocks strictly ascending and inside the level, texels sized blocks ×
/// channels × kBlockTexels; voxel attributes inside level 0 in strictly ascending Morton order;
/// origin finite, size finite and > 0. Texels of cells ≥ resolution are not stored.
/// @throws UsageError for bad options, std::invalid_argument for an inconsistent volume, IoError
/// if the file cannot be written.
RvolWriteResult writeRvol(const std::filesystem::path& file, const Volume& volume,
                          const RvolWriteOptions& options = {});

// ---- reading --------------------------------------------------------------------------------

/// An open .rvol file. The constructor reads and checks the header, the level table and the brick
/// directory (checksums, section sizes and offsets, brick coordinates in range and in strictly
/// ascending Morton order per level); bricks and attributes are read when asked for. Every
/// allocation is bounded by the file's size. Errors: IoError (2), InvalidDataError (3) naming the
/// file and the problem. Every const member function is thread-safe.
class RvolReader final : public RvolSampler {
public:
    explicit RvolReader(std::filesystem::path file);
    ~RvolReader() override;
    RvolReader(const RvolReader&) = delete;
    RvolReader& operator=(const RvolReader&) = delete;

    [[nodiscard]] const std::filesystem::path& path() const noexcept { return path_; }
    [[nodiscard]] const Header& header() const noexcept { return header_; }
    [[nodiscard]] std::uint32_t depth() const noexcept override { return header_.depth; }
    [[nodiscard]] const std::array<double, 3>& origin() const noexcept override {
        return header_.origin;
    }
    [[nodiscard]] double size() const noexcept override { return header_.size; }
    [[nodiscard]] const BakeInfo& bakeInfo() const noexcept override { return header_.bake; }
    [[nodiscard]] const std::vector<LevelEntry>& levels() const noexcept { return levels_; }
    [[nodiscard]] const LevelEntry& level(std::uint32_t level) const { return levels_.at(level); }
    /// Every directory entry, level 0's first.
    [[nodiscard]] std::span<const BrickEntry> directory() const noexcept { return directory_; }
    /// The directory entries of @p level, in ascending Morton order. @throws std::out_of_range.
    [[nodiscard]] std::span<const BrickEntry> bricks(std::uint32_t level) const;
    /// Index (within the level) of the brick at brick coordinates (x, y, z), or -1 if it is not
    /// stored (its texels are all zero). @throws std::out_of_range for a bad level.
    [[nodiscard]] std::int64_t findBrick(std::uint32_t level, std::uint32_t x, std::uint32_t y,
                                         std::uint32_t z) const;
    /// File offset of brick @p index of @p level: dataOffset plus the stored sizes of the level's
    /// bricks before it. @throws std::out_of_range for a bad level or index.
    [[nodiscard]] std::uint64_t brickOffset(std::uint32_t level, std::uint32_t index) const;
    /// Stored bytes of brick @p index of @p level (storedBrickBytes of its directory entry).
    [[nodiscard]] std::uint64_t storedBrickSize(std::uint32_t level, std::uint32_t index) const;

    /// The bytes of brick @p index of @p level as stored in the file, checksum verified.
    /// @throws std::out_of_range for a bad level or index, InvalidDataError on a checksum mismatch.
    [[nodiscard]] std::vector<std::uint8_t> readStoredBrick(std::uint32_t level,
                                                            std::uint32_t index) const;
    /// Brick @p index of @p level expanded to its dense planes (denseBrickBytes of them, the
    /// layout of brickBytes(): what a GPU uploads), checksum verified. @throws std::out_of_range
    /// for a bad level or index, InvalidDataError on a checksum mismatch or a stored brick that
    /// does not match its directory entry.
    [[nodiscard]] std::vector<std::uint8_t> readBrickBytes(std::uint32_t level,
                                                           std::uint32_t index) const;
    /// Brick @p index of @p level decoded: channels × N³ texels, channel-major, then z, y, x
    /// (x fastest); texel (i, j, k) is cell (bx·(N−1) + i, by·(N−1) + j, bz·(N−1) + k). Each
    /// channel's opacity comes from its axis' A8 plane, so ± channels read the same opacity; at
    /// level 0 of a binary-opacity file it is 1 for a non-zero RGB9E5 word, 0 for word 0.
    [[nodiscard]] std::vector<Texel> readBrick(std::uint32_t level, std::uint32_t index) const;

    /// Trilinear sample of @p channel of @p level at world position @p position, as a GPU's
    /// filter over the node-centred bricks gives it: u = (p − origin)/cellSize − 0.5 per axis,
    /// clamped to [0, resolution − 1]; brick min(⌊u/(N−1)⌋, bricksPerAxis − 1); the 8 texels
    /// around u in that brick, zero if the brick is not stored. Decoded bricks are cached (see
    /// setCacheBytes). @throws std::out_of_range for a bad level or channel, InvalidDataError if
    /// a brick read fails its checksum.
    [[nodiscard]] Texel sample(std::uint32_t level, std::uint32_t channel,
                               const std::array<double, 3>& position) const override;
    /// What a cone travelling along @p direction sees at @p position: Σ over the axes s of
    /// d_s²/|d|² × sample of the channel of s with d_s's sign (PosX for d_x > 0, NegX for d_x < 0;
    /// the directional convention of rvol.h). Level 0: the isotropic channel. A zero or
    /// non-finite @p direction gives zero at levels ≥ 1.
    [[nodiscard]] Texel sampleDirectional(std::uint32_t level,
                                          const std::array<double, 3>& position,
                                          const std::array<double, 3>& direction) const override;
    /// Bytes of decoded bricks kept for sample() (least recently used go first); 64 MiB by default.
    void setCacheBytes(std::uint64_t bytes) const;

    /// The static (@p dynamic false) or dynamic attribute layer, decoded, checksum verified.
    /// @throws InvalidDataError on a checksum mismatch.
    [[nodiscard]] std::vector<VoxelAttributes> readAttributes(bool dynamic) const;
    /// The layer's records as stored (checksum verified).
    [[nodiscard]] std::vector<AttributeRecord> readAttributeRecords(bool dynamic) const;

    /// The whole file as a Volume: every level's cells from the decoded bricks (blocks are the 8³
    /// blocks holding a non-zero texel), both attribute layers, the header's geometry and bake
    /// info. Equal to the written volume up to the encodings' precision.
    [[nodiscard]] Volume readVolume() const;

    /// Reads @p size bytes at file offset @p offset (inside the file). @throws InvalidDataError
    /// if the file ends early, IoError on a read error.
    void readBytes(std::uint64_t offset, std::uint8_t* out, std::uint64_t size) const;

private:
    struct Cache;
    [[nodiscard]] std::shared_ptr<const std::vector<Texel>> cachedBrick(std::uint32_t level,
                                                                        std::uint32_t index) const;

    std::filesystem::path path_;
    std::unique_ptr<vox::ReadOnlyFile> file_;  // opened by the constructor, never null
    Header header_;
    std::vector<LevelEntry> levels_;
    std::vector<BrickEntry> directory_;
    std::vector<std::uint64_t> brickOffsets_;  // per directory entry: file offset of its brick
    std::unique_ptr<Cache> cache_;
};

/// A brick in its stored form: the occupancy mask and the planes that are not all zero.
struct PackedBrick {
    std::vector<std::uint8_t> bytes;  ///< storedBrickBytes(N, …) bytes
    std::uint16_t planes = 0;         ///< BrickEntry::planes
    std::uint32_t texels = 0;         ///< BrickEntry::texels; 0: the brick is all zero
};
/// Packs a brick's dense planes (brickBytes(@p brickTexels, @p channels, @p binaryOpacity) bytes)
/// into its stored form: the mask holds the texels with a non-zero byte in some plane, a plane is
/// stored if one of its bytes is non-zero, each stored plane holds the mask's texels in texel
/// order. A8 plane padding is not stored (it must be zero). texels = 0 for an all-zero brick.
/// @throws std::invalid_argument for a bad size or channel count.
[[nodiscard]] PackedBrick packBrick(std::span<const std::uint8_t> dense, std::uint32_t brickTexels,
                                    std::uint32_t channels, bool binaryOpacity = false);
/// The inverse of packBrick: the dense planes of a stored brick whose directory entry has
/// @p planes and @p texels. Only checks what it needs to stay in bounds and exact: the size
/// (storedBrickBytes), plane bits of planes the level has, the mask's bit count equal to
/// @p texels and its bits past N³ zero. @throws std::invalid_argument otherwise.
[[nodiscard]] std::vector<std::uint8_t> expandBrick(std::span<const std::uint8_t> stored,
                                                    std::uint32_t brickTexels,
                                                    std::uint32_t channels, bool binaryOpacity,
                                                    std::uint16_t planes, std::uint32_t texels);

/// Decodes the @p channels × N³ texels of a brick's dense bytes (readBrick's order), channel c's
/// opacity from A8 plane alphaPlaneOf(c); with @p binaryOpacity (the file's
/// kFlagBinaryLevel0Opacity) a level-0 brick (1 channel) has no A8 plane and a texel's opacity is
/// 1 where its RGB9E5 word is not 0, else 0 (the word decoded as usual: kSolidBlackWord gives
/// (2^-24, 0, 0)). @p binaryOpacity does not change 6-channel bricks.
/// @throws std::invalid_argument if @p channels is neither 1 nor kDirections, or @p bytes is not
/// brickBytes(@p brickTexels, @p channels, @p binaryOpacity) long.
[[nodiscard]] std::vector<Texel> decodeBrick(std::span<const std::uint8_t> bytes,
                                             std::uint32_t brickTexels, std::uint32_t channels,
                                             bool binaryOpacity = false);

// ---- validation -----------------------------------------------------------------------------

/// What validateRvol found. The byte counts add up to fileBytes.
struct RvolReport {
    std::uint64_t fileBytes = 0;
    std::uint64_t headerBytes = 0, levelTableBytes = 0, directoryBytes = 0;
    std::uint64_t radianceBytes = 0;  ///< brick data
    std::uint64_t staticAttributeBytes = 0, dynamicAttributeBytes = 0;
    std::uint64_t paddingBytes = 0;  ///< alignment gaps (all zero)
    std::uint64_t bricks = 0;
    std::vector<std::uint64_t> bricksPerLevel;
    std::vector<std::uint64_t>
        nonZeroTexelsPerLevel;  ///< distinct cells with a non-zero texel in any channel
    std::uint64_t staticVoxels = 0, dynamicVoxels = 0;
};

/// Reads and checks every brick and attribute record of an open file: brick checksums, no stored
/// brick all zero (in the binary-opacity layout: a non-zero word), zero texels for cells outside
/// the level, zero A8 plane padding, equal shared faces between neighbouring bricks (and zero faces
/// towards bricks that are not stored), attribute checksums, Morton codes strictly ascending and
/// inside level 0, zero gaps between sections.
/// @throws InvalidDataError "FILE: where: what" at the first problem.
RvolReport validateRvol(const RvolReader& reader);

}  // namespace vox::rvol
