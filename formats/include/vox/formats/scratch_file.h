/// @file scratch_file.h
/// @brief An anonymous temporary file for data that does not fit in memory (the partitioned
/// octree build's finished slices): created in a directory and unlinked at once, so that it
/// vanishes with the process however that ends, and nothing of it is ever mistaken for output.
#pragma once

#include <cstdint>
#include <filesystem>

namespace vox {

class ScratchFile {
public:
    /// Creates the file in @p directory (on the output's file system, which must hold it).
    /// @throws IoError if the directory is not writable.
    explicit ScratchFile(const std::filesystem::path& directory);
    ~ScratchFile();
    ScratchFile(const ScratchFile&) = delete;
    ScratchFile& operator=(const ScratchFile&) = delete;

    /// Appends @p size bytes; returns the offset they start at. @throws IoError (disk full, …).
    std::uint64_t append(const void* data, std::uint64_t size);
    /// Reads back @p size bytes appended at @p offset. Thread-safe. @throws IoError.
    void read(std::uint64_t offset, void* out, std::uint64_t size) const;
    /// Bytes appended so far.
    [[nodiscard]] std::uint64_t size() const noexcept { return size_; }

private:
    std::filesystem::path directory_;  // for error messages
    int fd_ = -1;
    std::uint64_t size_ = 0;
};

}  // namespace vox
