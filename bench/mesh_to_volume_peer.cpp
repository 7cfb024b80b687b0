// The peer a user would reach for instead of voxelize: OpenVDB's meshToVolume on the same mesh,
// at the same resolution and thread count. It imports MESH with vox::importScene (the importer
// voxelize uses; static meshes only, as voxelize does by default; images are not decoded, since
// a distance field has no use for them), then builds an unsigned distance field whose narrow band
// is 0.87 voxel (√3/2) on both sides: the voxels whose centre lies within half a cube diagonal of
// a triangle, which holds every voxel a triangle touches (the octree's leaves) and a few more.
// The voxel size is the octree's leaf size (RootCube::enclosing(static bounds).size / 2^depth) and
// the transform puts OpenVDB's voxel (i,j,k), centred on an integer index point, exactly on the
// octree's leaf cell (i,j,k) = [origin + i·h, origin + (i+1)·h).
//
// Timed apart: the import, the mesh's flattening into index-space points and triangles
// (prepare), meshToVolume alone (the "voxelization" the acceptance compares against) and, with
// --output, writing the .vdb. Prints JSON (keys in docs/benchmarks.md); --stats writes it to a
// file instead. --cross-check afterwards voxelizes the scene with vox::voxelizeSurface (cubes
// only, untimed, after peak memory has been taken) and counts the octree's leaves that are active
// voxels of the grid and the other way round.
// Usage: mesh_to_volume_peer MESH [--depth N (default 10)] [--threads N (default: all cores)]
//        [--half-width W (voxels, default 0.87)] [--output FILE.vdb] [--stats FILE.json]
//        [--cross-check]
#include <vox/formats/atomic_file.h>
#include <vox/base/error.h>
#include <vox/import.h>
#include <vox/octree.h>
#include <vox/util/log.h>
#include <vox/util/parallel.h>
#include <vox/util/timings.h>

#include <nlohmann/json.hpp>
#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/MeshToVolume.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point start) {
    return std::chrono::duration<double>(Clock::now() - start).count();
}

struct Options {
    std::string input;
    std::uint32_t depth = 10;
    int threads = 0;  // all cores, as voxelize
    double halfWidth = 0.87;
    std::string output, stats;
    bool crossCheck = false;
};

Options parseOptions(int argc, char** argv) {
    Options o;
    for (int i = 1; i < argc; ++i) {
        const std::string key = argv[i];
        const auto value = [&]() -> std::string {
            if (i + 1 >= argc) throw vox::UsageError(key + " needs a value");
            return argv[++i];
        };
        const auto number = [&]() {
            const std::string text = value();
            char* end = nullptr;
            const double v = std::strtod(text.c_str(), &end);
            if (text.empty() || *end != '\0')
                throw vox::UsageError(key + ": expected a number, got '" + text + "'");
            return v;
        };
        if (key == "--depth")
            o.depth = static_cast<std::uint32_t>(std::clamp(number(), 0.0, 99.0));
        else if (key == "--threads") {
            o.threads = static_cast<int>(std::clamp(number(), 0.0, 1e5));
            if (o.threads < 1 || o.threads > 4096)
                throw vox::UsageError("--threads must be between 1 and 4096");
        } else if (key == "--half-width")
            o.halfWidth = number();
        else if (key == "--output" || key == "-o")
            o.output = value();
        else if (key == "--stats")
            o.stats = value();
        else if (key == "--cross-check")
            o.crossCheck = true;
        else if (!key.empty() && key[0] == '-')
            throw vox::UsageError("unknown option " + key);
        else if (o.input.empty())
            o.input = key;
        else
            throw vox::UsageError("more than one input: " + key);
    }
    if (o.input.empty())
        throw vox::UsageError(
            "usage: mesh_to_volume_peer MESH [--depth N] [--threads N] [--half-width W] [--output "
            "FILE.vdb] "
            "[--stats FILE.json] [--cross-check]");
    if (o.depth < 1 || o.depth > 20) throw vox::UsageError("--depth must be between 1 and 20");
    // meshToVolume returns an empty grid for a NaN or non-positive band, without a word.
    if (!(o.halfWidth > 0 && o.halfWidth < 1e6))
        throw vox::UsageError("--half-width must be a positive number of voxels");
    if (!o.output.empty() && std::filesystem::path(o.output).extension() != ".vdb")
        throw vox::UsageError("--output: expected a .vdb file name");
    return o;
}

/// The static meshes as one point and triangle list in the grid's index space (voxel (i,j,k)
/// centred on index point (i,j,k), i.e. world origin + (i + ½)·h).
struct IndexSpaceMesh {
    std::vector<openvdb::Vec3s> points;
    std::vector<openvdb::Vec3I> triangles;
};

