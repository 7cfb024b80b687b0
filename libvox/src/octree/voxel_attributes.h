// Shading attributes of voxels (Laine & Karras 5.4, and the original builder): each voxel's colour
// and normal are the area-weighted means over the triangle fragments its cube cuts out. Colour is
// base colour factor × base colour texture × vertex colour, the texture box-filtered exactly over
// each fragment (Texture::integrate); the normal is the interpolated shading normal, bent by the
// normal map.
// A parent's sums are exactly the sums of its children's (the children's cubes partition its
// fragments), so only the voxels where refinement stops filter theirs.
#pragma once

#include "../scene/surface_shading.h"
#include "triangle_box.h"

#include <vox/scene.h>

#include <array>
#include <cstdint>
#include <cstring>
#include <span>
#include <vector>

namespace vox::detail {

/// Area-weighted sums over fragments. Weights are fragment areas in leaf units², plus a tiny
/// term so that a voxel whose fragments all have zero area (a triangle touching its boundary)
/// still gets their attributes.
struct AttributeSums {
    double weight = 0;
    Vec3d color{0, 0, 0};     ///< linear RGB × weight
    double alpha = 0;         ///< × weight
    Vec3d normal{0, 0, 0};    ///< unit shading normal × weight
    Vec3d emission{0, 0, 0};  ///< linear emitted radiance × weight
    /// What the normal-weighted attenuation (vox::Attenuation::Weighted, lighting.h) needs of the
    /// normals: per axis direction (+x, −x, +y, −y, +z, −z), the sum of weight × |n_s| over
    /// fragments whose normal points that way.
    std::array<double, 6> normalMoments{};
    /// The heaviest fragment's normal: the fallback where opposite normals cancel in the mean.
    Vec3d dominantNormal{0, 0, 1};
    double dominantWeight = -1;
    /// With AttributeSampler's error moments (0 otherwise): Σ weight × the variance of the
    /// interpolated shading normal within each fragment (radians²), and per channel Σ weight ×
    /// (linear colour² + the texture's variance within the fragment). What error() reads.
    double normalSpread = 0;
    Vec3d colorSquares{0, 0, 0};
    /// With error moments: Σ weight over fragments of flat-shaded triangles at least as large as
    /// the voxel's face (facets, whose edges are creases at the voxel's scale).
    double facetWeight = 0;

    AttributeSums& operator+=(const AttributeSums& other) {  // inline: once per voxel
        weight += other.weight;
        color += other.color;
        alpha += other.alpha;
        normal += other.normal;
        emission += other.emission;
        for (std::size_t i = 0; i < normalMoments.size(); ++i)
            normalMoments[i] += other.normalMoments[i];
        if (other.dominantWeight > dominantWeight) {
            dominantWeight = other.dominantWeight;
            dominantNormal = other.dominantNormal;
        }
        normalSpread += other.normalSpread;
        colorSquares += other.colorSquares;
        facetWeight += other.facetWeight;
        return *this;
    }
    /// The voxel's attribute word pair: esvo::packColor (sRGB) | esvo::encodeNormal << 32.
    [[nodiscard]] std::uint64_t pack() const;

    /// How well one colour and one normal stand for the surface inside the voxel (from the error
    /// moments): the root-mean-square deviation over its area from the mean colour, in 8-bit
    /// sRGB steps (each channel's linear deviation times the sRGB curve's slope at the mean,
    /// averaged over the three channels), and from the mean normal, in degrees. The normal's is 0
    /// where facets (facetWeight) make up more than half the surface.
    struct Error {
        double color = 0;
        double normalDegrees = 0;
    };
    [[nodiscard]] Error error() const;
};

/// Sets @p sums to AttributeSums{} (a fixed-size copy: vector stores, where the default
/// constructor's zeroing compiles to a slow-starting rep stos).
inline void clear(AttributeSums& sums) {
    static constexpr AttributeSums kEmpty{};
    std::memcpy(static_cast<void*>(&sums), &kEmpty, sizeof sums);
}

/// Reusable buffers (one per thread).
struct AttributeScratch {
    CubeFragments fragments;
    std::vector<Vec3d> barycentrics;  ///< of the polygon's vertices
};

/// Triangles the sampler is handed by index: entry i of @p triangles (leaf units) is the
/// sampler's triangle global[i]. Empty: the sampler's own triangles.
struct TriangleView {
    const BoxTestTriangle* triangles = nullptr;
    const std::uint32_t* global = nullptr;
};

/// Evaluates materials over fragments: linear attributes at their centroids, textures over their
/// area.
class AttributeSampler {
public:
    /// @p triangles are in leaf units and @p sources says where each came from. With
    /// @p errorMoments, filter also sums what AttributeSums::error() reads.
    AttributeSampler(const Scene& scene, const std::vector<BoxTestTriangle>& triangles,
                     std::vector<TriangleSource> sources, bool errorMoments = false);

    /// Sums over the fragments of the triangles @p list inside the cube with centre @p c and
    /// half-extent @p h (leaf units).
    /// @p view: where the indices of @p list point (default: this sampler's triangles).
    [[nodiscard]] AttributeSums filter(std::span<const std::uint32_t> list, Vec3d c, double h,
                                       AttributeScratch& scratch, TriangleView view = {}) const;
    /// filter on the fragments of @p list in that cube, in its local frame (CubeFragments::clip at
    /// scale filterScale(h) gives the same sums, or a parent's CubeFragments::splitInto).
    /// @p errorMoments: false leaves the error moments (normalSpread, colorSquares, facetWeight)
    /// 0 even where the sampler sums them; every other field is the same.
    [[nodiscard]] AttributeSums filter(const CubeFragments& fragments,
                                       std::span<const std::uint32_t> list, Vec3d c, double h,
                                       AttributeScratch& scratch, TriangleView view = {},
                                       bool errorMoments = true) const;
    /// The scale from leaf units to the local frame of a cube of half-extent @p h that filter clips
    /// in.
    [[nodiscard]] static double filterScale(double h) { return 1.0 / (2 * h); }

private:
    /// @p view with its defaults filled in.
    [[nodiscard]] TriangleView resolve(TriangleView view) const {
        return {view.triangles ? view.triangles : triangles_.data(), view.global};
    }

    const Scene& scene_;
    const std::vector<BoxTestTriangle>& triangles_;
    std::vector<TriangleSource> sources_;
    std::vector<std::uint8_t> textured_;  ///< per mesh: its material has a texture
    bool errorMoments_ = false;
};

}  // namespace vox::detail
