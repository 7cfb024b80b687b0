/// @file atomic_file.h
/// @brief Writes an output file so that readers see either the previous file or the complete
/// new one, never a partial file: data goes to a temporary file beside the target, which is
/// renamed into place by commit(). A destroyed, uncommitted AtomicFile removes its temporary; a
/// killed writer's temporary is removed by the next AtomicFile of the same target.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string_view>
#include <vector>

namespace vox {

class AtomicFile {
public:
    /// Creates the temporary file "<dir>/.<name>.tmp-XXXXXX" beside @p target and holds an
    /// exclusive flock on it until it is renamed or removed. First removes the temporaries of
    /// @p target that no live writer holds (left by a killed or crashed run): regular files of
    /// this user named ".<name>.tmp-" and six characters whose lock it can take. Temporaries of
    /// other targets, and those a running writer holds, are never touched.
    /// @throws IoError if the directory is not writable.
    explicit AtomicFile(std::filesystem::path target);
    ~AtomicFile();
    AtomicFile(const AtomicFile&) = delete;
    AtomicFile& operator=(const AtomicFile&) = delete;

    /// Appends bytes. @throws IoError on a write failure (disk full, ...).
    void write(const void* data, std::size_t size);
    void write(std::string_view text) { write(text.data(), text.size()); }
    /// Overwrites @p size bytes already written, at file offset @p offset: for a header whose
    /// checksums are known only once the data after it is written. @throws IoError.
    void writeAt(std::uint64_t offset, const void* data, std::size_t size);

    /// Flushes, syncs and renames the temporary onto the target. @throws IoError.
    void commit();

    [[nodiscard]] const std::filesystem::path& target() const noexcept { return target_; }
    [[nodiscard]] const std::filesystem::path& temporaryPath() const noexcept { return temporary_; }

    /// True if @p name has the shape of a temporary this class creates (".X.tmp-XXXXXX").
    [[nodiscard]] static bool isTemporaryName(std::string_view name) noexcept;

private:
    void flushBuffer();

    std::filesystem::path target_;
    std::filesystem::path temporary_;
    int fd_ = -1;
    bool committed_ = false;
    std::vector<char> buffer_;
    std::size_t buffered_ = 0;
};

/// Writes @p contents to @p target atomically (see AtomicFile).
void writeFileAtomically(const std::filesystem::path& target, std::string_view contents);

}  // namespace vox
