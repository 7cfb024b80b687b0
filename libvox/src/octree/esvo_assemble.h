// Assembling an .esvo file from laid-out slices: the slices of each partition (laid out one
// partition at a time, possibly by other processes) and those of the top above them are linked
// into one slice tree, numbered breadth-first for the directory and written with their offsets,
// slice ids and checksums (docs/esvo-format.md §6-§7). Slices wait in a SliceStore: in memory up
// to a budget, then in a scratch file, or in the part files they were read from.
#pragma once

#include "esvo_layout.h"
#include "voxel_attributes.h"

#include <vox/formats/esvo.h>
#include <vox/formats/read_only_file.h>
#include <vox/formats/scratch_file.h>
#include <vox/octree.h>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>
#include <vector>

namespace vox::detail {

/// Where blocks wait until they are written: in memory while they fit @p memoryBudget, then in a
/// scratch file in @p scratchDirectory, or in a file they already lie in (a part file).
class SliceStore {
public:
    /// A block's place: memory block `offset` (`file` = kMemory), byte `offset` of the scratch
    /// file (kScratch), or byte `offset` of the store's external file number `file` (≥ 0).
    struct Location {
        std::int32_t file = -1;
        std::uint64_t offset = 0;
        std::uint64_t bytes = 0;
        std::uint32_t checksum = 0;  ///< an external block's CRC-32C, checked when it is read
    };
    static constexpr std::int32_t kMemory = -1, kScratch = -2;

    SliceStore(std::uint64_t memoryBudget, std::filesystem::path scratchDirectory);

    /// Takes a block. Thread-safe.
    Location add(std::vector<std::uint64_t>&& units);
    /// A block of @p bytes at @p offset in @p file (kept open by the store), whose CRC-32C is
    /// @p checksum.
    Location external(const std::shared_ptr<const ReadOnlyFile>& file, std::uint64_t offset,
                      std::uint64_t bytes, std::uint32_t checksum);
    /// Reads a block into @p out (resized to its units). @throws InvalidDataError if an
    /// external block does not match its checksum.
    void read(const Location& where, std::vector<std::uint64_t>& out) const;

    [[nodiscard]] std::uint64_t memoryBytes() const noexcept { return memoryBytes_; }
    [[nodiscard]] std::uint64_t scratchBytes() const noexcept {
        return scratch_ ? scratch_->size() : 0;
    }

private:
    std::uint64_t memoryBudget_;
    std::filesystem::path scratchDirectory_;
    std::uint64_t memoryBytes_ = 0;
    std::vector<std::vector<std::uint64_t>> memory_;
    std::unique_ptr<ScratchFile> scratch_;
    std::vector<std::shared_ptr<const ReadOnlyFile>> files_;
    mutable std::mutex mutex_;
};

/// A slice on its way into the file, in the file's levels and paths.
struct SliceRecord {
    std::uint32_t regionLevel = 0;
    std::uint64_t regionPath = 0;           ///< Morton path of the region voxel from the root
    std::uint32_t parent = esvo::kNoSlice;  ///< record index
    std::vector<std::uint32_t> children;    ///< record indices, in frontier order
    std::uint32_t infoWord = 0;
    std::uint32_t firstLevel = 0, endLevel = 0;
    std::uint32_t rootGroups = 0, descriptors = 0, farSlots = 0, frontier = 0;
    std::uint64_t voxels = 0;
    SliceStore::Location block;
    /// The top's place for the partition below the voxel at regionLevel, regionPath (no block).
    bool partition = false;
};

/// The slices of one partition (or of a whole file laid out from its root), in the file's
/// levels and paths; the first is the partition's root slice (or the file's).
struct PartitionSlices {
    std::uint32_t level = 0;          ///< the partition voxel's level (0: the whole file)
    std::uint64_t path = 0;           ///< its Morton path
    std::vector<SliceRecord> slices;  ///< parents and children index this list
};

/// Moves @p slices (laid out from a view whose root is the voxel at @p level, @p path) into
/// @p store, as records in the file's levels and paths.
[[nodiscard]] PartitionSlices storeSlices(std::vector<LaidOutSlice>&& slices, std::uint32_t level,
                                          std::uint64_t path, SliceStore& store);

/// What goes into the file besides the slices.
struct EsvoFileInfo {
    esvo::Header header;  ///< everything but the slice count, directory and file size
    std::vector<std::uint64_t> voxelsPerLevel;
};

/// The partition level @p requested (EsvoWriteOptions::partitionLevel) resolves to for
/// @p leafDepth. @throws UsageError if it is not below the leaf depth.
[[nodiscard]] std::uint32_t resolvePartitionLevel(std::int32_t requested, std::uint32_t leafDepth);

/// The header fields of a file with @p octree's cube and leaf depth (all but the slice count,
/// directory and file size). @throws UsageError for bad slice or pointer limits.
[[nodiscard]] esvo::Header esvoHeader(const RootCube& cube, std::uint32_t leafDepth, bool contours,
                                      bool attributes, const EsvoWriteOptions& options);

/// The layout options for a view of an octree with or without attributes.
[[nodiscard]] SliceLayoutOptions sliceLayoutOptions(const EsvoWriteOptions& options,
                                                    bool attributes, bool fileRoot);

/// A partition's root voxel as the top sees it: what its descriptor in the top needs.
struct PartitionRoot {
    std::uint32_t code = 0;    ///< Morton code at the partition level
    std::uint8_t mask = 0;     ///< valid mask
    std::uint8_t nonLeaf = 0;  ///< non-leaf mask: 0 if the partition has no slices
    std::vector<std::uint32_t>
        childContours;  ///< its children's, popc8(mask) of them (no contours: empty)
    std::vector<std::uint64_t>
        childAttributes;  ///< its children's, popc8(mask) of them (no attributes: empty)
    AttributeSums sums;   ///< with attributes: its own
    std::vector<std::uint64_t> voxelsPerLevel;  ///< the partition's, from its root's level down
};

/// The levels of a partitioned octree from the root down to the partition level, and the
/// partition roots' children's contours and attributes, as a view for layoutSlices.
struct TopTree {
    std::uint32_t partitionLevel = 0;
    std::vector<std::vector<std::uint8_t>> masks;  ///< levels 0 … partition level
    std::vector<std::vector<std::uint32_t>>
        contours;  ///< levels 0 … partition level + 1 (no contours: empty)
    std::vector<std::vector<std::uint64_t>>
        attributes;                     ///< levels 0 … partition level + 1 (no attributes: empty)
    std::vector<std::uint8_t> nonLeaf;  ///< per voxel of the partition level
    std::vector<std::uint64_t> voxelsPerLevel;  ///< levels 0 … partition level

    [[nodiscard]] OctreeView view() const;
};

/// The top over @p roots (all of the octree's, in Morton order): the levels above the
/// partition level as the voxelizer's tree reduction gives them (no contours; attributes
/// packed from the sums).
[[nodiscard]] TopTree buildTop(const std::vector<PartitionRoot>& roots,
                               std::uint32_t partitionLevel, bool contours, bool attributes);

/// Links the top (null when the file is one partition laid out from its root) with its
/// partitions, numbers the slices breadth-first and writes the file atomically.
/// @throws std::logic_error if a partition the top refers to is missing, IoError on I/O.
EsvoWriteResult assembleEsvo(const std::filesystem::path& file, const EsvoFileInfo& info,
                             const PartitionSlices* top, std::vector<PartitionSlices>&& partitions,
                             const SliceStore& store, Timings* timings);

}  // namespace vox::detail
