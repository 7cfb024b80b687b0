// The .esvo writer (libvox/src/octree/esvo_write.cpp), reader, validator and slice pool
// (formats/src/esvo*.cpp): files written from voxelized meshes open, validate and hold exactly the
// octree's voxels, whatever the slice size and near pointer limit; output is deterministic;
// corrupted files are rejected with InvalidDataError naming the file; the pool streams slices.
#include <vox/base/error.h>
#include <vox/formats/esvo.h>
#include <vox/formats/esvo_reader.h>
#include <vox/octree.h>
#include <vox/scene.h>
#include <vox/util/parallel.h>

#include "test_support.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <map>
#include <set>
#include <vector>

namespace fs = std::filesystem;
using vox::test::ScratchDir;

namespace {

constexpr double kPi = 3.14159265358979323846;

/// A bumpy UV sphere: @p stacks × @p slices quads (triangle fans at the poles), about
/// 2·stacks·slices triangles, so that no face lines up with the voxel grid.
vox::Scene bumpySphere(int stacks = 32, int slices = 64) {
    vox::Mesh mesh;
    mesh.name = "sphere";
    const auto radius = [](double theta, double phi) {
        return 1.0 + 0.08 * std::sin(3 * theta) * std::cos(2 * phi) + 0.03 * std::sin(5 * phi);
    };
    for (int i = 0; i <= stacks; ++i) {
        const double theta = kPi * i / stacks;
        for (int j = 0; j < slices; ++j) {
            const double phi = 2 * kPi * j / slices;
            const double r = radius(theta, phi);
            const vox::Vec3d p{r * std::sin(theta) * std::cos(phi), r * std::cos(theta),
                               r * std::sin(theta) * std::sin(phi)};
            mesh.positions.push_back({static_cast<float>(p.x + 0.3), static_cast<float>(p.y - 0.1),
                                      static_cast<float>(p.z + 2.0)});
            const vox::Vec3d n = vox::normalize(p);
            mesh.normals.push_back(
                {static_cast<float>(n.x), static_cast<float>(n.y), static_cast<float>(n.z)});
        }
    }
    const auto at = [&](int i, int j) {
        return static_cast<std::uint32_t>(i * slices + (j % slices));
    };
    for (int i = 0; i < stacks; ++i)
        for (int j = 0; j < slices; ++j) {
            if (i > 0)
                mesh.indices.insert(mesh.indices.end(), {at(i, j), at(i, j + 1), at(i + 1, j)});
            if (i + 1 < stacks)
                mesh.indices.insert(mesh.indices.end(),
                                    {at(i, j + 1), at(i + 1, j + 1), at(i + 1, j)});
        }
    vox::Scene scene;
    scene.materials.push_back(vox::Material{});
    scene.meshes.push_back(std::move(mesh));
    return scene;
}

vox::SparseOctree voxelizeSphere(std::uint32_t depth) {
    vox::SurfaceVoxelizeOptions options;
    options.depth = depth;
    return vox::voxelizeSurface(bumpySphere(), options);
}

/// The sphere octrees, built once.
const vox::SparseOctree& sphere(std::uint32_t depth) {
    static std::map<std::uint32_t, vox::SparseOctree> cache;
    auto it = cache.find(depth);
    if (it == cache.end()) it = cache.emplace(depth, voxelizeSphere(depth)).first;
    return it->second;
}

vox::EsvoWriteResult write(const fs::path& file, const vox::SparseOctree& octree,
                           std::uint32_t sliceBytes = 1u << 20,
                           std::uint32_t nearPointerLimit = 0x7FFF) {
    vox::EsvoWriteOptions options;
    options.sliceBytes = sliceBytes;
    options.nearPointerLimit = nearPointerLimit;
    options.sceneBounds = bumpySphere().bounds();
    return vox::writeEsvo(file, octree, options);
}

std::vector<std::uint8_t> readBytes(const fs::path& file) {
    std::ifstream in(file, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

using Key = std::uint64_t;  // x | y << 21 | z << 42
Key key(std::uint64_t x, std::uint64_t y, std::uint64_t z) { return x | (y << 21) | (z << 42); }
Key childKey(Key k, std::uint32_t slot) {
    return key(2 * (k & 0x1FFFFF) + (slot & 1u), 2 * ((k >> 21) & 0x1FFFFF) + ((slot >> 1) & 1u),
               2 * (k >> 42) + (slot >> 2));
}
using Levels = std::vector<std::set<Key>>;  // voxel positions per level

/// The octree's voxels per level, decoded from the masks.
Levels octreeVoxels(const vox::SparseOctree& octree) {
    Levels levels(octree.leafDepth + 1);
    std::vector<Key> current{0};
    levels[0].insert(0);
    for (std::uint32_t l = 0; l < octree.leafDepth; ++l) {
        std::vector<Key> next;
        for (std::size_t i = 0; i < current.size(); ++i)
            for (std::uint32_t slot = 0; slot < 8; ++slot)
                if (octree.masks[l][i] & (1u << slot)) next.push_back(childKey(current[i], slot));
        levels[l + 1].insert(next.begin(), next.end());
        current = std::move(next);
    }
    return levels;
}

/// The voxels reachable in a pool's arena, walking descriptors the way the format defines them
/// (valid mask, non-leaf mask, near child pointer or far slot; a far slot of 0 is a child slice
/// that is not loaded). Written independently of the ray caster.
struct WalkStats {
    std::uint32_t maxNearPointer = 0;
    std::uint64_t farDescriptors = 0;  ///< descriptors that reach their children through a far slot
};
Levels poolVoxels(const vox::esvo::EsvoPool& pool, std::uint32_t leafDepth,
                  WalkStats* stats = nullptr) {
    Levels levels(leafDepth + 1);
    levels[0].insert(0);
    const std::uint32_t* words = pool.words();
    struct Item {
        std::uint64_t word;
        std::uint32_t level;
        Key position;
    };
    std::vector<Item> stack{{pool.rootDescriptorWord(), 0, 0}};
    while (!stack.empty()) {
        const Item d = stack.back();
        stack.pop_back();
        EXPECT_LT(d.word + 1, pool.wordCount());
        if (d.word + 1 >= pool.wordCount()) return levels;
        const vox::esvo::ChildDescriptor desc{words[d.word], words[d.word + 1]};
        std::int64_t offset = desc.childPointer();
        bool loaded = true;
        if (desc.far()) {
            offset = static_cast<std::int32_t>(words[d.word + 2 * offset]);
            loaded = offset != 0;
            if (stats) ++stats->farDescriptors;
        } else if (stats) {
            stats->maxNearPointer = std::max(stats->maxNearPointer, desc.childPointer());
        }
        std::uint32_t nonLeafSeen = 0;
        for (std::uint32_t slot = 0; slot < 8; ++slot) {
            if (!(desc.validMask() & (1u << slot))) continue;
            const Key child = childKey(d.position, slot);
            levels[d.level + 1].insert(child);
            if (!(desc.nonLeafMask() & (1u << slot))) continue;
            if (loaded)
                stack.push_back({static_cast<std::uint64_t>(static_cast<std::int64_t>(d.word) +
                                                            2 * (offset + nonLeafSeen)),
                                 d.level + 1, child});
            ++nonLeafSeen;
        }
    }
    return levels;
}

std::uint64_t pagesBytes(std::uint32_t byteSize) {
    return (byteSize + vox::esvo::kPageBytes - 1) / vox::esvo::kPageBytes * vox::esvo::kPageBytes;
}

/// Checks everything a written file must satisfy against the octree it came from.
void expectFileMatches(const fs::path& file, const vox::SparseOctree& octree,
                       const vox::EsvoWriteResult& result, std::uint32_t sliceBytes,
                       std::uint32_t nearPointerLimit) {
    const vox::esvo::EsvoReader reader(file);
    const vox::esvo::Header& h = reader.header();
    EXPECT_EQ(h.leafDepth, octree.leafDepth);
    EXPECT_EQ(h.sliceBytesLimit, sliceBytes);
    EXPECT_EQ(h.nearPointerLimit, nearPointerLimit);
    EXPECT_EQ(h.worldToRoot, octree.cube.worldToUnit());
    EXPECT_EQ(h.fileBytes, fs::file_size(file));
    EXPECT_EQ(result.fileBytes, fs::file_size(file));
    EXPECT_EQ(result.slices, reader.sliceCount());
    EXPECT_EQ(h.sliceCount, reader.sliceCount());
    const vox::Bounds3f bounds = bumpySphere().bounds();
    EXPECT_EQ(h.sceneBoundsMin, (std::array<double, 3>{bounds.min.x, bounds.min.y, bounds.min.z}));
    EXPECT_EQ(h.sceneBoundsMax, (std::array<double, 3>{bounds.max.x, bounds.max.y, bounds.max.z}));
    EXPECT_EQ(reader.directory().voxelsPerLevel, octree.voxelsPerLevel);

    // Directory totals against the octree: one descriptor per voxel with children, every voxel
    // but the root counted once.
    std::uint64_t descriptors = 0, far = 0, voxels = 0;
    for (std::uint32_t i = 0; i < reader.sliceCount(); ++i) {
        const vox::esvo::SliceEntry& s = reader.slice(i);
        EXPECT_LE(s.byteSize, sliceBytes) << "slice " << i;
        EXPECT_EQ(s.fileOffset % 64, 0u) << "slice " << i;
        descriptors += s.descriptorCount;
        far += s.farPointerCount;
        voxels += s.voxelCount;
    }
    std::uint64_t interior = 0;
    for (std::uint32_t l = 0; l < octree.leafDepth; ++l) interior += octree.voxelsPerLevel[l];
    EXPECT_EQ(descriptors, interior);
    EXPECT_EQ(descriptors, result.descriptors);
    EXPECT_EQ(far, result.farPointers);
    EXPECT_EQ(voxels, octree.voxelCount() - 1);

    const vox::esvo::FileBreakdown b = vox::esvo::validateFile(reader);
    EXPECT_EQ(b.descriptorBytes, 8 * descriptors);
    EXPECT_EQ(b.farPointerBytes, 8 * far);
    EXPECT_EQ(b.attributeLookupBytes + b.attributeValueBytes + b.attributeBlockBytes, 0u);
    EXPECT_EQ(b.headerAndDirectoryBytes,
              256 + vox::esvo::directoryBytes(h.leafDepth, h.sliceCount));
    EXPECT_EQ(b.descriptorBytes + b.farPointerBytes + b.pageHeaderBytes + b.infoBytes +
                  b.paddingBytes + b.headerAndDirectoryBytes + b.slicePaddingBytes,
              h.fileBytes);

    // Loaded into a pool, the file holds exactly the octree's voxels.
    vox::esvo::EsvoPool pool(reader);
    pool.loadAll();
    EXPECT_EQ(pool.loadedSliceCount(), reader.sliceCount());
    const Levels fromFile = poolVoxels(pool, h.leafDepth);
    const Levels fromOctree = octreeVoxels(octree);
    for (std::uint32_t l = 0; l <= h.leafDepth; ++l) {
        EXPECT_EQ(fromFile[l].size(), octree.voxelsPerLevel[l]) << "level " << l;
        EXPECT_TRUE(fromFile[l] == fromOctree[l]) << "level " << l << " differs";
    }
}

/// Rewrites the directory's and the header's checksums after an edit of either.
void fixDirectoryAndHeaderChecksums(std::vector<std::uint8_t>& bytes) {
    using namespace vox::esvo;
    const std::uint64_t dirBytes = directoryBytes(load<std::uint32_t>(bytes.data() + 192),
                                                  load<std::uint32_t>(bytes.data() + 212));
    store<std::uint32_t>(bytes.data() + 232, crc32c(bytes.data() + 256, dirBytes));
    store<std::uint32_t>(bytes.data() + 252, crc32c(bytes.data(), 252));
}

/// Rewrites header checksum, directory checksums and slice checksums after @p edit changed
/// the bytes of a file, so that only the structural checks can catch the edit.
void fixChecksums(std::vector<std::uint8_t>& bytes) {
    using namespace vox::esvo;
    const std::uint32_t leafDepth = load<std::uint32_t>(bytes.data() + 192);
    const std::uint32_t sliceCount = load<std::uint32_t>(bytes.data() + 212);
    for (std::uint32_t i = 0; i < sliceCount; ++i) {
        std::uint8_t* e = bytes.data() + 256 + 8 * (leafDepth + 1) + 64 * i;
        const std::uint64_t offset = load<std::uint64_t>(e);
        const std::uint32_t size = load<std::uint32_t>(e + 8);
        store<std::uint32_t>(e + 12, crc32c(bytes.data() + offset, size));
    }
    fixDirectoryAndHeaderChecksums(bytes);
}

enum class Outcome { Valid, Invalid };

/// Opens and fully validates @p file; InvalidDataError must name the file; any other exception
/// type fails the test.
Outcome openAndValidate(const fs::path& file) {
    try {
        const vox::esvo::EsvoReader reader(file);
        (void)vox::esvo::validateFile(reader);
        vox::esvo::EsvoPool pool(reader);
        pool.loadAll();
        return Outcome::Valid;
    } catch (const vox::InvalidDataError& e) {
        EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
        EXPECT_EQ(e.exitCode(), vox::ExitCode::InvalidData);
        return Outcome::Invalid;
    }
}

}  // namespace

TEST(Esvo, SingleSliceFileHoldsTheOctree) {
    ScratchDir dir;
    const vox::SparseOctree& octree = sphere(8);
    const fs::path file = dir / "sphere.esvo";
    const vox::EsvoWriteResult result = write(file, octree);
    std::printf("depth 8: %llu voxels, %llu bytes, %u slices, %llu far pointers\n",
                static_cast<unsigned long long>(octree.voxelCount()),
                static_cast<unsigned long long>(result.fileBytes), result.slices,
                static_cast<unsigned long long>(result.farPointers));
    EXPECT_GT(octree.voxelsPerLevel.back(), 100000u);
    EXPECT_EQ(result.slices, 1u);  // < 1 MiB of descriptors
    expectFileMatches(file, octree, result, 1u << 20, 0x7FFF);
    EXPECT_TRUE(dir.files() ==
                std::vector<std::string>{"sphere.esvo"});  // no temporary left behind
}

TEST(Esvo, ManySmallSlices) {
    ScratchDir dir;
    for (std::uint32_t depth : {7u, 9u}) {
        SCOPED_TRACE("depth " + std::to_string(depth));
        const vox::SparseOctree& octree = sphere(depth);
        const fs::path file = dir / ("sphere" + std::to_string(depth) + ".esvo");
        const vox::EsvoWriteResult result = write(file, octree, 16384);
        std::printf("depth %u, 16 KiB slices: %u slices, %llu bytes\n", depth, result.slices,
                    static_cast<unsigned long long>(result.fileBytes));
        EXPECT_GT(result.slices, depth == 9 ? 50u : 2u);
        expectFileMatches(file, octree, result, 16384, 0x7FFF);

        // The directory is a tree in breadth-first order whose slices cover consecutive levels.
        const vox::esvo::EsvoReader reader(file);
        std::uint32_t deepest = 0;
        for (std::uint32_t i = 0; i < reader.sliceCount(); ++i) {
            const vox::esvo::SliceEntry& s = reader.slice(i);
            EXPECT_LE(s.byteSize, 16384u);
            EXPECT_GT(s.descriptorCount, 0u);
            deepest = std::max<std::uint32_t>(deepest, s.endLevel);
            if (i == 0) {
                EXPECT_EQ(s.parent, vox::esvo::kNoSlice);
                EXPECT_EQ(s.firstLevel, 0);
                continue;
            }
            ASSERT_LT(s.parent, i);
            // Root groups are children of the parent's frontier descriptors, which may sit at any
            // of the parent's levels.
            EXPECT_GT(s.firstLevel, reader.slice(s.parent).firstLevel);
            EXPECT_LE(s.firstLevel, reader.slice(s.parent).endLevel);
            EXPECT_LT(s.regionLevel, s.firstLevel);
            EXPECT_GE(i, reader.slice(s.parent).firstChild);
            EXPECT_LT(i, reader.slice(s.parent).firstChild + reader.slice(s.parent).childCount);
        }
        EXPECT_EQ(deepest,
                  depth);  // the last levels of descriptors sit at depth − 1 … describing depth
    }
}

TEST(Esvo, LowNearPointerLimitForcesFarPointers) {
    ScratchDir dir;
    const vox::SparseOctree& octree = sphere(8);
    const vox::EsvoWriteResult normal = write(dir / "near.esvo", octree);
    {
        const vox::esvo::EsvoReader reader(dir / "near.esvo");
        vox::esvo::EsvoPool pool(reader);
        WalkStats stats;
        (void)poolVoxels(pool, octree.leafDepth, &stats);
        EXPECT_GT(stats.maxNearPointer, 32u);  // so the limit of 32 below really changes the layout
        EXPECT_LE(stats.maxNearPointer, 0x7FFFu);
    }
    for (std::uint32_t sliceBytes : {1u << 20, 16384u}) {
        SCOPED_TRACE("slice bytes " + std::to_string(sliceBytes));
        const fs::path file = dir / ("far" + std::to_string(sliceBytes) + ".esvo");
        const vox::EsvoWriteResult result = write(file, octree, sliceBytes, 32);
        expectFileMatches(file, octree, result, sliceBytes, 32);
        const vox::esvo::EsvoReader reader(file);
        std::uint64_t far = 0;
        for (std::uint32_t i = 0; i < reader.sliceCount(); ++i)
            far += reader.slice(i).farPointerCount;
        EXPECT_GT(far, 0u);
        EXPECT_EQ(far, result.farPointers);
        if (sliceBytes == (1u << 20)) {
            EXPECT_GT(far, normal.farPointers);
            EXPECT_GT(result.fileBytes, normal.fileBytes);  // far slots cost space
        }
        // Every near child pointer respects the limit; the others go through far slots.
        vox::esvo::EsvoPool pool(reader);
        pool.loadAll();
        WalkStats stats;
        (void)poolVoxels(pool, octree.leafDepth, &stats);
        EXPECT_LE(stats.maxNearPointer, 32u);
        EXPECT_GT(stats.maxNearPointer, 0u);
        EXPECT_GT(stats.farDescriptors, 0u);
        if (sliceBytes == (1u << 20)) {
            EXPECT_EQ(stats.farDescriptors, far);  // one slice: no frontier slots
        }
    }
}

TEST(Esvo, PageHeadersEvery8KiBInsideLargeSlices) {
    ScratchDir dir;
    const vox::SparseOctree& octree = sphere(8);
    for (std::uint32_t sliceBytes : {1u << 20, 65536u}) {
        SCOPED_TRACE("slice bytes " + std::to_string(sliceBytes));
        const fs::path file = dir / "pages.esvo";
        const vox::EsvoWriteResult result = write(file, octree, sliceBytes);
        const vox::esvo::EsvoReader reader(file);
        EXPECT_NO_THROW((void)vox::esvo::validateFile(reader));
        std::vector<std::vector<vox::esvo::FrontierDescriptor>> frontiers(reader.sliceCount());
        const vox::esvo::FrontierDescriptor rootParent{1, {}};
        std::uint32_t bigSlices = 0;
        for (std::uint32_t i = 0; i < reader.sliceCount(); ++i) {
            const vox::esvo::SliceEntry& s = reader.slice(i);
            const std::vector<std::uint8_t> block = reader.readSlice(i);
            std::span<const vox::esvo::FrontierDescriptor> parents(&rootParent, 1);
            if (i > 0)
                parents = std::span<const vox::esvo::FrontierDescriptor>(
                    frontiers[s.parent].data() + s.firstFrontier, s.rootGroupCount);
            const vox::esvo::BlockSummary summary =
                vox::esvo::validateBlock(file, reader.header(), i, s, block, parents);
            frontiers[i] = summary.frontier;
            // One page header per 8 KiB page before the info section, each pointing at it.
            const auto infoWord = vox::esvo::load<std::int32_t>(block.data());
            const std::uint64_t pages = (4ull * infoWord + 8191) / 8192;
            EXPECT_EQ(summary.pageHeaderBytes, 8 * pages) << "slice " << i;
            for (std::uint64_t p = 0; p < pages; ++p) {
                EXPECT_EQ(vox::esvo::load<std::int32_t>(block.data() + 8192 * p),
                          infoWord - static_cast<std::int32_t>(2048 * p));
                EXPECT_EQ(vox::esvo::load<std::uint32_t>(block.data() + 8192 * p + 4), 0u);
            }
            if (s.byteSize > 8192 && 4ull * infoWord > 8192) {
                ++bigSlices;
                EXPECT_GT(summary.pageHeaderBytes, 8u) << "slice " << i;
            }
        }
        EXPECT_GT(bigSlices, 0u);
        (void)result;
    }
}

TEST(Esvo, OutputIsDeterministic) {
    ScratchDir dir;
    const vox::Scene scene = bumpySphere();
    vox::SurfaceVoxelizeOptions options;
    options.depth = 8;
    for (const auto& [sliceBytes, nearLimit] :
         {std::pair{1u << 20, 0x7FFFu}, std::pair{16384u, 64u}}) {
        SCOPED_TRACE("slice bytes " + std::to_string(sliceBytes) + ", near pointer limit " +
                     std::to_string(nearLimit));
        const vox::SparseOctree all = vox::voxelizeSurface(scene, options);
        write(dir / "a.esvo", all, sliceBytes, nearLimit);
        write(dir / "b.esvo", all, sliceBytes, nearLimit);
        {
            vox::ThreadLimit limit(1);
            const vox::SparseOctree one = vox::voxelizeSurface(scene, options);
            write(dir / "c.esvo", one, sliceBytes, nearLimit);
        }
        const auto a = readBytes(dir / "a.esvo");
        EXPECT_GT(a.size(), 100000u);
        EXPECT_TRUE(a == readBytes(dir / "b.esvo")) << "same octree written twice";
        EXPECT_TRUE(a == readBytes(dir / "c.esvo")) << "one thread vs all threads";
    }
}

TEST(Esvo, CorruptedFilesAreInvalidData) {
    ScratchDir dir;
    const fs::path good = dir / "good.esvo";
    write(good, sphere(7), 16384);
    const std::vector<std::uint8_t> bytes = readBytes(good);
    ASSERT_EQ(openAndValidate(good), Outcome::Valid);
    const vox::esvo::EsvoReader reader(good);
    ASSERT_GT(reader.sliceCount(), 1u);
    const std::uint64_t directoryEnd = 256 + reader.header().directoryBytes;
    const fs::path bad = dir / "bad.esvo";

    const auto expectInvalid = [&](const std::vector<std::uint8_t>& data, const std::string& what) {
        vox::test::writeBinary(bad, data);
        EXPECT_EQ(openAndValidate(bad), Outcome::Invalid) << what;
    };
    // Every byte of the header and the directory, flipped.
    for (std::uint64_t i = 0; i < directoryEnd; ++i) {
        std::vector<std::uint8_t> data = bytes;
        data[i] ^= 0x20;
        expectInvalid(data, "byte " + std::to_string(i) + " of the header/directory flipped");
    }
    // Bytes in every slice (a spread of positions: descriptors, page headers, info section).
    for (std::uint32_t s = 0; s < reader.sliceCount(); ++s) {
        const vox::esvo::SliceEntry& e = reader.slice(s);
        for (std::uint64_t at : {std::uint64_t{0}, std::uint64_t{5}, std::uint64_t{e.byteSize / 2},
                                 std::uint64_t{e.byteSize - 1}}) {
            std::vector<std::uint8_t> data = bytes;
            data[e.fileOffset + at] ^= 0x01;
            expectInvalid(
                data, "slice " + std::to_string(s) + " byte " + std::to_string(at) + " flipped");
        }
    }
    // Truncated (a byte short, or cut inside the header / directory / last slice) and appended to.
    for (std::uint64_t size :
         {std::uint64_t{0}, std::uint64_t{100}, std::uint64_t{256}, directoryEnd - 1,
          directoryEnd + 100, std::uint64_t{bytes.size() - 1}})
        expectInvalid(std::vector<std::uint8_t>(bytes.begin(),
                                                bytes.begin() + static_cast<std::ptrdiff_t>(size)),
                      "truncated to " + std::to_string(size));
    std::vector<std::uint8_t> appended = bytes;
    appended.push_back(0);
    expectInvalid(appended, "a byte appended");
    // Not an .esvo file at all.
    expectInvalid(std::vector<std::uint8_t>(4096, 0x41), "text");
}

TEST(Esvo, SliceOffsetsThatWrapPastTwoToThe64AreInvalidData) {
    // An aligned offset within one slice of 2^64 makes offset + size wrap to a small number that
    // lies inside the file (a crash the fuzzer found: the validator then sized a gap buffer from
    // the offset). With the directory's and header's checksums repaired, only the bounds check
    // can reject it, and it must name the entry.
    ScratchDir dir;
    const fs::path good = dir / "good.esvo";
    write(good, sphere(6), 16384);
    const std::vector<std::uint8_t> bytes = readBytes(good);
    const vox::esvo::EsvoReader reader(good);
    const vox::esvo::Header& h = reader.header();
    ASSERT_GT(reader.sliceCount(), 1u);
    const fs::path bad = dir / "bad.esvo";
    for (std::uint32_t s = 0; s < reader.sliceCount(); ++s) {
        const vox::esvo::SliceEntry& e = reader.slice(s);
        constexpr std::uint64_t align = vox::esvo::kSliceAlignment;
        for (const std::uint64_t offset : {0 - align, 0 - e.byteSize / align * align}) {
            ASSERT_LE(offset + e.byteSize, h.fileBytes)
                << "the sum must wrap into the file for the test to mean anything";
            std::vector<std::uint8_t> data = bytes;
            vox::esvo::store<std::uint64_t>(data.data() + 256 + 8 * (h.leafDepth + 1) + 64 * s,
                                            offset);
            fixDirectoryAndHeaderChecksums(
                data);  // not fixChecksums: it would read the slice at the offset
            vox::test::writeBinary(bad, data);
            try {
                const vox::esvo::EsvoReader r(bad);
                ADD_FAILURE() << "slice " << s << " at offset " << offset << " accepted";
            } catch (const vox::InvalidDataError& error) {
                EXPECT_NE(std::string(error.what())
                              .find("slice directory entry " + std::to_string(s) +
                                    ": extends past the end"),
                          std::string::npos)
                    << error.what();
            }
        }
    }
}

TEST(Esvo, RootGroupsAboveTheirSlicesRegionAreInvalidData) {
    // A directory entry whose region lies below its root groups' frontier descriptors: its
    // region level raised past them (pathLevels and regionPath extended by octant 0) and its
    // first level with it, so that every directory check passes. Without the validator's check,
    // the region test would shift by the wrapped level difference (undefined behaviour).
    ScratchDir dir;
    const fs::path good = dir / "good.esvo", bad = dir / "bad.esvo";
    std::uint32_t tampered = 0;
    // Depth 8 in 16 KiB slices has slices whose root groups lie at their region's level
    // (frontier above the parent's deepest level), so the region can move below them.
    write(good, sphere(8), 16384);
    const std::vector<std::uint8_t> bytes = readBytes(good);
    const vox::esvo::EsvoReader reader(good);
    const vox::esvo::Header& h = reader.header();
    for (std::uint32_t s = 1; s < reader.sliceCount(); ++s) {
        const vox::esvo::SliceEntry& e = reader.slice(s);
        const vox::esvo::SliceEntry& parent = reader.slice(e.parent);
        // The root groups are at level firstLevel − 1; the region moves one level below them.
        // A slice with children would break their entries' checks first.
        const std::uint32_t raise = e.firstLevel - e.regionLevel;
        const std::uint32_t newFirst = e.firstLevel + 1;
        if (e.childCount != 0 || newFirst > parent.endLevel || e.pathLevels + raise > 21) continue;
        std::vector<std::uint8_t> data = bytes;
        std::uint8_t* entry = data.data() + 256 + 8 * (h.leafDepth + 1) + 64 * s;
        entry[28] = static_cast<std::uint8_t>(e.regionLevel + raise);
        entry[29] = static_cast<std::uint8_t>(newFirst);
        entry[31] = static_cast<std::uint8_t>(e.pathLevels + raise);
        vox::esvo::store<std::uint64_t>(entry + 32, e.regionPath << (3 * raise));
        fixDirectoryAndHeaderChecksums(data);
        vox::test::writeBinary(bad, data);
        ++tampered;
        const vox::esvo::EsvoReader r(bad);  // the directory alone is consistent
        try {
            (void)vox::esvo::validateFile(r);
            ADD_FAILURE() << "slice " << s << " with its region below its root groups validated";
        } catch (const vox::InvalidDataError& error) {
            const std::string expected = "slice directory entry " + std::to_string(s) +
                                         ": a root group lies above the slice's region";
            EXPECT_NE(std::string(error.what()).find(expected), std::string::npos) << error.what();
        }
    }
    EXPECT_GT(tampered, 0u)
        << "no slice of the file could be tampered with this way; the test means nothing";
}

TEST(Esvo, StructuralCorruptionIsCaughtBehindValidChecksums) {
    // With the checksums recomputed, the validator's structural checks must catch the change or
    // the file must still be a consistent octree; nothing may crash.
    ScratchDir dir;
    const fs::path good = dir / "good.esvo";
    write(good, sphere(7), 16384);
    const std::vector<std::uint8_t> bytes = readBytes(good);
    const vox::esvo::EsvoReader reader(good);
    const fs::path bad = dir / "bad.esvo";
    const Levels original = octreeVoxels(sphere(7));
    std::uint32_t tried = 0, caught = 0;
    for (std::uint32_t s = 0; s < std::min<std::uint32_t>(reader.sliceCount(), 3); ++s) {
        const vox::esvo::SliceEntry& e = reader.slice(s);
        for (std::uint64_t at = 0; at < e.byteSize; at += 29) {
            for (std::uint8_t bit : {0x01, 0x10, 0x80}) {
                std::vector<std::uint8_t> data = bytes;
                data[e.fileOffset + at] ^= bit;
                fixChecksums(data);
                vox::test::writeBinary(bad, data);
                ++tried;
                const bool rejected = openAndValidate(bad) == Outcome::Invalid;
                caught += rejected;
                if (!rejected) {
                    // Accepted only if it changed nothing that matters: the same voxels.
                    std::printf("accepted: slice %u (size %u) byte %llu bit 0x%02x\n", s,
                                e.byteSize, (unsigned long long)at, bit);
                    const vox::esvo::EsvoReader changed(bad);
                    vox::esvo::EsvoPool pool(changed);
                    pool.loadAll();
                    EXPECT_TRUE(poolVoxels(pool, 7) == original)
                        << "a changed octree passed validation";
                }
            }
        }
    }
    std::printf("structural corruption: %u of %u single-bit changes rejected\n", caught, tried);
    EXPECT_GT(tried, 500u);
    EXPECT_GE(caught, tried * 95 / 100);
    // The checksum fix-up itself leaves a good file good.
    std::vector<std::uint8_t> same = bytes;
    fixChecksums(same);
    EXPECT_TRUE(same == bytes);
}

TEST(Esvo, MissingFileIsIoError) {
    ScratchDir dir;
    const fs::path missing = dir / "missing.esvo";
    try {
        const vox::esvo::EsvoReader reader(missing);
        ADD_FAILURE() << "opened a file that does not exist";
    } catch (const vox::IoError& e) {
        EXPECT_NE(std::string(e.what()).find("missing.esvo"), std::string::npos) << e.what();
        EXPECT_EQ(e.exitCode(), vox::ExitCode::Io);
    }
    EXPECT_THROW(vox::esvo::EsvoReader{dir.path()}, vox::IoError);  // a directory
}

TEST(Esvo, WriterRejectsBadOptions) {
    ScratchDir dir;
    const vox::SparseOctree& octree = sphere(7);
    EXPECT_THROW(write(dir / "x.esvo", octree, 16383), vox::UsageError);
    EXPECT_THROW(write(dir / "x.esvo", octree, 1u << 20, 31), vox::UsageError);
    EXPECT_THROW(write(dir / "x.esvo", octree, 1u << 20, 0x8000), vox::UsageError);
    EXPECT_TRUE(dir.files().empty());
}

TEST(Esvo, PoolStreamsSlices) {
    ScratchDir dir;
    const vox::SparseOctree& octree = sphere(9);
    const fs::path file = dir / "stream.esvo";
    write(file, octree, 16384);
    const vox::esvo::EsvoReader reader(file);
    const std::uint32_t count = reader.sliceCount();
    ASSERT_GT(count, 20u);
    std::uint64_t allBytes = 0;
    for (std::uint32_t i = 0; i < count; ++i) allBytes += pagesBytes(reader.slice(i).byteSize);

    vox::esvo::EsvoPool pool(reader);
    // Root only: its bytes, and the voxels down to the root slice's end level.
    const vox::esvo::SliceEntry& root = reader.slice(0);
    EXPECT_EQ(pool.loadedSliceCount(), 1u);
    EXPECT_TRUE(pool.loaded(0));
    for (std::uint32_t i = 1; i < count; ++i) EXPECT_FALSE(pool.loaded(i));
    const std::uint64_t rootBytes = pool.residentBytes();
    EXPECT_EQ(rootBytes, pagesBytes(root.byteSize));
    const Levels full = octreeVoxels(octree);
    // What a pool shows: a subset of the octree, level by level, with exactly the voxels the
    // loaded slices hold (plus the root voxel).
    const auto expectConsistentSubset = [&](const vox::esvo::EsvoPool& p) {
        const Levels partial = poolVoxels(p, octree.leafDepth);
        std::uint64_t shown = 0, expected = 1;
        for (std::uint32_t l = 0; l <= octree.leafDepth; ++l) {
            for (Key k : partial[l]) EXPECT_TRUE(full[l].count(k)) << "level " << l;
            shown += partial[l].size();
        }
        for (std::uint32_t i = 0; i < count; ++i)
            if (p.loaded(i)) expected += reader.slice(i).voxelCount;
        EXPECT_EQ(shown, expected);
        EXPECT_TRUE(partial[1] == full[1]);
        return shown;
    };
    EXPECT_LT(expectConsistentSubset(pool), octree.voxelCount());

    // Everything.
    pool.loadAll();
    EXPECT_EQ(pool.loadedSliceCount(), count);
    EXPECT_EQ(pool.residentBytes(), allBytes);
    EXPECT_TRUE(poolVoxels(pool, octree.leafDepth) == full);

    // Unload a child of the root that has children of its own: it and its subtree go.
    std::uint32_t victim = vox::esvo::kNoSlice;
    for (std::uint32_t c = root.firstChild; c < root.firstChild + root.childCount; ++c)
        if (reader.slice(c).childCount > 0) victim = c;
    if (victim == vox::esvo::kNoSlice) victim = root.firstChild;
    std::uint64_t subtreeBytes = 0;
    std::uint32_t subtreeSlices = 0;
    std::vector<std::uint32_t> subtree{victim};
    for (std::size_t k = 0; k < subtree.size(); ++k) {
        const vox::esvo::SliceEntry& s = reader.slice(subtree[k]);
        subtreeBytes += pagesBytes(s.byteSize);
        ++subtreeSlices;
        for (std::uint32_t c = 0; c < s.childCount; ++c) subtree.push_back(s.firstChild + c);
    }
    const std::size_t arenaWords = pool.wordCount();
    pool.unload(victim);
    EXPECT_EQ(pool.residentBytes(), allBytes - subtreeBytes);
    EXPECT_EQ(pool.loadedSliceCount(), count - subtreeSlices);
    for (std::uint32_t s : subtree) EXPECT_FALSE(pool.loaded(s));
    EXPECT_LT(expectConsistentSubset(pool), octree.voxelCount());
    pool.unload(0);  // the root slice stays
    EXPECT_TRUE(pool.loaded(0));

    // Loading a deep slice brings its ancestors back; loading the rest restores everything.
    pool.load(subtree.back());
    for (std::uint32_t s = subtree.back(); s != vox::esvo::kNoSlice; s = reader.slice(s).parent)
        EXPECT_TRUE(pool.loaded(s));
    pool.loadAll();
    EXPECT_EQ(pool.loadedSliceCount(), count);
    EXPECT_EQ(pool.residentBytes(), allBytes);
    EXPECT_LE(pool.wordCount(), arenaWords + 2 * 2048 * subtreeSlices);
    EXPECT_TRUE(poolVoxels(pool, octree.leafDepth) == full);

    // Every slice loaded one by one, in reverse order, into a fresh pool.
    vox::esvo::EsvoPool fresh(reader);
    for (std::uint32_t i = count; i-- > 0;) fresh.load(i);
    EXPECT_EQ(fresh.loadedSliceCount(), count);
    EXPECT_EQ(fresh.residentBytes(), allBytes);
    EXPECT_TRUE(poolVoxels(fresh, octree.leafDepth) == full);

    // Loading by level: the slices starting above level 5 only.
    vox::esvo::EsvoPool byLevel(reader);
    byLevel.loadAll(5);
    for (std::uint32_t i = 0; i < count; ++i)
        EXPECT_EQ(byLevel.loaded(i), reader.slice(i).firstLevel < 5) << "slice " << i;
    (void)expectConsistentSubset(byLevel);
    EXPECT_THROW(byLevel.load(count), vox::InvalidDataError);
}
