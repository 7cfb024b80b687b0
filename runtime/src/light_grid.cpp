#include "light_grid.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace vox::runtime::detail {
namespace {

/// A light whose range sphere bounds where it reaches (lightArrival returns false at or beyond
/// the range); every other light may reach everywhere.
bool hasSphere(const PunctualLight& l) {
    return l.type != PunctualLight::Type::Directional && l.range > 0 && std::isfinite(l.range) &&
           std::isfinite(l.position.x) && std::isfinite(l.position.y) &&
           std::isfinite(l.position.z);
}

struct Layout {
    std::array<double, 3> origin{}, cellSize{};
    std::array<double, 3> margin{};  ///< how far the shader's rounding can move a point, per axis
    std::array<std::uint32_t, 3> cells{1, 1, 1};

    std::uint64_t count() const { return std::uint64_t{cells[0]} * cells[1] * cells[2]; }

    /// Calls @p visit(cell index) for every cell the light may reach, in increasing index order.
    template <typename Visit>
    void forEachCell(const PunctualLight& l, Visit&& visit) const {
        if (!hasSphere(l)) {
            for (std::uint64_t c = 0; c < count(); ++c) visit(c);
            return;
        }
        const double r = double(l.range) * (1 + 1e-4);
        const std::array<double, 3> centre{l.position.x, l.position.y, l.position.z};
        std::array<std::uint32_t, 3> first{}, last{};
        for (int a = 0; a < 3; ++a) {
            const double lo = std::floor((centre[a] - r - margin[a] - origin[a]) / cellSize[a]);
            const double hi = std::floor((centre[a] + r + margin[a] - origin[a]) / cellSize[a]);
            if (hi < 0 || lo > double(cells[a] - 1)) return;
            first[a] = static_cast<std::uint32_t>(std::max(lo, 0.0));
            last[a] = static_cast<std::uint32_t>(std::min(hi, double(cells[a] - 1)));
        }
        for (std::uint32_t z = first[2]; z <= last[2]; ++z)
            for (std::uint32_t y = first[1]; y <= last[1]; ++y)
                for (std::uint32_t x = first[0]; x <= last[0]; ++x) {
                    const std::uint32_t i[3] = {x, y, z};
                    double d2 = 0;
                    for (int a = 0; a < 3; ++a) {
                        const double lo = origin[a] + i[a] * cellSize[a] - margin[a];
                        const double hi = origin[a] + (i[a] + 1) * cellSize[a] + margin[a];
                        const double d = std::max({lo - centre[a], 0.0, centre[a] - hi});
                        d2 += d * d;
                    }
                    if (d2 < r * r) visit((std::uint64_t{z} * cells[1] + y) * cells[0] + x);
                }
    }
};

}  // namespace

std::uint32_t LightGrid::cellOf(Vec3f p) const noexcept {
    std::uint32_t index[3];
    for (int a = 0; a < 3; ++a) {
        const float f = std::floor((p[a] - origin[a]) * inverseCell[a]);
        // NaN compares false both ways: cell 0.
        index[a] = f > 0 ? static_cast<std::uint32_t>(std::min(f, float(cells[a] - 1))) : 0;
    }
    return (index[2] * cells[1] + index[1]) * cells[0] + index[0];
}

LightGrid buildLightGrid(std::span<const Vec3f> points, std::span<const PunctualLight> lights,
                         std::uint32_t maxCellsPerAxis, std::uint64_t maxEntries) {
    LightGrid grid;
    const auto n = static_cast<std::uint32_t>(lights.size());
    Bounds3f bounds;
    for (const Vec3f& p : points)
        if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)) bounds.add(p);
    std::vector<float> ranges;
    for (const PunctualLight& l : lights)
        if (hasSphere(l)) ranges.push_back(l.range);
    if (bounds.empty() || ranges.empty()) {
        grid.cellRanges = {{0, n}};
        grid.lightList.resize(n);
        std::iota(grid.lightList.begin(), grid.lightList.end(), 0u);
        return grid;
    }
    // Cells about a typical light's range: a light then meets a few cells per axis, and a cell
    // lists about the lights whose spheres reach into it.
    std::nth_element(ranges.begin(), ranges.begin() + ranges.size() / 2, ranges.end());
    double cell = ranges[ranges.size() / 2];
    Layout layout;
    std::vector<std::uint32_t> counts;
    for (;;) {
        for (int a = 0; a < 3; ++a) {
            const double extent = double(bounds.max[a]) - double(bounds.min[a]);
            layout.cells[a] = static_cast<std::uint32_t>(
                std::clamp(std::ceil(extent / cell), 1.0, double(std::max(maxCellsPerAxis, 1u))));
            layout.cellSize[a] = extent > 0 ? extent / layout.cells[a] : 1.0;
            layout.origin[a] = bounds.min[a];
            // The cell's box grown by a thousandth of a cell and by a few float steps of the
            // coordinates: a point the shader's float arithmetic puts in a cell lies within it.
            const double magnitude = std::max(std::abs(double(bounds.min[a])),
                                              std::abs(double(bounds.max[a])));
            layout.margin[a] = 1e-3 * layout.cellSize[a] + 8 * 0x1p-23 * magnitude;
        }
        counts.assign(layout.count(), 0);
        std::uint64_t entries = 0;
        for (const PunctualLight& l : lights)
            layout.forEachCell(l, [&](std::uint64_t c) {
                ++counts[c];
                ++entries;
            });
        if (entries <= maxEntries || layout.count() == 1) break;
        cell *= 2;
    }
    grid.cells = layout.cells;
    for (int a = 0; a < 3; ++a) {
        grid.origin[a] = static_cast<float>(layout.origin[a]);
        grid.inverseCell[a] = static_cast<float>(1 / layout.cellSize[a]);
    }
    grid.cellRanges.resize(counts.size());
    std::uint32_t next = 0;
    for (std::size_t c = 0; c < counts.size(); ++c) {
        grid.cellRanges[c] = {next, counts[c]};
        next += counts[c];
    }
    grid.lightList.resize(next);
    std::vector<std::uint32_t> fill(counts.size(), 0);
    for (std::uint32_t i = 0; i < n; ++i)
        layout.forEachCell(lights[i], [&](std::uint64_t c) {
            grid.lightList[grid.cellRanges[c][0] + fill[c]++] = i;
        });
    return grid;
}

}  // namespace vox::runtime::detail
