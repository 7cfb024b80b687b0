#include <vox/formats/atomic_file.h>
#include <vox/formats/error.h>

#include <cerrno>
#include <algorithm>
#include <cstring>
#include <fcntl.h>
#include <string>
#include <sys/stat.h>
#include <unistd.h>

namespace vox {
namespace {

constexpr std::string_view kTemporaryMarker = ".tmp-";
constexpr std::size_t kRandomSuffixLength = 6;  // mkstemp's XXXXXX

mode_t currentUmask() {
    // umask can only be read by setting it; restore immediately.
    const mode_t mask = ::umask(0);
    ::umask(mask);
    return mask;
}

}  // namespace

AtomicFile::AtomicFile(std::filesystem::path target) : target_(std::move(target)), buffer_(std::size_t{1} << 16) {
    std::filesystem::path dir = target_.parent_path();
    if (dir.empty()) dir = ".";
    // Appended piecewise: GCC 12 reports a false -Wrestrict on chained string concatenation.
    std::string name = ".";
    name.append(target_.filename().string()).append(kTemporaryMarker).append("XXXXXX");
    std::string pattern = (dir / name).string();
    fd_ = ::mkstemp(pattern.data());
    if (fd_ < 0) throw IoError(target_, "cannot create a temporary file beside it: " + errnoMessage(errno));
    temporary_ = pattern;
    // mkstemp creates 0600; outputs should get the permissions any new file would get.
    ::fchmod(fd_, 0666 & ~currentUmask());
}

AtomicFile::~AtomicFile() {
    if (fd_ >= 0) ::close(fd_);
    if (!committed_ && !temporary_.empty()) ::unlink(temporary_.c_str());
}

void AtomicFile::flushBuffer() {
    const char* data = buffer_.data();
    std::size_t left = buffered_;
    while (left > 0) {
        const ssize_t n = ::write(fd_, data, left);
        if (n < 0) {
            if (errno == EINTR) continue;
            throw IoError(target_, "write failed: " + errnoMessage(errno));
        }
        data += n;
        left -= static_cast<std::size_t>(n);
    }
    buffered_ = 0;
}

void AtomicFile::write(const void* data, std::size_t size) {
    if (committed_) throw IoError(target_, "write after commit");
    const char* bytes = static_cast<const char*>(data);
    while (size > 0) {
        const std::size_t n = std::min(size, buffer_.size() - buffered_);
        std::memcpy(buffer_.data() + buffered_, bytes, n);
        buffered_ += n;
        bytes += n;
        size -= n;
        if (buffered_ == buffer_.size()) flushBuffer();
    }
}

void AtomicFile::writeAt(std::uint64_t offset, const void* data, std::size_t size) {
    if (committed_) throw IoError(target_, "write after commit");
    flushBuffer();
    const char* bytes = static_cast<const char*>(data);
    while (size > 0) {
        const ssize_t n = ::pwrite(fd_, bytes, size, static_cast<off_t>(offset));
        if (n < 0) {
            if (errno == EINTR) continue;
            throw IoError(target_, "write failed: " + errnoMessage(errno));
        }
        bytes += n;
        offset += static_cast<std::uint64_t>(n);
        size -= static_cast<std::size_t>(n);
    }
}

void AtomicFile::commit() {
    if (committed_) return;
    flushBuffer();
    if (::fsync(fd_) != 0) throw IoError(target_, "fsync failed: " + errnoMessage(errno));
    if (::close(fd_) != 0) {
        fd_ = -1;
        throw IoError(target_, "close failed: " + errnoMessage(errno));
    }
    fd_ = -1;
    if (::rename(temporary_.c_str(), target_.c_str()) != 0)
        throw IoError(target_, "cannot rename the temporary file into place: " + errnoMessage(errno));
    committed_ = true;
}

bool AtomicFile::isTemporaryName(std::string_view name) noexcept {
    if (name.size() < 1 + kTemporaryMarker.size() + kRandomSuffixLength || name.front() != '.') return false;
    const std::size_t marker = name.size() - kRandomSuffixLength - kTemporaryMarker.size();
    return name.substr(marker, kTemporaryMarker.size()) == kTemporaryMarker;
}

void writeFileAtomically(const std::filesystem::path& target, std::string_view contents) {
    AtomicFile file(target);
    file.write(contents);
    file.commit();
}

}  // namespace vox
