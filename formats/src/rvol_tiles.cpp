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
#include <condition_variable>
#include <fstream>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>

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

// ---- open tiles: a bound, least recently used closed first -----------------------------------
//
// A sample enters an open tile without the mutex: it counts itself among the tile's users, then
// reads the tile's reader pointer. Closing a tile clears that pointer first and then waits until
// the tile has no users. Both sides use sequentially consistent operations, so either the sample
// sees the cleared pointer (and takes the slow path, under the mutex) or the closer sees the
// sample counted and waits for it: no sample reads a closed file. Opening and closing happen
// under the mutex, one file at a time.

/// One tile of the index: its reader while open, who uses it, when it was last used.
struct TiledRvolReader::Tile {
    std::atomic<const RvolReader*> reader{nullptr};  // the open file; null while closed or closing
    std::atomic<std::uint32_t> users{0};             // samples reading it now, and handles
    std::atomic<std::uint64_t> lastUse{0};           // OpenFiles::clock when last used
    std::uint32_t handles = 0;                       // guarded by OpenFiles::mutex
    std::unique_ptr<RvolReader> owned;               // guarded by OpenFiles::mutex
};

struct TiledRvolReader::OpenFiles {
    explicit OpenFiles(std::size_t tileCount) : tiles(std::make_unique<Tile[]>(tileCount)) {}

    std::mutex mutex;
    std::unique_ptr<Tile[]> tiles;
    std::vector<std::size_t> open;  // guarded by mutex
    OpenTileStats stats;            // guarded by mutex; openTileStats() fills in open
    // Advanced by every opening: a use stamps its tile with it, so the tile with the lowest stamp
    // is the least recently used, at the resolution of openings (which is all eviction needs),
    // and a use that changes nothing writes nothing.
    std::atomic<std::uint64_t> clock{0};
    // Slow paths waiting for an open tile to lose its last user: a sample leaving a tile notifies
    // only while this is not 0, so that the common path never takes the mutex.
    std::atomic<std::uint32_t> waiting{0};
    std::condition_variable released;
    std::atomic<const RvolReader*> far{nullptr};
    std::unique_ptr<RvolReader> ownedFar;  // guarded by mutex

    void stamp(Tile& tile) const noexcept {
        const std::uint64_t now = clock.load(std::memory_order_relaxed);
        if (tile.lastUse.load(std::memory_order_relaxed) != now)
            tile.lastUse.store(now, std::memory_order_relaxed);
    }
    /// The tile's reader, counted as used, if it is open; null (and not counted) if not.
    const RvolReader* enter(Tile& tile) {
        tile.users.fetch_add(1);
        if (const RvolReader* reader = tile.reader.load()) {
            stamp(tile);
            return reader;
        }
        leave(tile);
        return nullptr;
    }
    void leave(Tile& tile) {
        if (tile.users.fetch_sub(1) == 1 && waiting.load() > 0) {
            const std::lock_guard lock(mutex);
            released.notify_all();
        }
    }
};

/// A sample's use of one tile: the file stays open while it lives.
class TiledRvolReader::TileUse {
public:
    TileUse(const TiledRvolReader& owner, std::size_t i)
        : files_(*owner.open_), tile_(files_.tiles[i]) {
        const RvolReader* reader = files_.enter(tile_);
        reader_ = reader ? reader : &owner.useTile(i, false);
    }
    ~TileUse() { files_.leave(tile_); }
    TileUse(const TileUse&) = delete;
    TileUse& operator=(const TileUse&) = delete;
    const RvolReader* operator->() const noexcept { return reader_; }

private:
    OpenFiles& files_;
    Tile& tile_;
    const RvolReader* reader_;
};

