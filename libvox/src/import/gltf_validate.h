// Structural validation of glTF 2.0 JSON before tinygltf loads it: property types, index
// ranges and buffer-view extents, so that the loader and the importer can index safely and a
// type error is reported with its JSON path instead of being silently ignored.
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

namespace vox::detail {

/// Validates the glTF JSON text. @throws InvalidDataError naming @p file and the first
/// offending JSON path, e.g. "materials[0].normalTexture.scale: expected a number, got a string".
/// Returns the JSON tinygltf should load: empty if @p jsonText is fine as it is, or a rewrite
/// in which Draco-compressed primitives have no "indices" (tinygltf, built without Draco,
/// rejects index accessors without a buffer view; libvox takes the indices from Draco).
[[nodiscard]] std::string validateGltfJson(std::string_view jsonText,
                                           const std::filesystem::path& file);

/// A GLB container like @p glb with its JSON chunk replaced by @p json.
[[nodiscard]] std::vector<std::uint8_t> replaceGlbJson(std::span<const std::uint8_t> glb,
                                                       std::string_view json);

/// The JSON chunk of a GLB container. @throws InvalidDataError if the container is malformed: a
/// header other than glTF 2's, a length beyond @p glb, or a JSON or second chunk that does not fit
/// inside that length.
[[nodiscard]] std::string_view glbJsonChunk(std::span<const std::uint8_t> glb,
                                            const std::filesystem::path& file);

}  // namespace vox::detail
