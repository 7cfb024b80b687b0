// Direct light at many render points from many lights: spatial clusters of render points with
// their cluster–light lists and cut reuse (the paper's 1.3 and 1.4), classic Lightcuts and brute
// force for comparison.
#include <vox/base/error.h>
#include <vox/many_lights.h>
#include <vox/util/progress.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <tuple>

namespace vox {

namespace {

constexpr double kPi = 3.14159265358979323846;

using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point start) {
    return std::chrono::duration<double>(Clock::now() - start).count();
}

/// Interleaves the low 10 bits of x, y and z (x lowest), the Morton code of a cell.
std::uint32_t mortonOf(const std::array<std::uint32_t, 3>& cell) {
    const auto spread = [](std::uint32_t v) {
        v &= 0x3FFu;
        v = (v | (v << 16)) & 0x030000FFu;
        v = (v | (v << 8)) & 0x0300F00Fu;
        v = (v | (v << 4)) & 0x030C30C3u;
        v = (v | (v << 2)) & 0x09249249u;
        return v;
    };
    return spread(cell[0]) | (spread(cell[1]) << 1) | (spread(cell[2]) << 2);
}

bool allSimilar(std::span<const LightcutPoint> points, const std::uint32_t* first,
                const std::uint32_t* last, const SimilarityOptions& options) {
    for (const std::uint32_t* p = first + 1; p < last; ++p)
        if (!similarRenderPoints(points[*first], points[*p], options)) return false;
    return true;
}

/// Appends the points [first, last) to @p out as one cluster, grouped into runs of similar points.
void appendCluster(std::span<const LightcutPoint> points, const std::uint32_t* first,
                   const std::uint32_t* last, const SimilarityOptions& options,
                   RenderPointClusters& out) {
    out.begin.push_back(std::uint32_t(out.order.size()));
    std::vector<std::vector<std::uint32_t>> runs;
    for (const std::uint32_t* p = first; p < last; ++p) {
        auto run = std::find_if(runs.begin(), runs.end(), [&](const std::vector<std::uint32_t>& r) {
            return similarRenderPoints(points[r.front()], points[*p], options);
        });
        if (run != runs.end())
            run->push_back(*p);
        else
            runs.push_back({*p});
    }
    for (const auto& run : runs) {
        out.runs.push_back(std::uint32_t(out.order.size()));
        out.order.insert(out.order.end(), run.begin(), run.end());
    }
}

void addStats(ManyLightStats& total, const LightcutStats& s) {
    total.cutNodes += s.cutSize;
    total.searchSteps += s.searchSteps;
    total.lightEvaluations += s.lightEvaluations;
    total.visibilityEvaluations += s.visibilityEvaluations;
    total.treesSearched += s.treesSearched;
    total.truncated += s.truncated ? 1 : 0;
}

void addStats(ManyLightStats& total, const ManyLightStats& s) {
    total.cutNodes += s.cutNodes;
    total.searchSteps += s.searchSteps;
    total.lightEvaluations += s.lightEvaluations;
    total.visibilityEvaluations += s.visibilityEvaluations;
    total.visibilityShared += s.visibilityShared;
    total.sharedVisibilityTests += s.sharedVisibilityTests;
    total.treesSearched += s.treesSearched;
    total.truncated += s.truncated;
}

LightVisibility visibilityAt(const PointVisibility& visibility, std::size_t point) {
    if (!visibility) return {};
    return [&visibility, point](const Light& light, const LightArrival& arrival) {
        return visibility(point, light, arrival);
    };
}

std::size_t staticLightCount(std::span<const Light> lights) {
    return static_cast<std::size_t>(
        std::count_if(lights.begin(), lights.end(), [](const Light& l) { return !l.dynamic; }));
}

}  // namespace

LightcutsMode parseLightcutsMode(const std::string& text) {
    if (text == "auto") return LightcutsMode::Auto;
    if (text == "on") return LightcutsMode::On;
    if (text == "off") return LightcutsMode::Off;
    throw ParameterError("lightcuts", "must be auto, on or off (got '" + text + "')");
}

LightcutCriterion parseLightcutCriterion(const std::string& text) {
    if (text == "per-node") return LightcutCriterion::PerNode;
    if (text == "sum") return LightcutCriterion::Sum;
    if (text == "rss") return LightcutCriterion::RootSumSquare;
    throw ParameterError("lightcutCriterion", "must be per-node, sum or rss (got '" + text + "')");
}

