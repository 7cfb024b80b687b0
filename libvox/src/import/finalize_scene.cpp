// Import's last step: validate what a reader produced, drop degenerate triangles, fill in
// missing normals and tangent frames, and fix the scene's bounds.
#include "import_context.h"

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
/// combine the same chunks in the same order.
constexpr std::size_t kChunk = 1 << 15;

/// The first i in [0, count) for which @p bad(i) holds, or count: the same one whatever the
/// threads.
template <typename Predicate>
std::size_t firstWhere(std::size_t count, const Predicate& bad) {
    return tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, count, kChunk), count,
        [&](const tbb::blocked_range<std::size_t>& r, std::size_t found) {
            for (std::size_t i = r.begin(); i < r.end() && i < found; ++i)
                if (bad(i)) return i;
            return found;
        },
        [](std::size_t a, std::size_t b) { return std::min(a, b); });
}

/// How many i in [0, count) @p visit(i) returns true for.
template <typename Visit>
std::size_t countWhere(std::size_t count, const Visit& visit) {
    return tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, count, kChunk), std::size_t{0},
        [&](const tbb::blocked_range<std::size_t>& r, std::size_t n) {
            for (std::size_t i = r.begin(); i < r.end(); ++i) n += visit(i) ? 1 : 0;
            return n;
        },
        std::plus<>());
}

}  // namespace

namespace detail {
namespace {

/// Largest coordinate magnitude accepted: sums, differences and the root cube's diagonal stay far
/// below float's 3.4e38 (docs/import.md, "Bad input").
constexpr float kMaxCoordinate = 1e30f;
/// Smallest longest side of a scene: its finest voxels at --depth 20 (about 1e-36) are still normal
/// floats, above 1.2e-38, with full precision.
constexpr double kMinExtent = 1e-30;

/// Triangles without area contribute no surface; the exact zero test keeps slivers.
bool isDegenerate(const Mesh& mesh, std::size_t triangle) {
    const std::uint32_t* tri = &mesh.indices[3 * triangle];
    if (tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2]) return true;
    const Vec3d n = faceNormal(mesh, triangle);
    return (n.x == 0 && n.y == 0 && n.z == 0) || !isFinite(n);
}

/// Drops the degenerate triangles of @p mesh, keeping the order of the others; returns how many.
std::size_t dropDegenerateTriangles(Mesh& mesh) {
    const std::size_t triangles = mesh.triangleCount();
    const std::size_t degenerate =
        countWhere(triangles, [&](std::size_t t) { return isDegenerate(mesh, t); });
    if (degenerate == 0) return 0;
    std::size_t kept = 0;  // in place, in order: rare enough to stay serial
    for (std::size_t t = 0; t < triangles; ++t) {
        if (isDegenerate(mesh, t)) continue;
        std::copy_n(&mesh.indices[3 * t], 3, &mesh.indices[3 * kept++]);
    }
    mesh.indices.resize(3 * kept);
    return degenerate;
}

std::string meshLabel(const Mesh& mesh, std::size_t index) {
    return mesh.name.empty() ? "mesh " + std::to_string(index) : "mesh '" + mesh.name + "'";
}

}  // namespace

