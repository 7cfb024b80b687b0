// voxelize: the command content builds call. Imports a scene (and, as the octree and radiance
// issues land, builds .esvo/.rvol assets from it); --stats and --depfile report what it did.
#include "../common/reports.h"
#include "../common/tool_main.h"

#include <vox/base/error.h>
#include <vox/import.h>
#include <vox/formats/rvol_io.h>
#include <vox/octree.h>
#include <vox/radiance.h>
#include <vox/radiance_tiles.h>
#include <vox/vdb_export.h>
#include <vox/util/log.h>
#include <vox/util/timings.h>
#include <vox/version.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>

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
    bool fullRefinement = false;
    double contourError = vox::kDefaultContourError;
    std::string attributes = "dxt";
    std::string attributeEffort = "fast";
    double colorError = vox::kDefaultColorError;
    double normalError = vox::kDefaultNormalErrorDegrees;
    std::string stats;
    std::string depfile;
    std::vector<std::string> dynamicNames;
    bool strict = false;
    bool noTextures = false;
    std::int64_t maxTriangles = 0;  // 0: no limit; signed, so that CLI11 rejects negative values
    // Radiance volume
    std::string radiance;
    unsigned radianceDepth = 8;
    std::string attenuation = "adaptive";
    double shadowAperture = 0;
    unsigned bounces = 2;
    std::string bounceGather = "auto";
    unsigned gatherRays = 256;
    double aoLambda = 8;
    unsigned brickTexels = 5;
    bool noStaticAttributes = false;
    std::string exportVdb;
    std::string lightcuts = "auto";
    double lightcutError = 0.02;
    std::string lightcutCriterion = "rss";
    unsigned lightcutMaxCut = 1000;
    bool lightcutsCompare = false;
    unsigned radianceTileDepth = 0;  // 0: one volume up to depth 10, tiles from 11
    unsigned radianceHalo = 0;       // 0: a quarter tile
    std::string radianceTile;        // "K/N" or "index"
    // Partitioned and out-of-core builds
    std::string memoryLimit;  // empty: vox::defaultMemoryLimit()
    std::string partition;    // "K/N"
    int partitionLevel = -1;
    // voxelize merge
    std::vector<std::string> mergeParts;
};

/// "8G", "512M", "1.5GiB", "123456" (bytes) → bytes. @throws UsageError.
std::uint64_t parseByteSize(const std::string& text, const std::string& option) {
    std::size_t used = 0;
    double value = 0;
    try {
        value = std::stod(text, &used);
    } catch (const std::exception&) {
        used = 0;
    }
    std::string unit = text.substr(used);
    if (!unit.empty() && (unit.back() == 'B' || unit.back() == 'b')) unit.pop_back();
    if (unit.size() == 2 && unit[1] == 'i') unit.pop_back();
    double scale = 0;
    if (unit.empty())
        scale = 1;
    else if (unit == "K" || unit == "k")
        scale = 1024.0;
    else if (unit == "M" || unit == "m")
        scale = 1024.0 * 1024;
    else if (unit == "G" || unit == "g")
        scale = 1024.0 * 1024 * 1024;
    else if (unit == "T" || unit == "t")
        scale = 1024.0 * 1024 * 1024 * 1024;
    if (used == 0 || scale == 0 || !(value > 0) || value * scale > 1e18)
        throw vox::UsageError(option + ": '" + text +
                              "' is not a size (bytes, or a number with K, M, G or T)");
    return static_cast<std::uint64_t>(value * scale);
}

/// "K/N" with 1 ≤ K ≤ N → the 0-based selection. @throws UsageError.
vox::PartitionSelection parsePartition(const std::string& text) {
    unsigned k = 0, n = 0;
    char tail = 0;
    if (std::sscanf(text.c_str(), "%u/%u%c", &k, &n, &tail) != 2 || k < 1 || k > n || n > 65536)
        throw vox::UsageError("--partition: '" + text + "' is not K/N with 1 ≤ K ≤ N ≤ 65536");
    return {k - 1, n};
}

