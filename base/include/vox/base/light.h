/// @file light.h
/// @brief A punctual light as glTF's KHR_lights_punctual describes it: the one light description
/// the importers, the radiance bake and the GPU final gather share.
#pragma once

#include <vox/base/math.h>

#include <cstdint>

namespace vox {

struct PunctualLight {
    enum class Type : std::uint8_t { Directional = 0, Point = 1, Spot = 2 };
    Type type = Type::Point;
    Vec3f color{1, 1, 1};                ///< linear
    float intensity = 1.0f;              ///< candela (point, spot) or lux (directional)
    float range = 0.0f;                  ///< cut-off distance; 0 = unlimited
    float innerConeAngle = 0.0f;         ///< radians (spot)
    float outerConeAngle = 0.78539816f;  ///< radians (spot)
    Vec3f position{0, 0, 0};             ///< world (point, spot)
    Vec3f direction{0, 0, -1};           ///< world, unit, the way light travels (directional, spot)
};

}  // namespace vox
