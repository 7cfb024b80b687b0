/// @file esvo_reader.h
/// @brief Reading .esvo files: the header and slice directory up front, any slice on demand,
/// structural validation of blocks, and the CPU-side pool that streams slices into one
/// 8 KB-aligned arena the way a GPU runtime does.
#pragma once

#include <vox/formats/esvo.h>
#include <vox/formats/esvo_attributes.h>

#include <cstdio>
#include <functional>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <vector>

namespace vox {
class ReadOnlyFile;  // vox/formats/read_only_file.h
}  // namespace vox

namespace vox::esvo {

/// An open .esvo file. The constructor reads and checks the header and the directory (checksums,
/// tree shape, offsets and sizes within the file); slices are read only when asked for. Every
/// allocation is bounded by the file's size. Errors: IoError (2), InvalidDataError (3) naming the
/// file and the problem.
class EsvoReader {
public:
    explicit EsvoReader(std::filesystem::path file);
    ~EsvoReader();
    EsvoReader(const EsvoReader&) = delete;
    EsvoReader& operator=(const EsvoReader&) = delete;

    [[nodiscard]] const std::filesystem::path& path() const noexcept { return path_; }
    [[nodiscard]] const Header& header() const noexcept { return header_; }
    [[nodiscard]] const Directory& directory() const noexcept { return directory_; }
    [[nodiscard]] const SliceEntry& slice(std::uint32_t index) const {
        return directory_.slices.at(index);
    }
    [[nodiscard]] std::uint32_t sliceCount() const noexcept {
        return static_cast<std::uint32_t>(directory_.slices.size());
    }

    /// Reads slice @p index into @p destination (exactly slice(index).byteSize bytes) with one
    /// read and verifies its checksum. Thread-safe.
    void readSlice(std::uint32_t index, std::span<std::uint8_t> destination) const;
    [[nodiscard]] std::vector<std::uint8_t> readSlice(std::uint32_t index) const;

private:
    std::filesystem::path path_;
    std::unique_ptr<vox::ReadOnlyFile> file_;  // opened by the constructor, never null
    Header header_;
    Directory directory_;
};

/// Where a descriptor's voxel is: level and integer cube coordinates at that level.
struct VoxelPosition {
    std::uint32_t level = 0;
    std::uint32_t x = 0, y = 0, z = 0;
    [[nodiscard]] VoxelPosition child(std::uint32_t slot) const noexcept {
        return {level + 1, 2 * x + (slot & 1u), 2 * y + ((slot >> 1) & 1u),
                2 * z + ((slot >> 2) & 1u)};
    }
    friend bool operator==(const VoxelPosition&, const VoxelPosition&) = default;
};

/// A descriptor whose non-leaf children live in child slices (its far slot is 0 in the file).
struct FrontierDescriptor {
    std::uint32_t nonLeafMask = 0;
    VoxelPosition position;
};

/// What validating one block found, for checking its child slices.
struct BlockSummary {
    std::vector<FrontierDescriptor> frontier;     ///< in frontier-table order
    std::vector<std::uint64_t> voxelsPerLevel;    ///< voxels this block holds, by level
    std::vector<std::uint64_t> leavesPerLevel;    ///< of them, voxels without children
    std::vector<std::uint64_t> contoursPerLevel;  ///< of them, voxels with a contour of their own
    std::uint64_t descriptorBytes = 0, farPointerBytes = 0, pageHeaderBytes = 0, infoBytes = 0,
                  paddingBytes = 0, contourBytes = 0;
    /// Attribute attachment: lookup words (uncompressed), stored values, compressed blocks.
    std::uint64_t attributeLookupBytes = 0, attributeValueBytes = 0, attributeBlockBytes = 0;
};

/// Word offsets inside a block, read from its info section (after validateBlock has passed).
struct BlockTables {
    std::uint32_t infoWord = 0;
    std::uint32_t rootGroupCount = 0, rootGroupTableWord = 0;
    std::uint32_t frontierCount = 0, frontierTableWord = 0;
    std::uint32_t descriptorEndWord =
        0;  ///< end of the descriptor area: the first attachment, or the info section
    std::uint32_t contourWord =
        0;  ///< start of the contour array; descriptorEndWord when there is none
    std::uint32_t contourEndWord = 0;
    /// The colour/normal attachment: AttachmentKind::Palette, Dxt or DxtLookup, or Contour when
    /// there is none.
    AttachmentKind attributeKind = AttachmentKind::Contour;
    std::uint32_t attributeWord = 0, attributeEndWord = 0;
    [[nodiscard]] bool hasAttributes() const noexcept {
        return attributeKind != AttachmentKind::Contour;
    }
};
/// Reads the tables' location from a block; throws InvalidDataError if they are out of range,
/// naming the slice, the byte in it and, when @p fileOffset (the slice's) is given, the file
/// offset.
[[nodiscard]] BlockTables readBlockTables(std::span<const std::uint8_t> block,
                                          const std::filesystem::path& file,
                                          std::uint32_t sliceIndex,
                                          std::optional<std::uint64_t> fileOffset = std::nullopt);

/// Checks every structural invariant of one slice's block: page headers at every 8 KB boundary
/// pointing at the info section, info section and tables, masks, child and far pointers in range
/// and not overlapping, sibling groups not straddling pages, zero padding, descriptor/far/voxel
/// counts equal to the directory's, and the root groups matching the parent's frontier
/// descriptors @p parents (for the root slice: one entry, mask 1, at level 0). Throws
/// InvalidDataError "FILE: slice S, byte B: what".
BlockSummary validateBlock(const std::filesystem::path& file, const Header& header,
                           std::uint32_t sliceIndex, const SliceEntry& entry,
                           std::span<const std::uint8_t> block,
                           std::span<const FrontierDescriptor> parents);

/// Per-part byte totals over a whole file, and its leaves and contours by level (voxinspect info).
struct FileBreakdown {
    std::uint64_t descriptorBytes = 0, farPointerBytes = 0, pageHeaderBytes = 0, infoBytes = 0,
                  paddingBytes = 0, contourBytes = 0, attributeLookupBytes = 0,
                  attributeValueBytes = 0, attributeBlockBytes = 0, headerAndDirectoryBytes = 0,
                  slicePaddingBytes = 0;
    std::vector<std::uint64_t> leavesPerLevel;  ///< voxels without children, levels 0 … leaf depth
    std::vector<std::uint64_t>
        contoursPerLevel;  ///< voxels with a contour of their own, levels 0 … leaf depth
};

/// Validates the whole file: header, directory, every slice and the links between slices.
/// Returns the byte breakdown. Throws InvalidDataError at the first violation.
FileBreakdown validateFile(const EsvoReader& reader);

/// The CPU-side runtime: one arena of 32-bit words holding loaded slices as blocks, each 8 KB
/// aligned, linked through the far pointer slots of their parents' frontier descriptors. This is
/// what the reference ray caster walks; the GPU runtime mirrors it.
class EsvoPool {
public:
    /// Loads the root slice.
    explicit EsvoPool(const EsvoReader& reader);

