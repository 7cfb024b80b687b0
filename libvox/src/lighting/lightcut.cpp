// Lightcuts' cut selection (Walter et al. 2005) on a light tree or forest, and the cut reuse of
// the paper's section 1.4 (LightcutCursor).
#include <vox/lightcuts.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

namespace vox {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kInvPi = 1.0 / kPi;
constexpr double kInf = std::numeric_limits<double>::infinity();

/// The callback's visibility, clamped to [0, 1] (NaN: 0).
double visibilityOf(const LightVisibility& visibility, const Light& light,
                    const LightArrival& arrival) {
    const double v = visibility(light, arrival);
    return v > 0 ? std::min(v, 1.0) : 0.0;
}

bool contains(const Bounds3f& b, Vec3d p) {
    return p.x >= b.min.x && p.x <= b.max.x && p.y >= b.min.y && p.y <= b.max.y && p.z >= b.min.z &&
           p.z <= b.max.z;
}

/// An upper bound on max over v in the box [lo, hi] of dot(f.n, v) / |v| (Walter 2005: the box
/// rotated into the frame, z/√(x² + y² + z²) maximised over the rotated box's bounding box). It
/// may be negative (every v points away from n); 1 where the box holds the origin.
double maxCosine(const OrthonormalFrame& f, Vec3d lo, Vec3d hi) {
    const Vec3d c = (lo + hi) * 0.5, h = (hi - lo) * 0.5;
    double range[3][2];
    const Vec3d axes[3] = {f.t, f.b, f.n};
    for (int k = 0; k < 3; ++k) {
        const Vec3d a = axes[k];
        const double centre = dot(a, c);
        const double half = std::abs(a.x) * h.x + std::abs(a.y) * h.y + std::abs(a.z) * h.z;
        // A little slack for the rounding of the frame and of these sums.
        const double slack = 1e-12 * (std::abs(centre) + half);
        range[k][0] = centre - half - slack;
        range[k][1] = centre + half + slack;
    }
    const double zmax = range[2][1];
    auto minSquare = [&](int k) {
        return range[k][0] <= 0 && range[k][1] >= 0
                   ? 0.0
                   : std::min(range[k][0] * range[k][0], range[k][1] * range[k][1]);
    };
    auto maxSquare = [&](int k) {
        return std::max(range[k][0] * range[k][0], range[k][1] * range[k][1]);
    };
    if (zmax > 0) {
        const double r2 = minSquare(0) + minSquare(1);
        return std::min(1.0, zmax / std::sqrt(r2 + zmax * zmax));
    }
    const double r2 = maxSquare(0) + maxSquare(1);
    const double len = std::sqrt(r2 + zmax * zmax);
    return len > 0 ? zmax / len : 1.0;
}

/// max over v in the box [lo, hi] of sign × v_axis / |v| where that is positive, else 0: exact,
/// since the largest v_axis and the smallest perpendicular part can be picked independently.
double axisCosine(Vec3d lo, Vec3d hi, int axis, double sign) {
    const double along = sign > 0 ? hi[axis] : -lo[axis];
    if (!(along > 0)) return 0;
    double across = 0;
    for (int k = 0; k < 3; ++k) {
        if (k == axis) continue;
        const double g = lo[k] > 0 ? lo[k] : (hi[k] < 0 ? -hi[k] : 0.0);
        across += g * g;
    }
    return std::min(1.0, along / std::sqrt(along * along + across) * (1 + 1e-12));
}

/// The surface response of a render point, bounded over a box of directions.
struct Response {
    OrthonormalFrame frame;
    bool axisWeighted;
    std::array<double, 6> weights;
    double cosineWeight;