IndexSpaceMesh flatten(const vox::Scene& scene, const vox::RootCube& cube, double voxelSize) {
    IndexSpaceMesh mesh;
    std::size_t points = 0, triangles = 0;
    for (const vox::Mesh& m : scene.meshes)
        if (!m.dynamic) points += m.positions.size(), triangles += m.triangleCount();
    mesh.points.reserve(points);
    mesh.triangles.reserve(triangles);
    const double scale = 1.0 / voxelSize;
    for (const vox::Mesh& m : scene.meshes) {
        if (m.dynamic) continue;
        const auto base = static_cast<std::uint32_t>(mesh.points.size());
        for (const vox::Vec3f& p : m.positions) {
            // In double, then rounded once: leaf units stay exact to ~1e-4 voxel at depth 12.
            const openvdb::Vec3s q(static_cast<float>((p.x - cube.origin.x) * scale - 0.5),
                                   static_cast<float>((p.y - cube.origin.y) * scale - 0.5),
                                   static_cast<float>((p.z - cube.origin.z) * scale - 0.5));
            if (!std::isfinite(q.x()) || !std::isfinite(q.y()) || !std::isfinite(q.z()))
                throw vox::InvalidDataError(
                    scene.sourceFiles.empty() ? "scene" : scene.sourceFiles.front(),
                    "non-finite vertex");
            mesh.points.push_back(q);
        }
        for (std::size_t t = 0; t + 2 < m.indices.size(); t += 3)
            mesh.triangles.emplace_back(base + m.indices[t], base + m.indices[t + 1],
                                        base + m.indices[t + 2]);
    }
    return mesh;
}

/// Calls @p visit(x, y, z) for every voxel of the octree's leaf level, in Morton order. Walks depth
/// first with one cursor per level: children of consecutive voxels are consecutive, so the
/// cursors stay in step without a table of first children.
template <typename Visit>
void forEachLeaf(const vox::SparseOctree& octree, Visit visit) {
    std::vector<std::uint64_t> cursor(octree.leafDepth + 1, 0);
    const auto walk = [&](auto& self, std::uint32_t level, std::uint64_t index, std::uint32_t x,
                          std::uint32_t y, std::uint32_t z) -> void {
        if (level == octree.leafDepth) {
            visit(x, y, z);
            return;
        }
        const unsigned mask = octree.masks[level][index];
        for (unsigned slot = 0; slot < 8; ++slot)
            if (mask & (1u << slot))
                self(self, level + 1, cursor[level + 1]++, 2 * x + (slot & 1u),
                     2 * y + ((slot >> 1) & 1u), 2 * z + ((slot >> 2) & 1u));
    };
    cursor[0] = 1;
    walk(walk, 0, 0, 0, 0, 0);
}