/// The tiling of a tiled radiance bake, or none for a single volume. @throws UsageError.
std::optional<vox::RadianceTiling> radianceTiling(const VoxelizeOptions& options,
                                                  std::uint64_t memoryLimit) {
    if (options.radianceTileDepth == 0 && options.radianceDepth <= 10) {
        if (!options.radianceTile.empty() || options.radianceHalo != 0)
            throw vox::UsageError(
                "--radiance-tile and --radiance-halo need a tiled bake "
                "(--radiance-tile-depth, or --radiance-depth above 10)");
        return std::nullopt;
    }
    const std::uint32_t tileDepth =
        options.radianceTileDepth != 0
            ? options.radianceTileDepth
            : vox::RadianceTiling::tileDepthFor(options.radianceDepth, memoryLimit);
    try {
        return vox::RadianceTiling::plan(options.radianceDepth, tileDepth, options.radianceHalo);
    } catch (const vox::ParameterError& e) {
        throw vox::UsageError(std::string("--radiance-tile-depth: ") + e.what());
    }
}

/// "K/N" (1 ≤ K ≤ N ≤ 65536) or "index" → the job of a tiled bake. @throws UsageError.
vox::TiledBakeJob parseRadianceTile(const std::string& text) {
    vox::TiledBakeJob job;
    if (text.empty()) return job;
    if (text == "index") {
        job.kind = vox::TiledBakeJob::Kind::Index;
        return job;
    }
    unsigned k = 0, n = 0;
    char tail = 0;
    if (std::sscanf(text.c_str(), "%u/%u%c", &k, &n, &tail) != 2 || k < 1 || k > n || n > 65536)
        throw vox::UsageError("--radiance-tile: '" + text +
                              "' is not K/N with 1 ≤ K ≤ N ≤ 65536, nor 'index'");
    job.kind = vox::TiledBakeJob::Kind::Run;
    job.run = k - 1;
    job.runs = n;
    return job;
}

/// The octree part of --stats for a build or a merge.
nlohmann::json octreeReport(const std::string& output, const vox::EsvoBuildResult& built,
                            const std::string& attributes, double buildSeconds,
                            double voxelizeSeconds) {
    const double voxels = double(built.voxelCount());
    return {{"output", output},
            {"depth", built.leafDepth},
            {"voxels", built.voxelCount()},
            {"voxels_per_level", built.voxelsPerLevel},
            {"descriptors", built.written.descriptors},
            {"slices", built.written.slices},
            {"far_pointers", built.written.farPointers},
            {"file_bytes", built.written.fileBytes},
            {"attributes", attributes},
            {"attribute_kernels", vox::attributeEncoderKernels()},
            {"bytes_per_voxel", voxels > 0 ? double(built.written.fileBytes) / voxels : 0.0},
            {"voxelize_seconds", voxelizeSeconds},
            {"build_seconds", buildSeconds},
            {"voxels_per_second", voxels / buildSeconds},
            {"partition_level", built.partitionLevel},
            {"partitions", built.partitionsTotal},
            {"partitions_built", built.partitionsBuilt},
            {"batches", built.batches},
            {"memory_limit_bytes", built.memoryLimit},
            {"scratch_bytes", built.scratchBytes}};
}

