// voxelize: the command content builds call. Imports a scene (and, as the octree and radiance
// issues land, builds .esvo/.rvol assets from it); --stats and --depfile report what it did.
#include "../common/reports.h"
#include "../common/tool_main.h"

#include <vox/formats/error.h>
#include <vox/import.h>
#include <vox/formats/rvol_io.h>
#include <vox/octree.h>
#include <vox/radiance.h>
#include <vox/vdb_export.h>
#include <vox/util/log.h>
#include <vox/util/timings.h>
#include <vox/version.h>

#include <chrono>
#include <cstdio>
#include <limits>

namespace {

struct VoxelizeOptions {
    vox::tools::CommonOptions common;
    std::string input;
    std::string output;
    unsigned depth = 10;
    std::uint32_t sliceBytes = 1u << 20;
    std::uint32_t nearPointerLimit = 0x7FFF;
    bool includeDynamic = false;
    bool noContours = false;
    double contourError = 0;
    std::string attributes = "dxt";
    double colorError = 0;
    double normalError = 0;
    std::string stats;
    std::string depfile;
    std::vector<std::string> dynamicNames;
    bool strict = false;
    bool noTextures = false;
    std::int64_t maxTriangles = 0;  // 0: no limit; signed, so that CLI11 rejects negative values
    // Radiance volume
    std::string radiance;
    unsigned radianceDepth = 8;
    std::string attenuation = "weighted";
    double shadowAperture = 0;
    unsigned bounces = 2;
    double aoLambda = 8;
    unsigned brickTexels = 5;
    bool noStaticAttributes = false;
    std::string exportVdb;
    std::string lightcuts = "auto";
    double lightcutError = 0.02;
    std::string lightcutCriterion = "rss";
    unsigned lightcutMaxCut = 1000;
    bool lightcutsCompare = false;
};

/// Bakes and writes the .rvol; returns its part of the report.
nlohmann::json bakeRadiance(const VoxelizeOptions& options, const vox::Scene& scene, vox::Timings& timings) {
    vox::RadianceBakeOptions bakeOptions;
    bakeOptions.depth = options.radianceDepth;
    bakeOptions.attenuation = options.attenuation == "paper"     ? vox::Attenuation::Paper
                              : options.attenuation == "average" ? vox::Attenuation::Average
                                                                 : vox::Attenuation::Weighted;
    bakeOptions.shadowApertureDegrees = options.shadowAperture;
    bakeOptions.bounces = options.bounces;
    bakeOptions.aoLambda = options.aoLambda;
    bakeOptions.timings = &timings;
    bakeOptions.lightcuts = vox::parseLightcutsMode(options.lightcuts);
    bakeOptions.lightcut.relativeError = options.lightcutError;
    bakeOptions.lightcut.criterion = vox::parseLightcutCriterion(options.lightcutCriterion);
    bakeOptions.lightcut.maxCutSize = options.lightcutMaxCut;
    bakeOptions.lightcutsCompare = options.lightcutsCompare;
    const auto start = std::chrono::steady_clock::now();
    vox::RadianceBake bake;
    {
        vox::Timings::Scope timer(&timings, "radiance_bake");
        bake = vox::bakeRadiance(scene, bakeOptions);
    }
    const double bakeSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    vox::rvol::RvolWriteOptions writeOptions;
    writeOptions.brickTexels = options.brickTexels;
    writeOptions.staticAttributes = !options.noStaticAttributes;
    vox::rvol::RvolWriteResult written;
    {
        vox::Timings::Scope timer(&timings, "rvol_write");
        written = vox::rvol::writeRvol(options.radiance, bake.volume, writeOptions);
    }
    if (!options.exportVdb.empty()) {
        vox::Timings::Scope timer(&timings, "vdb_export");
        vox::exportVdb(options.exportVdb, bake.volume);
    }
    char summary[512];
    std::snprintf(summary, sizeof summary,
                  "%s: %u³ cells, %llu static + %llu dynamic voxels, %u bounces, %llu bricks, %.2f MB (radiance %.2f MB) in %.2f s",
                  options.radiance.c_str(), 1u << options.radianceDepth, static_cast<unsigned long long>(bake.staticVoxels),
                  static_cast<unsigned long long>(bake.dynamicVoxels), options.bounces, static_cast<unsigned long long>(written.bricks),
                  double(written.fileBytes) / 1e6, double(written.radianceBytes) / 1e6, bakeSeconds);
    vox::log::info(summary);
    return {{"output", options.radiance},
            {"depth", options.radianceDepth},
            {"resolution", 1u << options.radianceDepth},
            {"static_voxels", bake.staticVoxels},
            {"dynamic_voxels", bake.dynamicVoxels},
            {"lights", bake.volume.bake.lights},
            {"bounces", options.bounces},
            {"attenuation", options.attenuation},
            {"shadow_aperture_degrees", options.shadowAperture},
            {"brick_texels", options.brickTexels},
            {"bricks", written.bricks},
            {"bricks_per_level", written.bricksPerLevel},
            {"file_bytes", written.fileBytes},
            {"radiance_bytes", written.radianceBytes},
            {"directory_bytes", written.directoryBytes},
            {"attribute_bytes", written.attributeBytes},
            {"bake_seconds", bakeSeconds},
            {"direct_light", vox::tools::directLightReport(bake.directLight, bakeOptions.lightcut)}};
}

void voxelize(const VoxelizeOptions& options) {
    vox::Timings timings;
    const auto start = std::chrono::steady_clock::now();
    if (!options.depfile.empty() && options.stats.empty() && options.output.empty() && options.radiance.empty())
        throw vox::UsageError("--depfile needs an output to name as its target (-o, --radiance or --stats)");
    const std::filesystem::path output(options.output);
    if (!options.output.empty() && output.extension() != ".esvo")
        throw vox::UsageError("-o: unknown output type '" + output.extension().string() + "' (expected .esvo)");
    if (!options.radiance.empty() && std::filesystem::path(options.radiance).extension() != ".rvol")
        throw vox::UsageError("--radiance: unknown output type '" + std::filesystem::path(options.radiance).extension().string() +
                              "' (expected .rvol)");
    if (!options.exportVdb.empty() && options.radiance.empty()) throw vox::UsageError("--export-vdb needs --radiance");
    if (!options.exportVdb.empty() && std::filesystem::path(options.exportVdb).extension() != ".vdb")
        throw vox::UsageError("--export-vdb: expected a .vdb file name");

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
    // Before anything is built or written: a scene over the limit leaves no output behind.
    if (options.maxTriangles > 0 && scene.triangleCount() > static_cast<std::uint64_t>(options.maxTriangles))
        throw vox::InvalidDataError(options.input, std::to_string(scene.triangleCount()) + " triangles, more than --max-triangles " +
                                                       std::to_string(options.maxTriangles));
    const vox::Bounds3f bounds = scene.bounds();
    char summary[512];
    std::snprintf(summary, sizeof summary,
                  "%s: %zu triangles (%zu dynamic) in %zu meshes, %zu materials, %zu textures, %zu lights; "
                  "bounds [%g %g %g] - [%g %g %g]",
                  options.input.c_str(), scene.triangleCount(), scene.dynamicTriangleCount(), scene.meshes.size(),
                  scene.materials.size(), scene.textures.size(), scene.lights.size(), bounds.min.x, bounds.min.y,
                  bounds.min.z, bounds.max.x, bounds.max.y, bounds.max.z);
    vox::log::info(summary);

    nlohmann::json report = vox::tools::sceneReport(scene);
    if (!options.output.empty()) {
        vox::SurfaceVoxelizeOptions voxelizeOptions;
        voxelizeOptions.depth = options.depth;
        voxelizeOptions.includeDynamic = options.includeDynamic;
        voxelizeOptions.contours = !options.noContours;
        voxelizeOptions.contourError = options.contourError;
        voxelizeOptions.attributes = options.attributes != "none";
        voxelizeOptions.colorError = options.colorError;
        voxelizeOptions.normalErrorDegrees = options.normalError;
        voxelizeOptions.timings = &timings;
        const auto buildStart = std::chrono::steady_clock::now();
        vox::SparseOctree octree;
        {
            vox::Timings::Scope timer(&timings, "voxelize");
            octree = vox::voxelizeSurface(scene, voxelizeOptions);
        }
        const double voxelizeSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - buildStart).count();
        vox::EsvoWriteOptions writeOptions;
        writeOptions.sliceBytes = options.sliceBytes;
        writeOptions.nearPointerLimit = options.nearPointerLimit;
        writeOptions.attributes = options.attributes == "raw"          ? vox::AttributeEncoding::Raw
                                : options.attributes == "dxt"        ? vox::AttributeEncoding::Compressed
                                : options.attributes == "dxt-lookup" ? vox::AttributeEncoding::CompressedLookup
                                                                     : vox::AttributeEncoding::None;
        writeOptions.sceneBounds = bounds;
        writeOptions.timings = &timings;
        vox::EsvoWriteResult written;
        {
            vox::Timings::Scope timer(&timings, "esvo");
            written = vox::writeEsvo(output, octree, writeOptions);
        }
        const double buildSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - buildStart).count();
        std::snprintf(summary, sizeof summary, "%s: depth %u, %llu voxels (%llu leaves), %u slices, %llu far pointers, %llu bytes (%.3f bytes/voxel)",
                      options.output.c_str(), octree.leafDepth, static_cast<unsigned long long>(octree.voxelCount()),
                      static_cast<unsigned long long>(octree.voxelsPerLevel.back()), written.slices,
                      static_cast<unsigned long long>(written.farPointers), static_cast<unsigned long long>(written.fileBytes),
                      double(written.fileBytes) / double(octree.voxelCount()));
        vox::log::info(summary);
        report["octree"] = {{"output", options.output},
                            {"depth", octree.leafDepth},
                            {"voxels", octree.voxelCount()},
                            {"voxels_per_level", octree.voxelsPerLevel},
                            {"descriptors", written.descriptors},
                            {"slices", written.slices},
                            {"far_pointers", written.farPointers},
                            {"file_bytes", written.fileBytes},
                            {"attributes", options.attributes},
                            {"bytes_per_voxel", double(written.fileBytes) / double(octree.voxelCount())},
                            {"voxelize_seconds", voxelizeSeconds},
                            {"build_seconds", buildSeconds},
                            {"voxels_per_second", double(octree.voxelCount()) / buildSeconds}};
    }

    if (!options.radiance.empty()) report["radiance"] = bakeRadiance(options, scene, timings);

    timings.add("total", std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
    if (!options.stats.empty()) vox::tools::writeStats(options.stats, report, "voxelize", timings);
    if (!options.depfile.empty())
        vox::tools::writeDepfile(options.depfile,
                                 !options.output.empty() ? options.output : !options.radiance.empty() ? options.radiance : options.stats,
                                 scene.sourceFiles);
}

}  // namespace