    explicit Response(const LightcutPoint& p)
        : frame(p.normal),
          axisWeighted(p.axisWeighted),
          weights(p.axisWeights),
          cosineWeight(p.axisCosineWeight) {}
    /// An upper bound of the response over the directions v / |v|, v in [lo, hi]; ≥ 0.
    [[nodiscard]] double bound(Vec3d lo, Vec3d hi) const {
        if (!axisWeighted) return std::max(0.0, maxCosine(frame, lo, hi));
        // An axis without weight adds 0 (the cosines are finite): most voxels weigh one or two.
        double sum = 0;
        for (int axis = 0; axis < 3; ++axis) {
            const double plus = weights[2 * axis], minus = weights[2 * axis + 1];
            double term = 0;
            if (plus > 0) term = plus * axisCosine(lo, hi, axis, 1);
            if (minus > 0) term = std::max(term, minus * axisCosine(lo, hi, axis, -1));
            sum += term;
        }
        if (cosineWeight > 0) sum += cosineWeight * std::max(0.0, maxCosine(frame, lo, hi));
        return sum;
    }
};

/// The scalar G of lightcutBound (before intensity and albedo); +∞ where the point lies in the box.
double geometricBound(const LightTreeNode& node, const Response& response, Vec3d point) {
    const Vec3d lo = vec3Cast<double>(node.bounds.min), hi = vec3Cast<double>(node.bounds.max);
    if (node.directional) return response.bound(lo, hi);
    double d2 = 0;
    for (int k = 0; k < 3; ++k) {
        const double g = std::max({0.0, lo[k] - point[k], point[k] - hi[k]});
        d2 += g * g;
    }
    const double range = node.maxRange;
    if (std::isfinite(range) && d2 >= range * range) return 0;
    const double cosBound = response.bound(lo - point, hi - point);
    if (!(cosBound > 0)) return 0;
    if (node.hasSpot && !node.hasOmni) {
        // Directions from the lights to the point, x − p for p in the box, against the cone of
        // spot axes widened by the largest outer angle.
        const OrthonormalFrame axis(normalize(vec3Cast<double>(node.coneAxis)));
        const double c = std::clamp(maxCosine(axis, point - hi, point - lo), -1.0, 1.0);
        if (std::acos(c) > double(node.coneHalfAngle) + double(node.maxOuterAngle) + 1e-6) return 0;
    }
    if (!(d2 > 0)) return kInf;
    double window = 1;
    if (std::isfinite(range)) {
        const double r2 = d2 / (range * range);
        const double w = std::clamp(1.0 - r2 * r2, 0.0, 1.0);
        window = w * w;
    }
    return cosBound * window / d2;
}

Vec3d boundOf(const LightTreeNode& node, const Response& response, Vec3d point,
              Vec3d albedoOverPi) {
    const double g = geometricBound(node, response, point);
    if (!(g > 0)) return {0, 0, 0};
    Vec3d out;
    for (int k = 0; k < 3; ++k) {
        const double i = albedoOverPi[k] * node.intensity[k];
        out[k] = i > 0 ? i * g * (1 + 1e-9) : 0.0;
    }
    return out;
}

/// The trees as the render points of a region see them (LightcutCursor::setRoots with a region):
/// subtrees whose lights cannot reach the region are left out, and a node with one such child
/// stands for its other child. Without a region (nodes null) every node is itself.
struct RegionView {
    const std::vector<LightTreeNode>* nodes = nullptr;
    Vec3d lo{0, 0, 0}, hi{0, 0, 0};

