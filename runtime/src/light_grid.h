// A uniform grid over the shading points whose cells list the lights that can reach them: the
// final gather's shader loops over its cell's list instead of over every light, so a scene of
// thousands of ranged lights costs each point only the lights in range.
#pragma once

#include <vox/base/light.h>
#include <vox/base/math.h>

#include <array>
#include <cstdint>
#include <span>
#include <vector>

namespace vox::runtime::detail {

struct LightGrid {
    std::array<float, 3> origin{0, 0, 0};
    std::array<float, 3> inverseCell{0, 0, 0};  ///< cells per world unit, per axis
    std::array<std::uint32_t, 3> cells{1, 1, 1};
    /// Per cell (x fastest), its first entry in lightList and its count.
    std::vector<std::array<std::uint32_t, 2>> cellRanges;
    /// Light indices, each cell's in increasing order (the order the lights are summed in
    /// without a grid, so that the sums are the same).
    std::vector<std::uint32_t> lightList;

    /// The cell of @p p as the shader finds it (floor, clamped to the grid).
    [[nodiscard]] std::uint32_t cellOf(Vec3f p) const noexcept;
};

/// The grid over @p points (the positions shaded). A cell lists every light that can reach a
/// point of the cell's box grown by a thousandth of a cell and a few float steps of the
/// coordinates (so that rounding in the shader's cell lookup cannot leave a light out): directional lights and lights without a range
/// everywhere, point and spot lights where their range sphere meets the box. Cells are about the
/// ranged lights' median range, at most @p maxCellsPerAxis per axis, and coarsened while the
/// lists would exceed @p maxEntries; with no ranged light it is one cell listing every light.
[[nodiscard]] LightGrid buildLightGrid(std::span<const Vec3f> points,
                                       std::span<const PunctualLight> lights,
                                       std::uint32_t maxCellsPerAxis = 64,
                                       std::uint64_t maxEntries = std::uint64_t{1} << 23);

}  // namespace vox::runtime::detail
