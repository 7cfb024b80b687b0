// Scenes built in code for the lighting tests: materials, quads and boxes with exact normals.
#pragma once

#include <vox/base/math.h>
#include <vox/scene.h>

#include <cstdint>

namespace vox::test {

/// Appends an opaque material with linear @p albedo and emitted radiance @p emission.
std::uint32_t addMaterial(Scene& scene, Vec3f albedo, Vec3f emission = {0, 0, 0});

/// The parallelogram corner, corner + u, corner + u + v, corner + v as two triangles whose front
/// (counter-clockwise, and the vertex normals) faces u × v.
void addQuad(Scene& scene, Vec3d corner, Vec3d u, Vec3d v, std::uint32_t material);

/// The six faces of the box [lo, hi], fronts facing out (@p inward: in).
void addBox(Scene& scene, Vec3d lo, Vec3d hi, std::uint32_t material, bool inward = false);

}  // namespace vox::test
