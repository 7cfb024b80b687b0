// Lightcuts (libvox/src/lighting/light_tree.cpp, lightcut.cpp): the light tree's invariants, the
// forest, conservative error bounds, cuts against brute force with and without visibility, cut
// reuse, determinism, a 10 000-light build, and the axis-weighted response of voxel render points.
#include <vox/lightcuts.h>
#include <vox/triangle_raycast.h>
#include <vox/util/parallel.h>

#include "scene_builder.h"
#include "test_random.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <random>
#include <string>
#include <vector>

namespace {

using vox::Light;
using vox::LightTree;
using vox::Vec3d;
using vox::Vec3f;
constexpr double kPi = 3.14159265358979323846;

using vox::test::Rng;

Vec3f f(Vec3d v) { return {float(v.x), float(v.y), float(v.z)}; }
Vec3d d(Vec3f v) { return {v.x, v.y, v.z}; }

struct LightMix {
    double spotShare = 0.3;    ///< of the point/spot lights
    double rangedShare = 0.5;  ///< of the point/spot lights
    double rangeLo = 2, rangeHi = 6;
    int directional = 0;
    Vec3d lo{-10, 1, -10}, hi{10, 6, 10};
    double intensityLo = 5, intensityHi = 100;
};

std::vector<Light> randomLights(std::size_t n, std::uint64_t seed, const LightMix& mix = {}) {
    Rng rng(seed);
    std::vector<Light> lights;
    for (std::size_t i = 0; i < n; ++i) {
        Light l;
        l.color = f({rng.uniform(0.2, 1), rng.uniform(0.2, 1), rng.uniform(0.2, 1)});
        l.intensity = float(rng.uniform(mix.intensityLo, mix.intensityHi));
        if (int(i) < mix.directional) {
            l.type = Light::Type::Directional;
            l.direction = f(rng.around({0, -1, 0}, 1.2));
            l.intensity = float(rng.uniform(0.5, 3));
        } else {
            l.type = rng.uniform() < mix.spotShare ? Light::Type::Spot : Light::Type::Point;
            l.position = f({rng.uniform(mix.lo.x, mix.hi.x), rng.uniform(mix.lo.y, mix.hi.y),
                            rng.uniform(mix.lo.z, mix.hi.z)});
            if (rng.uniform() < mix.rangedShare)
                l.range = float(rng.uniform(mix.rangeLo, mix.rangeHi));
            if (l.type == Light::Type::Spot) {
                l.direction = f(rng.around({0, -1, 0}, 1.0));
                l.outerConeAngle = float(rng.uniform(0.3, 1.2));
                l.innerConeAngle = float(rng.uniform(0, l.outerConeAngle));
            }
        }
        lights.push_back(l);
    }
    return lights;
}

bool within(const vox::Bounds3f& outer, const vox::Bounds3f& inner) {
    for (int k = 0; k < 3; ++k)
        if (inner.min[k] < outer.min[k] || inner.max[k] > outer.max[k]) return false;
    return true;
}

double angleBetween(Vec3d a, Vec3d b) {
    return std::acos(std::clamp(vox::dot(vox::normalize(a), vox::normalize(b)), -1.0, 1.0));
}

/// Every structural invariant of a light tree.
void expectInvariants(const LightTree& tree) {
    const auto& nodes = tree.nodes();
    const auto& lights = tree.lights();
    std::vector<int> seen(lights.size(), 0);
    std::size_t reached = 0;
    for (const LightTree::Root& root : tree.roots()) {
        ASSERT_LT(root.node, nodes.size());
        EXPECT_EQ(nodes[root.node].parent, vox::kNoLightNode);
        std::vector<std::uint32_t> stack{root.node};
        while (!stack.empty()) {
            const std::uint32_t k = stack.back();
            stack.pop_back();
            const vox::LightTreeNode& n = nodes[k];
            EXPECT_EQ(n.directional, root.directional);
            EXPECT_EQ(tree.treeOf(k), std::uint32_t(&root - tree.roots().data()));
            // The representative is a light of the subtree: walking up from its leaf reaches k.
            std::uint32_t up = tree.leafOf(n.representative);
            while (up != vox::kNoLightNode && up != k) up = nodes[up].parent;
            EXPECT_EQ(up, k) << "representative outside node " << k;
            if (n.leaf()) {
                ++reached;
                ++seen.at(n.representative);
                EXPECT_EQ(tree.leafOf(n.representative), k);
                EXPECT_EQ(n.lightCount, 1u);
                continue;
            }
            const vox::LightTreeNode& a = nodes[n.left];
            const vox::LightTreeNode& b = nodes[n.right];
            EXPECT_EQ(a.parent, k);
            EXPECT_EQ(b.parent, k);
            EXPECT_EQ(n.lightCount, a.lightCount + b.lightCount);
            for (int c = 0; c < 3; ++c)
                EXPECT_NEAR(n.intensity[c], a.intensity[c] + b.intensity[c],
                            1e-12 * n.intensity[c]);
            EXPECT_NEAR(n.luminance, a.luminance + b.luminance, 1e-12 * n.luminance);
            EXPECT_TRUE(within(n.bounds, a.bounds) && within(n.bounds, b.bounds)) << k;
            EXPECT_TRUE(within(n.influence, a.influence) && within(n.influence, b.influence)) << k;
            EXPECT_GE(n.maxRange, std::max(a.maxRange, b.maxRange));
            EXPECT_GE(n.maxOuterAngle, std::max(a.maxOuterAngle, b.maxOuterAngle));
            EXPECT_EQ(n.hasSpot, a.hasSpot || b.hasSpot);
            EXPECT_EQ(n.hasOmni, a.hasOmni || b.hasOmni);
            if (n.hasSpot && !n.hasOmni) {
                for (const vox::LightTreeNode* c : {&a, &b})
                    EXPECT_LE(angleBetween(d(n.coneAxis), d(c->coneAxis)) + c->coneHalfAngle,
                              n.coneHalfAngle + 1e-5)
                        << k;
            }
            stack.push_back(n.left);
            stack.push_back(n.right);
        }
    }
    EXPECT_EQ(reached, tree.leafCount());
    for (std::size_t i = 0; i < lights.size(); ++i) {
        const int expected = tree.leafOf(std::uint32_t(i)) == vox::kNoLightNode ? 0 : 1;
        EXPECT_EQ(seen[i], expected) << "light " << i << " is in " << seen[i] << " leaves";
    }
}

std::size_t directionalRoots(const LightTree& tree) {
    return std::size_t(std::count_if(tree.roots().begin(), tree.roots().end(),
                                     [](const LightTree::Root& r) { return r.directional; }));
}

double relativeError(Vec3d estimate, Vec3d exact) {
    const double e = vox::lightLuminance(exact);
    const double a = vox::lightLuminance(estimate);
    if (e <= 0) return a <= 0 ? 0.0 : 1.0;
    return std::abs(a - e) / e;
}

/// The result's cut meets its criterion (unless it was truncated), checked from the bounds anew.
void expectCutMeetsCriterion(const LightTree& tree, const vox::LightcutResult& r, Vec3d p, Vec3d n,
                             Vec3d albedo, const vox::LightcutOptions& o) {
    EXPECT_EQ(r.stats.cutSize, r.cut.size());
    if (r.stats.truncated) return;
    const double threshold =
        std::max(o.relativeError * vox::lightLuminance(r.radiance), o.absoluteError);
    double largest = 0, sum = 0, sum2 = 0;
    for (std::uint32_t k : r.cut) {
        if (tree.nodes()[k].leaf()) continue;
        const double b = vox::lightLuminance(vox::lightcutBound(tree, k, p, n, albedo));
        largest = std::max(largest, b);
        sum += b;
        sum2 += b * b;
    }
    EXPECT_NEAR(sum, r.errorBound, 1e-9 * sum + 1e-300);
    const double measure = o.criterion == vox::LightcutCriterion::PerNode ? largest
                           : o.criterion == vox::LightcutCriterion::Sum   ? sum
                                                                          : std::sqrt(sum2);
    EXPECT_LE(measure, threshold * (1 + 1e-9)) << "criterion " << int(o.criterion);
}

const char* name(vox::LightcutCriterion c) {
    switch (c) {
        case vox::LightcutCriterion::PerNode:
            return "per-node";
        case vox::LightcutCriterion::Sum:
            return "sum";
        case vox::LightcutCriterion::RootSumSquare:
            return "root-sum-square";
    }
    return "?";
}

constexpr vox::LightcutCriterion kCriteria[] = {vox::LightcutCriterion::PerNode,
                                                vox::LightcutCriterion::Sum,
                                                vox::LightcutCriterion::RootSumSquare};

}  // namespace