TiledRvolReader::TiledRvolReader(std::filesystem::path index, const TiledRvolReaderOptions& options)
    : path_(std::move(index)), options_(options) {
    if (options_.maxOpenTiles == 0) throw ParameterError("maxOpenTiles", "must be at least 1");
    index_ = readTileIndex(path_);
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

std::filesystem::path TiledRvolReader::tileFile(std::size_t i) const {
    const TileEntry& t = index_.tiles.at(i);
    return tilePath(path_, t.x, t.y, t.z);
}

void TiledRvolReader::openTile(std::size_t i) const {
    OpenFiles& files = *open_;
    Tile& tile = files.tiles[i];
    const TileEntry& t = index_.tiles[i];
    auto reader = std::make_unique<RvolReader>(tileFile(i));
    checkAgainstIndex(*reader, index_, index_.tileDepth, index_.tileOrigin(t.x, t.y, t.z),
                      index_.tileSize(), t.headerChecksum, t.fileBytes);
    reader->setCacheBytes(std::max<std::uint64_t>(1, options_.cacheBytes / options_.maxOpenTiles));
    tile.lastUse.store(files.clock.fetch_add(1) + 1, std::memory_order_relaxed);
    tile.owned = std::move(reader);
    tile.reader.store(tile.owned.get());
    files.open.push_back(i);
    ++files.stats.opened;
    files.stats.mostOpen =
        std::max(files.stats.mostOpen, static_cast<std::uint32_t>(files.open.size()));
}

void TiledRvolReader::closeTile(std::size_t i) const {
    OpenFiles& files = *open_;
    Tile& tile = files.tiles[i];
    tile.reader.store(nullptr);
    // A sample that counted itself before the pointer was cleared is still reading: let it end.
    while (tile.users.load() != 0) std::this_thread::yield();
    tile.owned.reset();
    files.open.erase(std::find(files.open.begin(), files.open.end(), i));
    ++files.stats.closed;
}

const RvolReader& TiledRvolReader::useTile(std::size_t i, bool handle) const {
    OpenFiles& files = *open_;
    Tile& tile = files.tiles[i];
    std::unique_lock lock(files.mutex);
    bool counted = false;  // among OpenFiles::waiting
    const auto stopWaiting = [&] {
        if (counted) files.waiting.fetch_sub(1);
        counted = false;
    };
    while (!tile.owned) {
        if (files.open.size() < options_.maxOpenTiles) {
            stopWaiting();
            openTile(i);
            break;
        }
        // Counted before looking, so that a user leaving after the look notifies.
        if (!counted) {
            files.waiting.fetch_add(1);
            counted = true;
        }
        std::size_t victim = index_.tiles.size();
        bool sampled = false;  // an open tile some sample is reading (it will be released soon)
        for (const std::size_t o : files.open) {
            const Tile& candidate = files.tiles[o];
            const std::uint32_t users = candidate.users.load();
            sampled = sampled || users > candidate.handles;
            if (users == 0 && (victim == index_.tiles.size() ||
                               candidate.lastUse.load(std::memory_order_relaxed) <
                                   files.tiles[victim].lastUse.load(std::memory_order_relaxed)))
                victim = o;
        }
        if (victim < index_.tiles.size() || !sampled) {
            // A victim to close; or every open tile held by handles, which may never be let go
            // while this caller waits: open past the bound.
            stopWaiting();
            if (victim < index_.tiles.size()) closeTile(victim);
            openTile(i);
            break;
        }
        files.released.wait(lock);
    }
    stopWaiting();
    tile.users.fetch_add(1);
    if (handle) ++tile.handles;
    files.stamp(tile);
    return *tile.owned;
}

void TiledRvolReader::dropHandle(std::size_t i) const {
    OpenFiles& files = *open_;
    Tile& tile = files.tiles[i];
    const std::lock_guard lock(files.mutex);
    --tile.handles;
    tile.users.fetch_sub(1);
    // Opened past the bound while handles held every tile: back within it as they go.
    if (files.open.size() > options_.maxOpenTiles && tile.users.load() == 0) closeTile(i);
    if (files.waiting.load() > 0) files.released.notify_all();
}

std::shared_ptr<const RvolReader> TiledRvolReader::tile(std::size_t i) const {
    if (i >= index_.tiles.size())
        throw std::out_of_range("TiledRvolReader::tile: no tile " + std::to_string(i));
    const RvolReader& reader = useTile(i, true);
    return {&reader, [this, i](const RvolReader*) { dropHandle(i); }};
}

OpenTileStats TiledRvolReader::openTileStats() const {
    const std::lock_guard lock(open_->mutex);
    OpenTileStats stats = open_->stats;
    stats.open = static_cast<std::uint32_t>(open_->open.size());
    return stats;
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
    Texel out;
    cellChannels(level, &channel, 1, {x, y, z}, &out);
    return out;
}

void TiledRvolReader::cellChannels(std::uint32_t level, const std::uint32_t* channels,
                                   std::size_t count, const std::array<std::uint32_t, 3>& cell,
                                   Texel* out) const {
    const std::uint32_t shift = index_.tileDepth - level;
    const std::int64_t t = findTile(cell[0] >> shift, cell[1] >> shift, cell[2] >> shift);
    if (t < 0) {
        std::fill_n(out, count, Texel{});
        return;
    }
    const std::uint32_t mask = (1u << shift) - 1;
    const double cs = index_.cellSize() * double(1ull << level);
    const TileUse reader(*this, static_cast<std::size_t>(t));
    const std::array<double, 3>& o = reader->header().origin;
    // At the cell's centre the tile's trilinear filter has weight 1 on that cell.
    const std::array<double, 3> centre{o[0] + ((cell[0] & mask) + 0.5) * cs,
                                       o[1] + ((cell[1] & mask) + 0.5) * cs,
                                       o[2] + ((cell[2] & mask) + 0.5) * cs};
    for (std::size_t k = 0; k < count; ++k) out[k] = reader->sample(level, channels[k], centre);
}

void TiledRvolReader::sampleChannels(std::uint32_t level, const std::uint32_t* channels,
                                     std::size_t count, const std::array<double, 3>& position,
                                     Texel* out) const {
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
    // Where one tile owns all eight cells, its own filter reads them: one brick lookup, not eight,
    // and one use of the tile for every channel.
    const std::uint32_t shift = index_.tileDepth - level;
    if (c0[0] >> shift == c1[0] >> shift && c0[1] >> shift == c1[1] >> shift &&
        c0[2] >> shift == c1[2] >> shift) {
        const std::int64_t t = findTile(c0[0] >> shift, c0[1] >> shift, c0[2] >> shift);
        if (t < 0) {
            std::fill_n(out, count, Texel{});
            return;
        }
        const TileUse reader(*this, static_cast<std::size_t>(t));
        for (std::size_t k = 0; k < count; ++k)
            out[k] = reader->sample(level, channels[k], position);
        return;
    }
    std::array<std::array<double, 4>, kDirections> sums{};
    std::array<Texel, kDirections> cells{};
    for (int corner = 0; corner < 8; ++corner) {
        const double w = (corner & 1 ? f[0] : 1 - f[0]) * (corner & 2 ? f[1] : 1 - f[1]) *
                         (corner & 4 ? f[2] : 1 - f[2]);
        if (w <= 0) continue;
        cellChannels(
            level, channels, count,
            {corner & 1 ? c1[0] : c0[0], corner & 2 ? c1[1] : c0[1], corner & 4 ? c1[2] : c0[2]},
            cells.data());
        for (std::size_t k = 0; k < count; ++k) {
            sums[k][0] += w * cells[k].r;
            sums[k][1] += w * cells[k].g;
            sums[k][2] += w * cells[k].b;
            sums[k][3] += w * cells[k].a;
        }
    }
    for (std::size_t k = 0; k < count; ++k)
        out[k] = {static_cast<float>(sums[k][0]), static_cast<float>(sums[k][1]),
                  static_cast<float>(sums[k][2]), static_cast<float>(sums[k][3])};
}

Texel TiledRvolReader::sample(std::uint32_t level, std::uint32_t channel,
                              const std::array<double, 3>& position) const {
    if (level > index_.depth) throw std::out_of_range("TiledRvolReader: level");
    if (channel >= levelChannels(level)) throw std::out_of_range("TiledRvolReader: channel");
    if (level > index_.tileDepth)
        return farField().sample(level - (index_.depth - index_.farDepth), channel, position);
    Texel out;
    sampleChannels(level, &channel, 1, position, &out);
    return out;
}

Texel TiledRvolReader::sampleDirectional(std::uint32_t level, const std::array<double, 3>& position,
                                         const std::array<double, 3>& direction) const {
    if (level == 0) return sample(0, 0, position);
    if (level > index_.depth) throw std::out_of_range("TiledRvolReader: level");
    if (level > index_.tileDepth)
        return farField().sampleDirectional(level - (index_.depth - index_.farDepth), position,
                                            direction);
    // The channels facing the direction, sampled together.
    std::array<std::uint32_t, 3> channels{};
    std::array<int, 3> axes{};
    std::size_t count = 0;
    for (int a = 0; a < 3; ++a)
        if (direction[a] != 0 && std::isfinite(direction[a])) {
            channels[count] = static_cast<std::uint32_t>(2 * a + (direction[a] < 0));
            axes[count++] = a;
        }
    std::array<Texel, 3> sampled{}, facing{};
    sampleChannels(level, channels.data(), count, position, sampled.data());
    for (std::size_t k = 0; k < count; ++k) facing[static_cast<std::size_t>(axes[k])] = sampled[k];
    return combineDirectional(facing, direction);
}

std::unique_ptr<RvolSampler> openRvolSampler(const std::filesystem::path& file,
                                             const TiledRvolReaderOptions& tiled) {
    if (isTileIndex(file)) return std::make_unique<TiledRvolReader>(file, tiled);
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
        const std::shared_ptr<const RvolReader> tile = reader.tile(i);
        const RvolReport r = validateRvol(*tile);
        const TileEntry& t = index.tiles[i];
        if (r.staticVoxels != t.staticVoxels || r.bricks != t.bricks)
            throw InvalidDataError(tile->path(),
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
