// Connected regions of empty space at level 0. The bake gathers each voxel's bounce light from a
// volume holding only the voxels that face the same region, so light cannot leak through a wall
// into a closed room however coarse the cone's samples get (a coarse sample straddling a wall
// would otherwise mix the lit outside into the dark inside).
#pragma once

#include "voxel_shadows.h"

#include <vox/base/math.h>

#include <array>
#include <cstdint>
#include <vector>

namespace vox::detail {

class AirRegions {
public:
    static constexpr std::uint16_t kSolid = 0xFFFF;
    static constexpr std::uint16_t kNone =
        0xFFFE;  ///< no region (also: regions beyond the label range)

    /// Labels the 6-connected components of the cells @p solid leaves empty, in scan order. Cells
    /// outside [@p lo, @p hi) hold no air (they are labelled kSolid): beyond the root cube of a
    /// region's bake there is no space to face or to connect through, as in the whole bake.
    AirRegions(const SolidGrid& solid, std::uint32_t depth, std::array<std::int64_t, 3> lo = {},
               std::array<std::int64_t, 3> hi = {kNoLimit, kNoLimit, kNoLimit});
    static constexpr std::int64_t kNoLimit = std::int64_t{1} << 40;

    [[nodiscard]] std::uint32_t count() const noexcept { return count_; }
    [[nodiscard]] std::uint16_t label(std::int64_t x, std::int64_t y,
                                      std::int64_t z) const noexcept;
    /// The region a surface voxel faces: that of the first empty cell up to three cells out along
    /// its unit @p normal (kNone if there is none).
    [[nodiscard]] std::uint16_t facing(std::uint32_t x, std::uint32_t y, std::uint32_t z,
                                       Vec3f normal) const noexcept;
    /// Whether a face neighbour of cell (x, y, z) belongs to @p region.
    [[nodiscard]] bool touches(std::uint32_t x, std::uint32_t y, std::uint32_t z,
                               std::uint16_t region) const noexcept;

private:
    std::uint32_t resolution_;
    std::uint32_t count_ = 0;
    std::vector<std::uint16_t> labels_;
};

}  // namespace vox::detail
