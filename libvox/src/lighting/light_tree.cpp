// The Lightcuts light tree (Walter et al. 2005) and its binary-tree forest (paper 1.2): exact
// greedy agglomerative clustering, the cheapest allowed pair found through a k-d tree over the
// clusters with lower bounds on the merge cost (after Walter et al. 2008, "Fast agglomerative
// clustering for rendering"); in a forest a pair is allowed only while its merged extent stays
// within the reach of the two clusters' representatives' influence spheres.
#include "../util/splitmix.h"

#include <vox/lightcuts.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <queue>
#include <stdexcept>

namespace vox {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr std::uint32_t kDead = kNoLightNode;

Bounds3f unionOf(const Bounds3f& a, const Bounds3f& b) {
    Bounds3f r = a;
    r.add(b);
    return r;
}

bool overlaps(const Bounds3f& a, const Bounds3f& b) {
    return a.min.x <= b.max.x && b.min.x <= a.max.x && a.min.y <= b.max.y && b.min.y <= a.max.y &&
           a.min.z <= b.max.z && b.min.z <= a.max.z;
}

struct Cone {
    Vec3d axis;
    double theta;  // half-angle, radians; ≥ π: every direction
};

/// The smallest cone (up to a little padding against rounding) holding both cones.
Cone unionCone(Cone a, Cone b) {
    if (a.theta >= kPi || b.theta >= kPi) return {a.axis, kPi};
    const double cosD = std::clamp(dot(a.axis, b.axis), -1.0, 1.0);
    const double d = std::acos(cosD);
    if (d + b.theta <= a.theta) return a;
    if (d + a.theta <= b.theta) return b;
    const double theta = 0.5 * (a.theta + d + b.theta) + 1e-6;
    if (theta >= kPi) return {a.axis, kPi};
    const Vec3d ortho = b.axis - a.axis * cosD;
    const double len = length(ortho);
    if (!(len > 1e-12)) return {a.axis, kPi};  // (anti)parallel axes that neither cone holds
    const double turn = theta - a.theta;
    return {normalize(a.axis * std::cos(turn) + ortho * (std::sin(turn) / len)), theta};
}

Cone coneOf(const LightTreeNode& n) {
    return {vec3Cast<double>(n.coneAxis), double(n.coneHalfAngle)};
}

double diagonal2(const Bounds3f& a, const Bounds3f& b) {
    double s = 0;
    for (int k = 0; k < 3; ++k) {
        const double e =
            double(std::max(a.max[k], b.max[k])) - double(std::min(a.min[k], b.min[k]));
        s += e * e;
    }
    return s;
}

/// The half-angle unionCone would give (without its axis).
double unionHalfAngle(Vec3f axisA, double ta, Vec3f axisB, double tb) {
    if (ta >= kPi || tb >= kPi) return kPi;
    const double d =
        std::acos(std::clamp(dot(vec3Cast<double>(axisA), vec3Cast<double>(axisB)), -1.0, 1.0));
    if (d + tb <= ta) return ta;
    if (d + ta <= tb) return tb;
    return std::min(kPi, 0.5 * (ta + d + tb) + 1e-6);
}

/// Walter 2005's merge cost is (I_A + I_B) × (diagonal² + c²·(1 − cos θ)²); this is (1 − cos θ)² of
/// the merged spot cone, 4 (θ = π) where a point light meets a spot, 0 without spots.
double orientationTerm(bool spotA, bool omniA, Vec3f axisA, double ta, bool spotB, bool omniB,
                       Vec3f axisB, double tb) {
    if (!spotA && !spotB) return 0;
    if (omniA || omniB) return 4;
    const double t = 1 - std::cos(unionHalfAngle(axisA, ta, axisB, tb));
    return t * t;
}

/// The least orientation term (without c²) of @p a with any cluster: its own cone's (1 − cos θ)².
double orientationFloor(const LightTreeNode& a) {
    if (!a.hasSpot) return 0;
    const double t = 1 - std::cos(std::min(kPi, double(a.coneHalfAngle)));
    return t * t;
}

/// A lower bound on the orientation term (without c²) of two spot-only clusters whose axes are at
/// least chord √chord2 apart: θ ≥ δ/2, so 1 − cos θ ≥ 2·sin²(δ/4) ≥ sin²(δ/2)/2 = chord²/8.
double chordBound(double chord2) { return (chord2 / 8) * (chord2 / 8); }

/// What the partner search reads of a cluster, stored by slot so that k-d leaves scan memory in
/// order.
struct SlotData {
    Bounds3f bounds;
    Vec3f axis;
    float halfAngle = 0;
    double luminance = 0;
    double radius = 0;  // the representative's influence radius (forest)
    std::uint32_t id = kDead;
    bool hasSpot = false, hasOmni = false;