TEST(LightTree, InvariantsHoldForMixedLights) {
    LightMix mix;
    mix.directional = 5;
    std::vector<Light> lights = randomLights(500, 1, mix);
    lights[7].dynamic = true;                                       // left out
    lights[8].intensity = std::numeric_limits<float>::quiet_NaN();  // left out
    for (bool forest : {true, false}) {
        vox::LightTreeOptions options;
        options.forest = forest;
        const LightTree tree(lights, options);
        EXPECT_EQ(tree.leafCount(), 498u);
        EXPECT_EQ(tree.leafOf(7), vox::kNoLightNode);
        EXPECT_EQ(tree.leafOf(8), vox::kNoLightNode);
        EXPECT_EQ(tree.nodes().size(), 2 * 498 - tree.roots().size());
        EXPECT_EQ(directionalRoots(tree), 1u);
        if (!forest) {
            EXPECT_EQ(tree.roots().size(), 2u);
        }
        expectInvariants(tree);
    }
}

TEST(LightTree, ForestSplitsLightsWhoseInfluencesDoNotOverlap) {
    // Three groups of ranged lights, 100 m apart, and five lone lights 10 m apart with 1 m ranges.
    std::vector<Light> lights;
    Rng rng(2);
    for (int g = 0; g < 3; ++g)
        for (int i = 0; i < 20; ++i) {
            Light l;
            l.position = f({100.0 * g + rng.uniform(-2, 2), rng.uniform(1, 3), rng.uniform(-2, 2)});
            l.range = 3;
            l.intensity = float(rng.uniform(10, 50));
            lights.push_back(l);
        }
    for (int i = 0; i < 5; ++i) {
        Light l;
        l.position = f({-100.0 - 10.0 * i, 2, 0});
        l.range = 1;
        lights.push_back(l);
    }
    const LightTree forest(lights);
    EXPECT_EQ(forest.roots().size(), 8u);
    expectInvariants(forest);
    for (const auto& root : forest.roots()) {
        const auto& n = forest.nodes()[root.node];
        EXPECT_TRUE(n.lightCount == 20 || n.lightCount == 1) << n.lightCount;
    }
    // Clustering stopped because no two trees may merge: the diagonal of their union's position
    // box exceeds the reach of their representatives' influence spheres (the paper's threshold).
    auto expectNoAllowedPair = [](const LightTree& tree) {
        for (std::size_t i = 0; i < tree.roots().size(); ++i)
            for (std::size_t j = i + 1; j < tree.roots().size(); ++j) {
                const auto& a = tree.nodes()[tree.roots()[i].node];
                const auto& b = tree.nodes()[tree.roots()[j].node];
                vox::Bounds3f both = a.bounds;
                both.add(b.bounds);
                EXPECT_GT(vox::length(d(both.extent())),
                          tree.influenceRadius(a.representative) +
                              tree.influenceRadius(b.representative));
            }
    };
    expectNoAllowedPair(forest);
    // The root index finds exactly the trees whose influence box holds a point.
    Rng points(3);
    std::vector<std::uint32_t> found;
    for (int i = 0; i < 200; ++i) {
        const Vec3d p{points.uniform(-160, 210), points.uniform(-2, 6), points.uniform(-5, 5)};
        forest.rootsContaining(p, found);
        std::vector<std::uint32_t> expected;
        for (std::uint32_t t = 0; t < forest.roots().size(); ++t) {
            const auto& b = forest.nodes()[forest.roots()[t].node].influence;
            if (p.x >= b.min.x && p.x <= b.max.x && p.y >= b.min.y && p.y <= b.max.y &&
                p.z >= b.min.z && p.z <= b.max.z)
                expected.push_back(t);
        }
        EXPECT_EQ(found, expected);
    }
    // The paper's Cubes scene: 16 × 16 lights 2 m apart, all of range 5 m. Every light overlaps
    // its neighbours, yet the forest holds many small trees, none wider than 10 m (two ranges).
    std::vector<Light> grid;
    for (int i = 0; i < 16; ++i)
        for (int j = 0; j < 16; ++j) {
            Light l;
            l.position = f({-15.0 + 2 * i, 4, -15.0 + 2 * j});
            l.range = 5;
            l.intensity = float(20 + (i * 7 + j * 3) % 11);
            grid.push_back(l);
        }
    const LightTree cubes(grid);
    expectInvariants(cubes);
    expectNoAllowedPair(cubes);
    EXPECT_GE(cubes.roots().size(), 9u);
    for (const auto& root : cubes.roots())
        EXPECT_LE(vox::length(d(cubes.nodes()[root.node].bounds.extent())), 10.0 + 1e-5);
    std::printf("[lightcuts] 16 x 16 grid of 5 m lights 2 m apart: %zu trees\n",
                cubes.roots().size());

    vox::LightTreeOptions classic;
    classic.forest = false;
    const LightTree single(lights, classic);
    EXPECT_EQ(single.roots().size(), 1u);
    expectInvariants(single);

    // Lights without a range: the default influence (1e-3 of the brightest at 1 m: ≈ 31.6 m for
    // equal lights) splits groups 1 km apart; with relativeInfluence = 0 they reach everywhere.
    std::vector<Light> unranged(4);
    for (std::size_t i = 0; i < 4; ++i)
        unranged[i].position = f({i < 2 ? 0.0 : 1000.0, 2, double(i % 2)});
    const LightTree split(unranged);
    EXPECT_EQ(split.roots().size(), 2u);
    EXPECT_NEAR(split.influenceRadius(0), std::sqrt(1000.0), 1e-9);
    vox::LightTreeOptions everywhere;
    everywhere.relativeInfluence = 0;
    EXPECT_EQ(LightTree(unranged, everywhere).roots().size(), 1u);
}