const char* lightcutCriterionName(LightcutCriterion criterion) {
    switch (criterion) {
        case LightcutCriterion::PerNode:
            return "per-node";
        case LightcutCriterion::Sum:
            return "sum";
        case LightcutCriterion::RootSumSquare:
            return "rss";
    }
    return "?";
}

bool similarRenderPoints(const LightcutPoint& a, const LightcutPoint& b,
                         const SimilarityOptions& options) {
    for (int k = 0; k < 3; ++k)
        if (std::abs(a.albedo[k] - b.albedo[k]) > options.albedoTolerance) return false;
    if (a.axisWeighted != b.axisWeighted) return false;
    return dot(a.normal, b.normal) >= std::cos(options.normalDegrees * kPi / 180);
}

RenderPointClusters clusterVoxelPoints(std::span<const LightcutPoint> points,
                                       std::span<const std::array<std::uint32_t, 3>> cells,
                                       std::uint32_t depth, std::uint32_t maxPoints,
                                       std::uint32_t minCells,
                                       const SimilarityOptions& similarity) {
    if (cells.size() != points.size()) throw UsageError("clusterVoxelPoints: one cell per point");
    if (depth > 10) throw UsageError("clusterVoxelPoints: depth at most 10");
    maxPoints = std::max<std::uint32_t>(maxPoints, 1);
    std::vector<std::uint32_t> codes(points.size());
    std::vector<std::uint32_t> sorted(points.size());
    for (std::uint32_t i = 0; i < points.size(); ++i) {
        codes[i] = mortonOf(cells[i]);
        sorted[i] = i;
    }
    std::sort(sorted.begin(), sorted.end(), [&](std::uint32_t a, std::uint32_t b) {
        return std::tie(codes[a], a) < std::tie(codes[b], b);
    });
    // The level whose nodes are minCells cells wide: the subdivision stops there.
    std::uint32_t finest = depth;
    for (std::uint32_t edge = 1; edge < minCells && finest > 0; edge *= 2) --finest;
    RenderPointClusters out;
    out.order.reserve(points.size());
    // Depth-first over the octree: a node is a contiguous range of the Morton order.
    struct Node {
        std::uint32_t first, last, level;
    };
    std::vector<Node> stack;
    if (!points.empty()) stack.push_back({0, std::uint32_t(points.size()), 0});
    while (!stack.empty()) {
        const Node node = stack.back();
        stack.pop_back();
        const std::uint32_t* first = sorted.data() + node.first;
        const std::uint32_t* last = sorted.data() + node.last;
        if (node.level >= finest ||
            (node.last - node.first <= maxPoints && allSimilar(points, first, last, similarity))) {
            appendCluster(points, first, last, similarity, out);
            continue;
        }
        // Children in reverse, so that they come off the stack in Morton order.
        const std::uint32_t shift = 3 * (depth - node.level - 1);
        std::uint32_t end = node.last;
        for (int child = 7; child >= 0; --child) {
            const std::uint32_t* split = std::partition_point(first, last, [&](std::uint32_t i) {
                return int((codes[i] >> shift) & 7u) < child;
            });
            const auto begin = std::uint32_t(split - sorted.data());
            if (begin < end) stack.push_back({begin, end, node.level + 1});
            end = begin;
        }
    }
    out.begin.push_back(std::uint32_t(points.size()));
    return out;
}

