/// @file color.h
/// @brief sRGB transfer functions and the headlight shading every renderer shares.
#pragma once

#include <vox/base/math.h>

#include <cstdint>

namespace vox {

/// sRGB-encoded value in [0, 1] to linear, and back (IEC 61966-2-1).
[[nodiscard]] float srgbToLinear(float value);
[[nodiscard]] float linearToSrgb(float value);
/// The slope of linearToSrgb at a linear value (12.92 up to its linear segment's end).
[[nodiscard]] double linearToSrgbSlope(double value);
/// The 8-bit sRGB code of a linear value: exactly lround(255 · linearToSrgb(clamp(value, 0, 1))),
/// by table instead of a pow (what packing a voxel's mean colour costs).
[[nodiscard]] std::uint8_t srgbCode(float value);

/// Phong under a headlight: ambient 0.1, diffuse 0.9 × @p albedo, specular 0.25 at exponent 32,
/// with the light at the eye. @p normal and @p toEye are unit; a normal facing away from the eye
/// is turned round (a sheet seen from behind shades like its front). Linear RGB.
[[nodiscard]] Vec3f shadeHeadlight(Vec3f normal, Vec3f toEye, Vec3f albedo);

}  // namespace vox