int main(int argc, char** argv) {
    VoxelizeOptions options;
    CLI::App app{"Turns a triangle scene (glTF/GLB, OBJ, PLY, STL, OFF, Draco) into voxel assets.", "voxelize"};
    app.set_version_flag("--version", std::string("voxelize (libvox) ") + LIBVOX_VERSION_STRING);
    app.add_option("input", options.input, "Scene file: .gltf .glb .obj .ply .stl .off .drc")->required();
    app.add_option("-o,--output", options.output, "Write the sparse voxel octree here (.esvo)");
    app.add_option("--depth", options.depth, "Leaf level: 2^N voxels along the scene's longest side")
        ->check(CLI::Range(1, 20))->capture_default_str();
    app.add_option("--slice-bytes", options.sliceBytes, "Largest .esvo slice in bytes")
        ->check(CLI::Range(16384, 1 << 26))->capture_default_str();
    app.add_flag("--include-dynamic", options.includeDynamic, "Voxelize dynamic meshes too (left out by default)");
    app.add_flag("--no-contours", options.noContours, "Cubes only: no contours (slabs) in the octree");
    app.add_option("--contour-error", options.contourError,
                   "Stop refining where a voxel's cube and contour lie within E leaf voxels of the surface (0: refine to --depth)")
        ->check(CLI::Range(0.0, 1e6))->capture_default_str();
    app.add_option("--attributes", options.attributes,
                   "Colour and normal per voxel: dxt (compressed, 6 words per pair of sibling descriptors), dxt-lookup "
                   "(compressed behind a lookup entry per descriptor, values equal to the parent's omitted), raw (64 bits "
                   "per stored voxel) or none")
        ->check(CLI::IsMember({"dxt", "dxt-lookup", "raw", "none"}))->capture_default_str();
    app.add_option("--color-error", options.colorError,
                   "With --contour-error: keep refining where colour varies more than this (8-bit sRGB steps) inside a voxel (0: off)")
        ->check(CLI::Range(0.0, 255.0))->capture_default_str();
    app.add_option("--normal-error", options.normalError,
                   "With --contour-error: keep refining where the normal varies more than this many degrees inside a voxel (0: off)")
        ->check(CLI::Range(0.0, 180.0))->capture_default_str();
    app.add_option("--radiance", options.radiance, "Bake a mipmapped anisotropic radiance volume here (.rvol)");
    app.add_option("--radiance-depth", options.radianceDepth, "Radiance volume: 2^N cells along the scene's longest side")
        ->check(CLI::Range(1, 10))->capture_default_str();
    app.add_option("--attenuation", options.attenuation,
                   "Direct light's normal attenuation per voxel: weighted (per axis, by the voxel's own normals), paper "
                   "(eq. 2 of Gui et al. on the mean normal) or average (cosine of the mean normal)")
        ->check(CLI::IsMember({"weighted", "paper", "average"}))->capture_default_str();
    app.add_option("--shadow-aperture", options.shadowAperture,
                   "Shadows by a cone of this aperture in degrees through the voxels' occlusion (0: shadow rays)")
        ->check(CLI::Range(0.0, 89.0))->capture_default_str();
    app.add_option("--bounces", options.bounces, "Indirect bounces gathered with cones")->check(CLI::Range(0, 16))->capture_default_str();
    app.add_option("--ao-lambda", options.aoLambda,
                   "Ambient occlusion falloff λ (eq. 4), per scene-cube edge of cone radius")
        ->check(CLI::Range(0.0, 1e6))->capture_default_str();
    app.add_option("--brick-texels", options.brickTexels, "Radiance volume: texels per brick edge (bricks share their faces)")
        ->check(CLI::Range(2, 32))->capture_default_str();
    app.add_flag("--no-static-attributes", options.noStaticAttributes,
                 "Radiance volume: leave out the static voxels' albedo/normal/emission layer (dynamic voxels' is always written)");
    app.add_option("--export-vdb", options.exportVdb, "With --radiance: also write albedo, radiance per direction and occlusion as OpenVDB grids");
    app.add_option("--lightcuts", options.lightcuts,
                   "Radiance volume's direct light through Lightcuts: on, off (every light at every voxel) or auto (on from " +
                       std::to_string(vox::kLightcutsAutoLights) + " static lights)")
        ->check(CLI::IsMember({"auto", "on", "off"}))->capture_default_str();
    app.add_option("--lightcut-error", options.lightcutError, "Lightcuts: relative error of each voxel's direct light")
        ->check(CLI::Range(0.0001, 1.0))->capture_default_str();
    app.add_option("--lightcut-criterion", options.lightcutCriterion,
                   "Lightcuts: what must stay within the error: rss (root of the sum of the clusters' squared bounds), sum, or "
                   "per-node (each cluster's bound, as published)")
        ->check(CLI::IsMember({"rss", "sum", "per-node"}))->capture_default_str();
    app.add_option("--lightcut-max-cut", options.lightcutMaxCut, "Lightcuts: most clusters in one cut")
        ->check(CLI::Range(1, 1000000))->capture_default_str();
    app.add_flag("--lightcuts-compare", options.lightcutsCompare,
                 "Also light every voxel with classic Lightcuts (one tree, no clusters, no reuse) and brute force, and report "
                 "both in --stats (direct_light.compare)");
    app.add_option("--debug-near-pointer-limit", options.nearPointerLimit,
                   "Largest near child pointer (testing far pointers)")
        ->check(CLI::Range(32, 0x7FFF))->group("");
    app.add_option("--stats", options.stats, "Write a JSON report: inputs, counts, timings, peak memory");
    app.add_option("--depfile", options.depfile, "Write a Make/Ninja depfile listing every file read");
    app.add_option("--dynamic", options.dynamicNames,
                   "Mark a node (glTF), object or group (OBJ) and everything below it dynamic; repeatable")
        ->allow_extra_args(false);
    app.add_flag("--strict", options.strict, "Treat repaired input (degenerate triangles, bad normals, ...) as an error");
    app.add_flag("--no-textures", options.noTextures, "Do not read or decode textures");
    app.add_option("--max-triangles", options.maxTriangles,
                   "Reject a scene with more triangles than this after import (invalid input, exit 3)")
        ->check(CLI::Range(std::int64_t{1}, std::numeric_limits<std::int64_t>::max()));
    vox::tools::addCommonOptions(app, options.common);
    return vox::tools::runTool("voxelize", app, argc, argv, options.common, [&] { voxelize(options); });
}
