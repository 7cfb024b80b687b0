// The volume's block structure and its anisotropic mip chain (Gui et al. 2019, 2.3).
#pragma once

#include <vox/formats/rvol.h>
#include <vox/radiance_field.h>

#include <cstdint>
#include <span>
#include <vector>

namespace vox::detail {

/// Level 0's blocks for @p cells (level-0 coordinates, ascending Morton order), and the blocks of
/// every coarser level above them, all texels zero. @p cellTexel receives, per cell, its texel's
/// index in level 0's texels.
void allocateVolume(rvol::Volume& volume, std::span<const std::array<std::uint32_t, 3>> cells,
                    std::vector<std::size_t>& cellTexel);

/// Rebuilds levels 1 … depth from level 0: per directional channel, each parent cell is the mean
/// over its four child columns of the two children composited front to back along the channel's
/// direction. @p hidden: per level-0 texel, bit k set where a cone looking along channel k sees
/// only the back of the voxel's surface: that channel treats the voxel as empty. The surface's
/// front (where the geometry is closed) stands in front of it for cones from outside, and a cone
/// leaving the surface does not occlude itself with the surface it starts on.
void filterMips(rvol::Volume& volume, const RadianceField& field,
                const std::vector<std::uint8_t>& hidden);

}  // namespace vox::detail
