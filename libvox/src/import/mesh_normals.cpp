// Normals for meshes that have none: angle-weighted smooth normals welded by position, or flat
// normals on unwelded vertices. Both run in parallel and in linear time, and give the same bits
// whatever the thread count: every sum is taken in the order of the corners it sums.
#include <vox/scene.h>

#include "import_context.h"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <span>

namespace vox::detail {

Vec3d faceNormal(const Mesh& mesh, std::size_t triangle) {
    const Vec3d a = vec3Cast<double>(mesh.positions[mesh.indices[3 * triangle]]);
    const Vec3d b = vec3Cast<double>(mesh.positions[mesh.indices[3 * triangle + 1]]);
    const Vec3d c = vec3Cast<double>(mesh.positions[mesh.indices[3 * triangle + 2]]);
    return cross(b - a, c - a);
}

namespace {

constexpr std::uint32_t kEmpty = 0xFFFFFFFFu;
constexpr std::size_t kGrain = 1 << 14;

/// The bits of a coordinate, -0 as +0: equal positions (by ==) have equal keys.
std::uint32_t coordinateBits(float v) { return std::bit_cast<std::uint32_t>(v == 0.0f ? 0.0f : v); }

std::uint64_t positionHash(Vec3f p) {
    std::uint64_t h = coordinateBits(p.x);
    h = h * 0x9E3779B97F4A7C15ull ^ coordinateBits(p.y);
    h = h * 0x9E3779B97F4A7C15ull ^ coordinateBits(p.z);
    return (h ^ (h >> 29)) * 0xBF58476D1CE4E5B9ull;
}

template <typename Body>
void parallelFor(std::size_t count, const Body& body) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, kGrain),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                          for (std::size_t i = r.begin(); i != r.end(); ++i) body(i);
                      });
}

/// For every vertex, the smallest index of a vertex at the same position (positions equal by
/// ==, so +0 and -0 weld; finite positions assumed). An open-addressing table of vertex indices
/// filled in parallel: a slot, once taken, only ever holds vertices of one position, and keeps the
/// smallest of them, so the result does not depend on the order of insertion.
std::vector<std::uint32_t> weldByPosition(const std::vector<Vec3f>& positions) {
    const std::size_t n = positions.size();
    const std::size_t capacity = std::bit_ceil(std::max<std::size_t>(2 * n, 16));
    const std::size_t mask = capacity - 1;
    std::vector<std::uint32_t> table(capacity, kEmpty);
    parallelFor(n, [&](std::size_t v) {
        const Vec3f p = positions[v];
        for (std::size_t slot = positionHash(p) & mask;; slot = (slot + 1) & mask) {
            std::atomic_ref<std::uint32_t> entry(table[slot]);
            std::uint32_t held = entry.load(std::memory_order_relaxed);
            if (held == kEmpty) {
                if (entry.compare_exchange_strong(held, static_cast<std::uint32_t>(v),
                                                  std::memory_order_relaxed))
                    return;
                // Taken meanwhile: held is now the taker, looked at below.
            }
            if (!(positions[held] == p)) continue;
            while (v < held && !entry.compare_exchange_weak(held, static_cast<std::uint32_t>(v),
                                                            std::memory_order_relaxed)) {}
            return;
        }
    });
    std::vector<std::uint32_t> canonical(n);
    parallelFor(n, [&](std::size_t v) {
        const Vec3f p = positions[v];
        std::size_t slot = positionHash(p) & mask;
        while (!(positions[table[slot]] == p)) slot = (slot + 1) & mask;
        canonical[v] = table[slot];
    });
    return canonical;
}

template <typename T>
void unweld(std::vector<T>& values, const std::vector<std::uint32_t>& indices) {
    if (values.empty()) return;
    std::vector<T> out(indices.size());
    parallelFor(indices.size(), [&](std::size_t i) { out[i] = values[indices[i]]; });
    values = std::move(out);
}