TEST(Lightcuts, BoundIsConservative) {
    LightMix mix;
    mix.directional = 4;
    mix.lo = {-4, -1, -4};
    mix.hi = {4, 4, 4};
    for (bool forest : {true, false}) {
        vox::LightTreeOptions options;
        options.forest = forest;
        const LightTree tree(randomLights(300, forest ? 3 : 4, mix), options);
        const auto& nodes = tree.nodes();
        Rng rng(5);
        std::vector<Vec3d> exact(nodes.size());
        for (int trial = 0; trial < 150; ++trial) {
            // Points among the lights too (inside their boxes), any normal, coloured albedo.
            const Vec3d p{rng.uniform(-6, 6), rng.uniform(-2, 5), rng.uniform(-6, 6)};
            const Vec3d n = rng.unit();
            const Vec3d albedo{rng.uniform(0, 1), rng.uniform(0, 1), rng.uniform(0, 1)};
            // Children come before their parents in nodes(): sum the subtree totals upwards.
            for (std::size_t k = 0; k < nodes.size(); ++k)
                exact[k] = nodes[k].leaf()
                               ? vox::lightContribution(tree.lights()[nodes[k].representative], p,
                                                        n, albedo)
                               : exact[nodes[k].left] + exact[nodes[k].right];
            for (std::size_t k = 0; k < nodes.size(); ++k) {
                const Vec3d bound = vox::lightcutBound(tree, std::uint32_t(k), p, n, albedo);
                for (int c = 0; c < 3; ++c)
                    ASSERT_GE(bound[c], exact[k][c] * (1 - 1e-12))
                        << "node " << k << " channel " << c << " trial " << trial;
            }
        }
    }
}

namespace {

struct AccuracyStats {
    int points = 0, within = 0, withinBound = 0;
    double worst = 0, cutSize = 0, visibility = 0, bruteVisibility = 0;

    void add(const vox::LightcutResult& cut, const vox::LightcutResult& exact, double threshold) {
        const double e = relativeError(cut.radiance, exact.radiance);
        ++points;
        within += e <= threshold;
        worst = std::max(worst, e);
        // The guaranteed bound: |estimate − exact| ≤ Σ bounds of the cut's clusters.
        withinBound +=
            std::abs(vox::lightLuminance(cut.radiance) - vox::lightLuminance(exact.radiance)) <=
            cut.errorBound * (1 + 1e-9) + 1e-12 * vox::lightLuminance(exact.radiance);
        cutSize += cut.stats.cutSize;
        visibility += cut.stats.visibilityEvaluations;
        bruteVisibility += exact.stats.visibilityEvaluations;
    }
    /// What every criterion guarantees, and the accuracy the bounded ones give.
    void expectAccuracy(vox::LightcutCriterion criterion, const char* what) const {
        EXPECT_EQ(withinBound, points) << what;
        switch (criterion) {
            case vox::LightcutCriterion::Sum:
                EXPECT_EQ(within, points) << what << ", worst " << worst;
                break;
            case vox::LightcutCriterion::RootSumSquare:
                EXPECT_GE(within, points * 99 / 100) << what << ", worst " << worst;
                break;
            // Per node (Walter 2005): each cluster within the threshold, the sum of their errors
            // not; a sanity check only.
            case vox::LightcutCriterion::PerNode:
                EXPECT_LE(worst, 0.2) << what;
                break;
        }
        std::printf(
            "[lightcuts] %-34s %-16s %3d/%d points within 2%%, worst %.4f, mean cut %.1f, "
            "visibility calls %.1f (brute %.1f)\n",
            what, name(criterion), within, points, worst, cutSize / points, visibility / points,
            bruteVisibility / points);
    }
};

/// Cuts at random points on the floor (y ∈ [0, 0.5], half of them tilted) against brute force.
AccuracyStats accuracy(const LightTree& tree, double extent, int count,
                       vox::LightcutCriterion criterion) {
    Rng rng(8);
    AccuracyStats s;
    vox::LightcutOptions options;
    options.criterion = criterion;
    for (int i = 0; i < count; ++i) {
        const Vec3d p{rng.uniform(-extent, extent), rng.uniform(0, 0.5),
                      rng.uniform(-extent, extent)};
        const Vec3d n = rng.uniform() < 0.5 ? Vec3d{0, 1, 0} : rng.around({0, 1, 0}, 1.3);
        const Vec3d albedo{rng.uniform(0.2, 1), rng.uniform(0.2, 1), rng.uniform(0.2, 1)};
        const auto cut = vox::evaluateCut(tree, p, n, albedo, options);
        s.add(cut, vox::bruteForce(tree, p, n, albedo), options.relativeError);
        expectCutMeetsCriterion(tree, cut, p, n, albedo, options);
    }
    return s;
}

}  // namespace

TEST(Lightcuts, AgainstBruteForceWithoutVisibility) {
    // A forest: 500 ranged lights (3 … 8 m) in four 10 m blocks 30 m apart; points anywhere,
    // between the blocks too (where every tree is skipped and the light is exactly 0).
    LightMix ranged;
    ranged.rangedShare = 1;
    ranged.rangeLo = 3;
    ranged.rangeHi = 8;
    ranged.lo = {-5, 1, -5};
    ranged.hi = {5, 5, 5};
    std::vector<Light> blocks = randomLights(500, 6, ranged);
    for (std::size_t i = 0; i < blocks.size(); ++i) {
        blocks[i].position.x += (i % 2 ? 15.0f : -15.0f);
        blocks[i].position.z += (i % 4 < 2 ? 15.0f : -15.0f);
    }
    const LightTree forest(blocks);
    EXPECT_GE(forest.roots().size(), 4u);  // at least one per block: the blocks are 20 m apart
    // A classic tree over 500 point and spot lights, half of them without a range.
    vox::LightTreeOptions classicOptions;
    classicOptions.forest = false;
    const LightTree classic(randomLights(500, 7), classicOptions);
    for (vox::LightcutCriterion criterion : kCriteria) {
        accuracy(forest, 22, 400, criterion).expectAccuracy(criterion, "forest, 4 blocks");
        accuracy(classic, 11, 400, criterion).expectAccuracy(criterion, "classic");
    }
}

