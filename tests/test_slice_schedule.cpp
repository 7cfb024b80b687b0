// The streaming policy (runtime/src/slice_schedule.cpp): slice regions, which slices a view
// needs, budgets, and a residency that loads and evicts along a camera flight.
#include <vox/formats/esvo_reader.h>
#include <vox/import.h>
#include <vox/octree.h>
#include <vox/runtime/slice_schedule.h>

#include "cornell_box.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <set>

namespace {

using vox::runtime::SliceRegion;
using vox::runtime::StreamingView;

/// The Cornell box at depth 8 in 16 KB slices: a tree of many slices.
std::filesystem::path smallSliceOctree(const vox::test::ScratchDir& dir) {
    const vox::Scene scene = vox::importScene(vox::scenes::writeCornellBox(dir.path()));
    vox::SurfaceVoxelizeOptions options;
    options.depth = 8;
    const vox::SparseOctree octree = vox::voxelizeSurface(scene, options);
    vox::EsvoWriteOptions write;
    write.sceneBounds = scene.bounds();
    write.sliceBytes = 16384;
    const auto file = dir / "box.esvo";
    (void)vox::writeEsvo(file, octree, write);
    return file;
}

StreamingView view(vox::Vec3d eye, vox::Vec3d target, int size = 256) {
    StreamingView v;
    v.camera.eye = eye;
    v.camera.target = target;
    v.camera.width = v.camera.height = size;
    return v;
}

std::uint64_t sum(const vox::esvo::EsvoReader& reader, const std::vector<std::uint32_t>& slices) {
    std::uint64_t bytes = 0;
    for (std::uint32_t s : slices) bytes += vox::runtime::residentBytesOf(reader.slice(s));
    return bytes;
}

}  // namespace

TEST(SliceSchedule, RegionsNestInTheirParentsAndHoldTheirVoxels) {
    vox::test::ScratchDir dir;
    const vox::esvo::EsvoReader reader(smallSliceOctree(dir));
    ASSERT_GT(reader.sliceCount(), 20u);
    const auto regions = vox::runtime::sliceRegions(reader.directory());
    EXPECT_EQ(regions[0].level, 0u);
    for (std::uint32_t i = 1; i < reader.sliceCount(); ++i) {
        const auto& e = reader.slice(i);
        const SliceRegion& r = regions[i];
        const SliceRegion& p = regions[e.parent];
        EXPECT_EQ(r.level, e.regionLevel) << i;
        ASSERT_GE(r.level, p.level);
        const std::uint32_t shift = r.level - p.level;
        EXPECT_EQ(r.x >> shift, p.x) << i;
        EXPECT_EQ(r.y >> shift, p.y) << i;
        EXPECT_EQ(r.z >> shift, p.z) << i;
        EXPECT_LT(r.level, e.firstLevel) << i;
    }
    // Every voxel a fully loaded pool holds lies in the region of a slice.
    vox::esvo::EsvoPool pool(reader);
    pool.loadAll();
    std::size_t checked = 0;
    pool.forEachVoxel([&](const vox::esvo::VoxelPosition& v, const vox::esvo::AttributeValue*) {
        if (v.level < 8 || ++checked % 97) return;
        const bool inside =
            std::any_of(regions.begin() + 1, regions.end(), [&](const SliceRegion& r) {
                const std::uint32_t shift = v.level - r.level;
                return v.level >= r.level && (v.x >> shift) == r.x && (v.y >> shift) == r.y &&
                       (v.z >> shift) == r.z;
            });
        EXPECT_TRUE(inside) << v.level << " " << v.x << " " << v.y << " " << v.z;
    });
    EXPECT_GT(checked, 1000u);
}

