#include <vox/formats/atomic_file.h>
#include <vox/base/error.h>

#include "positional_io.h"

#include <cerrno>
#include <algorithm>
#include <cstring>
#include <dirent.h>
#include <fcntl.h>
#include <string>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>
#include <utility>

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

/// ".NAME.tmp-": what every temporary of a target called NAME starts with.
std::string temporaryPrefix(const std::filesystem::path& target) {
    // Appended piecewise: GCC 12 reports a false -Wrestrict on chained string concatenation.
    std::string prefix = ".";
    prefix.append(target.filename().string()).append(kTemporaryMarker);
    return prefix;
}

/// Removes @p name in @p dirFd if it is a regular file of ours that no live AtomicFile holds:
/// every writer keeps an exclusive flock on its temporary until it is gone (killed included,
/// since the kernel drops the locks of a dead process), so a lock we can take belongs to no one.
/// Best effort: anything unexpected (no flock on this file system, another owner, a race with
/// another cleaner) leaves the file alone.
void removeIfAbandoned(int dirFd, const char* name) {
    const int fd = ::openat(dirFd, name, O_RDONLY | O_CLOEXEC | O_NOFOLLOW | O_NONBLOCK);
    if (fd < 0) return;
    struct stat opened {};
    if (::fstat(fd, &opened) == 0 && S_ISREG(opened.st_mode) && opened.st_uid == ::geteuid() &&
        opened.st_nlink > 0 && ::flock(fd, LOCK_EX | LOCK_NB) == 0) {
        // Still the file we locked under that name (not one a writer created since)?
        struct stat named {};
        if (::fstatat(dirFd, name, &named, AT_SYMLINK_NOFOLLOW) == 0 &&
            named.st_dev == opened.st_dev && named.st_ino == opened.st_ino)
            ::unlinkat(dirFd, name, 0);
    }
    ::close(fd);  // releases the lock
}

/// Removes the temporaries of @p target that killed or crashed writers left in @p dir.
void removeAbandonedTemporaries(const std::filesystem::path& dir,
                                const std::filesystem::path& target) {
    DIR* listing = ::opendir(dir.c_str());
    if (listing == nullptr) return;
    const std::string prefix = temporaryPrefix(target);
    while (const dirent* entry = ::readdir(listing)) {
        const std::string_view name(entry->d_name);
        if (name.size() == prefix.size() + kRandomSuffixLength && name.starts_with(prefix))
            removeIfAbandoned(::dirfd(listing), entry->d_name);
    }
    ::closedir(listing);
}

}  // namespace

AtomicFile::AtomicFile(std::filesystem::path target)
    : target_(std::move(target)), buffer_(std::size_t{1} << 16) {
    std::filesystem::path dir = target_.parent_path();
    if (dir.empty()) dir = ".";
    removeAbandonedTemporaries(dir, target_);
    const std::string pattern = (dir / (temporaryPrefix(target_) + "XXXXXX")).string();
    for (;;) {
        std::string name = pattern;
        fd_ = ::mkstemp(name.data());
        if (fd_ < 0)
            throw IoError(target_,
                          "cannot create a temporary file beside it: " + errnoMessage(errno));
        temporary_ = name;
        // Held until the temporary is renamed or removed: tells other writers' clean-up that it is
        // in use. A file system without flock gets no lock; its temporaries are then never removed
        // by others (removeIfAbandoned cannot lock them either).
        if (::flock(fd_, LOCK_EX) != 0) break;
        // Another writer's clean-up may have locked and removed it between mkstemp and flock.
        struct stat st {};
        if (::fstat(fd_, &st) != 0 || st.st_nlink > 0) break;
        ::close(fd_);
    }
    // mkstemp creates 0600; outputs should get the permissions any new file would get.
    ::fchmod(fd_, 0666 & ~currentUmask());
}

AtomicFile::~AtomicFile() {
    // Removed while still locked, so that no other writer's clean-up touches it meanwhile.
    if (!committed_ && !temporary_.empty()) ::unlink(temporary_.c_str());
    if (fd_ >= 0) ::close(fd_);
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
    if (const int error = detail::writeAllAt(fd_, data, size, offset))
        throw IoError(target_, "write failed: " + errnoMessage(error));
}

void AtomicFile::commit() {
    if (committed_) return;
    flushBuffer();
    if (::fsync(fd_) != 0) throw IoError(target_, "fsync failed: " + errnoMessage(errno));
    // Renamed before it is closed: until then the lock keeps other writers' clean-up away from it.
    if (::rename(temporary_.c_str(), target_.c_str()) != 0)
        throw IoError(target_,
                      "cannot rename the temporary file into place: " + errnoMessage(errno));
    committed_ = true;
    const int fd = std::exchange(fd_, -1);
    // The data is on disk (fsync); a failing close is still reported.
    if (::close(fd) != 0) throw IoError(target_, "close failed: " + errnoMessage(errno));
}

bool AtomicFile::isTemporaryName(std::string_view name) noexcept {
    if (name.size() < 1 + kTemporaryMarker.size() + kRandomSuffixLength || name.front() != '.')
        return false;
    const std::size_t marker = name.size() - kRandomSuffixLength - kTemporaryMarker.size();
    return name.substr(marker, kTemporaryMarker.size()) == kTemporaryMarker;
}

void writeFileAtomically(const std::filesystem::path& target, std::string_view contents) {
    AtomicFile file(target);
    file.write(contents);
    file.commit();
}

}  // namespace vox
