// Tiled radiance volumes: the tile index (write, read, check), sampling across tiles, and the
// validation of an index with its tiles and far field (docs/rvol-format.md, "Tiled volumes").
#include "rvol_internal.h"

#include <vox/base/error.h>
#include <vox/formats/atomic_file.h>
#include <vox/formats/checksum.h>
#include <vox/formats/rvol_tiles.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <fstream>
#include <mutex>
#include <stdexcept>
#include <string>

namespace vox::rvol {

using detail::load;
using detail::store;

namespace {

/// Header field offsets (docs/rvol-format.md, "Tile index").
namespace tix {
inline constexpr std::size_t kMagic = 0, kVersionMajor = 4, kVersionMinor = 6, kHeaderBytes = 8,
                             kDepth = 12, kTileDepth = 16, kHalo = 20, kFarDepth = 24,
                             kBrickTexels = 28, kOrigin = 32, kSize = 56, kSceneBounds = 64,
                             kBounces = 88, kShadowAperture = 92, kAoLambda = 96,
                             kAttenuation = 100, kLights = 104, kFlags = 108, kTileCount = 112,
                             kFarFileBytes = 120, kFarHeaderChecksum = 128, kTableChecksum = 132,
                             kChecksum = 188;
}  // namespace tix

/// Entry layout: x, y, z (u16), reserved u16 (0), the tile's header checksum (u32), its
/// brickCount (u32), fileBytes (u64), staticVoxelCount (u64).
void encodeEntry(std::uint8_t* p, const TileEntry& t) {
    store(p + 0, t.x);
    store(p + 2, t.y);
    store(p + 4, t.z);
    store(p + 6, std::uint16_t{0});
    store(p + 8, t.headerChecksum);
    store(p + 12, static_cast<std::uint32_t>(t.bricks));
    store(p + 16, t.fileBytes);
    store(p + 24, t.staticVoxels);
}

TileEntry decodeEntry(const std::uint8_t* p) {
    TileEntry t;
    t.x = load<std::uint16_t>(p + 0);
    t.y = load<std::uint16_t>(p + 2);
    t.z = load<std::uint16_t>(p + 4);
    t.headerChecksum = load<std::uint32_t>(p + 8);
    t.bricks = load<std::uint32_t>(p + 12);
    t.fileBytes = load<std::uint64_t>(p + 16);
    t.staticVoxels = load<std::uint64_t>(p + 24);
    return t;
}

std::uint32_t storedHeaderChecksum(const RvolReader& reader) {
    std::array<std::uint8_t, 4> bytes{};
    reader.readBytes(detail::hdr::kChecksum, bytes.data(), bytes.size());
    return load<std::uint32_t>(bytes.data());
}

}  // namespace

std::array<double, 3> TileIndex::tileOrigin(std::uint32_t x, std::uint32_t y,
                                            std::uint32_t z) const noexcept {
    const double step = double(1ull << tileDepth);
    const double cell = cellSize();
    return {origin[0] + double(x) * step * cell, origin[1] + double(y) * step * cell,
            origin[2] + double(z) * step * cell};
}

std::filesystem::path tileDirectory(const std::filesystem::path& index) {
    return std::filesystem::path(index.string() + ".tiles");
}

std::filesystem::path tilePath(const std::filesystem::path& index, std::uint32_t x, std::uint32_t y,
                               std::uint32_t z) {
    return tileDirectory(index) / ("tile-" + std::to_string(x) + "-" + std::to_string(y) + "-" +
                                   std::to_string(z) + ".rvol");
}

std::filesystem::path farFieldPath(const std::filesystem::path& index) {
    return tileDirectory(index) / "far.rvol";
}

bool isTileIndex(const std::filesystem::path& file) {
    std::ifstream in(file, std::ios::binary);
    std::array<char, 4> magic{};
    if (!in.read(magic.data(), magic.size())) return false;
    return std::equal(magic.begin(), magic.end(), kTileIndexMagic.begin(),
                      [](char a, std::uint8_t b) { return static_cast<std::uint8_t>(a) == b; });
}

void writeTileIndex(const std::filesystem::path& file, const TileIndex& index) {
    if (index.depth < 1 || index.depth > kMaxTiledDepth || index.tileDepth < 1 ||
        index.tileDepth > kMaxDepth || index.tileDepth > index.depth || index.farDepth < 1 ||
        index.farDepth > kMaxDepth || index.farDepth > index.depth)
        throw std::invalid_argument("writeTileIndex: depths out of range");
    const std::uint32_t tilesPerAxis = 1u << (index.depth - index.tileDepth);
    for (std::size_t i = 0; i < index.tiles.size(); ++i) {
        const TileEntry& t = index.tiles[i];
        if (t.x >= tilesPerAxis || t.y >= tilesPerAxis || t.z >= tilesPerAxis)
            throw std::invalid_argument("writeTileIndex: tile outside the volume");
        if (i > 0 && !(index.tiles[i - 1].morton() < t.morton()))
            throw std::invalid_argument("writeTileIndex: tiles not in ascending Morton order");
    }
    std::vector<std::uint8_t> table(index.tiles.size() * kTileEntryBytes, 0);
    for (std::size_t i = 0; i < index.tiles.size(); ++i)
        encodeEntry(table.data() + i * kTileEntryBytes, index.tiles[i]);
    std::array<std::uint8_t, kTileIndexHeaderBytes> h{};
    std::copy(kTileIndexMagic.begin(), kTileIndexMagic.end(), h.begin() + tix::kMagic);
    store(h.data() + tix::kVersionMajor, kTileIndexVersionMajor);
    store(h.data() + tix::kVersionMinor, kTileIndexVersionMinor);
    store(h.data() + tix::kHeaderBytes, kTileIndexHeaderBytes);
    store(h.data() + tix::kDepth, index.depth);
    store(h.data() + tix::kTileDepth, index.tileDepth);
    store(h.data() + tix::kHalo, index.halo);
    store(h.data() + tix::kFarDepth, index.farDepth);
    store(h.data() + tix::kBrickTexels, index.brickTexels);
    for (int a = 0; a < 3; ++a) store(h.data() + tix::kOrigin + 8 * a, index.origin[a]);
    store(h.data() + tix::kSize, index.size);
    for (int a = 0; a < 6; ++a) store(h.data() + tix::kSceneBounds + 4 * a, index.sceneBounds[a]);
    store(h.data() + tix::kBounces, index.bake.bounces);
    store(h.data() + tix::kShadowAperture, index.bake.shadowApertureDegrees);
    store(h.data() + tix::kAoLambda, index.bake.aoLambda);
    store(h.data() + tix::kAttenuation, index.bake.attenuation);
    store(h.data() + tix::kLights, index.bake.lights);
    store(h.data() + tix::kFlags, std::uint32_t{0});
    store(h.data() + tix::kTileCount, std::uint64_t{index.tiles.size()});
    store(h.data() + tix::kFarFileBytes, index.farFileBytes);
    store(h.data() + tix::kFarHeaderChecksum, index.farHeaderChecksum);
    store(h.data() + tix::kTableChecksum, crc32c(table.data(), table.size()));
    store(h.data() + tix::kChecksum, crc32c(h.data(), tix::kChecksum));
    AtomicFile out(file);
    out.write(h.data(), h.size());
    if (!table.empty()) out.write(table.data(), table.size());
    out.commit();
}

TileIndex readTileIndex(const std::filesystem::path& file) {
    std::ifstream in(file, std::ios::binary);
    if (!in) throw IoError(file, "cannot open");
    std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)),
                                    std::istreambuf_iterator<char>());
    if (in.bad()) throw IoError(file, "read error");
    const auto bad = [&](const std::string& what) { return InvalidDataError(file, what); };
    if (bytes.size() < kTileIndexHeaderBytes)
        throw bad("tile index: file is shorter than its " + std::to_string(kTileIndexHeaderBytes) +
                  "-byte header");
    const std::uint8_t* h = bytes.data();
    if (!std::equal(kTileIndexMagic.begin(), kTileIndexMagic.end(), h + tix::kMagic))
        throw bad("tile index: not a tile index (bad magic)");
    TileIndex index;
    index.versionMajor = load<std::uint16_t>(h + tix::kVersionMajor);
    index.versionMinor = load<std::uint16_t>(h + tix::kVersionMinor);
    if (index.versionMajor != kTileIndexVersionMajor)
        throw bad("tile index: unsupported version " + std::to_string(index.versionMajor) + "." +
                  std::to_string(index.versionMinor) + " (this reader reads " +
                  std::to_string(kTileIndexVersionMajor) + ".x)");
    if (load<std::uint32_t>(h + tix::kHeaderBytes) != kTileIndexHeaderBytes)
        throw bad("tile index: header size is not " + std::to_string(kTileIndexHeaderBytes));
    if (crc32c(h, tix::kChecksum) != load<std::uint32_t>(h + tix::kChecksum))
        throw bad("tile index: header checksum mismatch");
    index.depth = load<std::uint32_t>(h + tix::kDepth);
    index.tileDepth = load<std::uint32_t>(h + tix::kTileDepth);
    index.halo = load<std::uint32_t>(h + tix::kHalo);
    index.farDepth = load<std::uint32_t>(h + tix::kFarDepth);
    index.brickTexels = load<std::uint32_t>(h + tix::kBrickTexels);
    if (index.depth < 1 || index.depth > kMaxTiledDepth)
        throw bad("tile index: depth " + std::to_string(index.depth) + " is not 1 … " +
                  std::to_string(kMaxTiledDepth));
    if (index.tileDepth < 1 || index.tileDepth > std::min(index.depth, kMaxDepth))
        throw bad("tile index: tile depth " + std::to_string(index.tileDepth) +
                  " is not 1 … min(depth, 10)");
    if (index.farDepth < 1 || index.farDepth > std::min(index.depth, kMaxDepth) ||
        index.depth - index.farDepth >= index.tileDepth)
        throw bad("tile index: far-field depth " + std::to_string(index.farDepth) +
                  " is not above depth − tile depth and at most min(depth, 10)");
    if (index.brickTexels < kMinBrickTexels || index.brickTexels > kMaxBrickTexels)
        throw bad("tile index: brick texels " + std::to_string(index.brickTexels) +
                  " out of range");
    for (int a = 0; a < 3; ++a) index.origin[a] = load<double>(h + tix::kOrigin + 8 * a);
    index.size = load<double>(h + tix::kSize);
    if (!std::isfinite(index.origin[0]) || !std::isfinite(index.origin[1]) ||
        !std::isfinite(index.origin[2]) || !std::isfinite(index.size) || !(index.size > 0))
        throw bad("tile index: origin or size is not finite, or size ≤ 0");
    for (int a = 0; a < 6; ++a) index.sceneBounds[a] = load<float>(h + tix::kSceneBounds + 4 * a);
    index.bake.bounces = load<std::uint32_t>(h + tix::kBounces);
    index.bake.shadowApertureDegrees = load<float>(h + tix::kShadowAperture);
    index.bake.aoLambda = load<float>(h + tix::kAoLambda);
    index.bake.attenuation = load<std::uint32_t>(h + tix::kAttenuation);
    index.bake.lights = load<std::uint32_t>(h + tix::kLights);
    const auto tileCount = load<std::uint64_t>(h + tix::kTileCount);
    index.farFileBytes = load<std::uint64_t>(h + tix::kFarFileBytes);
    index.farHeaderChecksum = load<std::uint32_t>(h + tix::kFarHeaderChecksum);
    const std::uint64_t expected =
        kTileIndexHeaderBytes + std::min<std::uint64_t>(tileCount, bytes.size()) * kTileEntryBytes;
    if (tileCount > bytes.size() || bytes.size() != expected)
        throw bad("tile index: " + std::to_string(tileCount) + " tiles need " +
                  std::to_string(kTileIndexHeaderBytes + tileCount * kTileEntryBytes) +
                  " bytes but the file has " + std::to_string(bytes.size()));
    const std::uint8_t* table = h + kTileIndexHeaderBytes;
    if (crc32c(table, tileCount * kTileEntryBytes) != load<std::uint32_t>(h + tix::kTableChecksum))
        throw bad("tile index: tile table checksum mismatch");
    const std::uint32_t tilesPerAxis = 1u << (index.depth - index.tileDepth);
    index.tiles.reserve(tileCount);
    for (std::uint64_t i = 0; i < tileCount; ++i) {
        const std::uint8_t* p = table + i * kTileEntryBytes;
        const TileEntry t = decodeEntry(p);
        const std::string where = "tile index, entry " + std::to_string(i) + ": ";
        if (t.x >= tilesPerAxis || t.y >= tilesPerAxis || t.z >= tilesPerAxis)
            throw bad(where + "tile (" + std::to_string(t.x) + "," + std::to_string(t.y) + "," +
                      std::to_string(t.z) + ") outside the " + std::to_string(tilesPerAxis) +
                      " tiles per axis");
        if (load<std::uint16_t>(p + 6) != 0) throw bad(where + "reserved bytes not zero");
        if (!index.tiles.empty() && !(index.tiles.back().morton() < t.morton()))
            throw bad(where + "not in strictly ascending Morton order");
        index.tiles.push_back(t);
    }
    return index;
}

