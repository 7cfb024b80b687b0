/// @file many_lights.h
/// @brief Direct light from many punctual lights at many render points: Lightcuts over a
/// binary-tree forest, with render points grouped into spatial clusters that carry a
/// cluster–light list and reuse cuts (Yuan et al., "Lightcuts many-light clustering based on
/// adaptive spatial subdivision", sections 1.3 and 1.4), the classic Lightcuts it improves on,
/// and brute force, with the statistics of the paper's table 1.
///
/// The radiance bake lights its voxels with it (clusters from an octree subdivision of the
/// volume) and `voxinspect render` its pixels (clusters from the view-frustum subdivision).
#pragma once

#include <vox/lightcuts.h>
#include <vox/base/math.h>
#include <vox/raycast.h>

#include <array>
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

namespace vox {

/// Whether direct light goes through Lightcuts (`--lightcuts`).
enum class LightcutsMode : std::uint8_t {
    Auto,  ///< Lightcuts from kLightcutsAutoLights static lights on, brute force below
    On,
    Off,  ///< every light at every point (brute force)
};

/// The static light count from which LightcutsMode::Auto uses Lightcuts; below it, every light is
/// evaluated at every point (brute force). The choice changes the run time and, within each
/// method's error, the result. The measurements behind the value: docs/internals/lighting.md.
inline constexpr std::size_t kLightcutsAutoLights = 32;

/// Parses "auto", "on" or "off". @throws UsageError otherwise.
[[nodiscard]] LightcutsMode parseLightcutsMode(const std::string& text);
/// Parses "per-node", "sum" or "rss" (root of the sum of squares). @throws UsageError otherwise.
[[nodiscard]] LightcutCriterion parseLightcutCriterion(const std::string& text);
[[nodiscard]] const char* lightcutCriterionName(LightcutCriterion criterion);

/// Render points grouped into clusters: cluster k holds the points order[begin[k]] …
/// order[begin[k + 1] − 1], in the order their cuts are evaluated. A cluster is one region of
/// space with one cluster–light list; inside it the points come in *runs* of similar points
/// (similarRenderPoints to the run's first), and cut reuse carries a cut from one point to the
/// next only inside a run.
struct RenderPointClusters {
    std::vector<std::uint32_t> order;  ///< point indices, cluster after cluster, run after run
    std::vector<std::uint32_t> begin;  ///< clusters + 1 entries; begin.back() == order.size()
    std::vector<std::uint32_t>
        runs;  ///< where each run starts in order, ascending; every begin[k] is one
    [[nodiscard]] std::size_t count() const noexcept {
        return begin.empty() ? 0 : begin.size() - 1;
    }
};

/// When two render points count as similar (paper 1.4: the same material, and normals within 10°).
struct SimilarityOptions {
    double normalDegrees = 10;  ///< largest angle between the normals
    double albedoTolerance =
        1.0 / 64;  ///< largest difference of any albedo channel ("the same material")
};

/// Whether @p b is similar to @p a.
[[nodiscard]] bool similarRenderPoints(const LightcutPoint& a, const LightcutPoint& b,
                                       const SimilarityOptions& options = {});

/// Octree subdivision of a voxel volume for voxel render points (the bake): point i lies in
/// level-@p depth cell @p cells[i]. A node of the octree over the 2^depth grid becomes one
/// cluster when every point in it is similar to its first (Morton order) and it holds at most
/// @p maxPoints points, or when its edge is @p minCells cells (the resolution the subdivision
/// stops at); otherwise it is split into its eight children. Inside a cluster the points are
/// grouped into runs of similar points (each point joins the first run whose first point it is
/// similar to), each run in Morton order. Deterministic.
[[nodiscard]] RenderPointClusters clusterVoxelPoints(
    std::span<const LightcutPoint> points, std::span<const std::array<std::uint32_t, 3>> cells,
    std::uint32_t depth, std::uint32_t maxPoints = 512, std::uint32_t minCells = 4,
    const SimilarityOptions& similarity = {});

/// The paper's view-frustum subdivision (1.3, eq. 4) for pixel render points: the screen is cut
/// into square tiles of @p tilePixels pixels, the view depth into slabs whose thickness grows
/// with depth so that every sub-frustum is about as deep as it is wide
/// (C_{i+1} = C_i × (1 + 2 tan(γ/2) × tilePixels / height), C_0 the nearest point's depth, γ the
/// vertical field of view): the clusters are the occupied (tile, slab) cells. A cell whose
/// points are not all similar to its first is split into its four quarter tiles (same slab),
/// down to tiles of @p minTilePixels. Point i is pixel @p pixels[i] = {x, y} at view depth
/// @p depths[i] (distance along the camera's forward axis); inside a cluster the points form runs
/// of similar points as in clusterVoxelPoints, each run in scanline order.
[[nodiscard]] RenderPointClusters clusterPixelPoints(
    std::span<const LightcutPoint> points, std::span<const std::array<std::uint32_t, 2>> pixels,
    std::span<const double> depths, const PinholeCamera& camera, std::uint32_t tilePixels = 16,
    std::uint32_t minTilePixels = 4, const SimilarityOptions& similarity = {});

/// Visibility of a light from render point @p point (an index into the points), in [0, 1].
/// Called concurrently for different points.
using PointVisibility =
    std::function<double(std::size_t point, const Light& light, const LightArrival& arrival)>;

/// What a ClusterVisibility reports about the visibility it shared among points.
struct SharedVisibilityStats {
    std::uint64_t tests = 0;  ///< tests run once for a group of points
    /// Calls answered by such a test, without a ray or cone of their own.
    std::uint64_t answered = 0;
};

/// Visibility for the points of one cluster, in [0, 1]: as PointVisibility, with @p light the
/// light's index into the lights the light tree was built from. Called on one thread only, for
/// the cluster's points in their order, so it may keep state from call to call, e.g. a test that
/// decides a light's visibility for a whole group of nearby points at once.
using ClusterVisibility = std::function<double(std::size_t point, std::uint32_t light,
                                               const Light& lightRef, const LightArrival& arrival)>;

/// Makes the ClusterVisibility of one cluster from its points (indices into the points, in the
/// order they are lit); what it shares it counts into @p stats (which outlives the result).
/// Called concurrently for different clusters.
using ClusterVisibilityFactory = std::function<ClusterVisibility(
    std::span<const std::uint32_t> points, SharedVisibilityStats& stats)>;

/// What lighting a set of points cost and how good it was.
struct ManyLightStats {
    std::string method;  ///< "lightcuts", "classic" or "brute-force"
    std::uint64_t points = 0;
    std::uint64_t lights = 0;                 ///< lights in leaves of the tree
    std::uint64_t trees = 0;                  ///< trees in the forest (1 or 2 for classic)
    std::uint64_t clusters = 0;               ///< spatial clusters (0: none)
    std::uint64_t runs = 0;                   ///< runs of similar points the cuts were reused along
    std::uint64_t cutNodes = 0;               ///< Σ cut size over the points
    std::uint64_t searchSteps = 0;            ///< Σ LightcutStats::searchSteps
    std::uint64_t lightEvaluations = 0;       ///< Σ lightArrival calls
    std::uint64_t visibilityEvaluations = 0;  ///< visibility queries (lights times points)
    /// Of those, the queries a shared test answered (ClusterVisibilityFactory): the rays or
    /// cones traced are visibilityEvaluations − visibilityShared.
    std::uint64_t visibilityShared = 0;
    std::uint64_t sharedVisibilityTests = 0;  ///< shared tests run
    std::uint64_t treesSearched = 0;          ///< Σ trees searched per point
    std::uint64_t truncated = 0;              ///< points whose cut stopped at maxCutSize
    double seconds = 0;                       ///< wall time (building the tree not included)
    double treeSeconds = 0;                   ///< building the light tree
    double clusterSeconds = 0;  ///< clustering the points and their cluster–light lists

