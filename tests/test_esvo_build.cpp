// The partitioned octree build (libvox/src/octree/esvo_build.cpp, esvo_layout, esvo_assemble,
// esvo_parts): buildEsvo writes the bytes voxelizeSurface + writeEsvo write, for every partition
// level, attribute encoding, round size, scratch spill and thread count; runs of a build split
// with a partition selection merge into the same bytes; merge rejects parts that are missing,
// repeated, corrupt or from another build.
#include <vox/base/error.h>
#include <vox/formats/esvo_reader.h>
#include <vox/import.h>
#include <vox/octree.h>
#include <vox/util/parallel.h>

#include "cornell_box.h"
#include "test_support.h"

#include <fstream>
#include <unistd.h>
#include <iterator>

namespace fs = std::filesystem;
using vox::test::ScratchDir;

namespace {

std::vector<char> bytesOf(const fs::path& file) {
    std::ifstream in(file, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// The Cornell box example: walls, two boxes (one checkered), an emissive panel; written and
/// imported once per process, outside the tests' scratch directories.
const vox::Scene& cornellBox() {
    static const vox::Scene scene = [] {
        const fs::path dir =
            fs::temp_directory_path() / ("libvox-test-esvo-build-" + std::to_string(::getpid()));
        fs::create_directories(dir);
        vox::Scene imported = vox::importScene(vox::scenes::writeCornellBox(dir));
        fs::remove_all(dir);
        return imported;
    }();
    return scene;
}

vox::EsvoBuildOptions buildOptions(
    std::uint32_t depth, std::int32_t partitionLevel,
    vox::AttributeEncoding encoding = vox::AttributeEncoding::Compressed, bool contours = true) {
    vox::EsvoBuildOptions options;
    options.voxelize.depth = depth;
    options.voxelize.contours = contours;
    options.voxelize.attributes = encoding != vox::AttributeEncoding::None;
    options.write.attributes = encoding;
    options.write.partitionLevel = partitionLevel;
    options.write.sliceBytes = 16384;  // many slices, so that partitions hold trees of them
    options.write.sceneBounds = cornellBox().bounds();
    return options;
}

/// voxelizeSurface then writeEsvo: the in-memory path buildEsvo must agree with.
fs::path writeInMemory(const fs::path& file, const vox::EsvoBuildOptions& options) {
    const vox::SparseOctree octree = vox::voxelizeSurface(cornellBox(), options.voxelize);
    vox::writeEsvo(file, octree, options.write);
    return file;
}

}  // namespace

TEST(EsvoBuild, WritesTheBytesOfVoxelizeThenWriteAtEveryPartitionLevel) {
    ScratchDir dir;
    for (const std::int32_t level : {0, 1, 2, 3, 4}) {
        SCOPED_TRACE(level);
        const auto options = buildOptions(7, level);
        const auto built = vox::buildEsvo(dir / "built.esvo", cornellBox(), options);
        const fs::path reference = writeInMemory(dir / "memory.esvo", options);
        ASSERT_EQ(bytesOf(dir / "built.esvo"), bytesOf(reference));
        EXPECT_EQ(built.partitionLevel, std::uint32_t(level));
        EXPECT_NO_THROW(vox::esvo::validateFile(vox::esvo::EsvoReader(dir / "built.esvo")));
        const vox::esvo::EsvoReader reader(dir / "built.esvo");
        EXPECT_EQ(reader.directory().voxelsPerLevel, built.voxelsPerLevel);
        if (level > 0) {
            // No slice below the partition level spans two of its voxels.
            for (const auto& slice : reader.directory().slices) {
                if (slice.firstLevel > std::uint32_t(level)) {
                    EXPECT_GE(slice.regionLevel, std::uint32_t(level));
                }
            }
            EXPECT_EQ(built.partitionsTotal, reader.directory().voxelsPerLevel[level]);
        }
    }
}

TEST(EsvoBuild, EveryAttributeEncodingAndCubesOnlyAgreeWithTheInMemoryPath) {
    ScratchDir dir;
    for (const auto encoding : {vox::AttributeEncoding::None, vox::AttributeEncoding::Raw,
                                vox::AttributeEncoding::CompressedLookup}) {
        for (const bool contours : {true, false}) {
            SCOPED_TRACE(static_cast<int>(encoding) * 2 + contours);
            const auto options = buildOptions(7, 2, encoding, contours);
            vox::buildEsvo(dir / "built.esvo", cornellBox(), options);
            ASSERT_EQ(bytesOf(dir / "built.esvo"),
                      bytesOf(writeInMemory(dir / "memory.esvo", options)));
        }
    }
}

TEST(EsvoBuild, OnePartitionARoundAndEverySliceInScratchGiveTheSameBytes) {
    ScratchDir dir;
    const auto options = buildOptions(8, 3);
    const auto whole = vox::buildEsvo(dir / "whole.esvo", cornellBox(), options);
    EXPECT_EQ(whole.batches, 1u);
    EXPECT_EQ(whole.scratchBytes, 0u);
    auto small = options;
    small.roundBytes = 1;        // one partition at a time
    small.memorySliceBytes = 1;  // every finished slice waits on disk
    const auto rounds = vox::buildEsvo(dir / "rounds.esvo", cornellBox(), small);
    EXPECT_EQ(rounds.batches, rounds.partitionsTotal);
    EXPECT_GT(rounds.scratchBytes, rounds.written.fileBytes / 2);
    EXPECT_EQ(bytesOf(dir / "rounds.esvo"), bytesOf(dir / "whole.esvo"));
    // The scratch file is anonymous: nothing but the outputs is left in the directory.
    EXPECT_EQ(dir.files(), (std::vector<std::string>{"rounds.esvo", "whole.esvo"}));
}

TEST(EsvoBuild, TheThreadCountDoesNotChangeTheBytes) {
    ScratchDir dir;
    const auto options = buildOptions(8, 2);
    for (const int threads : {1, 2, 3}) {
        const vox::ThreadLimit limit(threads);
        vox::buildEsvo(dir / ("t" + std::to_string(threads) + ".esvo"), cornellBox(), options);
    }
    EXPECT_EQ(bytesOf(dir / "t1.esvo"), bytesOf(dir / "t2.esvo"));
    EXPECT_EQ(bytesOf(dir / "t1.esvo"), bytesOf(dir / "t3.esvo"));
}

TEST(EsvoBuild, EightRunsMergeIntoTheBytesOfTheWholeBuild) {
    ScratchDir dir;
    for (const auto& [level, runs] : {std::pair{3, 8u}, std::pair{3, 3u},
                                      std::pair{2, 100u}}) {  // 100: more runs than partitions
        SCOPED_TRACE(runs);
        const auto options = buildOptions(7, level);
        const auto whole = vox::buildEsvo(dir / "whole.esvo", cornellBox(), options);
        std::vector<fs::path> parts;
        std::uint64_t built = 0;
        for (std::uint32_t k = 0; k < runs; ++k) {
            auto run = options;
            run.partitions = {k, runs};
            parts.push_back(dir / ("run" + std::to_string(k) + ".esvopart"));
            built += vox::buildEsvo(parts.back(), cornellBox(), run).partitionsBuilt;
        }
        EXPECT_EQ(built, whole.partitionsTotal) << "every partition in exactly one run";
        std::reverse(parts.begin(), parts.end());  // any order
        const auto merged = vox::mergeEsvoParts(dir / "merged.esvo", parts);
        ASSERT_EQ(bytesOf(dir / "merged.esvo"), bytesOf(dir / "whole.esvo"));
        EXPECT_EQ(merged.voxelsPerLevel, whole.voxelsPerLevel);
        EXPECT_EQ(merged.written.slices, whole.written.slices);
        for (const auto& part : parts) fs::remove(part);
    }
}

TEST(EsvoBuild, MergeRejectsMissingRepeatedForeignAndCorruptParts) {
    ScratchDir dir;
    const auto options = buildOptions(7, 2);
    std::vector<fs::path> parts;
    for (std::uint32_t k = 0; k < 3; ++k) {
        auto run = options;
        run.partitions = {k, 3};
        parts.push_back(dir / ("run" + std::to_string(k) + ".esvopart"));
        vox::buildEsvo(parts.back(), cornellBox(), run);
    }
    const auto expectInvalid = [&](const std::vector<fs::path>& given, const std::string& problem) {
        try {
            vox::mergeEsvoParts(dir / "out.esvo", given);
            ADD_FAILURE() << "merged: " << problem;
        } catch (const vox::InvalidDataError& e) {
            EXPECT_NE(std::string(e.what()).find(problem), std::string::npos) << e.what();
        }
        EXPECT_FALSE(fs::exists(dir / "out.esvo"));
    };
    expectInvalid({parts[0], parts[2]}, "run 2 of 3 is missing");
    expectInvalid({parts[0], parts[1]}, "run 3 of 3 is missing");
    expectInvalid({parts[0], parts[1], parts[1], parts[2]}, "run 2 of 3 is given twice");

    // A run of a build with other options.
    auto other = options;
    other.voxelize.contourError = 1;
    other.partitions = {1, 3};
    vox::buildEsvo(dir / "other.esvopart", cornellBox(), other);
    expectInvalid({parts[0], dir / "other.esvopart", parts[2]}, "part of a different build");

    // A flipped byte: in a slice (found when the block is read), in the records, in the header.
    const auto bytes = bytesOf(parts[1]);
    for (const std::size_t at : {std::size_t{400}, bytes.size() - 10, std::size_t{20}}) {
        auto flipped = bytes;
        flipped[at] = static_cast<char>(flipped[at] ^ 0x40);
        vox::test::writeBinary(dir / "flipped.esvopart",
                               std::vector<std::uint8_t>(flipped.begin(), flipped.end()));
        expectInvalid({parts[0], dir / "flipped.esvopart", parts[2]}, "checksum");
    }
    // Truncated, and not a part file at all.
    vox::test::writeBinary(dir / "short.esvopart",
                           std::vector<std::uint8_t>(bytes.begin(), bytes.begin() + 1000));
    expectInvalid({parts[0], dir / "short.esvopart", parts[2]},
                  "part file header: inconsistent fields");
    vox::test::writeText(dir / "text.esvopart", std::string(400, 'x'));
    expectInvalid({parts[0], dir / "text.esvopart", parts[2]}, "not a part file");
    EXPECT_NO_THROW(vox::mergeEsvoParts(dir / "out.esvo", parts));
}

TEST(EsvoBuild, BadOptionsAreUsageErrors) {
    ScratchDir dir;
    auto options = buildOptions(8, 5);  // deeper than the cell level (4)
    EXPECT_THROW(vox::buildEsvo(dir / "a.esvo", cornellBox(), options), vox::UsageError);
    options = buildOptions(8, 0);
    options.partitions = {0, 2};  // runs need partitions
    EXPECT_THROW(vox::buildEsvo(dir / "a.esvopart", cornellBox(), options), vox::UsageError);
    options = buildOptions(8, 2);
    options.memoryLimit = 1 << 20;  // below what the process already holds
    EXPECT_THROW(vox::buildEsvo(dir / "a.esvo", cornellBox(), options), vox::UsageError);
    EXPECT_TRUE(dir.files().empty());
}
