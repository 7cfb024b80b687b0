// The final gather's light grid (runtime/src/light_grid.h): every light that can reach a point,
// by the shader's own float arithmetic, is in the list of the point's cell, in light order; and
// the lists are short where the lights' ranges are.
#include "light_grid.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

namespace rt = vox::runtime;
using vox::PunctualLight;
using vox::Vec3f;

namespace {

/// Whether the shader's lightArrival can return true for @p l at @p p (its range test in float).
bool mayReach(const PunctualLight& l, Vec3f p) {
    if (l.type == PunctualLight::Type::Directional || !(l.range > 0)) return true;
    const Vec3f o = l.position - p;
    const float d = std::sqrt(o.x * o.x + o.y * o.y + o.z * o.z);
    return d < l.range;
}

struct Case {
    std::vector<Vec3f> points;
    std::vector<PunctualLight> lights;
};

Case randomCase(float offset, float extent, float rangeScale, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(-extent, extent), range(0.5f, 1.5f);
    Case c;
    for (int i = 0; i < 3000; ++i) c.points.push_back({offset + u(rng), offset + u(rng), u(rng)});
    // Points on the cells' faces too: where the shader's rounding decides the cell.
    for (int i = 0; i < 200; ++i) c.points.push_back({offset + float(i % 7) - 3, offset, 0});
    for (int i = 0; i < 600; ++i) {
        PunctualLight l;
        l.type = i % 3 == 0 ? PunctualLight::Type::Spot : PunctualLight::Type::Point;
        l.position = {offset + u(rng), offset + u(rng), u(rng)};
        l.range = rangeScale * range(rng);
        c.lights.push_back(l);
    }
    PunctualLight sun;
    sun.type = PunctualLight::Type::Directional;
    c.lights.insert(c.lights.begin() + 100, sun);
    PunctualLight unranged;  // range 0: reaches everywhere
    c.lights.insert(c.lights.begin() + 300, unranged);
    return c;
}

void expectConservativeAndOrdered(const Case& c, const rt::detail::LightGrid& grid) {
    ASSERT_EQ(grid.cellRanges.size(), std::size_t{grid.cells[0]} * grid.cells[1] * grid.cells[2]);
    std::size_t missing = 0;
    for (const Vec3f& p : c.points) {
        const auto [first, count] = grid.cellRanges[grid.cellOf(p)];
        ASSERT_LE(std::size_t{first} + count, grid.lightList.size());
        const auto begin = grid.lightList.begin() + first, end = begin + count;
        ASSERT_TRUE(std::is_sorted(begin, end));
        ASSERT_EQ(std::adjacent_find(begin, end), end);
        for (std::uint32_t i = 0; i < c.lights.size(); ++i)
            if (mayReach(c.lights[i], p) && !std::binary_search(begin, end, i)) ++missing;
    }
    EXPECT_EQ(missing, 0u);
}

double meanListLength(const Case& c, const rt::detail::LightGrid& grid) {
    double sum = 0;
    for (const Vec3f& p : c.points) sum += grid.cellRanges[grid.cellOf(p)][1];
    return sum / double(c.points.size());
}

}  // namespace

TEST(LightGrid, EveryLightThatReachesAPointIsInItsCellInLightOrderAndListsAreShort) {
    const Case c = randomCase(0, 10, 1.5f, 1);
    const rt::detail::LightGrid grid = rt::detail::buildLightGrid(c.points, c.lights);
    EXPECT_GT(grid.cells[0] * grid.cells[1] * grid.cells[2], 100u);
    expectConservativeAndOrdered(c, grid);
    // About 600 · (4/3 π 1.5³ · ~2 for the cells' extent) / 20³ lights in range, plus the two
    // that reach everywhere: a small share of the 602.
    const double mean = meanListLength(c, grid);
    std::printf("[ light grid ] %u×%u×%u cells, %zu entries, %.1f of %zu lights per point\n",
                grid.cells[0], grid.cells[1], grid.cells[2], grid.lightList.size(), mean,
                c.lights.size());
    EXPECT_LT(mean, 0.15 * double(c.lights.size()));
    EXPECT_GE(mean, 2.0);
}

TEST(LightGrid, FarFromTheOriginRoundingStillKeepsEveryLightInRange) {
    // Coordinates near 10⁵ with lights of 0.2 m: a float step is 8 mm, 4 % of a cell.
    const Case c = randomCase(1e5f, 3, 0.2f, 2);
    const rt::detail::LightGrid grid = rt::detail::buildLightGrid(c.points, c.lights);
    EXPECT_GT(grid.cells[0], 8u);
    expectConservativeAndOrdered(c, grid);
}

TEST(LightGrid, TheEntryBoundCoarsensTheGridAndStillListsEveryLightInRange) {
    const Case c = randomCase(0, 10, 1.5f, 3);
    const rt::detail::LightGrid fine = rt::detail::buildLightGrid(c.points, c.lights);
    const rt::detail::LightGrid coarse =
        rt::detail::buildLightGrid(c.points, c.lights, 64, fine.lightList.size() / 4);
    EXPECT_LE(coarse.lightList.size(), fine.lightList.size() / 4);
    EXPECT_LT(coarse.cells[0], fine.cells[0]);
    expectConservativeAndOrdered(c, coarse);
}

TEST(LightGrid, WithoutRangedLightsOrPointsOneCellListsEveryLight) {
    Case c = randomCase(0, 10, 1.5f, 4);
    for (PunctualLight& l : c.lights) l.range = 0;
    for (const auto& grid : {rt::detail::buildLightGrid(c.points, c.lights),
                             rt::detail::buildLightGrid({}, randomCase(0, 10, 1, 5).lights)}) {
        EXPECT_EQ(grid.cells, (std::array<std::uint32_t, 3>{1, 1, 1}));
        ASSERT_EQ(grid.cellRanges.size(), 1u);
        EXPECT_EQ(grid.cellRanges[0][0], 0u);
        EXPECT_EQ(grid.cellRanges[0][1], c.lights.size());
        for (std::uint32_t i = 0; i < grid.lightList.size(); ++i) EXPECT_EQ(grid.lightList[i], i);
    }
}

TEST(LightGrid, ALightThatJustReachesAPointOnACellFaceFromTheNextCellIsListed) {
    // The hard case: the point is the box's nearest point to the light, on a face between two
    // cells, and the light sits just under its range away, across the face.
    std::mt19937 rng(6);
    std::uniform_real_distribution<float> u(-8, 8);
    Case c;
    for (int i = 0; i < 2000; ++i) c.points.push_back({u(rng), u(rng), u(rng)});
    const float range = 1.0f;
    PunctualLight probe;
    probe.range = range;
    const rt::detail::LightGrid layout = rt::detail::buildLightGrid(c.points, {&probe, 1});
    ASSERT_GT(layout.cells[0], 4u);
    for (int i = 0; i < 1500; ++i) {
        const int axis = i % 3;
        const std::uint32_t face = 1 + std::uint32_t(i / 3) % (layout.cells[axis] - 1);
        Vec3f p{u(rng), u(rng), u(rng)};
        p[axis] = layout.origin[axis] + float(face) / layout.inverseCell[axis];
        c.points.push_back(p);
        PunctualLight l = probe;
        l.position = p;
        l.position[axis] += (i % 2 ? 1 : -1) * range * (1 - 1e-5f);
        c.lights.push_back(l);
    }
    const rt::detail::LightGrid grid = rt::detail::buildLightGrid(c.points, c.lights);
    ASSERT_EQ(grid.cells, layout.cells);  // the same cells: the same bounds and median range
    expectConservativeAndOrdered(c, grid);
}