TEST(Lightcuts, AgainstBruteForceWithVisibility) {
    // Boxes on a floor as occluders, shadow rays through the triangle ray caster.
    vox::Scene scene;
    const std::uint32_t m = vox::test::addMaterial(scene, {0.7f, 0.7f, 0.7f});
    Rng rng(9);
    std::vector<std::pair<Vec3d, Vec3d>> boxes;
    for (int i = 0; i < 12; ++i) {
        const Vec3d lo{rng.uniform(-10, 8), 0, rng.uniform(-10, 8)};
        const Vec3d hi = lo + Vec3d{rng.uniform(0.5, 2), rng.uniform(0.5, 3), rng.uniform(0.5, 2)};
        vox::test::addBox(scene, lo, hi, m);
        boxes.emplace_back(lo, hi);
    }
    const vox::TriangleRayCaster caster(scene);
    LightMix mix;
    mix.lo = {-12, 3.2, -12};
    mix.hi = {12, 6, 12};
    const LightTree tree(randomLights(500, 10, mix));
    for (vox::LightcutCriterion criterion : kCriteria) {
        vox::LightcutOptions options;
        options.criterion = criterion;
        Rng pointRng(12);
        AccuracyStats s;
        while (s.points < 250) {
            const Vec3d p{pointRng.uniform(-11, 11), 0, pointRng.uniform(-11, 11)};
            bool inside = false;
            for (const auto& [lo, hi] : boxes)
                inside = inside || (p.x >= lo.x - 0.01 && p.x <= hi.x + 0.01 &&
                                    p.z >= lo.z - 0.01 && p.z <= hi.z + 0.01);
            if (inside) continue;
            const Vec3d n{0, 1, 0}, albedo{0.8, 0.6, 0.4};
            const vox::LightVisibility shadow = [&](const Light&,
                                                    const vox::LightArrival& a) -> double {
                const double tMax = std::isinf(a.distance) ? std::numeric_limits<double>::infinity()
                                                           : a.distance - 1e-3;
                return caster.castSurface({p + n * 1e-4, a.toLight}, tMax).hit ? 0.0 : 1.0;
            };
            const auto cut = vox::evaluateCut(tree, p, n, albedo, options, shadow);
            s.add(cut, vox::bruteForce(tree, p, n, albedo, shadow), options.relativeError);
            expectCutMeetsCriterion(tree, cut, p, n, albedo, options);
        }
        s.expectAccuracy(criterion, "shadow rays");
        // Fewer shadow rays than brute force (per node: under half).
        EXPECT_LT(s.visibility * (criterion == vox::LightcutCriterion::PerNode ? 2 : 1),
                  s.bruteVisibility);
    }
}

TEST(Lightcuts, CutReuseMatchesFreshCutsWithFewerSearchSteps) {
    // A plane of points under 200 lights, visited row by row (serpentine): a coherent run.
    LightMix mix;
    mix.lo = {-6, 1, -6};
    mix.hi = {6, 3, 6};
    mix.rangeLo = 3;
    mix.rangeHi = 8;
    for (bool forest : {true, false})
        for (vox::LightcutCriterion criterion :
             {vox::LightcutCriterion::PerNode, vox::LightcutCriterion::RootSumSquare}) {
            vox::LightTreeOptions treeOptions;
            treeOptions.forest = forest;
            const LightTree tree(randomLights(200, forest ? 13 : 14, mix), treeOptions);
            vox::LightcutOptions options;
            options.criterion = criterion;
            vox::LightcutCursor cursor(tree, options);
            const Vec3d n{0, 1, 0}, albedo{0.9, 0.8, 0.7};
            std::uint64_t freshSteps = 0, reuseSteps = 0, freshCut = 0, reuseCut = 0,
                          mergedBack = 0;
            int agree = 0;
            AccuracyStats fresh, reuse;
            double worstPair = 0;
            constexpr int kSide = 32;
            for (int row = 0; row < kSide; ++row)
                for (int c = 0; c < kSide; ++c) {
                    const int col = row % 2 ? kSide - 1 - c : c;
                    const Vec3d p{-5 + 10.0 * (col + 0.5) / kSide, 0,
                                  -5 + 10.0 * (row + 0.5) / kSide};
                    const auto f = vox::evaluateCut(tree, p, n, albedo, options);
                    const auto r = cursor.evaluate(p, n, albedo);
                    const auto exact = vox::bruteForce(tree, p, n, albedo);
                    expectCutMeetsCriterion(tree, r, p, n, albedo, options);
                    freshSteps += f.stats.searchSteps;
                    reuseSteps += r.stats.searchSteps;
                    freshCut += f.stats.cutSize;
                    reuseCut += r.stats.cutSize;
                    mergedBack += r.stats.mergedBack;
                    const double pair = relativeError(r.radiance, f.radiance);
                    worstPair = std::max(worstPair, pair);
                    agree += pair <= 2 * options.relativeError;
                    fresh.add(f, exact, options.relativeError);
                    reuse.add(r, exact, options.relativeError);
                }
            const int points = kSide * kSide;
            EXPECT_EQ(agree, points) << "worst relative difference " << worstPair;
            const std::string what = std::string(forest ? "forest" : "classic") + ", plane, fresh";
            fresh.expectAccuracy(criterion, what.c_str());
            reuse.expectAccuracy(
                criterion,
                (std::string(forest ? "forest" : "classic") + ", plane, reused").c_str());
            EXPECT_LT(double(reuseSteps), 0.8 * double(freshSteps));
            std::printf(
                "[lightcuts] reuse, %s, %s: search steps %.1f vs %.1f fresh per point (%.1f %% "
                "fewer), cut %.1f vs %.1f, "
                "%.2f merged back per point, worst reuse/fresh difference %.4f\n",
                forest ? "forest" : "classic", name(criterion), double(reuseSteps) / points,
                double(freshSteps) / points,
                100.0 * (1.0 - double(reuseSteps) / double(freshSteps)), double(reuseCut) / points,
                double(freshCut) / points, double(mergedBack) / points, worstPair);
        }
}