    /// Every light under @p n has a range and lies beyond it from every point of the region, so
    /// gives exactly 0 there: lightArrival's d ≥ range (the margin covers the rounding of d).
    [[nodiscard]] bool outOfReach(std::uint32_t n) const {
        const LightTreeNode& node = (*nodes)[n];
        const double range = node.maxRange;
        if (node.directional || !std::isfinite(range)) return false;
        double d2 = 0;
        for (int k = 0; k < 3; ++k) {
            const double g = std::max(
                {0.0, double(node.bounds.min[k]) - hi[k], lo[k] - double(node.bounds.max[k])});
            d2 += g * g;
        }
        return d2 > range * range * (1 + 1e-9);
    }
    /// The node that stands for @p n in the region (n itself, or the descendant that is left
    /// where one child of each node on the way is out of reach), or kNoLightNode where no light
    /// under it can reach the region. Remembered for the region: every point of a run asks.
    [[nodiscard]] std::uint32_t effective(std::uint32_t n) const {
        if (!nodes) return n;
        auto& [stamp, value] = memo[n];
        if (stamp == generation) return value;
        stamp = generation;
        value = kNoLightNode;
        if (outOfReach(n)) return value;
        for (std::uint32_t m = n;;) {
            const LightTreeNode& node = (*nodes)[m];
            const bool left = !node.leaf() && outOfReach(node.left);
            const bool right = !node.leaf() && outOfReach(node.right);
            if (left && right) return value;
            if (left == right) return value = m;
            m = left ? node.right : node.left;
        }
    }
    /// Starts a region (@p box empty: none); what effective() remembered is forgotten.
    void reset(const std::vector<LightTreeNode>& treeNodes, const Bounds3f& box) {
        nodes = nullptr;
        if (box.empty()) return;
        nodes = &treeNodes;
        lo = vec3Cast<double>(box.min);
        hi = vec3Cast<double>(box.max);
        if (memo.size() != treeNodes.size() || ++generation == 0) {
            memo.assign(treeNodes.size(), {0, 0});
            generation = 1;
        }
    }

private:
    mutable std::vector<std::pair<std::uint32_t, std::uint32_t>> memo;  // (generation, node)
    std::uint32_t generation = 0;
};

/// Everything one cut evaluation needs, shared by the fresh cut and the cursor.
struct Context {
    const LightTree& tree;
    const LightcutPoint& at;
    Response response;
    Vec3d point, albedoOverPi;
    const LightcutOptions& options;
    const LightVisibility& visibility;
    LightcutStats& stats;
    const RegionView& view;

    Context(const LightTree& t, const LightcutPoint& p, const LightcutOptions& o,
            const LightVisibility& v, LightcutStats& s, const RegionView& r)
        : tree(t),
          at(p),
          response(p),
          point(p.position),
          albedoOverPi(p.albedo * kInvPi),
          options(o),
          visibility(v),
          stats(s),
          view(r) {}

    /// falloff × response × visibility of light @p index: the representative's factor.
    double factor(std::uint32_t index) const {
        const Light& light = tree.lights()[index];
        ++stats.lightEvaluations;
        LightArrival arrival;
        if (!lightArrival(light, point, arrival)) return 0;
        const double cosine = at.response(arrival.toLight);
        if (!(cosine > 0)) return 0;
        const Vec3d rgb = vec3Cast<double>(light.color) * double(light.intensity);
        const double peak = std::max({rgb.x, rgb.y, rgb.z});
        if (!(peak > 0)) return 0;
        // irradiance = colour × intensity × falloff channel by channel: the brightest channel's
        // ratio is the falloff.
        const double irr =
            std::max({arrival.irradiance.x, arrival.irradiance.y, arrival.irradiance.z});
        double v = 1;
        if (visibility) {
            ++stats.visibilityEvaluations;
            v = visibilityOf(visibility, light, arrival);
        }
        return irr / peak * cosine * v;
    }
};

/// One node of a cut at the current point.
struct Entry {
    double key;       // luminance of the error bound; −1 for leaves (exact, never split)
    double boundLum;  // luminance of lightcutBound; for leaves −1 until boundLumOf needs it
    std::uint32_t node;
    double g;        // the representative's factor
    Vec3d estimate;  // albedo/π × intensity × g
};

/// A node of the cut that may be split (key > 0), in the max-heap refine keeps: small, so that the
/// heap moves 16 bytes, not an Entry.
struct HeapItem {
    double key;
    std::uint32_t node;
    std::uint32_t entry;  // index into the cut's entries
};

bool heapLess(const HeapItem& a, const HeapItem& b) {
    if (a.key != b.key) return a.key < b.key;
    return a.node > b.node;
}

/// The cut's entry for node @p index: its bound first, then its representative's factor (@p known
/// where the caller has it, else NaN), which a node bounded by 0 does not need: it gives 0.
Entry makeEntry(const Context& ctx, std::uint32_t index, double known) {
    const LightTreeNode& node = ctx.tree.nodes()[index];
    ++ctx.stats.searchSteps;
    Entry e;
    e.node = index;
    // A leaf is exact and never split: only merging back asks for its bound.
    e.boundLum = -1;
    e.key = -1;
    if (!node.leaf()) {
        const Vec3d bound = boundOf(node, ctx.response, ctx.point, ctx.albedoOverPi);
        e.boundLum = lightLuminance(bound);
        if (std::isnan(e.boundLum)) e.boundLum = kInf;
        e.key = e.boundLum;
    }
    e.g = e.boundLum == 0 ? 0.0 : std::isnan(known) ? ctx.factor(node.representative) : known;
    e.estimate = ctx.albedoOverPi * node.intensity * e.g;
    return e;
}

constexpr double kUnknown = std::numeric_limits<double>::quiet_NaN();

/// The luminance of @p e's bound, computed on first use for a leaf.
double boundLumOf(const Context& ctx, Entry& e) {
    if (e.boundLum < 0) {
        e.boundLum = lightLuminance(
            boundOf(ctx.tree.nodes()[e.node], ctx.response, ctx.point, ctx.albedoOverPi));
        if (std::isnan(e.boundLum)) e.boundLum = kInf;
    }
    return e.boundLum;
}

double thresholdOf(const LightcutOptions& o, Vec3d total) {
    return std::max(o.relativeError * std::max(0.0, lightLuminance(total)), o.absoluteError);
}

/// The error measure the criterion compares with the threshold, kept over the cut's keys (leaves,
/// key −1, count as 0).
struct Budget {
    LightcutCriterion criterion;
    double sum = 0, sum2 = 0;  // over the finite keys
    int infinite = 0;          // keys of +∞ (the point inside a node's box)