void flatNormals(Mesh& mesh) {
    unweld(mesh.positions, mesh.indices);
    for (auto& set : mesh.uvs) unweld(set, mesh.indices);
    unweld(mesh.colors, mesh.indices);
    mesh.normals.resize(mesh.indices.size());
    parallelFor(mesh.indices.size() / 3, [&](std::size_t t) {
        std::iota(mesh.indices.begin() + 3 * t, mesh.indices.begin() + 3 * t + 3,
                  static_cast<std::uint32_t>(3 * t));
        const Vec3f n = vec3Cast<float>(normalize(faceNormal(mesh, t)));
        for (int k = 0; k < 3; ++k) mesh.normals[3 * t + k] = n;
    });
}

}  // namespace

std::vector<Vec3f> smoothNormals(const Mesh& mesh) {
    const std::size_t vertexCount = mesh.positions.size(), cornerCount = mesh.indices.size();
    const std::vector<std::uint32_t> canonical = weldByPosition(mesh.positions);

    // The corners of each vertex in corner order: counted, then placed from each vertex's end
    // backwards, which leaves `start` at each vertex's first. Serial: plain increments over
    // mostly local indices beat atomic ones. Vertices welded to one position are chained
    // (canonical first), and their lists merged where the sum is taken.
    std::vector<std::uint32_t> start(vertexCount + 1, 0);
    for (std::size_t c = 0; c < cornerCount; ++c) ++start[mesh.indices[c]];
    std::inclusive_scan(start.begin(), start.end(), start.begin());
    std::vector<std::uint32_t> corners(cornerCount);
    for (std::size_t c = cornerCount; c-- > 0;)
        corners[--start[mesh.indices[c]]] = static_cast<std::uint32_t>(c);
    std::vector<std::uint32_t> nextWelded(vertexCount, kEmpty);
    for (std::size_t v = 0; v < vertexCount; ++v) {
        const std::uint32_t c = canonical[v];
        if (c == v) continue;
        nextWelded[v] = nextWelded[c];
        nextWelded[c] = static_cast<std::uint32_t>(v);
    }
    tbb::enumerable_thread_specific<std::vector<std::uint32_t>> mergedLists;

    std::vector<Vec3f> normals(vertexCount);
    parallelFor(vertexCount, [&](std::size_t v) {
        if (canonical[v] != v) return;
        std::span<const std::uint32_t> list(corners.data() + start[v], start[v + 1] - start[v]);
        if (nextWelded[v] != kEmpty) {
            std::vector<std::uint32_t>& merged = mergedLists.local();
            merged.assign(list.begin(), list.end());
            for (std::uint32_t u = nextWelded[v]; u != kEmpty; u = nextWelded[u])
                merged.insert(merged.end(), corners.data() + start[u],
                              corners.data() + start[u + 1]);
            std::sort(merged.begin(), merged.end());
            list = merged;
        }
        if (list.empty()) return;  // no triangle touches this position: zero, as before
        Vec3d sum{};
        for (const std::uint32_t corner : list) {
            const std::size_t t = corner / 3, k = corner % 3;
            const Vec3d n = normalize(faceNormal(mesh, t));
            const Vec3d p = vec3Cast<double>(mesh.positions[mesh.indices[3 * t + k]]);
            const Vec3d e1 =
                normalize(vec3Cast<double>(mesh.positions[mesh.indices[3 * t + (k + 1) % 3]]) - p);
            const Vec3d e2 =
                normalize(vec3Cast<double>(mesh.positions[mesh.indices[3 * t + (k + 2) % 3]]) - p);
            const double angle = std::acos(std::clamp(dot(e1, e2), -1.0, 1.0));
            sum += n * angle;
        }
        normals[v] = vec3Cast<float>(normalize(sum));
    });
    parallelFor(vertexCount, [&](std::size_t v) {
        if (canonical[v] != v) normals[v] = normals[canonical[v]];
    });
    return normals;
}

void generateNormals(Mesh& mesh, MissingNormals mode) {
    if (mode == MissingNormals::Flat)
        flatNormals(mesh);
    else
        mesh.normals = smoothNormals(mesh);
}

}  // namespace vox::detail