    static SlotData of(const LightTreeNode& n, std::uint32_t id, double radius) {
        return {n.bounds, n.coneAxis, n.coneHalfAngle, n.luminance,
                radius,   id,         n.hasSpot,       n.hasOmni};
    }
};

/// The forest's rule (paper 1.2): clusters merge only while the merge weight (I_A + I_B)·d² stays
/// at most the weight at which the two representatives' influence spheres just touch,
/// (I_A + I_B)·(r_A + r_B)², i.e. while the merged position box's diagonal d ≤ r_A + r_B.
bool forestAllows(double diagonal2, double ra, double rb) {
    const double reach = ra + rb;
    return std::isinf(reach) || diagonal2 <= reach * reach;
}

/// A k-d tree over the live clusters (by box centre) answering "cheapest partner of A": each k-d
/// node keeps a box holding its clusters' position boxes, their kinds of light, a box holding their
/// spot axes and a lower bound on their luminance, so whole subtrees are skipped by a lower bound
/// on the cost. Merges update it in place (the merged cluster takes one child's slot, boxes only
/// grow, the other slot dies); it is rebuilt when half its slots have died.
class ClusterIndex {
public:
    /// @p radius: influence radius per light for the forest's rule, null for a classic tree.
    ClusterIndex(const std::vector<LightTreeNode>& nodes, double c2,
                 const std::vector<double>* radius)
        : nodes_(nodes), c2_(c2), radius_(radius), slotOf_(nodes.capacity(), kDead) {}

    void build(std::vector<std::uint32_t> ids) {
        slots_ = std::move(ids);
        data_.resize(slots_.size());
        kd_.clear();
        slotLeaf_.assign(slots_.size(), 0);
        for (std::size_t s = 0; s < slots_.size(); ++s) slotOf_[slots_[s]] = std::uint32_t(s);
        built_ = slots_.size();
        alive_ = slots_.size();
        if (!slots_.empty()) buildNode(0, std::uint32_t(slots_.size()), kDead);
        for (std::size_t s = 0; s < slots_.size(); ++s)
            data_[s] = SlotData::of(nodes_[slots_[s]], slots_[s], radiusOf(slots_[s]));
    }

    [[nodiscard]] std::size_t alive() const noexcept { return alive_; }
    [[nodiscard]] std::size_t built() const noexcept { return built_; }