/// A tiled bake (or one run of it, or its index step); returns its part of the report.
nlohmann::json bakeTiled(const VoxelizeOptions& options, const vox::Scene& scene,
                         const vox::RadianceBakeOptions& bakeOptions,
                         const vox::RadianceTiling& tiling, vox::Timings& timings) {
    const vox::TiledBakeJob job = parseRadianceTile(options.radianceTile);
    vox::rvol::RvolWriteOptions writeOptions;
    writeOptions.brickTexels = options.brickTexels;
    writeOptions.staticAttributes = !options.noStaticAttributes;
    const auto start = std::chrono::steady_clock::now();
    vox::TiledBakeResult result;
    {
        vox::Timings::Scope timer(&timings, "radiance_tiled_bake");
        result =
            vox::bakeTiledRadiance(scene, bakeOptions, tiling, job, options.radiance, writeOptions);
    }
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    char summary[512];
    std::snprintf(summary, sizeof summary,
                  "%s: %u³ cells in tiles of %u³ (halo %u, far field %u³): %llu of %llu tiles "
                  "baked, %llu static voxels, %.2f MB of tiles in %.2f s",
                  options.radiance.c_str(), 1u << tiling.depth, 1u << tiling.tileDepth, tiling.halo,
                  1u << tiling.farDepth, static_cast<unsigned long long>(result.tilesBaked),
                  static_cast<unsigned long long>(result.tilesTotal),
                  static_cast<unsigned long long>(result.staticVoxels),
                  double(result.tileBytes) / 1e6, seconds);
    vox::log::info(summary);
    nlohmann::json report = {{"output", options.radiance},
                             {"depth", tiling.depth},
                             {"resolution", 1u << tiling.depth},
                             {"tile_depth", tiling.tileDepth},
                             {"halo", tiling.halo},
                             {"far_depth", tiling.farDepth},
                             {"tiles", result.tilesTotal},
                             {"tiles_baked", result.tilesBaked},
                             {"static_voxels", result.staticVoxels},
                             {"dynamic_voxels", result.dynamicVoxels},
                             {"largest_tile_voxels", result.largestTileVoxels},
                             {"bounces", options.bounces},
                             {"brick_texels", options.brickTexels},
                             {"tile_bytes", result.tileBytes},
                             {"far_bytes", result.farBytes},
                             {"index_bytes", result.indexBytes},
                             {"file_bytes", result.tileBytes + result.farBytes + result.indexBytes},
                             {"far_seconds", result.farSeconds},
                             {"tile_seconds", result.tileSeconds},
                             {"bake_seconds", seconds}};
    if (job.kind == vox::TiledBakeJob::Kind::Run)
        report["run"] = {{"run", job.run + 1}, {"runs", job.runs}};
    nlohmann::json files = nlohmann::json::array();
    for (const vox::rvol::TileEntry& t : result.tilesWritten)
        files.push_back(
            {{"file", vox::rvol::tilePath(options.radiance, t.x, t.y, t.z).filename().string()},
             {"bytes", t.fileBytes},
             {"header_checksum", t.headerChecksum}});
    report["tile_files"] = std::move(files);
    return report;
}