    [[nodiscard]] double meanCutSize() const noexcept {
        return points ? double(cutNodes) / double(points) : 0;
    }
    [[nodiscard]] double meanSearchSteps() const noexcept {
        return points ? double(searchSteps) / double(points) : 0;
    }
};

/// How lightPoints lights.
struct ManyLightOptions {
    LightcutOptions cut;
    bool clusterLists =
        true;               ///< search only the trees whose influence overlaps the point's cluster
    bool reuseCuts = true;  ///< start each point of a cluster from the previous point's cut
    /// When set (and there are clusters), the visibility of each cluster's points comes from the
    /// ClusterVisibility it makes instead of the PointVisibility.
    ClusterVisibilityFactory clusterVisibility;
};

/// The box lightPoints gives the cursor of a cluster with the points @p members (indices into
/// @p points): their bounding box in float, padded so that it holds every point; empty for no
/// members. Its cluster–light list is LightTree::rootsOverlapping of it.
[[nodiscard]] Bounds3f renderPointRegion(std::span<const LightcutPoint> points,
                                         std::span<const std::uint32_t> members);

/// Lights every point with Lightcuts: clusters in parallel (TBB), the points of a cluster in
/// their order with one LightcutCursor (reuseCuts) or fresh cuts; with clusterLists the cursor
/// searches the cluster's list and sees the tree as its region (renderPointRegion) does
/// (LightcutCursor::setRoots). @p out[i] receives point i's
/// radiance (LightcutPoint::albedo / π × Σ irradiance × response × visibility). Without
/// clusters (an empty @p clusters) every point is its own run. Deterministic: the same inputs
/// give the same results whatever the thread count.
ManyLightStats lightPoints(const LightTree& tree, std::span<const LightcutPoint> points,
                           const RenderPointClusters& clusters, const ManyLightOptions& options,
                           const PointVisibility& visibility, std::span<Vec3d> out);

/// Every static light of @p lights at every point (lightContribution), in parallel; the
/// reference Lightcuts is measured against.
ManyLightStats lightPointsBruteForce(std::span<const Light> lights,
                                     std::span<const LightcutPoint> points,
                                     const PointVisibility& visibility, std::span<Vec3d> out);

/// Lightcuts' error against brute force over a set of points, in luminance.
struct LightcutErrorStats {
    double threshold = 0.02;   ///< the relative error a point must stay within
    std::uint64_t points = 0;  ///< points compared (those brute force gives light)
    std::uint64_t within = 0;  ///< |lightcuts − brute| ≤ threshold × brute
    double maxRelative = 0;    ///< the largest |lightcuts − brute| / brute
    double meanRelative = 0;
    [[nodiscard]] double fractionWithin() const noexcept {
        return points ? double(within) / double(points) : 1;
    }
};

/// Compares @p estimate with @p exact point by point. Points where exact is 0 are skipped (an
/// estimate is then 0 too: a node's estimate comes from a light that lights the point).
[[nodiscard]] LightcutErrorStats compareWithBruteForce(std::span<const Vec3d> estimate,
                                                       std::span<const Vec3d> exact,
                                                       double threshold);

/// The statistics of `--stats` for one run of the direct light: what lit the points, and with
/// `--lightcuts-compare` all three methods on the same points: Lightcuts as used here (forest,
/// cluster–light lists, cut reuse), classic Lightcuts (one tree, no clusters, no reuse) and brute
/// force, with both Lightcuts' errors against brute force.
struct ManyLightReport {
    ManyLightStats used;
    bool compared = false;
    ManyLightStats lightcuts, classic, bruteForce;
    LightcutErrorStats lightcutsError, classicError;
};

/// Direct light at @p points through @p mode: the whole of what the bake and the renderer do.
/// Builds the forest over @p lights (static ones), clusters with @p clusters (called only when
/// Lightcuts runs), lights the points into @p out, and with @p compare also runs classic Lightcuts
/// and brute force (their results discarded) and fills the report's comparison. Lightcuts takes
/// its visibility from @p clusterVisibility where one is given (ManyLightOptions); classic
/// Lightcuts and brute force always from @p visibility, one query per light and point.
[[nodiscard]] ManyLightReport directLight(std::span<const Light> lights,
                                          std::span<const LightcutPoint> points, LightcutsMode mode,
                                          const LightcutOptions& cut, bool compare,
                                          const std::function<RenderPointClusters()>& clusters,
                                          const PointVisibility& visibility, std::span<Vec3d> out,
                                          const ClusterVisibilityFactory& clusterVisibility = {});

}  // namespace vox