    /// The cheapest partner of cluster @p a that the forest's rule allows (cost, id), or
    /// (+∞, kDead) if there is none.
    [[nodiscard]] std::pair<double, std::uint32_t> nearest(std::uint32_t a) const {
        double best = kInf;
        std::uint32_t bestId = kDead;
        if (kd_.empty()) return {best, bestId};
        const LightTreeNode& A = nodes_[a];
        const double floor = orientationFloor(A);
        const bool spotOnly = A.hasSpot && !A.hasOmni;
        const Vec3d axisA = vec3Cast<double>(A.coneAxis);
        const double ra = radiusOf(a);
        std::vector<std::pair<double, std::uint32_t>> stack;
        stack.reserve(64);
        double d2root = 0;
        stack.emplace_back(lowerBound(A, kd_[0], floor, d2root), 0);
        while (!stack.empty()) {
            const auto [lb, k] = stack.back();
            stack.pop_back();
            if (lb > best) continue;
            const Kd& K = kd_[k];
            if (K.leaf) {
                for (std::uint32_t s = K.first; s < K.second; ++s) {
                    const SlotData& B = data_[s];
                    const std::uint32_t id = B.id;
                    if (id == kDead || id == a) continue;
                    // The cost without the orientation term first: most candidates stop there.
                    const double weight = A.luminance + B.luminance;
                    const double d2 = diagonal2(A.bounds, B.bounds);
                    if (radius_ && !forestAllows(d2, ra, B.radius)) continue;
                    double orientation = floor;
                    if (spotOnly && B.hasSpot && !B.hasOmni) {
                        const Vec3d chord = axisA - vec3Cast<double>(B.axis);
                        orientation = std::max(floor, chordBound(dot(chord, chord)));
                    }
                    if (weight * (d2 + c2_ * orientation) > best) continue;
                    const double c =
                        weight * (d2 + c2_ * orientationTerm(A.hasSpot, A.hasOmni, A.coneAxis,
                                                             A.coneHalfAngle, B.hasSpot, B.hasOmni,
                                                             B.axis, B.halfAngle));
                    if (c < best || (c == best && id < bestId)) {
                        best = c;
                        bestId = id;
                    }
                }
                continue;
            }
            std::pair<double, std::uint32_t> children[2];
            int count = 0;
            for (std::uint32_t child : {K.first, K.second}) {
                const Kd& C = kd_[child];
                if (C.alive == 0) continue;
                double d2lb = 0;
                const double clb = lowerBound(A, C, floor, d2lb);
                if (radius_ && !forestAllows(d2lb, ra, C.maxRadius)) continue;
                if (clb > best) continue;
                children[count++] = {clb, child};
            }
            // Nearer child last: popped first.
            if (count == 2 && children[0].first < children[1].first)
                std::swap(children[0], children[1]);
            for (int i = 0; i < count; ++i) stack.push_back(children[i]);
        }
        return {best, bestId};
    }

    /// Clusters @p a and @p b have merged into @p c.
    void merge(std::uint32_t a, std::uint32_t b, std::uint32_t c) {
        const std::uint32_t sa = slotOf_[a], sb = slotOf_[b];
        slots_[sa] = c;
        slotOf_[c] = sa;
        slots_[sb] = kDead;
        const LightTreeNode& C = nodes_[c];
        data_[sa] = SlotData::of(C, c, radiusOf(c));
        data_[sb].id = kDead;
        for (std::uint32_t k = slotLeaf_[sa]; k != kDead; k = kd_[k].parent) {
            Kd& K = kd_[k];
            K.bounds.add(C.bounds);
            K.maxRadius = std::max(K.maxRadius, data_[sa].radius);
            // A's flags held for K; C holds at least A's kinds of light.
            if (C.hasSpot && !C.hasOmni) K.axes.add(C.coneAxis);
        }
        for (std::uint32_t k = slotLeaf_[sb]; k != kDead; k = kd_[k].parent) --kd_[k].alive;
        --alive_;
    }

    /// Live clusters, in slot order.
    [[nodiscard]] std::vector<std::uint32_t> live() const {
        std::vector<std::uint32_t> out;
        out.reserve(alive_);
        for (std::uint32_t id : slots_)
            if (id != kDead) out.push_back(id);
        return out;
    }

private:
    struct Kd {
        Bounds3f bounds;  // holds every live cluster's position box below
        Bounds3f axes;  // holds the spot-axis cone axes of the clusters below without point lights
        bool allSpot = true;  // every cluster below holds a spot light
        bool allOmni = true;  // every cluster below holds a point light
        double minLuminance = 0;
        double maxRadius = 0;  // of the representatives below (forest)
        std::uint32_t alive = 0;
        std::uint32_t parent = kDead;
        std::uint32_t first = 0, second = 0;  // leaf: slot range; inner: children
        bool leaf = false;
    };