RenderPointClusters clusterPixelPoints(std::span<const LightcutPoint> points,
                                       std::span<const std::array<std::uint32_t, 2>> pixels,
                                       std::span<const double> depths, const PinholeCamera& camera,
                                       std::uint32_t tilePixels, std::uint32_t minTilePixels,
                                       const SimilarityOptions& similarity) {
    if (pixels.size() != points.size() || depths.size() != points.size())
        throw UsageError("clusterPixelPoints: one pixel and depth per point");
    camera.validate();
    tilePixels = std::max<std::uint32_t>(tilePixels, 1);
    RenderPointClusters out;
    if (points.empty()) {
        out.begin.push_back(0);
        return out;
    }
    // Slab boundaries C_i = C_0 × q^i: a tile of tilePixels pixels is 2 tan(γ/2) × C × tilePixels /
    // height wide at depth C, and the slab from C that deep.
    double nearest = std::numeric_limits<double>::infinity();
    for (double z : depths)
        if (z > 0) nearest = std::min(nearest, z);
    if (!std::isfinite(nearest)) nearest = 1;
    const double tanHalf = std::tan(0.5 * camera.fovYDegrees * kPi / 180);
    const double logRatio = std::log1p(2 * tanHalf * double(tilePixels) / double(camera.height));
    const auto slabOf = [&](double z) {
        return z > nearest ? std::uint32_t(std::floor(std::log(z / nearest) / logRatio)) : 0u;
    };

    // (tile y, tile x, slab) → points, in scanline order.
    std::map<std::tuple<std::uint32_t, std::uint32_t, std::uint32_t>, std::vector<std::uint32_t>>
        cells;
    std::vector<std::uint32_t> byPixel(points.size());
    for (std::uint32_t i = 0; i < points.size(); ++i) byPixel[i] = i;
    std::sort(byPixel.begin(), byPixel.end(), [&](std::uint32_t a, std::uint32_t b) {
        return std::tie(pixels[a][1], pixels[a][0], a) < std::tie(pixels[b][1], pixels[b][0], b);
    });
    for (std::uint32_t i : byPixel)
        cells[{pixels[i][1] / tilePixels, pixels[i][0] / tilePixels, slabOf(depths[i])}].push_back(
            i);

    // Adaptive subdivision of a cell's tile into quarters while its points differ.
    struct Tile {
        std::vector<std::uint32_t> members;
        std::uint32_t x0, y0, size;
    };
    for (auto& [key, members] : cells) {
        std::vector<Tile> stack;
        stack.push_back({std::move(members), std::get<1>(key) * tilePixels,
                         std::get<0>(key) * tilePixels, tilePixels});
        while (!stack.empty()) {
            Tile tile = std::move(stack.back());
            stack.pop_back();
            const std::uint32_t* first = tile.members.data();
            const std::uint32_t* last = first + tile.members.size();
            if (tile.size <= minTilePixels || allSimilar(points, first, last, similarity)) {
                appendCluster(points, first, last, similarity, out);
                continue;
            }
            const std::uint32_t half = (tile.size + 1) / 2;
            std::array<Tile, 4> quarters;
            for (int q = 0; q < 4; ++q)
                quarters[std::size_t(q)] = {
                    {}, tile.x0 + (q & 1 ? half : 0), tile.y0 + (q & 2 ? half : 0), half};
            for (std::uint32_t i : tile.members) {
                const int q = (pixels[i][0] >= tile.x0 + half ? 1 : 0) |
                              (pixels[i][1] >= tile.y0 + half ? 2 : 0);
                quarters[std::size_t(q)].members.push_back(i);
            }
            for (int q = 3; q >= 0; --q)
                if (!quarters[std::size_t(q)].members.empty())
                    stack.push_back(std::move(quarters[std::size_t(q)]));
        }
    }
    out.begin.push_back(std::uint32_t(out.order.size()));
    return out;
}

Bounds3f renderPointRegion(std::span<const LightcutPoint> points,
                           std::span<const std::uint32_t> members) {
    Bounds3f region;
    for (const std::uint32_t i : members) {
        const Vec3d p = points[i].position;
        region.add(Vec3f{float(p.x), float(p.y), float(p.z)});
    }
    if (region.empty()) return region;
    // Pad by float rounding, so that the box holds every point.
    const Vec3f pad = (region.max - region.min) * 1e-6f +
                      Vec3f{1e-6f, 1e-6f, 1e-6f} *
                          std::max({std::abs(region.min.x), std::abs(region.min.y),
                                    std::abs(region.min.z), std::abs(region.max.x),
                                    std::abs(region.max.y), std::abs(region.max.z), 1.0f});
    region.min = region.min - pad;
    region.max = region.max + pad;
    return region;
}

