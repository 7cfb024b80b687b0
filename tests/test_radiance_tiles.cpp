// Tiled radiance bakes (libvox/src/radiance/radiance_tiles.cpp, formats/src/rvol_tiles.cpp):
// agreement with the single-volume bake, determinism, runs as separate jobs, and the validator.
#include <vox/base/error.h>
#include <vox/formats/rvol_tiles.h>
#include <vox/import.h>
#include <vox/radiance_tiles.h>

#include "cornell_box.h"
#include "test_support.h"

#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>

namespace {

namespace fs = std::filesystem;
using vox::rvol::TiledRvolReader;

std::vector<char> bytesOf(const fs::path& file) {
    std::ifstream in(file, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

vox::RadianceBakeOptions options(std::uint32_t bounces = 1) {
    vox::RadianceBakeOptions o;
    o.bounces = bounces;
    return o;
}

vox::TiledBakeResult bakeTiled(const vox::Scene& scene, const fs::path& index,
                               const vox::RadianceTiling& tiling, vox::TiledBakeJob job = {}) {
    return vox::bakeTiledRadiance(scene, options(), tiling, job, index, {});
}

/// Every file of a tiled volume, by name, with its bytes.
std::map<std::string, std::vector<char>> filesOf(const fs::path& index) {
    std::map<std::string, std::vector<char>> files;
    files["index"] = bytesOf(index);
    for (const auto& entry : fs::directory_iterator(vox::rvol::tileDirectory(index)))
        files[entry.path().filename().string()] = bytesOf(entry.path());
    return files;
}

TEST(RadianceTiles, PlanKeepsTheFarFieldBelowTheTiles) {
    const auto t = vox::RadianceTiling::plan(12, 8);
    EXPECT_EQ(t.halo, 64u);
    EXPECT_EQ(t.farDepth, 8u);  // far cells of 16 finest cells: a quarter of the halo
    EXPECT_EQ(vox::RadianceTiling::plan(13, 6).farDepth, 10u);
    EXPECT_THROW((void)vox::RadianceTiling::plan(13, 3), vox::ParameterError);     // F would be 11
    EXPECT_THROW((void)vox::RadianceTiling::plan(8, 5, 17), vox::ParameterError);  // halo > T/2
    EXPECT_EQ(vox::RadianceTiling::tileDepthFor(12, 4ull << 30), 8u);
    EXPECT_EQ(vox::RadianceTiling::tileDepthFor(12, 256ull << 20), 7u);
}

/// A single-volume bake and a tiled one (depth 6, tiles of 16³ with a halo of @p halo cells) of
/// the Cornell box, voxel by voxel.
struct Agreement {
    double diff = 0, sum = 0;  ///< Σ |tiled − single| and Σ single, of r + g + b over the voxels
    double worst = 0;          ///< the largest relative difference of one voxel
};

Agreement agreement(const fs::path& dir, std::uint32_t bounces, std::uint32_t halo) {
    const vox::Scene scene = vox::importScene(vox::scenes::writeCornellBox(dir));
    vox::RadianceBakeOptions single = options(bounces);
    single.depth = 6;
    const vox::rvol::Volume whole = vox::bakeRadiance(scene, single).volume;
    const fs::path index = dir / "tiled.rvol";
    const auto tiling = vox::RadianceTiling::plan(6, 4, halo);
    const auto result = vox::bakeTiledRadiance(scene, options(bounces), tiling, {}, index, {});
    EXPECT_EQ(result.tilesBaked, result.tilesTotal);
    EXPECT_EQ(result.staticVoxels, whole.staticVoxels.size());

    const TiledRvolReader tiled(index);
    const auto& level0 = whole.levels[0];
    Agreement out;
    std::vector<std::pair<double, double>> values;  // (single, tiled) per voxel
    for (const vox::rvol::VoxelAttributes& v : whole.staticVoxels) {
        // The same voxels, solid in exactly the same cells (one voxelizer, one grid).
        const vox::rvol::Texel a = level0.at(v.x, v.y, v.z, 0);
        const vox::rvol::Texel b = tiled.cell(0, 0, v.x, v.y, v.z);
        EXPECT_EQ(b.a, 1.0f) << v.x << "," << v.y << "," << v.z;
        const double sa = double(a.r) + a.g + a.b, sb = double(b.r) + b.g + b.b;
        out.diff += std::abs(sa - sb);
        out.sum += sa;
        values.emplace_back(sa, sb);
    }
    // Relative to each voxel's value, floored at 1 % of the mean (as bench/radiance_seams).
    const double floor = 0.01 * out.sum / double(std::max<std::size_t>(values.size(), 1));
    for (const auto& [sa, sb] : values)
        out.worst = std::max(out.worst, std::abs(sa - sb) / std::max(sa, floor));
    // Above the tiles the far field answers, in the same world frame.
    const vox::rvol::RvolReader& far = tiled.farField();
    const std::array<double, 3> p{0.1, 0.5, 0.2};
    EXPECT_EQ(tiled.sample(5, 2, p), far.sample(5 - (6 - tiling.farDepth), 2, p));
    vox::rvol::validateTiledRvol(index);
    return out;
}

TEST(RadianceTiles, TiledDirectLightIsTheSingleVolumes) {
    // Shadow rays run through the whole scene's occupancy at the finest level, and no voxel lies
    // beyond the root cube: every voxel's direct light is the single bake's (it was 20.7 % off
    // with shadow rays through the far field's coarse cells, and the box's outer faces black).
    const vox::test::ScratchDir dir;
    const Agreement a = agreement(dir.path(), 0, 4);  // far cells of 1
    // Measured 0.05 % summed over the box, 0.4 % at worst (rounding: the tile's cube has another
    // origin, so the voxel centres and ray origins differ in the last bits).
    EXPECT_LT(a.diff / a.sum, 0.002);
    EXPECT_LT(a.worst, 0.02);
}

TEST(RadianceTiles, TiledBakeAgreesWithTheSingleVolume) {
    const vox::test::ScratchDir dir;
    // A halo of 8 cells, far cells of 2: cones read a coarser far field beyond the halo.
    const Agreement a = agreement(dir.path(), 1, 8);
    // One bounce, which reads the far field beyond the halo: the radiance summed over the box
    // within 3.7 % (measured 3.4 %, 23 % with the far field's shadow rays; the seams at larger
    // depths are in docs/internals/rvol-writer.md, "Tiled bakes").
    EXPECT_LT(a.diff / a.sum, 0.037);
}

TEST(RadianceTiles, ByteIdenticalWhateverTheThreadCount) {
    const vox::test::ScratchDir dir;
    const vox::Scene scene = vox::importScene(vox::scenes::writeCornellBox(dir.path()));
    const auto tiling = vox::RadianceTiling::plan(5, 3);
    std::map<std::string, std::vector<char>> files[2];
    for (int threads : {1, 2}) {
        const tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                                        static_cast<std::size_t>(threads));
        const fs::path index = dir.path() / (threads == 1 ? "t1.rvol" : "t2.rvol");
        bakeTiled(scene, index, tiling);
        files[threads - 1] = filesOf(index);
    }
    EXPECT_GT(files[0].size(), 3u);
    EXPECT_EQ(files[0], files[1]);
}

TEST(RadianceTiles, RunsAsSeparateJobsGiveTheWholeBakesFiles) {
    const vox::test::ScratchDir dir;
    const vox::Scene scene = vox::importScene(vox::scenes::writeCornellBox(dir.path()));
    const auto tiling = vox::RadianceTiling::plan(5, 3);
    const fs::path whole = dir.path() / "whole.rvol", split = dir.path() / "split.rvol";
    bakeTiled(scene, whole, tiling);
    using Kind = vox::TiledBakeJob::Kind;
    std::uint64_t baked = 0;
    for (std::uint32_t run = 0; run < 3; ++run)
        baked += bakeTiled(scene, split, tiling, {Kind::Run, run, 3}).tilesBaked;
    // The index step refuses while a tile is missing, then writes the index.
    const auto files = filesOf(split);
    EXPECT_EQ(baked, files.size() - 1);
    const fs::path oneTile = fs::directory_iterator(vox::rvol::tileDirectory(split))->path();
    fs::rename(oneTile, dir.path() / "aside");
    EXPECT_THROW(bakeTiled(scene, split, tiling, {Kind::Index, 0, 1}), vox::IoError);
    EXPECT_FALSE(fs::exists(split));
    fs::rename(dir.path() / "aside", oneTile);
    bakeTiled(scene, split, tiling, {Kind::Index, 0, 1});
    EXPECT_EQ(filesOf(whole), filesOf(split));
}

TEST(RadianceTiles, ValidatorRejectsABrokenIndexOrAForeignTile) {
    const vox::test::ScratchDir dir;
    const vox::Scene scene = vox::importScene(vox::scenes::writeCornellBox(dir.path()));
    const fs::path index = dir.path() / "t.rvol";
    bakeTiled(scene, index, vox::RadianceTiling::plan(5, 3));
    const std::vector<char> good = bytesOf(index);
    const auto write = [&](const std::vector<char>& bytes) {
        std::ofstream(index, std::ios::binary).write(bytes.data(), std::streamsize(bytes.size()));
    };
    const auto message = [&]() -> std::string {
        try {
            vox::rvol::validateTiledRvol(index);
        } catch (const vox::InvalidDataError& e) {
            return e.what();
        }
        return "";
    };
    EXPECT_EQ(message(), "");
    // A flipped byte anywhere in the index: header or table checksum.
    for (std::size_t at : {std::size_t{12}, std::size_t{200}, good.size() - 1}) {
        std::vector<char> bad = good;
        bad[at] = static_cast<char>(bad[at] ^ 0x10);
        write(bad);
        EXPECT_NE(message().find("tile index"), std::string::npos) << at;
    }
    // Truncated.
    write(std::vector<char>(good.begin(), good.end() - 32));
    EXPECT_NE(message().find("tiles need"), std::string::npos);
    // A tile file swapped for another tile's: its region and checksum are not the entry's.
    write(good);
    const vox::rvol::TileIndex parsed = vox::rvol::readTileIndex(index);
    ASSERT_GE(parsed.tiles.size(), 2u);
    const auto& t0 = parsed.tiles[0];
    const auto& t1 = parsed.tiles[1];
    fs::copy_file(vox::rvol::tilePath(index, t1.x, t1.y, t1.z),
                  vox::rvol::tilePath(index, t0.x, t0.y, t0.z),
                  fs::copy_options::overwrite_existing);
    EXPECT_NE(message().find("does not match its tile index"), std::string::npos);
    // A missing tile is a file that cannot be read.
    fs::remove(vox::rvol::tilePath(index, t0.x, t0.y, t0.z));
    EXPECT_THROW(vox::rvol::validateTiledRvol(index), vox::IoError);
}

}  // namespace
