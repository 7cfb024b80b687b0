/// @file rvol_residency.h
/// @brief Which radiance bricks a camera needs on the GPU, under a memory budget: the radiance
/// volume's streaming policy (the .esvo one is slice_schedule.h), for a single .rvol and for a
/// tiled volume alike.
///
/// Every shaded point starts its cones at the finest level, so a level's bricks are needed as far
/// as its cells would still look bigger than lodScale pixels from the eye (as an octree slice's
/// voxels, slice_schedule.h): a brick of level l with cells of c_l is needed while its distance d
/// to the eye has c_l / d > lodScale × the camera's pixel angle; the top level always. Beyond that
/// the level above serves (a clipmap around the eye). Needed bricks are taken in order of
/// S_l / d (S_l the brick's edge: coarse and near first), and the selection stops at the first
/// brick that does not fit, so that every selected brick's coarser cover is selected too: a
/// missing brick (kMissingBrick) then always has a resident level above it to fall back to.
///
/// A tiled volume's far field is such a volume (levels depth − farDepth … depth), and the tiles'
/// bricks join the same order; at equal S / d the far field's brick goes first, so a tile brick's
/// fallback, the far field at its level (or its finest), is kept whenever the tile brick is. Tile
/// bricks at levels the far field also has only refine it: they come after every other needed
/// brick. A tile's file is opened only when the order reaches its bound (the edge of its coarsest
/// brick below the far field's levels over its distance) within the budget: tiles far from the
/// eye are never read.
#pragma once

#include <vox/base/camera.h>
#include <vox/runtime/rvol_gpu_volume.h>

#include <cstdint>
#include <map>

namespace vox::runtime {

/// Keeps an RvolGpuVolume's resident bricks to what the camera needs, within a budget.
class RvolResidency {
public:
    /// @p volume must outlive this (create it with uploadAll false and atlasBytes ≈ the budget).
    RvolResidency(RvolGpuVolume& volume, std::uint64_t budgetBytes, double lodScale = 1);

    struct Update {
        std::uint32_t uploaded = 0, evicted = 0;  ///< bricks
        std::uint32_t selected = 0;               ///< bricks the view keeps
        /// Needed bricks the budget (or the atlas, or the tile slots) leaves out, of the files
        /// opened: a tile beyond the budget's cut is not opened to count its bricks.
        std::uint32_t neededNotFitting = 0;
        std::uint32_t tilesUploaded = 0;  ///< tiles that got their first resident brick
        std::uint32_t tilesEvicted = 0;   ///< tiles that lost their last one
        std::uint32_t residentTiles = 0;  ///< tiles with a resident brick, after the update
        std::uint64_t residentBytes = 0;  ///< brickBytes of the resident bricks
    };
    /// Selects for @p camera's eye, evicts what is not selected (bricks of tiles the view does not
    /// keep first, then the finest level, then least recently selected) as far as the budget and
    /// the tile slots need, uploads what is missing.
    Update update(const PinholeCamera& camera);
    [[nodiscard]] std::uint64_t residentBytes() const noexcept { return residentBytes_; }
    [[nodiscard]] std::uint64_t budget() const noexcept { return budget_; }

private:
    RvolGpuVolume& volume_;
    std::uint64_t budget_;
    double lodScale_;
    std::uint64_t frame_ = 0, residentBytes_ = 0;
    std::map<RvolBrickRef, std::uint64_t> lastUsed_;  // the frame each resident brick was last kept
};

}  // namespace vox::runtime
