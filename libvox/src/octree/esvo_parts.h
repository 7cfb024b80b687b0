// Part files (docs/esvo-part-format.md): what one run of a partitioned build (voxelize
// --partition K/N) makes, for `voxelize merge` to join into the .esvo file the whole build makes:
// the run's partition roots as the top needs them and the laid-out slices of its partitions.
#pragma once

#include "esvo_assemble.h"

#include <vox/formats/esvo.h>
#include <vox/formats/read_only_file.h>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <vector>

namespace vox::detail {

/// One part file's contents; the slices' blocks are in a SliceStore.
struct EsvoPart {
    std::filesystem::path path;  ///< where it was read from
    std::uint32_t runIndex = 0, runCount = 1;
    std::uint32_t partitionLevel = 0;
    std::uint32_t partitionsTotal = 0;  ///< partitions of the whole build (binned, in Morton order)
    std::uint32_t firstPartition = 0;   ///< the run's first, as an index into them
    std::uint32_t partitionsInRun = 0;
    std::uint64_t fingerprint =
        0;                ///< of the build: scene, options and partitions (buildFingerprint)
    esvo::Header header;  ///< the merged file's, but for its slices, directory and size
    AttributeEffort attributeEffort =
        AttributeEffort::Default;         ///< for the top's compressed blocks
    std::vector<PartitionRoot> roots;     ///< the run's occupied partitions, in Morton order
    std::vector<PartitionSlices> slices;  ///< per root (empty where it has no slices)
};

/// Writes @p part atomically, the blocks read from @p store; returns the file's size.
std::uint64_t writeEsvoPart(const std::filesystem::path& file, const EsvoPart& part,
                            const SliceStore& store);

/// Reads and checks a part file; its blocks stay in the file, registered in @p store (and
/// checked against their checksums when read). @throws InvalidDataError "FILE: problem" for a
/// file that is not a sound part file, IoError.
[[nodiscard]] EsvoPart readEsvoPart(const std::filesystem::path& file, SliceStore& store);

/// 64-bit FNV-1a: a fingerprint, not a checksum (part files are checked by CRC-32C).
[[nodiscard]] std::uint64_t fnv1a64(const void* data, std::size_t size,
                                    std::uint64_t hash = 0xCBF29CE484222325ull) noexcept;

}  // namespace vox::detail
