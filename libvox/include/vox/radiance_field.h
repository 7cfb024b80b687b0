/// @file radiance_field.h
/// @brief Sampling and cone tracing over a radiance volume (Gui et al. 2019, 2.3–2.4), an
/// rvol::Volume in memory or a volume read through an rvol::RvolSampler (a file, a tiled volume):
/// the bake's bounces, `voxinspect render`'s final gather and the tests all trace cones through
/// this.
#pragma once

#include <vox/formats/rvol.h>
#include <vox/formats/rvol_sampler.h>
#include <vox/base/math.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace vox {

/// Read access to a volume's levels. Over an rvol::Volume: a dense block index per level, for
/// fast lookups; the volume must outlive the field and keep its blocks (texel values may change:
/// the bake rewrites them each bounce). Over an rvol::RvolSampler: every sample is the sampler's,
/// and the sampling members throw what it throws (a file that cannot be read). Const members are
/// thread-safe.
class RadianceField {
public:
    explicit RadianceField(const rvol::Volume& volume);
    /// Samples through @p sampler, which must outlive the field.
    explicit RadianceField(const rvol::RvolSampler& sampler);

    /// Level 0 has 2^depth() cells per axis.
    [[nodiscard]] std::uint32_t depth() const noexcept { return depth_; }
    /// Root cube: minimum corner and edge, world units.
    [[nodiscard]] Vec3d origin() const noexcept { return origin_; }
    [[nodiscard]] double size() const noexcept { return size_; }

    /// Trilinear sample of level @p level at world point @p p, the cone looking along unit @p dir:
    /// level 0's single channel, or the three directional channels facing @p dir: colour blended
    /// by dir_s² (paper 2.3), opacity as 1 − Π_s (1 − a_s)^(|dir_s| / Σ|dir|), so a wall opaque
    /// along its normal stays opaque to oblique cones. Cell coordinates are clamped to the level,
    /// like a GPU's clamp-to-edge.
    [[nodiscard]] rvol::Texel sample(std::uint32_t level, Vec3d p, Vec3d dir) const;
    /// Between levels: linear in the fractional level (clamped to [0, depth]).
    [[nodiscard]] rvol::Texel sampleLod(double level, Vec3d p, Vec3d dir) const;

    /// One cone: from @p origin along unit @p dir, half-angle tangent @p tanHalfAngle, samples from
    /// @p start to @p maxDistance (world units) stepping half a footprint, compositing front to
    /// back (eq. 3, opacity corrected for the step).
    struct Cone {
        Vec3d origin, dir;
        double tanHalfAngle = 0.577;
        double start = 0;
        double maxDistance = 1e30;
        /// With a non-zero @p plane normal: the cone leaves the surface through @p planePoint with
        /// that unit normal, and no sample's filter reaches behind that plane (a sample's level is
        /// lowered until its trilinear footprint, 1.5 cells each way around the point it reads,
        /// its position clamped to the root cube, stays in front). Without
        /// this, coarse samples near the start straddle the surface the cone leaves and pick up
        /// what lies behind it: the lit outside of a closed room's wall, seen from inside.
        Vec3d planePoint{0, 0, 0};
        Vec3d planeNormal{0, 0, 0};
    };
    struct ConeResult {
        Vec3d radiance{0, 0, 0};  ///< composited radiance arriving along the cone
        double opacity = 0;       ///< accumulated opacity (1 − visibility)
        double occlusion = 0;     ///< ambient occlusion, eq. 4
    };
    /// @p aoLambda: eq. 4's λ, per root-cube edge of cone radius. @p opacityOnly skips radiance
    /// (shadow cones).
    [[nodiscard]] ConeResult traceCone(const Cone& cone, double aoLambda,
                                       bool opacityOnly = false) const;

    /// The diffuse gather's cones over the hemisphere of a normal n with tangent frame (t, b):
    /// one along n and kRing tilted from it, cone i along
    /// n·cosTilt + (t·cosAzimuth[i] + b·sinAzimuth[i])·sinTilt, all of half-angle tangent
    /// tanHalf. The weights are the cones' cosine-weighted solid angles, scaled so that
    /// centreWeight + kRing·ringWeight = π.
    struct DiffuseCones {
        static constexpr std::size_t kRing = 6;
        double tanHalf = 0;
        double cosTilt = 0, sinTilt = 0;
        double cosAzimuth[kRing] = {}, sinAzimuth[kRing] = {};
        double centreWeight = 0, ringWeight = 0;

