// What the block encoders' files (attribute_encode.h) share: the blocks' points and the states
// of the searches, the effort tables of the normal encoder, and the functions one file defines
// for another. Private to libvox/src/octree: not for callers of the encoders.
//   color_encode.cpp        the colour encoder (RGB565 endpoints and indices)
//   normal_encode.cpp       the normal encoder: efforts, the choice of fits, the codes' search
//   normal_encode_face.cpp  the normals' face-plane fit
//   normal_encode_3d.cpp    the normals' 3-D fit
//   attribute_encode_simd.cpp  the SIMD kernels both encoders measure with (SSE2, AVX-512 chosen
//                           at run time, a scalar fallback) and the choice of kernels
//   attribute_encode.cpp    encodeCompressedBlock: both encoders
// and in libvox/src/util: linear_solve.h (the 3-D fit's Cholesky solver) and cpu_features.h.
// Every file that holds encoder code is built with -ffp-contract=off (libvox/CMakeLists.txt): the
// kernels and their scalar fallbacks give the same bits only where no multiply-add is fused.
#pragma once

#include "attribute_encode.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cstdint>
#include <limits>
#include <numbers>
#include <span>

namespace vox::detail::encode {

using esvo::Vec3;

// ============================================================================================
// Colour: RGB565 endpoints c0, c1 and a palette {c0, c1, ⅔c0+⅓c1, ⅓c0+⅔c1}.
// ============================================================================================

/// The used colours of a block, as 8-bit sRGB integers; also per channel as floats (exact),
/// padded to 16 with copies of the first, for the vectorised evaluation.
struct ColorPoints {
    unsigned count = 0;
    std::array<unsigned, 16> slot{};
    std::array<std::array<int, 3>, 16> rgb{};
    alignas(16) std::array<std::array<float, 16>, 3> channel{};
};

inline constexpr int expand5(int c) { return (c << 3) | (c >> 2); }
inline constexpr int expand6(int c) { return (c << 2) | (c >> 4); }

/// Summed squared error of the used colours against the palette of (c0, c1), each taking its
/// nearest entry (the lowest index on ties), with their indices in @p index. Stops early once
/// the sum exceeds @p bound (the scalar fallback; the SSE2 kernel sums them all).
[[nodiscard]] std::uint32_t evalColors(const ColorPoints& p, std::uint32_t c0, std::uint32_t c1,
                                       std::array<std::uint8_t, 16>& index, std::uint32_t bound);

/// The ordered cluster fit's search (orderedClusterFit): of every split of @p n colours, sorted
/// along the principal axis, into the four palette entries in line, the one whose least-squares
/// endpoints leave the smallest unquantised error; @p prefix holds the sorted colours' prefix
/// sums per channel, padded past @p n with the total. @p split gets the ends of the first three
/// clusters; false when no split determines both endpoints.
[[nodiscard]] bool orderedSplit(const std::array<std::array<float, 20>, 3>& prefix, unsigned n,
                                std::array<unsigned, 3>& split);

// ============================================================================================
// Normals: normalise(base + cu·u + cv·v), base a cube-face point, cu, cv ∈ kAxisWeights.
// ============================================================================================

/// The distinct used normals (unit) of a block, each with its multiplicity, and their
/// projections onto the plane of one cube face. Every sum over the normals weighs each by its
/// multiplicity, so the search sees the block's sixteen slots while it loops over fewer points:
/// flat-shaded faces and the edges between them repeat normals exactly (a third of the normals
/// the 3-D fit sees on the assimp-testmodels engine at depth 10).
struct NormalPoints {
    unsigned count = 0;  ///< distinct normals
    unsigned total = 0;  ///< used slots: the sum of the multiplicities
    std::array<Vec3, 16> n{};
    std::array<float, 16> multiplicity{};
    unsigned axis = 2;  ///< the face's axis
    float sign = 1;     ///< and its direction
    std::array<float, 16> px{}, py{},
        weight{};  ///< in-plane coordinates (axis+1, axis+2) and LS weights
    bool singleEquations =
        false;  ///< the 3-D fit's normal equations in single precision (normalEquationsSingle)
};

/// A fit in the face plane: p ≈ b + cu·u + cv·v, combo k = uIndex + 4·vIndex.
struct PlaneFit {
    float bx = 0, by = 0, ux = 0, uy = 0, vx = 0, vy = 0;
    double error = std::numeric_limits<double>::max();
    std::array<std::uint8_t, 16> combo{};
};

/// A quantised normal block: words 2 (base) and 4 (axes), the summed squared chord error of the
/// used normals (see evalNormals) and their combos.
struct NormalState {
    std::uint32_t base = 0, axes = 0;
    double error = std::numeric_limits<double>::max();
    std::array<std::uint8_t, 16> combo{};
};

/// 2^(e − 13), the step of axis exponent e (as esvo::decodeAxis).
inline float axisStep(int e) {
    return std::bit_cast<float>(static_cast<std::uint32_t>(e + 127 - 13) << 23);
}

/// The exponent esvo::encodeAxis chooses for components within [@p lo, @p hi] (lo ≤ 0 ≤ hi).
inline int axisExponent(float lo, float hi) {
    int e = 0;
    while (e < 15 && (hi > 7.5f * axisStep(e) || lo < -8.5f * axisStep(e))) ++e;
    return e;
}

// ---- How hard the normal encoder searches (the efforts: normal_encode.cpp) --------------------

/// Summed squared chord per used normal (≈ squared angle) above which the face-plane fit is
/// followed by the 3-D search: (1°)² for narrow blocks, where the face-plane fit is nearly always
/// as good, (0.3°)² for wide ones.
inline constexpr double kDegree2 = (std::numbers::pi / 180) * (std::numbers::pi / 180);
inline constexpr double kNarrowThreshold = 1.0 * 1.0 * kDegree2,
                        kWideThreshold = 0.3 * 0.3 * kDegree2;

/// How the codes around a quantised block are searched: passes, and per pass the moves measured
/// (0: every move in turn, searchCodes; otherwise the best few predicted, searchCodesGuided);
/// and the summed error at or below which a quantiser stops (0: never before it is exact).
struct CodeSearch {
    int passes = 0;
    unsigned measured = 0;
    double enough = 0;
};

/// The error per normal at which the faster efforts' 3-D search stops, (0.02°)²: what more search
/// could gain is then about the precision of the base's code (2⁻¹³ radians, 0.007°).
inline constexpr double kEnough = 0.02 * 0.02 * kDegree2;

/// How hard the normal encoder searches (see AttributeEffort).
struct NormalSearch {
    /// The face-plane fit's starts (fitNormals).
    unsigned startMask = 63;
    /// Plane fit on the codes (fitPlaneOnCodes) rather than fit unquantised and quantised by code
    /// search (quantiseFit).
    bool planeOnCodes = false;
    /// The 3-D fit's normal equations in single precision (normalEquationsSingle).
    bool singleEquations = false;
    /// Summed squared chord per used normal above which the 3-D search follows.
    double narrowThreshold = kNarrowThreshold, wideThreshold = kWideThreshold;
    /// The 3-D search: candidates refined at all, iterations for the best two of wide blocks,
    /// whether a second candidate may be quantised, and how (code search, or enumeration
    /// followed by that many passes of code search).
    unsigned refined = 4;
    int moreIterations = 6;
    bool second = true;
    bool enumerateModel = false;
    /// The search of the codes around a quantised model: of wide blocks (for narrow ones none when
    /// enumerating) and, when not enumerating, of narrow ones.
    CodeSearch modelCodes{3, 0}, narrowModelCodes{2, 0};
    /// Below this error per normal (the plane fit's) the 3-D search runs with `light` instead.
    double lightBelow = 0;
    /// Whether the code-search quantiser (quantiseModel) of wide blocks rounds each axis first in
    /// turn (or only u, as for narrow blocks).
    bool roundBothAxes = true;
    /// At or below this error per normal the 3-D search stops (0: only when exact): what more
    /// search could gain is then below the codes' own precision.
    double enoughPerNormal = 0;
    /// The second candidate is quantised only where the first quantised is more than this many
    /// times the first's unquantised error (0: wherever kSecondRatio and kQuantisationLoss allow).
    double secondAbove = 0;
    /// Below this error per normal (the face-plane fit's, unquantised) the first start's fit is
    /// kept without trying the others (0: never).
    double earlyBelow = 0;
};

// ---- The kernels (attribute_encode_simd.cpp) --------------------------------------------------

/// Assigns every point its nearest of the 16 lattice points of @p f in the face plane, and sets
/// f.error to their weighted summed squared distance; true when a combo changed.
bool assignPlane(const NormalPoints& p, PlaneFit& f);

/// Summed squared chord |n − d|² = 2 (1 − cos) between each used normal n and the nearest d of
/// the 16 directions normalise(b + cu·u + cv·v), computed as esvo::decodeBlockNormal computes
/// them; the nearest one's combo goes to @p combo. Stops early beyond @p bound.
[[nodiscard]] double evalLattice(const NormalPoints& p, const Vec3& b, const Vec3& u, const Vec3& v,
                                 std::array<std::uint8_t, 16>& combo, double bound);

/// An unquantised lattice of the 3-D fit: base b = x[0…2], axes u = x[3…5], v = x[6…8].
using Model = std::array<double, 9>;

/// The Gauss–Newton normal equations of the decoded error at model @p x with @p combo: the
/// Jacobian of P̂ is (I − P̂P̂ᵀ)/|P|, and P is linear in x with the coefficients k = (1, cu, cv)
/// on its three parts, so the normal matrix's 3×3 block of parts (s, t) is Σ k_s k_t M with
/// M = (I − P̂P̂ᵀ)/|P|² (symmetric: six entries kept), for the parts in @p freeAxes (bit 0: u,
/// bit 1: v; the base always); @p g is the gradient of half the error.
struct NormalEquations {
    std::array<std::array<double, 6>, 6> block{};  // part pairs (0,0) (1,0) (1,1) (2,0) (2,1) (2,2)
    std::array<double, 9> g{};
    /// Entry (row, col) of the 9×9 normal matrix.
    [[nodiscard]] double h(unsigned row, unsigned col) const {
        const auto [b, e] = kEntries[row][col];
        return block[b][e];
    }

private:
    /// Where entry (row, col) is stored: the block of parts (row / 3, col / 3), larger first, and
    /// in it (each block is symmetric, a multiple of M) the entry of (row % 3, col % 3), larger
    /// first.
    struct Entry {
        std::uint8_t block, entry;
    };
    static constexpr std::array<std::array<Entry, 9>, 9> kEntries = [] {
        std::array<std::array<Entry, 9>, 9> t{};
        for (unsigned row = 0; row < 9; ++row)
            for (unsigned col = 0; col < 9; ++col) {
                const unsigned si = std::max(row / 3, col / 3), ti = std::min(row / 3, col / 3);
                const unsigned c = row / 3 >= col / 3 ? row % 3 : col % 3,
                               d = row / 3 >= col / 3 ? col % 3 : row % 3;
                const unsigned lo = std::min(c, d), hi = std::max(c, d);
                t[row][col] = {static_cast<std::uint8_t>(si * (si + 1) / 2 + ti),
                               static_cast<std::uint8_t>(hi * (hi + 1) / 2 + lo)};
            }
        return t;
    }();
};

/// normalEquations (normal_encode_3d.cpp) in single precision, four points at a time (lane by
/// lane, which the compiler vectorises; a lane past the points contributes nothing), the lanes
/// summed in double at the end; defined for FreeAxes 0…3. For the faster efforts: a
/// Levenberg–Marquardt step only has to lead downhill (whether it is taken is decided by the exact
/// decoded error) and the quantisers' quadratics only rank codes that are then measured, and this
/// costs a quarter of the double-precision sums.
template <unsigned FreeAxes>
[[nodiscard]] NormalEquations normalEquationsSingle(const NormalPoints& p, const Model& x,
                                                    const std::array<std::uint8_t, 16>& combo);

// ---- The codes (normal_encode.cpp) ------------------------------------------------------------

/// evalLattice of the decoded (base, axes) words.
[[nodiscard]] double evalNormals(const NormalPoints& p, std::uint32_t base, std::uint32_t axes,
                                 std::array<std::uint8_t, 16>& combo, double bound);

/// Replaces @p s by the codes (@p base, @p axes) if they decode with a smaller error.
bool tryNormals(const NormalPoints& p, std::uint32_t base, std::uint32_t axes, NormalState& s);

/// Re-rounds a 16-bit axis at exponent @p e (components clamped to −8 … 7).
[[nodiscard]] std::uint32_t roundAxis(const Vec3& a, int e);

/// One pass over the axis codes around @p s: each of the @p components of either axis one step
/// either way, and each axis one exponent finer or coarser (re-rounded). True if any improved.
bool stepAxisCodes(const NormalPoints& p, NormalState& s, std::span<const unsigned> components);

// ---- The face-plane fit (normal_encode_face.cpp) ----------------------------------------------

/// Projects the normals onto their face plane and fits the lattice there (fitPlaneOnCodes when
/// @p onCodes, which rounds the axes to their codes at every step, otherwise unquantised) from
/// the starts in @p startMask (bit i: start i; start 0 always), keeping the lowest error; where
/// the first start's fit is within @p enough, the others are not tried.
[[nodiscard]] PlaneFit fitNormals(NormalPoints& p, unsigned startMask, bool onCodes, double enough);

/// The codes of a face-plane fit (its base's cube-face point through encodeNormal, its axes
/// through encodeAxis, rescaled where the base falls off its face); the error is not measured.
[[nodiscard]] NormalState planeCodes(const NormalPoints& p, const PlaneFit& f);

/// Quantises a plane fit: the base through encodeNormal (rescaling the axes when the base falls
/// off its face), the axes through encodeAxis; then refits the base to the quantised axes and
/// searches neighbouring axis codes, all measured against the decoded normals.
[[nodiscard]] NormalState quantiseFit(const NormalPoints& p, const PlaneFit& f);

// ---- The 3-D fit (normal_encode_3d.cpp) -------------------------------------------------------

/// How a block's normals spread, which decides the 3-D search it gets.
struct NormalSpread {
    bool spread = false;  ///< some normal more than 30° from the outermost one
    bool few = false;     ///< at most four distinct directions (more than ~1° apart)
};
/// The spread of @p p's normals; the distinct directions are counted only where the normals do
/// not spread, or where @p countFew.
[[nodiscard]] NormalSpread normalSpread(const NormalPoints& p, bool countFew);

/// The 3-D search: candidate models from the face-plane fit @p f and (for @p wide blocks, see
/// NormalSpread) from clusters of the normals, the best refined; the best one or two quantised.
/// Replaces @p s where one decodes better.
void fit3d(const NormalPoints& p, const PlaneFit& f, bool wide, const NormalSearch& search,
           NormalState& s);

}  // namespace vox::detail::encode
