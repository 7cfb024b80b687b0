// Many lights (libvox/src/lighting/many_lights.cpp): the spatial clusters of render points (octree
// for voxels, view-frustum cells for pixels) and their runs of similar points, lightPoints with
// cluster–light lists and cut reuse against brute force, its determinism and its search steps
// against classic Lightcuts, brute force itself, directLight's method choice and comparison, and
// the option parsers.
#include <vox/base/error.h>
#include <vox/many_lights.h>

#include "test_random.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <map>
#include <random>
#include <set>
#include <span>
#include <string>
#include <tuple>
#include <vector>

namespace {

using vox::Light;
using vox::LightcutPoint;
using vox::LightTree;
using vox::RenderPointClusters;
using vox::Vec3d;
using vox::Vec3f;
using Cell = std::array<std::uint32_t, 3>;
using Pixel = std::array<std::uint32_t, 2>;
constexpr double kPi = 3.14159265358979323846;

using vox::test::Rng;

Vec3f f(Vec3d v) { return {float(v.x), float(v.y), float(v.z)}; }

/// Point and spot lights, every one with a range (so that skipping a tree is exact), above the
/// floor y = 0 in [lo, hi].
std::vector<Light> rangedLights(std::size_t n, std::uint64_t seed, Vec3d lo, Vec3d hi,
                                double rangeLo = 3, double rangeHi = 8, double spotShare = 0.3) {
    Rng rng(seed);
    std::vector<Light> lights;
    for (std::size_t i = 0; i < n; ++i) {
        Light l;
        l.color = f({rng.uniform(0.2, 1), rng.uniform(0.2, 1), rng.uniform(0.2, 1)});
        l.intensity = float(rng.uniform(5, 100));
        l.type = rng.uniform() < spotShare ? Light::Type::Spot : Light::Type::Point;
        l.position = f({rng.uniform(lo.x, hi.x), rng.uniform(lo.y, hi.y), rng.uniform(lo.z, hi.z)});
        l.range = float(rng.uniform(rangeLo, rangeHi));
        if (l.type == Light::Type::Spot) {
            l.direction = f(rng.around({0, -1, 0}, 1.0));
            l.outerConeAngle = float(rng.uniform(0.4, 1.2));
            l.innerConeAngle = float(rng.uniform(0, l.outerConeAngle));
        }
        lights.push_back(l);
    }
    return lights;
}

/// Morton code of a cell (x lowest bit), written independently of the library's.
std::uint64_t morton(const Cell& c) {
    std::uint64_t code = 0;
    for (int bit = 0; bit < 10; ++bit)
        for (int axis = 0; axis < 3; ++axis)
            code |= std::uint64_t((c[std::size_t(axis)] >> bit) & 1u) << (3 * bit + axis);
    return code;
}

/// The run that starts at runs[r]: [runs[r], end).
std::uint32_t runEnd(const RenderPointClusters& c, std::size_t r) {
    return r + 1 < c.runs.size() ? c.runs[r + 1] : std::uint32_t(c.order.size());
}

/// The structural invariants every clustering keeps: a permutation, cluster and run boundaries
/// ascending, every cluster starting a run, every run's points similar to its first and each point
/// in the first run of its cluster it is similar to.
void expectStructure(const RenderPointClusters& c, std::span<const LightcutPoint> points,
                     const vox::SimilarityOptions& similarity = {}) {
    ASSERT_EQ(c.order.size(), points.size());
    std::vector<int> seen(points.size(), 0);
    for (std::uint32_t i : c.order) {
        ASSERT_LT(i, points.size());
        ++seen[i];
    }
    for (std::size_t i = 0; i < points.size(); ++i) ASSERT_EQ(seen[i], 1) << "point " << i;
    ASSERT_FALSE(c.begin.empty());
    EXPECT_EQ(c.begin.front(), 0u);
    EXPECT_EQ(c.begin.back(), c.order.size());
    for (std::size_t k = 0; k + 1 < c.begin.size(); ++k)
        ASSERT_LT(c.begin[k], c.begin[k + 1]) << "empty or unordered cluster " << k;
    if (points.empty()) {
        EXPECT_EQ(c.count(), 0u);
        EXPECT_TRUE(c.runs.empty());
        return;
    }
    for (std::size_t r = 0; r + 1 < c.runs.size(); ++r) ASSERT_LT(c.runs[r], c.runs[r + 1]);
    ASSERT_FALSE(c.runs.empty());
    EXPECT_LT(c.runs.back(), c.order.size());
    for (std::size_t k = 0; k < c.count(); ++k)
        EXPECT_TRUE(std::binary_search(c.runs.begin(), c.runs.end(), c.begin[k]))
            << "cluster " << k << " does not start a run";
    for (std::size_t k = 0; k < c.count(); ++k) {
        const auto firstRun = std::size_t(
            std::lower_bound(c.runs.begin(), c.runs.end(), c.begin[k]) - c.runs.begin());
        for (std::size_t r = firstRun; r < c.runs.size() && c.runs[r] < c.begin[k + 1]; ++r) {
            ASSERT_LE(runEnd(c, r), c.begin[k + 1])
                << "run " << r << " crosses the end of cluster " << k;
            const LightcutPoint& head = points[c.order[c.runs[r]]];
            for (std::uint32_t j = c.runs[r]; j < runEnd(c, r); ++j) {
                ASSERT_TRUE(vox::similarRenderPoints(head, points[c.order[j]], similarity))
                    << "run " << r << " position " << j;
                for (std::size_t earlier = firstRun; earlier < r; ++earlier)
                    ASSERT_FALSE(vox::similarRenderPoints(points[c.order[c.runs[earlier]]],
                                                          points[c.order[j]], similarity))
                        << "point " << c.order[j] << " skipped an earlier similar run";
            }
        }
    }
}

bool sameClusters(const RenderPointClusters& a, const RenderPointClusters& b) {
    return a.order == b.order && a.begin == b.begin && a.runs == b.runs;
}

/// Points order[first, last) of a clustering.
std::vector<std::uint32_t> members(const RenderPointClusters& c, std::size_t k) {
    return {c.order.begin() + c.begin[k], c.order.begin() + c.begin[k + 1]};
}

LightcutPoint floorPoint(Vec3d p, Vec3d normal = {0, 0, 1}, Vec3d albedo = {0.7, 0.7, 0.7}) {
    return LightcutPoint::lambertian(p, normal, albedo);
}

}  // namespace

