// Whole-range positional reads and writes on a file descriptor, retried over EINTR and short
// transfers: the one loop under AtomicFile::writeAt, ScratchFile and ReadOnlyFile, which turn
// its result into their own errors (they name different files and problems).
#pragma once

#include <cstdint>

namespace vox::detail {

/// Writes @p size bytes of @p data at byte @p offset of @p fd. Returns 0, or the errno of the
/// write that failed (the bytes before it are written).
int writeAllAt(int fd, const void* data, std::uint64_t size, std::uint64_t offset) noexcept;

/// What readAllAt got: the bytes read, fewer than asked where the file ends first (`error` 0),
/// and the errno of a read that failed.
struct PositionalRead {
    std::uint64_t bytes = 0;
    int error = 0;
};

/// Reads @p size bytes at byte @p offset of @p fd into @p out.
PositionalRead readAllAt(int fd, void* out, std::uint64_t size, std::uint64_t offset) noexcept;

}  // namespace vox::detail
