/// @file lightcuts.h
/// @brief Many punctual lights through Lightcuts: a light tree (or a forest of them) and the cut
/// of it that lights one Lambertian render point within a relative error.
///
/// After Walter et al., "Lightcuts: a scalable approach to illumination" (SIGGRAPH 2005), with the
/// binary-tree forest and the cut reuse of Yuan, Liu, Quan, Wang and Wu, "Lightcuts many-light
/// clustering based on adaptive spatial subdivision" (sections 1.2 and 1.4):
///
/// - **Light tree** (LightTree): the lights are clustered bottom up, always merging the two
///   clusters whose merge is cheapest by Walter's metric. A cluster stores the sum of its lights'
///   intensities, bounds on where its lights are and where they point, and one *representative*
///   light.
/// - **Forest** (LightTreeOptions::forest, paper 1.2): every light has an influence region (a
///   sphere); two clusters are not merged when their merge weight exceeds the weight at which
///   their representatives' influence regions just overlap, so clustering stops with several
///   spatially compact trees, each of which is skipped as a whole where a render point lies
///   outside its influence.
/// - **Cut** (evaluateCut): a set of nodes that covers every light once. Each node's light is
///   estimated by its representative's exact contribution scaled by the cluster's intensity. The
///   cut starts at the roots and splits the node with the largest error bound until the bounds
///   meet LightcutOptions' criterion: by default the root of the sum of the squared bounds at
///   most relativeError (2 %, Weber–Fechner) of the total estimate (Walter's: every bound).
/// - **Cut reuse** (LightcutCursor, paper 1.4): for a run of similar render points the previous
///   point's cut is the starting point: over-split parts are merged back up to the highest
///   ancestor that meets the threshold, under-split nodes are split further.
///
/// Every exact light evaluation goes through vox::lightArrival (vox/lighting.h), so the cut agrees
/// with the radiance bake and the path-traced reference light for light.
///
/// **Units.** Positions and distances in world units (glTF: metres). Point and spot intensities
/// in candela, directional in lux, as in vox::Light. Results are outgoing *radiance* of a
/// Lambertian surface: albedo/π × Σ irradiance × max(0, n·l) × visibility (linear RGB); a white
/// surface facing a 1 cd light 1 m away has radiance 1/π.
///
/// **Luminance.** Scalar intensities (clustering weights, representative choice, error bounds
/// compared against the threshold) are Rec. 709 luminance: 0.2126 R + 0.7152 G + 0.0722 B.
#pragma once

#include <vox/lighting.h>
#include <vox/base/math.h>
#include <vox/scene.h>

#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <span>
#include <vector>

