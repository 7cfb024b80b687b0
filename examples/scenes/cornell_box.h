// The Cornell-box-like example scene the README's first command runs on.
#pragma once

#include "gltf_builder.h"

#include <filesystem>

namespace vox::scenes {

/// Facts about the generated scene that tests assert against.
struct CornellBoxFacts {
    static constexpr int kLights = 3;
    static constexpr int kMaterials = 6;  ///< white, red, green, light panel, checker, sphere
    static constexpr std::size_t kSphereTriangles = 2 * 24 * (16 - 1);    ///< 24 segments, 16 rings
    static constexpr std::size_t kTriangles = 8 * 12 + kSphereTriangles;  ///< 8 boxes + the sphere
    static constexpr const char* kDynamicNode = "DynamicSphere";
    static constexpr const char* kTexturedNode = "CheckerBlock";
};

/// Writes "cornell_box.gltf" (+ .bin and checker.png, or a single .glb) into @p directory and
/// returns the scene file's path. Red wall at -X, green at +X, open towards +Z, 2 units high.
std::filesystem::path writeCornellBox(const std::filesystem::path& directory,
                                      BufferStorage storage = BufferStorage::External);

}  // namespace vox::scenes