ManyLightStats lightPoints(const LightTree& tree, std::span<const LightcutPoint> points,
                           const RenderPointClusters& clusters, const ManyLightOptions& options,
                           const PointVisibility& visibility, std::span<Vec3d> out) {
    if (out.size() != points.size()) throw UsageError("lightPoints: one output per point");
    const auto start = Clock::now();
    ManyLightStats total;
    total.method = "lightcuts";
    total.points = points.size();
    total.lights = tree.leafCount();
    total.trees = tree.roots().size();
    total.clusters = clusters.count();
    total.runs = clusters.runs.size();
    if (clusters.count() == 0) {
        // Every point on its own: a fresh cut over every tree whose influence holds it.
        std::vector<LightcutStats> stats(points.size());
        Progress progress("direct light (" + total.method + ")", points.size());
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points.size(), 256),
                          [&](const tbb::blocked_range<std::size_t>& r) {
                              for (std::size_t i = r.begin(); i != r.end(); ++i) {
                                  LightcutResult result = evaluateCut(tree, points[i], options.cut,
                                                                      visibilityAt(visibility, i));
                                  out[i] = result.radiance;
                                  stats[i] = result.stats;
                              }
                              progress.advance(r.size());
                          });
        for (const LightcutStats& s : stats) addStats(total, s);
    } else {
        std::vector<ManyLightStats> perCluster(clusters.count());
        Progress progress("direct light (" + total.method + ")", points.size());
        tbb::parallel_for(
            tbb::blocked_range<std::size_t>(0, clusters.count(), 1),
            [&](const tbb::blocked_range<std::size_t>& r) {
                LightcutCursor cursor(tree, options.cut);
                for (std::size_t c = r.begin(); c != r.end(); ++c) {
                    const std::uint32_t first = clusters.begin[c], last = clusters.begin[c + 1];
                    if (options.clusterLists) {
                        const Bounds3f region =
                            renderPointRegion(points, std::span<const std::uint32_t>(clusters.order)
                                                          .subspan(first, last - first));
                        cursor.setRoots(tree.rootsOverlapping(region), region);
                    } else {
                        cursor.clearRoots();
                    }
                    ManyLightStats& s = perCluster[c];
                    SharedVisibilityStats shared;
                    ClusterVisibility clusterVisibility;
                    if (options.clusterVisibility)
                        clusterVisibility =
                            options.clusterVisibility(std::span<const std::uint32_t>(clusters.order)
                                                          .subspan(first, last - first),
                                                      shared);
                    // One callback per cluster, reading the point being lit.
                    const Light* lightsBegin = tree.lights().data();
                    std::size_t current = 0;
                    LightVisibility clusterPointVisibility;
                    if (clusterVisibility)
                        clusterPointVisibility = [&clusterVisibility, &current, lightsBegin](
                                                     const Light& light,
                                                     const LightArrival& arrival) {
                            return clusterVisibility(current, std::uint32_t(&light - lightsBegin),
                                                     light, arrival);
                        };
                    else if (visibility)
                        clusterPointVisibility = [&visibility, &current](
                                                     const Light& light,
                                                     const LightArrival& arrival) {
                            return visibility(current, light, arrival);
                        };
                    auto run = std::lower_bound(clusters.runs.begin(), clusters.runs.end(), first);
                    for (std::uint32_t k = first; k < last; ++k) {
                        const std::uint32_t i = clusters.order[k];
                        const bool runStarts = run != clusters.runs.end() && *run == k;
                        if (runStarts) ++run;
                        if (!options.reuseCuts || runStarts) cursor.reset();
                        current = i;
                        const LightcutResult result =
                            cursor.evaluate(points[i], clusterPointVisibility);
                        out[i] = result.radiance;
                        addStats(s, result.stats);
                    }
                    s.visibilityShared += shared.answered;
                    s.sharedVisibilityTests += shared.tests;
                    progress.advance(last - first);
                }
            });
        for (const ManyLightStats& s : perCluster) addStats(total, s);
    }
    total.seconds = secondsSince(start);
    return total;
}

