/// @file lighting.h
/// @brief Punctual lights after KHR_lights_punctual: how much light reaches a point, before
/// visibility and the surface's cosine. One definition for the radiance bake, the renderers and
/// the path-traced reference, so that they light the same scene.
#pragma once

#include <vox/base/math.h>
#include <vox/scene.h>

#include <array>
#include <cstdint>
#include <limits>

namespace vox {

/// Light arriving at a point from one punctual light.
struct LightArrival {
    Vec3d toLight{0, 0, 1};  ///< unit, from the point towards the light (directional: −direction)
    double distance =
        std::numeric_limits<double>::infinity();  ///< to the light; +inf for directional
    /// Irradiance on a surface facing the light (lux for glTF's units): colour × intensity ×
    /// inverse-square falloff × range window × spot cone falloff.
    Vec3d irradiance{0, 0, 0};
};

/// Evaluates @p light at @p point (world units). Point and spot lights: intensity / d², times
/// KHR_lights_punctual's recommended range window clamp(1 − (d/range)⁴, 0, 1)² where a range is
/// given, and for spots the smooth falloff between the inner and outer cone
/// (clamp((cos θ − cos outer) / (cos inner − cos outer), 0, 1)²). Directional lights: intensity,
/// from −direction. Returns false where the light cannot reach the point (out of range or cone,
/// or at its position); @p out is then unspecified.
[[nodiscard]] bool lightArrival(const Light& light, Vec3d point, LightArrival& out);

/// How a voxel's direct light is attenuated by the normals inside it.
enum class Attenuation : std::uint8_t {
    /// Per axis, as in Gui et al. 2019 eq. 2, but weighted by the surface's own normals: for each
    /// axis direction (+x, −x, +y, −y, +z, −z) the area share w of |n_s| over the fragments whose
    /// normals point that way, and V = Σ_s w_s± · max(±L_s, 0). For a flat voxel this is exactly
    /// n·L wherever L lies in n's octant; where a voxel holds both sides of a thin wall, the side
    /// facing the light still receives it instead of a cancelled mean normal deciding.
    Weighted,
    /// Eq. 2 as printed: V = Σ_s n_s² · max(sign(n_s) L_s, 0) on the unit mean normal n. It
    /// underestimates tilted surfaces (n = L = (1,1,1)/√3 gives 0.577 instead of 1).
    Paper,
    /// max(n·L, 0) on the unit mean normal.
    Average,
    /// Average where the voxel's surface is flat, Weighted where it folds. With m = Σ_s (w_s+ −
    /// w_s−) e_s the fragments' area-weighted mean normal (|m| = 1 for a plane, less where the
    /// normals spread or cancel) and the flat share t = clamp((|m| − 0.9) / 0.09, 0, 1):
    /// V = t · max(m̂·L, 0) + (1 − t) · Weighted's V, m̂ = m / |m|. Exact for a plane whatever L
    /// (where Weighted over-lights L outside n's octant) and for faces along the axes (a box's
    /// edges, a thin wall's two sides, where Average under-lights one face).
    Adaptive,
};

/// What the attenuation of one voxel needs of its normals.
struct VoxelNormals {
    Vec3f mean{0, 0, 1};  ///< unit area-weighted mean normal
    std::array<float, 6>
        moments{};  ///< area shares of |n_s| per axis direction (Attenuation::Weighted)
};

/// Attenuation::Adaptive's parts of @p normals: the area-weighted mean normal m (not unit) and the
/// flat share t ∈ [0, 1].
struct AdaptiveAttenuation {
    Vec3d mean{0, 0, 0};
    double flat = 0;
};
[[nodiscard]] AdaptiveAttenuation adaptiveAttenuation(const VoxelNormals& normals);

/// The attenuation V ∈ [0, √3] of light arriving from unit direction @p toLight.
[[nodiscard]] double attenuate(Attenuation mode, const VoxelNormals& normals, Vec3d toLight);

}  // namespace vox
