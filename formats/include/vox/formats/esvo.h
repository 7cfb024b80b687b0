/// @file esvo.h
/// @brief The .esvo sparse voxel octree format (docs/esvo-format.md): the bit layout of child
/// descriptors, page headers and info sections shared by every block, and the file's header and
/// slice directory. All multi-byte values are little-endian.
#pragma once

#include <vox/formats/checksum.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <vector>

namespace vox::esvo {

// ---- constants ------------------------------------------------------------------------------

inline constexpr std::array<std::uint8_t, 8> kMagic{0x89, 'E', 'S', 'V', 'O', '\r', '\n', 0x1A};
inline constexpr std::uint16_t kVersionMajor = 1;  ///< readers reject other majors
inline constexpr std::uint16_t kVersionMinor = 0;  ///< readers accept any minor of their major
inline constexpr std::uint32_t kHeaderBytes = 256;
inline constexpr std::uint32_t kDirectoryEntryBytes = 64;
inline constexpr std::uint32_t kSliceAlignment = 64;  ///< file offset alignment of slices
inline constexpr std::uint32_t kPageBytes = 8192;     ///< page size; blocks load 8 KB aligned
inline constexpr std::uint32_t kPageHeaderBytes = 8;
inline constexpr std::uint32_t kMaxLeafDepth = 20;  ///< the ray caster's float positions allow 22
inline constexpr std::uint32_t kNearPointerMax = 0x7FFF;  ///< 15-bit child pointer
inline constexpr std::uint32_t kMinSliceBytes = 2 * kPageBytes;
inline constexpr std::uint32_t kDefaultSliceBytes = 1u << 20;
inline constexpr std::uint32_t kNoSlice = 0xFFFFFFFFu;

/// Attachment kinds (the original release's set); a bit per kind in Header::attachmentKinds.
enum class AttachmentKind : std::uint32_t {
    Contour = 0,
    Palette = 1,  ///< uncompressed colour + normal
    Dxt = 2,      ///< compressed colour + normal, a block per pair of sibling descriptors
    Corner = 3,
    AmbientOcclusion = 4,
    BuildData = 5,
    /// Compressed colour + normal behind a lookup entry per descriptor: Laine & Karras 5.7's
    /// "combined indirect attribute lookup" (libvox's addition; not in the original release).
    DxtLookup = 6,
};

/// The attachment kinds that hold colours and normals (at most one per file).
inline constexpr std::uint32_t kAttributeKindBits = (1u << 1) | (1u << 2) | (1u << 6);

// ---- child descriptors ----------------------------------------------------------------------

/// A 64-bit child descriptor as two 32-bit words (esvo-layout: word 0 topology, word 1 contours).
struct ChildDescriptor {
    std::uint32_t topology =
        0;  ///< bits 0-7 non-leaf mask, 8-15 valid mask, 16 far, 17-31 child pointer
    std::uint32_t contour = 0;  ///< bits 0-7 contour mask, 8-31 contour pointer

    [[nodiscard]] constexpr std::uint32_t nonLeafMask() const noexcept { return topology & 0xFFu; }
    [[nodiscard]] constexpr std::uint32_t validMask() const noexcept {
        return (topology >> 8) & 0xFFu;
    }
    [[nodiscard]] constexpr bool far() const noexcept { return (topology >> 16) & 1u; }
    [[nodiscard]] constexpr std::uint32_t childPointer() const noexcept { return topology >> 17; }
    [[nodiscard]] constexpr std::uint32_t contourMask() const noexcept { return contour & 0xFFu; }
    /// 32-bit words from this descriptor's first word to the contour of its first child with one.
    [[nodiscard]] constexpr std::uint32_t contourPointer() const noexcept { return contour >> 8; }

    [[nodiscard]] static constexpr ChildDescriptor make(std::uint32_t validMask,
                                                        std::uint32_t nonLeafMask,
                                                        std::uint32_t childPointer,
                                                        bool far) noexcept {
        return {(childPointer << 17) | (far ? 1u << 16 : 0u) | ((validMask & 0xFFu) << 8) |
                    (nonLeafMask & 0xFFu),
                0};
    }
};

/// A contour (esvo-layout, "Contour"): the slab |n·u − position·0.75| ≤ thickness·0.75/2 in the
/// voxel's local coordinates u ∈ [−0.5, 0.5]³, n an integer vector whose largest component is ±31.
struct Contour {
    int nx = 0, ny = 0, nz = 0;  ///< 6-bit signed each
    int position = 0;            ///< 7-bit signed, steps of 0.75
    unsigned thickness = 0;      ///< 7-bit unsigned, steps of 0.75

