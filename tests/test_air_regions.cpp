// The air regions of the radiance bake (libvox/src/radiance/air_regions.h) against a flood fill
// from seeds in scan order, the definition: the same label for every cell of random rooms and
// walls, with and without a box limit, and the label cap.
#include "radiance/air_regions.h"

#include <gtest/gtest.h>

#include <random>

using vox::detail::AirRegions;
using vox::detail::SolidGrid;

namespace {

/// Labels by depth-first flood fill from each unlabelled empty cell in scan order.
std::vector<std::uint16_t> floodFill(const SolidGrid& solid, std::uint32_t depth,
                                     std::array<std::int64_t, 3> lo,
                                     std::array<std::int64_t, 3> hi, std::uint32_t& count) {
    const std::size_t r = std::size_t{1} << depth;
    std::vector<std::uint16_t> labels(r * r * r, AirRegions::kNone);
    for (std::size_t z = 0; z < r; ++z)
        for (std::size_t y = 0; y < r; ++y)
            for (std::size_t x = 0; x < r; ++x) {
                const std::int64_t c[3] = {std::int64_t(x), std::int64_t(y), std::int64_t(z)};
                bool outside = false;
                for (int a = 0; a < 3; ++a) outside = outside || c[a] < lo[a] || c[a] >= hi[a];
                if (outside || solid.solid(c[0], c[1], c[2]))
                    labels[(z * r + y) * r + x] = AirRegions::kSolid;
            }
    count = 0;
    std::vector<std::size_t> stack;
    for (std::size_t seed = 0; seed < labels.size(); ++seed) {
        if (labels[seed] != AirRegions::kNone) continue;
        if (count >= AirRegions::kNone) break;
        const auto region = static_cast<std::uint16_t>(count++);
        labels[seed] = region;
        stack.push_back(seed);
        while (!stack.empty()) {
            const std::size_t i = stack.back();
            stack.pop_back();
            const std::size_t x = i % r, y = (i / r) % r, z = i / (r * r);
            for (const auto& [ok, j] : {std::pair{x > 0, i - 1}, std::pair{x + 1 < r, i + 1},
                                       std::pair{y > 0, i - r}, std::pair{y + 1 < r, i + r},
                                       std::pair{z > 0, i - r * r},
                                       std::pair{z + 1 < r, i + r * r}})
                if (ok && labels[j] == AirRegions::kNone) {
                    labels[j] = region;
                    stack.push_back(j);
                }
        }
    }
    return labels;
}

void expectSameAsFloodFill(const std::vector<std::array<std::uint32_t, 3>>& cells,
                           std::uint32_t depth, std::array<std::int64_t, 3> lo = {},
                           std::array<std::int64_t, 3> hi = {AirRegions::kNoLimit,
                                                             AirRegions::kNoLimit,
                                                             AirRegions::kNoLimit}) {
    const SolidGrid solid(depth, cells);
    const AirRegions regions(solid, depth, lo, hi);
    std::uint32_t count = 0;
    const std::vector<std::uint16_t> expected = floodFill(solid, depth, lo, hi, count);
    EXPECT_EQ(regions.count(), count);
    const std::int64_t r = std::int64_t{1} << depth;
    std::size_t differ = 0;
    for (std::int64_t z = 0; z < r; ++z)
        for (std::int64_t y = 0; y < r; ++y)
            for (std::int64_t x = 0; x < r; ++x)
                differ += regions.label(x, y, z) != expected[std::size_t((z * r + y) * r + x)];
    EXPECT_EQ(differ, 0u);
}

/// Closed boxes (rooms, some with a door), slabs and random solid cells in a 2^depth grid.
std::vector<std::array<std::uint32_t, 3>> rooms(std::uint32_t depth, unsigned seed) {
    const std::uint32_t r = 1u << depth;
    std::mt19937 rng(seed);
    std::uniform_int_distribution<std::uint32_t> at(0, r - 1), size(2, r / 3);
    std::vector<std::array<std::uint32_t, 3>> cells;
    for (int room = 0; room < 12; ++room) {
        const std::uint32_t x0 = at(rng), y0 = at(rng), z0 = at(rng);
        const std::uint32_t x1 = std::min(r - 1, x0 + size(rng)),
                            y1 = std::min(r - 1, y0 + size(rng)),
                            z1 = std::min(r - 1, z0 + size(rng));
        const bool door = room % 3 == 0;
        for (std::uint32_t z = z0; z <= z1; ++z)
            for (std::uint32_t y = y0; y <= y1; ++y)
                for (std::uint32_t x = x0; x <= x1; ++x) {
                    const bool wall = x == x0 || x == x1 || y == y0 || y == y1 || z == z0 || z == z1;
                    if (wall && !(door && x == x0 && y == (y0 + y1) / 2 && z == (z0 + z1) / 2))
                        cells.push_back({x, y, z});
                }
    }
    for (std::uint32_t y = 0; y < r; ++y)  // a slab with a hole
        for (std::uint32_t x = 0; x < r; ++x)
            if (x != r / 2 || y != r / 3) cells.push_back({x, y, r / 4});
    for (int i = 0; i < int(r * r * r / 10); ++i) cells.push_back({at(rng), at(rng), at(rng)});
    return cells;
}

}  // namespace

TEST(AirRegions, LabelsRoomsAndPocketsAsAFloodFillFromSeedsInScanOrder) {
    for (unsigned seed = 1; seed <= 4; ++seed) expectSameAsFloodFill(rooms(5, seed), 5);
    const std::vector<std::array<std::uint32_t, 3>> none;
    expectSameAsFloodFill(none, 4);  // all air: one region
}

TEST(AirRegions, CellsOutsideTheLimitBoxHoldNoAir) {
    expectSameAsFloodFill(rooms(5, 7), 5, {3, 5, 2}, {29, 20, 31});
    expectSameAsFloodFill(rooms(5, 8), 5, {0, 0, 16}, {32, 32, 17});  // one layer
}

TEST(AirRegions, BeyondTheLabelRangeTheLaterRegionsStayUnlabelled) {
    // Air only at cells with three odd coordinates: 64³ = 262 144 isolated pockets, more than
    // the 65 534 labels.
    const std::uint32_t depth = 7, r = 1u << depth;
    std::vector<std::array<std::uint32_t, 3>> cells;
    for (std::uint32_t z = 0; z < r; ++z)
        for (std::uint32_t y = 0; y < r; ++y)
            for (std::uint32_t x = 0; x < r; ++x)
                if (!(x % 2 && y % 2 && z % 2)) cells.push_back({x, y, z});
    const SolidGrid solid(depth, cells);
    const AirRegions regions(solid, depth);
    EXPECT_EQ(regions.count(), std::uint32_t{AirRegions::kNone});
    EXPECT_EQ(regions.label(1, 1, 1), 0);
    EXPECT_EQ(regions.label(3, 1, 1), 1);
    EXPECT_EQ(regions.label(0, 0, 0), AirRegions::kSolid);
    EXPECT_EQ(regions.label(r - 1, r - 1, r - 1), AirRegions::kNone);
    expectSameAsFloodFill(cells, depth);
}