    /// The orientation term's least value over the clusters below K (without c²).
    double orientationBound(const LightTreeNode& A, const Kd& K, double floor) const {
        const bool spot = A.hasSpot || K.allSpot, omni = A.hasOmni || K.allOmni;
        if (spot && omni) return 4;
        if (!A.hasSpot || A.hasOmni || K.axes.empty()) return floor;
        // The distance from A's axis to the box of the axes below bounds the chord to any of them.
        double chord2 = 0;
        for (int k = 0; k < 3; ++k) {
            const double a = A.coneAxis[k];
            const double g = std::max({0.0, double(K.axes.min[k]) - a, a - double(K.axes.max[k])});
            chord2 += g * g;
        }
        return std::max(floor, chordBound(chord2));
    }

    [[nodiscard]] double radiusOf(std::uint32_t id) const {
        return radius_ ? (*radius_)[nodes_[id].representative] : kInf;
    }

    /// A lower bound on the cost of A with any cluster below K; @p d2 gets the lower bound on
    /// the merged box's squared diagonal.
    double lowerBound(const LightTreeNode& A, const Kd& K, double floor, double& d2) const {
        // Per axis the union's extent is at least A's extent plus the gap between A and the box
        // that holds every candidate's box.
        d2 = 0;
        for (int k = 0; k < 3; ++k) {
            const double lo = A.bounds.min[k], hi = A.bounds.max[k];
            const double gap =
                std::max({0.0, double(K.bounds.min[k]) - hi, lo - double(K.bounds.max[k])});
            const double e = hi - lo + gap;
            d2 += e * e;
        }
        return (A.luminance + K.minLuminance) * (d2 + c2_ * orientationBound(A, K, floor));
    }

    std::uint32_t buildNode(std::uint32_t first, std::uint32_t last, std::uint32_t parent) {
        const std::uint32_t index = std::uint32_t(kd_.size());
        kd_.emplace_back();
        Kd k;
        k.parent = parent;
        k.alive = last - first;
        k.minLuminance = kInf;
        Bounds3f centres;
        for (std::uint32_t s = first; s < last; ++s) {
            const LightTreeNode& n = nodes_[slots_[s]];
            k.bounds.add(n.bounds);
            k.minLuminance = std::min(k.minLuminance, n.luminance);
            k.maxRadius = std::max(k.maxRadius, radiusOf(slots_[s]));
            k.allSpot = k.allSpot && n.hasSpot;
            k.allOmni = k.allOmni && n.hasOmni;
            if (n.hasSpot && !n.hasOmni) {
                k.axes.add(n.coneAxis);
            }
            centres.add((n.bounds.min + n.bounds.max) * 0.5f);
        }
        constexpr std::uint32_t kLeafSize = 6;
        if (last - first <= kLeafSize) {
            k.leaf = true;
            k.first = first;
            k.second = last;
            for (std::uint32_t s = first; s < last; ++s) slotLeaf_[s] = index;
            kd_[index] = k;
            return index;
        }
        std::uint32_t mid = first + (last - first) / 2;
        std::uint32_t spotOnly = 0;
        for (std::uint32_t s = first; s < last; ++s)
            spotOnly += nodes_[slots_[s]].hasSpot && !nodes_[slots_[s]].hasOmni;
        if (spotOnly > 0 && spotOnly < last - first) {
            // Spot-only clusters apart from the others: a spot meeting a point light costs 4c², so
            // the two halves rarely need searching together.
            mid = std::uint32_t(std::stable_partition(slots_.begin() + first, slots_.begin() + last,
                                                      [&](std::uint32_t id) {
                                                          return !(nodes_[id].hasSpot &&
                                                                   !nodes_[id].hasOmni);
                                                      }) -
                                slots_.begin());
        } else {
            // Split the longest side of the centres' box; spot-only clusters also by their axes,
            // scaled by c/8 (the orientation term of two spots is at least c²·(chord²/8)², so
            // small angles matter little).
            Bounds3f axes;
            if (spotOnly > 0)
                for (std::uint32_t s = first; s < last; ++s) axes.add(nodes_[slots_[s]].coneAxis);
            const Vec3f e = centres.extent();
            const Vec3f ea = axes.extent() * float(std::sqrt(c2_) / 8);
            float longest = -1;
            int axis = 0;
            for (int a = 0; a < 6; ++a) {
                const float v = a < 3 ? e[a] : ea[a - 3];
                if (v > longest) {
                    longest = v;
                    axis = a;
                }
            }
            auto key = [&](std::uint32_t id) {
                const LightTreeNode& n = nodes_[id];
                return std::pair{
                    axis < 3 ? n.bounds.min[axis] + n.bounds.max[axis] : n.coneAxis[axis - 3], id};
            };
            std::nth_element(slots_.begin() + first, slots_.begin() + mid, slots_.begin() + last,
                             [&](std::uint32_t x, std::uint32_t y) { return key(x) < key(y); });
        }
        for (std::uint32_t s = first; s < last; ++s) slotOf_[slots_[s]] = s;
        kd_[index] = k;
        const std::uint32_t left = buildNode(first, mid, index);
        const std::uint32_t right = buildNode(mid, last, index);
        kd_[index].first = left;
        kd_[index].second = right;
        return index;
    }

