/// @file vdb_export.h
/// @brief Writes a baked radiance volume (.rvol's in-memory model) as OpenVDB grids, for DCC tools
/// (Houdini, Blender) to look at or re-use the bake (`voxelize --export-vdb FILE.vdb`).
///
/// Every grid has a linear transform whose voxel size is its level's cell size and whose voxel
/// (i, j, k) (OpenVDB's index-space integer point, the voxel's centre) lies at the centre of cell
/// (i, j, k): origin + (i + ½, j + ½, k + ½) · cellSize(level). Voxels are active only where the
/// value is non-zero (the background, 0, is the value everywhere else). The grids:
///
/// | grid | type | level | what |
/// |---|---|---|---|
/// | `albedo` | vec3s | 0 | linear base colour of each static voxel |
/// | `emission` | vec3s | 0 | emitted radiance of each static voxel; only written if any is
/// non-zero | | `normal` | vec3s | 0 | unit normal of each static voxel (covariant, normalised) |
/// | `occlusion` | float | 0 | ambient occlusion of each static voxel, 0 = open |
/// | `radiance` | vec3s | 0 | radiance, un-premultiplied (rgb / a where a > 0; cells with a = 0 are
/// inactive) | | `density` | float | 0 | opacity (fog volume) | | `radiance_px` … `radiance_nz` |
/// vec3s | 1 | each direction's radiance, un-premultiplied | | `opacity_px` … `opacity_nz` | float
/// | 1 | each direction's opacity (fog volume) |
///
/// Directions are named as rvol::Direction names them (px = PosX: the cone travelling along +x).
/// With VdbExportOptions::allLevels the directional grids of every coarser level n ≥ 2 follow,
/// suffixed `_L<n>` (`radiance_px_L2`). Colour grids are vec-invariant. File metadata: `source`
/// ("libvox .rvol bake"), `depth`, `origin`, `size`. The output is deterministic: the same volume
/// gives the same bytes (the header UUID, random in OpenVDB, is a hash of the volume and options).
#pragma once

#include <vox/formats/rvol.h>

#include <filesystem>

namespace vox {

struct VdbExportOptions {
    /// Also write the directional grids of levels 2 … depth (suffix `_L<n>`).
    bool allLevels = false;
};

/// Writes @p volume to @p file as OpenVDB grids (see above), atomically (AtomicFile).
/// @throws IoError naming @p file if it cannot be written; InvalidDataError if @p volume's levels
/// do not match its depth.
void exportVdb(const std::filesystem::path& file, const rvol::Volume& volume,
               const VdbExportOptions& options = {});

}  // namespace vox
