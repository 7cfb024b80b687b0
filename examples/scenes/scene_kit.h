// Small helpers shared by the many-light example scenes (corridor, light grid, city block): a
// portable seeded random generator, merged box geometry, light definitions shared between nodes,
// and number rounding so that the written JSON is short and the same on every run.
#pragma once

#include "gltf_builder.h"

#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <span>
#include <string>

namespace vox::scenes {

/// splitmix64: the same sequence on every platform and standard library (unlike the
/// <random> distributions), so that a fixed seed gives the same scene bytes everywhere.
class SceneRng {
public:
    explicit SceneRng(std::uint64_t seed) : state_(seed) {}
    std::uint64_t next() {
        std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        return z ^ (z >> 31);
    }
    /// An integer in [0, n) (n > 0).
    int below(int n) { return static_cast<int>(next() % static_cast<std::uint64_t>(n)); }
    /// lo + step · k for k uniform in [0, steps): values that print exactly.
    double steps(double lo, double step, int steps) { return lo + step * below(steps); }
    template <class T>
    const T& pick(std::span<const T> values) {
        return values[static_cast<std::size_t>(below(static_cast<int>(values.size())))];
    }

private:
    std::uint64_t state_;
};

/// @p value rounded to multiples of @p step (1 cm by default), without a negative zero.
[[nodiscard]] inline double quantize(double value, double step = 0.01) {
    return std::round(value / step) * step + 0.0;
}
[[nodiscard]] inline float quantizef(double value, double step = 0.01) {
    return static_cast<float>(quantize(value, step));
}

/// Appends an axis-aligned box (boxPrimitive's 24 vertices, 12 triangles) to @p primitive.
void appendBox(GltfBuilder::Primitive& primitive, std::array<float, 3> min,
               std::array<float, 3> max);

/// Light definitions keyed by name: nodes that use the same definition share one entry of the
/// KHR_lights_punctual light list (thousands of lights, a few dozen definitions).
class LightPalette {
public:
    explicit LightPalette(GltfBuilder& gltf) : gltf_(gltf) {}
    /// The index of @p light, added on first use. Definitions must differ by name.
    int operator()(const GltfBuilder::LightDesc& light);

private:
    GltfBuilder& gltf_;
    std::map<std::string, int> indices_;
};

/// Quaternion (x, y, z, w) of the rotation that turns -Z (glTF's light direction) straight down.
[[nodiscard]] inline std::array<double, 4> pointingDown() {
    const double s = std::sqrt(0.5);
    return {-s, 0.0, 0.0, s};
}

/// ∛100: a lamp at height h above a floor lights the floor at distance d with I·h/d³ (cosine
/// law), 1 % of its peak I/h² straight below where d = ∛100 · h.
inline constexpr double kCubeRootOf100 = 4.641588833612779;

}  // namespace vox::scenes
