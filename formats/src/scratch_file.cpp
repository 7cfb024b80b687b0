#include <vox/formats/scratch_file.h>

#include <vox/base/error.h>

#include "positional_io.h"

#include <cerrno>
#include <fcntl.h>
#include <string>
#include <unistd.h>

namespace vox {

ScratchFile::ScratchFile(const std::filesystem::path& directory)
    : directory_(directory.empty() ? "." : directory) {
    std::string pattern = (directory_ / ".libvox-scratch-XXXXXX").string();
    fd_ = ::mkostemp(pattern.data(), O_CLOEXEC);
    if (fd_ < 0) throw IoError(directory_, "cannot create a scratch file: " + errnoMessage(errno));
    ::unlink(pattern.c_str());
}

ScratchFile::~ScratchFile() {
    if (fd_ >= 0) ::close(fd_);
}

std::uint64_t ScratchFile::append(const void* data, std::uint64_t size) {
    const std::uint64_t start = size_;
    if (const int error = detail::writeAllAt(fd_, data, size, start))
        throw IoError(directory_, "cannot write the scratch file: " + errnoMessage(error));
    size_ += size;
    return start;
}

void ScratchFile::read(std::uint64_t offset, void* out, std::uint64_t size) const {
    const detail::PositionalRead got = detail::readAllAt(fd_, out, size, offset);
    if (got.bytes < size)
        throw IoError(directory_,
                      "cannot read the scratch file back: " +
                          (got.error ? errnoMessage(got.error) : std::string("ends early")));
}

}  // namespace vox
