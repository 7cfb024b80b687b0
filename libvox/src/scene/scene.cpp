#include <vox/scene.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cstdio>
#include <cmath>
#include <functional>
#include <limits>

namespace vox {
namespace {

/// Chunks of a fixed size (whatever the thread count), so that reductions that depend on order
/// (signed zeros in min/max) combine the same chunks in the same order.
constexpr std::size_t kChunk = 1 << 15;

/// The bounds of the vertices @p indices refer to, as adding them one by one would give.
Bounds3f indexedBounds(const std::vector<Vec3f>& positions,
                       const std::vector<std::uint32_t>& indices) {
    const std::size_t chunks = (indices.size() + kChunk - 1) / kChunk;
    std::vector<Bounds3f> partial(chunks);
    tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
        const std::size_t end = std::min(indices.size(), (c + 1) * kChunk);
        for (std::size_t i = c * kChunk; i < end; ++i) partial[c].add(positions[indices[i]]);
    });
    Bounds3f bounds;
    for (const Bounds3f& b : partial) {
        // Min with min, max with max: the earlier of equal values (+0, -0) stays, as one by one.
        bounds.min = {std::min(bounds.min.x, b.min.x), std::min(bounds.min.y, b.min.y),
                      std::min(bounds.min.z, b.min.z)};
        bounds.max = {std::max(bounds.max.x, b.max.x), std::max(bounds.max.y, b.max.y),
                      std::max(bounds.max.z, b.max.z)};
    }
    return bounds;
}

}  // namespace

std::size_t Scene::triangleCount() const noexcept {
    std::size_t n = 0;
    for (const Mesh& mesh : meshes) n += mesh.triangleCount();
    return n;
}

std::size_t Scene::dynamicTriangleCount() const noexcept {
    std::size_t n = 0;
    for (const Mesh& mesh : meshes)
        if (mesh.dynamic) n += mesh.triangleCount();
    return n;
}

Bounds3f Scene::bounds() const {
    Bounds3f bounds;
    for (const Mesh& mesh : meshes) {
        const Bounds3f b = indexedBounds(mesh.positions, mesh.indices);
        bounds.min = {std::min(bounds.min.x, b.min.x), std::min(bounds.min.y, b.min.y),
                      std::min(bounds.min.z, b.min.z)};
        bounds.max = {std::max(bounds.max.x, b.max.x), std::max(bounds.max.y, b.max.y),
                      std::max(bounds.max.z, b.max.z)};
    }
    return bounds;
}

}  // namespace vox
