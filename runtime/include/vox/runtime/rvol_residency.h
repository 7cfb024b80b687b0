/// @file rvol_residency.h
/// @brief Which .rvol bricks a camera needs on the GPU, under a memory budget: the radiance
/// volume's streaming policy (the .esvo one is slice_schedule.h).
///
/// Cones sample fine levels near their start and coarser ones further out, so what a view needs
/// is a clipmap around the eye: a brick of level l (edge S_l = (N − 1) cells of that level) is
/// needed while the eye is within radius × S_l of it; the top level always. Needed bricks are
/// taken in order of S_l / distance (coarse and near first), and the selection stops at the first
/// brick that does not fit, so that every selected brick's coarser cover is selected too: a
/// missing brick (kMissingBrick) then always has a resident level above it to fall back to.
#pragma once

#include <vox/runtime/camera.h>
#include <vox/runtime/rvol_gpu_volume.h>

#include <cstdint>
#include <vector>

namespace vox::runtime {

/// Keeps an RvolGpuVolume's resident bricks to what the camera needs, within a budget.
class RvolResidency {
public:
    /// @p volume must outlive this (create it with uploadAll false and atlasBytes ≈ the budget).
    /// @p radiusBricks: how many of its own edges around the eye a level's bricks are kept.
    RvolResidency(RvolGpuVolume& volume, std::uint64_t budgetBytes, double radiusBricks = 4);

    struct Update {
        std::uint32_t uploaded = 0, evicted = 0;  ///< bricks
        std::uint32_t selected = 0;               ///< bricks the view keeps
        std::uint32_t neededNotFitting = 0;       ///< needed bricks the budget leaves out
        std::uint64_t residentBytes = 0;          ///< brickBytes of the resident bricks
    };
    /// Selects for @p camera's eye, evicts what is not selected (finest level first, then least
    /// recently selected) as far as needed, uploads what is missing.
    Update update(const Camera& camera);
    [[nodiscard]] std::uint64_t residentBytes() const noexcept { return residentBytes_; }
    [[nodiscard]] std::uint64_t budget() const noexcept { return budget_; }

private:
    RvolGpuVolume& volume_;
    std::uint64_t budget_;
    double radius_;
    std::uint64_t frame_ = 0, residentBytes_ = 0;
    std::vector<std::vector<std::uint64_t>> lastUsed_;  // per level, per brick
};

}  // namespace vox::runtime