TEST(SimilarRenderPoints, NormalsWithinTenDegreesAndTheSameMaterial) {
    const Vec3d albedo{0.5, 0.5, 0.5};
    const LightcutPoint a = floorPoint({0, 0, 0}, {0, 0, 1}, albedo);
    auto tilted = [&](double degrees) {
        const double t = degrees * kPi / 180;
        return floorPoint({5, 5, 5}, {std::sin(t), 0, std::cos(t)}, albedo);
    };
    EXPECT_TRUE(vox::similarRenderPoints(a, a));
    EXPECT_TRUE(vox::similarRenderPoints(a, tilted(9.9)));
    EXPECT_FALSE(vox::similarRenderPoints(a, tilted(10.1)));
    EXPECT_FALSE(vox::similarRenderPoints(a, tilted(90)));
    vox::SimilarityOptions wide;
    wide.normalDegrees = 45;
    EXPECT_TRUE(vox::similarRenderPoints(a, tilted(40), wide));
    // Albedo: within 1/64 per channel.
    EXPECT_TRUE(
        vox::similarRenderPoints(a, floorPoint({0, 0, 0}, {0, 0, 1}, {0.5, 0.5 + 0.015, 0.5})));
    EXPECT_FALSE(
        vox::similarRenderPoints(a, floorPoint({0, 0, 0}, {0, 0, 1}, {0.5, 0.5, 0.5 - 0.02})));
    // A cosine point and an axis-weighted one are different materials.
    vox::VoxelNormals normals;
    normals.mean = {0, 0, 1};
    normals.moments = {0, 0, 0, 0, 1, 0};
    EXPECT_FALSE(vox::similarRenderPoints(
        a, LightcutPoint::voxel({0, 0, 0}, normals, vox::Attenuation::Weighted, albedo)));
    EXPECT_TRUE(vox::similarRenderPoints(
        LightcutPoint::voxel({0, 0, 0}, normals, vox::Attenuation::Weighted, albedo),
        LightcutPoint::voxel({1, 0, 0}, normals, vox::Attenuation::Weighted, albedo)));
}

// ---------------------------------------------------------------------------------------------
// clusterVoxelPoints

TEST(ClusterVoxelPoints, StructureOnRandomPoints) {
    Rng rng(1);
    constexpr std::uint32_t kDepth = 4;
    std::vector<LightcutPoint> points;
    std::vector<Cell> cells;
    const Vec3d normals[] = {{0, 1, 0}, vox::normalize(Vec3d{0.05, 1, 0}), {1, 0, 0}, {0, 0, -1}};
    const Vec3d albedos[] = {{0.2, 0.2, 0.2}, {0.8, 0.5, 0.2}, {0.21, 0.2, 0.2}};
    for (int i = 0; i < 700; ++i) {
        // Mostly a coherent floor, some random cells; several points per cell sometimes.
        const Cell c = i < 450 ? Cell{rng.below(16), rng.below(2), rng.below(16)}
                               : Cell{rng.below(16), rng.below(16), rng.below(16)};
        cells.push_back(c);
        const Vec3d n = i < 450 && rng.uniform() < 0.8 ? normals[0] : normals[rng.below(4)];
        points.push_back(
            floorPoint({double(c[0]), double(c[1]), double(c[2])}, n, albedos[rng.below(3)]));
    }
    for (std::uint32_t maxPoints : {1u, 8u, 64u, 512u, 100000u})
        for (std::uint32_t minCells : {1u, 2u, 4u, 16u}) {
            SCOPED_TRACE(::testing::Message()
                         << "maxPoints " << maxPoints << ", minCells " << minCells);
            const RenderPointClusters c =
                vox::clusterVoxelPoints(points, cells, kDepth, maxPoints, minCells);
            expectStructure(c, points);
            // Deterministic.
            EXPECT_TRUE(sameClusters(
                c, vox::clusterVoxelPoints(points, cells, kDepth, maxPoints, minCells)));
            // The level at which the subdivision stops: nodes minCells cells wide.
            std::uint32_t finest = kDepth;
            for (std::uint32_t edge = 1; edge < minCells; edge *= 2) --finest;
            const std::uint32_t finestShift = 3 * (kDepth - finest);
            std::uint64_t previousMax = 0;
            for (std::size_t k = 0; k < c.count(); ++k) {
                std::vector<std::uint32_t> m = members(c, k);
                // Octree nodes in Morton order: clusters never interleave.
                std::uint64_t lo = ~0ull, hi = 0;
                for (std::uint32_t i : m) {
                    lo = std::min(lo, morton(cells[i]));
                    hi = std::max(hi, morton(cells[i]));
                }
                if (k > 0) {
                    EXPECT_GT(lo, previousMax) << "cluster " << k;
                }
                previousMax = hi;
                // A cluster is small and similar, or a node of the finest level.
                std::sort(m.begin(), m.end(), [&](std::uint32_t a, std::uint32_t b) {
                    return std::make_tuple(morton(cells[a]), a) <
                           std::make_tuple(morton(cells[b]), b);
                });
                bool similar = true;
                for (std::uint32_t i : m)
                    similar = similar && vox::similarRenderPoints(points[m.front()], points[i]);
                const bool finestNode = (lo >> finestShift) == (hi >> finestShift);
                EXPECT_TRUE((m.size() <= maxPoints && similar) || finestNode)
                    << "cluster " << k << " of " << m.size();
            }
            // Each run in Morton order (ties: by index).
            for (std::size_t r = 0; r < c.runs.size(); ++r)
                for (std::uint32_t j = c.runs[r] + 1; j < runEnd(c, r); ++j) {
                    const std::uint32_t a = c.order[j - 1], b = c.order[j];
                    EXPECT_LT(std::make_tuple(morton(cells[a]), a),
                              std::make_tuple(morton(cells[b]), b))
                        << "run " << r;
                }
            if (maxPoints == 1 && minCells == 1) {
                // Every occupied cell its own cluster, at least.
                std::set<std::uint64_t> occupied;
                for (const Cell& cell : cells) occupied.insert(morton(cell));
                EXPECT_GE(c.count(), occupied.size());
            }
        }
    // Edge cases.
    const RenderPointClusters none = vox::clusterVoxelPoints({}, {}, 5);
    EXPECT_EQ(none.count(), 0u);
    EXPECT_EQ(none.begin, (std::vector<std::uint32_t>{0}));
    EXPECT_THROW(
        (void)vox::clusterVoxelPoints(points, std::span<const Cell>(cells).first(3), kDepth),
        vox::UsageError);
    EXPECT_THROW((void)vox::clusterVoxelPoints(points, cells, 11), vox::UsageError);
}