TEST(Lightcuts, CursorAfterResetIsAFreshCut) {
    const LightTree tree(randomLights(200, 15));
    vox::LightcutCursor cursor(tree);
    const Vec3d n{0, 1, 0}, albedo{0.5, 0.5, 0.5};
    (void)cursor.evaluate({1, 0, 1}, n, albedo);
    cursor.reset();
    const auto a = cursor.evaluate({-2, 0, 3}, n, albedo);
    const auto b = vox::evaluateCut(tree, {-2, 0, 3}, n, albedo);
    EXPECT_EQ(a.radiance, b.radiance);
    EXPECT_EQ(a.stats.searchSteps, b.stats.searchSteps);
    EXPECT_EQ(a.cut, b.cut);
}

TEST(Lightcuts, CursorWithARegionLeavesOutOnlyLightsThatCannotReachIt) {
    // A region (a floor patch) with ranged lights whose ranges end just short of or just past
    // its two far corners, and some inside the box around it. With a zero error threshold the
    // cut is exact, so a cursor told the region must give brute force's light at every point of
    // it, corners included; a light dropped while it still reaches a corner (pruning by the
    // region's centre, a margin on the wrong side) shows there.
    vox::Bounds3f region;
    region.add(Vec3f{0, 0, 0});
    region.add(Vec3f{2, 0.5f, 2});
    const Vec3d corners[2] = {{0, 0, 0}, {2, 0.5, 2}};
    LightMix mix;
    mix.spotShare = 0;
    mix.rangedShare = 1;
    mix.lo = {-3, 1, -3};
    mix.hi = {5, 4, 5};
    std::vector<Light> lights = randomLights(40, 41, mix);
    Rng rng(42);
    std::vector<Light> edge[2];  // [0]: just inside range of a corner, [1]: just outside
    for (int k = 0; k < 24; ++k) {
        const int corner = k % 2, inside = (k / 2) % 2 == 0 ? 0 : 1;
        const double sign = corner == 0 ? -1 : 1;
        const Vec3d u = vox::normalize(Vec3d{sign * rng.uniform(0.2, 1), sign * rng.uniform(0.2, 1),
                                             sign * rng.uniform(0.2, 1)});
        Light l;
        l.color = {1, 1, 1};
        l.intensity = float(rng.uniform(20, 50));
        l.range = float(rng.uniform(1, 3));
        l.position =
            f(corners[corner] + u * (double(l.range) * (inside == 0 ? 1 - 1e-3 : 1 + 1e-3)));
        edge[inside].push_back(l);
        lights.push_back(l);
    }
    const LightTree tree(lights);
    std::vector<std::uint32_t> all(tree.roots().size());
    for (std::uint32_t t = 0; t < all.size(); ++t) all[t] = t;
    std::vector<vox::LightcutPoint> points;
    for (const Vec3d c : corners)
        points.push_back(vox::LightcutPoint::lambertian(c, {0, 1, 0}, {1, 1, 1}));
    for (int k = 0; k < 30; ++k)
        points.push_back(vox::LightcutPoint::lambertian(
            {rng.uniform(0, 2), rng.uniform(0, 0.5), rng.uniform(0, 2)}, {0, 1, 0}, {1, 1, 1}));
    for (vox::LightcutPoint& p : points) {
        // Every direction lights the point: its response is Σ |l_axis|.
        p.axisWeighted = true;
        p.axisWeights = {1, 1, 1, 1, 1, 1};
    }
    // The test can fail: the lights just inside range give each corner a measurable share, and
    // those just outside give nothing.
    for (int corner = 0; corner < 2; ++corner) {
        const double total = vox::lightLuminance(vox::bruteForce(tree, points[corner]).radiance);
        double near = 0, beyond = 0;
        for (const Light& l : edge[0])
            near += vox::lightLuminance(vox::lightContribution(l, points[corner]));
        for (const Light& l : edge[1])
            beyond += vox::lightLuminance(vox::lightContribution(l, points[corner]));
        EXPECT_GT(near, 1e-7 * total) << "corner " << corner;
        EXPECT_EQ(beyond, 0) << "corner " << corner;
    }
    vox::LightcutOptions exact;
    exact.relativeError = 0;
    exact.criterion = vox::LightcutCriterion::Sum;
    for (const vox::LightcutOptions& options : {exact, vox::LightcutOptions{}}) {
        vox::LightcutCursor withRegion(tree, options), without(tree, options);
        withRegion.setRoots(all, region);
        without.setRoots(all);
        std::uint64_t cutWith = 0, cutWithout = 0;
        for (std::size_t i = 0; i < points.size(); ++i) {
            const auto r = withRegion.evaluate(points[i]);
            const auto w = without.evaluate(points[i]);
            const double ref = vox::lightLuminance(vox::bruteForce(tree, points[i]).radiance);
            const double got = vox::lightLuminance(r.radiance);
            if (options.relativeError == 0)
                EXPECT_NEAR(got, ref, 1e-12 * ref) << "point " << i;
            else  // the rss criterion: close, not guaranteed
                EXPECT_NEAR(got, ref, 0.05 * ref) << "point " << i;
            cutWith += r.stats.cutSize;
            cutWithout += w.stats.cutSize;
        }
        // The lights that cannot reach the region are left out of its cuts.
        EXPECT_LT(cutWith, cutWithout);
    }
}

TEST(Lightcuts, DirectionalLightsAreCutToo) {
    LightMix mix;
    mix.directional = 50;
    const LightTree tree(randomLights(50, 16, mix));
    ASSERT_EQ(tree.roots().size(), 1u);
    EXPECT_TRUE(tree.roots()[0].directional);
    expectInvariants(tree);
    Rng rng(17);
    for (int i = 0; i < 50; ++i) {
        const Vec3d n = rng.around({0, 1, 0}, 1.4), albedo{1, 1, 1};
        const auto cut = vox::evaluateCut(tree, {0, 0, 0}, n, albedo);
        const auto exact = vox::bruteForce(tree, {0, 0, 0}, n, albedo);
        EXPECT_LE(std::abs(vox::lightLuminance(cut.radiance) - vox::lightLuminance(exact.radiance)),
                  cut.errorBound * (1 + 1e-9) + 1e-12);
        EXPECT_LE(relativeError(cut.radiance, exact.radiance), 0.05);
    }
}

