#include "fuzz_support.h"

#include <vox/formats/checksum.h>
#include <vox/formats/esvo.h>
#include <vox/formats/rvol_io.h>
#include <vox/util/log.h>

#include "rvol_internal.h"  // the .rvol header's field offsets (formats/src)

#include <bit>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fcntl.h>
#include <stdexcept>
#include <system_error>
#include <unistd.h>

namespace vox::fuzz {
namespace {

/// The directory all of this process's input files live in, created on first use and removed at
/// exit. Never destroyed: the exit handler still needs it after static destructors have run.
const std::filesystem::path& privateDirectory() {
    static const std::filesystem::path* const dir = [] {
        std::string base = "/tmp";
        if (const char* tmp = std::getenv("TMPDIR"); tmp && *tmp) base = tmp;
        if (::access("/dev/shm", W_OK) == 0) base = "/dev/shm";  // no disk writes per input
        std::string pattern = base + "/libvox-fuzz-XXXXXX";
        if (::mkdtemp(pattern.data()) == nullptr)
            throw std::system_error(errno, std::generic_category(),
                                    "cannot create a directory in " + base);
        std::atexit([] {
            std::error_code ignored;
            std::filesystem::remove_all(privateDirectory(), ignored);
        });
        return new std::filesystem::path(pattern);
    }();
    return *dir;
}

template <typename T>
T load(const std::vector<std::uint8_t>& bytes, std::uint64_t offset) {
    T value{};
    std::memcpy(&value, bytes.data() + offset, sizeof value);
    return value;
}

/// Stores the CRC-32C of [@p begin, @p begin + @p size) at @p at, if both lie inside @p bytes.
/// Returns whether the stored value changed.
bool storeChecksum(std::vector<std::uint8_t>& bytes, std::uint64_t at, std::uint64_t begin,
                   std::uint64_t size) {
    if (at > bytes.size() || bytes.size() - at < 4 || begin > bytes.size() ||
        size > bytes.size() - begin)
        return false;
    const std::uint32_t crc = crc32c(bytes.data() + begin, static_cast<std::size_t>(size));
    if (load<std::uint32_t>(bytes, at) == crc) return false;
    std::memcpy(bytes.data() + at, &crc, sizeof crc);
    return true;
}

}  // namespace

InputFile::InputFile(const std::string& extension)
    : path_(privateDirectory() / ("input" + extension)) {}

const std::filesystem::path& InputFile::write(const std::uint8_t* data, std::size_t size) {
    const int fd = ::open(path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
    if (fd < 0)
        throw std::system_error(errno, std::generic_category(), "cannot write " + path_.string());
    while (size > 0) {
        const ssize_t n = ::write(fd, data, size);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) {
            ::close(fd);
            throw std::system_error(errno, std::generic_category(),
                                    "cannot write " + path_.string());
        }
        data += n;
        size -= static_cast<std::size_t>(n);
    }
    ::close(fd);
    return path_;
}

bool repairEsvoChecksums(std::vector<std::uint8_t>& bytes) {
    using namespace vox::esvo;
    if (bytes.size() < kHeaderBytes) return false;
    bool changed = false;
    const std::uint32_t leafDepth = load<std::uint32_t>(bytes, 192);
    const std::uint32_t sliceCount = load<std::uint32_t>(bytes, 212);
    const std::uint64_t directoryOffset = load<std::uint64_t>(bytes, 216);
    const std::uint64_t directoryBytes = load<std::uint64_t>(bytes, 224);
    // The directory: voxel counts per level (8 bytes each, levels 0 … leafDepth), then the entries.
    if (leafDepth <= kMaxLeafDepth && directoryOffset <= bytes.size() &&
        directoryBytes <= bytes.size() - directoryOffset) {
        const std::uint64_t entries = directoryOffset + 8ull * (leafDepth + 1);
        for (std::uint64_t i = 0; i < sliceCount; ++i) {
            const std::uint64_t entry = entries + i * kDirectoryEntryBytes;
            if (entry + kDirectoryEntryBytes > directoryOffset + directoryBytes) break;
            changed |= storeChecksum(bytes, entry + 12, load<std::uint64_t>(bytes, entry),
                                     load<std::uint32_t>(bytes, entry + 8));
        }
        changed |= storeChecksum(bytes, 232, directoryOffset, directoryBytes);
    }
    changed |= storeChecksum(bytes, 252, 0, 252);
    return changed;
}

bool repairRvolChecksums(std::vector<std::uint8_t>& bytes) {
    using namespace vox::rvol;
    namespace o = vox::rvol::detail::hdr;
    if (bytes.size() < kHeaderBytes) return false;
    bool changed = false;
    const auto field64 = [&](std::size_t at) { return load<std::uint64_t>(bytes, at); };
    const std::uint64_t levelTable = field64(o::kLevelTableOffset),
                        levelTableBytes = field64(o::kLevelTableBytes);
    const std::uint64_t directory = field64(o::kDirectoryOffset),
                        directoryBytes = field64(o::kDirectoryBytes);
    const bool directoryInside =
        directory <= bytes.size() && directoryBytes <= bytes.size() - directory;
    // Bricks first (their checksums are in the directory), level by level as the table places them.
    if (levelTable <= bytes.size() && levelTableBytes <= bytes.size() - levelTable &&
        directoryInside) {
        const std::uint32_t n = load<std::uint32_t>(bytes, o::kBrickTexels);
        for (std::uint64_t e = levelTable; e + kLevelEntryBytes <= levelTable + levelTableBytes;
             e += kLevelEntryBytes) {
            const std::uint32_t channels = load<std::uint32_t>(bytes, e + 4);
            const std::uint64_t count = load<std::uint32_t>(bytes, e + 16),
                                first = load<std::uint32_t>(bytes, e + 20);
            std::uint64_t offset = load<std::uint64_t>(bytes, e + 24);
            if (channels > 16 || n > kMaxBrickTexels) break;
            const std::uint32_t rgbBits = (1u << channels) - 1;
            // Each brick's stored size from its entry's plane bits and texel count.
            for (std::uint64_t i = 0; i < count; ++i) {
                const std::uint64_t entry = directory + (first + i) * kBrickEntryBytes;
                if (first + i >= directoryBytes / kBrickEntryBytes) break;
                const std::uint32_t planes = load<std::uint16_t>(bytes, entry + 6);
                const std::uint64_t size =
                    storedBrickBytes(n, static_cast<std::uint32_t>(std::popcount(planes & rgbBits)),
                                     static_cast<std::uint32_t>(std::popcount(planes & ~rgbBits)),
                                     load<std::uint32_t>(bytes, entry + 8));
                if (offset > bytes.size() || size > bytes.size() - offset) break;
                changed |= storeChecksum(bytes, entry + 12, offset, size);
                offset += size;
            }
        }
    }
    changed |= storeChecksum(bytes, o::kDirectoryChecksum, directory, directoryBytes);
    changed |= storeChecksum(bytes, o::kLevelTableChecksum, levelTable, levelTableBytes);
    changed |= storeChecksum(bytes, o::kStaticChecksum, field64(o::kStaticOffset),
                             field64(o::kStaticBytes));
    changed |= storeChecksum(bytes, o::kDynamicChecksum, field64(o::kDynamicOffset),
                             field64(o::kDynamicBytes));
    changed |= storeChecksum(bytes, o::kChecksum, 0, o::kChecksum);
    return changed;
}

}  // namespace vox::fuzz

// libFuzzer calls this once before the first input, in every harness (this library is linked as
// objects, so the definition is always there). Logging is quiet (errors only): thousands of
// inputs a second, each of which may warn.
extern "C" int LLVMFuzzerInitialize(int*, char***) {
    vox::log::setVerbosity(vox::log::Verbosity::Quiet);
    return 0;
}