    const std::vector<LightTreeNode>& nodes_;
    double c2_;
    const std::vector<double>* radius_;
    std::vector<Kd> kd_;
    std::vector<std::uint32_t> slots_;     // cluster id per slot, kDead once merged away
    std::vector<SlotData> data_;           // the cluster per slot (id kDead once merged away)
    std::vector<std::uint32_t> slotOf_;    // slot per cluster id
    std::vector<std::uint32_t> slotLeaf_;  // k-d leaf per slot
    std::size_t built_ = 0, alive_ = 0;
};

struct Pair {
    double cost;
    std::uint32_t a, b;
    // Min-heap order with a total tie-break, so that the merge order is fixed.
    bool operator>(const Pair& o) const {
        if (cost != o.cost) return cost > o.cost;
        if (a != o.a) return a > o.a;
        return b > o.b;
    }
};

}  // namespace

/// Clusters @p ids (parentless nodes, capacity for the new ones reserved) greedily until no
/// allowed pair is left (one tree without @p radius); returns the roots, ascending. A cluster is
/// live while it has no parent.
static std::vector<std::uint32_t> agglomerate(std::vector<LightTreeNode>& nodes,
                                              const std::vector<std::uint32_t>& ids, double c2,
                                              const std::vector<double>* radius) {
    if (ids.size() <= 1) return ids;
    ClusterIndex index(nodes, c2, radius);
    index.build(ids);
    auto alive = [&](std::uint32_t id) { return nodes[id].parent == kNoLightNode; };

    std::vector<std::pair<double, std::uint32_t>> first(ids.size());
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, ids.size(), 64),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                          for (std::size_t i = r.begin(); i != r.end(); ++i)
                              first[i] = index.nearest(ids[i]);
                      });
    std::priority_queue<Pair, std::vector<Pair>, std::greater<>> heap;
    for (std::size_t i = 0; i < ids.size(); ++i)
        if (first[i].second != kDead) heap.push({first[i].first, ids[i], first[i].second});

    while (!heap.empty()) {
        const Pair p = heap.top();
        heap.pop();
        if (!alive(p.a)) continue;
        if (!alive(p.b)) {
            // The partner merged away: the cheapest partner now (costs with a merged cluster only
            // grow, so the heap's minimum stays the cheapest pair overall).
            const auto [cost, b] = index.nearest(p.a);
            if (b != kDead) heap.push({cost, p.a, b});
            continue;
        }
        const std::uint32_t c = std::uint32_t(nodes.size());
        const LightTreeNode& A = nodes[p.a];
        const LightTreeNode& B = nodes[p.b];
        LightTreeNode n;
        n.left = p.a;
        n.right = p.b;
        n.lightCount = A.lightCount + B.lightCount;
        n.directional = A.directional;
        n.hasSpot = A.hasSpot || B.hasSpot;
        n.hasOmni = A.hasOmni || B.hasOmni;
        n.bounds = unionOf(A.bounds, B.bounds);
        n.influence = unionOf(A.influence, B.influence);
        const Cone cone = unionCone(coneOf(A), coneOf(B));
        n.coneAxis = vec3Cast<float>(cone.axis);
        n.coneHalfAngle = cone.theta >= kPi ? float(kPi) : floatAtOrAbove(cone.theta);
        n.maxOuterAngle = std::max(A.maxOuterAngle, B.maxOuterAngle);
        n.maxRange = std::max(A.maxRange, B.maxRange);
        n.intensity = A.intensity + B.intensity;
        n.luminance = A.luminance + B.luminance;
        // Representative ∝ the children's luminance, drawn by a hash of the two candidates.
        const double u =
            double(detail::splitmix64((std::uint64_t(A.representative) << 32) | B.representative) >>
                   11) *
            0x1p-53;
        n.representative = (n.luminance > 0 ? u * n.luminance < A.luminance : true)
                               ? A.representative
                               : B.representative;
        nodes[p.a].parent = c;
        nodes[p.b].parent = c;
        nodes.push_back(n);  // capacity reserved: no reallocation
        index.merge(p.a, p.b, c);
        if (index.alive() * 2 < index.built() && index.alive() > 16) index.build(index.live());
        const auto [cost, partner] = index.nearest(c);
        if (partner != kDead) heap.push({cost, c, partner});
    }
    std::vector<std::uint32_t> roots = index.live();
    std::sort(roots.begin(), roots.end());
    return roots;
}