/// Bakes and writes the .rvol; returns its part of the report.
nlohmann::json bakeRadiance(const VoxelizeOptions& options, const vox::Scene& scene,
                            const std::optional<vox::RadianceTiling>& tiling,
                            vox::Timings& timings) {
    vox::RadianceBakeOptions bakeOptions;
    bakeOptions.depth = options.radianceDepth;
    bakeOptions.attenuation = options.attenuation == "paper"      ? vox::Attenuation::Paper
                              : options.attenuation == "average"  ? vox::Attenuation::Average
                              : options.attenuation == "adaptive" ? vox::Attenuation::Adaptive
                                                                  : vox::Attenuation::Weighted;
    bakeOptions.shadowApertureDegrees = options.shadowAperture;
    bakeOptions.bounces = options.bounces;
    bakeOptions.bounceGather = options.bounceGather == "rays"    ? vox::BounceGather::Rays
                               : options.bounceGather == "cones" ? vox::BounceGather::Cones
                                                                 : vox::BounceGather::Auto;
    bakeOptions.gatherRays = options.gatherRays;
    bakeOptions.aoLambda = options.aoLambda;
    bakeOptions.timings = &timings;
    bakeOptions.lightcuts = vox::parseLightcutsMode(options.lightcuts);
    bakeOptions.lightcut.relativeError = options.lightcutError;
    bakeOptions.lightcut.criterion = vox::parseLightcutCriterion(options.lightcutCriterion);
    bakeOptions.lightcut.maxCutSize = options.lightcutMaxCut;
    bakeOptions.lightcutsCompare = options.lightcutsCompare;
    if (tiling) return bakeTiled(options, scene, bakeOptions, *tiling, timings);
    const auto start = std::chrono::steady_clock::now();
    vox::RadianceBake bake;
    {
        vox::Timings::Scope timer(&timings, "radiance_bake");
        bake = vox::bakeRadiance(scene, bakeOptions);
    }
    const double bakeSeconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
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
                  "%s: %u³ cells, %llu static + %llu dynamic voxels, %u bounces, %llu bricks, %.2f "
                  "MB (radiance %.2f MB) in %.2f s",
                  options.radiance.c_str(), 1u << options.radianceDepth,
                  static_cast<unsigned long long>(bake.staticVoxels),
                  static_cast<unsigned long long>(bake.dynamicVoxels), options.bounces,
                  static_cast<unsigned long long>(written.bricks), double(written.fileBytes) / 1e6,
                  double(written.radianceBytes) / 1e6, bakeSeconds);
    vox::log::info(summary);
    return {
        {"output", options.radiance},
        {"depth", options.radianceDepth},
        {"resolution", 1u << options.radianceDepth},
        {"static_voxels", bake.staticVoxels},
        {"dynamic_voxels", bake.dynamicVoxels},
        {"lights", bake.volume.bake.lights},
        {"bounces", options.bounces},
        {"bounce_gather", bake.volume.bake.gatherRays > 0 ? "rays" : "cones"},
        {"gather_rays", bake.volume.bake.gatherRays},
        {"two_sided_voxels", bake.twoSidedVoxels},
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
    if (!options.depfile.empty() && options.stats.empty() && options.output.empty() &&
        options.radiance.empty())
        throw vox::UsageError(
            "--depfile needs an output to name as its target (-o, --radiance or --stats)");
    const std::filesystem::path output(options.output);
    const vox::PartitionSelection partitions =
        options.partition.empty() ? vox::PartitionSelection{} : parsePartition(options.partition);
    const char* expected = partitions.count > 1 ? ".esvopart" : ".esvo";
    if (!options.output.empty() && output.extension() != expected)
        throw vox::UsageError("-o: unknown output type '" + output.extension().string() +
                              "' (expected " + expected + ")");
    if (partitions.count > 1 && options.output.empty())
        throw vox::UsageError("--partition needs -o FILE.esvopart");
    if (partitions.count > 1 && !options.radiance.empty())
        throw vox::UsageError("--partition builds octrees only: no --radiance");
    const std::uint64_t memoryLimit =
        options.memoryLimit.empty() ? 0 : parseByteSize(options.memoryLimit, "--memory-limit");
    if (!options.radiance.empty() && std::filesystem::path(options.radiance).extension() != ".rvol")
        throw vox::UsageError("--radiance: unknown output type '" +
                              std::filesystem::path(options.radiance).extension().string() +
                              "' (expected .rvol)");
    if (!options.exportVdb.empty() && options.radiance.empty())
        throw vox::UsageError("--export-vdb needs --radiance");
    const std::optional<vox::RadianceTiling> tiling =
        options.radiance.empty() ? std::nullopt : radianceTiling(options, memoryLimit);
    parseRadianceTile(options.radianceTile);
    if (tiling && !options.exportVdb.empty())
        throw vox::UsageError("--export-vdb: not for a tiled bake");
    if (tiling && options.bounceGather == "rays")
        throw vox::UsageError("--bounce-gather rays: not for a tiled bake");
    if (const auto strata = static_cast<unsigned>(std::lround(std::sqrt(options.gatherRays)));
        strata * strata != options.gatherRays)
        throw vox::UsageError("--gather-rays: " + std::to_string(options.gatherRays) +
                              " is not a square number (64, 256, 1024, …)");
    if (!options.exportVdb.empty() &&
        std::filesystem::path(options.exportVdb).extension() != ".vdb")
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
    const std::uint64_t importPeakRss = vox::peakRssBytes();  // before anything else grows it
    // Before anything is built or written: a scene over the limit leaves no output behind.
    if (options.maxTriangles > 0 &&
        scene.triangleCount() > static_cast<std::uint64_t>(options.maxTriangles))
        throw vox::InvalidDataError(options.input, std::to_string(scene.triangleCount()) +
                                                       " triangles, more than --max-triangles " +
                                                       std::to_string(options.maxTriangles));
    const vox::Bounds3f bounds = scene.bounds();
    char summary[512];
    std::snprintf(
        summary, sizeof summary,
        "%s: %zu triangles (%zu dynamic) in %zu meshes, %zu materials, %zu textures, %zu lights; "
        "bounds [%g %g %g] - [%g %g %g]",
        options.input.c_str(), scene.triangleCount(), scene.dynamicTriangleCount(),
        scene.meshes.size(), scene.materials.size(), scene.textures.size(), scene.lights.size(),
        bounds.min.x, bounds.min.y, bounds.min.z, bounds.max.x, bounds.max.y, bounds.max.z);
    vox::log::info(summary);

    nlohmann::json report = vox::tools::sceneReport(scene);
    report["import"] =
        vox::tools::importReport(scene, timings.get("import") / 1000.0, importPeakRss);
    if (!options.output.empty()) {
        vox::EsvoBuildOptions build;
        build.voxelize.depth = options.depth;
        build.voxelize.includeDynamic = options.includeDynamic;
        build.voxelize.contours = !options.noContours;
        build.voxelize.contourError = options.fullRefinement ? 0.0 : options.contourError;
        build.voxelize.attributes = options.attributes != "none";
        build.voxelize.colorError = options.colorError;
        build.voxelize.normalErrorDegrees = options.normalError;
        build.voxelize.timings = &timings;
        build.write.sliceBytes = options.sliceBytes;
        build.write.nearPointerLimit = options.nearPointerLimit;
        build.write.attributes = options.attributes == "raw"   ? vox::AttributeEncoding::Raw
                                 : options.attributes == "dxt" ? vox::AttributeEncoding::Compressed
                                 : options.attributes == "dxt-lookup"
                                     ? vox::AttributeEncoding::CompressedLookup
                                     : vox::AttributeEncoding::None;
        build.write.attributeEffort = options.attributeEffort == "fast" ? vox::AttributeEffort::Fast
                                      : options.attributeEffort == "best"
                                          ? vox::AttributeEffort::Best
                                          : vox::AttributeEffort::Default;
        build.write.partitionLevel = options.partitionLevel;
        build.write.sceneBounds = bounds;
        build.write.timings = &timings;
        build.memoryLimit = memoryLimit;
        build.partitions = partitions;
        const auto buildStart = std::chrono::steady_clock::now();
        vox::EsvoBuildResult built;
        built = vox::buildEsvo(output, scene, build);
        const double buildSeconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - buildStart).count();
        std::snprintf(summary, sizeof summary,
                      "%s: depth %u, %llu voxels (%llu leaves), %u slices, %llu far pointers, %llu "
                      "bytes (%.3f bytes/voxel); "
                      "%llu of %llu partitions at level %u in %u rounds",
                      options.output.c_str(), built.leafDepth,
                      static_cast<unsigned long long>(built.voxelCount()),
                      static_cast<unsigned long long>(built.voxelsPerLevel.back()),
                      built.written.slices,
                      static_cast<unsigned long long>(built.written.farPointers),
                      static_cast<unsigned long long>(built.written.fileBytes),
                      double(built.written.fileBytes) / double(built.voxelCount()),
                      static_cast<unsigned long long>(built.partitionsBuilt),
                      static_cast<unsigned long long>(built.partitionsTotal), built.partitionLevel,
                      built.batches);
        vox::log::info(summary);
        report["octree"] = octreeReport(options.output, built, options.attributes, buildSeconds,
                                        built.voxelizeSeconds);
        const bool full = build.voxelize.contourError == 0 || !build.voxelize.contours;
        report["octree"]["refinement"] = {
            {"full", full},
            {"contour_error", full ? 0.0 : build.voxelize.contourError},
            {"color_error", full ? 0.0 : build.voxelize.colorError},
            {"normal_error_degrees", full ? 0.0 : build.voxelize.normalErrorDegrees}};
        if (partitions.count > 1)
            report["octree"]["partition"] = {{"run", partitions.index + 1},
                                             {"runs", partitions.count}};
    }

    if (!options.radiance.empty())
        report["radiance"] = bakeRadiance(options, scene, tiling, timings);

    timings.add("total",
                std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
                    .count());
    if (!options.stats.empty()) vox::tools::writeStats(options.stats, report, "voxelize", timings);
    if (!options.depfile.empty())
        vox::tools::writeDepfile(options.depfile,
                                 !options.output.empty()     ? options.output
                                 : !options.radiance.empty() ? options.radiance
                                                             : options.stats,
                                 scene.sourceFiles);
}