TEST(ClusterVoxelPoints, FlatFloorGivesFewClusters) {
    // 32 × 32 identical voxels at z = 0 of a depth-5 volume (32³ cells).
    std::vector<LightcutPoint> points;
    std::vector<Cell> cells;
    for (std::uint32_t y = 0; y < 32; ++y)
        for (std::uint32_t x = 0; x < 32; ++x) {
            cells.push_back({x, y, 0});
            points.push_back(floorPoint({x + 0.5, y + 0.5, 0.5}));
        }
    // Everything fits: one cluster, one run, in Morton order.
    const RenderPointClusters one = vox::clusterVoxelPoints(points, cells, 5, 1024);
    expectStructure(one, points);
    EXPECT_EQ(one.count(), 1u);
    EXPECT_EQ(one.runs, (std::vector<std::uint32_t>{0}));
    for (std::size_t j = 1; j < one.order.size(); ++j)
        EXPECT_LT(morton(cells[one.order[j - 1]]), morton(cells[one.order[j]]));
    // 1023: the root is split once; its four occupied octants (16 × 16) fit.
    EXPECT_EQ(vox::clusterVoxelPoints(points, cells, 5, 1023).count(), 4u);
    // 64: twice; sixteen aligned 8 × 8 squares of 64, each one run.
    const RenderPointClusters sixteen = vox::clusterVoxelPoints(points, cells, 5, 64);
    expectStructure(sixteen, points);
    ASSERT_EQ(sixteen.count(), 16u);
    EXPECT_EQ(sixteen.runs,
              std::vector<std::uint32_t>(sixteen.begin.begin(), sixteen.begin.end() - 1));
    for (std::size_t k = 0; k < 16; ++k) {
        const auto m = members(sixteen, k);
        ASSERT_EQ(m.size(), 64u);
        const Cell first = cells[m.front()];
        EXPECT_EQ(first[0] % 8, 0u);
        EXPECT_EQ(first[1] % 8, 0u);
        for (std::uint32_t i : m) {
            EXPECT_EQ(cells[i][0] / 8, first[0] / 8);
            EXPECT_EQ(cells[i][1] / 8, first[1] / 8);
        }
    }
    // maxPoints 1: the subdivision still stops at minCells (4 × 4 cells: 64 clusters of 16); with
    // minCells 1 at single cells.
    EXPECT_EQ(vox::clusterVoxelPoints(points, cells, 5, 1, 4).count(), 64u);
    EXPECT_EQ(vox::clusterVoxelPoints(points, cells, 5, 1, 1).count(), 1024u);
    // The default (512): the four 16 × 16 octants.
    EXPECT_EQ(vox::clusterVoxelPoints(points, cells, 5).count(), 4u);
}

TEST(ClusterVoxelPoints, CheckerOfMaterialsSplitsIntoRuns) {
    // 32 × 32 floor, two materials (albedo 0.2 and 0.7) in a checker of 4 × 4-cell squares.
    std::vector<LightcutPoint> points;
    std::vector<Cell> cells;
    auto materialOf = [](const Cell& c) { return (c[0] / 4 + c[1] / 4) % 2; };
    for (std::uint32_t y = 0; y < 32; ++y)
        for (std::uint32_t x = 0; x < 32; ++x) {
            const Cell c{x, y, 0};
            cells.push_back(c);
            const double a = materialOf(c) ? 0.7 : 0.2;
            points.push_back(floorPoint({x + 0.5, y + 0.5, 0.5}, {0, 0, 1}, {a, a, a}));
        }
    // minCells 4: split down to the 4 × 4 squares, each one cluster of one material.
    const RenderPointClusters squares = vox::clusterVoxelPoints(points, cells, 5, 1024, 4);
    expectStructure(squares, points);
    ASSERT_EQ(squares.count(), 64u);
    EXPECT_EQ(squares.runs.size(), 64u);
    // minCells 8: stops at 8 × 8 nodes holding two squares of each material: two runs of 32,
    // the first of the material of the node's first (Morton) cell, material 0.
    const RenderPointClusters mixed = vox::clusterVoxelPoints(points, cells, 5, 1024, 8);
    expectStructure(mixed, points);
    ASSERT_EQ(mixed.count(), 16u);
    ASSERT_EQ(mixed.runs.size(), 32u);
    for (std::size_t r = 0; r < mixed.runs.size(); ++r) {
        EXPECT_EQ(runEnd(mixed, r) - mixed.runs[r], 32u);
        const std::uint32_t material = materialOf(cells[mixed.order[mixed.runs[r]]]);
        EXPECT_EQ(material, r % 2) << "run " << r;
        for (std::uint32_t j = mixed.runs[r]; j < runEnd(mixed, r); ++j)
            EXPECT_EQ(materialOf(cells[mixed.order[j]]), material);
    }
    // minCells 32 (the whole volume): one cluster, two runs of 512.
    const RenderPointClusters whole = vox::clusterVoxelPoints(points, cells, 5, 1, 32);
    expectStructure(whole, points);
    EXPECT_EQ(whole.count(), 1u);
    EXPECT_EQ(whole.runs, (std::vector<std::uint32_t>{0, 512}));
    // Deterministic.
    EXPECT_TRUE(sameClusters(mixed, vox::clusterVoxelPoints(points, cells, 5, 1024, 8)));
    // Albedo within the tolerance (1/64) is the same material: one cluster.
    std::vector<LightcutPoint> close = points;
    for (std::size_t i = 0; i < close.size(); ++i) {
        const double a = materialOf(cells[i]) ? 0.21 : 0.2;
        close[i].albedo = {a, a, a};
    }
    EXPECT_EQ(vox::clusterVoxelPoints(close, cells, 5, 1024, 4).count(), 1u);
}

// ---------------------------------------------------------------------------------------------
// clusterPixelPoints

namespace {

vox::PinholeCamera camera64() {
    vox::PinholeCamera camera;
    camera.eye = {0, 0, 5};
    camera.target = {0, 0, 0};
    camera.width = camera.height = 64;
    camera.fovYDegrees = 60;
    return camera;
}

/// Slab ratio q of the view-frustum subdivision: C_{i+1} = q C_i.
double slabRatio(const vox::PinholeCamera& camera, std::uint32_t tilePixels) {
    return 1 + 2 * std::tan(0.5 * camera.fovYDegrees * kPi / 180) * tilePixels / camera.height;
}

}  // namespace