// ---- reading across tiles -------------------------------------------------------------------

namespace {

/// Checks an opened tile or far-field file against what the index says it must be.
void checkAgainstIndex(const RvolReader& reader, const TileIndex& index, std::uint32_t depth,
                       const std::array<double, 3>& origin, double size,
                       std::uint32_t headerChecksum, std::uint64_t fileBytes) {
    const Header& h = reader.header();
    const auto bad = [&](const std::string& what) {
        return InvalidDataError(reader.path(), "does not match its tile index: " + what);
    };
    if (h.fileBytes != fileBytes)
        throw bad("the index says " + std::to_string(fileBytes) + " bytes, the file has " +
                  std::to_string(h.fileBytes));
    if (storedHeaderChecksum(reader) != headerChecksum)
        throw bad("header checksum differs from the index's (a file of another bake)");
    if (h.depth != depth)
        throw bad("depth " + std::to_string(h.depth) + ", expected " + std::to_string(depth));
    if (h.brickTexels != index.brickTexels) throw bad("brick texels differ from the index's");
    if (h.origin != origin || h.size != size) throw bad("origin or size is not its region's");
}

}  // namespace

/// The files opened so far. A slot is published (release) once its reader is open and checked,
/// so that samplers reach an open file without locking; opening takes the mutex, one file at a
/// time, which costs little next to the sampling that follows.
struct TiledRvolReader::OpenFiles {
    explicit OpenFiles(std::size_t tileCount) : tiles(tileCount), ownedTiles(tileCount) {}

