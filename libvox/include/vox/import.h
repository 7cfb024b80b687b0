/// @file import.h
/// @brief Reads a scene file into a Scene: glTF/GLB (with Draco, KHR_lights_punctual,
/// KHR_materials_emissive_strength, KHR_texture_transform), OBJ + MTL, PLY, STL, OFF and
/// Draco .drc. The format follows the file extension and must match the file's contents.
#pragma once

#include <vox/scene.h>

#include <filesystem>
#include <string>
#include <vector>

namespace vox {

class Timings;

struct ImportOptions {
    /// Names of nodes (glTF), objects or groups (OBJ), or the file stem (single-mesh formats)
    /// whose geometry and lights are dynamic, with everything below them.
    std::vector<std::string> dynamicNames;
    /// Treat every repair (dropped degenerate triangles, invalid normals, unknown materials,
    /// unused --dynamic names, ...) as invalid data instead of a warning.
    bool strict = false;
    /// Decode textures. Off, Scene::textures stays empty and no material binds a texture
    /// (referenced image files are then not read either).
    bool loadTextures = true;
    /// Receives the import's stage timings ("import.parse", "import.textures", ...), if set.
    Timings* timings = nullptr;
};

/// Imports @p file. @throws IoError when the file, or a file it references, cannot be read;
/// InvalidDataError when the data is malformed or holds no triangles.
[[nodiscard]] Scene importScene(const std::filesystem::path& file,
                                const ImportOptions& options = {});

/// File extensions importScene accepts, lower case with the dot (".gltf", ".glb", ...).
[[nodiscard]] const std::vector<std::string>& supportedSceneExtensions();

}  // namespace vox