    explicit Budget(LightcutCriterion c) : criterion(c) {}
    void add(double key) {
        if (!(key > 0)) return;
        if (std::isinf(key)) {
            ++infinite;
            return;
        }
        sum += key;
        sum2 += key * key;
    }
    void remove(double key) {
        if (!(key > 0)) return;
        if (std::isinf(key)) {
            --infinite;
            return;
        }
        sum -= key;
        sum2 -= key * key;
    }
    /// Recomputed from scratch (after removing a large key, against cancellation).
    void reset(const std::vector<Entry>& entries) {
        sum = sum2 = 0;
        infinite = 0;
        for (const Entry& e : entries) add(e.key);
    }
    /// The measure with the largest key @p top (PerNode looks at it alone).
    [[nodiscard]] double measure(double top) const {
        if (infinite > 0) return kInf;
        switch (criterion) {
            case LightcutCriterion::PerNode:
                return top;
            case LightcutCriterion::Sum:
                return sum;
            case LightcutCriterion::RootSumSquare:
                return std::sqrt(std::max(0.0, sum2));
        }
        return top;
    }
    /// Whether the cut still meets @p threshold with keys @p a and @p b replaced by @p parent.
    [[nodiscard]] bool acceptsReplacing(double a, double b, double parent, double threshold) const {
        if (!(parent <= threshold)) return false;  // (every criterion; also +∞ and NaN)
        if (infinite > 0 && criterion != LightcutCriterion::PerNode) return false;
        const double p = std::max(parent, 0.0), x = std::max(a, 0.0), y = std::max(b, 0.0);
        switch (criterion) {
            case LightcutCriterion::PerNode:
                return parent <= threshold;
            case LightcutCriterion::Sum:
                return sum - x - y + p <= threshold;
            case LightcutCriterion::RootSumSquare:
                return std::sqrt(std::max(0.0, sum2 - x * x - y * y + p * p)) <= threshold;
        }
        return false;
    }
};

/// Refines the cut @p cut until it meets the options, always splitting the node with the largest
/// key (a max-heap over the nodes that can be split, in @p heap); fills @p result. Entries whose
/// node is kNoLightNode are not in the cut; a split node stays in @p cut, marked so.
void refine(const Context& ctx, std::vector<Entry>& cut, std::vector<HeapItem>& heap,
            LightcutResult& result) {
    const auto& nodes = ctx.tree.nodes();
    Vec3d total{0, 0, 0};
    Budget budget(ctx.options.criterion);
    heap.clear();
    std::size_t size = 0;
    for (std::uint32_t i = 0; i < cut.size(); ++i) {
        const Entry& e = cut[i];
        if (e.node == kNoLightNode) continue;
        ++size;
        total += e.estimate;
        budget.add(e.key);
        // Leaves (−1) and nodes without a bound are never split.
        if (e.key > 0) heap.push_back({e.key, e.node, i});
    }
    std::make_heap(heap.begin(), heap.end(), heapLess);
    while (!heap.empty()) {
        const HeapItem top = heap.front();
        if (!(budget.measure(top.key) > thresholdOf(ctx.options, total))) break;
        if (size + 1 > ctx.options.maxCutSize) {
            ctx.stats.truncated = true;
            break;
        }
        std::pop_heap(heap.begin(), heap.end(), heapLess);
        heap.pop_back();
        const Entry parent = cut[top.entry];
        cut[top.entry].node = kNoLightNode;
        cut[top.entry].key = -1;
        --size;
        total = total - parent.estimate;
        if (parent.key > 0.5 * budget.sum)
            budget.reset(cut);  // (the parent's key no longer in it)
        else
            budget.remove(parent.key);
        const LightTreeNode& p = nodes[parent.node];
        for (std::uint32_t side : {p.left, p.right}) {
            const std::uint32_t child = ctx.view.effective(side);
            if (child == kNoLightNode) continue;  // no light of it reaches the region
            const double g = nodes[child].representative == p.representative ? parent.g : kUnknown;
            const Entry e = makeEntry(ctx, child, g);
            total += e.estimate;
            budget.add(e.key);
            ++size;
            if (e.key > 0) {
                heap.push_back({e.key, e.node, std::uint32_t(cut.size())});
                std::push_heap(heap.begin(), heap.end(), heapLess);
            }
            cut.push_back(e);
        }
    }
    result.radiance = {0, 0, 0};
    result.errorBound = 0;
    result.cut.clear();
    result.cut.reserve(size);
    for (const Entry& e : cut) {
        if (e.node == kNoLightNode) continue;
        result.radiance += e.estimate;
        if (e.key > 0) result.errorBound += e.key;
        result.cut.push_back(e.node);
    }
    ctx.stats.cutSize = std::uint32_t(size);
}

/// Roots to search: (root index, node) of the trees in @p roots whose influence holds the point.
/// The trees to search at the point, ascending (indices into LightTree::roots()): with @p all,
/// those whose influence contains it (through the tree's root index), else those of @p roots
/// that do; counts searched and skipped trees.
void treesAt(const Context& ctx, std::span<const std::uint32_t> roots, bool all,
             std::vector<std::uint32_t>& out) {
    out.clear();
    const auto& treeRoots = ctx.tree.roots();
    if (all) {
        ctx.tree.rootsContaining(ctx.point, out);
        ctx.stats.treesSkipped += std::uint32_t(treeRoots.size() - out.size());
    } else {
        for (std::uint32_t t : roots) {
            if (t >= treeRoots.size()) continue;
            if (contains(ctx.tree.nodes()[treeRoots[t].node].influence, ctx.point))
                out.push_back(t);
            else
                ++ctx.stats.treesSkipped;
        }
        if (!std::is_sorted(out.begin(), out.end())) std::sort(out.begin(), out.end());
        out.erase(std::unique(out.begin(), out.end()), out.end());
    }
    ctx.stats.treesSearched += std::uint32_t(out.size());
}

void startTree(const Context& ctx, std::uint32_t t, std::vector<Entry>& heap) {
    const std::uint32_t node = ctx.view.effective(ctx.tree.roots()[t].node);
    if (node != kNoLightNode) heap.push_back(makeEntry(ctx, node, kUnknown));
}

LightcutResult freshCut(const LightTree& tree, std::span<const std::uint32_t> roots, bool all,
                        const LightcutPoint& point, const LightcutOptions& options,
                        const LightVisibility& visibility, const RegionView& view = {}) {
    LightcutResult result;
    const Context ctx(tree, point, options, visibility, result.stats, view);
    std::vector<Entry> cut;
    std::vector<HeapItem> heap;
    std::vector<std::uint32_t> trees;
    treesAt(ctx, roots, all, trees);
    for (std::uint32_t t : trees) startTree(ctx, t, cut);
    refine(ctx, cut, heap, result);
    return result;
}

}  // namespace