    [[nodiscard]] const EsvoReader& reader() const noexcept { return reader_; }
    [[nodiscard]] bool loaded(std::uint32_t slice) const {
        return slices_.at(slice).baseWord != kNotLoaded;
    }
    /// Loads @p slice (its parent must be loaded), validating it, and links it in.
    void load(std::uint32_t slice);
    /// Unlinks and frees @p slice and everything loaded below it. The root slice stays.
    void unload(std::uint32_t slice);
    /// Loads every slice whose first level is below @p level (all slices by default).
    void loadAll(std::uint32_t level = 0xFFFFFFFFu);

    [[nodiscard]] const std::uint32_t* words() const noexcept { return arena_.data(); }
    [[nodiscard]] std::size_t wordCount() const noexcept { return arena_.size(); }
    /// Word index of the root descriptor.
    [[nodiscard]] std::uint32_t rootDescriptorWord() const noexcept { return rootWord_; }
    [[nodiscard]] std::uint64_t residentBytes() const noexcept { return residentBytes_; }
    /// Visits every voxel below the root that the loaded slices hold, depth first in slot order,
    /// with its colour and normal resolved: its own stored value, else the nearest ancestor's
    /// (nullptr before any ancestor has one, e.g. in a file without colours).
    void forEachVoxel(
        const std::function<void(const VoxelPosition&, const AttributeValue*)>& visit) const;
    [[nodiscard]] std::uint32_t loadedSliceCount() const noexcept { return loadedCount_; }

private:
    static constexpr std::uint32_t kNotLoaded = 0xFFFFFFFFu;
    struct Resident {
        std::uint32_t baseWord = kNotLoaded;
        std::uint32_t pages = 0;
        BlockTables tables;
        std::vector<FrontierDescriptor> frontier;
    };
    std::uint32_t allocatePages(std::uint32_t pages);
    void freePages(std::uint32_t firstPage, std::uint32_t pages);
    void link(std::uint32_t slice, bool attach);

    const EsvoReader& reader_;
    std::vector<std::uint32_t> arena_;
    std::vector<std::pair<std::uint32_t, std::uint32_t>> freeRuns_;  // (first page, pages)
    std::vector<Resident> slices_;
    std::uint32_t rootWord_ = 0;
    std::uint64_t residentBytes_ = 0;
    std::uint32_t loadedCount_ = 0;
};

}  // namespace vox::esvo