TEST(LightTree, SameTreeWhateverTheThreadCount) {
    LightMix mix;
    mix.directional = 3;
    const std::vector<Light> lights = randomLights(3000, 18, mix);
    auto build = [&](int threads) {
        vox::ThreadLimit limit(threads);
        return LightTree(lights);
    };
    const LightTree a = build(1), b = build(0);
    ASSERT_EQ(a.nodes().size(), b.nodes().size());
    ASSERT_EQ(a.roots().size(), b.roots().size());
    for (std::size_t i = 0; i < a.roots().size(); ++i)
        EXPECT_EQ(a.roots()[i].node, b.roots()[i].node);
    for (std::size_t k = 0; k < a.nodes().size(); ++k) {
        const auto& x = a.nodes()[k];
        const auto& y = b.nodes()[k];
        ASSERT_TRUE(x.left == y.left && x.right == y.right && x.parent == y.parent &&
                    x.representative == y.representative && x.intensity == y.intensity &&
                    x.bounds.min == y.bounds.min && x.bounds.max == y.bounds.max &&
                    x.coneAxis == y.coneAxis && x.coneHalfAngle == y.coneHalfAngle)
            << k;
    }
    // And the same cuts.
    Rng rng(19);
    for (int i = 0; i < 20; ++i) {
        const Vec3d p{rng.uniform(-10, 10), 0, rng.uniform(-10, 10)};
        const auto ca = vox::evaluateCut(a, p, {0, 1, 0}, {1, 1, 1});
        const auto cb = vox::evaluateCut(b, p, {0, 1, 0}, {1, 1, 1});
        EXPECT_EQ(ca.radiance, cb.radiance);
        EXPECT_EQ(ca.cut, cb.cut);
    }
}

TEST(LightTree, TenThousandLightsBuild) {
    // A sanity check that the clustering is not quadratic: it runs, it is not timed against a
    // limit.
    LightMix mix;
    mix.lo = {-100, 1, -100};
    mix.hi = {100, 10, 100};
    mix.directional = 2;
    const std::vector<Light> lights = randomLights(10000, 20, mix);
    for (bool forest : {true, false}) {
        vox::LightTreeOptions options;
        options.forest = forest;
        const auto start = std::chrono::steady_clock::now();
        const LightTree tree(lights, options);
        const double ms =
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
                .count();
        EXPECT_EQ(tree.leafCount(), lights.size());
        EXPECT_EQ(tree.nodes().size(), 2 * lights.size() - tree.roots().size());
        std::printf("[lightcuts] 10 000 lights, %s: %zu trees, built in %.1f ms\n",
                    forest ? "forest" : "classic", tree.roots().size(), ms);
        ::testing::Test::RecordProperty(forest ? "forest_build_ms" : "classic_build_ms",
                                        std::to_string(ms));
        const auto cut = vox::evaluateCut(tree, {0, 0, 0}, {0, 1, 0}, {1, 1, 1});
        EXPECT_GT(cut.stats.cutSize, 0u);
    }
}

TEST(Lightcuts, EdgeCases) {
    const Vec3d n{0, 1, 0}, albedo{1, 1, 1};
    // No lights; only dynamic ones.
    const LightTree empty(std::span<const Light>{});
    EXPECT_TRUE(empty.roots().empty());
    EXPECT_EQ(vox::evaluateCut(empty, {0, 0, 0}, n, albedo).radiance, (Vec3d{0, 0, 0}));
    std::vector<Light> lights(3);
    for (Light& l : lights) l.dynamic = true;
    EXPECT_EQ(LightTree(lights).leafCount(), 0u);
    // One light: its exact contribution, one node, no error.
    Light one;
    one.position = {0, 2, 0};
    one.intensity = 4;
    const LightTree single(std::span<const Light>(&one, 1));
    const auto cut = vox::evaluateCut(single, {0, 0, 0}, n, albedo);
    EXPECT_NEAR(cut.radiance.x, 1.0 / kPi, 1e-12);  // 4 cd at 2 m: 1 lux, white Lambertian: 1/π
    EXPECT_EQ(cut.stats.cutSize, 1u);
    EXPECT_EQ(cut.errorBound, 0.0);
    // Coincident lights, the point on them and just beside them: no NaN, the exact answer.
    std::vector<Light> same(8, one);
    const LightTree stacked(same);
    expectInvariants(stacked);
    for (Vec3d p : {Vec3d{0, 2, 0}, Vec3d{0, 1.999, 0}, Vec3d{0.5, 0, 0}}) {
        const auto c = vox::evaluateCut(stacked, p, n, albedo);
        const auto b = vox::bruteForce(stacked, p, n, albedo);
        EXPECT_NEAR(c.radiance.x, b.radiance.x, 1e-12 * b.radiance.x) << p.y;
        EXPECT_TRUE(std::isfinite(c.errorBound));
    }
    // A surface facing away from every light: nothing, and no refinement.
    const LightTree many(randomLights(100, 21));
    const auto away = vox::evaluateCut(many, {0, 0, 0}, {0, -1, 0}, albedo);
    EXPECT_EQ(away.radiance, (Vec3d{0, 0, 0}));
    EXPECT_EQ(away.stats.cutSize, many.roots().size());
    // maxCutSize stops refinement (a cut still holds every searched tree's root).
    vox::LightcutOptions tight;
    tight.maxCutSize = 5;
    vox::LightTreeOptions classic;
    classic.forest = false;
    const auto small =
        vox::evaluateCut(LightTree(randomLights(100, 21), classic), {0, 0, 0}, n, albedo, tight);
    EXPECT_EQ(small.stats.cutSize, 5u);
    EXPECT_TRUE(small.stats.truncated);
    const auto forestCut = vox::evaluateCut(many, {0, 0, 0}, n, albedo, tight);
    EXPECT_LE(forestCut.stats.cutSize, std::max(5u, forestCut.stats.treesSearched));
}

// ---------------------------------------------------------------------------------------------
// Axis-weighted render points (LightcutPoint::voxel): the radiance bake's voxel responses.

namespace {

constexpr vox::Attenuation kAttenuations[] = {vox::Attenuation::Weighted, vox::Attenuation::Paper,
                                              vox::Attenuation::Average,
                                              vox::Attenuation::Adaptive};
constexpr int kModes = int(std::size(kAttenuations));

const char* name(vox::Attenuation a) {
    switch (a) {
        case vox::Attenuation::Weighted:
            return "weighted";
        case vox::Attenuation::Paper:
            return "paper";
        case vox::Attenuation::Average:
            return "average";
        case vox::Attenuation::Adaptive:
            return "adaptive";
    }
    return "?";
}

/// Normals of a voxel as the bake computes them: a few fragments (area, unit normal) around
/// @p up, sometimes the far side of a thin wall too; mean = normalised area-weighted sum,
/// moments = area shares of |n_s| per axis direction.
vox::VoxelNormals fragmentNormals(Rng& rng, Vec3d up, double spread) {
    const int fragments = 1 + int(rng.uniform(0, 3));
    Vec3d sum{0, 0, 0};
    std::array<double, 6> moments{};
    double area = 0;
    auto add = [&](Vec3d n, double a) {
        sum += n * a;
        area += a;
        for (int axis = 0; axis < 3; ++axis)
            moments[std::size_t(2 * axis + (n[axis] < 0 ? 1 : 0))] += a * std::abs(n[axis]);
    };
    for (int i = 0; i < fragments; ++i) add(rng.around(up, spread), rng.uniform(0.1, 1));
    if (rng.uniform() < 0.15) add(-rng.around(up, spread), rng.uniform(0.1, 1));  // the wall's back
    vox::VoxelNormals n;
    n.mean = f(vox::normalize(sum));
    for (std::size_t k = 0; k < 6; ++k) n.moments[k] = float(moments[k] / area);
    return n;
}

/// Random normals: a random unit mean and random non-negative moments (some zero), unrelated.
vox::VoxelNormals randomNormals(Rng& rng) {
    vox::VoxelNormals n;
    n.mean = f(rng.unit());
    for (float& m : n.moments) m = rng.uniform() < 0.25 ? 0.0f : float(rng.uniform(0, 1.2));
    return n;
}

}  // namespace

