#include <vox/formats/read_only_file.h>

#include <vox/base/error.h>

#include "positional_io.h"

#include <cerrno>
#include <fcntl.h>
#include <string>
#include <sys/stat.h>
#include <unistd.h>
#include <utility>

namespace vox {

ReadOnlyFile::ReadOnlyFile(std::filesystem::path file) : path_(std::move(file)) {
    fd_ = ::open(path_.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd_ < 0) throw IoError(path_, "cannot open: " + errnoMessage(errno));
    try {
        struct stat st {};
        if (::fstat(fd_, &st) != 0) throw IoError(path_, "cannot stat: " + errnoMessage(errno));
        if (!S_ISREG(st.st_mode)) throw IoError(path_, "not a regular file");
        size_ = static_cast<std::uint64_t>(st.st_size);
    } catch (...) {
        ::close(fd_);
        throw;
    }
}

ReadOnlyFile::~ReadOnlyFile() {
    if (fd_ >= 0) ::close(fd_);
}

ReadOnlyFile::ReadOnlyFile(ReadOnlyFile&& other) noexcept
    : path_(std::move(other.path_)),
      fd_(std::exchange(other.fd_, -1)),
      size_(std::exchange(other.size_, 0)) {}

ReadOnlyFile& ReadOnlyFile::operator=(ReadOnlyFile&& other) noexcept {
    if (this != &other) {
        if (fd_ >= 0) ::close(fd_);
        path_ = std::move(other.path_);
        fd_ = std::exchange(other.fd_, -1);
        size_ = std::exchange(other.size_, 0);
    }
    return *this;
}

void ReadOnlyFile::read(std::uint64_t offset, std::uint8_t* out, std::uint64_t size) const {
    const detail::PositionalRead got = detail::readAllAt(fd_, out, size, offset);
    if (got.error) throw IoError(path_, "cannot read: " + errnoMessage(got.error));
    if (got.bytes < size)
        throw InvalidDataError(path_,
                               "file ends early at byte " + std::to_string(offset + got.bytes));
}

}  // namespace vox
