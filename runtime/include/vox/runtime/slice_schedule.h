/// @file slice_schedule.h
/// @brief Which .esvo slices a view needs, and keeping a pool of them under a memory budget:
/// the policy half of streaming, free of GL so that it is tested on its own.
///
/// A slice holds the voxels below its parent's frontier descriptors (level firstLevel); without
/// it those descriptors render as leaves. So a slice is *needed* while its frontier voxels (edge
/// 2^−firstLevel of the root cube) would look bigger than a pixel: their angular size from the
/// eye to the nearest point of the slice's region cube exceeds lodScale × the pixel angle. Slices
/// whose region is outside the view frustum are not needed. Under a budget the needed slices are
/// chosen coarse and near first (largest angular size first), always with their parents, so what
/// is resident is a top of the tree in which rays stop at the finest resident level.
#pragma once

#include <vox/formats/esvo.h>
#include <vox/formats/esvo_reader.h>
#include <vox/base/camera.h>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace vox::runtime {

/// A view to stream for: the camera, and the detail wanted.
struct StreamingView {
    PinholeCamera camera;
    /// A slice is needed while its frontier voxels look bigger than lodScale pixels (1: about
    /// one voxel per pixel, as the ray caster's LOD cut at the pixel angle).
    double lodScale = 1;
};

/// A slice's region cube in root-cube coordinates ([0, 1]³): level, integer position at that level.
struct SliceRegion {
    std::uint32_t level = 0;
    std::uint64_t x = 0, y = 0, z = 0;
    [[nodiscard]] double size() const noexcept { return 1.0 / double(std::uint64_t{1} << level); }
};

/// The region cube of every slice of @p directory (docs/esvo-format.md, "Regions").
[[nodiscard]] std::vector<SliceRegion> sliceRegions(const esvo::Directory& directory);

/// Bytes slice @p entry takes in a pool: its size rounded up to whole 8 KB pages (EsvoPool's
/// residentBytes counts the same).
[[nodiscard]] std::uint64_t residentBytesOf(const esvo::SliceEntry& entry) noexcept;

/// What a view needs.
struct SliceSelection {
    /// Slices to have resident, parents before children (slice 0, the root, always first).
    std::vector<std::uint32_t> slices;
    std::uint64_t bytes = 0;             ///< their residentBytesOf total
    std::uint32_t neededNotFitting = 0;  ///< needed slices left out by the budget (0: full detail)
};

/// Selects the slices @p view needs from @p reader's file, at most @p budgetBytes in all (the
/// root slice always, even over the budget). Deterministic: ties go to the lower slice index.
/// @p excluded (one flag per slice, or null): slices never to select, nor anything below them
/// (slices found corrupt).
[[nodiscard]] SliceSelection selectSlices(const esvo::EsvoReader& reader,
                                          const std::vector<SliceRegion>& regions,
                                          const StreamingView& view, std::uint64_t budgetBytes,
                                          const std::vector<char>* excluded = nullptr);

/// Keeps an EsvoPool's resident slices to what successive views select, under a budget: loads
/// what is selected and missing (parents first), and evicts least-recently-selected slices (the
/// deepest first among equals) only as far as needed to stay within the budget, so slices a
/// view stops needing stay cached while memory allows. A slice that fails to load (IoError or
/// InvalidDataError: unreadable, checksum or structure wrong) is marked bad: never retried, never
/// selected again, nor anything below it, so rays stop at its parent's level there.
class SliceResidency {
public:
    /// @p pool must outlive this; it starts with the root slice.
    SliceResidency(esvo::EsvoPool& pool, std::uint64_t budgetBytes);

    /// What update() did.
    struct Update {
        std::vector<std::uint32_t> loaded;   ///< in load order
        std::vector<std::uint32_t> evicted;  ///< slices unloaded (with EsvoPool::unload, which also
                                             ///< drops their descendants)
        std::uint64_t loadedBytes = 0;       ///< residentBytesOf the loaded slices
        /// Selected slices left for later frames by the per-frame load limit (0: the view is at
        /// the detail the budget allows).
        std::uint32_t pending = 0;
        SliceSelection selection;
        /// Slices that failed to load in this update (now bad), and why: one line each naming the
        /// file and the slice.
        std::vector<std::uint32_t> failed;
        std::vector<std::string> errors;
    };
    /// Selects for @p view, evicts to make room, loads what is missing.
    Update update(const StreamingView& view);
    void setBudget(std::uint64_t budgetBytes) noexcept { budget_ = budgetBytes; }
    /// Most bytes of slices loaded by one update() (0: no limit), so that a camera jump spreads
    /// its loads over frames, coarse first, instead of stalling one. At least one slice is loaded
    /// per update when any is missing.
    void setFrameLoadLimit(std::uint64_t bytes) noexcept { frameLimit_ = bytes; }
    [[nodiscard]] std::uint64_t budget() const noexcept { return budget_; }
    [[nodiscard]] std::uint64_t frame() const noexcept { return frame_; }
    /// Slices found bad so far (see the class), in the order found.
    [[nodiscard]] const std::vector<std::uint32_t>& badSlices() const noexcept { return badList_; }

private:
    esvo::EsvoPool& pool_;
    std::vector<SliceRegion> regions_;
    std::vector<std::uint64_t> lastUsed_;  // per slice: the frame that last selected it
    std::vector<char> bad_;                // per slice: failed to load once, never retried
    std::vector<std::uint32_t> badList_;
    std::uint64_t budget_;
    std::uint64_t frameLimit_ = 0;
    std::uint64_t frame_ = 0;
};

}  // namespace vox::runtime