double LightcutPoint::response(Vec3d toLight) const noexcept {
    if (!axisWeighted) return std::max(0.0, dot(normal, toLight));
    double v = 0;
    for (int axis = 0; axis < 3; ++axis) {
        const double l = toLight[axis];
        v += l > 0 ? axisWeights[std::size_t(2 * axis)] * l
                   : axisWeights[std::size_t(2 * axis + 1)] * -l;
    }
    if (axisCosineWeight > 0) v += axisCosineWeight * std::max(0.0, dot(normal, toLight));
    return v;
}

LightcutPoint LightcutPoint::lambertian(Vec3d position, Vec3d normal, Vec3d albedo) {
    LightcutPoint p;
    p.position = position;
    p.normal = normalize(normal);
    p.albedo = albedo;
    return p;
}

LightcutPoint LightcutPoint::voxel(Vec3d position, const VoxelNormals& normals, Attenuation mode,
                                   Vec3d albedo) {
    LightcutPoint p = lambertian(position, vec3Cast<double>(normals.mean), albedo);
    switch (mode) {
        case Attenuation::Weighted:
            p.axisWeighted = true;
            for (std::size_t k = 0; k < 6; ++k)
                p.axisWeights[k] = std::max(0.0f, normals.moments[k]);
            break;
        case Attenuation::Paper:
            // V = Σ n_s² max(sign(n_s) L_s, 0): the weight n_s² on the side n_s points to.
            p.axisWeighted = true;
            for (int axis = 0; axis < 3; ++axis) {
                const double n = p.normal[axis];
                p.axisWeights[std::size_t(2 * axis + (n < 0 ? 1 : 0))] = n * n;
            }
            break;
        case Attenuation::Average:
            break;
        case Attenuation::Adaptive: {
            // A flat voxel is a plain cosine point on the moments' mean direction.
            const AdaptiveAttenuation a = adaptiveAttenuation(normals);
            if (a.flat > 0) p.normal = normalize(a.mean);
            if (a.flat == 1) break;
            p.axisWeighted = true;
            for (std::size_t k = 0; k < 6; ++k)
                p.axisWeights[k] = (1 - a.flat) * std::max(0.0f, normals.moments[k]);
            p.axisCosineWeight = a.flat;
            break;
        }
    }
    return p;
}