    std::mutex mutex;
    std::vector<std::atomic<const RvolReader*>> tiles;
    std::atomic<const RvolReader*> far{nullptr};
    std::vector<std::unique_ptr<RvolReader>> ownedTiles;  // guarded by mutex
    std::unique_ptr<RvolReader> ownedFar;                 // guarded by mutex
};

TiledRvolReader::TiledRvolReader(std::filesystem::path index)
    : path_(std::move(index)), index_(readTileIndex(path_)) {
    for (std::size_t i = 0; i < index_.tiles.size(); ++i)
        byMorton_.emplace(index_.tiles[i].morton(), i);
    open_ = std::make_unique<OpenFiles>(index_.tiles.size());
}

TiledRvolReader::~TiledRvolReader() = default;

std::int64_t TiledRvolReader::findTile(std::uint32_t x, std::uint32_t y,
                                       std::uint32_t z) const noexcept {
    const auto it = byMorton_.find(morton3(x, y, z));
    return it == byMorton_.end() ? -1 : static_cast<std::int64_t>(it->second);
}

const RvolReader& TiledRvolReader::tile(std::size_t i) const {
    std::atomic<const RvolReader*>& slot = open_->tiles.at(i);
    if (const RvolReader* open = slot.load(std::memory_order_acquire)) return *open;
    const std::lock_guard lock(open_->mutex);
    if (const RvolReader* open = slot.load(std::memory_order_relaxed)) return *open;
    const TileEntry& t = index_.tiles[i];
    auto reader = std::make_unique<RvolReader>(tilePath(path_, t.x, t.y, t.z));
    checkAgainstIndex(*reader, index_, index_.tileDepth, index_.tileOrigin(t.x, t.y, t.z),
                      index_.tileSize(), t.headerChecksum, t.fileBytes);
    reader->setCacheBytes(8u << 20);
    open_->ownedTiles[i] = std::move(reader);
    slot.store(open_->ownedTiles[i].get(), std::memory_order_release);
    return *open_->ownedTiles[i];
}