LightTree::LightTree(std::span<const Light> lights, const LightTreeOptions& options)
    : lights_(lights.begin(), lights.end()),
      leafOf_(lights.size(), kNoLightNode),
      radius_(lights.size(), 0.0) {
    if (lights.size() >= std::size_t(kNoLightNode) / 2)
        throw std::invalid_argument("LightTree: too many lights");
    const std::size_t n = lights.size();
    auto rgbOf = [](const Light& l) { return vec3Cast<double>(l.color) * double(l.intensity); };
    std::vector<char> usable(n, 0);
    Bounds3f positions;
    double brightest = 0;
    for (std::size_t i = 0; i < n; ++i) {
        const Light& l = lights[i];
        const Vec3d rgb = rgbOf(l);
        bool ok = !l.dynamic && isFinite(rgb) && rgb.x >= 0 && rgb.y >= 0 && rgb.z >= 0;
        if (l.type == Light::Type::Directional)
            ok = ok && isFinite(l.direction) && length(vec3Cast<double>(l.direction)) > 0;
        else
            ok = ok && isFinite(l.position) && std::isfinite(l.range);
        if (l.type == Light::Type::Spot)
            ok = ok && isFinite(l.direction) && length(vec3Cast<double>(l.direction)) > 0;
        usable[i] = ok;
        if (!ok || l.type == Light::Type::Directional) continue;
        positions.add(l.position);
        brightest = std::max(brightest, lightLuminance(rgb));
    }
    if (!positions.empty()) diagonal_ = length(vec3Cast<double>(positions.extent()));
    threshold_ =
        options.influenceThreshold > 0
            ? options.influenceThreshold
            : (options.relativeInfluence > 0 ? options.relativeInfluence * brightest : 0.0);
    if (!(threshold_ > 0) || !std::isfinite(threshold_) || !options.forest) threshold_ = 0;

    nodes_.reserve(2 * n + 1);
    std::vector<std::uint32_t> local, directional;
    for (std::size_t i = 0; i < n; ++i) {
        if (!usable[i]) continue;
        const Light& l = lights[i];
        LightTreeNode leaf;
        leaf.representative = std::uint32_t(i);
        leaf.lightCount = 1;
        leaf.intensity = rgbOf(l);
        leaf.luminance = lightLuminance(leaf.intensity);
        const float inf = std::numeric_limits<float>::infinity();
        if (l.type == Light::Type::Directional) {
            // Clustered by the unit vector towards the light, exactly as lightArrival computes it.
            leaf.directional = true;
            const Vec3d to = -normalize(vec3Cast<double>(l.direction));
            constexpr double pad = 1e-6;
            leaf.bounds.add(Vec3f{floatAtOrBelow(to.x - pad), floatAtOrBelow(to.y - pad),
                                  floatAtOrBelow(to.z - pad)});
            leaf.bounds.add(Vec3f{floatAtOrAbove(to.x + pad), floatAtOrAbove(to.y + pad),
                                  floatAtOrAbove(to.z + pad)});
            leaf.influence = {{-inf, -inf, -inf}, {inf, inf, inf}};
            leaf.maxRange = inf;
            radius_[i] = kInf;
            directional.push_back(std::uint32_t(nodes_.size()));
        } else {
            leaf.bounds.add(l.position);
            leaf.maxRange = l.range > 0 ? l.range : inf;
            double r = l.range > 0
                           ? double(l.range)
                           : (threshold_ > 0 ? std::sqrt(leaf.luminance / threshold_) : kInf);
            radius_[i] = r;
            if (std::isinf(r)) {
                leaf.influence = {{-inf, -inf, -inf}, {inf, inf, inf}};
            } else {
                const Vec3d p = vec3Cast<double>(l.position);
                leaf.influence.add(Vec3f{floatAtOrBelow(p.x - r), floatAtOrBelow(p.y - r),
                                         floatAtOrBelow(p.z - r)});
                leaf.influence.add(Vec3f{floatAtOrAbove(p.x + r), floatAtOrAbove(p.y + r),
                                         floatAtOrAbove(p.z + r)});
            }
            if (l.type == Light::Type::Spot) {
                leaf.hasSpot = true;
                leaf.coneAxis = vec3Cast<float>(normalize(vec3Cast<double>(l.direction)));
                leaf.coneHalfAngle = 1e-6f;  // the float axis is within that of the exact one
                leaf.maxOuterAngle = std::max(0.0f, l.outerConeAngle);
            } else {
                leaf.hasOmni = true;
            }
            local.push_back(std::uint32_t(nodes_.size()));
        }
        leafOf_[i] = std::uint32_t(nodes_.size());
        nodes_.push_back(leaf);
    }

    for (std::uint32_t r :
         agglomerate(nodes_, local, diagonal_ * diagonal_, options.forest ? &radius_ : nullptr))
        roots_.push_back({r, false});
    for (std::uint32_t r : agglomerate(nodes_, directional, 0.0, nullptr))
        roots_.push_back({r, true});

    treeOf_.assign(nodes_.size(), kNoLightNode);
    std::vector<std::uint32_t> stack;
    for (std::uint32_t t = 0; t < roots_.size(); ++t) {
        stack.push_back(roots_[t].node);
        while (!stack.empty()) {
            const std::uint32_t k = stack.back();
            stack.pop_back();
            treeOf_[k] = t;
            if (!nodes_[k].leaf()) {
                stack.push_back(nodes_[k].left);
                stack.push_back(nodes_[k].right);
            }
        }
    }
    buildRootIndex();
}

