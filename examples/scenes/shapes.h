// Triangle shapes for example and test scenes, as glTF primitives (positions, normals, UVs,
// indices).
#pragma once

#include "gltf_builder.h"

namespace vox::scenes {

/// An axis-aligned box with per-face normals and UVs (24 vertices, 12 triangles).
[[nodiscard]] GltfBuilder::Primitive boxPrimitive(std::array<float, 3> min,
                                                  std::array<float, 3> max, int material);
/// A latitude/longitude sphere around the origin with smooth normals and UVs.
[[nodiscard]] GltfBuilder::Primitive spherePrimitive(float radius, int rings, int segments,
                                                     int material);
/// Quaternion (x, y, z, w) that turns -Z (where glTF lights and cameras point) towards @p
/// direction.
[[nodiscard]] std::array<double, 4> rotationFromMinusZ(std::array<double, 3> direction);

}  // namespace vox::scenes