const RvolReader& TiledRvolReader::farField() const {
    if (const RvolReader* open = open_->far.load(std::memory_order_acquire)) return *open;
    const std::lock_guard lock(open_->mutex);
    if (const RvolReader* open = open_->far.load(std::memory_order_relaxed)) return *open;
    auto reader = std::make_unique<RvolReader>(farFieldPath(path_));
    checkAgainstIndex(*reader, index_, index_.farDepth, index_.origin, index_.size,
                      index_.farHeaderChecksum, index_.farFileBytes);
    open_->ownedFar = std::move(reader);
    open_->far.store(open_->ownedFar.get(), std::memory_order_release);
    return *open_->ownedFar;
}

Texel TiledRvolReader::cell(std::uint32_t level, std::uint32_t channel, std::uint32_t x,
                            std::uint32_t y, std::uint32_t z) const {
    if (level > index_.depth) throw std::out_of_range("TiledRvolReader: level");
    const double cs = index_.cellSize() * double(1ull << level);
    if (level > index_.tileDepth) {
        // Above the tiles: the far field's cell at the same world position and size.
        const std::uint32_t farLevel = level - (index_.depth - index_.farDepth);
        return farField().sample(
            farLevel, channel,
            {index_.origin[0] + (x + 0.5) * cs, index_.origin[1] + (y + 0.5) * cs,
             index_.origin[2] + (z + 0.5) * cs});
    }
    const std::uint32_t shift = index_.tileDepth - level;
    const std::int64_t t = findTile(x >> shift, y >> shift, z >> shift);
    if (t < 0) return {};
    const std::uint32_t mask = (1u << shift) - 1;
    const RvolReader& reader = tile(static_cast<std::size_t>(t));
    const std::array<double, 3>& o = reader.header().origin;
    // At the cell's centre the tile's trilinear filter has weight 1 on that cell.
    return reader.sample(level, channel,
                         {o[0] + ((x & mask) + 0.5) * cs, o[1] + ((y & mask) + 0.5) * cs,
                          o[2] + ((z & mask) + 0.5) * cs});
}

