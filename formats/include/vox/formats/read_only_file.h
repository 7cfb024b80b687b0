/// @file read_only_file.h
/// @brief A file opened for reading with pread, shared by the .esvo and .rvol readers and the
/// partitioned octree build's part files.
#pragma once

#include <cstdint>
#include <filesystem>

namespace vox {

/// A regular file open for reading (O_RDONLY | O_CLOEXEC), closed on destruction. Move-only.
/// read() uses pread, so any number of threads may read at once.
class ReadOnlyFile {
public:
    /// Opens @p file and checks that it is a regular file.
    /// @throws IoError "FILE: cannot open: …", "FILE: cannot stat: …", "FILE: not a regular file".
    explicit ReadOnlyFile(std::filesystem::path file);
    ~ReadOnlyFile();
    ReadOnlyFile(ReadOnlyFile&& other) noexcept;
    ReadOnlyFile& operator=(ReadOnlyFile&& other) noexcept;
    ReadOnlyFile(const ReadOnlyFile&) = delete;
    ReadOnlyFile& operator=(const ReadOnlyFile&) = delete;

    [[nodiscard]] const std::filesystem::path& path() const noexcept { return path_; }
    /// The file's size in bytes when it was opened.
    [[nodiscard]] std::uint64_t size() const noexcept { return size_; }

    /// Reads exactly @p size bytes at file offset @p offset into @p out. Thread-safe.
    /// @throws IoError "FILE: cannot read: …" on a read error, InvalidDataError
    /// "FILE: file ends early at byte N" if the file ends first.
    void read(std::uint64_t offset, std::uint8_t* out, std::uint64_t size) const;

private:
    std::filesystem::path path_;
    int fd_ = -1;
    std::uint64_t size_ = 0;
};

}  // namespace vox