namespace vox {

/// "No node" / "no light" in LightTreeNode's links and LightTree::leafOf.
inline constexpr std::uint32_t kNoLightNode = 0xFFFFFFFFu;

/// Rec. 709 luminance of a linear RGB colour.
[[nodiscard]] constexpr double lightLuminance(Vec3d rgb) {
    return 0.2126 * rgb.x + 0.7152 * rgb.y + 0.0722 * rgb.z;
}

/// How LightTree clusters the lights.
struct LightTreeOptions {
    /// true: a binary-tree forest (paper 1.2). Clusters A and B may merge only while their merge
    /// weight (I_A + I_B)·d² (d: the diagonal of the union of their position boxes) is at most
    /// the weight at which their representative lights' influence spheres just overlap,
    /// (I_A + I_B)·(r_a + r_b)², i.e. while d ≤ r_a + r_b (r: LightTree::influenceRadius); the
    /// cheapest allowed pair merges next, and clustering stops when no pair is allowed. So a
    /// tree's lights span (position box diagonal) at most the r_a + r_b of its last merge, at
    /// most twice its largest influence radius, however far a chain of overlapping lights
    /// reaches, and groups of lights whose influences do not meet are never in one tree. Applies to
    /// point and spot lights; directional lights reach everywhere and share one tree. (Overlap of
    /// the clusters' influence boxes, the other reading, merges every chain of overlapping lights
    /// into one tree, since each merge grows the box.) false: classic Lightcuts, one tree for the
    /// point and spot lights (and one for the directional lights, if any).
    bool forest = true;
    /// The irradiance (lux) below which a light without a range is taken not to reach a point:
    /// its influence radius is sqrt(luminance(colour × intensity) / influenceThreshold). Only
    /// used with a value > 0; otherwise relativeInfluence decides.
    double influenceThreshold = 0;
    /// Used when influenceThreshold ≤ 0: the threshold is relativeInfluence × the brightest point
    /// or spot light's luminous intensity at 1 world unit (lux at 1 m), so the brightest light
    /// without a range reaches 1/√relativeInfluence units (default 1e-3: ≈ 31.6 m), and a light
    /// k times dimmer 1/√k of that. 0: lights without a range reach everywhere (they then never
    /// split the forest). Lights with a range (Light::range > 0) always use their range.
    ///
    /// Both thresholds apply only with forest = true: classic trees give lights without a range an
    /// infinite influence (a classic tree is skipped only where every light has a range and none
    /// reaches).
    ///
    /// Skipping a tree whose influence does not contain a point is exact for lights with a range
    /// (they give exactly 0 there); for lights without one it drops at most
    /// (threshold × the number of such lights in the skipped trees) of irradiance.
    double relativeInfluence = 1e-3;
};

/// One node of a light tree, in LightTree::nodes(). Leaves hold one light each.
struct LightTreeNode {
    std::uint32_t left = kNoLightNode;    ///< first child (kNoLightNode for a leaf)
    std::uint32_t right = kNoLightNode;   ///< second child (kNoLightNode for a leaf)
    std::uint32_t parent = kNoLightNode;  ///< kNoLightNode for a root
    /// The representative light, an index into the span the tree was built from (and into
    /// LightTree::lights()); for a leaf, its own light. A merged cluster takes one child's
    /// representative, chosen with probability ∝ the children's luminance by a hash of the two
    /// children's representatives (deterministic, no global random state).
    std::uint32_t representative = kNoLightNode;
    std::uint32_t lightCount = 0;  ///< lights in the subtree
    bool directional = false;      ///< a directional-light tree's node
    bool hasSpot = false;          ///< the subtree holds at least one spot light
    bool hasOmni = false;          ///< the subtree holds at least one point light
    /// Point and spot trees: bounding box of the lights' positions (world units). Directional
    /// trees: bounding box of the unit vectors towards the lights (−direction), slightly padded.
    Bounds3f bounds;
    /// Bounding cone of the spot lights' axes (the way light travels): unit axis and half-angle
    /// in radians (0 for one spot). Meaningless unless hasSpot; π where hasOmni (all directions).
    Vec3f coneAxis{0, 0, -1};
    float coneHalfAngle = 3.14159265f;
    float maxOuterAngle = 0;  ///< largest spot outer cone angle in the subtree (radians)
    /// Largest Light::range in the subtree; +∞ when any light has none (or for directional).
    float maxRange = std::numeric_limits<float>::infinity();
    /// Bounding box of the union of the lights' influence spheres (centre = position, radius =
    /// LightTree::influenceRadius); infinite for directional trees.
    Bounds3f influence;
    Vec3d intensity{0, 0, 0};  ///< Σ colour × intensity (RGB; cd, or lux for directional)
    double luminance = 0;      ///< lightLuminance(intensity)

    [[nodiscard]] bool leaf() const noexcept { return left == kNoLightNode; }
};

/// A light tree, or forest of them, over a set of punctual lights. Immutable once built; every
/// const member is safe to call from several threads.
class LightTree {
public:
    /// One tree of the forest.
    struct Root {
        std::uint32_t node = kNoLightNode;  ///< index into nodes()
        bool directional = false;           ///< a tree of directional lights (infinite influence)
    };

    LightTree() = default;
    /// Builds the tree(s) over @p lights (world space, as vox::Scene holds them). Left out, and in
    /// no leaf: lights flagged dynamic, lights with a negative or non-finite colour × intensity,
    /// and point or spot lights with a non-finite position (directional ones with a zero or
    /// non-finite direction). Point and spot lights are clustered together (an orientation term
    /// keeps spots with different directions, and spots from points, apart); directional lights
    /// get their own tree, clustered by direction, never split by the forest.
    ///
    /// Merge cost (weight) of clusters A and B (Walter 2005, section 4.1): (I_A + I_B) × (d² +
    /// c²·(1 − cos θ)²), I the luminance, d the diagonal of the union of the two position boxes,
    /// θ the half-angle of the union of the spot-axis cones (π if a point light is in either, so
    /// a spot meets a point light last; the term is 0 when neither cluster holds a spot), c the
    /// diagonal of the point and spot lights' bounding box. The cheapest (allowed) pair is always
    /// merged next (exact greedy agglomeration, ties broken by node index), found through a k-d
    /// tree over the clusters with lower bounds on the cost (Walter et al. 2008's heap-based
    /// method). The result does not depend on the thread count.
    explicit LightTree(std::span<const Light> lights, const LightTreeOptions& options = {});

