// Hostile input (issue 10): single-byte flips of a small .esvo (Cornell box, depth 5, Dxt
// attributes, several slices) and a small .rvol (depth 4) must all be caught by what
// `voxinspect validate` runs (the reader, then esvo::validateFile / rvol::validateRvol), with a
// vox::Error, never a crash, a hang or another exception. Every byte of the header and the
// directory (the .rvol level table too) is flipped, and about 500 sampled bytes of the data plus
// the first and last byte of every slice / brick / attribute layer, each with XOR 0xFF and XOR
// 0x01; validations run in forked children (a crash or a hang is caught and counted, and the
// sweep goes on). bench/byte_flip_sweep does the same, larger.
#include <vox/formats/esvo_reader.h>
#include <vox/formats/rvol_io.h>
#include <vox/import.h>
#include <vox/octree.h>
#include <vox/radiance.h>

#include "byte_flip.h"
#include "cornell_box.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

using namespace vox::test;

/// Flips every chosen byte of @p file (a copy of it) and expects each flip detected.
void sweep(const fs::path& file, const fs::path& scratch) {
    ASSERT_NO_THROW(validateFlipTarget(file)) << "the unflipped file must validate";
    const fs::path work = scratch / ("flipped" + file.extension().string());
    fs::copy_file(file, work, fs::copy_options::overwrite_existing);
    const auto start = std::chrono::steady_clock::now();
    std::uint64_t totalFlips = 0;
    for (const FlipRegion& region : flipRegionsOf(file, {.oneDataRegion = true})) {
        std::uint64_t flips = 0, outcome[kFlipOutcomes] = {0, 0, 0, 0, 0};
        std::vector<std::string> undetected, failures;
        const std::vector<ByteFlip> planned = byteFlipsOf(region, 500);
        const std::vector<FlipOutcome> outcomes = flipAndValidate(work, planned);
        ASSERT_EQ(outcomes.size(), planned.size()) << "the sweep stopped early";
        for (std::size_t i = 0; i < planned.size(); ++i) {
            const FlipOutcome o = outcomes[i];
            ++flips, ++outcome[o];
            const std::string what =
                std::to_string(planned[i].offset) + "^" + std::to_string(planned[i].mask);
            if (o == kUndetected && undetected.size() < 10) undetected.push_back(what);
            if (o > kUndetected && failures.size() < 10)
                failures.push_back(what + (o == kCrashed    ? " crashed"
                                           : o == kTimedOut ? " hung"
                                                            : " threw non-vox::Error"));
        }
        totalFlips += flips;
        std::printf(
            "[ byteflip ] %s %s: %llu flips, %llu detected, %llu undetected, %llu other exception, "
            "%llu crashed, %llu timed out\n",
            file.filename().c_str(), region.name.c_str(), (unsigned long long)flips,
            (unsigned long long)outcome[kDetected], (unsigned long long)outcome[kUndetected],
            (unsigned long long)outcome[kOtherException], (unsigned long long)outcome[kCrashed],
            (unsigned long long)outcome[kTimedOut]);
        std::string list;
        for (const auto& u : undetected) list += " " + u;
        EXPECT_EQ(outcome[kUndetected], 0u)
            << file << " " << region.name << ": undetected flips (offset^mask):" << list;
        list.clear();
        for (const auto& f : failures) list += " " + f;
        EXPECT_EQ(outcome[kOtherException] + outcome[kCrashed] + outcome[kTimedOut], 0u)
            << file << " " << region.name << ":" << list;
    }
    std::printf("[ byteflip ] %s: %llu flips in %.1f s\n", file.filename().c_str(),
                (unsigned long long)totalFlips,
                std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
}

}  // namespace

TEST(ByteFlip, EveryFlipOfASmallEsvoIsDetected) {
    vox::test::ScratchDir dir;
    const vox::Scene scene = vox::importScene(vox::scenes::writeCornellBox(dir.path()));
    vox::SurfaceVoxelizeOptions voxelize;
    voxelize.depth = 5;
    voxelize.contours = true;
    voxelize.attributes = true;
    vox::EsvoWriteOptions options;
    options.attributes = vox::AttributeEncoding::Compressed;
    options.sliceBytes = 16384;
    options.nearPointerLimit = 64;
    const fs::path file = dir / "cornell.esvo";
    vox::writeEsvo(file, vox::voxelizeSurface(scene, voxelize), options);
    ASSERT_GT(vox::esvo::EsvoReader(file).sliceCount(), 1u)
        << "several slices: a directory of several entries";
    sweep(file, dir.path());
}

TEST(ByteFlip, EveryFlipOfASmallRvolIsDetected) {
    vox::test::ScratchDir dir;
    const vox::Scene scene = vox::importScene(vox::scenes::writeCornellBox(dir.path()));
    vox::RadianceBakeOptions options;
    options.depth = 4;
    options.bounces = 1;
    const fs::path file = dir / "cornell.rvol";
    vox::rvol::writeRvol(file, vox::bakeRadiance(scene, options).volume);
    sweep(file, dir.path());
}
