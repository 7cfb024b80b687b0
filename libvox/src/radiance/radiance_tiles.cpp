// Tiled radiance bakes: the far field of the whole root cube, then tile after tile, each in its
// own cube of twice the tile's edge so that the halo's voxels are lit and filtered with it, and
// the index that binds the tile files together (docs/internals/rvol-writer.md, "Tiled bakes").
#include <vox/radiance_tiles.h>

#include "scene_occupancy.h"

#include <vox/base/error.h>
#include <vox/octree.h>
#include <vox/util/log.h>

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <map>
#include <optional>
#include <string>

namespace vox {

namespace {

double secondsSince(std::chrono::steady_clock::time_point start) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

RadianceBakeOptions quiet(RadianceBakeOptions options) {
    options.keepVoxelLighting = false;
    options.lightcutsCompare = false;
    options.region = nullptr;
    return options;
}

rvol::TileEntry entryOf(const rvol::RvolReader& reader, std::array<std::uint32_t, 3> tile) {
    rvol::TileEntry e;
    e.x = static_cast<std::uint16_t>(tile[0]);
    e.y = static_cast<std::uint16_t>(tile[1]);
    e.z = static_cast<std::uint16_t>(tile[2]);
    std::array<std::uint8_t, 4> crc{};
    reader.readBytes(rvol::kHeaderBytes - 4, crc.data(), crc.size());
    e.headerChecksum = std::uint32_t{crc[0]} | std::uint32_t{crc[1]} << 8 |
                       std::uint32_t{crc[2]} << 16 | std::uint32_t{crc[3]} << 24;
    e.fileBytes = reader.header().fileBytes;
    e.staticVoxels = reader.header().staticVoxelCount;
    e.bricks = reader.header().brickCount;
    return e;
}

/// The whole scene's occupancy at depth D for the tiles' shadow rays, its triangles binned in the
/// far field's cells.
SceneOccupancy occupancyOf(const Scene& scene, const RadianceTiling& tiling,
                           const rvol::Volume& far) {
    const RootCube world{{far.origin[0], far.origin[1], far.origin[2]}, far.size};
    return SceneOccupancy(scene, world, tiling.depth, tiling.farDepth);
}

RadianceBake bakeTile(const Scene& scene, const RadianceBakeOptions& options,
                      const RadianceTiling& tiling, std::array<std::uint32_t, 3> tile,
                      const rvol::Volume& far, const SceneOccupancy& occupancy) {
    rvol::TileIndex geometry;  // the index's arithmetic, so that tile origins match it exactly
    geometry.depth = tiling.depth;
    geometry.tileDepth = tiling.tileDepth;
    geometry.origin = far.origin;
    geometry.size = far.size;
    const double cell = geometry.cellSize();
    const std::uint32_t own = 1u << tiling.tileDepth, half = own / 2;
    RadianceBakeRegion region;
    for (int a = 0; a < 3; ++a) {
        const std::int64_t first = std::int64_t{tile[a]} * own - half;
        region.cubeOrigin[a] = far.origin[a] + double(first) * cell;
        region.cubeCell[static_cast<std::size_t>(a)] = first;
        // The kept box ends at the root cube's faces: a surface on a face touches the cells on
        // both sides of it in the tile's cube, but the whole volume has no cell beyond the face
        // (those voxels shadowed the outer faces of a box whose walls end at the root cube).
        const std::int64_t world = std::int64_t{1} << tiling.depth;
        region.keepLo[a] = static_cast<std::uint32_t>(
            std::max<std::int64_t>(std::int64_t{half} - tiling.halo, -first));
        region.keepHi[a] = static_cast<std::uint32_t>(
            std::min<std::int64_t>(std::int64_t{half} + own + tiling.halo, world - first));
        region.ownLo[a] = half;
    }
    region.cubeSize = cell * double(2 * own);
    region.ownDepth = tiling.tileDepth;
    const auto origin = geometry.tileOrigin(tile[0], tile[1], tile[2]);
    region.ownOrigin = {origin[0], origin[1], origin[2]};
    region.ownSize = geometry.tileSize();
    region.far = &far;
    region.occupancy = &occupancy;
    region.rootDepth = tiling.depth;
    RadianceBakeOptions tileOptions = options;
    tileOptions.depth = tiling.tileDepth + 1;
    tileOptions.region = &region;
    return bakeRadiance(scene, tileOptions);
}

}  // namespace

RadianceTiling RadianceTiling::plan(std::uint32_t depth, std::uint32_t tileDepth,
                                    std::uint32_t halo) {
    if (depth < 2 || depth > rvol::kMaxTiledDepth)
        throw ParameterError(
            "radianceDepth",
            "must be between 2 and " + std::to_string(rvol::kMaxTiledDepth) + " for a tiled bake");
    if (tileDepth < 2 || tileDepth > rvol::kMaxDepth - 1 || tileDepth >= depth)
        throw ParameterError("radianceTileDepth",
                             "must be between 2 and 9 and below the radiance depth");
    if (depth - tileDepth + 1 > rvol::kMaxDepth)
        throw ParameterError("radianceTileDepth", "must be at least the radiance depth − 9");
    RadianceTiling t;
    t.depth = depth;
    t.tileDepth = tileDepth;
    t.halo = halo == 0 ? std::max(1u, 1u << (tileDepth - 2)) : halo;
    if (t.halo > (1u << (tileDepth - 1)))
        throw ParameterError("radianceHalo", "must be at most half a tile (2^(tile depth − 1))");
    const auto log2Halo = static_cast<std::uint32_t>(std::bit_width(t.halo) - 1);
    // Far cells a sixteenth of the halo: the bounces beyond the halo read the far field, a coarser
    // bake darker than the depth-D one's mips. Half the halo left 8.3 % seams at depth 8 (T 6), a
    // quarter 4.6 %; at depth 9 (T 7) a quarter 4.2 %, an eighth 3.4 %, a sixteenth 3.0 %
    // (docs/internals/rvol-writer.md). No deeper than T + 1, so that the far field's bake is no
    // larger than a tile's and --memory-limit, which picks T, bounds it too.
    const std::int64_t wanted = std::int64_t{depth} - log2Halo + 4;
    const std::int64_t finest = std::min<std::int64_t>({wanted, std::min(depth, rvol::kMaxDepth),
                                                        std::int64_t{tileDepth} + 1});
    t.farDepth = static_cast<std::uint32_t>(
        std::max<std::int64_t>(finest, std::int64_t{depth} - tileDepth + 1));
    return t;
}

std::uint64_t RadianceTiling::estimateTileBytes(std::uint32_t tileDepth) {
    const std::uint64_t cells = std::uint64_t{1} << (3 * (tileDepth + 1));
    return cells * 2 + cells / 8 + cells / 10;
}

std::uint32_t RadianceTiling::tileDepthFor(std::uint32_t depth, std::uint64_t memoryLimit) {
    std::uint32_t t = std::min<std::uint32_t>(8, depth - 1);
    if (memoryLimit > 0)
        while (t > 2 && estimateTileBytes(t) > memoryLimit / 2) --t;
    return std::max<std::uint32_t>(t, depth > 9 ? depth - 9 : 2);
}

std::vector<std::pair<std::array<std::uint32_t, 3>, std::uint64_t>> radianceTiles(
    const rvol::Volume& far, const RadianceTiling& tiling) {
    // A far cell holds 2^(D − F) finest cells per axis, inside one tile (D − F < T); a triangle
    // touching a finest cell touches the far cell around it, so every tile with voxels is here.
    const std::uint32_t shift = tiling.tileDepth - (tiling.depth - tiling.farDepth);
    std::map<std::uint64_t, std::pair<std::array<std::uint32_t, 3>, std::uint64_t>> tiles;
    for (const rvol::VoxelAttributes& v : far.staticVoxels) {
        const std::array<std::uint32_t, 3> t{v.x >> shift, v.y >> shift, v.z >> shift};
        auto& slot = tiles[rvol::morton3(t[0], t[1], t[2])];
        slot.first = t;
        ++slot.second;
    }
    std::vector<std::pair<std::array<std::uint32_t, 3>, std::uint64_t>> out;
    out.reserve(tiles.size());
    for (auto& [code, tile] : tiles) out.push_back(tile);
    return out;
}

std::vector<std::uint32_t> radianceTileRuns(
    const std::vector<std::pair<std::array<std::uint32_t, 3>, std::uint64_t>>& tiles,
    std::uint32_t runs) {
    std::uint64_t total = 0;
    for (const auto& t : tiles) total += t.second;
    std::vector<std::uint32_t> run(tiles.size(), 0);
    std::uint64_t before = 0;
    for (std::size_t i = 0; i < tiles.size(); ++i) {
        // before < total ≤ 2^40 or so (voxels of a depth ≤ 10 far field): no overflow in double
        // precision, and the same answer on every host.
        run[i] =
            total == 0
                ? 0
                : static_cast<std::uint32_t>(std::floor(double(before) * runs / double(total)));
        before += tiles[i].second;
    }
    return run;
}

RadianceBake bakeRadianceTile(const Scene& scene, const RadianceBakeOptions& options,
                              const RadianceTiling& tiling, std::array<std::uint32_t, 3> tile,
                              const rvol::Volume& far) {
    return bakeTile(scene, options, tiling, tile, far, occupancyOf(scene, tiling, far));
}

TiledBakeResult bakeTiledRadiance(const Scene& scene, const RadianceBakeOptions& options,
                                  const RadianceTiling& tiling, const TiledBakeJob& job,
                                  const std::filesystem::path& indexPath,
                                  const rvol::RvolWriteOptions& write) {
    TiledBakeResult result;
    auto start = std::chrono::steady_clock::now();
    RadianceBakeOptions farOptions = quiet(options);
    farOptions.depth = tiling.farDepth;
    const rvol::Volume far = bakeRadiance(scene, farOptions).volume;
    result.farSeconds = secondsSince(start);
    const auto tiles = radianceTiles(far, tiling);
    std::optional<SceneOccupancy> occupancy;
    if (job.kind != TiledBakeJob::Kind::Index) occupancy.emplace(occupancyOf(scene, tiling, far));
    result.tilesTotal = tiles.size();
    const auto runs = radianceTileRuns(tiles, job.kind == TiledBakeJob::Kind::Run ? job.runs : 1);

    std::error_code ec;
    std::filesystem::create_directories(rvol::tileDirectory(indexPath), ec);
    if (ec) throw IoError(rvol::tileDirectory(indexPath), "cannot create: " + ec.message());

    rvol::TileIndex index;
    index.depth = tiling.depth;
    index.tileDepth = tiling.tileDepth;
    index.halo = tiling.halo;
    index.farDepth = tiling.farDepth;
    index.brickTexels = write.brickTexels;
    index.origin = far.origin;
    index.size = far.size;
    index.sceneBounds = far.sceneBounds;
    index.bake = far.bake;

    start = std::chrono::steady_clock::now();
    for (std::size_t i = 0; i < tiles.size(); ++i) {
        const auto& t = tiles[i].first;
        const std::filesystem::path file = rvol::tilePath(indexPath, t[0], t[1], t[2]);
        if (job.kind == TiledBakeJob::Kind::Index) {
            const rvol::RvolReader reader(file);  // IoError (2) if the run did not write it
            const rvol::Header& h = reader.header();
            const auto o = index.tileOrigin(t[0], t[1], t[2]);
            if (h.depth != tiling.tileDepth || h.origin != o || h.size != index.tileSize() ||
                h.brickTexels != write.brickTexels || h.bake.bounces != far.bake.bounces ||
                h.bake.aoLambda != far.bake.aoLambda ||
                h.bake.shadowApertureDegrees != far.bake.shadowApertureDegrees ||
                h.bake.attenuation != far.bake.attenuation)
                throw InvalidDataError(file,
                                       "is not a tile of this bake (depth, region, brick texels "
                                       "or bake options differ)");
            index.tiles.push_back(entryOf(reader, t));
            continue;
        }
        if (job.kind == TiledBakeJob::Kind::Run && runs[i] != job.run) continue;
        RadianceBake bake = bakeTile(scene, quiet(options), tiling, t, far, *occupancy);
        const rvol::RvolWriteResult written = rvol::writeRvol(file, bake.volume, write);
        ++result.tilesBaked;
        result.staticVoxels += bake.staticVoxels;
        result.dynamicVoxels += bake.dynamicVoxels;
        result.largestTileVoxels = std::max(result.largestTileVoxels, bake.staticVoxels);
        result.tileBytes += written.fileBytes;
        log::info("tile " + std::to_string(t[0]) + "," + std::to_string(t[1]) + "," +
                  std::to_string(t[2]) + " (" + std::to_string(i + 1) + " of " +
                  std::to_string(tiles.size()) + "): " + std::to_string(bake.staticVoxels) +
                  " voxels, " + std::to_string(written.fileBytes) + " bytes");
        result.tilesWritten.push_back(entryOf(rvol::RvolReader(file), t));
        if (job.kind == TiledBakeJob::Kind::Whole)
            index.tiles.push_back(result.tilesWritten.back());
    }
    result.tileSeconds = secondsSince(start);
    if (job.kind == TiledBakeJob::Kind::Run) return result;

    // The far field, then the index last: an index names only files that are complete.
    const std::filesystem::path farFile = rvol::farFieldPath(indexPath);
    result.farBytes = rvol::writeRvol(farFile, far, write).fileBytes;
    const rvol::RvolReader farReader(farFile);
    const rvol::TileEntry farEntry = entryOf(farReader, {0, 0, 0});
    index.farFileBytes = farEntry.fileBytes;
    index.farHeaderChecksum = farEntry.headerChecksum;
    rvol::writeTileIndex(indexPath, index);
    result.indexBytes = rvol::kTileIndexHeaderBytes + index.tiles.size() * rvol::kTileEntryBytes;
    return result;
}

}  // namespace vox
