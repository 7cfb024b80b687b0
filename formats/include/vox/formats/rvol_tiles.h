/// @file rvol_tiles.h
/// @brief Tiled radiance volumes (docs/rvol-format.md, "Tiled volumes"): a tile index file naming
/// the tiles of a volume deeper than one .rvol file holds, each tile an .rvol file over 2^T³
/// finest cells of its own, and a far-field .rvol of the whole root cube at a coarser depth that
/// supplies the levels above the tiles. Writing the index, reading and sampling across tiles, and
/// validating the whole set.
#pragma once

#include <vox/formats/rvol_io.h>

#include <array>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <vector>

namespace vox::rvol {

inline constexpr std::array<std::uint8_t, 4> kTileIndexMagic{'R', 'V', 'T', 'I'};
/// The tile index version this library reads and writes, 1.0 (docs/rvol-format.md, "Tiled
/// volumes"). Readers reject other majors and accept any minor of theirs.
inline constexpr std::uint16_t kTileIndexVersionMajor = 1;
inline constexpr std::uint16_t kTileIndexVersionMinor = 0;
inline constexpr std::uint32_t kTileIndexHeaderBytes = 192;
inline constexpr std::uint32_t kTileEntryBytes = 32;
/// Deepest finest level of a tiled volume: 2^13 cells per axis.
inline constexpr std::uint32_t kMaxTiledDepth = 13;

/// One tile of the index: tile coordinates (finest cell / 2^tileDepth) and what binds the entry to
/// its file.
struct TileEntry {
    std::uint16_t x = 0, y = 0, z = 0;
    std::uint32_t headerChecksum = 0;  ///< the tile file's header checksum (header bytes 252…255)
    std::uint64_t fileBytes = 0;       ///< the tile file's size
    std::uint64_t staticVoxels = 0;    ///< the tile file's staticVoxelCount
    std::uint64_t bricks = 0;          ///< the tile file's brickCount
    [[nodiscard]] std::uint64_t morton() const noexcept { return morton3(x, y, z); }
};

/// The tile index's contents (docs/rvol-format.md, "Tile index").
struct TileIndex {
    std::uint16_t versionMajor = kTileIndexVersionMajor;
    std::uint16_t versionMinor = kTileIndexVersionMinor;
    std::uint32_t depth = 0;      ///< D: the finest level has 2^D cells per axis
    std::uint32_t tileDepth = 0;  ///< T: a tile owns 2^T cells per axis of the finest level
    std::uint32_t halo = 0;       ///< H: cells around its own the bake computed (informational)
    std::uint32_t farDepth = 0;   ///< F: depth of the far-field volume
    std::uint32_t brickTexels = 5;
    std::array<double, 3> origin{0, 0, 0};
    double size = 1;
    std::array<float, 6> sceneBounds{};
    BakeInfo bake;
    std::uint64_t farFileBytes = 0;
    std::uint32_t farHeaderChecksum = 0;
    std::vector<TileEntry> tiles;  ///< strictly ascending Morton order

