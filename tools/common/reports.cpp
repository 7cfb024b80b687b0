#include "reports.h"

#include <vox/formats/atomic_file.h>
#include <vox/util/parallel.h>
#include <vox/version.h>

#include <system_error>

namespace vox::tools {
namespace {

nlohmann::json vec3(Vec3f v) { return nlohmann::json::array({v.x, v.y, v.z}); }

std::string escapeDepfilePath(const std::string& path) {
    std::string out;
    for (char c : path) {
        if (c == ' ' || c == '#') out.push_back('\\');
        if (c == '$') out.push_back('$');
        out.push_back(c);
    }
    return out;
}

}  // namespace

const char* lightTypeName(Light::Type type) {
    switch (type) {
        case Light::Type::Directional:
            return "directional";
        case Light::Type::Point:
            return "point";
        case Light::Type::Spot:
            return "spot";
    }
    return "unknown";
}

nlohmann::json importReport(const Scene& scene, double seconds, std::uint64_t peakRss) {
    const double triangles = static_cast<double>(scene.triangleCount());
    return {{"triangles", scene.triangleCount()},
            {"seconds", seconds},
            {"triangles_per_second", seconds > 0 ? triangles / seconds : 0.0},
            {"peak_rss_bytes", peakRss},
            {"peak_rss_bytes_per_triangle",
             triangles > 0 ? static_cast<double>(peakRss) / triangles : 0.0}};
}

nlohmann::json sceneReport(const Scene& scene) {
    nlohmann::json report;
    nlohmann::json inputs = nlohmann::json::array();
    for (const auto& file : scene.sourceFiles) {
        std::error_code ec;
        const auto size = std::filesystem::file_size(file, ec);
        inputs.push_back({{"path", file.string()}, {"bytes", ec ? 0 : size}});
    }
    report["inputs"] = inputs;
    report["triangles"] = scene.triangleCount();
    report["dynamic_triangles"] = scene.dynamicTriangleCount();
    report["degenerate_triangles_dropped"] = scene.degenerateTrianglesDropped;
    report["meshes"] = scene.meshes.size();
    report["materials"] = scene.materials.size();
    std::size_t textureBytes = 0;
    for (const Texture& t : scene.textures) textureBytes += t.memoryBytes();
    report["textures"] = scene.textures.size();
    report["texture_bytes"] = textureBytes;
    nlohmann::json lights = nlohmann::json::array();
    for (const Light& light : scene.lights)
        lights.push_back({{"name", light.name},
                          {"type", lightTypeName(light.type)},
                          {"color", vec3(light.color)},
                          {"intensity", light.intensity},
                          {"range", light.range},
                          {"position", vec3(light.position)},
                          {"direction", vec3(light.direction)},
                          {"dynamic", light.dynamic}});
    report["lights"] = lights;
    const Bounds3f bounds = scene.bounds();
    report["bounds"] = {{"min", vec3(bounds.min)}, {"max", vec3(bounds.max)}};
    report["warnings"] = scene.warnings;
    return report;
}

nlohmann::json esvoReport(const esvo::EsvoReader& reader, const esvo::FileBreakdown& b) {
    const esvo::Header& h = reader.header();
    const esvo::Directory& d = reader.directory();
    std::uint64_t voxels = 0, farPointers = 0, descriptors = 0;
    for (std::uint64_t n : d.voxelsPerLevel) voxels += n;
    for (const esvo::SliceEntry& s : d.slices) {
        farPointers += s.farPointerCount;
        descriptors += s.descriptorCount;
    }
    const auto perVoxel = [&](std::uint64_t bytes) {
        return voxels ? double(bytes) / double(voxels) : 0.0;
    };
    nlohmann::json report;
    report["file"] = reader.path().string();
    report["version"] = std::to_string(h.versionMajor) + "." + std::to_string(h.versionMinor);
    report["depth"] = h.leafDepth;
    report["voxels"] = voxels;
    report["voxels_per_level"] = d.voxelsPerLevel;
    report["descriptors"] = descriptors;
    report["slices"] = d.slices.size();
    std::uint32_t maxSlice = 0;
    for (const esvo::SliceEntry& s : d.slices) maxSlice = std::max(maxSlice, s.byteSize);
    report["largest_slice_bytes"] = maxSlice;
    report["slice_bytes_limit"] = h.sliceBytesLimit;
    report["far_pointers"] = farPointers;
    report["file_bytes"] = h.fileBytes;
    report["root_cube"] = {
        {"origin",
         {-h.worldToRoot[3] / h.worldToRoot[0], -h.worldToRoot[7] / h.worldToRoot[5],
          -h.worldToRoot[11] / h.worldToRoot[10]}},
        {"size", 1.0 / h.worldToRoot[0]}};
    const auto kinds = h.attachmentKinds;
    const auto has = [&](esvo::AttachmentKind k) {
        return (kinds >> static_cast<unsigned>(k)) & 1u;
    };
    report["contours"] = has(esvo::AttachmentKind::Contour) != 0;
    // Leaves above the leaf depth are where refinement stopped early; contours per level, where
    // a voxel kept one of its own (the others inherit their ancestors').
    std::uint64_t leaves = 0, contourVoxels = 0;
    for (std::uint64_t n : b.leavesPerLevel) leaves += n;
    for (std::uint64_t n : b.contoursPerLevel) contourVoxels += n;
    report["leaves"] = leaves;
    report["leaves_per_level"] = b.leavesPerLevel;
    report["contour_voxels"] = contourVoxels;
    report["contour_voxels_per_level"] = b.contoursPerLevel;
    report["contour_voxel_share"] = voxels ? double(contourVoxels) / double(voxels) : 0.0;
    report["attributes"] = has(esvo::AttachmentKind::Dxt)         ? "dxt"
                           : has(esvo::AttachmentKind::DxtLookup) ? "dxt-lookup"
                           : has(esvo::AttachmentKind::Palette)   ? "raw"
                                                                  : "none";
    const std::array<std::uint64_t, kEsvoByteParts.size()> parts{
        b.descriptorBytes,     b.farPointerBytes,
        b.pageHeaderBytes,     b.paddingBytes + b.slicePaddingBytes,
        b.infoBytes,           b.headerAndDirectoryBytes,
        b.contourBytes,        b.attributeLookupBytes,
        b.attributeValueBytes, b.attributeBlockBytes};
    nlohmann::json bytes = nlohmann::json::object(), perVoxelBytes = nlohmann::json::object();
    perVoxelBytes["total"] = perVoxel(h.fileBytes);
    for (std::size_t i = 0; i < parts.size(); ++i) {
        bytes[kEsvoByteParts[i]] = parts[i];
        perVoxelBytes[kEsvoByteParts[i]] = perVoxel(parts[i]);
    }
    report["bytes"] = bytes;
    report["bytes_per_voxel"] = perVoxelBytes;
    return report;
}

void writeStats(const std::filesystem::path& file, nlohmann::json report, const std::string& tool,
                const Timings& timings) {
    nlohmann::json ms = nlohmann::json::object();
    for (const auto& [stage, milliseconds] : timings.entries()) ms[stage] = milliseconds;
    report["timings_ms"] = ms;
    report["peak_rss_bytes"] = peakRssBytes();
    report["threads"] = ThreadLimit::active();
    report["tool"] = tool;
    report["version"] = LIBVOX_VERSION_STRING;
    writeFileAtomically(file, report.dump(2) + "\n");
}

std::string depfileText(const std::filesystem::path& target,
                        const std::vector<std::filesystem::path>& dependencies) {
    std::string text = escapeDepfilePath(target.string()) + ":";
    for (const auto& dep : dependencies) text += " \\\n  " + escapeDepfilePath(dep.string());
    return text + "\n";
}

void writeDepfile(const std::filesystem::path& file, const std::filesystem::path& target,
                  const std::vector<std::filesystem::path>& dependencies) {
    writeFileAtomically(file, depfileText(target, dependencies));
}

namespace {

nlohmann::json manyLightStats(const ManyLightStats& s) {
    return {{"method", s.method},
            {"points", s.points},
            {"lights", s.lights},
            {"trees", s.trees},
            {"clusters", s.clusters},
            {"runs", s.runs},
            {"mean_cut_size", s.meanCutSize()},
            {"mean_search_steps", s.meanSearchSteps()},
            {"light_evaluations", s.lightEvaluations},
            {"visibility_evaluations", s.visibilityEvaluations},
            {"visibility_shared", s.visibilityShared},
            {"shared_visibility_tests", s.sharedVisibilityTests},
            {"mean_trees_searched", s.points ? double(s.treesSearched) / double(s.points) : 0.0},
            {"truncated_points", s.truncated},
            {"seconds", s.seconds},
            {"tree_seconds", s.treeSeconds},
            {"cluster_seconds", s.clusterSeconds}};
}

nlohmann::json errorStats(const LightcutErrorStats& e) {
    return {{"threshold", e.threshold},
            {"points", e.points},
            {"within", e.within},
            {"fraction_within", e.fractionWithin()},
            {"max_relative", e.maxRelative},
            {"mean_relative", e.meanRelative}};
}

}  // namespace

nlohmann::json directLightReport(const ManyLightReport& report, const LightcutOptions& options) {
    nlohmann::json out = manyLightStats(report.used);
    out["relative_error"] = options.relativeError;
    out["criterion"] = lightcutCriterionName(options.criterion);
    out["max_cut_size"] = options.maxCutSize;
    if (!report.compared) return out;
    nlohmann::json compare;
    compare["lightcuts"] = manyLightStats(report.lightcuts);
    compare["lightcuts"]["error"] = errorStats(report.lightcutsError);
    compare["classic"] = manyLightStats(report.classic);
    compare["classic"]["error"] = errorStats(report.classicError);
    compare["brute_force"] = manyLightStats(report.bruteForce);
    const auto change = [](double ours, double theirs) {
        return theirs > 0 ? ours / theirs - 1 : 0.0;
    };
    compare["search_steps_vs_classic"] =
        change(report.lightcuts.meanSearchSteps(), report.classic.meanSearchSteps());
    compare["cut_size_vs_classic"] =
        change(report.lightcuts.meanCutSize(), report.classic.meanCutSize());
    compare["time_vs_classic"] = change(report.lightcuts.seconds, report.classic.seconds);
    compare["speedup_vs_brute_force"] =
        report.lightcuts.seconds > 0 ? report.bruteForce.seconds / report.lightcuts.seconds : 0.0;
    compare["classic_speedup_vs_brute_force"] =
        report.classic.seconds > 0 ? report.bruteForce.seconds / report.classic.seconds : 0.0;
    out["compare"] = std::move(compare);
    return out;
}

}  // namespace vox::tools