TEST(ClusterPixelPoints, StructureAndCells) {
    const vox::PinholeCamera camera = camera64();
    Rng rng(2);
    std::vector<LightcutPoint> points;
    std::vector<Pixel> pixels;
    std::vector<double> depths;
    const Vec3d normals[] = {{0, 0, 1}, vox::normalize(Vec3d{0.05, 0, 1}), {1, 0, 0}};
    for (int i = 0; i < 800; ++i) {
        const Pixel px{rng.below(64), rng.below(64)};
        pixels.push_back(px);
        depths.push_back(rng.uniform(1, 60));
        points.push_back(
            floorPoint({double(px[0]), double(px[1]), -depths.back()}, normals[rng.below(3)],
                       rng.uniform() < 0.7 ? Vec3d{0.5, 0.5, 0.5} : Vec3d{0.9, 0.1, 0.1}));
    }
    const double nearest = *std::min_element(depths.begin(), depths.end());
    for (std::uint32_t tile : {8u, 16u})
        for (std::uint32_t minTile : {1u, 2u, 4u, 16u}) {
            SCOPED_TRACE(::testing::Message() << "tile " << tile << ", min tile " << minTile);
            const RenderPointClusters c =
                vox::clusterPixelPoints(points, pixels, depths, camera, tile, minTile);
            expectStructure(c, points);
            EXPECT_TRUE(sameClusters(
                c, vox::clusterPixelPoints(points, pixels, depths, camera, tile, minTile)));
            const double logQ = std::log(slabRatio(camera, tile));
            auto slabOf = [&](double z) {
                return std::uint32_t(std::floor(std::log(z / nearest) / logQ));
            };
            std::set<std::tuple<std::uint32_t, std::uint32_t, std::uint32_t>> cellsSeen;
            for (std::size_t k = 0; k < c.count(); ++k) {
                const auto m = members(c, k);
                // One (tile, slab) cell per cluster; each cell's points in one cluster when all
                // similar.
                const auto key = std::make_tuple(pixels[m[0]][0] / tile, pixels[m[0]][1] / tile,
                                                 slabOf(depths[m[0]]));
                cellsSeen.insert(key);
                bool similar = true;
                std::uint32_t x0 = 64, x1 = 0, y0 = 64, y1 = 0;
                for (std::uint32_t i : m) {
                    EXPECT_EQ(std::make_tuple(pixels[i][0] / tile, pixels[i][1] / tile,
                                              slabOf(depths[i])),
                              key)
                        << "cluster " << k;
                    similar = similar && vox::similarRenderPoints(points[m[0]], points[i]);
                    x0 = std::min(x0, pixels[i][0]);
                    x1 = std::max(x1, pixels[i][0]);
                    y0 = std::min(y0, pixels[i][1]);
                    y1 = std::max(y1, pixels[i][1]);
                }
                // Not all similar: a tile of at most minTile pixels (its points within one).
                if (!similar) {
                    EXPECT_TRUE(x1 - x0 < std::max(minTile, 1u) && y1 - y0 < std::max(minTile, 1u))
                        << "cluster " << k;
                }
            }
            EXPECT_GE(c.count(), cellsSeen.size());
            // Runs in scanline order.
            for (std::size_t r = 0; r < c.runs.size(); ++r)
                for (std::uint32_t j = c.runs[r] + 1; j < runEnd(c, r); ++j) {
                    const std::uint32_t a = c.order[j - 1], b = c.order[j];
                    EXPECT_LT(std::make_tuple(pixels[a][1], pixels[a][0], a),
                              std::make_tuple(pixels[b][1], pixels[b][0], b));
                }
        }
    const RenderPointClusters none = vox::clusterPixelPoints({}, {}, {}, camera);
    EXPECT_EQ(none.count(), 0u);
    EXPECT_EQ(none.begin, (std::vector<std::uint32_t>{0}));
    EXPECT_THROW((void)vox::clusterPixelPoints(points, pixels,
                                               std::span<const double>(depths).first(5), camera),
                 vox::UsageError);
}

TEST(ClusterPixelPoints, SimilarPointsGiveOneClusterPerOccupiedCell) {
    const vox::PinholeCamera camera = camera64();
    const double q = slabRatio(camera, 16);
    Rng rng(3);
    // The nearest point at depth 2 (C_0); the others in the middle of slab k: 2 q^(k + 0.5).
    std::vector<LightcutPoint> points;
    std::vector<Pixel> pixels;
    std::vector<double> depths;
    std::set<std::tuple<std::uint32_t, std::uint32_t>> tiles;
    std::set<std::tuple<std::uint32_t, std::uint32_t, std::uint32_t>> cells;
    for (int i = 0; i < 300; ++i) {
        const Pixel px{rng.below(64), rng.below(64)};
        const std::uint32_t slab = i == 0 ? 0 : rng.below(6);
        pixels.push_back(px);
        depths.push_back(i == 0 ? 2.0 : 2 * std::pow(q, slab + 0.5));
        points.push_back(floorPoint({0, 0, 0}));
        tiles.insert({px[0] / 16, px[1] / 16});
        cells.insert({px[0] / 16, px[1] / 16, slab});
    }
    // One depth: one cluster per occupied tile.
    const std::vector<double> flat(points.size(), 7.0);
    const RenderPointClusters byTile = vox::clusterPixelPoints(points, pixels, flat, camera);
    expectStructure(byTile, points);
    EXPECT_EQ(byTile.count(), tiles.size());
    EXPECT_EQ(byTile.runs.size(), tiles.size());
    // Six slabs: one per occupied (tile, slab).
    const RenderPointClusters bySlab = vox::clusterPixelPoints(points, pixels, depths, camera);
    expectStructure(bySlab, points);
    EXPECT_EQ(bySlab.count(), cells.size());
    EXPECT_GT(cells.size(), tiles.size());
    // Depths 1 and 100 in one tile: two clusters.
    const std::vector<LightcutPoint> two(2, floorPoint({0, 0, 0}));
    const std::vector<Pixel> twoPixels{Pixel{3, 3}, Pixel{4, 4}};
    const std::vector<double> far{1.0, 100.0};
    const RenderPointClusters apart = vox::clusterPixelPoints(two, twoPixels, far, camera);
    expectStructure(apart, two);
    EXPECT_EQ(apart.count(), 2u);
    const std::vector<double> near{10.0, 10.0 * (1 + 0.5 * (q - 1))};
    EXPECT_EQ(vox::clusterPixelPoints(two, twoPixels, near, camera).count(), 1u);
}

TEST(ClusterPixelPoints, DissimilarNormalsSplitTilesDownToTheMinimum) {
    const vox::PinholeCamera camera = camera64();
    // Tile (1, 1) fully covered: pixels 16 … 31 in x and y, one depth.
    auto tileWith = [&](auto normalOf) {
        std::vector<LightcutPoint> points;
        std::vector<Pixel> pixels;
        for (std::uint32_t y = 16; y < 32; ++y)
            for (std::uint32_t x = 16; x < 32; ++x) {
                pixels.push_back({x, y});
                points.push_back(floorPoint({double(x), double(y), -5}, normalOf(x, y)));
            }
        return std::make_pair(points, pixels);
    };
    const Vec3d up{0, 0, 1}, side{1, 0, 0};  // 90° apart
    const std::vector<double> depths(256, 5.0);
    {
        // Normals alternate by column: every tile down to the minimum holds both.
        const auto [points, pixels] =
            tileWith([&](std::uint32_t x, std::uint32_t) { return x % 2 ? side : up; });
        const RenderPointClusters four =
            vox::clusterPixelPoints(points, pixels, depths, camera, 16, 4);
        expectStructure(four, points);
        ASSERT_EQ(four.count(), 16u);  // 4 × 4-pixel tiles
        ASSERT_EQ(four.runs.size(), 32u);
        for (std::size_t k = 0; k < four.count(); ++k) {
            const auto m = members(four, k);
            ASSERT_EQ(m.size(), 16u);
            for (std::uint32_t i : m) {
                EXPECT_EQ(pixels[i][0] / 4, pixels[m[0]][0] / 4);
                EXPECT_EQ(pixels[i][1] / 4, pixels[m[0]][1] / 4);
            }
        }
        for (std::size_t r = 0; r < four.runs.size(); ++r)
            EXPECT_EQ(runEnd(four, r) - four.runs[r], 8u);
        EXPECT_EQ(vox::clusterPixelPoints(points, pixels, depths, camera, 16, 2).count(), 64u);
        EXPECT_EQ(vox::clusterPixelPoints(points, pixels, depths, camera, 16, 1).count(), 256u);
        const RenderPointClusters whole =
            vox::clusterPixelPoints(points, pixels, depths, camera, 16, 16);
        EXPECT_EQ(whole.count(), 1u);
        EXPECT_EQ(whole.runs, (std::vector<std::uint32_t>{0, 128}));
    }
    {
        // Left half up, right half sideways: the quarter tiles are uniform.
        const auto [points, pixels] =
            tileWith([&](std::uint32_t x, std::uint32_t) { return x < 24 ? up : side; });
        const RenderPointClusters quarters =
            vox::clusterPixelPoints(points, pixels, depths, camera, 16, 4);
        expectStructure(quarters, points);
        EXPECT_EQ(quarters.count(), 4u);
        EXPECT_EQ(quarters.runs.size(), 4u);
    }
    {
        // 5° apart: similar, one cluster.
        const Vec3d tilted = vox::normalize(Vec3d{std::tan(5 * kPi / 180), 0, 1});
        const auto [points, pixels] =
            tileWith([&](std::uint32_t x, std::uint32_t) { return x % 2 ? tilted : up; });
        EXPECT_EQ(vox::clusterPixelPoints(points, pixels, depths, camera, 16, 4).count(), 1u);
    }
}