Texel TiledRvolReader::sample(std::uint32_t level, std::uint32_t channel,
                              const std::array<double, 3>& position) const {
    if (level > index_.depth) throw std::out_of_range("TiledRvolReader: level");
    if (channel >= levelChannels(level)) throw std::out_of_range("TiledRvolReader: channel");
    if (level > index_.tileDepth)
        return farField().sample(level - (index_.depth - index_.farDepth), channel, position);
    const std::uint32_t resolution = 1u << (index_.depth - level);
    const double cs = index_.cellSize() * double(1ull << level);
    std::uint32_t c0[3], c1[3];
    double f[3];
    for (int a = 0; a < 3; ++a) {
        const double u =
            std::clamp((position[a] - index_.origin[a]) / cs - 0.5, 0.0, resolution - 1.0);
        const double fl = std::floor(u);
        c0[a] = static_cast<std::uint32_t>(fl);
        c1[a] = std::min(c0[a] + 1, resolution - 1);
        f[a] = u - fl;
    }
    // Where one tile owns all eight cells, its own filter reads them: one brick lookup, not eight.
    const std::uint32_t shift = index_.tileDepth - level;
    if (c0[0] >> shift == c1[0] >> shift && c0[1] >> shift == c1[1] >> shift &&
        c0[2] >> shift == c1[2] >> shift) {
        const std::int64_t t = findTile(c0[0] >> shift, c0[1] >> shift, c0[2] >> shift);
        return t < 0 ? Texel{} : tile(static_cast<std::size_t>(t)).sample(level, channel, position);
    }
    double sum[4] = {0, 0, 0, 0};
    for (int corner = 0; corner < 8; ++corner) {
        const double w = (corner & 1 ? f[0] : 1 - f[0]) * (corner & 2 ? f[1] : 1 - f[1]) *
                         (corner & 4 ? f[2] : 1 - f[2]);
        if (w <= 0) continue;
        const Texel t = cell(level, channel, corner & 1 ? c1[0] : c0[0], corner & 2 ? c1[1] : c0[1],
                             corner & 4 ? c1[2] : c0[2]);
        sum[0] += w * t.r;
        sum[1] += w * t.g;
        sum[2] += w * t.b;
        sum[3] += w * t.a;
    }
    return {static_cast<float>(sum[0]), static_cast<float>(sum[1]), static_cast<float>(sum[2]),
            static_cast<float>(sum[3])};
}