/// voxelize merge PARTS… -o OUT.esvo
void merge(const VoxelizeOptions& options) {
    vox::Timings timings;
    const auto start = std::chrono::steady_clock::now();
    if (options.output.empty()) throw vox::UsageError("merge needs -o OUT.esvo");
    if (std::filesystem::path(options.output).extension() != ".esvo")
        throw vox::UsageError("-o: unknown output type '" +
                              std::filesystem::path(options.output).extension().string() +
                              "' (expected .esvo)");
    std::vector<std::filesystem::path> parts(options.mergeParts.begin(), options.mergeParts.end());
    const std::uint64_t memoryLimit =
        options.memoryLimit.empty() ? 0 : parseByteSize(options.memoryLimit, "--memory-limit");
    vox::EsvoBuildResult merged;
    {
        vox::Timings::Scope timer(&timings, "merge");
        merged = vox::mergeEsvoParts(options.output, parts, memoryLimit, &timings);
    }
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    char summary[512];
    std::snprintf(summary, sizeof summary,
                  "%s: %zu parts, depth %u, %llu voxels, %u slices, %llu bytes in %.2f s",
                  options.output.c_str(), parts.size(), merged.leafDepth,
                  static_cast<unsigned long long>(merged.voxelCount()), merged.written.slices,
                  static_cast<unsigned long long>(merged.written.fileBytes), seconds);
    vox::log::info(summary);
    timings.add("total", seconds * 1000);
    nlohmann::json report;
    report["inputs"] = options.mergeParts;
    report["octree"] = octreeReport(options.output, merged, "", seconds, 0);
    if (!options.stats.empty())
        vox::tools::writeStats(options.stats, report, "voxelize merge", timings);
    if (!options.depfile.empty()) vox::tools::writeDepfile(options.depfile, options.output, parts);
}

}  // namespace

