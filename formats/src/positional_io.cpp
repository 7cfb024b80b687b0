#include "positional_io.h"

#include <cerrno>
#include <sys/types.h>
#include <unistd.h>

namespace vox::detail {

int writeAllAt(int fd, const void* data, std::uint64_t size, std::uint64_t offset) noexcept {
    const char* bytes = static_cast<const char*>(data);
    while (size > 0) {
        const ssize_t n =
            ::pwrite(fd, bytes, static_cast<std::size_t>(size), static_cast<off_t>(offset));
        if (n < 0) {
            if (errno == EINTR) continue;
            return errno;
        }
        bytes += n;
        offset += static_cast<std::uint64_t>(n);
        size -= static_cast<std::uint64_t>(n);
    }
    return 0;
}

PositionalRead readAllAt(int fd, void* out, std::uint64_t size, std::uint64_t offset) noexcept {
    char* bytes = static_cast<char*>(out);
    PositionalRead result;
    while (result.bytes < size) {
        const ssize_t n =
            ::pread(fd, bytes + result.bytes, static_cast<std::size_t>(size - result.bytes),
                    static_cast<off_t>(offset + result.bytes));
        if (n < 0) {
            if (errno == EINTR) continue;
            result.error = errno;
            return result;
        }
        if (n == 0) return result;  // the end of the file
        result.bytes += static_cast<std::uint64_t>(n);
    }
    return result;
}

}  // namespace vox::detail
