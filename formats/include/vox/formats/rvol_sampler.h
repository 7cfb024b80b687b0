/// @file rvol_sampler.h
/// @brief Sampling a radiance volume through one interface, whether it is one .rvol file
/// (RvolReader) or a tiled volume (TiledRvolReader): what a cone tracer needs to read a volume
/// it does not hold in memory.
#pragma once

#include <vox/formats/rvol.h>

#include <array>
#include <cstdint>

namespace vox::rvol {

/// A radiance volume of levels 0 … depth() over the root cube at origin() of edge size(), level l
/// of 2^(depth − l) cells per axis, sampled as docs/rvol-format.md, "Sampling" defines it.
/// Implementations make every member safe to call from several threads at once.
class RvolSampler {
public:
    virtual ~RvolSampler() = default;

    /// Finest level's depth: level 0 has 2^depth() cells per axis.
    [[nodiscard]] virtual std::uint32_t depth() const noexcept = 0;
    /// World position of the root cube's minimum corner.
    [[nodiscard]] virtual const std::array<double, 3>& origin() const noexcept = 0;
    /// Root cube edge, world units.
    [[nodiscard]] virtual double size() const noexcept = 0;
    /// The bake that wrote the volume (informational).
    [[nodiscard]] virtual const BakeInfo& bakeInfo() const noexcept = 0;

    /// Trilinear sample of @p channel of @p level at world position @p position, clamped to the
    /// level's cells. @throws std::out_of_range for a bad level or channel; IoError or
    /// InvalidDataError (naming the file) where the data behind the sample cannot be read.
    [[nodiscard]] virtual Texel sample(std::uint32_t level, std::uint32_t channel,
                                       const std::array<double, 3>& position) const = 0;
    /// What a cone travelling along @p direction sees at @p position: level 0's isotropic
    /// channel, above it combineDirectional of the three channels facing @p direction (zero for a
    /// zero or non-finite direction). Throws as sample().
    [[nodiscard]] virtual Texel sampleDirectional(std::uint32_t level,
                                                  const std::array<double, 3>& position,
                                                  const std::array<double, 3>& direction) const = 0;

protected:
    RvolSampler() = default;
    RvolSampler(const RvolSampler&) = default;
    RvolSampler& operator=(const RvolSampler&) = default;
};

}  // namespace vox::rvol