int main(int argc, char** argv) {
    VoxelizeOptions options;
    CLI::App app{"Turns a triangle scene (glTF/GLB, OBJ, PLY, STL, OFF, Draco) into voxel assets.",
                 "voxelize"};
    app.set_version_flag("--version", std::string("voxelize (libvox) ") + LIBVOX_VERSION_STRING);
    CLI::App* mergeApp = app.add_subcommand(
        "merge", "Join the part files of every run of a --partition K/N build into one .esvo file");
    mergeApp
        ->add_option("parts", options.mergeParts, "Part files (.esvopart), one per run, any order")
        ->required();
    mergeApp->add_option("-o,--output", options.output, "The .esvo file to write")->required();
    mergeApp->add_option("--memory-limit", options.memoryLimit,
                         "Bytes the merge may use (as for the build)");
    mergeApp->add_option("--stats", options.stats, "Write a JSON report");
    mergeApp->add_option("--depfile", options.depfile,
                         "Write a Make/Ninja depfile listing the parts");
    vox::tools::addCommonOptions(*mergeApp, options.common);
    app.add_option("input", options.input, "Scene file: .gltf .glb .obj .ply .stl .off .drc");
    app.add_option("-o,--output", options.output, "Write the sparse voxel octree here (.esvo)");
    app.add_option("--depth", options.depth,
                   "Finest level allowed: at most 2^N voxels along the scene's longest side "
                   "(voxels stop coarser where "
                   "--contour-error, --normal-error and --color-error allow; --full-refinement: "
                   "every voxel to this level)")
        ->check(CLI::Range(1, 20))
        ->capture_default_str();
    app.add_option("--slice-bytes", options.sliceBytes, "Largest .esvo slice in bytes")
        ->check(CLI::Range(16384, 1 << 26))
        ->capture_default_str();
    app.add_flag("--include-dynamic", options.includeDynamic,
                 "Voxelize dynamic meshes too (left out by default)");
    app.add_flag("--no-contours", options.noContours,
                 "Cubes only: no contours (slabs), every voxel refined to --depth");
    app.add_flag(
        "--full-refinement", options.fullRefinement,
        "Refine every voxel to --depth (as --contour-error 0): no error-bounded early stop");
    app.add_option("--contour-error", options.contourError,
                   "Stop refining where a voxel's cube and contour lie within E leaf voxels of the "
                   "surface (E/2 where its colour varies by more than half of --color-error), and "
                   "its colour and normal within --color-error and --normal-error (0: refine to "
                   "--depth)")
        ->check(CLI::Range(0.0, 1e6))
        ->capture_default_str();
    app.add_option("--attributes", options.attributes,
                   "Colour and normal per voxel: dxt (compressed, 6 words per pair of sibling "
                   "descriptors), dxt-lookup "
                   "(compressed behind a lookup entry per descriptor, values equal to the parent's "
                   "omitted), raw (64 bits "
                   "per stored voxel) or none")
        ->check(CLI::IsMember({"dxt", "dxt-lookup", "raw", "none"}))
        ->capture_default_str();
    app.add_option("--attribute-effort", options.attributeEffort,
                   "How hard the dxt and dxt-lookup encoders search: fast, default (a wider "
                   "search: about 1.6x slower for "
                   "8-11 % less normal error against raw, about 1 % against the mesh) or best (the "
                   "full search, about 1.8x "
                   "slower than default for 0.02 dB and 1-2 % normal error)")
        ->check(CLI::IsMember({"fast", "default", "best"}))
        ->capture_default_str();
    app.add_option("--color-error", options.colorError,
                   "With --contour-error: keep refining where the colour's RMS deviation from the "
                   "voxel's over its surface "
                   "is above this (8-bit sRGB steps; 0: off)")
        ->check(CLI::Range(0.0, 255.0))
        ->capture_default_str();
    app.add_option("--normal-error", options.normalError,
                   "With --contour-error: keep refining where the shading normal's RMS deviation "
                   "from the voxel's over its "
                   "surface is above this many degrees (0: off)")
        ->check(CLI::Range(0.0, 180.0))
        ->capture_default_str();
    app.add_option("--radiance", options.radiance,
                   "Bake a mipmapped anisotropic radiance volume here (.rvol)");
    app.add_option("--radiance-depth", options.radianceDepth,
                   "Radiance volume: 2^N cells along the scene's longest side")
        ->check(CLI::Range(1, 13))
        ->capture_default_str();
    app.add_option("--radiance-tile-depth", options.radianceTileDepth,
                   "Bake the radiance volume in tiles of 2^T cells per axis, each in memory "
                   "bounded by its tile (default: one volume up to depth 10; from 11, tiles as "
                   "large as --memory-limit allows)")
        ->check(CLI::Range(2, 9));
    app.add_option("--radiance-halo", options.radianceHalo,
                   "Tiled bake: cells around each tile lit and gathered with it (default: a "
                   "quarter tile)")
        ->check(CLI::Range(1, 256));
    app.add_option("--radiance-tile", options.radianceTile,
                   "Tiled bake: bake only run K of N of the tiles (K/N), or write the far field "
                   "and the index once every run has ('index')");
    app.add_option(
           "--attenuation", options.attenuation,
           "Direct light's normal attenuation per voxel: adaptive (the cosine of the mean normal "
           "where the voxel's surface is flat, weighted where it folds), weighted (per axis, by "
           "the voxel's own normals), paper (eq. 2 of Gui et al. on the mean normal) or average "
           "(cosine of the mean normal)")
        ->check(CLI::IsMember({"adaptive", "weighted", "paper", "average"}))
        ->capture_default_str();
    app.add_option("--shadow-aperture", options.shadowAperture,
                   "Shadows by a cone of this aperture in degrees through the voxels' occlusion "
                   "(0: shadow rays)")
        ->check(CLI::Range(0.0, 89.0))
        ->capture_default_str();
    app.add_option("--bounces", options.bounces, "Indirect bounces")
        ->check(CLI::Range(0, 16))
        ->capture_default_str();
    app.add_option("--bounce-gather", options.bounceGather,
                   "How each voxel gathers bounce light: cones (through the volume, as the "
                   "runtime's final gather), rays (against the triangles, each reading the "
                   "voxel it hits: slower, closer to the truth where thin walls or the volume's "
                   "edge mislead cones; not for tiled bakes) or auto (rays where the volume is "
                   "baked whole and its rays' hits fit in 512 MiB, about 800 000 voxels; else "
                   "cones)")
        ->check(CLI::IsMember({"auto", "cones", "rays"}))
        ->capture_default_str();
    app.add_option("--gather-rays", options.gatherRays,
                   "Where rays gather bounces: rays per voxel and bounce, a square number")
        ->check(CLI::Range(1, 4096))
        ->capture_default_str();
    app.add_option("--ao-lambda", options.aoLambda,
                   "Ambient occlusion falloff λ (eq. 4), per scene-cube edge of cone radius")
        ->check(CLI::Range(0.0, 1e6))
        ->capture_default_str();
    app.add_option("--brick-texels", options.brickTexels,
                   "Radiance volume: texels per brick edge (bricks share their faces)")
        ->check(CLI::Range(2, 32))
        ->capture_default_str();
    app.add_flag("--no-static-attributes", options.noStaticAttributes,
                 "Radiance volume: leave out the static voxels' albedo/normal/emission layer "
                 "(dynamic voxels' is always written)");
    app.add_option("--export-vdb", options.exportVdb,
                   "With --radiance: also write albedo, radiance per direction and occlusion as "
                   "OpenVDB grids");
    app.add_option("--lightcuts", options.lightcuts,
                   "Radiance volume's direct light through Lightcuts: on, off (every light at "
                   "every voxel) or auto (on from " +
                       std::to_string(vox::kLightcutsAutoLights) + " static lights)")
        ->check(CLI::IsMember({"auto", "on", "off"}))
        ->capture_default_str();
    app.add_option("--lightcut-error", options.lightcutError,
                   "Lightcuts: relative error of each voxel's direct light")
        ->check(CLI::Range(0.0001, 1.0))
        ->capture_default_str();
    app.add_option("--lightcut-criterion", options.lightcutCriterion,
                   "Lightcuts: what must stay within the error: rss (root of the sum of the "
                   "clusters' squared bounds), sum, or "
                   "per-node (each cluster's bound, as published)")
        ->check(CLI::IsMember({"rss", "sum", "per-node"}))
        ->capture_default_str();
    app.add_option("--lightcut-max-cut", options.lightcutMaxCut,
                   "Lightcuts: most clusters in one cut")
        ->check(CLI::Range(1, 1000000))
        ->capture_default_str();
    app.add_flag("--lightcuts-compare", options.lightcutsCompare,
                 "Also light every voxel with classic Lightcuts (one tree, no clusters, no reuse) "
                 "and brute force, and report "
                 "both in --stats (direct_light.compare)");
    app.add_option("--memory-limit", options.memoryLimit,
                   "Bytes the octree build may use, e.g. 8G (default: half the memory): it builds "
                   "as many partitions at a "
                   "time as fit and keeps finished slices beyond a quarter of it in a scratch file "
                   "beside the output");
    app.add_option(
        "--partition", options.partition,
        "Build only run K of N of the octree's partitions into a part file (-o FILE.esvopart); "
        "'voxelize merge' joins the N part files into the file the whole build makes");
    app.add_option("--partition-level", options.partitionLevel,
                   "Level of the partitions: no slice spans two of its voxels (default: depth − 9, "
                   "none below depth 10; "
                   "at most 4, or depth − 9 from depth 14)")
        ->check(CLI::Range(0, 10));
    app.add_option("--debug-near-pointer-limit", options.nearPointerLimit,
                   "Largest near child pointer (testing far pointers)")
        ->check(CLI::Range(32, 0x7FFF))
        ->group("");
    app.add_option("--stats", options.stats,
                   "Write a JSON report: inputs, counts, timings, peak memory");
    app.add_option("--depfile", options.depfile,
                   "Write a Make/Ninja depfile listing every file read");
    app.add_option(
           "--dynamic", options.dynamicNames,
           "Mark a node (glTF), object or group (OBJ) and everything below it dynamic; repeatable")
        ->allow_extra_args(false);
    app.add_flag("--strict", options.strict,
                 "Treat repaired input (degenerate triangles, bad normals, ...) as an error");
    app.add_flag("--no-textures", options.noTextures, "Do not read or decode textures");
    app.add_option(
           "--max-triangles", options.maxTriangles,
           "Reject a scene with more triangles than this after import (invalid input, exit 3)")
        ->check(CLI::Range(std::int64_t{1}, std::numeric_limits<std::int64_t>::max()));
    vox::tools::addCommonOptions(app, options.common);
    return vox::tools::runTool("voxelize", app, argc, argv, options.common, [&] {
        if (mergeApp->parsed()) return merge(options);
        if (options.input.empty()) throw vox::UsageError("input is required (see --help)");
        voxelize(options);
    });
}