Vec3d lightcutBound(const LightTree& tree, std::uint32_t node, const LightcutPoint& point) {
    return boundOf(tree.nodes().at(node), Response(point), point.position, point.albedo * kInvPi);
}

Vec3d lightContribution(const Light& light, const LightcutPoint& point,
                        const LightVisibility& visibility) {
    LightArrival arrival;
    if (!lightArrival(light, point.position, arrival)) return {0, 0, 0};
    const double response = point.response(arrival.toLight);
    if (!(response > 0)) return {0, 0, 0};
    const double v = visibility ? visibilityOf(visibility, light, arrival) : 1.0;
    return point.albedo * kInvPi * arrival.irradiance * (response * v);
}

LightcutResult evaluateCut(const LightTree& tree, const LightcutPoint& point,
                           const LightcutOptions& options, const LightVisibility& visibility) {
    return freshCut(tree, {}, true, point, options, visibility);
}

LightcutResult evaluateCut(const LightTree& tree, std::span<const std::uint32_t> roots,
                           const LightcutPoint& point, const LightcutOptions& options,
                           const LightVisibility& visibility) {
    return freshCut(tree, roots, false, point, options, visibility);
}

LightcutResult bruteForce(const LightTree& tree, const LightcutPoint& point,
                          const LightVisibility& visibility) {
    LightcutResult result;
    const auto& lights = tree.lights();
    for (std::uint32_t i = 0; i < lights.size(); ++i) {
        if (tree.leafOf(i) == kNoLightNode) continue;
        ++result.stats.lightEvaluations;
        ++result.stats.cutSize;
        LightArrival arrival;
        if (!lightArrival(lights[i], point.position, arrival)) continue;
        const double response = point.response(arrival.toLight);
        if (!(response > 0)) continue;
        double v = 1;
        if (visibility) {
            ++result.stats.visibilityEvaluations;
            v = visibilityOf(visibility, lights[i], arrival);
        }
        result.radiance += point.albedo * kInvPi * arrival.irradiance * (response * v);
    }
    return result;
}