void LightTree::buildRootIndex() {
    // A bounding volume hierarchy over the trees' influence boxes; unbounded ones are kept apart.
    rootIndex_.clear();
    rootOrder_.clear();
    unboundedRoots_.clear();
    for (std::uint32_t t = 0; t < roots_.size(); ++t) {
        const Bounds3f& b = nodes_[roots_[t].node].influence;
        const bool finite = std::isfinite(b.min.x) && std::isfinite(b.min.y) &&
                            std::isfinite(b.min.z) && std::isfinite(b.max.x) &&
                            std::isfinite(b.max.y) && std::isfinite(b.max.z);
        (finite ? rootOrder_ : unboundedRoots_).push_back(t);
    }
    if (rootOrder_.empty()) return;
    auto build = [&](auto&& self, std::uint32_t first, std::uint32_t last) -> void {
        const std::uint32_t index = std::uint32_t(rootIndex_.size());
        rootIndex_.push_back({});
        Bounds3f bounds, centres;
        for (std::uint32_t k = first; k < last; ++k) {
            const Bounds3f& b = nodes_[roots_[rootOrder_[k]].node].influence;
            bounds.add(b);
            centres.add((b.min + b.max) * 0.5f);
        }
        rootIndex_[index].bounds = bounds;
        if (last - first <= 4) {
            rootIndex_[index].first = first;
            rootIndex_[index].count = last - first;
            return;
        }
        const Vec3f e = centres.extent();
        const int axis = e.x >= e.y && e.x >= e.z ? 0 : (e.y >= e.z ? 1 : 2);
        const std::uint32_t mid = first + (last - first) / 2;
        std::nth_element(rootOrder_.begin() + first, rootOrder_.begin() + mid,
                         rootOrder_.begin() + last, [&](std::uint32_t x, std::uint32_t y) {
                             const Bounds3f& a = nodes_[roots_[x].node].influence;
                             const Bounds3f& b = nodes_[roots_[y].node].influence;
                             return std::pair{a.min[axis] + a.max[axis], x} <
                                    std::pair{b.min[axis] + b.max[axis], y};
                         });
        self(self, first, mid);                                      // left child: index + 1
        rootIndex_[index].first = std::uint32_t(rootIndex_.size());  // right child
        rootIndex_[index].count = 0;
        self(self, mid, last);
    };
    build(build, 0, std::uint32_t(rootOrder_.size()));
}