ManyLightStats lightPointsBruteForce(std::span<const Light> lights,
                                     std::span<const LightcutPoint> points,
                                     const PointVisibility& visibility, std::span<Vec3d> out) {
    if (out.size() != points.size())
        throw UsageError("lightPointsBruteForce: one output per point");
    const auto start = Clock::now();
    std::vector<const Light*> used;
    for (const Light& light : lights)
        if (!light.dynamic) used.push_back(&light);
    ManyLightStats total;
    total.method = "brute-force";
    total.points = points.size();
    total.lights = used.size();
    std::vector<std::uint64_t> visibilityCalls(points.size(), 0);
    Progress progress("direct light (every light)", points.size());
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points.size(), 256),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                          for (std::size_t i = r.begin(); i != r.end(); ++i) {
                              const LightcutPoint& p = points[i];
                              Vec3d sum{0, 0, 0};
                              for (const Light* light : used) {
                                  LightArrival arrival;
                                  if (!lightArrival(*light, p.position, arrival)) continue;
                                  const double response = p.response(arrival.toLight);
                                  if (!(response > 0)) continue;
                                  double v = 1;
                                  if (visibility) {
                                      ++visibilityCalls[i];
                                      v = visibility(i, *light, arrival);
                                      v = v > 0 ? std::min(v, 1.0) : 0.0;
                                      if (v == 0) continue;
                                  }
                                  sum += arrival.irradiance * (response * v);
                              }
                              out[i] = p.albedo * (1 / kPi) * sum;
                          }
                          progress.advance(r.size());
                      });
    total.cutNodes = total.lightEvaluations = std::uint64_t(points.size()) * used.size();
    for (std::uint64_t v : visibilityCalls) total.visibilityEvaluations += v;
    total.seconds = secondsSince(start);
    return total;
}

LightcutErrorStats compareWithBruteForce(std::span<const Vec3d> estimate,
                                         std::span<const Vec3d> exact, double threshold) {
    if (estimate.size() != exact.size()) throw UsageError("compareWithBruteForce: sizes differ");
    LightcutErrorStats s;
    s.threshold = threshold;
    double sum = 0;
    for (std::size_t i = 0; i < exact.size(); ++i) {
        const double ref = lightLuminance(exact[i]);
        if (!(ref > 0)) continue;
        const double rel = std::abs(lightLuminance(estimate[i]) - ref) / ref;
        ++s.points;
        if (rel <= threshold) ++s.within;
        s.maxRelative = std::max(s.maxRelative, rel);
        sum += rel;
    }
    s.meanRelative = s.points ? sum / double(s.points) : 0;
    return s;
}

ManyLightReport directLight(std::span<const Light> lights, std::span<const LightcutPoint> points,
                            LightcutsMode mode, const LightcutOptions& cut, bool compare,
                            const std::function<RenderPointClusters()>& clusters,
                            const PointVisibility& visibility, std::span<Vec3d> out,
                            const ClusterVisibilityFactory& clusterVisibility) {
    ManyLightReport report;
    const bool useLightcuts =
        mode == LightcutsMode::On ||
        (mode == LightcutsMode::Auto && staticLightCount(lights) >= kLightcutsAutoLights);
    const auto runLightcuts = [&](std::span<Vec3d> into) {
        auto start = Clock::now();
        const LightTree tree(lights);
        const double treeSeconds = secondsSince(start);
        start = Clock::now();
        const RenderPointClusters groups = clusters ? clusters() : RenderPointClusters{};
        const double clusterSeconds = secondsSince(start);
        ManyLightStats s = lightPoints(tree, points, groups, {cut, true, true, clusterVisibility},
                                       visibility, into);
        s.treeSeconds = treeSeconds;
        s.clusterSeconds = clusterSeconds;
        return s;
    };
    std::vector<Vec3d> brute;
    if (compare) {
        report.compared = true;
        brute.resize(points.size());
        report.bruteForce = lightPointsBruteForce(lights, points, visibility, brute);
        std::vector<Vec3d> lc(points.size());
        report.lightcuts = runLightcuts(lc);
        report.lightcutsError = compareWithBruteForce(lc, brute, cut.relativeError);
        auto start = Clock::now();
        LightTreeOptions classicOptions;
        classicOptions.forest = false;
        const LightTree classicTree(lights, classicOptions);
        const double treeSeconds = secondsSince(start);
        std::vector<Vec3d> classic(points.size());
        report.classic =
            lightPoints(classicTree, points, {}, {cut, false, false, {}}, visibility, classic);
        report.classic.method = "classic";
        report.classic.treeSeconds = treeSeconds;
        report.classicError = compareWithBruteForce(classic, brute, cut.relativeError);
        if (useLightcuts) {
            std::copy(lc.begin(), lc.end(), out.begin());
            report.used = report.lightcuts;
        } else {
            std::copy(brute.begin(), brute.end(), out.begin());
            report.used = report.bruteForce;
        }
        return report;
    }
    report.used =
        useLightcuts ? runLightcuts(out) : lightPointsBruteForce(lights, points, visibility, out);
    return report;
}

}  // namespace vox
