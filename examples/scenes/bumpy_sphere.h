// A dense organic test mesh: a sphere displaced by a few sine waves, for octree builds and
// benchmarks at a million triangles and more.
#pragma once

#include "gltf_builder.h"

#include <filesystem>

namespace vox::scenes {

/// Triangles writeBumpySphere produces for @p rings and @p segments.
[[nodiscard]] constexpr std::size_t bumpySphereTriangles(int rings, int segments) {
    return 2 * static_cast<std::size_t>(rings - 1) * static_cast<std::size_t>(segments);
}

/// Writes "bumpy_sphere.glb" (radius about 1 around the origin) into @p directory; returns its
/// path.
/// @p bumps false: a plain unit sphere ("sphere.glb"), the smooth surface normal measurements use.
std::filesystem::path writeBumpySphere(const std::filesystem::path& directory, int rings,
                                       int segments, bool bumps = true);

}  // namespace vox::scenes
