// Contours (Laine & Karras 5.2): a pair of parallel planes per voxel bounding the surface inside
// it, fitted to the triangle fragments the voxel's cube cuts out, encoded conservatively in the
// 32-bit esvo::Contour, and the geometric error of the shape cube ∩ slab that drives refinement.
#pragma once

#include "triangle_box.h"

#include <array>
#include <cstdint>
#include <span>
#include <vector>

namespace vox::detail {

/// Reusable buffers for contour fitting (one per thread).
struct ContourScratch {
    CubeFragments fragments;  // the voxel's fragments, voxel-local
};

/// A fitted contour: the encoded value (0: no useful contour) and the slab's thickness.
struct ContourFit {
    std::uint32_t encoded = 0;
    double thickness = 0;  ///< world-free: in units of the voxel's edge
};

/// Fits a contour to the triangles @p list of @p triangles inside the cube with centre @p c and
/// half-extent @p h (leaf units). Candidates: the fragments' area-weighted normal and the normals
/// of the largest fragments, each quantised first; the slab must contain every fragment after
/// quantisation. Returns encoded 0 when no slab is thinner than 90 % of the cube along it.
[[nodiscard]] ContourFit fitContour(std::span<const std::uint32_t> list, const std::vector<BoxTestTriangle>& triangles, Vec3d c,
                                    double h, ContourScratch& scratch);
/// Per triangle, what the fit would otherwise recompute at every voxel, computed as it computes
/// them: length[t] = length(normal), unit[t] = normal · (1 / length[t]) where length[t] > 0.
struct TriangleNormals {
    const double* length = nullptr;
    const Vec3d* unit = nullptr;
};

/// fitContour on fragments already clipped (CubeFragments::clip at scale fitContourScale(h)) from
/// the triangles @p list of @p triangles: the same result. @p normals: empty, or theirs.
[[nodiscard]] ContourFit fitContour(const CubeFragments& fragments, std::span<const std::uint32_t> list,
                                    const std::vector<BoxTestTriangle>& triangles, TriangleNormals normals = {});
/// The scale from leaf units to the local frame of a cube of half-extent @p h that fitContour clips in.
[[nodiscard]] inline double fitContourScale(double h) { return 0.5 / h; }

/// The slab of contour @p encoded of a voxel, seen from its child in @p slot (pos' = 2·pos +
/// Σ n·(½ − bit), thickness doubled): 0 when none or when it no longer fits the encoding.
/// @p thickness receives its thickness in the child's edge units.
[[nodiscard]] std::uint32_t carryContour(std::uint32_t encoded, std::uint32_t slot, double& thickness);

/// Largest distance (leaf units) from a vertex of cube ∩ slab (@p encoded may be 0: the cube)
/// to the nearest of the triangles in @p list: the shape's geometric error.
[[nodiscard]] double shapeError(std::uint32_t encoded, std::span<const std::uint32_t> list, const std::vector<BoxTestTriangle>& triangles,
                                Vec3d c, double h);

}  // namespace vox::detail