TEST(LightcutPoint, VoxelResponseMatchesAttenuate) {
    // The largest |response − attenuate| per mode, with where it happened.
    struct Worst {
        double difference = 0, got = 0, expected = 0;
        Vec3d mean{0, 0, 0}, l{0, 0, 0};
    };
    Worst worst[kModes];
    Rng rng(40);
    for (int trial = 0; trial < 400; ++trial) {
        const vox::VoxelNormals normals =
            trial % 2 ? randomNormals(rng) : fragmentNormals(rng, rng.unit(), 1.2);
        const Vec3d position{rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(-5, 5)};
        const Vec3d albedo{rng.uniform(0, 1), rng.uniform(0, 1), rng.uniform(0, 1)};
        for (int m = 0; m < kModes; ++m) {
            const vox::Attenuation mode = kAttenuations[m];
            const vox::LightcutPoint p = vox::LightcutPoint::voxel(position, normals, mode, albedo);
            EXPECT_EQ(p.position, position);
            EXPECT_EQ(p.albedo, albedo);
            // Adaptive: a flat voxel is a cosine point, a folded one axis-weighted.
            EXPECT_EQ(p.axisWeighted, mode == vox::Attenuation::Adaptive
                                          ? vox::adaptiveAttenuation(normals).flat < 1
                                          : mode != vox::Attenuation::Average)
                << name(mode);
            std::vector<Vec3d> directions;
            for (int k = 0; k < 20; ++k) directions.push_back(rng.unit());
            // The axis directions themselves (one axis weight each) too.
            for (int axis = 0; axis < 3; ++axis)
                for (double sign : {1.0, -1.0}) {
                    Vec3d l{0, 0, 0};
                    l[axis] = sign;
                    directions.push_back(l);
                }
            for (const Vec3d& l : directions) {
                const double expected = vox::attenuate(mode, normals, l);
                const double got = p.response(l);
                if (std::abs(got - expected) > worst[m].difference)
                    worst[m] = {std::abs(got - expected), got, expected, d(normals.mean), l};
            }
        }
    }
    for (int m = 0; m < kModes; ++m) {
        const Worst& w = worst[m];
        std::printf("[lightcuts] voxel response vs attenuate, %-8s largest difference %.3g\n",
                    name(kAttenuations[m]), w.difference);
        EXPECT_LE(w.difference, 1e-12)
            << name(kAttenuations[m]) << ": response " << w.got << " vs attenuate " << w.expected
            << " for mean normal (" << w.mean.x << ", " << w.mean.y << ", " << w.mean.z
            << "), l = (" << w.l.x << ", " << w.l.y << ", " << w.l.z << ")";
    }
    // The plain Lambertian point is max(0, n·l).
    const vox::LightcutPoint lambert =
        vox::LightcutPoint::lambertian({0, 0, 0}, {0, 0, 2}, {1, 1, 1});
    EXPECT_EQ(lambert.normal, (Vec3d{0, 0, 1}));
    EXPECT_FALSE(lambert.axisWeighted);
    EXPECT_NEAR(lambert.response(vox::normalize(Vec3d{1, 0, 1})), std::sqrt(0.5), 1e-15);
    EXPECT_EQ(lambert.response({0, 0, -1}), 0.0);
    // A thin wall (both sides, mean normal cancelled): Weighted still lights the side facing the
    // light.
    vox::VoxelNormals wall;
    wall.mean = {0, 0, 0};
    wall.moments = {0, 0, 0, 0, 0.5f, 0.5f};
    const auto w =
        vox::LightcutPoint::voxel({0, 0, 0}, wall, vox::Attenuation::Weighted, {1, 1, 1});
    EXPECT_DOUBLE_EQ(w.response({0, 0, 1}), 0.5);
    EXPECT_DOUBLE_EQ(w.response({0, 0, -1}), 0.5);
    EXPECT_EQ(w.response({1, 0, 0}), 0.0);
}

TEST(Attenuation, AdaptiveIsTheCosineOnAPlaneAndWeightedWhereTheSurfaceFolds) {
    // A tilted plane, lit from outside its normal's octant: Weighted drops the negative axis term
    // and over-lights; Adaptive is the cosine.
    const Vec3d n = vox::normalize(Vec3d{1, 1, 0});
    vox::VoxelNormals plane;
    plane.mean = f(n);
    plane.moments = {float(n.x), 0, float(n.y), 0, 0, 0};
    const Vec3d l = vox::normalize(Vec3d{-0.5, 1, 0.2});
    const double cosine = dot(n, l);
    ASSERT_GT(cosine, 0.1);
    EXPECT_NEAR(vox::attenuate(vox::Attenuation::Adaptive, plane, l), cosine, 1e-6);
    EXPECT_GT(vox::attenuate(vox::Attenuation::Weighted, plane, l), cosine + 0.3);
    EXPECT_EQ(vox::adaptiveAttenuation(plane).flat, 1.0);
    // A box's edge, two faces along +x and +y of equal area: Weighted is exact there, and so is
    // Adaptive (|m| = 0.71, no flat share): light along (−0.6, 0.8) reaches the +y face only.
    vox::VoxelNormals edge;
    edge.mean = f(vox::normalize(Vec3d{1, 1, 0}));
    edge.moments = {0.5f, 0, 0.5f, 0, 0, 0};
    const Vec3d side = vox::normalize(Vec3d{-0.6, 0.8, 0});
    EXPECT_EQ(vox::adaptiveAttenuation(edge).flat, 0.0);
    EXPECT_NEAR(vox::attenuate(vox::Attenuation::Adaptive, edge, side), 0.5 * side.y, 1e-6);
    EXPECT_LT(vox::attenuate(vox::Attenuation::Average, edge, side), 0.5 * side.y - 0.1);
    // A thin wall's two sides: no flat share either, each side lit from its own.
    vox::VoxelNormals wall;
    wall.moments = {0, 0, 0, 0, 0.5f, 0.5f};
    EXPECT_EQ(vox::adaptiveAttenuation(wall).flat, 0.0);
    EXPECT_DOUBLE_EQ(vox::attenuate(vox::Attenuation::Adaptive, wall, {0, 0, -1}), 0.5);
    // Lightcuts' point gives the same response.
    const auto p =
        vox::LightcutPoint::voxel({0, 0, 0}, plane, vox::Attenuation::Adaptive, {1, 1, 1});
    EXPECT_FALSE(p.axisWeighted);
    EXPECT_NEAR(p.response(l), cosine, 1e-6);
    // Half flat (|m| = 0.945): half the cosine, half Weighted.
    vox::VoxelNormals fold;
    fold.moments = {0.945f, 0, 0, 0, 0, 0};
    const double t = vox::adaptiveAttenuation(fold).flat;
    EXPECT_NEAR(t, 0.5, 1e-6);
    const Vec3d oblique = vox::normalize(Vec3d{1, 0, 1});
    EXPECT_NEAR(vox::attenuate(vox::Attenuation::Adaptive, fold, oblique),
                t * oblique.x + (1 - t) * 0.945 * oblique.x, 1e-6);
    const auto q =
        vox::LightcutPoint::voxel({0, 0, 0}, fold, vox::Attenuation::Adaptive, {1, 1, 1});
    EXPECT_TRUE(q.axisWeighted);
    EXPECT_NEAR(q.response(oblique), vox::attenuate(vox::Attenuation::Adaptive, fold, oblique),
                1e-12);
}