Texel TiledRvolReader::sampleDirectional(std::uint32_t level, const std::array<double, 3>& position,
                                         const std::array<double, 3>& direction) const {
    if (level == 0) return sample(0, 0, position);
    if (level > index_.tileDepth)
        return farField().sampleDirectional(level - (index_.depth - index_.farDepth), position,
                                            direction);
    std::array<Texel, 3> facing{};
    for (int a = 0; a < 3; ++a)
        if (direction[a] != 0 && std::isfinite(direction[a]))
            facing[a] =
                sample(level, static_cast<std::uint32_t>(2 * a + (direction[a] < 0)), position);
    return combineDirectional(facing, direction);
}

std::unique_ptr<RvolSampler> openRvolSampler(const std::filesystem::path& file) {
    if (isTileIndex(file)) return std::make_unique<TiledRvolReader>(file);
    return std::make_unique<RvolReader>(file);
}

// ---- validation -----------------------------------------------------------------------------

TiledRvolReport validateTiledRvol(const std::filesystem::path& file) {
    TiledRvolReader reader(file);
    const TileIndex& index = reader.index();
    TiledRvolReport report;
    report.indexBytes = kTileIndexHeaderBytes + index.tiles.size() * kTileEntryBytes;
    report.tiles = index.tiles.size();
    for (std::size_t i = 0; i < index.tiles.size(); ++i) {
        const RvolReader& tile = reader.tile(i);
        const RvolReport r = validateRvol(tile);
        const TileEntry& t = index.tiles[i];
        if (r.staticVoxels != t.staticVoxels || r.bricks != t.bricks)
            throw InvalidDataError(tile.path(),
                                   "does not match its tile index: voxel or brick count differs");
        report.tileBytes += r.fileBytes;
        report.largestTileBytes = std::max(report.largestTileBytes, r.fileBytes);
        report.bricks += r.bricks;
        report.staticVoxels += r.staticVoxels;
    }
    const RvolReport far = validateRvol(reader.farField());
    report.farBytes = far.fileBytes;
    report.bricks += far.bricks;
    return report;
}

}  // namespace vox::rvol
