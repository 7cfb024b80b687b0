// The radiance bake's diffuse irradiance against the Monte Carlo path-traced reference
// (tests/support/path_reference.h): bakes the scene with per-voxel lighting kept, picks voxels
// that stand for one surface, estimates the reference on that surface, and prints JSON with the
// bake's error per bounce (1, 2) and for direct light, next to the reference's own noise.
//
// Usage: radiance_accuracy SCENE [--depth D=6] [--points N=300] [--samples S=65536] [--seed K=1]
//                          [--threads T=0 (all)] [--sun DX,DY,DZ,LUX] [--gather-strata G=32]
//                          [--json FILE]
//
// --sun adds a white directional light travelling along (DX, DY, DZ) to the scene the bake and the
// reference both see: for meshes without lights of their own, whose bounces are otherwise zero.
//
// Which voxels. A static voxel qualifies when the static triangles overlapping its cube (the
// bake's own conservative test) form one surface: every one faces within 20° of their
// area-weighted mean normal, and every one passes within h/4 (h: the cell edge) of the plane
// through the point nearest the centre, along that normal. That excludes corners and edges
// (two orientations), both sides of a thin wall or sheet (opposite normals, so also a cancelled
// mean normal), and parallel layers such as a light panel under a ceiling (two planes). From the
// qualifying voxels, in the bake's Morton order (spatially spread), N are taken at indices
// ⌊(i + ½)·M/N⌋: even and deterministic. Voxels whose surface has another surface less than
// three cells in front of it (a cavity the volume cannot resolve) are excluded and counted.
//
// Where the reference is evaluated. At the point of the voxel's surface nearest its centre, with
// the shading normal there (the front side, which the bake's mean normal also follows), not at
// the raw centre: the centre lies up to √3·h/2 off the surface, maybe inside a wall or behind
// the face, where a hemisphere sees the wall's inside or the surface from below; the voxel
// stands for its surface fragment, so that fragment's irradiance is what the bake approximates.
// (For a plane through the cube, the nearest point is the centre's projection onto it.)
//
// The numbers, all on luminance (Rec. 709 weights of linear RGB), per quantity:
//   mean_relative_error        Σ|E_bake − E_ref| / Σ E_ref  (the acceptance number, < 20 %)
//   bias                       Σ(E_bake − E_ref) / Σ E_ref
//   mean_point_relative_error  mean of |E_bake − E_ref| / E_ref over the points whose E_ref is at
//                              least 1 % of the mean E_ref (points_compared of them)
//   reference_relative_standard_error  √(Σ σ²) / Σ E_ref: the noise of the aggregated reference
//   reference_point_relative_standard_error  mean σ / E_ref over the compared points
//   reference_noise_bound      √(2/π)·Σσ / Σ E_ref: how far the reference's noise can move
//                              mean_relative_error in expectation (E|a + ε| ≤ |a| + σ√(2/π))
// Direct light is exact in the reference (shadow rays to punctual lights): its σ is 0.
// Bounce 1's error, split (summaries of the same form; G² stratified rays per point against the
// triangles, each reading the radiance its hit's voxel leaves, albedo/π × direct + emission):
//   bounce1_ray_gather_against_reference     those rays over the hemisphere against the reference:
//                                            what one radiance per level-0 voxel costs (thin
//                                            parts' two sides, the voxels' direct light; the
//                                            bake's rays read a two-sided voxel's sides apart)
//   bounce1_cone_layout_against_ray_gather   the rays inside each diffuse cone, averaged and
//                                            weighted as the gather weights its cones, against
//                                            the hemisphere: what seven cones cost
//   bounce1_cones_against_ray_gather         the bake's cones against the hemisphere's rays: the
//                                            cone layout and the volume's sampling together
//   bounce1_voxel_ray_gather_against_reference  the hemisphere's rays marched through the level-0
//                                            voxels instead (no triangles), each hitting the first
//                                            voxel more than --voxel-ray-plane cells (2) in front
//                                            of the point's tangent plane: its whole cube, or with
//                                            --voxel-ray-hit slab only where the ray crosses the
//                                            voxel's plane (its centre, its mean normal)
// Also in the JSON: `worst`, the five worst points per quantity, and `every_point`, each point's
// cell, surface point, normal, [bake, reference] for direct, bounce1 and bounce2, and
// bounce1_ray_gather, bounce1_voxel_ray_gather and bounce1_cone_layout.
#include "path_reference.h"

