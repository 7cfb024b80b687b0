// BVH over triangles: median splits on the longest centroid axis, four triangles per leaf,
// slab tests and Möller–Trumbore intersection.
#include "../scene/surface_shading.h"

#include <vox/formats/esvo_attributes.h>
#include <vox/texture.h>
#include <vox/triangle_raycast.h>

#include <algorithm>
#include <cmath>
#include <numeric>

namespace vox {

TriangleRayCaster::TriangleRayCaster(const Scene& scene, bool includeDynamic) : scene_(scene) {
    std::vector<Vec3f> centroids;
    for (std::uint32_t m = 0; m < scene.meshes.size(); ++m) {
        const Mesh& mesh = scene.meshes[m];
        if (mesh.dynamic && !includeDynamic) continue;
        for (std::size_t t = 0; t < mesh.triangleCount(); ++t) {
            sources_.push_back((std::uint64_t{m} << 32) | t);
            const Vec3f a = mesh.positions[mesh.indices[3 * t]],
                        b = mesh.positions[mesh.indices[3 * t + 1]],
                        c = mesh.positions[mesh.indices[3 * t + 2]];
            triangles_.push_back({a, b - a, c - a});
            centroids.push_back((a + b + c) * (1.0f / 3.0f));
        }
    }
    if (!triangles_.empty()) {
        nodes_.reserve(2 * triangles_.size() / 4 + 1);
        build(0, static_cast<std::uint32_t>(triangles_.size()), centroids);
    }
}

std::uint32_t TriangleRayCaster::build(std::uint32_t first, std::uint32_t count,
                                       std::vector<Vec3f>& centroids) {
    const auto index = static_cast<std::uint32_t>(nodes_.size());
    nodes_.push_back({});
    Node node{};
    for (int a = 0; a < 3; ++a)
        node.lo[a] = std::numeric_limits<float>::infinity(),
        node.hi[a] = -std::numeric_limits<float>::infinity();
    float clo[3] = {node.lo[0], node.lo[1], node.lo[2]},
          chi[3] = {node.hi[0], node.hi[1], node.hi[2]};
    for (std::uint32_t i = first; i < first + count; ++i) {
        const Triangle& t = triangles_[i];
        const Vec3f v[3] = {t.v0, t.v0 + t.e1, t.v0 + t.e2};
        for (int a = 0; a < 3; ++a) {
            for (const Vec3f& p : v)
                node.lo[a] = std::min(node.lo[a], p[a]), node.hi[a] = std::max(node.hi[a], p[a]);
            clo[a] = std::min(clo[a], centroids[i][a]);
            chi[a] = std::max(chi[a], centroids[i][a]);
        }
    }
    if (count <= 4) {
        node.first = first;
        node.count = count;
        nodes_[index] = node;
        return index;
    }
    int axis = 0;
    for (int a = 1; a < 3; ++a)
        if (chi[a] - clo[a] > chi[axis] - clo[axis]) axis = a;
    // Sort triangles and centroids together by the split axis around the median.
    std::vector<std::uint32_t> order(count);
    std::iota(order.begin(), order.end(), first);
    const std::uint32_t half = count / 2;
    std::nth_element(
        order.begin(), order.begin() + half, order.end(),
        [&](std::uint32_t x, std::uint32_t y) { return centroids[x][axis] < centroids[y][axis]; });
    std::vector<Triangle> tris(count);
    std::vector<Vec3f> cents(count);
    std::vector<std::uint64_t> sources(count);
    for (std::uint32_t i = 0; i < count; ++i)
        tris[i] = triangles_[order[i]], cents[i] = centroids[order[i]],
        sources[i] = sources_[order[i]];
    std::copy(tris.begin(), tris.end(), triangles_.begin() + first);
    std::copy(cents.begin(), cents.end(), centroids.begin() + first);
    std::copy(sources.begin(), sources.end(), sources_.begin() + first);
    build(first, half, centroids);
    node.first = build(first + half, count - half, centroids);
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
    std::uint32_t stack[64];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
        const Node& n = nodes_[stack[--top]];
        ++result.iterations;
        float t0 = 0.0f, t1 = best;
        for (int a = 0; a < 3; ++a) {
            float ta = (n.lo[a] - o[a]) * inv[a], tb = (n.hi[a] - o[a]) * inv[a];
            if (ta > tb) std::swap(ta, tb);
            t0 = std::max(t0, ta);
            t1 = std::min(t1, tb);
        }
        if (!(t0 <= t1)) continue;
        if (n.count == 0) {
            const auto self = static_cast<std::uint32_t>(&n - nodes_.data());
            stack[top++] = n.first;
            stack[top++] = self + 1;
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
