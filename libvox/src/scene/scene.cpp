#include <vox/scene.h>

#include "../import/import_context.h"

#include <algorithm>
#include <bit>
#include <cstdio>
#include <cmath>
#include <numeric>
#include <unordered_map>

namespace vox {

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
    for (const Mesh& mesh : meshes)
        for (std::uint32_t index : mesh.indices) bounds.add(mesh.positions[index]);
    return bounds;
}

namespace detail {
namespace {

/// Largest coordinate magnitude accepted: sums, differences and the root cube's diagonal stay far
/// below float's 3.4e38 (docs/import.md, "Bad input").
constexpr float kMaxCoordinate = 1e30f;
/// Smallest longest side of a scene: its finest voxels at --depth 20 (about 1e-36) are still normal
/// floats, above 1.2e-38, with full precision.
constexpr double kMinExtent = 1e-30;

struct PositionHash {
    std::size_t operator()(const Vec3f& p) const noexcept {
        const auto bits = [](float v) { return std::bit_cast<std::uint32_t>(v == 0.0f ? 0.0f : v); };
        std::size_t h = bits(p.x);
        h = h * 0x9E3779B97F4A7C15ull ^ bits(p.y);
        h = h * 0x9E3779B97F4A7C15ull ^ bits(p.z);
        return h;
    }
};

Vec3d toDouble(Vec3f v) { return {v.x, v.y, v.z}; }
Vec3f toFloat(Vec3d v) { return {static_cast<float>(v.x), static_cast<float>(v.y), static_cast<float>(v.z)}; }

/// Unnormalised face normal in double precision (its length is twice the area).
Vec3d faceNormal(const Mesh& mesh, std::size_t triangle) {
    const Vec3d a = toDouble(mesh.positions[mesh.indices[3 * triangle]]);
    const Vec3d b = toDouble(mesh.positions[mesh.indices[3 * triangle + 1]]);
    const Vec3d c = toDouble(mesh.positions[mesh.indices[3 * triangle + 2]]);
    return cross(b - a, c - a);
}

/// Angle-weighted normals per vertex, summed over every triangle touching the vertex's position
/// (so UV seams, which split vertices, do not split the shading).
std::vector<Vec3f> smoothNormals(const Mesh& mesh) {
    std::unordered_map<Vec3f, Vec3d, PositionHash> byPosition;
    byPosition.reserve(mesh.positions.size());
    for (std::size_t t = 0; t < mesh.triangleCount(); ++t) {
        const Vec3d n = normalize(faceNormal(mesh, t));
        for (int k = 0; k < 3; ++k) {
            const Vec3d p = toDouble(mesh.positions[mesh.indices[3 * t + k]]);
            const Vec3d e1 = normalize(toDouble(mesh.positions[mesh.indices[3 * t + (k + 1) % 3]]) - p);
            const Vec3d e2 = normalize(toDouble(mesh.positions[mesh.indices[3 * t + (k + 2) % 3]]) - p);
            const double angle = std::acos(std::clamp(dot(e1, e2), -1.0, 1.0));
            byPosition[mesh.positions[mesh.indices[3 * t + k]]] += n * angle;
        }
    }
    std::vector<Vec3f> normals(mesh.positions.size());
    for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
        auto it = byPosition.find(mesh.positions[v]);
        normals[v] = it == byPosition.end() ? Vec3f{} : toFloat(normalize(it->second));
    }
    return normals;
}

template <typename T>
void unweld(std::vector<T>& values, const std::vector<std::uint32_t>& indices) {
    if (values.empty()) return;
    std::vector<T> out(indices.size());
    for (std::size_t i = 0; i < indices.size(); ++i) out[i] = values[indices[i]];
    values = std::move(out);
}

void flatNormals(Mesh& mesh) {
    unweld(mesh.positions, mesh.indices);
    for (auto& set : mesh.uvs) unweld(set, mesh.indices);
    unweld(mesh.colors, mesh.indices);
    mesh.normals.assign(mesh.indices.size(), Vec3f{});
    for (std::size_t t = 0; t < mesh.indices.size() / 3; ++t) {
        std::iota(mesh.indices.begin() + 3 * t, mesh.indices.begin() + 3 * t + 3, static_cast<std::uint32_t>(3 * t));
        const Vec3f n = toFloat(normalize(faceNormal(mesh, t)));
        for (int k = 0; k < 3; ++k) mesh.normals[3 * t + k] = n;
    }
}

std::string meshLabel(const Mesh& mesh, std::size_t index) {
    return mesh.name.empty() ? "mesh " + std::to_string(index) : "mesh '" + mesh.name + "'";
}

}  // namespace

void generateNormals(Mesh& mesh, MissingNormals mode) {
    if (mode == MissingNormals::Flat)
        flatNormals(mesh);
    else
        mesh.normals = smoothNormals(mesh);
}

