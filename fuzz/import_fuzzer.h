// The import harnesses' common body: one input through vox::importScene, as voxelize imports it.
#pragma once

#include "fuzz_support.h"

#include <vox/formats/error.h>
#include <vox/import.h>

namespace vox::fuzz {

/// Imports @p file as voxelize does, without textures: image decoding is OpenImageIO's (not
/// libvox's, and not instrumented), so these harnesses leave it out. A vox::Error is a correct
/// rejection; anything else escapes to libFuzzer as a bug. An accepted scene must hold triangles
/// with finite positions and in-range indices (what importScene promises).
inline void importLikeVoxelize(const std::filesystem::path& file) {
    ImportOptions options;
    options.loadTextures = false;
    try {
        const Scene scene = importScene(file, options);
        if (scene.triangleCount() == 0) __builtin_trap();
        for (const Mesh& mesh : scene.meshes)
            for (std::uint32_t index : mesh.indices)
                if (index >= mesh.positions.size() || !isFinite(mesh.positions[index])) __builtin_trap();
    } catch (const vox::Error&) {
    }
}

}  // namespace vox::fuzz