TEST(SliceSchedule, ANearViewNeedsMoreThanAFarOneAndOnlyWhatItSees) {
    vox::test::ScratchDir dir;
    const vox::esvo::EsvoReader reader(smallSliceOctree(dir));
    const auto regions = vox::runtime::sliceRegions(reader.directory());
    const std::uint64_t unlimited = ~std::uint64_t{0};
    // The box spans about 2 m; seen whole from 3 m at 256 pixels, and from 30 m at 64.
    const auto near =
        vox::runtime::selectSlices(reader, regions, view({0, 1, 3.2}, {0, 1, 0}, 512), unlimited);
    const auto far =
        vox::runtime::selectSlices(reader, regions, view({0, 1, 30}, {0, 1, 0}, 64), unlimited);
    EXPECT_EQ(near.neededNotFitting, 0u);
    EXPECT_EQ(near.slices.front(), 0u);
    EXPECT_GT(near.slices.size(), 3 * far.slices.size());
    EXPECT_GE(far.slices.size(), 1u);
    EXPECT_EQ(near.bytes, sum(reader, near.slices));
    // Looking away from the box: the root only.
    const auto away =
        vox::runtime::selectSlices(reader, regions, view({0, 1, 3.2}, {0, 1, 10}, 512), unlimited);
    EXPECT_EQ(away.slices, std::vector<std::uint32_t>{0});
    // Parents before children, no repeats.
    std::set<std::uint32_t> seen;
    for (std::uint32_t s : near.slices) {
        if (s != 0) {
            EXPECT_TRUE(seen.count(reader.slice(s).parent)) << s;
        }
        EXPECT_TRUE(seen.insert(s).second) << s;
    }
    // Deterministic.
    EXPECT_EQ(near.slices, vox::runtime::selectSlices(reader, regions,
                                                      view({0, 1, 3.2}, {0, 1, 0}, 512), unlimited)
                               .slices);
}

TEST(SliceSchedule, ABudgetKeepsTheCoarsestNeededSlices) {
    vox::test::ScratchDir dir;
    const vox::esvo::EsvoReader reader(smallSliceOctree(dir));
    const auto regions = vox::runtime::sliceRegions(reader.directory());
    const StreamingView v = view({0, 1, 3.2}, {0, 1, 0}, 512);
    const auto all = vox::runtime::selectSlices(reader, regions, v, ~std::uint64_t{0});
    const std::uint64_t budget = all.bytes / 3;
    const auto some = vox::runtime::selectSlices(reader, regions, v, budget);
    EXPECT_LE(some.bytes, budget);
    EXPECT_GT(some.neededNotFitting, 0u);
    EXPECT_LT(some.slices.size(), all.slices.size());
    // What fits is a subset of what is needed, closed under parents, and the levels it leaves
    // out are no coarser than the ones it keeps.
    const std::set<std::uint32_t> needed(all.slices.begin(), all.slices.end());
    std::uint32_t keptFinest = 0, droppedCoarsest = 255;
    const std::set<std::uint32_t> kept(some.slices.begin(), some.slices.end());
    for (std::uint32_t s : some.slices) {
        EXPECT_TRUE(needed.count(s)) << s;
        if (s != 0) {
            EXPECT_TRUE(kept.count(reader.slice(s).parent)) << s;
        }
    }
    for (std::uint32_t s : all.slices) {
        const std::uint32_t level = reader.slice(s).firstLevel;
        if (kept.count(s))
            keptFinest = std::max(keptFinest, level);
        else
            droppedCoarsest = std::min(droppedCoarsest, level);
    }
    EXPECT_LE(droppedCoarsest + 0u, keptFinest + 2u)
        << "a budget drops fine slices, not coarse ones";
    EXPECT_GE(droppedCoarsest, reader.slice(some.slices[1]).firstLevel);
    // Even a budget of nothing keeps the root.
    EXPECT_EQ(vox::runtime::selectSlices(reader, regions, v, 0).slices,
              std::vector<std::uint32_t>{0});
}