template <typename Test>
static void visitRoots(const std::vector<LightTree::Root>& roots,
                       const std::vector<LightTreeNode>& nodes,
                       const std::vector<LightTree::RootIndexNode>& index,
                       const std::vector<std::uint32_t>& order,
                       const std::vector<std::uint32_t>& unbounded, Test test,
                       std::vector<std::uint32_t>& out) {
    out.clear();
    for (std::uint32_t t : unbounded)
        if (roots[t].directional || test(nodes[roots[t].node].influence)) out.push_back(t);
    if (!index.empty()) {
        std::uint32_t stack[64];
        int top = 0;
        stack[top++] = 0;
        while (top > 0) {
            const std::uint32_t k = stack[--top];
            const LightTree::RootIndexNode& n = index[k];
            if (!test(n.bounds)) continue;
            if (n.count > 0) {
                for (std::uint32_t i = n.first; i < n.first + n.count; ++i)
                    if (test(nodes[roots[order[i]].node].influence)) out.push_back(order[i]);
            } else {
                stack[top++] = n.first;
                stack[top++] = k + 1;
            }
        }
    }
    std::sort(out.begin(), out.end());
}

void LightTree::rootsContaining(Vec3d point, std::vector<std::uint32_t>& out) const {
    visitRoots(
        roots_, nodes_, rootIndex_, rootOrder_, unboundedRoots_,
        [&](const Bounds3f& b) {
            return point.x >= b.min.x && point.x <= b.max.x && point.y >= b.min.y &&
                   point.y <= b.max.y && point.z >= b.min.z && point.z <= b.max.z;
        },
        out);
}

std::size_t LightTree::leafCount() const noexcept {
    return std::size_t(std::count_if(leafOf_.begin(), leafOf_.end(),
                                     [](std::uint32_t k) { return k != kNoLightNode; }));
}

std::vector<std::uint32_t> LightTree::rootsOverlapping(const Bounds3f& region) const {
    std::vector<std::uint32_t> out;
    if (region.empty()) return out;
    visitRoots(
        roots_, nodes_, rootIndex_, rootOrder_, unboundedRoots_,
        [&](const Bounds3f& b) { return overlaps(b, region); }, out);
    return out;
}

}  // namespace vox