/// The cursor's working storage, kept from point to point so that a point allocates nothing.
struct LightcutCursor::Scratch {
    std::vector<std::uint32_t> here, present, work;
    std::vector<Entry> entries;
    std::vector<HeapItem> heap;
    std::vector<char> dead;
    RegionView view;
    /// Per node of the tree: (point stamp, its entry); valid where the stamp is this point's, so
    /// that nothing is cleared from point to point.
    std::vector<std::pair<std::uint32_t, std::uint32_t>> slots;
    std::uint32_t stamp = 0;

    void clearIndex(std::size_t nodes) {
        if (slots.size() != nodes || ++stamp == 0) {
            slots.assign(nodes, {0, 0});
            stamp = 1;
        }
    }
    void index(std::uint32_t node, std::uint32_t entry) { slots[node] = {stamp, entry}; }
    /// The entry of @p node, or kNoLightNode.
    [[nodiscard]] std::uint32_t find(std::uint32_t node) const {
        return slots[node].first == stamp ? slots[node].second : kNoLightNode;
    }
};

LightcutCursor::LightcutCursor(const LightTree& tree, const LightcutOptions& options)
    : tree_(&tree), options_(options), scratch_(std::make_unique<Scratch>()) {}

LightcutCursor::LightcutCursor(const LightcutCursor& other)
    : tree_(other.tree_),
      options_(other.options_),
      roots_(other.roots_),
      allRoots_(other.allRoots_),
      previous_(other.previous_),
      havePrevious_(other.havePrevious_),
      scratch_(std::make_unique<Scratch>()) {
    scratch_->view = other.scratch_->view;
}

LightcutCursor& LightcutCursor::operator=(const LightcutCursor& other) {
    if (this != &other) {
        LightcutCursor copy(other);
        *this = std::move(copy);
    }
    return *this;
}

LightcutCursor::LightcutCursor(LightcutCursor&&) noexcept = default;
LightcutCursor& LightcutCursor::operator=(LightcutCursor&&) noexcept = default;
LightcutCursor::~LightcutCursor() = default;

void LightcutCursor::setRoots(std::vector<std::uint32_t> roots) {
    setRoots(std::move(roots), Bounds3f{});
}

void LightcutCursor::setRoots(std::vector<std::uint32_t> roots, const Bounds3f& region) {
    roots_ = std::move(roots);
    // Ascending and unique, as the trees searched at a point are kept.
    std::sort(roots_.begin(), roots_.end());
    roots_.erase(std::unique(roots_.begin(), roots_.end()), roots_.end());
    allRoots_ = false;
    scratch_->view.reset(tree_->nodes(), region);
    reset();
}

void LightcutCursor::clearRoots() {
    roots_.clear();
    allRoots_ = true;
    scratch_->view.reset(tree_->nodes(), Bounds3f{});
    reset();
}

void LightcutCursor::reset() {
    previous_.clear();
    havePrevious_ = false;
}