TEST(SliceSchedule, ResidencyAlongAFlightStaysUnderTheBudgetAndCachesWhatFits) {
    vox::test::ScratchDir dir;
    const vox::esvo::EsvoReader reader(smallSliceOctree(dir));
    vox::esvo::EsvoPool pool(reader);
    const auto regions = vox::runtime::sliceRegions(reader.directory());
    const StreamingView close = view({0, 1, 3.2}, {0, 1, 0}, 512);
    const std::uint64_t budget =
        vox::runtime::selectSlices(reader, regions, close, ~std::uint64_t{0}).bytes * 2 / 3;
    vox::runtime::SliceResidency residency(pool, budget);
    std::uint64_t loads = 0, evictions = 0;
    // A flight from far away to close up, round the box, and back out.
    for (int frame = 0; frame < 24; ++frame) {
        const double t = frame / 23.0;
        const double angle = 6.2831853 * t;
        const double distance = 12 - 9 * std::sin(3.14159265 * t);
        const auto update = residency.update(
            view({distance * std::sin(angle), 1, distance * std::cos(angle)}, {0, 1, 0}, 512));
        loads += update.loaded.size();
        evictions += update.evicted.size();
        EXPECT_LE(pool.residentBytes(), budget) << frame;
        // Everything selected is resident afterwards: no holes.
        for (std::uint32_t s : update.selection.slices)
            EXPECT_TRUE(pool.loaded(s)) << frame << " " << s;
        EXPECT_EQ(update.selection.bytes, sum(reader, update.selection.slices));
    }
    EXPECT_GT(loads, 0u);
    EXPECT_GT(evictions, 0u) << "the budget is two thirds of a close view: the flight must evict";
    // Standing still costs nothing after the first frame.
    const auto first = residency.update(close);
    const auto again = residency.update(close);
    EXPECT_TRUE(again.loaded.empty());
    EXPECT_TRUE(again.evicted.empty());
    EXPECT_EQ(first.selection.slices, again.selection.slices);
    // A bigger budget keeps slices the view stopped needing: looking away and back loads nothing.
    residency.setBudget(~std::uint64_t{0});
    (void)residency.update(close);
    (void)residency.update(view({0, 1, 3.2}, {0, 1, 10}, 512));
    EXPECT_TRUE(residency.update(close).loaded.empty());
}

TEST(SliceSchedule, AFrameLoadLimitSpreadsACameraJumpOverFramesCoarseFirst) {
    vox::test::ScratchDir dir;
    const vox::esvo::EsvoReader reader(smallSliceOctree(dir));
    vox::esvo::EsvoPool pool(reader);
    vox::runtime::SliceResidency residency(pool, ~std::uint64_t{0});
    residency.setFrameLoadLimit(64 << 10);  // 64 KB a frame: four 16 KB slices
    (void)residency.update(view({0, 1, 30}, {0, 1, 0}, 64));
    // Jump close: every needed slice arrives within a bounded number of frames, at most 64 KB a
    // frame, and the coarsest first.
    const StreamingView close = view({0, 1, 3.2}, {0, 1, 0}, 512);
    int frames = 0;
    std::uint32_t previousLevel = 0;
    bool coarseFirst = true;
    for (;;) {
        const auto update = residency.update(close);
        ++frames;
        EXPECT_LE(update.loadedBytes, 64u << 10);
        for (std::uint32_t s : update.loaded) {
            const std::uint32_t level = reader.slice(s).firstLevel;
            coarseFirst = coarseFirst && level + 1 >= previousLevel;
            previousLevel = std::max(previousLevel, level);
        }
        if (update.pending == 0) break;
        ASSERT_LT(frames, 1000);
    }
    EXPECT_TRUE(coarseFirst);
    const auto all = vox::runtime::selectSlices(
        reader, vox::runtime::sliceRegions(reader.directory()), close, ~std::uint64_t{0});
    EXPECT_EQ(pool.loadedSliceCount(), all.slices.size());
    // The bytes the jump needs, 64 KB a frame (slices are 8 or 16 KB, so frames fill up but
    // for the last slice that does not fit).
    const std::uint64_t jump = all.bytes - vox::runtime::residentBytesOf(reader.slice(0));
    const int least = int((jump + (64 << 10) - 1) / (64 << 10));
    EXPECT_GE(frames, least);
    EXPECT_LE(frames, least + least / 4 + 1);
}