#include "octree/triangle_box.h"
#include "scene/surface_shading.h"

#include <vox/base/error.h>
#include <vox/import.h>
#include <vox/radiance.h>
#include <vox/radiance_field.h>
#include <vox/triangle_raycast.h>
#include <vox/util/log.h>
#include <vox/util/parallel.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cmath>
#include <fstream>
#include <iostream>
#include <numbers>
#include <numeric>
#include <optional>
#include <span>
#include <string>
#include <unordered_map>

namespace {

using vox::Vec3d;

constexpr double kMaxNormalDegrees = 20;
constexpr double kMaxPlaneOffset = 0.25;  ///< in cell edges
/// Free space a surface needs in front of it, in cell edges: the bake's cones start 2 cells off
/// the surface, so a cavity thinner than that (a light panel 1.2 cells under the ceiling at depth
/// 8) is below what the volume can resolve. Such points are counted and reported, not compared.
constexpr double kMinClearanceCells = 3;

Vec3d toDouble(vox::Vec3f v) { return {v.x, v.y, v.z}; }

/// Barycentric weights of the point of triangle (a, b, c) nearest to @p p (Ericson, Real-Time
/// Collision Detection, 5.1.5): the Voronoi regions of the corners, then the edges, then the face.
Vec3d closestPointWeights(Vec3d p, Vec3d a, Vec3d b, Vec3d c) {
    const Vec3d ab = b - a, ac = c - a, ap = p - a;
    const double d1 = dot(ab, ap), d2 = dot(ac, ap);
    if (d1 <= 0 && d2 <= 0) return {1, 0, 0};
    const Vec3d bp = p - b;
    const double d3 = dot(ab, bp), d4 = dot(ac, bp);
    if (d3 >= 0 && d4 <= d3) return {0, 1, 0};
    const double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) {
        const double v = d1 / (d1 - d3);
        return {1 - v, v, 0};
    }
    const Vec3d cp = p - c;
    const double d5 = dot(ab, cp), d6 = dot(ac, cp);
    if (d6 >= 0 && d5 <= d6) return {0, 0, 1};
    const double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) {
        const double w = d2 / (d2 - d6);
        return {1 - w, 0, w};
    }
    const double va = d3 * d6 - d5 * d4;
    if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) {
        const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return {0, 1 - w, w};
    }
    const double denom = 1 / (va + vb + vc);
    const double v = vb * denom, w = vc * denom;
    return {1 - v - w, v, w};
}

struct StaticTriangle {
    vox::detail::TriangleSource source;
    std::array<Vec3d, 3> corners;
    vox::detail::BoxTestTriangle box;
    Vec3d normal;  ///< unit, of the winding
    double area = 0;
};

/// A voxel chosen for the comparison and where the reference is evaluated for it.
struct Sample {
    std::size_t voxel = 0;  ///< index into RadianceBake::voxels
    vox::reference::SurfacePoint point;
    double distance = 0;  ///< from the voxel centre to point.position
};

/// The surface point standing for voxel @p v, or nothing where the voxel does not qualify (see
/// the file comment).
std::optional<Sample> qualify(const vox::Scene& scene, const vox::VoxelLighting& v,
                              std::span<const std::uint32_t> overlapping,
                              const std::vector<StaticTriangle>& triangles, double cell) {
    if (overlapping.empty()) return std::nullopt;
    Vec3d sum{0, 0, 0};
    for (std::uint32_t t : overlapping) sum += triangles[t].normal * triangles[t].area;
    const Vec3d mean = normalize(sum);
    const double minCos = std::cos(kMaxNormalDegrees * std::numbers::pi / 180);
    double best = std::numeric_limits<double>::infinity();
    std::uint32_t nearest = 0;
    Vec3d nearestWeights, nearestPoint;
    std::vector<Vec3d> closest(overlapping.size());
    for (std::size_t i = 0; i < overlapping.size(); ++i) {
        const StaticTriangle& t = triangles[overlapping[i]];
        if (dot(t.normal, mean) < minCos) return std::nullopt;  // also a cancelled (zero) mean
        const Vec3d w = closestPointWeights(v.centre, t.corners[0], t.corners[1], t.corners[2]);
        closest[i] = t.corners[0] * w.x + t.corners[1] * w.y + t.corners[2] * w.z;
        const double d = length(closest[i] - v.centre);
        if (d < best)
            best = d, nearest = overlapping[i], nearestWeights = w, nearestPoint = closest[i];
    }
    for (const Vec3d& p : closest)
        if (std::abs(dot(mean, p - nearestPoint)) > kMaxPlaneOffset * cell) return std::nullopt;
    const StaticTriangle& t = triangles[nearest];
    const vox::detail::SurfaceSample s =
        vox::detail::shadeTriangle(scene, t.source, t.corners, nearestWeights, 0);
    Sample out;
    out.point.position = nearestPoint;
    out.point.normal = dot(s.normal, t.normal) < 0 ? -s.normal : s.normal;  // the front side
    out.distance = best;
    return out;
}

