// Contours (Laine & Karras 5.2): a pair of parallel planes per voxel bounding the surface inside
// it, fitted to the triangle fragments the voxel's cube cuts out, encoded conservatively in the
// 32-bit esvo::Contour, and the geometric error of the shape cube ∩ slab that drives refinement.
#pragma once

#include "triangle_box.h"

#include <vox/formats/esvo.h>

#include <array>
#include <cmath>
#include <cstdlib>
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
[[nodiscard]] ContourFit fitContour(std::span<const std::uint32_t> list,
                                    const std::vector<BoxTestTriangle>& triangles, Vec3d c,
                                    double h, ContourScratch& scratch);
/// A direction quantised to a contour normal (scaled so that its largest component is ±31 and
/// rounded), as the fit's candidates are.
struct QuantisedNormal {
    std::array<int, 3> n{};
    double norm = 0;  ///< std::sqrt(double(|n|²))
    /// Its direction times any (normal, not tiny) positive factor quantises to it too: no scaled
    /// component lies within 10⁻⁹ of a rounding tie, far beyond what the factor's rounding moves.
    bool scaleInvariant = false;
};
/// @p direction quantised (zero: all zero); scaleInvariant only computed with @p
/// checkScaleInvariance.
[[nodiscard]] QuantisedNormal quantiseDirection(Vec3d direction, bool checkScaleInvariance = false);

/// Per triangle, what the fit would otherwise recompute at every voxel, computed as it computes
/// them: length[t] = length(normal), unit[t] = normal · (1 / length[t]) where length[t] > 0, and
/// quantised[t] = quantiseDirection(unit[t], true) there.
struct TriangleNormals {
    const double* length = nullptr;
    const Vec3d* unit = nullptr;
    const QuantisedNormal* quantised = nullptr;  ///< null, or with length and unit
};

/// fitContour on fragments already clipped (CubeFragments::clip at scale fitContourScale(h)) from
/// the triangles @p list of @p triangles: the same result. @p normals: empty, or theirs.
[[nodiscard]] ContourFit fitContour(const CubeFragments& fragments,
                                    std::span<const std::uint32_t> list,
                                    const std::vector<BoxTestTriangle>& triangles,
                                    TriangleNormals normals = {});
/// The scale from leaf units to the local frame of a cube of half-extent @p h that fitContour clips
/// in.
[[nodiscard]] inline double fitContourScale(double h) { return 0.5 / h; }

/// The slab of contour @p encoded of a voxel, seen from its child in @p slot (pos' = 2·pos +
/// Σ n·(½ − bit), thickness doubled): 0 when none or when it no longer fits the encoding.
/// @p thickness receives its thickness in the child's edge units.
[[nodiscard]] std::uint32_t carryContour(std::uint32_t encoded, std::uint32_t slot,
                                         double& thickness);

/// carryContour for the children of one voxel: its contour decoded, and its normal's length
/// taken, once.
class ContourCarrier {
public:
    explicit ContourCarrier(std::uint32_t encoded)
        : encoded_(encoded), contour_(esvo::Contour::decode(encoded)) {
        if (encoded_ != 0)
            norm_ = std::sqrt(double(contour_.nx * contour_.nx + contour_.ny * contour_.ny +
                                     contour_.nz * contour_.nz));
    }

    /// carryContour(encoded, @p slot, @p thickness).
    [[nodiscard]] std::uint32_t operator()(std::uint32_t slot, double& thickness) const {
        if (encoded_ == 0) return 0;
        esvo::Contour c = contour_;
        // Positions are in steps of 0.75, the offsets Σ n·(½ − bit) in steps of 0.5: only whole
        // steps survive exactly; round the position outward by widening the slab instead.
        //   centre = 2·position·0.75 + 0.5·S = N/4 with N = 6·position + 2·S (S = ±nx ± ny ± nz)
        //   new position = lround(centre / 0.75) = nearest integer to N/3 (never a tie)
        //   reach = thickness·0.75 + |centre − new position·0.75| = R/4, R = 3·thickness + |N −
        //   3·new| new thickness = ceil(2·reach / 0.75 − 1e-9) = ceil(2R/3)
        // all in integers: every one of these doubles is a small multiple of 1/4, exact, and N/3,
        // 2R/3 lie at least 1/3 from the half-integers and integers where the rounding would
        // decide otherwise (an integer 2R/3 less 1e-9 still has that ceiling).
        const int s =
            (slot & 1u ? -c.nx : c.nx) + (slot & 2u ? -c.ny : c.ny) + (slot & 4u ? -c.nz : c.nz);
        const long n = 6L * c.position + 2L * s;
        const long position = n >= 0 ? (n + 1) / 3 : -((1 - n) / 3);
        const long r = 3L * static_cast<long>(c.thickness) + std::abs(n - 3 * position);
        const long t = (2 * r + 2) / 3;
        if (position < -64 || position > 63 || t > 127) return 0;
        c.position = static_cast<int>(position);
        c.thickness = static_cast<unsigned>(t);
        thickness = c.thickness * esvo::Contour::kStep / norm_;
        return c.encode();
    }

private:
    std::uint32_t encoded_;
    esvo::Contour contour_;
    double norm_ = 0;  // |normal|
};

/// Largest distance (leaf units) from a vertex of cube ∩ slab (@p encoded may be 0: the cube)
/// to the nearest of the triangles in @p list: the shape's geometric error.
[[nodiscard]] double shapeError(std::uint32_t encoded, std::span<const std::uint32_t> list,
                                const std::vector<BoxTestTriangle>& triangles, Vec3d c, double h);
/// shapeError(...) <= @p bound, without finding the largest distance: each vertex stops at the
/// first triangle within the bound, and the test at the first vertex with none.
[[nodiscard]] bool shapeWithinError(std::uint32_t encoded, std::span<const std::uint32_t> list,
                                    const std::vector<BoxTestTriangle>& triangles, Vec3d c,
                                    double h, double bound);

}  // namespace vox::detail
