// TiledRvolReader's bound on open tile files (formats/src/rvol_tiles.cpp): a bounded reader
// samples exactly what an unbounded one does, never holds more tiles open than allowed, shares its
// tiles safely among threads, and fails, naming the file, where a closed tile has gone.
#include <vox/base/error.h>
#include <vox/formats/rvol_tiles.h>
#include <vox/import.h>
#include <vox/radiance_tiles.h>

#include "cornell_box.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <thread>

namespace {

namespace fs = std::filesystem;
using vox::rvol::Texel;
using vox::rvol::TiledRvolReader;
using vox::rvol::TiledRvolReaderOptions;

/// The Cornell box baked tiled: depth 6, tiles of 16³ cells (57 of the 64 listed).
fs::path bakedIndex(const vox::test::ScratchDir& dir) {
    const vox::Scene scene = vox::importScene(vox::scenes::writeCornellBox(dir.path()));
    vox::RadianceBakeOptions options;
    options.bounces = 1;
    const fs::path index = dir / "tiled.rvol";
    vox::bakeTiledRadiance(scene, options, vox::RadianceTiling::plan(6, 4), {}, index, {});
    return index;
}

TiledRvolReaderOptions bound(std::uint32_t maxOpenTiles) {
    TiledRvolReaderOptions options;
    options.maxOpenTiles = maxOpenTiles;
    return options;
}

/// Every tile kept open once opened: the reader as it was before the bound.
TiledRvolReaderOptions unbounded(const fs::path& index) {
    return bound(static_cast<std::uint32_t>(vox::rvol::readTileIndex(index).tiles.size()));
}

/// The centre of tile @p i's region (its cells' filter reads that tile alone).
std::array<double, 3> tileCentre(const vox::rvol::TileIndex& index, std::size_t i) {
    const vox::rvol::TileEntry& t = index.tiles[i];
    const std::array<double, 3> o = index.tileOrigin(t.x, t.y, t.z);
    const double half = index.tileSize() / 2;
    return {o[0] + half, o[1] + half, o[2] + half};
}

/// Sample positions over the root cube and a little beyond it (clamped there), in an order that
/// jumps between tiles, with a cone direction each.
struct Query {
    std::array<double, 3> p, d;
};
std::vector<Query> queries(const TiledRvolReader& reader, int count) {
    const auto& o = reader.index().origin;
    const double size = reader.index().size;
    std::vector<Query> out;
    for (int i = 0; i < count; ++i) {
        const auto frac = [&](double a) { return i * a - std::floor(i * a); };
        const double u = frac(0.618034), v = frac(0.414214), w = frac(0.732051);
        out.push_back({{o[0] + (1.04 * u - 0.02) * size, o[1] + (1.04 * v - 0.02) * size,
                        o[2] + (1.04 * w - 0.02) * size},
                       {u - 0.5, 0.3 - v, w - 0.5}});
    }
    return out;
}

/// Every channel of every level, and the directional sample above level 0, at each query.
std::vector<Texel> sampleEverything(const TiledRvolReader& reader,
                                    const std::vector<Query>& where) {
    std::vector<Texel> out;
    for (const Query& q : where)
        for (std::uint32_t level = 0; level <= reader.depth(); ++level) {
            for (std::uint32_t c = 0; c < vox::rvol::levelChannels(level); ++c)
                out.push_back(reader.sample(level, c, q.p));
            out.push_back(reader.sampleDirectional(level, q.p, q.d));
        }
    return out;
}

TEST(TiledRvolOpenTiles, FourOpenTilesSampleWhatEveryTileOpenSamples) {
    const vox::test::ScratchDir dir;
    const fs::path index = bakedIndex(dir);
    const TiledRvolReader all(index, unbounded(index));
    const TiledRvolReader four(index, bound(4));
    ASSERT_GT(all.index().tiles.size(), 40u);
    const std::vector<Query> where = queries(all, 1500);
    const std::vector<Texel> expected = sampleEverything(all, where);
    EXPECT_EQ(sampleEverything(four, where), expected);
    // Every cell of level 0, x fastest: each row crosses four tiles, each plane sixteen.
    const std::uint32_t resolution = 1u << all.depth();
    for (std::uint32_t z = 0; z < resolution; ++z)
        for (std::uint32_t y = 0; y < resolution; ++y)
            for (std::uint32_t x = 0; x < resolution; ++x)
                ASSERT_EQ(four.cell(0, 0, x, y, z), all.cell(0, 0, x, y, z))
                    << x << "," << y << "," << z;

    const vox::rvol::OpenTileStats stats = four.openTileStats();
    EXPECT_EQ(stats.mostOpen, 4u) << "the bound must be reached, and never passed";
    EXPECT_LE(stats.open, 4u);
    EXPECT_GT(stats.opened, all.index().tiles.size()) << "closed tiles must have been reopened";
    EXPECT_EQ(stats.opened - stats.closed, stats.open);
    // The unbounded reader opened each tile the samples met once.
    const vox::rvol::OpenTileStats allStats = all.openTileStats();
    EXPECT_EQ(allStats.closed, 0u);
    EXPECT_EQ(allStats.opened, allStats.open);
    std::size_t nonZero = 0;
    for (const Texel& t : expected) nonZero += t.a > 0;
    EXPECT_GT(nonZero, expected.size() / 5);
    std::printf("[ open tiles ] %zu samples; bound 4: %llu openings, %llu closings\n",
                expected.size(), static_cast<unsigned long long>(stats.opened),
                static_cast<unsigned long long>(stats.closed));
}

TEST(TiledRvolOpenTiles, EightThreadsWithTwoOpenTilesSampleAsOneThread) {
    const vox::test::ScratchDir dir;
    const fs::path index = bakedIndex(dir);
    const TiledRvolReader sequential(index, unbounded(index));
    const std::vector<Query> where = queries(sequential, 300);
    std::vector<Texel> expected;
    for (const Query& q : where)
        for (std::uint32_t level = 0; level <= sequential.depth(); ++level)
            expected.push_back(sequential.sampleDirectional(level, q.p, q.d));
    // Each thread starts elsewhere in the list, so that they want different tiles at once.
    const TiledRvolReader shared(index, bound(2));
    std::vector<std::vector<Texel>> got(8);
    std::vector<std::thread> threads;
    for (std::size_t t = 0; t < got.size(); ++t)
        threads.emplace_back([&, t] {
            got[t].resize(expected.size());
            const std::size_t start = t * where.size() / got.size();
            for (std::size_t k = 0; k < where.size(); ++k) {
                const std::size_t i = (start + k) % where.size();
                for (std::uint32_t level = 0; level <= shared.depth(); ++level)
                    got[t][i * (shared.depth() + 1) + level] =
                        shared.sampleDirectional(level, where[i].p, where[i].d);
            }
        });
    for (std::thread& t : threads) t.join();
    for (std::size_t t = 0; t < got.size(); ++t) EXPECT_EQ(got[t], expected) << "thread " << t;
    const vox::rvol::OpenTileStats stats = shared.openTileStats();
    EXPECT_LE(stats.mostOpen, 2u);
    EXPECT_GT(stats.closed, 0u);
}

TEST(TiledRvolOpenTiles, HandlesKeepTheirTilesOpenPastTheBoundUntilReleased) {
    const vox::test::ScratchDir dir;
    const fs::path index = bakedIndex(dir);
    const TiledRvolReader reader(index, bound(2));
    const TiledRvolReader all(index, unbounded(index));
    {
        const auto a = reader.tile(0), b = reader.tile(1), c = reader.tile(2);
        EXPECT_EQ(a->path(), reader.tileFile(0));
        EXPECT_EQ(reader.openTileStats().open, 3u);
        // A sample meeting a fourth tile while handles hold every open one opens it too, rather
        // than wait for handles that this thread holds.
        const std::array<double, 3> p = tileCentre(reader.index(), 3);
        EXPECT_EQ(reader.sample(0, 0, p), all.sample(0, 0, p));
        EXPECT_EQ(reader.openTileStats().open, 4u);
    }
    // Each handle let go closes its tile while the reader is past the bound.
    EXPECT_EQ(reader.openTileStats().open, 2u);
    EXPECT_EQ(reader.openTileStats().mostOpen, 4u);
}

TEST(TiledRvolOpenTiles, AClosedTileWhoseFileHasGoneFailsNamingTheFile) {
    const vox::test::ScratchDir dir;
    const fs::path index = bakedIndex(dir);
    const TiledRvolReader reader(index, bound(1));
    const vox::rvol::TileIndex& tiles = reader.index();
    // Tile 0's centre, then tile 1's: opening tile 1 closes tile 0 (one tile open at most).
    const auto centre = [&](std::size_t i) { return tileCentre(tiles, i); };
    const Texel first = reader.sample(0, 0, centre(0));
    const Texel second = reader.sample(0, 0, centre(1));
    EXPECT_EQ(reader.openTileStats().open, 1u);
    EXPECT_EQ(reader.openTileStats().closed, 1u);

    const fs::path gone = reader.tileFile(0);
    const fs::path kept = dir / "tile-0.rvol";
    fs::rename(gone, kept);
    try {
        (void)reader.sample(0, 0, centre(0));
        ADD_FAILURE() << "sampling a tile whose file has gone must throw";
    } catch (const vox::IoError& e) {
        EXPECT_EQ(std::string(e.what()).rfind(gone.string() + ": cannot open: ", 0), 0u)
            << e.what();
    }
    // Another tile's file in its place is checked against the index entry as on first opening.
    fs::copy_file(reader.tileFile(1), gone);
    try {
        (void)reader.sample(0, 0, centre(0));
        ADD_FAILURE() << "a tile file of another tile must be rejected";
    } catch (const vox::InvalidDataError& e) {
        EXPECT_EQ(std::string(e.what()).rfind(gone.string() + ": does not match its tile index", 0),
                  0u)
            << e.what();
    }
    // The reader goes on: tile 1 (closed to make room for the failed openings) and tile 0, back
    // in place, read as before, one open at a time.
    fs::remove(gone);
    fs::rename(kept, gone);
    EXPECT_EQ(reader.sample(0, 0, centre(1)), second);
    EXPECT_EQ(reader.sample(0, 0, centre(0)), first);
    EXPECT_EQ(reader.openTileStats().mostOpen, 1u);
}

TEST(TiledRvolOpenTiles, NoOpenTilesIsAParameterError) {
    const vox::test::ScratchDir dir;
    EXPECT_THROW(TiledRvolReader(dir / "tiled.rvol", bound(0)), vox::ParameterError);
}

}  // namespace