    /// Finest cell edge: size / 2^depth.
    [[nodiscard]] double cellSize() const noexcept { return size / double(1ull << depth); }
    /// World origin of tile (x, y, z)'s own region: origin + (x, y, z)·2^T·cellSize().
    [[nodiscard]] std::array<double, 3> tileOrigin(std::uint32_t x, std::uint32_t y,
                                                   std::uint32_t z) const noexcept;
    /// Edge of a tile's region: 2^T·cellSize().
    [[nodiscard]] double tileSize() const noexcept {
        return cellSize() * double(1ull << tileDepth);
    }
};

/// Where the tiles of the index @p index live: "<index>.tiles/".
[[nodiscard]] std::filesystem::path tileDirectory(const std::filesystem::path& index);
/// The file of tile (x, y, z): "<index>.tiles/tile-X-Y-Z.rvol" (decimal).
[[nodiscard]] std::filesystem::path tilePath(const std::filesystem::path& index, std::uint32_t x,
                                             std::uint32_t y, std::uint32_t z);
/// The far-field file: "<index>.tiles/far.rvol".
[[nodiscard]] std::filesystem::path farFieldPath(const std::filesystem::path& index);

/// Whether @p file starts with the tile index magic (false if it cannot be read).
[[nodiscard]] bool isTileIndex(const std::filesystem::path& file);

/// Writes the index atomically (AtomicFile). Expects tiles in strictly ascending Morton order with
/// coordinates below 2^(depth − tileDepth). @throws std::invalid_argument for an inconsistent
/// index, IoError if the file cannot be written.
void writeTileIndex(const std::filesystem::path& file, const TileIndex& index);

/// Reads and checks a tile index (header checksum, fields in range, table checksum, tiles in
/// strictly ascending Morton order and inside the volume). Tiles and the far field are not opened.
/// @throws IoError, InvalidDataError naming the file.
[[nodiscard]] TileIndex readTileIndex(const std::filesystem::path& file);

/// How many tile files a TiledRvolReader keeps open, and how much they cache.
struct TiledRvolReaderOptions {
    /// Tile files open at once, at least 1 (the far field, open from its first use on, is not
    /// counted). Each holds a file descriptor, its brick directory and its brick cache.
    std::uint32_t maxOpenTiles = 64;
    /// Decoded bricks kept for sampling, over all open tiles: each open tile caches
    /// cacheBytes / maxOpenTiles (RvolReader::setCacheBytes). The far field keeps RvolReader's
    /// default cache besides.
    std::uint64_t cacheBytes = std::uint64_t{512} << 20;
};

/// What a TiledRvolReader has open now, and what it opened and closed since it was made.
struct OpenTileStats {
    std::uint32_t open = 0;      ///< tile files open now
    std::uint32_t mostOpen = 0;  ///< the most tile files open at once
    std::uint64_t opened = 0;    ///< tile files opened, each reopening counted
    std::uint64_t closed = 0;    ///< tile files closed to make room for another
};

/// A tiled volume open for sampling: the index, and the tile and far-field files opened on first
/// use, each checked against its index entry (header checksum, size, depth, geometry). Samples
/// cross tile borders as a single volume of depth D would: level l ≤ T reads every cell from the
/// tile owning it, levels above T come from the far field.
///
/// At most TiledRvolReaderOptions::maxOpenTiles tile files are open at once: opening another
/// closes the least recently used open tile that no sample is reading and no handle (tile())
/// holds. A closed tile is opened again, and checked against its entry again, when it is next
/// needed; a tile file removed or replaced since then fails there, as a first opening would.
///
/// Every const member function is thread-safe. A sample keeps the tiles it reads open until it
/// returns; where every open tile is being read by other threads' samples, opening another waits
/// for one of them to finish. Handles keep their tiles open for as long as they live; where the
/// tiles that handles hold leave no room, a tile opens past the bound, and the count returns to
/// it as those handles go.
class TiledRvolReader final : public RvolSampler {
public:
    /// Reads and checks the index (readTileIndex); opens no tile. @throws IoError,
    /// InvalidDataError; ParameterError for maxOpenTiles 0.
    explicit TiledRvolReader(std::filesystem::path index,
                             const TiledRvolReaderOptions& options = {});
    /// Expects no handle from tile() to be alive.
    ~TiledRvolReader() override;
    TiledRvolReader(const TiledRvolReader&) = delete;
    TiledRvolReader& operator=(const TiledRvolReader&) = delete;

    [[nodiscard]] const TileIndex& index() const noexcept { return index_; }
    [[nodiscard]] const std::filesystem::path& path() const noexcept { return path_; }
    [[nodiscard]] const TiledRvolReaderOptions& options() const noexcept { return options_; }
    [[nodiscard]] std::uint32_t depth() const noexcept override { return index_.depth; }
    [[nodiscard]] const std::array<double, 3>& origin() const noexcept override {
        return index_.origin;
    }
    [[nodiscard]] double size() const noexcept override { return index_.size; }
    [[nodiscard]] const BakeInfo& bakeInfo() const noexcept override { return index_.bake; }

