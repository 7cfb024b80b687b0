// voxelize: the command content builds call. Imports a scene (and, as the octree and radiance
// issues land, builds .esvo/.rvol assets from it); --stats and --depfile report what it did.
#include "../common/reports.h"
#include "../common/tool_main.h"

#include <vox/formats/error.h>
#include <vox/import.h>
#include <vox/util/log.h>
#include <vox/util/timings.h>
#include <vox/version.h>

#include <chrono>
#include <cstdio>

namespace {

struct VoxelizeOptions {
    vox::tools::CommonOptions common;
    std::string input;
    std::string stats;
    std::string depfile;
    std::vector<std::string> dynamicNames;
    bool strict = false;
    bool noTextures = false;
};

void voxelize(const VoxelizeOptions& options) {
    vox::Timings timings;
    const auto start = std::chrono::steady_clock::now();
    if (!options.depfile.empty() && options.stats.empty())
        throw vox::UsageError("--depfile needs an output to name as its target (--stats)");

    vox::ImportOptions importOptions;
    importOptions.dynamicNames = options.dynamicNames;
    importOptions.strict = options.strict;
    importOptions.loadTextures = !options.noTextures;
    importOptions.timings = &timings;
    vox::Scene scene;
    {
        vox::Timings::Scope timer(&timings, "import");
        scene = vox::importScene(options.input, importOptions);
    }
    const vox::Bounds3f bounds = scene.bounds();
    char summary[512];
    std::snprintf(summary, sizeof summary,
                  "%s: %zu triangles (%zu dynamic) in %zu meshes, %zu materials, %zu textures, %zu lights; "
                  "bounds [%g %g %g] - [%g %g %g]",
                  options.input.c_str(), scene.triangleCount(), scene.dynamicTriangleCount(), scene.meshes.size(),
                  scene.materials.size(), scene.textures.size(), scene.lights.size(), bounds.min.x, bounds.min.y,
                  bounds.min.z, bounds.max.x, bounds.max.y, bounds.max.z);
    vox::log::info(summary);

    timings.add("total", std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
    if (!options.stats.empty()) vox::tools::writeStats(options.stats, vox::tools::sceneReport(scene), "voxelize", timings);
    if (!options.depfile.empty()) vox::tools::writeDepfile(options.depfile, options.stats, scene.sourceFiles);
}

}  // namespace

int main(int argc, char** argv) {
    VoxelizeOptions options;
    CLI::App app{"Turns a triangle scene (glTF/GLB, OBJ, PLY, STL, OFF, Draco) into voxel assets.", "voxelize"};
    app.set_version_flag("--version", std::string("voxelize (libvox) ") + LIBVOX_VERSION_STRING);
    app.add_option("input", options.input, "Scene file: .gltf .glb .obj .ply .stl .off .drc")->required();
    app.add_option("--stats", options.stats, "Write a JSON report: inputs, counts, timings, peak memory");
    app.add_option("--depfile", options.depfile, "Write a Make/Ninja depfile listing every file read");
    app.add_option("--dynamic", options.dynamicNames,
                   "Mark a node (glTF), object or group (OBJ) and everything below it dynamic; repeatable")
        ->allow_extra_args(false);
    app.add_flag("--strict", options.strict, "Treat repaired input (degenerate triangles, bad normals, ...) as an error");
    app.add_flag("--no-textures", options.noTextures, "Do not read or decode textures");
    vox::tools::addCommonOptions(app, options.common);
    return vox::tools::runTool("voxelize", app, argc, argv, options.common, [&] { voxelize(options); });
}