TEST(LightcutBound, AxisWeightedIsConservative) {
    LightMix mix;
    mix.directional = 4;
    mix.lo = {-4, -1, -4};
    mix.hi = {4, 4, 4};
    int positive = 0, checked = 0;
    for (bool forest : {true, false}) {
        vox::LightTreeOptions options;
        options.forest = forest;
        const LightTree tree(randomLights(300, forest ? 41 : 42, mix), options);
        const auto& nodes = tree.nodes();
        Rng rng(43);
        std::vector<Vec3d> exact(nodes.size());
        for (int trial = 0; trial < 150; ++trial) {
            // Points among the lights too (inside their boxes), any normals, coloured albedo.
            const Vec3d p{rng.uniform(-6, 6), rng.uniform(-2, 5), rng.uniform(-6, 6)};
            const vox::VoxelNormals normals =
                trial % 3 == 0 ? randomNormals(rng) : fragmentNormals(rng, rng.unit(), 1.0);
            const Vec3d albedo{rng.uniform(0, 1), rng.uniform(0, 1), rng.uniform(0, 1)};
            const vox::Attenuation mode = trial % 4 == 3   ? vox::Attenuation::Paper
                                          : trial % 4 == 2 ? vox::Attenuation::Adaptive
                                                           : vox::Attenuation::Weighted;
            const vox::LightcutPoint point = vox::LightcutPoint::voxel(p, normals, mode, albedo);
            ASSERT_TRUE(point.axisWeighted || mode == vox::Attenuation::Adaptive);
            // Children come before their parents in nodes(): sum the subtree totals upwards.
            for (std::size_t k = 0; k < nodes.size(); ++k)
                exact[k] = nodes[k].leaf() ? vox::lightContribution(
                                                 tree.lights()[nodes[k].representative], point)
                                           : exact[nodes[k].left] + exact[nodes[k].right];
            for (std::size_t k = 0; k < nodes.size(); ++k) {
                const Vec3d bound = vox::lightcutBound(tree, std::uint32_t(k), point);
                ++checked;
                positive += vox::lightLuminance(exact[k]) > 0;
                for (int c = 0; c < 3; ++c)
                    ASSERT_GE(bound[c], exact[k][c] * (1 - 1e-12))
                        << "node " << k << " channel " << c << " trial " << trial
                        << (forest ? " forest" : " classic");
            }
        }
    }
    // Not vacuous: most subtrees light the points.
    EXPECT_GT(positive, checked / 2);
}

TEST(Lightcuts, AxisWeightedAgainstBruteForce) {
    // Voxel points on a floor (y ∈ [0, 0.5]): mostly the bake's Weighted response, some Paper and
    // Average; the default options (root-sum-square criterion, 2 %).
    LightMix ranged;
    ranged.rangedShare = 1;
    ranged.rangeLo = 3;
    ranged.rangeHi = 8;
    const LightTree forest(randomLights(300, 44, ranged));
    LightMix mixed;
    mixed.directional = 3;
    vox::LightTreeOptions classicOptions;
    classicOptions.forest = false;
    const LightTree classic(randomLights(300, 45, mixed), classicOptions);
    const vox::LightcutOptions options;
    ASSERT_EQ(options.criterion, vox::LightcutCriterion::RootSumSquare);
    for (const LightTree* tree : {&forest, &classic}) {
        Rng rng(46);
        AccuracyStats s;
        int lit = 0;
        for (int i = 0; i < 300; ++i) {
            const Vec3d p{rng.uniform(-11, 11), rng.uniform(0, 0.5), rng.uniform(-11, 11)};
            const vox::VoxelNormals normals = fragmentNormals(rng, {0, 1, 0}, i % 2 ? 0.3 : 1.2);
            const Vec3d albedo{rng.uniform(0.2, 1), rng.uniform(0.2, 1), rng.uniform(0.2, 1)};
            const vox::Attenuation mode = i % 5 == 3   ? vox::Attenuation::Paper
                                          : i % 5 == 4 ? vox::Attenuation::Average
                                          : i % 5 == 2 ? vox::Attenuation::Adaptive
                                                       : vox::Attenuation::Weighted;
            const vox::LightcutPoint point = vox::LightcutPoint::voxel(p, normals, mode, albedo);
            const auto cut = vox::evaluateCut(*tree, point, options);
            const auto exact = vox::bruteForce(*tree, point);
            lit += vox::lightLuminance(exact.radiance) > 0;
            s.add(cut, exact, options.relativeError);
            // The cut meets the criterion, from the axis-weighted bounds anew.
            if (!cut.stats.truncated) {
                double sum = 0, sum2 = 0;
                for (std::uint32_t k : cut.cut) {
                    if (tree->nodes()[k].leaf()) continue;
                    const double b = vox::lightLuminance(vox::lightcutBound(*tree, k, point));
                    sum += b;
                    sum2 += b * b;
                }
                EXPECT_NEAR(sum, cut.errorBound, 1e-9 * sum + 1e-300);
                EXPECT_LE(std::sqrt(sum2),
                          options.relativeError * vox::lightLuminance(cut.radiance) * (1 + 1e-9));
            }
        }
        EXPECT_GT(lit, 250);
        s.expectAccuracy(options.criterion, tree == &forest ? "axis-weighted voxels, forest"
                                                            : "axis-weighted voxels, classic");
    }
}
