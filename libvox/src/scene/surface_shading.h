// The material of a point on a scene triangle: what the voxel attribute filter averages and what
// the triangle reference renderer shows, from one function so the two cannot disagree.
#pragma once

#include <vox/math.h>
#include <vox/scene.h>

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
    Vec4f color{1, 1, 1, 1};  ///< linear RGBA: base colour factor × base colour texture × vertex colour
    Vec3d normal{0, 0, 1};    ///< unit shading normal: interpolated, bent by the normal map
    Vec3f emission{0, 0, 0};  ///< linear emitted radiance: emissive factor × strength × emissive texture
};

/// Shades triangle @p source of @p scene at barycentric coordinates @p b (weights of its three
/// corners). @p corners are its positions in any frame that is a uniform scale and translation of
/// world space; @p footprint, in that frame's length unit, is the width textures are filtered
/// over (0: the finest mip level). With @p fragment (the barycentric coordinates of a convex
/// polygon's vertices, @p b its centroid), textures are instead box-filtered over that polygon
/// exactly (Texture::integrate): a fragment's mean, not a blur centred on it.
[[nodiscard]] SurfaceSample shadeTriangle(const Scene& scene, TriangleSource source, const std::array<Vec3d, 3>& corners, Vec3d b,
                                          double footprint, std::span<const Vec3d> fragment = {});

/// esvo::packColor word of a linear RGBA colour: RGB sRGB-encoded, alpha linear, clamped to [0, 1]
/// and rounded to 8 bits.
[[nodiscard]] std::uint32_t packLinearColor(Vec4f color);

/// Barycentric coordinates of the point of triangle @p corners nearest to @p p's projection onto
/// its plane, clamped into the triangle.
[[nodiscard]] Vec3d barycentric(const std::array<Vec3d, 3>& corners, Vec3d p);

}  // namespace vox::detail