LightcutResult LightcutCursor::evaluate(const LightcutPoint& point,
                                        const LightVisibility& visibility) {
    const LightTree& tree = *tree_;
    if (!havePrevious_) {
        LightcutResult result =
            freshCut(tree, roots_, allRoots_, point, options_, visibility, scratch_->view);
        previous_.assign(result.cut.begin(), result.cut.end());
        havePrevious_ = true;
        return result;
    }
    LightcutResult result;
    Scratch& w = *scratch_;
    const Context ctx(tree, point, options_, visibility, result.stats, w.view);
    const auto& nodes = tree.nodes();

    // The previous cut's nodes in trees still searched, evaluated here; trees entered since start
    // from their roots.
    treesAt(ctx, roots_, allRoots_, w.here);
    const std::vector<std::uint32_t>& here = w.here;
    std::vector<std::uint32_t>& present = w.present;  // per tree of here: 1 if the cut holds it
    std::vector<Entry>& entries = w.entries;
    present.assign(here.size(), 0);
    entries.clear();
    for (std::uint32_t node : previous_) {
        const auto at = std::lower_bound(here.begin(), here.end(), tree.treeOf(node));
        if (at == here.end() || *at != tree.treeOf(node)) continue;
        present[std::size_t(at - here.begin())] = 1;
        entries.push_back(makeEntry(ctx, node, kUnknown));
    }
    for (std::size_t k = 0; k < here.size(); ++k)
        if (!present[k]) startTree(ctx, here[k], entries);

    // Backtrack over-split parts: a parent replaces its two children when both are in the cut and
    // the cut still meets the criterion with it, against the threshold of the cut's total here;
    // repeatedly, so the cut climbs to the highest such ancestor.
    Vec3d total{0, 0, 0};
    Budget budget(options_.criterion);
    for (const Entry& e : entries) {
        total += e.estimate;
        budget.add(e.key);
    }
    const double threshold = thresholdOf(options_, total);
    w.clearIndex(nodes.size());
    for (std::uint32_t i = 0; i < entries.size(); ++i) w.index(entries[i].node, i);
    // dead: replaced by its parent; 2: its pair was tried and stays apart (the measure only
    // grows as parents replace pairs, so a pair that fails once fails again).
    std::vector<char>& dead = w.dead;
    dead.assign(entries.size(), 0);
    std::vector<std::uint32_t>& work = w.work;
    work.clear();
    for (std::uint32_t i = 0; i < entries.size(); ++i)
        if (entries[i].key <= threshold) work.push_back(i);
    while (!work.empty()) {
        const std::uint32_t i = work.back();
        work.pop_back();
        if (dead[i]) continue;  // merged, or its pair was tried
        const std::uint32_t u = entries[i].node;
        // The parent as the region sees it: the first ancestor whose other child has light there.
        std::uint32_t from = u, p = nodes[u].parent, s = kNoLightNode;
        for (; p != kNoLightNode; from = p, p = nodes[p].parent) {
            s = ctx.view.effective(nodes[p].left == from ? nodes[p].right : nodes[p].left);
            if (s != kNoLightNode) break;
        }
        if (p == kNoLightNode) continue;
        const std::uint32_t j = w.find(s);
        if (j == kNoLightNode || dead[j]) continue;
        if (entries[j].key > threshold) continue;
        // Tried once, from either side: the measure only grows as parents replace pairs (a
        // parent's bound is at least the sum of its children's), so a pair that fails here
        // fails again later. A child's bound is at least its estimate: where even the estimates'
        // sum fails the criterion, neither the leaves' bounds nor the parent need be evaluated.
        dead[j] = 2;
        if (!budget.acceptsReplacing(entries[i].key, entries[j].key,
                                     lightLuminance(entries[i].estimate + entries[j].estimate),
                                     threshold))
            continue;
        if (!budget.acceptsReplacing(entries[i].key, entries[j].key,
                                     boundLumOf(ctx, entries[i]) + boundLumOf(ctx, entries[j]),
                                     threshold))
            continue;
        const std::uint32_t rep = nodes[p].representative;
        const double g = rep == nodes[u].representative   ? entries[i].g
                         : rep == nodes[s].representative ? entries[j].g
                                                          : kUnknown;
        const Entry e = makeEntry(ctx, p, g);
        if (!budget.acceptsReplacing(entries[i].key, entries[j].key, e.key, threshold)) continue;
        budget.remove(entries[i].key);
        budget.remove(entries[j].key);
        budget.add(e.key);
        dead[i] = dead[j] = 1;
        ++result.stats.mergedBack;
        entries.push_back(e);
        dead.push_back(0);
        w.index(p, std::uint32_t(entries.size() - 1));
        work.push_back(std::uint32_t(entries.size() - 1));
    }
    // Merged entries leave the cut in place (refine skips them).
    for (std::uint32_t i = 0; i < entries.size(); ++i)
        if (dead[i] == 1) {
            entries[i].node = kNoLightNode;
            entries[i].key = -1;
        }

    // Split what is under-split, as a fresh cut does.
    refine(ctx, entries, w.heap, result);
    previous_.assign(result.cut.begin(), result.cut.end());
    return result;
}

}  // namespace vox
