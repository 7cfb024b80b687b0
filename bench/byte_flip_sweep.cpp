// Byte-flip sweep (issue 10): flips single bytes of an .esvo or .rvol file, one at a time, and
// runs what `voxinspect validate` runs (the reader's constructor, then esvo::validateFile or
// rvol::validateRvol) on each, in forked children so that a crash or a hang is caught too (one
// child works through the flips in turn; after a crash or a hang a new one goes on).
// Every byte of the header and the directory (the .rvol level table included) is flipped, and a
// sample of the data: every k-th byte (k chosen for about --samples bytes per region) plus the
// first and last byte of every slice / brick / attribute layer. Each byte is flipped twice:
// XOR 0xFF and XOR 0x01. A flip is *detected* when validation throws vox::Error; *undetected*
// when it passes; anything else (another exception, a signal, a hang past --timeout seconds) is
// a failure. Gaps between sections (alignment padding) are swept as their own region.
//
//   byte_flip_sweep FILE... [--samples N] [--timeout S]
//
// Prints, per file and region: bytes, flips, detected, undetected (first offsets), other
// exceptions, crashes, timeouts. Exit status 0 only when every flip was detected.
#include "byte_flip.h"

#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

using namespace vox::test;

struct Counts {
    std::uint64_t bytes = 0, flips = 0;
    std::uint64_t outcome[kFlipOutcomes] = {0, 0, 0, 0, 0};
    std::vector<std::pair<std::uint64_t, int>> undetected;  // (offset, mask), the first few
    std::vector<std::pair<std::uint64_t, int>> failures;    // other exception, crash or timeout
};

}  // namespace

int main(int argc, char** argv) {
    std::vector<fs::path> files;
    std::uint64_t samples = 4000;
    unsigned timeout = 20;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--samples" && i + 1 < argc)
            samples = std::strtoull(argv[++i], nullptr, 10);
        else if (a == "--timeout" && i + 1 < argc)
            timeout = unsigned(std::strtoul(argv[++i], nullptr, 10));
        else if (!a.empty() && a[0] != '-')
            files.emplace_back(a);
        else {
            std::fprintf(stderr,
                         "usage: byte_flip_sweep FILE.esvo|FILE.rvol... [--samples N per data "
                         "region] [--timeout S]\n");
            return 2;
        }
    }
    if (files.empty() || samples == 0) {
        std::fprintf(stderr,
                     "usage: byte_flip_sweep FILE.esvo|FILE.rvol... [--samples N per data region] "
                     "[--timeout S]\n");
        return 2;
    }
    bool allDetected = true;
    for (const fs::path& file : files) {
        try {
            validateFlipTarget(file);
        } catch (const std::exception& e) {
            std::fprintf(stderr, "%s: the unflipped file must validate: %s\n", file.c_str(),
                         e.what());
            return 2;
        }
        const std::uint64_t fileBytes = fs::file_size(file);
        const fs::path work = fs::temp_directory_path() /
                              ("byte_flip_" + std::to_string(getpid()) + file.extension().string());
        fs::copy_file(file, work, fs::copy_options::overwrite_existing);
        const auto start = std::chrono::steady_clock::now();
        std::map<std::string, Counts> table;
        std::vector<std::string> order;
        Counts total;
        for (const FlipRegion& region : flipRegionsOf(file, {.gaps = true})) {
            Counts& c = table[region.name];
            order.push_back(region.name);
            c.bytes += byteCount(region);
            const std::vector<ByteFlip> planned = byteFlipsOf(region, samples);
            const std::vector<FlipOutcome> outcomes = flipAndValidate(work, planned, timeout);
            if (outcomes.size() != planned.size()) {
                std::fprintf(
                    stderr,
                    "%s: could not read or write %s; the sweep stopped after %zu of %zu flips\n",
                    file.c_str(), work.c_str(), outcomes.size(), planned.size());
                fs::remove(work);
                return 2;
            }
            for (std::size_t i = 0; i < planned.size(); ++i) {
                const FlipOutcome o = outcomes[i];
                ++c.flips;
                ++c.outcome[o];
                if (o == kUndetected && c.undetected.size() < 16)
                    c.undetected.push_back({planned[i].offset, planned[i].mask});
                if (o > kUndetected && c.failures.size() < 16)
                    c.failures.push_back({planned[i].offset, planned[i].mask});
            }
            total.flips += c.flips, total.bytes += c.bytes;
            for (int k = 0; k < kFlipOutcomes; ++k) total.outcome[k] += c.outcome[k];
        }
        fs::remove(work);
        const double seconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        std::printf("%s (%llu bytes): %llu flips in %.1f s\n", file.c_str(),
                    (unsigned long long)fileBytes, (unsigned long long)total.flips, seconds);
        std::printf("  %-11s %10s %8s %9s %10s %6s %7s %8s\n", "region", "bytes", "flips",
                    "detected", "undetected", "other", "crashed", "timedout");
        const auto row = [](const std::string& name, const Counts& c) {
            std::printf("  %-11s %10llu %8llu %9llu %10llu %6llu %7llu %8llu\n", name.c_str(),
                        (unsigned long long)c.bytes, (unsigned long long)c.flips,
                        (unsigned long long)c.outcome[kDetected],
                        (unsigned long long)c.outcome[kUndetected],
                        (unsigned long long)c.outcome[kOtherException],
                        (unsigned long long)c.outcome[kCrashed],
                        (unsigned long long)c.outcome[kTimedOut]);
        };
        for (const std::string& name : order) row(name, table[name]);
        row("total", total);
        for (const std::string& name : order) {
            const Counts& c = table[name];
            if (!c.undetected.empty()) {
                std::printf("  %s undetected (offset^mask, first %zu):", name.c_str(),
                            c.undetected.size());
                for (const auto& [o, m] : c.undetected)
                    std::printf(" %llu^0x%02X", (unsigned long long)o, m);
                std::printf("\n");
            }
            if (!c.failures.empty()) {
                std::printf("  %s other exception/crash/timeout (first %zu):", name.c_str(),
                            c.failures.size());
                for (const auto& [o, m] : c.failures)
                    std::printf(" %llu^0x%02X", (unsigned long long)o, m);
                std::printf("\n");
            }
        }
        if (total.outcome[kDetected] != total.flips) allDetected = false;
    }
    return allDetected ? 0 : 1;
}
