#include <vox/formats/scratch_file.h>

#include <vox/formats/error.h>

#include <cerrno>
#include <fcntl.h>
#include <string>
#include <unistd.h>

namespace vox {

ScratchFile::ScratchFile(const std::filesystem::path& directory) : directory_(directory.empty() ? "." : directory) {
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
    const char* bytes = static_cast<const char*>(data);
    while (size > 0) {
        const ssize_t n = ::pwrite(fd_, bytes, size, static_cast<off_t>(size_));
        if (n < 0) {
            if (errno == EINTR) continue;
            throw IoError(directory_, "cannot write the scratch file: " + errnoMessage(errno));
        }
        bytes += n;
        size -= static_cast<std::uint64_t>(n);
        size_ += static_cast<std::uint64_t>(n);
    }
    return start;
}

void ScratchFile::read(std::uint64_t offset, void* out, std::uint64_t size) const {
    char* bytes = static_cast<char*>(out);
    while (size > 0) {
        const ssize_t n = ::pread(fd_, bytes, size, static_cast<off_t>(offset));
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) throw IoError(directory_, "cannot read the scratch file back: " + (n < 0 ? errnoMessage(errno) : std::string("ends early")));
        bytes += n;
        offset += static_cast<std::uint64_t>(n);
        size -= static_cast<std::uint64_t>(n);
    }
}

}  // namespace vox
