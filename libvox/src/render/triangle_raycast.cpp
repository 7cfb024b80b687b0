// BVH over triangles: binned surface-area-heuristic splits, up to four triangles per leaf,
// children visited nearer first, slab tests and Möller–Trumbore intersection.
#include "../scene/surface_shading.h"

#include <vox/formats/esvo_attributes.h>
#include <vox/texture.h>
#include <vox/triangle_raycast.h>

#include <algorithm>
#include <cmath>
#include <numeric>

namespace vox {

namespace {

/// Binned SAH build (Wald 2007): bins per axis, and the relative cost of a node visit against a
/// triangle test.
constexpr int kSahBins = 16;
constexpr float kTraversalCost = 1.0f;
/// A leaf holds at most this many triangles unless they cannot be split (equal centroids).
constexpr std::uint32_t kMaxLeafTriangles = 4;
/// Below this depth nodes split at the median (log2 of the triangles more levels at most), so
/// that no path exceeds the traversal's stack.
constexpr std::uint32_t kMaxSahDepth = 64;
constexpr int kStackEntries = 128;

/// Half the surface area of @p b (0 when empty): the SAH's measure of a node.
float halfArea(const Bounds3f& b) {
    const Vec3f e = b.extent();
    return e.x * e.y + e.y * e.z + e.z * e.x;
}

}  // namespace

TriangleRayCaster::TriangleRayCaster(const Scene& scene, bool includeDynamic) : scene_(scene) {
    for (std::uint32_t m = 0; m < scene.meshes.size(); ++m) {
        const Mesh& mesh = scene.meshes[m];
        if (mesh.dynamic && !includeDynamic) continue;
        for (std::size_t t = 0; t < mesh.triangleCount(); ++t) {
            sources_.push_back((std::uint64_t{m} << 32) | t);
            const Vec3f a = mesh.positions[mesh.indices[3 * t]],
                        b = mesh.positions[mesh.indices[3 * t + 1]],
                        c = mesh.positions[mesh.indices[3 * t + 2]];
            triangles_.push_back({a, b - a, c - a});
        }
    }
    if (triangles_.empty()) return;
    BuildInput input;
    input.order.resize(triangles_.size());
    std::iota(input.order.begin(), input.order.end(), 0u);
    input.centroids.resize(triangles_.size());
    input.bounds.resize(triangles_.size());
    for (std::size_t i = 0; i < triangles_.size(); ++i) {
        const Triangle& t = triangles_[i];
        const Vec3f v[3] = {t.v0, t.v0 + t.e1, t.v0 + t.e2};
        input.centroids[i] = (v[0] + v[1] + v[2]) * (1.0f / 3.0f);
        for (const Vec3f& p : v) input.bounds[i].add(p);
    }
    nodes_.reserve(2 * triangles_.size());  // at most 2n − 1 nodes: every leaf holds a triangle
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
}

std::uint32_t TriangleRayCaster::build(std::uint32_t first, std::uint32_t count,
                                       std::uint32_t depth, BuildInput& input) {
    const auto index = static_cast<std::uint32_t>(nodes_.size());
    nodes_.push_back({});
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
        nodes_[index] = node;
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
                halfArea(left) * float(n) + rightArea[b + 1] * float(rightCount[b + 1]);
            if (cost < bestCost) bestCost = cost, bestAxis = a, bestBin = b;
        }
    }
    const float leafCost = float(count);
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
    nodes_[index] = node;
    return index;
}

TriangleRayCaster::Nearest TriangleRayCaster::nearest(const Ray& ray, double tMax) const {
    Nearest result;
    if (nodes_.empty()) return result;
    const Vec3f o{static_cast<float>(ray.origin.x), static_cast<float>(ray.origin.y),
                  static_cast<float>(ray.origin.z)};
    const Vec3f d{static_cast<float>(ray.direction.x), static_cast<float>(ray.direction.y),
                  static_cast<float>(ray.direction.z)};
    const Vec3f inv{1.0f / d.x, 1.0f / d.y, 1.0f / d.z};
    float best = static_cast<float>(std::min(tMax, 3.0e38));
    // Where the ray enters a node's box (≤ best), or infinity where it misses it.
    const auto enter = [&](const Node& n) {
        float t0 = 0.0f, t1 = best;
        for (int a = 0; a < 3; ++a) {
            float ta = (n.lo[a] - o[a]) * inv[a], tb = (n.hi[a] - o[a]) * inv[a];
            if (ta > tb) std::swap(ta, tb);
            t0 = std::max(t0, ta);
            t1 = std::min(t1, tb);
        }
        return t0 <= t1 ? t0 : std::numeric_limits<float>::infinity();
    };
    // Nodes to visit with the distance where the ray enters them: the nearer child is taken
    // first, and an entry beyond a hit found since it was pushed is dropped.
    struct Entry {
        std::uint32_t node;
        float t;
    };
    Entry stack[kStackEntries];
    int top = 0;
    ++result.iterations;
    if (const float t = enter(nodes_[0]); t <= best) stack[top++] = {0, t};
    while (top > 0) {
        const Entry e = stack[--top];
        if (e.t > best) continue;
        const Node& n = nodes_[e.node];
        if (n.count == 0) {
            const std::uint32_t near = e.node + 1, far = n.first;
            const float tNear = enter(nodes_[near]), tFar = enter(nodes_[far]);
            result.iterations += 2;
            const bool hitNear = tNear <= best, hitFar = tFar <= best;
            if (hitNear && hitFar) {
                if (tNear <= tFar) {
                    stack[top++] = {far, tFar};
                    stack[top++] = {near, tNear};
                } else {
                    stack[top++] = {near, tNear};
                    stack[top++] = {far, tFar};
                }
            } else if (hitNear) {
                stack[top++] = {near, tNear};
            } else if (hitFar) {
                stack[top++] = {far, tFar};
            }
            continue;
        }
        for (std::uint32_t i = n.first; i < n.first + n.count; ++i) {
            const Triangle& tri = triangles_[i];
            const Vec3f p = cross(d, tri.e2);
            const float det = dot(tri.e1, p);
            if (det == 0.0f) continue;
            const float invDet = 1.0f / det;
            const Vec3f s = o - tri.v0;
            const float u = dot(s, p) * invDet;
            if (u < 0.0f || u > 1.0f) continue;
            const Vec3f q = cross(s, tri.e1);
            const float v = dot(d, q) * invDet;
            if (v < 0.0f || u + v > 1.0f) continue;
            const float t = dot(tri.e2, q) * invDet;
            if (t >= 0.0f && t < best) best = t, result.triangle = i, result.u = u, result.v = v;
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

}  // namespace vox