// ---------------------------------------------------------------------------------------------
// lightPoints, lightPointsBruteForce

namespace {

/// Render points for the lighting tests: a coherent floor patch (two materials, most normals up)
/// and scattered voxels (some axis-weighted), with their depth-5 cells of [-8, 8]³ (0.5 m).
struct PointSet {
    std::vector<LightcutPoint> points;
    std::vector<Cell> cells;
    RenderPointClusters clusters;
};

PointSet makePoints(std::size_t scattered, std::uint64_t seed) {
    Rng rng(seed);
    PointSet s;
    auto add = [&](Cell c, const LightcutPoint& p) {
        s.cells.push_back(c);
        s.points.push_back(p);
    };
    auto centre = [](Cell c) {
        return Vec3d{-8 + 0.5 * (c[0] + 0.5), 0.5 * c[1], -8 + 0.5 * (c[2] + 0.5)};
    };
    for (std::uint32_t z = 4; z < 20; ++z)
        for (std::uint32_t x = 4; x < 20; ++x) {
            const Cell c{x, 0, z};
            const double a = (x / 4 + z / 4) % 2 ? 0.8 : 0.3;
            add(c, LightcutPoint::lambertian(centre(c), {0, 1, 0}, {a, a, a}));
        }
    for (std::size_t i = 0; i < scattered; ++i) {
        const Cell c{rng.below(32), rng.below(4), rng.below(32)};
        const Vec3d albedo{rng.uniform(0.2, 1), rng.uniform(0.2, 1), rng.uniform(0.2, 1)};
        if (i % 3 == 0) {
            vox::VoxelNormals n;
            n.mean = f(rng.around({0, 1, 0}, 1.0));
            for (float& m : n.moments) m = float(rng.uniform(0, 0.8));
            n.moments[3] = 0;  // (−y: nothing faces down)
            add(c, LightcutPoint::voxel(centre(c), n, vox::Attenuation::Weighted, albedo));
        } else {
            add(c, LightcutPoint::lambertian(centre(c), rng.around({0, 1, 0}, 1.3), albedo));
        }
    }
    s.clusters = vox::clusterVoxelPoints(s.points, s.cells, 5, 64);
    return s;
}

std::vector<Light> testLights(std::size_t n, std::uint64_t seed) {
    return rangedLights(n, seed, {-9, 1, -9}, {9, 5, 9});
}

/// lightPoints' cluster loop written out with one LightcutCursor over every tree (no cluster
/// lists): the same cuts, and their error bounds.
std::vector<vox::LightcutResult> cursorReference(const LightTree& tree, const PointSet& s,
                                                 const vox::LightcutOptions& options, bool reuse) {
    std::vector<vox::LightcutResult> out(s.points.size());
    vox::LightcutCursor cursor(tree, options);
    for (std::size_t k = 0; k < s.clusters.count(); ++k) {
        const vox::Bounds3f region = vox::renderPointRegion(
            s.points,
            std::span<const std::uint32_t>(s.clusters.order)
                .subspan(s.clusters.begin[k], s.clusters.begin[k + 1] - s.clusters.begin[k]));
        cursor.setRoots(tree.rootsOverlapping(region), region);
        for (std::uint32_t j = s.clusters.begin[k]; j < s.clusters.begin[k + 1]; ++j) {
            if (!reuse || std::binary_search(s.clusters.runs.begin(), s.clusters.runs.end(), j))
                cursor.reset();
            const std::uint32_t i = s.clusters.order[j];
            out[i] = cursor.evaluate(s.points[i]);
        }
    }
    return out;
}

}  // namespace

TEST(LightPoints, WithinTheErrorGuaranteeOfBruteForce) {
    const std::vector<Light> lights = testLights(300, 10);
    const LightTree tree(lights);
    const PointSet s = makePoints(250, 11);
    const std::size_t n = s.points.size();
    ASSERT_GT(s.clusters.count(), 4u);
    std::vector<Vec3d> brute(n), reused(n), fresh(n), single(n);
    const vox::ManyLightStats b = vox::lightPointsBruteForce(lights, s.points, {}, brute);
    EXPECT_EQ(b.method, "brute-force");
    EXPECT_EQ(b.points, n);
    EXPECT_EQ(b.lights, lights.size());
    EXPECT_EQ(b.lightEvaluations, n * lights.size());
    const vox::ManyLightOptions reuse{};
    vox::ManyLightOptions noReuse;
    noReuse.reuseCuts = false;
    const vox::ManyLightStats r = vox::lightPoints(tree, s.points, s.clusters, reuse, {}, reused);
    const vox::ManyLightStats f = vox::lightPoints(tree, s.points, s.clusters, noReuse, {}, fresh);
    const vox::ManyLightStats p = vox::lightPoints(tree, s.points, {}, reuse, {}, single);
    EXPECT_EQ(r.method, "lightcuts");
    EXPECT_EQ(r.points, n);
    EXPECT_EQ(r.lights, tree.leafCount());
    EXPECT_EQ(r.trees, tree.roots().size());
    EXPECT_EQ(r.clusters, s.clusters.count());
    EXPECT_EQ(r.runs, s.clusters.runs.size());
    EXPECT_EQ(p.clusters, 0u);
    for (const vox::ManyLightStats* st : {&r, &f, &p}) {
        EXPECT_GT(st->cutNodes, n);
        EXPECT_GE(st->searchSteps, st->cutNodes);
        EXPECT_EQ(st->truncated, 0u);
        EXPECT_LT(st->lightEvaluations, b.lightEvaluations / 2);
    }
    const char* names[] = {"clusters + reuse", "clusters, fresh cuts", "no clusters"};
    const std::vector<Vec3d>* results[] = {&reused, &fresh, &single};
    for (int m = 0; m < 3; ++m) {
        const vox::LightcutErrorStats e = vox::compareWithBruteForce(*results[m], brute, 0.02);
        std::printf("[many lights] %-22s %llu/%llu points within 2%%, max %.4f, mean %.5f\n",
                    names[m], static_cast<unsigned long long>(e.within),
                    static_cast<unsigned long long>(e.points), e.maxRelative, e.meanRelative);
        EXPECT_GT(e.points, n * 9 / 10) << names[m];
        EXPECT_GE(e.fractionWithin(), 0.99) << names[m];
        EXPECT_LT(e.maxRelative, 0.1) << names[m];
    }
    // Without clusters each point is a fresh evaluateCut; with them, each result is the cursor's
    // over the cluster's runs, searching its list and seeing the tree as its region does. All
    // within their error bounds of brute force at every point: the list and the region leave
    // out no light that reaches a point.
    const vox::LightcutOptions options;
    const auto reference = cursorReference(tree, s, options, true);
    const auto referenceFresh = cursorReference(tree, s, options, false);
    for (std::size_t i = 0; i < n; ++i) {
        const vox::LightcutResult cut = vox::evaluateCut(tree, s.points[i], options);
        ASSERT_EQ(single[i], cut.radiance) << i;
        ASSERT_EQ(reused[i], reference[i].radiance) << i;
        ASSERT_EQ(fresh[i], referenceFresh[i].radiance) << i;
        const double exact = vox::lightLuminance(brute[i]);
        for (const vox::LightcutResult* res : {&cut, &reference[i], &referenceFresh[i]})
            EXPECT_LE(std::abs(vox::lightLuminance(res->radiance) - exact),
                      res->errorBound * (1 + 1e-9) + 1e-12 * exact)
                << i;
    }
    EXPECT_THROW((void)vox::lightPoints(tree, s.points, s.clusters, reuse, {},
                                        std::span<Vec3d>(reused).first(3)),
                 vox::UsageError);
    EXPECT_THROW(
        (void)vox::lightPointsBruteForce(lights, s.points, {}, std::span<Vec3d>(brute).first(3)),
        vox::UsageError);
}

