#include "byte_flip.h"

#include <vox/base/error.h>
#include <vox/formats/esvo_reader.h>
#include <vox/formats/rvol_io.h>

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <set>

namespace fs = std::filesystem;

namespace vox::test {

namespace {

/// A data region whose units are also its ranges (slices, attribute layers).
void addUnit(FlipRegion& region, std::uint64_t begin, std::uint64_t end) {
    region.ranges.push_back({begin, end});
    region.units.push_back({begin, end});
}

/// The bytes of the file no region covers.
FlipRegion gapsOf(const std::vector<FlipRegion>& regions, std::uint64_t fileBytes) {
    ByteRanges covered;
    for (const FlipRegion& r : regions)
        covered.insert(covered.end(), r.ranges.begin(), r.ranges.end());
    std::sort(covered.begin(), covered.end());
    FlipRegion gaps{"gaps", {}, {}, false};
    std::uint64_t at = 0;
    for (const auto& [b, e] : covered) {
        if (b > at) gaps.ranges.push_back({at, b});
        at = std::max(at, e);
    }
    if (fileBytes > at) gaps.ranges.push_back({at, fileBytes});
    return gaps;
}

}  // namespace

bool isRvol(const fs::path& file) { return file.extension() == ".rvol"; }

void validateFlipTarget(const fs::path& file) {
    if (isRvol(file)) {
        const vox::rvol::RvolReader reader(file);
        (void)vox::rvol::validateRvol(reader);
    } else {
        const vox::esvo::EsvoReader reader(file);
        (void)vox::esvo::validateFile(reader);
    }
}

std::vector<FlipRegion> flipRegionsOf(const fs::path& file, const FlipRegionOptions& options) {
    std::vector<FlipRegion> regions;
    if (isRvol(file)) {
        const vox::rvol::RvolReader reader(file);
        const auto& h = reader.header();
        regions.push_back({"header", {{0, vox::rvol::kHeaderBytes}}, {}, true});
        regions.push_back({"directory",
                           {{h.levelTableOffset, h.levelTableOffset + h.levelTableBytes},
                            {h.directoryOffset, h.directoryOffset + h.directoryBytes}},
                           {},
                           true});
        FlipRegion bricks{"bricks", {}, {}, false};
        for (std::uint32_t l = 0; l < reader.levels().size(); ++l) {
            const auto& level = reader.level(l);
            if (level.brickCount == 0) continue;
            bricks.ranges.push_back({level.dataOffset, level.dataOffset + level.dataBytes});
            for (std::uint32_t b = 0; b < level.brickCount; ++b)
                bricks.units.push_back({reader.brickOffset(l, b),
                                        reader.brickOffset(l, b) + reader.storedBrickSize(l, b)});
        }
        regions.push_back(bricks);
        FlipRegion attributes{"attributes", {}, {}, false};
        for (const auto& [offset, bytes] :
             {std::pair{h.staticAttributesOffset, h.staticAttributesBytes},
              std::pair{h.dynamicAttributesOffset, h.dynamicAttributesBytes}})
            if (bytes > 0) addUnit(attributes, offset, offset + bytes);
        regions.push_back(attributes);
    } else {
        const vox::esvo::EsvoReader reader(file);
        const auto& h = reader.header();
        regions.push_back({"header", {{0, vox::esvo::kHeaderBytes}}, {}, true});
        regions.push_back(
            {"directory", {{h.directoryOffset, h.directoryOffset + h.directoryBytes}}, {}, true});
        FlipRegion slices{"slices", {}, {}, false};
        for (std::uint32_t s = 0; s < reader.sliceCount(); ++s)
            addUnit(slices, reader.slice(s).fileOffset,
                    reader.slice(s).fileOffset + reader.slice(s).byteSize);
        regions.push_back(slices);
    }
    if (options.oneDataRegion) {
        // Bricks are contiguous within a level, so the levels' ranges hold the same bytes, in the
        // same order, as the bricks one by one.
        FlipRegion data{"data", {}, {}, false};
        for (auto r = regions.begin() + 2; r != regions.end(); ++r) {
            data.ranges.insert(data.ranges.end(), r->ranges.begin(), r->ranges.end());
            data.units.insert(data.units.end(), r->units.begin(), r->units.end());
        }
        regions.resize(2);
        regions.push_back(std::move(data));
    }
    if (options.gaps) regions.push_back(gapsOf(regions, fs::file_size(file)));
    return regions;
}

std::uint64_t byteCount(const FlipRegion& region) {
    std::uint64_t bytes = 0;
    for (const auto& [b, e] : region.ranges) bytes += e - b;
    return bytes;
}

std::vector<std::uint64_t> flipOffsetsOf(const FlipRegion& region, std::uint64_t samples) {
    std::set<std::uint64_t> out;
    const std::uint64_t bytes = byteCount(region);
    const std::uint64_t stride =
        region.everyByte || bytes <= samples ? 1 : (bytes + samples - 1) / samples;
    std::uint64_t seen = 0;
    for (const auto& [b, e] : region.ranges)
        for (std::uint64_t o = b; o < e; ++o, ++seen)
            if (seen % stride == 0) out.insert(o);
    for (const auto& [b, e] : region.units)
        if (e > b) out.insert({b, e - 1});
    return {out.begin(), out.end()};
}

std::vector<ByteFlip> byteFlipsOf(const FlipRegion& region, std::uint64_t samples) {
    std::vector<ByteFlip> flips;
    for (const std::uint64_t offset : flipOffsetsOf(region, samples))
        for (const int mask : {0xFF, 0x01}) flips.push_back({offset, mask});
    return flips;
}

std::vector<FlipOutcome> flipAndValidate(const fs::path& file, const std::vector<ByteFlip>& flips,
                                         unsigned timeoutSeconds) {
    std::vector<FlipOutcome> out;
    while (out.size() < flips.size()) {
        int fds[2];
        if (pipe(fds) != 0) return out;
        std::fflush(nullptr);
        const std::size_t first = out.size();
        const pid_t pid = fork();
        if (pid < 0) {
            close(fds[0]);
            close(fds[1]);
            return out;
        }
        if (pid == 0) {
            close(fds[0]);
            const int fd = open(file.c_str(), O_RDWR);
            if (fd < 0) _exit(100);
            for (std::size_t i = first; i < flips.size(); ++i) {
                const auto [offset, mask] = flips[i];
                std::uint8_t original = 0;
                if (pread(fd, &original, 1, off_t(offset)) != 1) _exit(100);
                const std::uint8_t flipped = std::uint8_t(original ^ mask);
                if (pwrite(fd, &flipped, 1, off_t(offset)) != 1) _exit(100);
                alarm(timeoutSeconds);  // SIGALRM kills the child: a hang
                std::uint8_t code = kDetected;
                try {
                    validateFlipTarget(file);
                    code = kUndetected;
                } catch (const vox::Error&) {
                    code = kDetected;
                } catch (...) {
                    code = kOtherException;
                }
                alarm(0);
                if (pwrite(fd, &original, 1, off_t(offset)) != 1) _exit(100);
                if (write(fds[1], &code, 1) != 1) _exit(100);
            }
            _exit(0);
        }
        close(fds[1]);
        std::uint8_t code = 0;
        while (read(fds[0], &code, 1) == 1) out.push_back(FlipOutcome(code));
        close(fds[0]);
        int status = 0;
        while (waitpid(pid, &status, 0) < 0)
            if (errno != EINTR) break;
        if (out.size() < flips.size()) {
            if (WIFEXITED(status) && WEXITSTATUS(status) == 100)
                return out;  // the file itself failed: the caller sees a short result
            // The flip in progress crashed or hung; the file still holds it: restore the byte.
            const auto [offset, mask] = flips[out.size()];
            const int fd = open(file.c_str(), O_RDWR);
            if (fd < 0) return out;
            std::uint8_t b = 0;
            const bool restored =
                pread(fd, &b, 1, off_t(offset)) == 1 &&
                (b = std::uint8_t(b ^ mask), pwrite(fd, &b, 1, off_t(offset)) == 1);
            close(fd);
            if (!restored) return out;
            out.push_back(WIFSIGNALED(status) && WTERMSIG(status) == SIGALRM ? kTimedOut
                                                                             : kCrashed);
        }
        if (out.size() == first) return out;  // no progress
    }
    return out;
}

}  // namespace vox::test