    [[nodiscard]] static constexpr Contour decode(std::uint32_t v) noexcept {
        const auto field = [v](int shift, int bits) {
            // Sign-extend a bit field by shifting it to the top and back.
            return static_cast<int>(static_cast<std::int32_t>(v << (32 - shift - bits)) >>
                                    (32 - bits));
        };
        return {field(12, 6), field(6, 6), field(0, 6), field(18, 7), v >> 25};
    }
    [[nodiscard]] constexpr std::uint32_t encode() const noexcept {
        return (thickness << 25) | ((static_cast<std::uint32_t>(position) & 0x7Fu) << 18) |
               ((static_cast<std::uint32_t>(nx) & 0x3Fu) << 12) |
               ((static_cast<std::uint32_t>(ny) & 0x3Fu) << 6) |
               (static_cast<std::uint32_t>(nz) & 0x3Fu);
    }
    static constexpr double kStep = 0.75;
};

/// Number of set bits in the low 8 bits.
[[nodiscard]] constexpr std::uint32_t popc8(std::uint32_t mask) noexcept {
    // Bit arithmetic rather than __builtin_popcount: without -mpopcnt (baseline x86-64) that is a
    // call into libgcc, in the ray caster's innermost loop.
    mask &= 0xFFu;
    mask -= (mask >> 1) & 0x55u;
    mask = (mask & 0x33u) + ((mask >> 2) & 0x33u);
    return (mask + (mask >> 4)) & 0x0Fu;
}

// ---- info section ---------------------------------------------------------------------------

/// Word offsets inside a block's info section (docs/esvo-format.md, "Info section").
namespace info {
inline constexpr std::uint32_t kSliceId = 0;
inline constexpr std::uint32_t kBlockIndex = 1;
inline constexpr std::uint32_t kFirstDescriptor =
    2;  ///< signed, words, relative to the info section
inline constexpr std::uint32_t kAttachmentCount = 3;
inline constexpr std::uint32_t kAttachments =
    4;  ///< attachmentCount × (kind, signed relative words)
/// After the attachment directory: root group count, root group table (relative words),
/// frontier count, frontier table (relative words).
[[nodiscard]] constexpr std::uint32_t tablesWord(std::uint32_t attachmentCount) noexcept {
    return kAttachments + 2 * attachmentCount;
}
inline constexpr std::uint32_t kTablesWords = 4;
}  // namespace info

// ---- header and directory -------------------------------------------------------------------

/// The 256-byte file header (docs/esvo-format.md, "Header").
struct Header {
    std::uint16_t versionMajor = kVersionMajor;
    std::uint16_t versionMinor = kVersionMinor;
    /// Row-major affine 4×4 matrix taking world coordinates to the root cube [0,1]³.
    std::array<double, 16> worldToRoot{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    std::array<double, 3> sceneBoundsMin{0, 0, 0};
    std::array<double, 3> sceneBoundsMax{0, 0, 0};
    std::uint32_t leafDepth = 0;
    std::uint32_t attachmentKinds = 0;  ///< bit k: AttachmentKind k present
    std::uint32_t sliceBytesLimit = kDefaultSliceBytes;
    std::uint32_t nearPointerLimit =
        kNearPointerMax;  ///< largest near child pointer the build used
    std::uint32_t buildFlags = 0;
    std::uint32_t sliceCount = 0;
    std::uint64_t directoryOffset = 0;
    std::uint64_t directoryBytes = 0;
    std::uint32_t directoryChecksum = 0;
    std::uint64_t fileBytes = 0;

    [[nodiscard]] bool hasAttributes() const noexcept {
        return (attachmentKinds & kAttributeKindBits) != 0;
    }
};

/// One slice in the directory (docs/esvo-format.md, "Slice directory").
struct SliceEntry {
    std::uint64_t fileOffset = 0;
    std::uint32_t byteSize = 0;
    std::uint32_t checksum = 0;  ///< CRC-32C of the slice's bytes
    std::uint32_t parent = kNoSlice;
    std::uint32_t firstChild = 0;
    std::uint32_t childCount = 0;
    std::uint8_t regionLevel = 0;  ///< level of the cube the slice covers
    std::uint8_t firstLevel = 0;   ///< level of the slice's first descriptors
    std::uint8_t endLevel = 0;     ///< one past the level of its last descriptors
    std::uint8_t pathLevels = 0;   ///< regionLevel − parent's regionLevel
    std::uint64_t regionPath =
        0;  ///< octants from the parent's region, 3 bits per level, first step highest
    std::uint32_t firstFrontier =
        0;  ///< first entry of the parent's frontier table this slice resolves
    std::uint32_t rootGroupCount = 0;  ///< number of those entries (= root groups in this slice)
    std::uint32_t descriptorCount = 0;
    std::uint32_t farPointerCount = 0;  ///< far pointer slots, frontier slots included
    std::uint64_t voxelCount = 0;       ///< voxels at levels firstLevel+1 … endLevel in the slice
};

/// Header + directory as a reader holds them in memory.
struct Directory {
    std::vector<std::uint64_t> voxelsPerLevel;  ///< leafDepth + 1 entries, level 0 (the root) first
    std::vector<SliceEntry> slices;             ///< slices[0] is the root slice
};

/// CRC-32C (Castagnoli), as used for every checksum in the file (checksum.h).
using vox::crc32c;

/// Serialises the header (with its checksum) into 256 bytes.
[[nodiscard]] std::array<std::uint8_t, kHeaderBytes> encodeHeader(const Header& header);
/// Serialises the directory: per-level voxel counts, then the slice entries.
[[nodiscard]] std::vector<std::uint8_t> encodeDirectory(const Directory& directory);
/// Byte size of the directory for @p leafDepth and @p sliceCount.
[[nodiscard]] constexpr std::uint64_t directoryBytes(std::uint32_t leafDepth,
                                                     std::uint32_t sliceCount) noexcept {
    return 8ull * (leafDepth + 1) + std::uint64_t{kDirectoryEntryBytes} * sliceCount;
}

// ---- little-endian access -------------------------------------------------------------------

template <typename T>
[[nodiscard]] inline T load(const std::uint8_t* p) noexcept {
    T value;
    std::memcpy(&value, p,
                sizeof value);  // the format is little-endian, as is every supported host
    return value;
}
template <typename T>
inline void store(std::uint8_t* p, T value) noexcept {
    std::memcpy(p, &value, sizeof value);
}
static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
              "libvox's formats assume a little-endian host");

}  // namespace vox::esvo
