/// @file rvol.h
/// @brief The .rvol radiance volume (docs/rvol-format.md): a mipmapped, anisotropic radiance
/// volume after Gui et al. 2019 — an isotropic finest level, six directional channels on every
/// coarser level, opacity in alpha — stored as sparse bricks with shared borders, plus the voxel
/// attribute layers (static and dynamic) a runtime needs to re-light or re-inject voxels.
/// This header holds the in-memory model the bake produces and the writer and reader exchange.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

namespace vox::rvol {

/// Premultiplied linear RGB radiance (radiance × opacity) and opacity.
struct Texel {
    float r = 0, g = 0, b = 0, a = 0;
    friend bool operator==(const Texel&, const Texel&) = default;
};

/// The six directional channels of levels ≥ 1, in this order. A channel is named by the direction
/// a cone *looks* (travels): channel PosX holds the level's cells composited front to back along
/// +x (the child with the lower x in front), i.e. the light they send towards −x.
enum class Direction : std::uint8_t { PosX = 0, NegX, PosY, NegY, PosZ, NegZ };
constexpr std::uint32_t kDirections = 6;
/// Cells per axis of the blocks a Level stores its texels in.
constexpr std::uint32_t kBlockCells = 8;
constexpr std::uint32_t kBlockTexels = kBlockCells * kBlockCells * kBlockCells;

/// What a cone travelling along @p direction (any length, not zero) sees, from the samples of the
/// three channels facing it (@p facing[a]: the channel of axis a with direction[a]'s sign; ignored
/// where direction[a] = 0): colour blended by d_a²/|d|², opacity 1 − Π_a (1 − a_a)^(|d_a| / Σ|d|),
/// the colour rescaled to that opacity (docs/rvol-format.md, "Directional sample"). The one
/// definition the reader, the bake's cones and the final gather share.
[[nodiscard]] Texel combineDirectional(const std::array<Texel, 3>& facing,
                                       const std::array<double, 3>& direction) noexcept;

/// Morton code of (x, y, z) (x in bit 0), up to 21 bits per axis.
[[nodiscard]] std::uint64_t morton3(std::uint32_t x, std::uint32_t y, std::uint32_t z) noexcept;
/// Inverse of morton3.
[[nodiscard]] std::array<std::uint32_t, 3> demorton3(std::uint64_t code) noexcept;

/// One mip level in memory: sparse 8³ blocks of cells, each with one texel per channel. Cells
/// outside every block are zero (empty space).
struct Level {
    std::uint32_t resolution = 0;  ///< cells per axis (2^(depth − level))
    std::uint32_t channels = 1;    ///< 1 at level 0 (isotropic), kDirections above
    /// Morton code (morton3) of each block's coordinates (cell / kBlockCells), strictly ascending.
    std::vector<std::uint64_t> blocks;
    /// Per block, channels × kBlockTexels texels: channel-major, then z, y, x (x fastest).
    std::vector<Texel> texels;

    /// Index of the block holding cell (x, y, z), or -1.
    [[nodiscard]] std::int64_t findBlock(std::uint32_t x, std::uint32_t y,
                                         std::uint32_t z) const noexcept;
    /// The texel of cell (x, y, z) in @p channel; zero outside the level or outside every block.
    [[nodiscard]] Texel at(std::uint32_t x, std::uint32_t y, std::uint32_t z,
                           std::uint32_t channel) const noexcept;
    /// Offset of cell (x, y, z) of block @p block, channel @p channel, in texels.
    [[nodiscard]] static std::size_t texelIndex(std::size_t block, std::uint32_t channels,
                                                std::uint32_t channel, std::uint32_t x,
                                                std::uint32_t y, std::uint32_t z) noexcept {
        return ((block * channels + channel) * kBlockCells + (z % kBlockCells)) * kBlockCells *
                   kBlockCells +
               (y % kBlockCells) * kBlockCells + (x % kBlockCells);
    }
};

/// Flags of a voxel in the attribute layers.
enum VoxelFlags : std::uint8_t { kVoxelDynamic = 1 };

/// The attributes of one finest-level voxel, filtered over the triangle fragments inside it.
struct VoxelAttributes {
    std::uint32_t x = 0, y = 0, z = 0;       ///< cell at level 0
    std::array<float, 3> albedo{0, 0, 0};    ///< linear, area-weighted mean base colour
    float coverage = 0;                      ///< mean base-colour alpha
    std::array<float, 3> normal{0, 0, 1};    ///< unit mean normal
    std::array<float, 3> emission{0, 0, 0};  ///< linear emitted radiance
    float occlusion = 0;                     ///< ambient occlusion (Gui et al. eq. 4), 0 = open
};

/// What the bake records about itself (shown by `voxinspect info`).
struct BakeInfo {
    std::uint32_t bounces = 0;
    float shadowApertureDegrees = 0;  ///< 0: shadow rays
    float aoLambda = 0;
    std::uint32_t attenuation = 0;  ///< vox::Attenuation
    std::uint32_t lights = 0;
    std::uint32_t gatherRays = 0;  ///< rays per voxel that gathered the bounces; 0: cones
};

/// A whole radiance volume in memory.
struct Volume {
    std::array<double, 3> origin{0, 0, 0};  ///< world position of the root cube's minimum corner
    double size = 1;                        ///< root cube edge, world units
    std::uint32_t depth = 0;                ///< level 0 has 2^depth cells per axis
    std::array<float, 6> sceneBounds{};     ///< min xyz, max xyz (world)
    /// levels[0] … levels[depth]: levels[l].resolution = 2^(depth − l).
    std::vector<Level> levels;
    std::vector<VoxelAttributes> staticVoxels;   ///< ascending Morton order
    std::vector<VoxelAttributes> dynamicVoxels;  ///< ascending Morton order; not in the radiance
    BakeInfo bake;

    [[nodiscard]] double cellSize(std::uint32_t level) const noexcept {
        return size / double(1u << (depth - level));
    }
};

}  // namespace vox::rvol