    /// Index in index().tiles of tile (x, y, z), or -1.
    [[nodiscard]] std::int64_t findTile(std::uint32_t x, std::uint32_t y,
                                        std::uint32_t z) const noexcept;
    /// The file of tile @p i: tilePath(path(), x, y, z).
    [[nodiscard]] std::filesystem::path tileFile(std::size_t i) const;
    /// Tile @p i, opened and checked against its entry if it is not open: a handle that keeps it
    /// open while it or a copy lives, and that must not outlive this reader.
    /// @throws std::out_of_range for a bad @p i; IoError "FILE: cannot open: …" naming the tile's
    /// file (also when it was open before and has gone since), InvalidDataError.
    [[nodiscard]] std::shared_ptr<const RvolReader> tile(std::size_t i) const;
    /// The far field opened and checked; it stays open as long as this reader.
    /// @throws IoError, InvalidDataError.
    [[nodiscard]] const RvolReader& farField() const;
    /// The tile files open now and since construction (a snapshot).
    [[nodiscard]] OpenTileStats openTileStats() const;

    /// Texel of cell (x, y, z) of @p level (≤ depth), @p channel: from the owning tile at levels
    /// ≤ T (zero where no tile is listed), from the far field above. Throws as sample().
    [[nodiscard]] Texel cell(std::uint32_t level, std::uint32_t channel, std::uint32_t x,
                             std::uint32_t y, std::uint32_t z) const;
    /// Trilinear sample as RvolReader::sample over the whole depth-D volume: each of the eight
    /// cells from the tile owning it (where one tile owns all eight, its own filter reads them,
    /// equal up to rounding), levels above T from the far field. @throws std::out_of_range for a
    /// bad level or channel; IoError or InvalidDataError naming the file that cannot be opened
    /// (or opened again) or read.
    [[nodiscard]] Texel sample(std::uint32_t level, std::uint32_t channel,
                               const std::array<double, 3>& position) const override;
    /// As RvolReader::sampleDirectional over the whole depth-D volume. Throws as sample().
    [[nodiscard]] Texel sampleDirectional(std::uint32_t level,
                                          const std::array<double, 3>& position,
                                          const std::array<double, 3>& direction) const override;

private:
    struct Tile;
    struct OpenFiles;
    class TileUse;

    /// @p count channels of level ≤ T at @p position into @p out, with a single use of the tile
    /// where one tile owns the eight cells.
    void sampleChannels(std::uint32_t level, const std::uint32_t* channels, std::size_t count,
                        const std::array<double, 3>& position, Texel* out) const;
    /// @p count channels of level ≤ T's cell @p cell, from the tile owning it, into @p out.
    void cellChannels(std::uint32_t level, const std::uint32_t* channels, std::size_t count,
                      const std::array<std::uint32_t, 3>& cell, Texel* out) const;
    [[nodiscard]] const RvolReader& useTile(std::size_t i, bool handle) const;
    void dropHandle(std::size_t i) const;
    void openTile(std::size_t i) const;   // expects OpenFiles::mutex held
    void closeTile(std::size_t i) const;  // expects OpenFiles::mutex held, the tile unused

    std::filesystem::path path_;
    TileIndex index_;
    TiledRvolReaderOptions options_;
    std::map<std::uint64_t, std::size_t> byMorton_;
    std::unique_ptr<OpenFiles> open_;
};

/// @p file open for sampling: a TiledRvolReader (with @p tiled) where it starts with the tile
/// index magic (isTileIndex), else an RvolReader. @throws what their constructors throw.
[[nodiscard]] std::unique_ptr<RvolSampler> openRvolSampler(
    const std::filesystem::path& file, const TiledRvolReaderOptions& tiled = {});

/// What validateTiledRvol found.
struct TiledRvolReport {
    std::uint64_t indexBytes = 0;
    std::uint64_t tiles = 0;
    std::uint64_t tileBytes = 0;  ///< all tile files
    std::uint64_t farBytes = 0;
    std::uint64_t bricks = 0;  ///< all tiles' and the far field's
    std::uint64_t staticVoxels = 0;
    std::uint64_t largestTileBytes = 0;
};

/// Validates the index, every tile file (validateRvol, and its entry: header checksum, size,
/// depth T, brick texels, origin and size of its region, voxel and brick counts) and the far field
/// (validateRvol; depth F, the root cube). @throws InvalidDataError "FILE: problem" at the first
/// problem (FILE the index or the tile), IoError if a file is missing.
TiledRvolReport validateTiledRvol(const std::filesystem::path& index);

}  // namespace vox::rvol