void finalizeScene(ImportContext& context, MissingNormals missingNormals) {
    Scene& scene = context.scene();
    std::size_t degenerate = 0, invalidNormals = 0, invalidUvs = 0, invalidColors = 0, trianglesBefore = 0;
    for (std::size_t m = 0; m < scene.meshes.size(); ++m) {
        Mesh& mesh = scene.meshes[m];
        const std::size_t vertexCount = mesh.positions.size();
        for (std::size_t v = 0; v < vertexCount; ++v) {
            const Vec3f& p = mesh.positions[v];
            if (!isFinite(p)) context.fail(meshLabel(mesh, m) + ": vertex " + std::to_string(v) + " has a non-finite position");
            if (std::max({std::fabs(p.x), std::fabs(p.y), std::fabs(p.z)}) > kMaxCoordinate)
                context.fail(meshLabel(mesh, m) + ": vertex " + std::to_string(v) + " has a coordinate beyond ±1e30 (absurd scale)");
        }
        if (mesh.indices.size() % 3 != 0) context.fail(meshLabel(mesh, m) + ": index count is not a multiple of 3");
        for (std::uint32_t index : mesh.indices)
            if (index >= vertexCount)
                context.fail(meshLabel(mesh, m) + ": vertex index " + std::to_string(index) + " out of range (" +
                             std::to_string(vertexCount) + " vertices)");
        trianglesBefore += mesh.triangleCount();

        // Triangles without area contribute no surface; the exact zero test keeps slivers.
        std::size_t kept = 0;
        for (std::size_t t = 0; t < mesh.triangleCount(); ++t) {
            const std::uint32_t* tri = &mesh.indices[3 * t];
            const bool repeated = tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2];
            const Vec3d n = faceNormal(mesh, t);
            if (repeated || (n.x == 0 && n.y == 0 && n.z == 0) || !isFinite(n)) {
                ++degenerate;
                continue;
            }
            std::copy(tri, tri + 3, &mesh.indices[3 * kept++]);
        }
        mesh.indices.resize(3 * kept);

        for (auto& set : mesh.uvs)
            for (Vec2f& uv : set)
                if (!std::isfinite(uv.x) || !std::isfinite(uv.y)) {
                    uv = {0, 0};
                    ++invalidUvs;
                }
        for (Vec4f& color : mesh.colors)
            if (!std::isfinite(color.x) || !std::isfinite(color.y) || !std::isfinite(color.z) || !std::isfinite(color.w)) {
                color = {1, 1, 1, 1};
                ++invalidColors;
            }

        if (mesh.normals.empty()) {
            generateNormals(mesh, missingNormals);
        } else {
            std::vector<Vec3f> replacements;
            for (std::size_t v = 0; v < mesh.normals.size(); ++v) {
                Vec3f& n = mesh.normals[v];
                // In double: a huge or tiny but finite normal still has a direction.
                const double len = isFinite(n) ? length(toDouble(n)) : 0.0;
                if (len > 0 && std::isfinite(len)) {
                    n = toFloat(toDouble(n) / len);
                    continue;
                }
                if (replacements.empty()) replacements = smoothNormals(mesh);
                n = replacements[v];
                ++invalidNormals;
            }
        }
    }
    std::erase_if(scene.meshes, [](const Mesh& mesh) { return mesh.indices.empty(); });

    // Importers may have dropped degenerate triangles already (OpenMesh does): report them all.
    scene.degenerateTrianglesDropped += degenerate;
    if (scene.meshes.empty()) {
        if (trianglesBefore > 0 || scene.degenerateTrianglesDropped > 0)
            context.fail("all " + std::to_string(trianglesBefore + scene.degenerateTrianglesDropped - degenerate) +
                         " triangles are degenerate (no area)");
        // What was skipped explains why nothing is left.
        std::string skipped;
        for (const std::string& warning : scene.warnings) skipped += (skipped.empty() ? " (" : "; ") + warning;
        context.fail("contains no triangles" + (skipped.empty() ? std::string() : skipped + ")"));
    }
    for (const Light& light : scene.lights)
        if (std::max({std::fabs(light.position.x), std::fabs(light.position.y), std::fabs(light.position.z)}) > kMaxCoordinate)
            context.fail("light '" + light.name + "' has a position beyond ±1e30 (absurd scale)");
    // The finest voxel of the deepest octree (2^-20 of the longest side) must stay a normal float.
    const Bounds3f bounds = scene.bounds();
    const double extent = std::max({double(bounds.max.x) - bounds.min.x, double(bounds.max.y) - bounds.min.y,
                                    double(bounds.max.z) - bounds.min.z});
    if (extent < kMinExtent) {
        char text[64];
        std::snprintf(text, sizeof text, "%g", extent);
        context.fail(std::string("the scene's longest side is ") + text + ", below 1e-30 (absurd scale: zero or denormal size)");
    }
    if (scene.degenerateTrianglesDropped)
        context.warn("dropped " + std::to_string(scene.degenerateTrianglesDropped) + " degenerate triangle(s) with no area");
    if (invalidNormals) context.warn("replaced " + std::to_string(invalidNormals) + " zero or non-finite normal(s)");
    if (invalidUvs) context.warn("replaced " + std::to_string(invalidUvs) + " non-finite texture coordinate(s) by 0");
    if (invalidColors) context.warn("replaced " + std::to_string(invalidColors) + " non-finite vertex colour(s) by white");
}

}  // namespace detail
}  // namespace vox