    [[nodiscard]] const std::vector<LightTreeNode>& nodes() const noexcept { return nodes_; }
    [[nodiscard]] const std::vector<Root>& roots() const noexcept { return roots_; }
    /// A copy of the span the tree was built from, same indices (left-out lights included).
    [[nodiscard]] const std::vector<Light>& lights() const noexcept { return lights_; }
    /// The leaf holding light @p light (index into lights()), or kNoLightNode if it was left out.
    [[nodiscard]] std::uint32_t leafOf(std::uint32_t light) const { return leafOf_.at(light); }
    /// Influence radius of light @p light (world units): its range if it has one, else where
    /// its irradiance I/d² falls to the influence threshold (LightTreeOptions); +∞ for
    /// directional lights (and all lights when the threshold is 0); 0 for a left-out light.
    [[nodiscard]] double influenceRadius(std::uint32_t light) const { return radius_.at(light); }
    /// The influence threshold used (lux); 0 where lights without a range reach everywhere
    /// (always in classic mode).
    [[nodiscard]] double influenceThreshold() const noexcept { return threshold_; }
    /// Diagonal of the point and spot lights' position bounding box: c of the merge cost.
    [[nodiscard]] double sceneDiagonal() const noexcept { return diagonal_; }
    /// Number of lights in leaves.
    [[nodiscard]] std::size_t leafCount() const noexcept;
    /// The tree (index into roots()) that node @p node belongs to.
    [[nodiscard]] std::uint32_t treeOf(std::uint32_t node) const { return treeOf_.at(node); }

    /// The "cluster–light list" of paper 1.3: the indices into roots() of the trees whose
    /// influence bounds overlap @p region (closed boxes; an empty region overlaps nothing).
    /// Directional trees always overlap. Pass the result to evaluateCut / LightcutCursor for
    /// every render point inside @p region.
    [[nodiscard]] std::vector<std::uint32_t> rootsOverlapping(const Bounds3f& region) const;
    /// The indices into roots() of the trees whose influence bounds contain @p point (closed
    /// boxes; directional trees always), ascending, into @p out (cleared first). Through a
    /// bounding volume hierarchy over the trees' influence boxes: O(log trees) for a forest of
    /// many small trees.
    void rootsContaining(Vec3d point, std::vector<std::uint32_t>& out) const;

    /// A node of the hierarchy over the trees' influence boxes (internal).
    struct RootIndexNode {
        Bounds3f bounds;
        std::uint32_t first =
            0;  ///< leaf: first entry of the root order; inner: right child (left: this + 1)
        std::uint32_t count = 0;  ///< leaf: number of trees; inner: 0
    };

private:
    std::vector<Light> lights_;
    std::vector<LightTreeNode> nodes_;
    std::vector<Root> roots_;
    std::vector<std::uint32_t> leafOf_;
    std::vector<double> radius_;
    std::vector<std::uint32_t> treeOf_;
    std::vector<RootIndexNode> rootIndex_;       // over the finite influence boxes
    std::vector<std::uint32_t> rootOrder_;       // root indices, in the hierarchy's leaf order
    std::vector<std::uint32_t> unboundedRoots_;  // roots with an infinite influence box
    void buildRootIndex();
    double threshold_ = 0;
    double diagonal_ = 0;
};

/// A render point: where light is gathered and how its surface turns arriving light into
/// outgoing radiance. Lambertian: albedo/π × Σ irradiance × response(l) × visibility, the
/// response being max(0, n·l) (the default) or, for the radiance bake's voxels, the axis-weighted
/// attenuation of vox::attenuate (Attenuation::Weighted and Paper are of that form; Adaptive adds
/// a cosine term).
struct LightcutPoint {
    Vec3d position{0, 0, 0};  ///< world units
    Vec3d normal{0, 0,
                 1};  ///< unit; the cosine response's normal (and the side shadow rays leave from)
    Vec3d albedo{1, 1,
                 1};  ///< linear, each channel in [0, 1] (π gives irradiance instead of radiance)
    /// false: response max(0, n·l). true: Σ over the axis directions (+x, −x, +y, −y, +z, −z) of
    /// axisWeights[k] × max(0, ±l_axis), each weight ≥ 0, plus axisCosineWeight × max(0, n·l).
    bool axisWeighted = false;
    std::array<double, 6> axisWeights{};
    double axisCosineWeight = 0;  ///< ≥ 0; read only where axisWeighted (unit normal)