TEST(LightPoints, VisibilityIsAskedForTheRightPoint) {
    const std::vector<Light> lights = testLights(200, 12);
    const LightTree tree(lights);
    const PointSet s = makePoints(150, 13);
    const std::size_t n = s.points.size();
    // Every third point (by index) fully shadowed; elsewhere lights with x < 0 at half.
    const vox::PointVisibility visibility = [&](std::size_t point, const Light& light,
                                                const vox::LightArrival&) {
        return point % 3 == 0 ? 0.0 : (light.position.x < 0 ? 0.5 : 1.0);
    };
    std::vector<Vec3d> brute(n), cuts(n), unshadowed(n);
    const auto b = vox::lightPointsBruteForce(lights, s.points, visibility, brute);
    const auto c = vox::lightPoints(tree, s.points, s.clusters, {}, visibility, cuts);
    (void)vox::lightPointsBruteForce(lights, s.points, {}, unshadowed);
    EXPECT_GT(b.visibilityEvaluations, 0u);
    EXPECT_GT(c.visibilityEvaluations, 0u);
    EXPECT_LT(c.visibilityEvaluations, b.visibilityEvaluations);
    int lit = 0, dimmer = 0;
    for (std::size_t i = 0; i < n; ++i) {
        if (i % 3 == 0) {
            EXPECT_EQ(brute[i], (Vec3d{0, 0, 0})) << i;
            EXPECT_EQ(cuts[i], (Vec3d{0, 0, 0})) << i;
        } else if (vox::lightLuminance(unshadowed[i]) > 0) {
            ++lit;
            EXPECT_LE(vox::lightLuminance(brute[i]), vox::lightLuminance(unshadowed[i]));
            dimmer += vox::lightLuminance(brute[i]) < vox::lightLuminance(unshadowed[i]);
        }
    }
    EXPECT_GT(lit, int(n / 2));
    EXPECT_GT(dimmer, lit / 2);  // (points that only lights at x ≥ 0 reach keep all their light)
    const vox::LightcutErrorStats e = vox::compareWithBruteForce(cuts, brute, 0.02);
    EXPECT_GE(e.fractionWithin(), 0.99);
    EXPECT_LT(e.maxRelative, 0.1);
}

TEST(LightPoints, SameResultWhateverTheThreadCount) {
    const std::vector<Light> lights = testLights(300, 14);
    const LightTree tree(lights);
    const PointSet s = makePoints(250, 15);
    const std::size_t n = s.points.size();
    auto run = [&](int threads, const RenderPointClusters& clusters, bool reuse,
                   std::vector<Vec3d>& out) {
        const tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                                        std::size_t(threads));
        out.assign(n, Vec3d{-1, -1, -1});
        vox::ManyLightOptions options;
        options.reuseCuts = reuse;
        return vox::lightPoints(tree, s.points, clusters, options, {}, out);
    };
    for (bool clustered : {true, false})
        for (bool reuse : {true, false}) {
            const RenderPointClusters none;
            const RenderPointClusters& clusters = clustered ? s.clusters : none;
            std::vector<Vec3d> one, two;
            const auto a = run(1, clusters, reuse, one);
            const auto b = run(2, clusters, reuse, two);
            for (std::size_t i = 0; i < n; ++i)
                ASSERT_EQ(one[i], two[i])
                    << "point " << i << (clustered ? " clusters" : "") << (reuse ? " reuse" : "");
            EXPECT_EQ(a.searchSteps, b.searchSteps);
            EXPECT_EQ(a.cutNodes, b.cutNodes);
            EXPECT_EQ(a.lightEvaluations, b.lightEvaluations);
            EXPECT_EQ(a.treesSearched, b.treesSearched);
        }
    std::vector<Vec3d> one(n), two(n);
    {
        const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
        (void)vox::lightPointsBruteForce(lights, s.points, {}, one);
    }
    {
        const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
        (void)vox::lightPointsBruteForce(lights, s.points, {}, two);
    }
    EXPECT_EQ(one, two);
}

