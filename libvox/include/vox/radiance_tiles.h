/// @file radiance_tiles.h
/// @brief Tiled radiance bakes (docs/rvol-format.md, "Tiled volumes"): a volume of 2^depth cells
/// per axis (up to 2^13) baked as tiles of 2^tileDepth cells, each in memory bounded by its tile,
/// with a far-field volume of the whole root cube for what lies beyond a tile's halo. Every tile
/// can be baked by a job of its own; the index step then checks the tiles and writes the index.
#pragma once

#include <vox/formats/rvol_io.h>
#include <vox/formats/rvol_tiles.h>
#include <vox/radiance.h>
#include <vox/scene.h>

#include <array>
#include <cstdint>
#include <filesystem>
#include <vector>

namespace vox {

/// How a tiled volume is cut.
struct RadianceTiling {
    std::uint32_t depth = 0;      ///< D: 2^D finest cells per axis (tileDepth + 1 … 13)
    std::uint32_t tileDepth = 0;  ///< T: a tile owns 2^T cells per axis (2 … 9)
    std::uint32_t halo = 0;       ///< H: cells baked around a tile's own (0 … 2^(T−1))
    std::uint32_t farDepth = 0;   ///< F: the far field's depth (D − T < F ≤ min(D, 10))

    /// The tiling for @p depth and @p tileDepth; @p halo 0 picks 2^(T−2) cells. The far field's
    /// cells are a sixteenth of the halo (F = D − log2(H) + 4), at most min(D, 10, T + 1) (a far
    /// bake no larger than a tile's) and at least D − T + 1.
    /// @throws ParameterError ("radianceTileDepth", "radianceHalo") where no tiling fits.
    [[nodiscard]] static RadianceTiling plan(std::uint32_t depth, std::uint32_t tileDepth,
                                             std::uint32_t halo = 0);
    /// The largest tile depth (≤ 8, ≤ depth − 1, ≥ depth − 9) whose bake's dense grids
    /// (estimateTileBytes) take at most half of @p memoryLimit (0: 8).
    [[nodiscard]] static std::uint32_t tileDepthFor(std::uint32_t depth, std::uint64_t memoryLimit);
    /// Estimated peak bytes of one tile's bake beyond the scene: the dense grids over its cube of
    /// 2^(T+1) cells per axis (air-region labels and solid bits, about 2.2 bytes a cell).
    [[nodiscard]] static std::uint64_t estimateTileBytes(std::uint32_t tileDepth);
};

/// What to do: the whole bake, one run of several, or the index step.
struct TiledBakeJob {
    enum class Kind { Whole, Run, Index } kind = Kind::Whole;
    std::uint32_t run = 0, runs = 1;  ///< Kind::Run: run (0-based) of runs
};

struct TiledBakeResult {
    std::uint64_t tilesTotal = 0;                       ///< tiles of the volume holding voxels
    std::uint64_t tilesBaked = 0;                       ///< by this job
    std::uint64_t staticVoxels = 0, dynamicVoxels = 0;  ///< of the tiles baked
    std::uint64_t tileBytes = 0;                        ///< files written by this job
    std::uint64_t farBytes = 0;                         ///< far field written (0: not written)
    std::uint64_t indexBytes = 0;                       ///< index written (0: not written)
    std::uint64_t largestTileVoxels = 0;
    double farSeconds = 0, tileSeconds = 0;
    /// The tile files this job wrote (Whole, Run), in Morton order, as their index entries: what
    /// a scheduler checks to know that a run's tiles are still there and whole.
    std::vector<rvol::TileEntry> tilesWritten;
};

/// The tiles of @p far's volume that hold a voxel of its static layer, in Morton order, with
/// their far-field voxel counts (the work shares of runs).
[[nodiscard]] std::vector<std::pair<std::array<std::uint32_t, 3>, std::uint64_t>> radianceTiles(
    const rvol::Volume& far, const RadianceTiling& tiling);

/// Which run of @p runs bakes each tile: tiles in Morton order, run k takes those whose
/// cumulative weight before them falls in the k-th of runs equal shares.
[[nodiscard]] std::vector<std::uint32_t> radianceTileRuns(
    const std::vector<std::pair<std::array<std::uint32_t, 3>, std::uint64_t>>& tiles,
    std::uint32_t runs);

/// Bakes tile @p tile of @p scene: its cube of 2^(T+1) cells centred on the tile, voxels within
/// the halo lit and gathered, beyond it @p far; the result holds the tile's own 2^T cells.
/// Deterministic, whatever the thread count.
[[nodiscard]] RadianceBake bakeRadianceTile(const Scene& scene, const RadianceBakeOptions& options,
                                            const RadianceTiling& tiling,
                                            std::array<std::uint32_t, 3> tile,
                                            const rvol::Volume& far);

/// Bakes (Whole, Run) and writes the tile files under rvol::tileDirectory(@p index); Whole and
/// Index also write the far field and, last, the index (Index checks that every tile's file is
/// there and of this bake's geometry, reading only headers). Every file is written atomically;
/// the same scene and options give the same bytes whatever the job split or thread count.
/// @throws ParameterError for bad options, IoError (a tile file missing for Index, a file that
/// cannot be written), InvalidDataError (a tile file of another tiling).
TiledBakeResult bakeTiledRadiance(const Scene& scene, const RadianceBakeOptions& options,
                                  const RadianceTiling& tiling, const TiledBakeJob& job,
                                  const std::filesystem::path& index,
                                  const rvol::RvolWriteOptions& write);

}  // namespace vox