struct Compared {
    double bake = 0, reference = 0, standardError = 0;
};

nlohmann::json summarise(const std::vector<Compared>& values) {
    double sumRef = 0, sumBake = 0, sumAbs = 0, sumSigned = 0, sumVar = 0, sumSigma = 0;
    for (const Compared& c : values) {
        sumRef += c.reference;
        sumBake += c.bake;
        sumAbs += std::abs(c.bake - c.reference);
        sumSigned += c.bake - c.reference;
        sumVar += c.standardError * c.standardError;
        sumSigma += c.standardError;
    }
    const double meanRef = values.empty() ? 0 : sumRef / double(values.size());
    double pointError = 0, pointSigma = 0;
    std::size_t compared = 0;
    for (const Compared& c : values) {
        if (!(c.reference >= 0.01 * meanRef) || c.reference <= 0) continue;
        pointError += std::abs(c.bake - c.reference) / c.reference;
        pointSigma += c.standardError / c.reference;
        ++compared;
    }
    const auto ratio = [&](double x) { return sumRef > 0 ? x / sumRef : 0.0; };
    return {
        {"mean_relative_error", ratio(sumAbs)},
        {"bias", ratio(sumSigned)},
        {"mean_point_relative_error", compared ? pointError / double(compared) : 0.0},
        {"points_compared", compared},
        {"reference_mean", meanRef},
        {"bake_mean", values.empty() ? 0 : sumBake / double(values.size())},
        {"reference_relative_standard_error", ratio(std::sqrt(sumVar))},
        {"reference_point_relative_standard_error", compared ? pointSigma / double(compared) : 0.0},
        {"reference_noise_bound", ratio(std::sqrt(2 / std::numbers::pi) * sumSigma)}};
}

double seconds(std::chrono::steady_clock::time_point since) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

}  // namespace