        /// The cones' unit axes about unit @p normal: index 0 along it, 1 … kRing the ring, with
        /// the tangent t = normalize(cross(h, n)), h = (1, 0, 0) where |n_x| < 0.9, else
        /// (0, 1, 0), and b = n × t.
        [[nodiscard]] std::array<Vec3d, kRing + 1> axes(Vec3d normal) const;
        /// Cone @p i's weight: centreWeight for 0, else ringWeight.
        [[nodiscard]] double weight(std::size_t i) const noexcept {
            return i == 0 ? centreWeight : ringWeight;
        }
    };
    [[nodiscard]] static const DiffuseCones& diffuseCones() noexcept;

    /// Diffuse irradiance at a surface point: the diffuseCones() along their axes() about
    /// @p normal, so that uniform radiance L gives π·L.
    /// @p offset: world distance the cones start off the surface, along the normal; no sample
    /// filters behind a plane one level-0 cell above @p point (Cone::planePoint).
    struct Gather {
        Vec3d irradiance{0, 0, 0};
        double occlusion = 0;  ///< cosine-weighted mean of the cones' eq. 4 occlusion
    };
    [[nodiscard]] Gather gatherDiffuse(Vec3d point, Vec3d normal, double offset,
                                       double aoLambda) const;

    /// The texels of cell (x, y, z) of @p level (channel c at offset c·rvol::kBlockTexels), or null
    /// where no block holds it. Coordinates must be inside the level; a field over a Volume only.
    [[nodiscard]] const rvol::Texel* cellTexels(std::uint32_t level, std::uint32_t x,
                                                std::uint32_t y, std::uint32_t z) const noexcept;

    /// Cell edge of level 0, world units.
    [[nodiscard]] double finestCell() const noexcept { return finestCell_; }

    /// Makes cones reach beyond this volume: a sample whose filter (the two cells per axis it
    /// reads at the upper of its two levels) leaves the box [@p nearLo, @p nearHi] (world) reads
    /// @p far instead, at the level of
    /// the same footprint (never below far's level 0), and cones end, and ambient occlusion is
    /// scaled, by far's root cube. @p far must cover this volume, with a finest cell 2^k times
    /// this one's (k ≥ 0), and outlive this field; null detaches it. A field over a Volume only
    /// (a sampler of a tiled volume reads its own far field).
    void setFarField(const RadianceField* far, Vec3d nearLo, Vec3d nearHi) noexcept;

private:
    struct LevelIndex {
        std::uint32_t blocksPerAxis = 1;
        std::vector<std::int32_t> blocks;  ///< dense: block index in the level, or -1

        /// The index in the level of the block holding cell (x, y, z), or -1.
        [[nodiscard]] std::int32_t blockOf(std::uint32_t x, std::uint32_t y,
                                           std::uint32_t z) const noexcept {
            return blocks[(std::size_t{z / rvol::kBlockCells} * blocksPerAxis +
                           y / rvol::kBlockCells) *
                              blocksPerAxis +
                          x / rvol::kBlockCells];
        }
    };
    /// sampleLod here or, where the sample's filter leaves the near box, in the far field.
    [[nodiscard]] rvol::Texel sampleNearOrFar(double level, Vec3d p, Vec3d dir) const;

    const rvol::Volume* volume_ = nullptr;        // either this
    const rvol::RvolSampler* sampler_ = nullptr;  // or this
    std::vector<LevelIndex> index_;
    Vec3d origin_{0, 0, 0};
    double size_ = 1;
    std::uint32_t depth_ = 0;
    double finestCell_ = 1;
    const RadianceField* far_ = nullptr;
    Vec3d nearLo_{0, 0, 0}, nearHi_{0, 0, 0};
    double farLevelOffset_ = 0;  ///< log2(far's finest cell / this one's)
};

}  // namespace vox
