// Single-byte flips of an .esvo or .rvol file, each validated as `voxinspect validate` does it
// (issue 10): shared by tests/test_byte_flip and bench/byte_flip_sweep. Needs only vox::formats.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace vox::test {

using ByteRanges = std::vector<std::pair<std::uint64_t, std::uint64_t>>;  // [begin, end)

/// A part of a file to flip bytes in.
struct FlipRegion {
    std::string name;
    ByteRanges ranges;  // the bytes of the region
    ByteRanges
        units;  // slices / bricks / attribute layers: their first and last bytes are always flipped
    bool everyByte = false;  // header and directory: every byte, not a sample
};

struct FlipRegionOptions {
    /// One region "data" for all data units; otherwise .esvo "slices", .rvol "bricks" and
    /// "attributes".
    bool oneDataRegion = false;
    /// A last region "gaps": the bytes no other region covers (alignment padding). Readers need not
    /// check them (docs/esvo-format.md), so flips there may go undetected.
    bool gaps = false;
};

/// True for an .rvol (by its extension); otherwise an .esvo.
[[nodiscard]] bool isRvol(const std::filesystem::path& file);

/// What `voxinspect validate` runs: the reader's constructor, then esvo::validateFile or
/// rvol::validateRvol. Throws vox::Error on a damaged file.
void validateFlipTarget(const std::filesystem::path& file);

/// The regions of @p file: header, directory (the .rvol level table included), the data units,
/// and optionally the gaps between them.
[[nodiscard]] std::vector<FlipRegion> flipRegionsOf(const std::filesystem::path& file,
                                                    const FlipRegionOptions& options = {});

/// The number of bytes of @p region.
[[nodiscard]] std::uint64_t byteCount(const FlipRegion& region);

/// The offsets of @p region to flip, ascending: all of them (everyByte, or at most @p samples
/// bytes), or every k-th (k chosen for about @p samples) plus each unit's first and last byte.
[[nodiscard]] std::vector<std::uint64_t> flipOffsetsOf(const FlipRegion& region,
                                                       std::uint64_t samples);

struct ByteFlip {
    std::uint64_t offset = 0;
    int mask = 0;  // XORed into the byte
};

/// flipOffsetsOf(@p region, @p samples), each offset flipped twice: XOR 0xFF, then XOR 0x01.
[[nodiscard]] std::vector<ByteFlip> byteFlipsOf(const FlipRegion& region, std::uint64_t samples);

enum FlipOutcome : int {
    kDetected = 0,
    kUndetected = 1,
    kOtherException = 2,
    kCrashed = 3,
    kTimedOut = 4
};
inline constexpr int kFlipOutcomes = 5;

/// Flips the bytes of @p file (which it changes, and restores after each flip) one at a time,
/// each validated with validateFlipTarget, in forked children: one child takes the flips in turn
/// and reports each outcome through a pipe (forking per flip is ~50 times slower); when it dies
/// (a crash) or hangs (SIGALRM after @p timeoutSeconds), that flip is recorded as such and a new
/// child goes on with the next one. A result shorter than @p flips means the file could not be
/// read or written.
[[nodiscard]] std::vector<FlipOutcome> flipAndValidate(const std::filesystem::path& file,
                                                       const std::vector<ByteFlip>& flips,
                                                       unsigned timeoutSeconds = 10);

}  // namespace vox::test