    /// The response to light arriving from unit direction @p toLight.
    [[nodiscard]] double response(Vec3d toLight) const noexcept;
    /// A Lambertian point with a cosine response.
    [[nodiscard]] static LightcutPoint lambertian(Vec3d position, Vec3d normal, Vec3d albedo);
    /// A voxel of the radiance bake: the response of vox::attenuate(@p mode, @p normals, l)
    /// (Attenuation::Average is the cosine of the mean normal).
    [[nodiscard]] static LightcutPoint voxel(Vec3d position, const VoxelNormals& normals,
                                             Attenuation mode, Vec3d albedo);
};

/// When a cut is fine enough: which measure of the cut's error bounds (luminance of
/// lightcutBound for each non-leaf node; leaves are exact) must be at most the threshold
/// max(LightcutOptions::relativeError × luminance(total estimate), LightcutOptions::absoluteError).
/// Refinement always splits the node with the largest bound next.
enum class LightcutCriterion : std::uint8_t {
    /// Every node's bound ≤ threshold: Walter 2005's criterion and the paper's (1.1, eq. 3). Each
    /// cluster's error is within the threshold, but their sum is not: where many lights of similar
    /// weight reach a point, the result can be off by several times the threshold.
    PerNode,
    /// Σ bounds ≤ threshold: the result is guaranteed within relativeError of the exact sum over
    /// the searched trees (LightcutResult::errorBound). The most nodes of the three.
    Sum,
    /// √(Σ bounds²) ≤ threshold: treats the clusters' errors as independent (they are, over the
    /// representatives' draws), so the result lies within the threshold at almost every point,
    /// without a guarantee; a fresh cut has at least PerNode's nodes and at most Sum's.
    RootSumSquare,
};

/// How fine a cut must be.
struct LightcutOptions {
    /// What must meet the threshold. RootSumSquare (the default) keeps the result itself within
    /// about relativeError, which per node (Lightcuts as published) does not where many lights of
    /// similar weight reach a point (docs/lighting.md; measurements in
    /// docs/internals/lighting.md).
    LightcutCriterion criterion = LightcutCriterion::RootSumSquare;
    /// The threshold relative to the cut's total estimate (luminance). Walter 2005 and the paper
    /// use 0.02 (Weber–Fechner).
    double relativeError = 0.02;
    /// Radiance (luminance) below which the criterion is always met; 0: none. Keeps points that
    /// receive (almost) nothing, e.g. fully shadowed, from refining to maxCutSize.
    double absoluteError = 0;
    /// Most nodes in a cut: refinement stops when the next split would exceed it (a cut still
    /// starts with the root of every tree it searches, however many).
    std::uint32_t maxCutSize = 1000;
};

/// Visibility of a light from the render point, in [0, 1]: called only for lights that reach the
/// point with max(0, n·l) > 0, with the light (an element of LightTree::lights(); its index is
/// `&light - tree.lights().data()`) and what lightArrival gave. Empty: everything visible.
/// Called from the thread that evaluates the cut.
using LightVisibility = std::function<double(const Light&, const LightArrival&)>;

/// What a cut cost.
struct LightcutStats {
    std::uint32_t cutSize = 0;  ///< nodes in the final cut
    /// Search steps: the number of times a node's error bound (lightcutBound) was evaluated. A
    /// fresh cut evaluates each searched root once and both children of each split node
    /// (1 + 2·splits per tree); a reused cut evaluates each node of the previous cut it keeps,
    /// each root of a tree it enters, each parent it evaluates while merging back, and both
    /// children of each split. The paper's "search steps" (its table 1) measure.
    std::uint32_t searchSteps = 0;
    std::uint32_t visibilityEvaluations = 0;  ///< calls of the visibility callback
    std::uint32_t lightEvaluations = 0;       ///< calls of lightArrival
    std::uint32_t treesSearched = 0;          ///< trees whose influence contains the point
    std::uint32_t treesSkipped = 0;  ///< trees not searched: the point lies outside their influence
    std::uint32_t mergedBack = 0;    ///< cut reuse: nodes that replaced their two children
    bool truncated = false;          ///< refinement stopped at maxCutSize
};

/// The lighting of one render point.
struct LightcutResult {
    /// Outgoing Lambertian radiance, linear RGB: albedo/π × Σ_nodes I_node × (falloff × max(0,
    /// n·l) × visibility of the node's representative).
    Vec3d radiance{0, 0, 0};
    /// Σ over the cut's non-leaf nodes of luminance(error bound): a guaranteed bound on
    /// |luminance(radiance) − luminance(exact)|, exact being bruteForce over the searched trees
    /// (for any visibility in [0, 1]: a node's exact light and its estimate both lie in
    /// [0, bound]).
    double errorBound = 0;
    /// The cut: node indices into LightTree::nodes(), in no particular order.
    std::vector<std::uint32_t> cut;
    LightcutStats stats;
};

/// Conservative bound on the radiance the lights under node @p node of @p tree can send to a
/// Lambertian point (@p point, unit @p normal, linear @p albedo), visibility taken as 1:
/// albedo/π × node intensity (RGB) × G, with G for point and spot trees
/// = 1/d_min² × window(d_min) × cosBound × spotBound, where d_min is the distance from the
/// point to the node's position box (G = +∞ when the point lies in the box),
/// window(d) = clamp(1 − (d/maxRange)⁴, 0, 1)² (0 beyond maxRange; 1 without ranges), cosBound
/// is Walter 2005's bound on max(0, n·l) over the box (the box rotated into the normal's frame,
/// z/√(x² + y² + z²) maximised over that box), and spotBound is 0 where every direction from the
/// box to the point is outside every spot's outer cone (from the cone of the spot axes and the
/// largest outer angle), else 1; for directional trees G = cosBound over the box of directions.
/// Padded by a relative 1e-9 against rounding; never below the exact total of the subtree's
/// lights (tested on random configurations). Used as the node's error bound.
///
/// For an axis-weighted point (LightcutPoint::axisWeighted) cosBound is Σ over the axes of
/// max(w₊ × bound on l_axis, w₋ × bound on −l_axis) over the box, each bound Walter's with that
/// axis as the normal, plus axisCosineWeight × Walter's bound on max(0, n·l).
[[nodiscard]] Vec3d lightcutBound(const LightTree& tree, std::uint32_t node,
                                  const LightcutPoint& point);
/// lightcutBound at a Lambertian point with a cosine response.
[[nodiscard]] inline Vec3d lightcutBound(const LightTree& tree, std::uint32_t node, Vec3d point,
                                         Vec3d normal, Vec3d albedo) {
    return lightcutBound(tree, node, LightcutPoint::lambertian(point, normal, albedo));
}

/// The exact radiance of one light at a Lambertian point (lightArrival × max(0, n·l) ×
/// visibility × albedo/π); zero where lightArrival says the light does not reach.
[[nodiscard]] Vec3d lightContribution(const Light& light, const LightcutPoint& point,
                                      const LightVisibility& visibility = {});
[[nodiscard]] inline Vec3d lightContribution(const Light& light, Vec3d point, Vec3d normal,
                                             Vec3d albedo, const LightVisibility& visibility = {}) {
    return lightContribution(light, LightcutPoint::lambertian(point, normal, albedo), visibility);
}

/// A fresh lightcut at a Lambertian render point: @p point in world units, unit @p normal,
/// linear @p albedo (each channel in [0, 1]). Searches every tree whose influence bounds contain
/// the point (the others are counted in stats.treesSkipped and contribute nothing), starting
/// from the roots and always splitting the node with the largest error bound (lightcutBound;
/// leaves are exact) until the bounds meet LightcutOptions' criterion, or maxCutSize.
/// Thread-safe.
[[nodiscard]] LightcutResult evaluateCut(const LightTree& tree, const LightcutPoint& point,
                                         const LightcutOptions& options = {},
                                         const LightVisibility& visibility = {});
[[nodiscard]] inline LightcutResult evaluateCut(const LightTree& tree, Vec3d point, Vec3d normal,
                                                Vec3d albedo, const LightcutOptions& options = {},
                                                const LightVisibility& visibility = {}) {
    return evaluateCut(tree, LightcutPoint::lambertian(point, normal, albedo), options, visibility);
}
/// As above, searching only the trees @p roots (indices into tree.roots(), e.g. from
/// LightTree::rootsOverlapping for a region around the point); the point-in-influence test still
/// applies to each.
[[nodiscard]] LightcutResult evaluateCut(const LightTree& tree,
                                         std::span<const std::uint32_t> roots,
                                         const LightcutPoint& point,
                                         const LightcutOptions& options = {},
                                         const LightVisibility& visibility = {});
[[nodiscard]] inline LightcutResult evaluateCut(const LightTree& tree,
                                                std::span<const std::uint32_t> roots, Vec3d point,
                                                Vec3d normal, Vec3d albedo,
                                                const LightcutOptions& options = {},
                                                const LightVisibility& visibility = {}) {
    return evaluateCut(tree, roots, LightcutPoint::lambertian(point, normal, albedo), options,
                       visibility);
}

/// Every light in a leaf of @p tree summed exactly (lightContribution, with visibility), for
/// reference: no influence skipping. stats.cutSize and lightEvaluations are the light count.
[[nodiscard]] LightcutResult bruteForce(const LightTree& tree, const LightcutPoint& point,
                                        const LightVisibility& visibility = {});
[[nodiscard]] inline LightcutResult bruteForce(const LightTree& tree, Vec3d point, Vec3d normal,
                                               Vec3d albedo,
                                               const LightVisibility& visibility = {}) {
    return bruteForce(tree, LightcutPoint::lambertian(point, normal, albedo), visibility);
}

/// Lightcuts with cut reuse over a run of similar render points (paper 1.4): each evaluate()
/// starts from the previous point's cut instead of the roots.
///
/// At the new point every node of the previous cut is evaluated again (estimate and bound);
/// trees the point has left are dropped, trees it has entered start at their root. With the
/// threshold from that total, over-split parts are backtracked: a parent whose two children are
/// both in the cut replaces them where the cut still meets the criterion with it (per node: the
/// parent's own bound ≤ threshold), repeatedly, so the cut climbs to the highest such ancestor
/// (the paper: the node that meets the threshold and whose parent does not). A parent is not even
/// evaluated when the sum of its children's bounds already fails (a parent's bound is at least
/// that sum). Then the cut is refined exactly as a fresh cut is, so the final cut meets the same
/// criterion against its own total (or stops at maxCutSize) and carries the same error
/// guarantee; on coherent runs it takes fewer search steps, and its cut can differ from the
/// fresh one.
/// Call reset() where a run ends (the next point is not similar: different material or
/// visibility, or a normal more than ~10° off, the paper's criterion). Not thread-safe: one
/// cursor per thread.
class LightcutCursor {
public:
    /// @p tree must outlive the cursor.
    explicit LightcutCursor(const LightTree& tree, const LightcutOptions& options = {});
    /// Restricts the search to the trees @p roots (indices into tree.roots()), e.g. the
    /// cluster–light list of the region the coming points lie in; resets the cursor.
    void setRoots(std::vector<std::uint32_t> roots);
    /// As above, with every coming point inside @p region (a closed box; empty: no region). The
    /// cuts are then taken in the tree as the region sees it: a subtree all of whose lights have
    /// a range and lie farther than it from every point of the region gives exactly 0 there and
    /// is left out, and a node with such a child stands for its other child. A cut then covers
    /// every light that can reach the region, and results agree with those without a region
    /// within the error criterion (the cuts, and so the estimates, can differ).
    void setRoots(std::vector<std::uint32_t> roots, const Bounds3f& region);
    /// Searches every tree again (the default); resets the cursor.
    void clearRoots();
    /// Forgets the previous cut: the next evaluate() is a fresh cut.
    void reset();
    /// The cut at the next point of the run; the same arguments and result as evaluateCut.
    [[nodiscard]] LightcutResult evaluate(const LightcutPoint& point,
                                          const LightVisibility& visibility = {});
    [[nodiscard]] LightcutResult evaluate(Vec3d point, Vec3d normal, Vec3d albedo,
                                          const LightVisibility& visibility = {}) {
        return evaluate(LightcutPoint::lambertian(point, normal, albedo), visibility);
    }
    /// The previous point's cut (node indices), empty after reset().
    [[nodiscard]] const std::vector<std::uint32_t>& previousCut() const noexcept {
        return previous_;
    }

    LightcutCursor(const LightcutCursor& other);
    LightcutCursor& operator=(const LightcutCursor& other);
    LightcutCursor(LightcutCursor&&) noexcept;
    LightcutCursor& operator=(LightcutCursor&&) noexcept;
    ~LightcutCursor();

private:
    struct Scratch;  // working storage kept from point to point
    const LightTree* tree_;
    LightcutOptions options_;
    std::vector<std::uint32_t> roots_;
    bool allRoots_ = true;
    std::vector<std::uint32_t> previous_;
    bool havePrevious_ = false;
    std::unique_ptr<Scratch> scratch_;
};

}  // namespace vox