int main(int argc, char** argv) {
    try {
        const std::string usage =
            "usage: radiance_accuracy SCENE [--depth D=6] [--points N=300] [--samples S=65536] "
            "[--seed K=1] [--threads T] [--sun DX,DY,DZ,LUX] [--gather-strata G=32] "
            "[--voxel-ray-plane P=2] [--voxel-ray-hit cube|slab] [--bounce-gather auto|cones|rays] "
            "[--gather-rays R=256] [--json FILE]";
        if (argc < 2) throw vox::UsageError(usage);
        std::uint32_t depth = 6, points = 300, gatherStrata = 32;
        double voxelRayPlane = 2;  // cells
        bool voxelRaySlab = false;
        vox::RadianceBakeOptions options;
        vox::reference::PathReferenceOptions reference;
        reference.samples = 65536;
        int threads = 0;
        std::string jsonFile;
        std::optional<vox::Light> sun;
        for (int i = 2; i < argc; i += 2) {
            const std::string key = argv[i];
            if (i + 1 >= argc) throw vox::UsageError(usage);
            const std::string value = argv[i + 1];
            if (key == "--depth")
                depth = static_cast<std::uint32_t>(std::stoul(value));
            else if (key == "--points")
                points = static_cast<std::uint32_t>(std::stoul(value));
            else if (key == "--samples")
                reference.samples = static_cast<std::uint32_t>(std::stoul(value));
            else if (key == "--seed")
                reference.seed = std::stoull(value);
            else if (key == "--threads")
                threads = std::stoi(value);
            else if (key == "--gather-strata")
                gatherStrata = static_cast<std::uint32_t>(std::stoul(value));
            else if (key == "--voxel-ray-plane")
                voxelRayPlane = std::stod(value);
            else if (key == "--voxel-ray-hit" && (value == "cube" || value == "slab"))
                voxelRaySlab = value == "slab";
            else if (key == "--bounce-gather" &&
                     (value == "cones" || value == "rays" || value == "auto"))
                options.bounceGather = value == "rays"    ? vox::BounceGather::Rays
                                       : value == "cones" ? vox::BounceGather::Cones
                                                          : vox::BounceGather::Auto;
            else if (key == "--gather-rays")
                options.gatherRays = static_cast<std::uint32_t>(std::stoul(value));
            else if (key == "--json")
                jsonFile = value;
            else if (key == "--sun") {
                double v[4];
                char tail = 0;
                if (std::sscanf(value.c_str(), "%lf,%lf,%lf,%lf%c", &v[0], &v[1], &v[2], &v[3],
                                &tail) != 4 ||
                    !(v[3] > 0) || !(v[0] * v[0] + v[1] * v[1] + v[2] * v[2] > 0))
                    throw vox::UsageError("--sun wants DX,DY,DZ,LUX (a direction, lux > 0)");
                vox::Light light;
                light.name = "sun";
                light.type = vox::Light::Type::Directional;
                light.intensity = static_cast<float>(v[3]);
                const Vec3d d = normalize(Vec3d{v[0], v[1], v[2]});
                light.direction = {static_cast<float>(d.x), static_cast<float>(d.y),
                                   static_cast<float>(d.z)};
                sun = light;
            } else
                throw vox::UsageError("unknown option " + key + "\n" + usage);
        }
        if (points == 0 || reference.samples < 2 || gatherStrata == 0 || gatherStrata > 256)
            throw vox::UsageError(
                "--points must be ≥ 1, --samples ≥ 2 and --gather-strata in 1…256");
        const vox::ThreadLimit limit(threads);
        vox::log::setVerbosity(vox::log::Verbosity::Quiet);  // the benchmark's output is its JSON
        vox::Scene scene = vox::importScene(argv[1]);
        if (sun) scene.lights.push_back(*sun);

        auto start = std::chrono::steady_clock::now();
        options.depth = depth;
        options.keepVoxelLighting = true;
        const vox::RadianceBake bake = vox::bakeRadiance(scene, options);
        const double bakeSeconds = seconds(start);
        if (options.bounces < 2) throw vox::UsageError("the bake must run two bounces");

        // Triangles overlapping each static voxel's cube: each static triangle against the cells
        // of its bounding box that hold a voxel.
        start = std::chrono::steady_clock::now();
        const double cell = bake.volume.cellSize(0);
        const Vec3d origin{bake.volume.origin[0], bake.volume.origin[1], bake.volume.origin[2]};
        std::unordered_map<std::uint64_t, std::size_t> voxelAt;
        for (std::size_t i = 0; i < bake.voxels.size(); ++i)
            voxelAt.emplace(
                vox::rvol::morton3(bake.voxels[i].x, bake.voxels[i].y, bake.voxels[i].z), i);
        std::vector<StaticTriangle> triangles;
        std::vector<std::vector<std::uint32_t>> overlapping(bake.voxels.size());
        const std::int64_t last = (std::int64_t{1} << depth) - 1;
        for (std::uint32_t m = 0; m < scene.meshes.size(); ++m) {
            const vox::Mesh& mesh = scene.meshes[m];
            if (mesh.dynamic) continue;
            for (std::uint32_t t = 0; t < mesh.triangleCount(); ++t) {
                StaticTriangle tri;
                tri.source = {m, t};
                for (int k = 0; k < 3; ++k)
                    tri.corners[k] =
                        toDouble(mesh.positions[mesh.indices[3 * std::size_t{t} + std::size_t(k)]]);
                tri.box =
                    vox::detail::prepareBoxTest(tri.corners[0], tri.corners[1], tri.corners[2]);
                tri.area = 0.5 * length(tri.box.normal);
                tri.normal = normalize(tri.box.normal);
                if (!(tri.area > 0)) continue;
                const auto id = static_cast<std::uint32_t>(triangles.size());
                std::array<std::int64_t, 3> lo{}, hi{};
                for (int a = 0; a < 3; ++a) {
                    const double mn =
                        std::min({tri.corners[0][a], tri.corners[1][a], tri.corners[2][a]});
                    const double mx =
                        std::max({tri.corners[0][a], tri.corners[1][a], tri.corners[2][a]});
                    // One cell of slack each way: touching counts as overlapping.
                    lo[a] = std::clamp<std::int64_t>(
                        std::int64_t(std::floor((mn - origin[a]) / cell)) - 1, 0, last);
                    hi[a] = std::clamp<std::int64_t>(
                        std::int64_t(std::floor((mx - origin[a]) / cell)) + 1, 0, last);
                }
                for (std::int64_t z = lo[2]; z <= hi[2]; ++z)
                    for (std::int64_t y = lo[1]; y <= hi[1]; ++y)
                        for (std::int64_t x = lo[0]; x <= hi[0]; ++x) {
                            const auto it = voxelAt.find(vox::rvol::morton3(
                                std::uint32_t(x), std::uint32_t(y), std::uint32_t(z)));
                            if (it == voxelAt.end()) continue;
                            if (vox::detail::triangleOverlapsCube(
                                    tri.box, bake.voxels[it->second].centre, cell / 2))
                                overlapping[it->second].push_back(id);
                        }
                triangles.push_back(tri);
            }
        }
        std::vector<Sample> candidates;
        std::size_t cavities = 0;
        const vox::TriangleRayCaster caster(scene);
        for (std::size_t i = 0; i < bake.voxels.size(); ++i)
            if (auto s = qualify(scene, bake.voxels[i], overlapping[i], triangles, cell)) {
                const vox::Ray ray{s->point.position + s->point.normal * (1e-4 * cell),
                                   s->point.normal};
                if (caster.castSurface(ray, kMinClearanceCells * cell).hit) {
                    ++cavities;
                    continue;
                }
                s->voxel = i;
                candidates.push_back(*s);
            }
        if (candidates.empty())
            throw vox::InvalidDataError(argv[1], "no voxel stands for a single surface");
        std::vector<Sample> chosen;
        const std::size_t n = std::min<std::size_t>(points, candidates.size());
        for (std::size_t i = 0; i < n; ++i)
            chosen.push_back(candidates[(2 * i + 1) * candidates.size() / (2 * n)]);
        const double selectSeconds = seconds(start);

        start = std::chrono::steady_clock::now();
        const vox::reference::PathReference tracer(scene);
        std::vector<vox::reference::SurfacePoint> where;
        for (const Sample& s : chosen) where.push_back(s.point);
        const std::vector<vox::reference::PointIrradiance> truth =
            tracer.estimate(where, reference);
        const double referenceSeconds = seconds(start);

        // Bounce 1 gathered by rays instead of cones (the split in the file comment).
        // The radiance the bake's voxel at the ray's hit leaves (0 on a miss, or where no voxel
        // holds the hit: counted in @p misses).
        const auto leavingLuminance = [](const vox::VoxelLighting& v) {
            return vox::reference::luminance(
                toDouble(v.albedo) * toDouble(v.direct) / std::numbers::pi + toDouble(v.emission));
        };
        const auto voxelRadiance = [&](Vec3d from, Vec3d dir, std::size_t& misses) {
            const vox::SurfaceHit h = caster.castSurface({from, dir});
            if (!h.hit) return 0.0;
            const Vec3d p = from + dir * h.t;
            std::uint32_t c[3];
            for (int a = 0; a < 3; ++a)
                c[a] = std::uint32_t(std::clamp<std::int64_t>(
                    std::int64_t(std::floor((p[a] - origin[a]) / cell)), 0, last));
            const auto it = voxelAt.find(vox::rvol::morton3(c[0], c[1], c[2]));
            if (it == voxelAt.end()) {
                ++misses;
                return 0.0;
            }
            return leavingLuminance(bake.voxels[it->second]);
        };
        // The same rays marched through the bake's level-0 voxels instead of the triangles (what a
        // bake could gather without them): the first voxel on the ray whose centre lies more than
        // --voxel-ray-plane cells in front of the point's tangent plane (so that the point's own
        // surface is not hit), reading the radiance it leaves; 0 where the ray leaves the cube.
        const std::int64_t cells = last + 1;
        const auto voxelMarch = [&](Vec3d from, Vec3d normal, Vec3d dir) {
            Vec3d g = (from - origin) / cell;  // grid units
            std::int64_t c[3], step[3];
            double tMax[3], tDelta[3];
            for (int a = 0; a < 3; ++a) {
                c[a] = std::int64_t(std::floor(g[a]));
                step[a] = dir[a] > 0 ? 1 : -1;
                tDelta[a] =
                    dir[a] != 0 ? std::abs(1 / dir[a]) : std::numeric_limits<double>::infinity();
                const double boundary = dir[a] > 0 ? double(c[a] + 1) : double(c[a]);
                tMax[a] = dir[a] != 0 ? (boundary - g[a]) / dir[a]
                                      : std::numeric_limits<double>::infinity();
            }
            while (c[0] >= 0 && c[1] >= 0 && c[2] >= 0 && c[0] < cells && c[1] < cells &&
                   c[2] < cells) {
                const auto it = voxelAt.find(vox::rvol::morton3(
                    std::uint32_t(c[0]), std::uint32_t(c[1]), std::uint32_t(c[2])));
                if (it != voxelAt.end()) {
                    const vox::VoxelLighting& v = bake.voxels[it->second];
                    const Vec3d centre =
                        origin +
                        Vec3d{double(c[0]) + 0.5, double(c[1]) + 0.5, double(c[2]) + 0.5} * cell;
                    // --voxel-ray-hit slab: a voxel is hit only where the ray crosses the plane
                    // through its centre along its mean normal inside its cell.
                    bool crosses = true;
                    if (voxelRaySlab) {
                        const Vec3d slabNormal = toDouble(v.normal);
                        const double denom = dot(dir, slabNormal);
                        crosses = false;
                        if (denom != 0) {
                            const double t = dot(centre - from, slabNormal) / denom;
                            const Vec3d x = (from + dir * t - centre) / cell;
                            crosses = t > 0 && std::abs(x.x) <= 0.5 && std::abs(x.y) <= 0.5 &&
                                      std::abs(x.z) <= 0.5;
                        }
                    }
                    if (crosses && dot(centre - from, normal) > voxelRayPlane * cell)
                        return leavingLuminance(v);
                }
                const int a =
                    tMax[0] < tMax[1] ? (tMax[0] < tMax[2] ? 0 : 2) : (tMax[1] < tMax[2] ? 1 : 2);
                c[a] += step[a];
                tMax[a] += tDelta[a];
            }
            return 0.0;
        };
        const std::uint32_t gatherRays = gatherStrata * gatherStrata;
        constexpr std::uint32_t kConeRays = 256;  // 16² strata
        std::vector<double> rayGather(chosen.size(), 0.0), coneLayoutGather(chosen.size(), 0.0),
            voxelRayGather(chosen.size(), 0.0);
        std::size_t rayGatherMisses = 0;
        const vox::RadianceField::DiffuseCones& cones = vox::RadianceField::diffuseCones();
        const double cosHalf = 1 / std::sqrt(1 + cones.tanHalf * cones.tanHalf);
        for (std::size_t i = 0; i < chosen.size(); ++i) {
            const Vec3d normal = chosen[i].point.normal;
            const Vec3d from = chosen[i].point.position + normal * (1e-4 * cell);
            // The hemisphere, cosine-distributed.
            double sum = 0, marched = 0;
            for (std::uint32_t r = 0; r < gatherRays; ++r) {
                const Vec3d dir = vox::reference::cosineDirection(
                    normal, (double(r % gatherStrata) + 0.5) / gatherStrata,
                    (double(r / gatherStrata) + 0.5) / gatherStrata);
                sum += voxelRadiance(from, dir, rayGatherMisses);
                marched += voxelMarch(from, normal, dir);
            }
            rayGather[i] = std::numbers::pi * sum / gatherRays;
            voxelRayGather[i] = std::numbers::pi * marched / gatherRays;
            // Each cone: uniform over its solid angle (what a cone's footprint averages).
            double layout = 0;
            const auto axes = cones.axes(normal);
            for (std::size_t k = 0; k < axes.size(); ++k) {
                const Vec3d axis = axes[k];
                const Vec3d ta = normalize(
                    cross(std::abs(axis.x) < 0.9 ? Vec3d{1, 0, 0} : Vec3d{0, 1, 0}, axis));
                const Vec3d ba = cross(axis, ta);
                double coneSum = 0;
                for (std::uint32_t r = 0; r < kConeRays; ++r) {
                    const double u = (double(r % 16) + 0.5) / 16, v = (double(r / 16) + 0.5) / 16;
                    const double cz = 1 - u * (1 - cosHalf), sz = std::sqrt(1 - cz * cz);
                    const double phi = 2 * std::numbers::pi * v;
                    const Vec3d dir =
                        ta * (sz * std::cos(phi)) + ba * (sz * std::sin(phi)) + axis * cz;
                    std::size_t ignored = 0;
                    if (dot(dir, normal) > 0) coneSum += voxelRadiance(from, dir, ignored);
                }
                layout += cones.weight(k) * coneSum / kConeRays;
            }
            coneLayoutGather[i] = layout;
        }

        std::vector<Compared> direct, bounce[2], conesAgainstRays, raysAgainstReference,
            coneLayoutAgainstRays, voxelRaysAgainstReference;
        std::size_t normalDisagrees = 0;
        double meanDistance = 0;
        nlohmann::json worst = nlohmann::json::object();
        std::vector<std::pair<double, std::size_t>> ranked[2];
        for (std::size_t i = 0; i < chosen.size(); ++i) {
            const vox::VoxelLighting& v = bake.voxels[chosen[i].voxel];
            if (v.indirect.size() < 2)
                throw vox::InvalidDataError(argv[1],
                                            "the bake kept fewer than two bounces per voxel");
            direct.push_back({vox::reference::luminance(toDouble(v.direct)),
                              vox::reference::luminance(truth[i].direct), 0});
            for (int b = 0; b < 2; ++b) {
                const auto& e = b == 0 ? truth[i].bounce1 : truth[i].bounce2;
                bounce[b].push_back(
                    {vox::reference::luminance(toDouble(v.indirect[std::size_t(b)])), e.luminance,
                     e.luminanceStandardError});
                ranked[b].push_back(
                    {e.luminance > 0 ? std::abs(bounce[b].back().bake - e.luminance) / e.luminance
                                     : 0.0,
                     i});
            }
            conesAgainstRays.push_back({bounce[0].back().bake, rayGather[i], 0});
            raysAgainstReference.push_back({rayGather[i], bounce[0].back().reference, 0});
            coneLayoutAgainstRays.push_back({coneLayoutGather[i], rayGather[i], 0});
            voxelRaysAgainstReference.push_back({voxelRayGather[i], bounce[0].back().reference, 0});
            normalDisagrees += dot(toDouble(v.normal), chosen[i].point.normal) <
                               std::cos(kMaxNormalDegrees * std::numbers::pi / 180);
            meanDistance += chosen[i].distance / cell;
        }
        // A listed point: its voxel's cell, the surface point and normal, bake and reference.
        const auto describe = [&](std::size_t i, const Compared& c) {
            const vox::VoxelLighting& v = bake.voxels[chosen[i].voxel];
            const Vec3d p = chosen[i].point.position, nn = chosen[i].point.normal;
            return nlohmann::json{{"cell", {v.x, v.y, v.z}},
                                  {"point", {p.x, p.y, p.z}},
                                  {"normal", {nn.x, nn.y, nn.z}},
                                  {"bake", c.bake},
                                  {"reference", c.reference}};
        };
        // The five worst points per bounce (among those bright enough to count), to look at.
        for (int b = 0; b < 2; ++b) {
            double meanRef = 0;
            for (const Compared& c : bounce[b]) meanRef += c.reference / double(bounce[b].size());
            std::erase_if(ranked[b], [&](const auto& r) {
                return bounce[b][r.second].reference < 0.01 * meanRef;
            });
            std::sort(ranked[b].begin(), ranked[b].end(), [](const auto& x, const auto& y) {
                return x.first > y.first || (x.first == y.first && x.second < y.second);
            });
            nlohmann::json list = nlohmann::json::array();
            for (std::size_t k = 0; k < std::min<std::size_t>(5, ranked[b].size()); ++k) {
                const std::size_t i = ranked[b][k].second;
                nlohmann::json entry = describe(i, bounce[b][i]);
                entry["relative_error"] = ranked[b][k].first;
                list.push_back(entry);
            }
            worst["bounce" + std::to_string(b + 1)] = list;
        }

        // Direct light: the five points that add most to Σ|bake − ref| (shadows the voxels miss
        // have a reference of 0, so a relative ranking would leave them out).
        {
            std::vector<std::size_t> order(direct.size());
            std::iota(order.begin(), order.end(), std::size_t{0});
            const auto gap = [&](std::size_t i) {
                return std::abs(direct[i].bake - direct[i].reference);
            };
            std::stable_sort(order.begin(), order.end(),
                             [&](std::size_t a, std::size_t b) { return gap(a) > gap(b); });
            nlohmann::json list = nlohmann::json::array();
            for (std::size_t k = 0; k < std::min<std::size_t>(5, order.size()); ++k) {
                const std::size_t i = order[k];
                nlohmann::json entry = describe(i, direct[i]);
                if (sun) {
                    // How far towards the sun the triangles occlude the point (cells; null:
                    // open): an occluder within a cell or two is one the voxels' shadow ray,
                    // which leaves from a cell off the surface, can miss.
                    const Vec3d toSun = -toDouble(sun->direction);
                    const vox::reference::SurfacePoint& at = chosen[i].point;
                    const vox::SurfaceHit h =
                        caster.castSurface({at.position + at.normal * (1e-4 * cell), toSun});
                    entry["sun_occluder_cells"] =
                        h.hit ? nlohmann::json(h.t / cell) : nlohmann::json(nullptr);
                }
                list.push_back(entry);
            }
            worst["direct"] = list;
        }

        // Every point, in the order picked: to plot or to compare two builds point by point.
        nlohmann::json everyPoint = nlohmann::json::array();
        for (std::size_t i = 0; i < chosen.size(); ++i) {
            nlohmann::json entry = describe(i, direct[i]);
            entry.erase("bake");
            entry.erase("reference");
            entry["direct"] = {direct[i].bake, direct[i].reference};
            entry["bounce1"] = {bounce[0][i].bake, bounce[0][i].reference};
            entry["bounce2"] = {bounce[1][i].bake, bounce[1][i].reference};
            entry["bounce1_ray_gather"] = rayGather[i];
            entry["bounce1_voxel_ray_gather"] = voxelRayGather[i];
            entry["bounce1_cone_layout"] = coneLayoutGather[i];
            everyPoint.push_back(entry);
        }

        const nlohmann::json b1 = summarise(bounce[0]), b2 = summarise(bounce[1]);
        constexpr double kLimit = 0.20, kNoiseLimit = 0.01;
        nlohmann::json out{
            {"scene", argv[1]},
            {"depth", depth},
            {"cell", cell},
            {"threads", vox::ThreadLimit::active()},
            {"lights", scene.lights.size()},
            {"static_voxels", bake.voxels.size()},
            {"qualifying_voxels", candidates.size()},
            {"excluded_cavity_voxels", cavities},
            {"bounce_gather", bake.volume.bake.gatherRays > 0 ? "rays" : "cones"},
            {"gather_rays", bake.volume.bake.gatherRays},
            {"points", chosen.size()},
            {"samples_per_point", reference.samples},
            {"seed", reference.seed},
            {"mean_point_distance_cells", meanDistance / double(chosen.size())},
            {"bake_normal_disagrees", normalDisagrees},
            {"direct", summarise(direct)},
            {"bounce1", b1},
            {"bounce2", b2},
            {"bounce1_cones_against_ray_gather", summarise(conesAgainstRays)},
            {"bounce1_ray_gather_against_reference", summarise(raysAgainstReference)},
            {"bounce1_voxel_ray_gather_against_reference", summarise(voxelRaysAgainstReference)},
            {"bounce1_cone_layout_against_ray_gather", summarise(coneLayoutAgainstRays)},
            {"ray_gather_misses", rayGatherMisses},
            {"worst", worst},
            {"every_point", everyPoint},
            {"acceptance",
             {{"limit", kLimit},
              {"bounce1_ok", b1["mean_relative_error"].get<double>() < kLimit},
              {"bounce2_ok", b2["mean_relative_error"].get<double>() < kLimit},
              {"reference_noise_ok",
               b1["reference_relative_standard_error"].get<double>() < kNoiseLimit &&
                   b2["reference_relative_standard_error"].get<double>() < kNoiseLimit}}},
            {"seconds",
             {{"bake", bakeSeconds}, {"select", selectSeconds}, {"reference", referenceSeconds}}},
        };
        const std::string text = out.dump(2);
        std::cout << text << '\n';
        if (!jsonFile.empty()) {
            std::ofstream file(jsonFile);
            file << text << '\n';
            if (!file) throw vox::IoError(jsonFile, "cannot write");
        }
        return 0;
    } catch (const vox::UsageError& e) {
        std::cerr << "radiance_accuracy: " << e.what() << '\n';
        return 1;
    } catch (const std::exception& e) {
        std::cerr << "radiance_accuracy: error: " << e.what() << '\n';
        return 4;
    }
}
