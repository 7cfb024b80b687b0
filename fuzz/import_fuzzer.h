// The import harnesses' common body: one input through vox::importScene, and what it accepted
// through a small voxelization, as voxelize -o does with it.
#pragma once

#include "fuzz_support.h"

#include <vox/base/error.h>
#include <vox/import.h>
#include <vox/octree.h>
#include <vox/util/parallel.h>

namespace vox::fuzz {

/// Imports @p file as voxelize does, without textures: image decoding is OpenImageIO's (not
/// libvox's, and not instrumented), so these harnesses leave it out. A vox::Error is a correct
/// rejection; anything else escapes to libFuzzer as a bug. An accepted scene must hold triangles
/// with in-range indices and finite positions (what importScene promises), and must voxelize
/// (depth 4, contours and attributes: the hostile numbers an importer lets through reach the
/// voxelizer next).
inline void importAndVoxelize(const std::filesystem::path& file) {
    static ThreadLimit oneThread(1);  // one fuzzer per core; and reproducible
    ImportOptions options;
    options.loadTextures = false;
    try {
        const Scene scene = importScene(file, options);
        if (scene.triangleCount() == 0) __builtin_trap();
        for (const Mesh& mesh : scene.meshes)
            for (std::uint32_t index : mesh.indices)
                if (index >= mesh.positions.size() || !isFinite(mesh.positions[index]))
                    __builtin_trap();
        SurfaceVoxelizeOptions voxelize;
        voxelize.depth = 4;
        voxelize.includeDynamic = true;
        voxelize.contours = true;
        voxelize.attributes = true;
        // voxelize's default, error-bounded refinement (early stops, carried slabs, attribute
        // bounds), then full refinement.
        voxelize.contourError = kDefaultContourError;
        voxelize.colorError = kDefaultColorError;
        voxelize.normalErrorDegrees = kDefaultNormalErrorDegrees;
        (void)voxelizeSurface(scene, voxelize);
        voxelize.contourError = 0;
        (void)voxelizeSurface(scene, voxelize);
    } catch (const vox::Error&) {}
}

}  // namespace vox::fuzz