TEST(LightPoints, ClustersAndReuseTakeFewerSearchStepsThanClassic) {
    // A 40 × 40 grid of points on a floor (0.5 m apart) under 256 ranged lights, cells of a
    // depth-6 volume.
    const std::vector<Light> lights = rangedLights(256, 16, {-10, 1, -10}, {10, 4, 10});
    std::vector<LightcutPoint> points;
    std::vector<Cell> cells;
    for (std::uint32_t z = 0; z < 40; ++z)
        for (std::uint32_t x = 0; x < 40; ++x) {
            cells.push_back({x, 0, z});
            points.push_back(LightcutPoint::lambertian(
                {-10 + 0.5 * (x + 0.5), 0, -10 + 0.5 * (z + 0.5)}, {0, 1, 0}, {0.8, 0.7, 0.6}));
        }
    const RenderPointClusters clusters = vox::clusterVoxelPoints(points, cells, 6);
    const LightTree forest(lights);
    vox::LightTreeOptions classicOptions;
    classicOptions.forest = false;
    const LightTree classic(lights, classicOptions);
    std::vector<Vec3d> brute(points.size()), out(points.size());
    (void)vox::lightPointsBruteForce(lights, points, {}, brute);
    auto steps = [&](const LightTree& tree, bool clustered, bool reuse, const char* what) {
        vox::ManyLightOptions options;
        options.clusterLists = clustered;
        options.reuseCuts = reuse;
        const vox::ManyLightStats s = vox::lightPoints(
            tree, points, clustered ? clusters : RenderPointClusters{}, options, {}, out);
        const vox::LightcutErrorStats e = vox::compareWithBruteForce(out, brute, 0.02);
        std::printf(
            "[many lights] plane, %-30s %6.1f search steps, cut %5.1f, %5.2f trees per point; %.4f "
            "within 2%%, max %.4f\n",
            what, s.meanSearchSteps(), s.meanCutSize(), double(s.treesSearched) / double(s.points),
            e.fractionWithin(), e.maxRelative);
        EXPECT_GE(e.fractionWithin(), 0.99) << what;
        EXPECT_LT(e.maxRelative, 0.1) << what;
        return s.meanSearchSteps();
    };
    const double paper = steps(forest, true, true, "forest, clusters, reuse");
    const double forestFresh = steps(forest, true, false, "forest, clusters, fresh cuts");
    const double forestAlone = steps(forest, false, false, "forest, no clusters");
    const double classicReuse = steps(classic, true, true, "classic tree, clusters, reuse");
    const double classicFresh = steps(classic, false, false, "classic");
    std::printf(
        "[many lights] plane: %.1f %% fewer search steps than classic (reuse alone: %.1f %%)\n",
        100 * (1 - paper / classicFresh), 100 * (1 - paper / forestFresh));
    EXPECT_LT(paper, 0.8 * classicFresh);
    // Both parts pay: reuse on the forest, and on the classic tree.
    EXPECT_LT(paper, 0.85 * forestFresh);
    EXPECT_LT(classicReuse, 0.85 * classicFresh);
    // A cluster's list and region leave out only trees and subtrees that cannot light its points
    // (the errors above), so its cuts take fewer steps than over every tree.
    EXPECT_LT(forestFresh, forestAlone);
}

TEST(LightPointsBruteForce, OneLightByHand) {
    Light light;
    light.position = {0, 2, 0};
    light.intensity = 4;
    light.color = {1, 0.5f, 0.25f};
    Light dynamic = light;
    dynamic.position = {0, 1, 0};
    dynamic.intensity = 100;
    dynamic.dynamic = true;
    Light ranged = light;
    ranged.range = 3;
    const std::vector<Light> lights{dynamic, light};
    const Vec3d albedo{0.8, 0.6, 0.4};
    // (1, 0, 0), facing up: d² = 5, cos θ = 2/√5.
    const std::vector<LightcutPoint> points{
        LightcutPoint::lambertian({1, 0, 0}, {0, 1, 0}, albedo),
        LightcutPoint::lambertian({0, 0, 0}, {0, -1, 0}, albedo)};
    std::vector<Vec3d> out(2);
    const vox::ManyLightStats s = vox::lightPointsBruteForce(lights, points, {}, out);
    EXPECT_EQ(s.lights, 1u);
    EXPECT_EQ(s.points, 2u);
    EXPECT_EQ(s.cutNodes, 2u);
    const double cosine = 2 / std::sqrt(5.0);
    const Vec3d colour{1, 0.5, 0.25};
    for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(out[0][c], 4 * colour[c] * cosine / 5 * albedo[c] / kPi, 1e-15) << c;
    EXPECT_EQ(out[1], (Vec3d{0, 0, 0}));  // facing away
    // With a range of 3 m: the window (1 − (d/3)⁴)².
    const std::vector<Light> windowed{ranged};
    (void)vox::lightPointsBruteForce(windowed, points, {}, out);
    const double window = std::pow(1 - std::pow(5.0 / 9.0, 2), 2);
    EXPECT_NEAR(out[0].x, 4 * cosine / 5 * window * albedo.x / kPi, 1e-15);
    // An axis-weighted point: the response Σ w max(0, ±l) (here 0.5 × l_y + 0.25 × l_x).
    vox::VoxelNormals normals;
    normals.mean = {0, 1, 0};
    normals.moments = {0.25f, 0, 0.5f, 0, 0, 0};
    const std::vector<LightcutPoint> voxel{
        LightcutPoint::voxel({1, 0, 0}, normals, vox::Attenuation::Weighted, albedo)};
    (void)vox::lightPointsBruteForce(lights, voxel, {}, std::span<Vec3d>(out).first(1));
    const double lx = -1 / std::sqrt(5.0),
                 ly = 2 / std::sqrt(5.0);  // towards the light; l_x < 0 gets the −x weight 0
    EXPECT_NEAR(out[0].x, 4 * (0.5 * ly + 0 * lx) / 5 * albedo.x / kPi, 1e-15);
    // Visibility scales, and is clamped to [0, 1].
    const vox::PointVisibility half = [](std::size_t, const Light&, const vox::LightArrival&) {
        return 0.5;
    };
    const vox::PointVisibility over = [](std::size_t, const Light&, const vox::LightArrival&) {
        return 7.0;
    };
    (void)vox::lightPointsBruteForce(lights, points, half, out);
    EXPECT_NEAR(out[0].x, 0.5 * 4 * cosine / 5 * albedo.x / kPi, 1e-15);
    (void)vox::lightPointsBruteForce(lights, points, over, out);
    EXPECT_NEAR(out[0].x, 4 * cosine / 5 * albedo.x / kPi, 1e-15);
    // Matches bruteForce on a tree and lightContribution.
    const LightTree tree(lights);
    EXPECT_NEAR(vox::bruteForce(tree, points[0]).radiance.x, 4 * cosine / 5 * albedo.x / kPi,
                1e-15);
}

// ---------------------------------------------------------------------------------------------
// compareWithBruteForce, directLight, parsing

TEST(CompareWithBruteForce, RelativeLuminanceErrors) {
    const std::vector<Vec3d> exact{{1, 1, 1}, {2, 2, 2}, {0, 0, 0}, {1, 1, 1}};
    const std::vector<Vec3d> estimate{{1.01, 1.01, 1.01}, {2.1, 2.1, 2.1}, {5, 5, 5}, {1, 1, 1}};
    const vox::LightcutErrorStats e = vox::compareWithBruteForce(estimate, exact, 0.02);
    EXPECT_EQ(e.points, 3u);  // the unlit point is skipped
    EXPECT_EQ(e.within, 2u);
    EXPECT_NEAR(e.maxRelative, 0.05, 1e-12);
    EXPECT_NEAR(e.meanRelative, (0.01 + 0.05 + 0) / 3, 1e-12);
    EXPECT_NEAR(e.fractionWithin(), 2.0 / 3, 1e-15);
    EXPECT_EQ(vox::compareWithBruteForce({}, {}, 0.02).fractionWithin(), 1.0);
    EXPECT_THROW(
        (void)vox::compareWithBruteForce(std::span<const Vec3d>(estimate).first(2), exact, 0.02),
        vox::UsageError);
}