void finalizeScene(ImportContext& context, MissingNormals missingNormals) {
    Scene& scene = context.scene();
    std::size_t degenerate = 0, invalidNormals = 0, invalidUvs = 0, invalidColors = 0,
                trianglesBefore = 0;
    for (std::size_t m = 0; m < scene.meshes.size(); ++m) {
        Mesh& mesh = scene.meshes[m];
        const std::size_t vertexCount = mesh.positions.size();
        // Every check in parallel, each failing on the first offender in file order.
        const std::size_t badVertex = firstWhere(vertexCount, [&](std::size_t v) {
            const Vec3f& p = mesh.positions[v];
            return !isFinite(p) ||
                   std::max({std::fabs(p.x), std::fabs(p.y), std::fabs(p.z)}) > kMaxCoordinate;
        });
        if (badVertex < vertexCount) {
            if (!isFinite(mesh.positions[badVertex]))
                context.fail(meshLabel(mesh, m) + ": vertex " + std::to_string(badVertex) +
                             " has a non-finite position");
            context.fail(meshLabel(mesh, m) + ": vertex " + std::to_string(badVertex) +
                         " has a coordinate beyond ±1e30 (absurd scale)");
        }
        if (mesh.indices.size() % 3 != 0)
            context.fail(meshLabel(mesh, m) + ": index count is not a multiple of 3");
        const std::size_t badIndex = firstWhere(
            mesh.indices.size(), [&](std::size_t i) { return mesh.indices[i] >= vertexCount; });
        if (badIndex < mesh.indices.size())
            context.fail(meshLabel(mesh, m) + ": vertex index " +
                         std::to_string(mesh.indices[badIndex]) + " out of range (" +
                         std::to_string(vertexCount) + " vertices)");
        trianglesBefore += mesh.triangleCount();
        degenerate += dropDegenerateTriangles(mesh);

        for (auto& set : mesh.uvs)
            invalidUvs += countWhere(set.size(), [&](std::size_t v) {
                Vec2f& uv = set[v];
                if (std::isfinite(uv.x) && std::isfinite(uv.y)) return false;
                uv = {0, 0};
                return true;
            });
        invalidColors += countWhere(mesh.colors.size(), [&](std::size_t v) {
            Vec4f& color = mesh.colors[v];
            if (std::isfinite(color.x) && std::isfinite(color.y) && std::isfinite(color.z) &&
                std::isfinite(color.w))
                return false;
            color = {1, 1, 1, 1};
            return true;
        });

        if (mesh.normals.empty()) {
            generateNormals(mesh, missingNormals);
        } else {
            // In double: a huge or tiny but finite normal still has a direction.
            const auto validLength = [](Vec3f n) {
                const double len = isFinite(n) ? length(vec3Cast<double>(n)) : 0.0;
                return len > 0 && std::isfinite(len) ? len : 0.0;
            };
            const std::size_t invalid = countWhere(mesh.normals.size(), [&](std::size_t v) {
                return validLength(mesh.normals[v]) == 0.0;
            });
            const std::vector<Vec3f> replacements =
                invalid ? smoothNormals(mesh) : std::vector<Vec3f>();
            tbb::parallel_for(tbb::blocked_range<std::size_t>(0, mesh.normals.size(), kChunk),
                              [&](const tbb::blocked_range<std::size_t>& r) {
                                  for (std::size_t v = r.begin(); v != r.end(); ++v) {
                                      Vec3f& n = mesh.normals[v];
                                      const double len = validLength(n);
                                      n = len > 0 ? vec3Cast<float>(vec3Cast<double>(n) / len)
                                                  : replacements[v];
                                  }
                              });
            invalidNormals += invalid;
        }
    }
    std::erase_if(scene.meshes, [](const Mesh& mesh) { return mesh.indices.empty(); });

    // Importers may have dropped degenerate triangles already: report them all.
    scene.degenerateTrianglesDropped += degenerate;
    if (scene.meshes.empty()) {
        if (trianglesBefore > 0 || scene.degenerateTrianglesDropped > 0)
            context.fail(
                "all " +
                std::to_string(trianglesBefore + scene.degenerateTrianglesDropped - degenerate) +
                " triangles are degenerate (no area)");
        // What was skipped explains why nothing is left.
        std::string skipped;
        for (const std::string& warning : scene.warnings)
            skipped += (skipped.empty() ? " (" : "; ") + warning;
        context.fail("contains no triangles" + (skipped.empty() ? std::string() : skipped + ")"));
    }
    for (const Light& light : scene.lights)
        if (std::max({std::fabs(light.position.x), std::fabs(light.position.y),
                      std::fabs(light.position.z)}) > kMaxCoordinate)
            context.fail("light '" + light.name + "' has a position beyond ±1e30 (absurd scale)");
    // The finest voxel of the deepest octree (2^-20 of the longest side) must stay a normal float.
    const Bounds3f bounds = scene.bounds();
    const double extent =
        std::max({double(bounds.max.x) - bounds.min.x, double(bounds.max.y) - bounds.min.y,
                  double(bounds.max.z) - bounds.min.z});
    if (extent < kMinExtent) {
        char text[64];
        std::snprintf(text, sizeof text, "%g", extent);
        context.fail(std::string("the scene's longest side is ") + text +
                     ", below 1e-30 (absurd scale: zero or denormal size)");
    }
    if (scene.degenerateTrianglesDropped)
        context.warn("dropped " + std::to_string(scene.degenerateTrianglesDropped) +
                     " degenerate triangle(s) with no area");
    if (invalidNormals)
        context.warn("replaced " + std::to_string(invalidNormals) +
                     " zero or non-finite normal(s)");
    if (invalidUvs)
        context.warn("replaced " + std::to_string(invalidUvs) +
                     " non-finite texture coordinate(s) by 0");
    if (invalidColors)
        context.warn("replaced " + std::to_string(invalidColors) +
                     " non-finite vertex colour(s) by white");
}

}  // namespace detail
}  // namespace vox