nlohmann::json run(const Options& o) {
    const auto processStart = Clock::now();
    vox::Timings timings;
    vox::ImportOptions importOptions;
    importOptions.loadTextures = false;
    importOptions.timings = &timings;
    vox::Scene scene;
    {
        vox::Timings::Scope timer(&timings, "import");
        scene = vox::importScene(o.input, importOptions);
    }
    vox::Bounds3f bounds;
    std::size_t staticTriangles = 0;
    for (const vox::Mesh& m : scene.meshes)
        if (!m.dynamic) {
            for (std::uint32_t index : m.indices) bounds.add(m.positions[index]);
            staticTriangles += m.triangleCount();
        }
    if (staticTriangles == 0)
        throw vox::InvalidDataError(o.input, "no static triangles to voxelize");
    const vox::RootCube cube = vox::RootCube::enclosing(bounds);
    const double voxelSize = std::ldexp(cube.size, -static_cast<int>(o.depth));

    openvdb::initialize();
    const auto prepareStart = Clock::now();
    IndexSpaceMesh mesh;
    {
        vox::Timings::Scope timer(&timings, "mesh_to_volume_prepare");
        mesh = flatten(scene, cube, voxelSize);
    }
    const double prepareSeconds = secondsSince(prepareStart);
    openvdb::math::Transform::Ptr transform =
        openvdb::math::Transform::createLinearTransform(voxelSize);
    transform->postTranslate(openvdb::Vec3d(cube.origin.x + 0.5 * voxelSize,
                                            cube.origin.y + 0.5 * voxelSize,
                                            cube.origin.z + 0.5 * voxelSize));

    const auto buildStart = Clock::now();
    openvdb::FloatGrid::Ptr grid;
    {
        vox::Timings::Scope timer(&timings, "mesh_to_volume");
        const openvdb::tools::QuadAndTriangleDataAdapter<openvdb::Vec3s, openvdb::Vec3I> adapter(
            mesh.points, mesh.triangles);
        const auto band = static_cast<float>(o.halfWidth);
        grid = openvdb::tools::meshToVolume<openvdb::FloatGrid>(
            adapter, *transform, band, band, openvdb::tools::UNSIGNED_DISTANCE_FIELD);
    }
    const double buildSeconds = secondsSince(buildStart);
    const std::uint64_t activeVoxels = grid->activeVoxelCount();
    if (activeVoxels == 0)
        throw vox::InvalidDataError(o.input, "meshToVolume produced an empty grid");

    nlohmann::json report;
    report["tool"] = "mesh_to_volume_peer";
    report["input"] = o.input;
    report["triangles"] = scene.triangleCount();
    report["static_triangles"] = staticTriangles;
    report["threads"] = vox::ThreadLimit::active();
    report["grid"] = {{"depth", o.depth},
                      {"voxel_size", voxelSize},
                      {"half_width_voxels", o.halfWidth},
                      {"active_voxels", activeVoxels},
                      {"leaf_nodes", grid->tree().leafCount()},
                      {"mem_usage_bytes", grid->memUsage()},
                      {"prepare_seconds", prepareSeconds},
                      {"mesh_to_volume_seconds", buildSeconds},
                      {"voxels_per_second", static_cast<double>(activeVoxels) / buildSeconds}};
    if (!o.output.empty()) {
        const auto writeStart = Clock::now();
        {
            vox::Timings::Scope timer(&timings, "vdb_write");
            grid->setName("distance");
            grid->setGridClass(openvdb::GRID_UNKNOWN);
            openvdb::io::File file(o.output);
            file.write({grid});
            file.close();
        }
        const auto bytes = std::filesystem::file_size(o.output);
        report["grid"]["output"] = o.output;
        report["grid"]["write_seconds"] = secondsSince(writeStart);
        report["grid"]["file_bytes"] = bytes;
        report["grid"]["bytes_per_voxel"] =
            static_cast<double>(bytes) / static_cast<double>(activeVoxels);
    }
    report["peak_rss_bytes"] = vox::peakRssBytes();  // before the cross-check's octree
    timings.add("total",
                std::chrono::duration<double, std::milli>(Clock::now() - processStart).count());

    if (o.crossCheck) {
        vox::SurfaceVoxelizeOptions options;
        options.depth = o.depth;
        const vox::SparseOctree octree = vox::voxelizeSurface(scene, options);
        const openvdb::FloatGrid::ConstAccessor accessor = grid->getConstAccessor();
        std::uint64_t leaves = 0, shared = 0;
        forEachLeaf(octree, [&](std::uint32_t x, std::uint32_t y, std::uint32_t z) {
            ++leaves;
            shared += accessor.isValueOn(
                openvdb::Coord(static_cast<int>(x), static_cast<int>(y), static_cast<int>(z)));
        });
        const auto fraction = [](std::uint64_t part, std::uint64_t whole) {
            return whole ? static_cast<double>(part) / static_cast<double>(whole) : 0.0;
        };
        report["cross_check"] = {{"octree_leaves", leaves},
                                 {"grid_active_voxels", activeVoxels},
                                 {"shared", shared},
                                 {"octree_leaves_in_grid", fraction(shared, leaves)},
                                 {"grid_voxels_in_octree", fraction(shared, activeVoxels)},
                                 {"grid_over_octree", fraction(activeVoxels, leaves)}};
    }
    nlohmann::json ms = nlohmann::json::object();
    for (const auto& [stage, milliseconds] : timings.entries()) ms[stage] = milliseconds;
    report["timings_ms"] = ms;
    return report;
}

}  // namespace

int main(int argc, char** argv) {
    try {
        const Options options = parseOptions(argc, argv);
        vox::log::setVerbosity(vox::log::Verbosity::Quiet);  // the benchmark's output is its JSON
        const vox::ThreadLimit threads(options.threads);
        const nlohmann::json report = run(options);
        if (options.stats.empty())
            std::cout << report.dump(2) << '\n';
        else
            vox::writeFileAtomically(options.stats, report.dump(2) + "\n");
        return 0;
    } catch (const vox::Error& e) {
        std::fprintf(stderr, "mesh_to_volume_peer: error: %s\n", e.what());
        return static_cast<int>(e.exitCode());
    } catch (const std::exception& e) {
        std::fprintf(stderr, "mesh_to_volume_peer: error: %s\n", e.what());
        return 4;
    }
}