TEST(DirectLight, ChoosesTheMethodAndCompares) {
    const PointSet s = makePoints(100, 20);
    const std::size_t n = s.points.size();
    int clusterCalls = 0;
    const std::function<RenderPointClusters()> clusters = [&] {
        ++clusterCalls;
        return s.clusters;
    };
    const vox::LightcutOptions cut;
    auto lightsWith = [](std::size_t staticCount) {
        std::vector<Light> lights = testLights(staticCount + 3, 21);
        for (std::size_t i = staticCount; i < lights.size(); ++i) lights[i].dynamic = true;
        return lights;
    };
    const std::vector<Light> few = lightsWith(vox::kLightcutsAutoLights - 1),
                             enough = lightsWith(vox::kLightcutsAutoLights);
    std::vector<Vec3d> out(n), alone(n);

    // Off: brute force, no clustering.
    auto report =
        vox::directLight(enough, s.points, vox::LightcutsMode::Off, cut, false, clusters, {}, out);
    EXPECT_EQ(report.used.method, "brute-force");
    EXPECT_FALSE(report.compared);
    EXPECT_EQ(clusterCalls, 0);
    (void)vox::lightPointsBruteForce(enough, s.points, {}, alone);
    EXPECT_EQ(out, alone);
    // On: Lightcuts over the forest with the clusters, reuse on.
    report = vox::directLight(few, s.points, vox::LightcutsMode::On, cut, false, clusters, {}, out);
    EXPECT_EQ(report.used.method, "lightcuts");
    EXPECT_EQ(clusterCalls, 1);
    EXPECT_EQ(report.used.clusters, s.clusters.count());
    EXPECT_EQ(report.used.lights, vox::kLightcutsAutoLights - 1);
    {
        const LightTree tree(few);
        (void)vox::lightPoints(tree, s.points, s.clusters, {cut, true, true}, {}, alone);
        EXPECT_EQ(out, alone);
    }
    // Auto: the static light count decides (dynamic lights do not count).
    EXPECT_EQ(
        vox::directLight(few, s.points, vox::LightcutsMode::Auto, cut, false, clusters, {}, out)
            .used.method,
        "brute-force");
    EXPECT_EQ(
        vox::directLight(enough, s.points, vox::LightcutsMode::Auto, cut, false, clusters, {}, out)
            .used.method,
        "lightcuts");
    // No clustering function: lightcuts without clusters.
    report = vox::directLight(enough, s.points, vox::LightcutsMode::On, cut, false, {}, {}, out);
    EXPECT_EQ(report.used.method, "lightcuts");
    EXPECT_EQ(report.used.clusters, 0u);

    // compare: all three filled, and out what the chosen method gives alone, bit for bit.
    for (vox::LightcutsMode mode :
         {vox::LightcutsMode::Off, vox::LightcutsMode::On, vox::LightcutsMode::Auto})
        for (const std::vector<Light>* lights : {&few, &enough}) {
            SCOPED_TRACE(::testing::Message()
                         << "mode " << int(mode) << ", " << lights->size() << " lights");
            std::vector<Vec3d> compared(n, Vec3d{-1, -1, -1});
            const auto r =
                vox::directLight(*lights, s.points, mode, cut, true, clusters, {}, compared);
            const auto plain =
                vox::directLight(*lights, s.points, mode, cut, false, clusters, {}, alone);
            EXPECT_TRUE(r.compared);
            EXPECT_EQ(r.used.method, plain.used.method);
            EXPECT_EQ(compared, alone);
            EXPECT_EQ(r.lightcuts.method, "lightcuts");
            EXPECT_EQ(r.classic.method, "classic");
            EXPECT_EQ(r.bruteForce.method, "brute-force");
            for (const vox::ManyLightStats* st : {&r.lightcuts, &r.classic, &r.bruteForce}) {
                EXPECT_EQ(st->points, n);
                EXPECT_GT(st->cutNodes, 0u);
                EXPECT_GT(st->lightEvaluations, 0u);
            }
            EXPECT_EQ(r.bruteForce.lights, lights->size() - 3);
            EXPECT_EQ(r.lightcuts.clusters, s.clusters.count());
            EXPECT_EQ(r.classic.clusters, 0u);
            EXPECT_LE(r.classic.trees, 2u);
            EXPECT_GT(r.lightcutsError.points, n / 2);
            EXPECT_EQ(r.lightcutsError.points, r.classicError.points);
            EXPECT_GE(r.lightcutsError.fractionWithin(), 0.99);
            EXPECT_GE(r.classicError.fractionWithin(), 0.99);
            EXPECT_EQ(r.lightcutsError.threshold, cut.relativeError);
            const std::string expected =
                mode == vox::LightcutsMode::On ||
                        (mode == vox::LightcutsMode::Auto && lights == &enough)
                    ? "lightcuts"
                    : "brute-force";
            EXPECT_EQ(r.used.method, expected);
            EXPECT_EQ(r.used.cutNodes,
                      expected == "lightcuts" ? r.lightcuts.cutNodes : r.bruteForce.cutNodes);
        }
}

TEST(ParseLightcuts, ModesAndCriteria) {
    EXPECT_EQ(vox::parseLightcutsMode("auto"), vox::LightcutsMode::Auto);
    EXPECT_EQ(vox::parseLightcutsMode("on"), vox::LightcutsMode::On);
    EXPECT_EQ(vox::parseLightcutsMode("off"), vox::LightcutsMode::Off);
    for (const char* bad : {"", "On", "AUTO", "yes", "true", "1", "off ", " on"})
        EXPECT_THROW((void)vox::parseLightcutsMode(bad), vox::UsageError) << "'" << bad << "'";
    EXPECT_EQ(vox::parseLightcutCriterion("per-node"), vox::LightcutCriterion::PerNode);
    EXPECT_EQ(vox::parseLightcutCriterion("sum"), vox::LightcutCriterion::Sum);
    EXPECT_EQ(vox::parseLightcutCriterion("rss"), vox::LightcutCriterion::RootSumSquare);
    for (const char* bad : {"", "pernode", "per_node", "RSS", "root-sum-square", "max", "sum "})
        EXPECT_THROW((void)vox::parseLightcutCriterion(bad), vox::UsageError) << "'" << bad << "'";
    for (vox::LightcutCriterion c : {vox::LightcutCriterion::PerNode, vox::LightcutCriterion::Sum,
                                     vox::LightcutCriterion::RootSumSquare})
        EXPECT_EQ(vox::parseLightcutCriterion(vox::lightcutCriterionName(c)), c);
    try {
        (void)vox::parseLightcutsMode("maybe");
        FAIL() << "no exception";
    } catch (const vox::UsageError& e) {
        EXPECT_NE(std::string(e.what()).find("maybe"), std::string::npos);
        EXPECT_EQ(e.exitCode(), vox::ExitCode::Usage);
    }
}
