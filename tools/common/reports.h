// Machine-readable outputs the tools write: --stats JSON and --depfile dependency lists.
#pragma once

#include <vox/formats/esvo_reader.h>
#include <vox/many_lights.h>
#include <vox/scene.h>
#include <vox/util/timings.h>

#include <nlohmann/json.hpp>

#include <array>
#include <filesystem>
#include <string>
#include <vector>

namespace vox::tools {

/// "directional", "point" or "spot".
[[nodiscard]] const char* lightTypeName(Light::Type type);

/// The scene part of a stats report: inputs, triangles, materials, textures, lights, bounds, ...
/// (keys documented in docs/cli.md).
[[nodiscard]] nlohmann::json sceneReport(const Scene& scene);
/// The `import` keys of --stats: triangles, seconds, triangles_per_second, peak_rss_bytes and
/// peak_rss_bytes_per_triangle, with @p peakRssBytes the process's peak taken right after the
/// import.
[[nodiscard]] nlohmann::json importReport(const Scene& scene, double seconds,
                                          std::uint64_t peakRssBytes);

/// The keys of esvoReport's "bytes" and "bytes_per_voxel" parts, in the order tools print them.
inline constexpr std::array<const char*, 10> kEsvoByteParts{
    "hierarchy",        "far_pointers",         "page_headers", "padding",
    "info_sections",    "header_and_directory", "contours",     "attribute_lookup",
    "attribute_values", "attribute_blocks"};

/// The .esvo summary voxinspect info prints: depth, voxels, voxels_per_level, slices,
/// far_pointers, file_bytes, contours, attributes, bytes and bytes_per_voxel (total and each of
/// kEsvoByteParts) (docs/cli.md).
[[nodiscard]] nlohmann::json esvoReport(const esvo::EsvoReader& reader,
                                        const esvo::FileBreakdown& breakdown);

/// The direct light's part of a stats report (docs/cli.md, "direct_light"): the method used with
/// its lights, trees, clusters, mean cut size and search steps, time; with a comparison the same
/// for "lightcuts", "classic" and "brute_force", both Lightcuts' errors against brute force and
/// the ratios of the paper's table 1.
[[nodiscard]] nlohmann::json directLightReport(const ManyLightReport& report,
                                               const LightcutOptions& options);

/// Adds timings_ms, peak_rss_bytes, threads, tool and version to @p report and writes it
/// atomically to @p file.
void writeStats(const std::filesystem::path& file, nlohmann::json report, const std::string& tool,
                const Timings& timings);

/// Writes a Make/Ninja depfile "TARGET: DEP DEP ..." atomically, escaping spaces, '#' and '$'.
void writeDepfile(const std::filesystem::path& file, const std::filesystem::path& target,
                  const std::vector<std::filesystem::path>& dependencies);

/// The text of a depfile (what writeDepfile writes).
[[nodiscard]] std::string depfileText(const std::filesystem::path& target,
                                      const std::vector<std::filesystem::path>& dependencies);

}  // namespace vox::tools
