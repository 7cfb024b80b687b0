// The material of a point on a scene triangle: what the voxel attribute filter averages and what
// the triangle reference renderer shows, from one function so the two cannot disagree.
#pragma once

#include <vox/base/math.h>
#include <vox/scene.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <span>

namespace vox::detail {

/// Where a triangle came from: mesh index and triangle index within the mesh.
struct TriangleSource {
    std::uint32_t mesh = 0;
    std::uint32_t triangle = 0;
};

/// A shaded surface point.
struct SurfaceSample {
    Vec4f color{1, 1, 1,
                1};  ///< linear RGBA: base colour factor × base colour texture × vertex colour
    Vec3d normal{0, 0, 1};  ///< unit shading normal: interpolated, bent by the normal map
    Vec3f emission{0, 0,
                   0};  ///< linear emitted radiance: emissive factor × strength × emissive texture
};

/// Shades triangle @p source of @p scene at barycentric coordinates @p b (weights of its three
/// corners). @p corners are its positions in any frame that is a uniform scale and translation of
/// world space; @p footprint, in that frame's length unit, is the width textures are filtered
/// over (0: the finest mip level). With @p fragment (the barycentric coordinates of a convex
/// polygon's vertices, @p b its centroid), textures are instead box-filtered over that polygon
/// exactly (Texture::integrate): a fragment's mean, not a blur centred on it.
/// @p colorVariance: null, or receives the variance of the base colour (linear RGB) over the
/// fragment that its texture contributes (0 without a fragment or a texture).
[[nodiscard]] SurfaceSample shadeTriangle(const Scene& scene, TriangleSource source,
                                          const std::array<Vec3d, 3>& corners, Vec3d b,
                                          double footprint, std::span<const Vec3d> fragment = {},
                                          Vec3f* colorVariance = nullptr);

/// esvo::packColor word of a linear RGBA colour: RGB sRGB-encoded, alpha linear, clamped to [0, 1]
/// and rounded to 8 bits.
[[nodiscard]] std::uint32_t packLinearColor(Vec4f color);

/// barycentric() for many points of one triangle: what depends on the triangle alone (its edges
/// and their dot products) computed once, the rest per point exactly as barycentric does it.
class BarycentricFrame {
public:
    explicit BarycentricFrame(const std::array<Vec3d, 3>& corners)
        : origin_(corners[0]),
          e1_(corners[1] - corners[0]),
          e2_(corners[2] - corners[0]),
          d00_(dot(e1_, e1_)),
          d01_(dot(e1_, e2_)),
          d11_(dot(e2_, e2_)),
          denom_(d00_ * d11_ - d01_ * d01_) {}

    /// The coordinates of @p p (see barycentric).
    [[nodiscard]] Vec3d operator()(Vec3d p) const {
        if (!(denom_ > 0)) return {1.0 / 3, 1.0 / 3, 1.0 / 3};
        const Vec3d vp = p - origin_;
        const double d20 = dot(vp, e1_), d21 = dot(vp, e2_);
        const double b1 = std::clamp((d11_ * d20 - d01_ * d21) / denom_, 0.0, 1.0);
        const double b2 = std::clamp((d00_ * d21 - d01_ * d20) / denom_, 0.0, 1.0 - b1);
        return {1 - b1 - b2, b1, b2};
    }

    /// The same coordinates up to rounding, for the many points of a fragment's polygon (a
    /// texture's footprint): they are linear in the point, so two dot products with their
    /// gradients instead of two divisions each; clamped alike.
    class Linear {
    public:
        [[nodiscard]] Vec3d operator()(Vec3d p) const {
            if (!valid_) return {1.0 / 3, 1.0 / 3, 1.0 / 3};
            const Vec3d vp = p - origin_;
            const double b1 = std::clamp(dot(vp, gradient1_), 0.0, 1.0);
            const double b2 = std::clamp(dot(vp, gradient2_), 0.0, 1.0 - b1);
            return {1 - b1 - b2, b1, b2};
        }

    private:
        friend class BarycentricFrame;
        Vec3d origin_, gradient1_, gradient2_;  // gradients of the second and third coordinates
        bool valid_;
    };
    [[nodiscard]] Linear linear() const {
        Linear out;
        out.origin_ = origin_;
        out.valid_ = denom_ > 0;
        const double inverse = out.valid_ ? 1.0 / denom_ : 0.0;
        out.gradient1_ = (e1_ * d11_ - e2_ * d01_) * inverse;
        out.gradient2_ = (e2_ * d00_ - e1_ * d01_) * inverse;
        return out;
    }

private:
    Vec3d origin_, e1_, e2_;
    double d00_, d01_, d11_, denom_;
};

/// Barycentric coordinates of the point of triangle @p corners nearest to @p p's projection onto
/// its plane, clamped into the triangle.
[[nodiscard]] inline Vec3d barycentric(const std::array<Vec3d, 3>& corners, Vec3d p) {
    return BarycentricFrame(corners)(p);
}

}  // namespace vox::detail
