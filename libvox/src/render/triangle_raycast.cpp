// BVH over triangles: a binary tree by binned surface-area-heuristic splits (up to four triangles
// per leaf), collapsed into eight-wide nodes whose children's boxes one ray tests at once (eight
// lanes with AVX2, else four twice); children visited nearer first; a leaf's four triangles
// intersected at once (Möller–Trumbore). Each lane evaluates the very float operations of the
// one-triangle, one-box test, in the same order.
#include "triangle_raycast_kernels.h"

#include "../scene/surface_shading.h"
#include "../util/cpu_features.h"

#include <vox/formats/esvo_attributes.h>
#include <vox/texture.h>
#include <vox/triangle_raycast.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <numeric>
#include <stdexcept>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define VOX_TRIANGLE_AVX2 1
#include <immintrin.h>
#else
#define VOX_TRIANGLE_AVX2 0
#endif

namespace vox {

namespace {

/// Binned SAH build (Wald 2007): bins per axis, and the relative costs of a node visit and of a
/// leaf's test of up to four triangles at once (so a leaf costs as many tests as it has groups of
/// four, not triangles: with four-wide nodes, 7–22 % more bounce rays per second on the bench
/// meshes than counting triangles, and about the same at twice the cost).
constexpr int kSahBins = 16;
constexpr float kTraversalCost = 1.0f;
constexpr float kPacketCost = 1.0f;
/// A leaf holds at most this many triangles unless they cannot be split (equal centroids).
constexpr std::uint32_t kMaxLeafTriangles = 4;
/// Below this depth nodes split at the median (log2 of the triangles more levels at most), so
/// that no path exceeds the traversal's stack.
constexpr std::uint32_t kMaxSahDepth = 64;
/// A wide node leaves at most seven siblings on the stack per level, over at most
/// kMaxSahDepth + 32 levels.
constexpr int kStackEntries = 7 * (kMaxSahDepth + 33);
constexpr std::uint32_t kWidth = 8;  // children per WideNode
static_assert(kMaxLeafTriangles == 4, "a leaf's triangles fill one TrianglePacket");

// Four float lanes: SSE2 where the target has it (every x86-64), else a plain loop. Comparisons
// give a bit per lane (bit i: lane i). maxKeep / minKeep return the accumulator where the
// candidate is NaN (0·∞ in a slab test where the ray runs in a box's face), as the one-box test
// does with std::max / std::min.
#if defined(__SSE2__)
struct Lanes {
    __m128 v;
};
inline Lanes load(const float* p) { return {_mm_load_ps(p)}; }
inline Lanes splat(float x) { return {_mm_set1_ps(x)}; }
inline Lanes operator+(Lanes a, Lanes b) { return {_mm_add_ps(a.v, b.v)}; }
inline Lanes operator-(Lanes a, Lanes b) { return {_mm_sub_ps(a.v, b.v)}; }
inline Lanes operator*(Lanes a, Lanes b) { return {_mm_mul_ps(a.v, b.v)}; }
inline Lanes operator/(Lanes a, Lanes b) { return {_mm_div_ps(a.v, b.v)}; }
inline Lanes maxKeep(Lanes candidate, Lanes acc) { return {_mm_max_ps(candidate.v, acc.v)}; }
inline Lanes minKeep(Lanes candidate, Lanes acc) { return {_mm_min_ps(candidate.v, acc.v)}; }
inline unsigned lessThan(Lanes a, Lanes b) {
    return unsigned(_mm_movemask_ps(_mm_cmplt_ps(a.v, b.v)));
}
inline unsigned lessEqual(Lanes a, Lanes b) {
    return unsigned(_mm_movemask_ps(_mm_cmple_ps(a.v, b.v)));
}
inline unsigned notEqual(Lanes a, Lanes b) {
    return unsigned(_mm_movemask_ps(_mm_cmpneq_ps(a.v, b.v)));
}
inline void store(float* p, Lanes a) { _mm_store_ps(p, a.v); }
#else
struct Lanes {
    float v[4];
};
template <typename Op>
inline Lanes lanewise(Lanes a, Lanes b, Op op) {
    Lanes r;
    for (int i = 0; i < 4; ++i) r.v[i] = op(a.v[i], b.v[i]);
    return r;
}
template <typename Op>
inline unsigned compare(Lanes a, Lanes b, Op op) {
    unsigned bits = 0;
    for (int i = 0; i < 4; ++i) bits |= op(a.v[i], b.v[i]) ? 1u << i : 0u;
    return bits;
}
inline Lanes load(const float* p) { return {{p[0], p[1], p[2], p[3]}}; }
inline Lanes splat(float x) { return {{x, x, x, x}}; }
inline Lanes operator+(Lanes a, Lanes b) {
    return lanewise(a, b, [](float x, float y) { return x + y; });
}
inline Lanes operator-(Lanes a, Lanes b) {
    return lanewise(a, b, [](float x, float y) { return x - y; });
}
inline Lanes operator*(Lanes a, Lanes b) {
    return lanewise(a, b, [](float x, float y) { return x * y; });
}
inline Lanes operator/(Lanes a, Lanes b) {
    return lanewise(a, b, [](float x, float y) { return x / y; });
}
inline Lanes maxKeep(Lanes c, Lanes acc) {
    return lanewise(c, acc, [](float x, float a) { return x > a ? x : a; });
}
inline Lanes minKeep(Lanes c, Lanes acc) {
    return lanewise(c, acc, [](float x, float a) { return x < a ? x : a; });
}
inline unsigned lessThan(Lanes a, Lanes b) {
    return compare(a, b, [](float x, float y) { return x < y; });
}
inline unsigned lessEqual(Lanes a, Lanes b) {
    return compare(a, b, [](float x, float y) { return x <= y; });
}
inline unsigned notEqual(Lanes a, Lanes b) {
    return compare(a, b, [](float x, float y) { return x != y; });
}
inline void store(float* p, Lanes a) { std::copy(a.v, a.v + 4, p); }
#endif
constexpr unsigned kAllLanes = 0xFu;

/// Whether new casters use the AVX2 boxes (setTriangleCasterAvx2).
std::atomic<bool> g_avx2{detail::cpuFeatures().avx2};

// A WideNode's children's boxes against one ray: enter() gives a bit per child the ray enters
// before @p best (the same slab test, lane for lane, as the one-box test) and where it enters
// (t0Out, eight floats, 32-byte aligned). nearPlane[a] / farPlane[a]: the node's lo or hi of
// axis a, whichever the ray meets first.
struct BoxesSse {
    struct Slabs {
        Lanes origin[3], inverse[3];
    };
    static void prepare(const float origin[3], const float inverse[3], Slabs& s) {
        for (int a = 0; a < 3; ++a)
            s.origin[a] = splat(origin[a]), s.inverse[a] = splat(inverse[a]);
    }
    static unsigned enter(const float* const nearPlane[3], const float* const farPlane[3],
                          const Slabs& s, float best, float* t0Out) {
        unsigned bits = 0;
        for (std::uint32_t half = 0; half < kWidth; half += 4) {
            Lanes t0 = splat(0.0f), t1 = splat(best);
            for (int a = 0; a < 3; ++a) {
                t0 = maxKeep((load(nearPlane[a] + half) - s.origin[a]) * s.inverse[a], t0);
                t1 = minKeep((load(farPlane[a] + half) - s.origin[a]) * s.inverse[a], t1);
            }
            bits |= lessEqual(t0, t1) << half;
            store(t0Out + half, t0);
        }
        return bits;
    }
};

#if VOX_TRIANGLE_AVX2
#define VOX_AVX2 [[gnu::target("avx2")]]
struct BoxesAvx2 {
    struct Slabs {
        __m256 origin[3], inverse[3];
    };
    VOX_AVX2 static void prepare(const float origin[3], const float inverse[3], Slabs& s) {
        for (int a = 0; a < 3; ++a)
            s.origin[a] = _mm256_set1_ps(origin[a]), s.inverse[a] = _mm256_set1_ps(inverse[a]);
    }
    // _mm256_max_ps / _mm256_min_ps return their second operand where either is NaN: maxKeep.
    VOX_AVX2 static unsigned enter(const float* const nearPlane[3], const float* const farPlane[3],
                                   const Slabs& s, float best, float* t0Out) {
        __m256 t0 = _mm256_setzero_ps(), t1 = _mm256_set1_ps(best);
        for (int a = 0; a < 3; ++a) {
            t0 = _mm256_max_ps(
                _mm256_mul_ps(_mm256_sub_ps(_mm256_load_ps(nearPlane[a]), s.origin[a]),
                              s.inverse[a]),
                t0);
            t1 =
                _mm256_min_ps(_mm256_mul_ps(_mm256_sub_ps(_mm256_load_ps(farPlane[a]), s.origin[a]),
                                            s.inverse[a]),
                              t1);
        }
        _mm256_store_ps(t0Out, t0);
        return unsigned(_mm256_movemask_ps(_mm256_cmp_ps(t0, t1, _CMP_LE_OQ)));
    }
};
#endif

/// The cost of intersecting @p n triangles, four at a time.
float packets(std::uint32_t n) { return kPacketCost * float((n + 3) / 4); }

/// Half the surface area of @p b (0 when empty): the SAH's measure of a node.
float halfArea(const Bounds3f& b) {
    const Vec3f e = b.extent();
    return e.x * e.y + e.y * e.z + e.z * e.x;
}

}  // namespace

TriangleRayCaster::TriangleRayCaster(const Scene& scene, bool includeDynamic) : scene_(scene) {
    std::vector<Bounds3f> bounds;  // per triangle
    for (std::uint32_t m = 0; m < scene.meshes.size(); ++m) {
        const Mesh& mesh = scene.meshes[m];
        if (mesh.dynamic && !includeDynamic) continue;
        for (std::size_t t = 0; t < mesh.triangleCount(); ++t) {
            sources_.push_back((std::uint64_t{m} << 32) | t);
            const Vec3f a = mesh.positions[mesh.indices[3 * t]],
                        b = mesh.positions[mesh.indices[3 * t + 1]],
                        c = mesh.positions[mesh.indices[3 * t + 2]];
            triangles_.push_back({a, b - a, c - a});
            // The box holds the corners as given and as the test sees them (v0 + e1 may round
            // off b): a ray through a corner hits the triangle, so it must enter the box.
            Bounds3f box;
            for (const Vec3f& p : {a, b, c, a + (b - a), a + (c - a)}) box.add(p);
            bounds.push_back(box);
        }
    }
    if (triangles_.empty()) return;
    BuildInput input;
    input.order.resize(triangles_.size());
    std::iota(input.order.begin(), input.order.end(), 0u);
    input.centroids.resize(triangles_.size());
    for (std::size_t i = 0; i < triangles_.size(); ++i) {
        const Triangle& t = triangles_[i];
        input.centroids[i] = (t.v0 + (t.v0 + t.e1) + (t.v0 + t.e2)) * (1.0f / 3.0f);
    }
    input.bounds = std::move(bounds);
    input.nodes.reserve(2 * triangles_.size());  // at most 2n − 1: every leaf holds a triangle
    build(0, static_cast<std::uint32_t>(triangles_.size()), 0, input);
    // The leaves index the build's order: store the triangles in it.
    std::vector<Triangle> triangles(triangles_.size());
    std::vector<std::uint64_t> sources(triangles_.size());
    for (std::size_t i = 0; i < triangles_.size(); ++i) {
        triangles[i] = triangles_[input.order[i]];
        sources[i] = sources_[input.order[i]];
    }
    triangles_ = std::move(triangles);
    sources_ = std::move(sources);
    collapse(input.nodes, 0);
    avx2_ = g_avx2.load();
}

std::uint32_t TriangleRayCaster::collapse(const std::vector<Node>& nodes, std::uint32_t node) {
    const auto index = static_cast<std::uint32_t>(wide_.size());
    wide_.emplace_back();
    // Opens the inner node of largest surface area among the children until there are kWidth
    // (the SAH's own measure of how often a ray enters a box) or only leaves.
    std::uint32_t children[kWidth] = {node};
    std::uint32_t count = 1;
    while (count < kWidth) {
        int open = -1;
        float openArea = -1;
        for (std::uint32_t i = 0; i < count; ++i) {
            const Node& n = nodes[children[i]];
            if (n.count != 0) continue;
            Bounds3f box;
            box.add(Vec3f{n.lo[0], n.lo[1], n.lo[2]});
            box.add(Vec3f{n.hi[0], n.hi[1], n.hi[2]});
            if (const float area = halfArea(box); area > openArea)
                openArea = area, open = static_cast<int>(i);
        }
        if (open < 0) break;
        const std::uint32_t inner = children[open];
        children[open] = inner + 1;
        children[count++] = nodes[inner].first;
    }
    WideNode wide{};
    for (int a = 0; a < 3; ++a)
        for (std::uint32_t i = 0; i < kWidth; ++i)
            wide.lo[a][i] = i < count ? nodes[children[i]].lo[a] : 0.0f,
            wide.hi[a][i] = i < count ? nodes[children[i]].hi[a] : 0.0f;
    wide.count = count;
    for (std::uint32_t i = 0; i < count; ++i) wide.child[i] = childCode(nodes, children[i]);
    wide_[index] = wide;  // after the children: collapsing them may move wide_
    return index;
}

std::uint32_t TriangleRayCaster::childCode(const std::vector<Node>& nodes, std::uint32_t node) {
    const Node& n = nodes[node];
    if (n.count == 0) return collapse(nodes, node);
    if (n.count > kMaxLeafTriangles) throw std::logic_error("TriangleRayCaster: leaf too large");
    TrianglePacket packet{};  // unused lanes: no area, so their determinant is 0 and they miss
    for (std::uint32_t lane = 0; lane < 4; ++lane) {
        packet.triangle[lane] = Nearest::kNone;
        if (lane >= n.count) continue;
        const Triangle& t = triangles_[n.first + lane];
        for (int a = 0; a < 3; ++a)
            packet.v0[a][lane] = t.v0[a], packet.e1[a][lane] = t.e1[a],
            packet.e2[a][lane] = t.e2[a];
        packet.triangle[lane] = n.first + lane;
    }
    packets_.push_back(packet);
    return kLeafChild | static_cast<std::uint32_t>(packets_.size() - 1);
}

std::uint32_t TriangleRayCaster::build(std::uint32_t first, std::uint32_t count,
                                       std::uint32_t depth, BuildInput& input) {
    const auto index = static_cast<std::uint32_t>(input.nodes.size());
    input.nodes.push_back({});
    Bounds3f box, centroidBox;
    for (std::uint32_t i = first; i < first + count; ++i) {
        const std::uint32_t t = input.order[i];
        box.add(input.bounds[t]);
        centroidBox.add(input.centroids[t]);
    }
    Node node{};
    for (int a = 0; a < 3; ++a) node.lo[a] = box.min[a], node.hi[a] = box.max[a];
    const auto leaf = [&] {
        node.first = first;
        node.count = count;
        input.nodes[index] = node;
        return index;
    };
    if (count <= 1) return leaf();

    // The cheapest plane between bins of the centroids, on any axis, by the surface area
    // heuristic.
    int bestAxis = -1;
    int bestBin = 0;
    float bestCost = std::numeric_limits<float>::infinity();
    // The bin of triangle t's centroid along axis a: the binning and the partition must agree.
    const auto binOf = [&](std::uint32_t t, int a) {
        const float scale = kSahBins / (centroidBox.max[a] - centroidBox.min[a]);
        return std::min(kSahBins - 1,
                        static_cast<int>((input.centroids[t][a] - centroidBox.min[a]) * scale));
    };
    for (int a = 0; a < 3 && depth < kMaxSahDepth; ++a) {
        if (!(centroidBox.max[a] - centroidBox.min[a] > 0)) continue;
        Bounds3f bins[kSahBins];
        std::uint32_t counts[kSahBins] = {};
        for (std::uint32_t i = first; i < first + count; ++i) {
            const std::uint32_t t = input.order[i];
            const int b = binOf(t, a);
            ++counts[b];
            bins[b].add(input.bounds[t]);
        }
        float rightArea[kSahBins];
        std::uint32_t rightCount[kSahBins];
        Bounds3f right;
        std::uint32_t n = 0;
        for (int b = kSahBins - 1; b > 0; --b) {
            right.add(bins[b]);
            n += counts[b];
            rightArea[b] = halfArea(right);
            rightCount[b] = n;
        }
        Bounds3f left;
        n = 0;
        for (int b = 0; b < kSahBins - 1; ++b) {
            left.add(bins[b]);
            n += counts[b];
            if (n == 0 || rightCount[b + 1] == 0) continue;
            const float cost =
                halfArea(left) * packets(n) + rightArea[b + 1] * packets(rightCount[b + 1]);
            if (cost < bestCost) bestCost = cost, bestAxis = a, bestBin = b;
        }
    }
    const float leafCost = packets(count);
    const float splitCost = kTraversalCost + bestCost / std::max(halfArea(box), 1e-30f);
    if (count <= kMaxLeafTriangles && leafCost <= splitCost) return leaf();
    std::uint32_t half = 0;
    if (bestAxis >= 0) {
        const auto middle =
            std::partition(input.order.begin() + first, input.order.begin() + first + count,
                           [&](std::uint32_t t) { return binOf(t, bestAxis) <= bestBin; });
        half = static_cast<std::uint32_t>(middle - (input.order.begin() + first));
    }
    if (bestAxis < 0 || half == 0 || half == count) {
        // Too deep, or every centroid the same: halves at the median of the longest axis.
        if (count <= kMaxLeafTriangles) return leaf();
        int axis = 0;
        for (int a = 1; a < 3; ++a)
            if (centroidBox.extent()[a] > centroidBox.extent()[axis]) axis = a;
        half = count / 2;
        std::nth_element(input.order.begin() + first, input.order.begin() + first + half,
                         input.order.begin() + first + count,
                         [&](std::uint32_t x, std::uint32_t y) {
                             return input.centroids[x][axis] < input.centroids[y][axis];
                         });
    }
    build(first, half, depth + 1, input);
    node.first = build(first + half, count - half, depth + 1, input);
    node.count = 0;
    input.nodes[index] = node;
    return index;
}

TriangleRayCaster::Nearest TriangleRayCaster::nearest(const Ray& ray, double tMax) const {
    if (wide_.empty()) return {};
    return avx2_ ? traverseAvx2(ray, tMax) : traverse<BoxesSse>(ray, tMax);
}

#if VOX_TRIANGLE_AVX2
// Flattened: traverse's body, and the AVX2 boxes' tests in it, compiled for AVX2 here alone.
[[gnu::target("avx2"), gnu::flatten]] TriangleRayCaster::Nearest TriangleRayCaster::traverseAvx2(
    const Ray& ray, double tMax) const {
    return traverse<BoxesAvx2>(ray, tMax);
}
#else
TriangleRayCaster::Nearest TriangleRayCaster::traverseAvx2(const Ray& ray, double tMax) const {
    return traverse<BoxesSse>(ray, tMax);
}
#endif

template <class Boxes>
inline TriangleRayCaster::Nearest TriangleRayCaster::traverse(const Ray& ray, double tMax) const {
    Nearest result;
    const float o[3] = {static_cast<float>(ray.origin.x), static_cast<float>(ray.origin.y),
                        static_cast<float>(ray.origin.z)};
    const float d[3] = {static_cast<float>(ray.direction.x), static_cast<float>(ray.direction.y),
                        static_cast<float>(ray.direction.z)};
    Lanes origin[3], direction[3];
    float inverse[3];
    bool nearIsLo[3];  // the slab's near plane: lo where the ray runs up the axis
    for (int a = 0; a < 3; ++a) {
        inverse[a] = 1.0f / d[a];
        nearIsLo[a] = !(inverse[a] < 0);
        origin[a] = splat(o[a]), direction[a] = splat(d[a]);
    }
    typename Boxes::Slabs slabs;
    Boxes::prepare(o, inverse, slabs);
    float best = static_cast<float>(std::min(tMax, 3.0e38));
    // Nodes (child codes) to visit with the distance where the ray enters them: the nearest
    // child is taken first, and an entry beyond a hit found since it was pushed is dropped.
    struct Entry {
        std::uint32_t code;
        float t;
    };
    Entry stack[kStackEntries];
    int top = 0;
    stack[top++] = {0, 0.0f};
    alignas(32) float lanes[kWidth];
    while (top > 0) {
        const Entry e = stack[--top];
        if (e.t > best) continue;
        if (e.code & kLeafChild) {
            const TrianglePacket& p = packets_[e.code & ~kLeafChild];
            const Lanes e1[3] = {load(p.e1[0]), load(p.e1[1]), load(p.e1[2])};
            const Lanes e2[3] = {load(p.e2[0]), load(p.e2[1]), load(p.e2[2])};
            // p = d × e2, s = o − v0, q = s × e1, as cross() and dot() evaluate them.
            const Lanes px = direction[1] * e2[2] - direction[2] * e2[1];
            const Lanes py = direction[2] * e2[0] - direction[0] * e2[2];
            const Lanes pz = direction[0] * e2[1] - direction[1] * e2[0];
            const Lanes det = e1[0] * px + e1[1] * py + e1[2] * pz;
            const Lanes invDet = splat(1.0f) / det;
            const Lanes sx = origin[0] - load(p.v0[0]), sy = origin[1] - load(p.v0[1]),
                        sz = origin[2] - load(p.v0[2]);
            const Lanes u = (sx * px + sy * py + sz * pz) * invDet;
            const Lanes qx = sy * e1[2] - sz * e1[1];
            const Lanes qy = sz * e1[0] - sx * e1[2];
            const Lanes qz = sx * e1[1] - sy * e1[0];
            const Lanes v = (direction[0] * qx + direction[1] * qy + direction[2] * qz) * invDet;
            const Lanes t = (e2[0] * qx + e2[1] * qy + e2[2] * qz) * invDet;
            const Lanes zero = splat(0.0f), one = splat(1.0f);
            unsigned hits = notEqual(det, zero) & ~lessThan(u, zero) & ~lessThan(one, u) &
                            ~lessThan(v, zero) & ~lessThan(one, u + v) & lessEqual(zero, t) &
                            lessThan(t, splat(best)) & kAllLanes;
            if (hits == 0) continue;
            alignas(16) float us[4], vs[4];
            store(lanes, t), store(us, u), store(vs, v);
            for (; hits != 0; hits &= hits - 1) {  // lanes in triangle order: the first of equals
                const int lane = std::countr_zero(hits);
                if (lanes[lane] < best)
                    best = lanes[lane], result.triangle = p.triangle[lane], result.u = us[lane],
                    result.v = vs[lane];
            }
            continue;
        }
        const WideNode& n = wide_[e.code];
        result.iterations += n.count;
        const float* const nearPlane[3] = {nearIsLo[0] ? n.lo[0] : n.hi[0],
                                           nearIsLo[1] ? n.lo[1] : n.hi[1],
                                           nearIsLo[2] ? n.lo[2] : n.hi[2]};
        const float* const farPlane[3] = {nearIsLo[0] ? n.hi[0] : n.lo[0],
                                          nearIsLo[1] ? n.hi[1] : n.lo[1],
                                          nearIsLo[2] ? n.hi[2] : n.lo[2]};
        unsigned entered =
            Boxes::enter(nearPlane, farPlane, slabs, best, lanes) & ((1u << n.count) - 1);
        if (entered == 0) continue;
        // The entered children onto the stack, sorted in place so that the nearest is on top.
        const int base = top;
        for (; entered != 0; entered &= entered - 1) {
            const int lane = std::countr_zero(entered);
            const Entry c{n.child[lane], lanes[lane]};
            int i = top++;
            for (; i > base && stack[i - 1].t < c.t; --i) stack[i] = stack[i - 1];
            stack[i] = c;
        }
    }
    result.t = best;
    return result;
}

CastHit TriangleRayCaster::cast(const Ray& ray, double tMax, double footprintAngle) const {
    CastHit result;
    const Nearest near = nearest(ray, tMax);
    result.iterations = near.iterations;
    if (near.triangle == Nearest::kNone) return result;
    const float best = near.t;
    const Vec3f d{static_cast<float>(ray.direction.x), static_cast<float>(ray.direction.y),
                  static_cast<float>(ray.direction.z)};
    result.hit = true;
    result.t = best;
    Vec3f n = normalize(cross(triangles_[near.triangle].e1, triangles_[near.triangle].e2));
    if (dot(n, d) > 0) n = -n;
    result.normal = n;

    const std::uint64_t source = sources_[near.triangle];
    const detail::TriangleSource where{static_cast<std::uint32_t>(source >> 32),
                                       static_cast<std::uint32_t>(source)};
    const Mesh& mesh = scene_.meshes[where.mesh];
    std::array<Vec3d, 3> corners;
    for (int k = 0; k < 3; ++k) {
        const Vec3f p = mesh.positions[mesh.indices[3 * std::size_t{where.triangle} + k]];
        corners[k] = {p.x, p.y, p.z};
    }
    const Vec3d at = ray.origin + ray.direction * double(best);
    const detail::SurfaceSample sample = detail::shadeTriangle(
        scene_, where, corners, detail::barycentric(corners, at), footprintAngle * best);
    result.hasAttributes = true;
    result.color = detail::packLinearColor(sample.color);
    result.shadingNormal = {static_cast<float>(sample.normal.x),
                            static_cast<float>(sample.normal.y),
                            static_cast<float>(sample.normal.z)};
    return result;
}

SurfaceHit TriangleRayCaster::castSurface(const Ray& ray, double tMax) const {
    SurfaceHit result;
    const Nearest near = nearest(ray, tMax);
    result.iterations = near.iterations;
    if (near.triangle == Nearest::kNone) return result;
    result.hit = true;
    result.t = near.t;
    const std::uint64_t source = sources_[near.triangle];
    result.mesh = static_cast<std::uint32_t>(source >> 32);
    result.triangle = static_cast<std::uint32_t>(source);
    // Möller–Trumbore's u and v weigh corners 1 and 2 (the stored edges keep the mesh's corner
    // order), so the weights need no re-projection of the rounded hit point.
    result.barycentric = {1.0 - double(near.u) - double(near.v), double(near.u), double(near.v)};
    const Triangle& tri = triangles_[near.triangle];
    result.geometricNormal =
        normalize(cross(Vec3d{tri.e1.x, tri.e1.y, tri.e1.z}, Vec3d{tri.e2.x, tri.e2.y, tri.e2.z}));
    return result;
}

RenderBuffers renderTriangles(const TriangleRayCaster& caster, const PinholeCamera& camera) {
    const double footprint = camera.pixelAngle();
    return renderPixels(camera, [&](const Ray& ray) {
        return caster.cast(ray, std::numeric_limits<double>::infinity(), footprint);
    });
}

namespace detail {

bool setTriangleCasterAvx2(bool enabled) noexcept {
    const bool on = enabled && VOX_TRIANGLE_AVX2 && cpuFeatures().avx2;
    g_avx2.store(on);
    return on;
}

}  // namespace detail

}  // namespace vox
