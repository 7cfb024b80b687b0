// The normals' 3-D fit. The face-plane fit (normal_encode_face.cpp) cannot serve blocks whose
// normals span 90° or more: the voxels along the edges and corners where walls meet (+x, +y and
// their average), or both sides of a thin sheet (+y and −y). The decoded directions are the
// central projection of a planar lattice b + cu·u + cv·v that may lie anywhere in space, and the
// fit below works with that lattice directly: unquantised models built exactly through up to
// four cluster representatives of the normals (and the face-plane fit lifted to 3-D), each
// refined by Levenberg–Marquardt on the decoded error; the best are quantised and refined on the
// codes.
//
// The search costs several times the face-plane fit, so it runs only where that fit leaves an
// error worth the time, and builds the cluster models only for blocks wide enough to need them.
#include "attribute_encode_internal.h"

#include "../util/linear_solve.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>

namespace vox::detail::encode {
namespace {

/// Blocks whose normals span more than 30° ("wide"), or that hold at most four distinct
/// directions (more than ~1° apart), get models through clusters of their normals; others only
/// the face-plane fit lifted to 3-D.
constexpr double kWideCos = 0.8660254, kDistinctCos = 0.99985;

/// The best few (at most 4) of scored candidates, lowest score first, the earliest of equals.
struct TopK {
    unsigned k = 0, n = 0;
    std::array<double, 4> score{};
    std::array<unsigned, 4> id{};
    explicit TopK(unsigned keep) : k(std::min(keep, 4u)) {}
    void offer(double sc, unsigned i) {
        if (n == k && (k == 0 || !(sc < score[n - 1]))) return;
        unsigned at = n < k ? n++ : n - 1;
        while (at > 0 && sc < score[at - 1]) {
            score[at] = score[at - 1];
            id[at] = id[at - 1];
            --at;
        }
        score[at] = sc;
        id[at] = i;
    }
};

using Dir = std::array<double, 3>;

Vec3 modelPart(const Model& x, unsigned part) {
    return {static_cast<float>(x[3 * part]), static_cast<float>(x[3 * part + 1]),
            static_cast<float>(x[3 * part + 2])};
}

double modelError(const NormalPoints& p, const Model& x, std::array<std::uint8_t, 16>& combo) {
    return evalLattice(p, modelPart(x, 0), modelPart(x, 1), modelPart(x, 2), combo,
                       std::numeric_limits<double>::max());
}

/// Scales @p x (which leaves its directions alone) so that the base's largest component is ±1,
/// the cube-face form; false when the axes would then exceed the code's range (7·2²).
bool normaliseModel(Model& x) {
    const double bMax = std::max({std::fabs(x[0]), std::fabs(x[1]), std::fabs(x[2])});
    double aMax = 0;
    for (unsigned i = 3; i < 9; ++i) aMax = std::max(aMax, std::fabs(x[i]));
    if (!(bMax > 0) || !(aMax <= 28.0 * bMax)) return false;
    for (double& c : x) c /= bMax;
    return true;
}

unsigned dominantAxis(const Model& x) {
    const double ax = std::fabs(x[0]), ay = std::fabs(x[1]), az = std::fabs(x[2]);
    return ax >= ay && ax >= az ? 0u : (ay >= az ? 1u : 2u);
}

/// Solves the orders refineModel solves (the base's two minor components, with none, one or both
/// axes) by solveCholesky, each unrolled by the compiler.
bool solveSpd(std::array<std::array<double, 9>, 9>& m, std::array<double, 9>& r, unsigned n) {
    switch (n) {
        case 2:
            return solveCholesky<2>(m, r);
        case 5:
            return solveCholesky<5>(m, r);
        case 8:
            return solveCholesky<8>(m, r);
        default:
            return false;
    }
}

template <unsigned FreeAxes>
NormalEquations normalEquations(const NormalPoints& p, const Model& x,
                                const std::array<std::uint8_t, 16>& combo) {
    NormalEquations ne;
    auto& block = ne.block;
    auto& g = ne.g;
    constexpr bool used[3]{true, (FreeAxes & 1u) != 0, (FreeAxes & 2u) != 0};
    for (unsigned i = 0; i < p.count; ++i) {
        const double k[3]{1.0, esvo::kAxisWeights[combo[i] & 3], esvo::kAxisWeights[combo[i] >> 2]};
        double q[3];
        for (unsigned c = 0; c < 3; ++c) q[c] = x[c] + k[1] * x[3 + c] + k[2] * x[6 + c];
        const double len2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2];
        if (!(len2 > 1e-24)) continue;
        const double inv = 1.0 / std::sqrt(len2), inv2 = inv * inv * p.multiplicity[i];
        for (double& c : q) c *= inv;
        const double nd = p.n[i][0] * q[0] + p.n[i][1] * q[1] + p.n[i][2] * q[2];
        const double m[6]{(1 - q[0] * q[0]) * inv2, -q[1] * q[0] * inv2, (1 - q[1] * q[1]) * inv2,
                          -q[2] * q[0] * inv2,      -q[2] * q[1] * inv2, (1 - q[2] * q[2]) * inv2};
        for (unsigned st = 0, si = 0; si < 3; ++si)
            for (unsigned ti = 0; ti <= si; ++ti, ++st) {
                if (!used[si] || !used[ti]) continue;
                const double w = k[si] * k[ti];
                for (unsigned e = 0; e < 6; ++e) block[st][e] += w * m[e];
            }
        for (unsigned c = 0; c < 3; ++c) {
            const double r = -(p.n[i][c] - nd * q[c]) * inv * p.multiplicity[i];
            for (unsigned si = 0; si < 3; ++si) g[3 * si + c] += k[si] * r;
        }
    }
    return ne;
}

/// normalEquations, in single precision where p.singleEquations, with the free axes' loops
/// specialised.
template <unsigned FreeAxes>
NormalEquations normalEquationsOf(const NormalPoints& p, const Model& x,
                                  const std::array<std::uint8_t, 16>& combo) {
    return p.singleEquations ? normalEquationsSingle<FreeAxes>(p, x, combo)
                             : normalEquations<FreeAxes>(p, x, combo);
}

NormalEquations normalEquations(const NormalPoints& p, const Model& x,
                                const std::array<std::uint8_t, 16>& combo, unsigned freeAxes) {
    switch (freeAxes) {
        case 0:
            return normalEquationsOf<0>(p, x, combo);
        case 1:
            return normalEquationsOf<1>(p, x, combo);
        case 2:
            return normalEquationsOf<2>(p, x, combo);
        default:
            return normalEquationsOf<3>(p, x, combo);
    }
}

/// Levenberg–Marquardt on the decoded error Σ|P̂ − n|² (P = b + cu·u + cv·v, P̂ = P/|P|) over
/// the base's two minor components and the axes in @p freeAxes (bit 0: u, bit 1: v); the base's
/// dominant component stays ±1, which fixes the scale. Every step re-assigns each normal its
/// nearest lattice point, which only lowers the error: a descent on what evalLattice measures,
/// starting from @p error (the model's). With both axes free the model is renormalised to the
/// cube-face form after each step; otherwise the base's minor components are clamped to it.
/// Returns the error.
double refineModel(const NormalPoints& p, Model& x, std::array<std::uint8_t, 16>& combo,
                   unsigned freeAxes, int iterations, double error) {
    double lambda = 1e-3;
    for (int iteration = 0; iteration < iterations && error > 0; ++iteration) {
        const unsigned a = dominantAxis(x);
        const NormalEquations ne = normalEquations(p, x, combo, freeAxes);
        const auto& g = ne.g;
        const auto h = [&](unsigned row, unsigned col) { return ne.h(row, col); };
        std::array<unsigned, 8> index{};
        unsigned n = 0;
        for (unsigned c = 0; c < 3; ++c)
            if (c != a) index[n++] = c;
        for (unsigned axis = 0; axis < 2; ++axis)
            if ((freeAxes >> axis) & 1u)
                for (unsigned c = 0; c < 3; ++c) index[n++] = 3 + 3 * axis + c;
        // The lower triangle of the free variables' normal matrix, gathered once for all attempts.
        std::array<std::array<double, 9>, 9> normal{};
        for (unsigned j = 0; j < n; ++j)
            for (unsigned l = 0; l <= j; ++l) normal[j][l] = h(index[j], index[l]);
        double trace = 0;
        for (unsigned j = 0; j < n; ++j) trace += normal[j][j];
        const double floor = 1e-9 * trace / n + 1e-30;
        bool accepted = false;
        double gain = 0;
        for (int attempt = 0; attempt < 4 && !accepted; ++attempt) {
            std::array<std::array<double, 9>, 9> m = normal;
            std::array<double, 9> step{};
            for (unsigned j = 0; j < n; ++j) {
                m[j][j] = m[j][j] * (1 + lambda) + floor;
                step[j] = -g[index[j]];
            }
            if (!solveSpd(m, step, n)) {
                lambda *= 10;
                continue;
            }
            Model y = x;
            bool finite = true;
            for (unsigned j = 0; j < n; ++j) {
                y[index[j]] += step[j];
                finite = finite && std::isfinite(y[index[j]]);
            }
            if (!finite) {
                lambda *= 10;
                continue;
            }
            if (freeAxes == 3) {
                if (!normaliseModel(y)) {
                    lambda *= 10;
                    continue;
                }
            } else {
                for (unsigned c = 0; c < 3; ++c)
                    if (c != a) y[c] = std::clamp(y[c], -1.0, 1.0);
            }
            std::array<std::uint8_t, 16> yc{};
            const double e = modelError(p, y, yc);
            if (e < error) {
                gain = error - e;
                x = y;
                combo = yc;
                error = e;
                lambda *= 0.3;
                accepted = true;
            } else {
                lambda *= 10;
            }
        }
        if (!accepted || gain < 1e-3 * error) break;
    }
    return error;
}

/// The model of a quantised block.
Model decodedModel(const NormalState& s) {
    const Vec3 b = esvo::decodeNormal(s.base), u = esvo::decodeAxis(s.axes & 0xFFFFu),
               v = esvo::decodeAxis(s.axes >> 16);
    return {b[0], b[1], b[2], u[0], u[1], u[2], v[0], v[1], v[2]};
}

/// Searches the codes around @p s: every axis component one step either way and each axis one
/// exponent finer or coarser (re-rounded); after each pass (at most @p passes), the base refit
/// to the axes.
void searchCodes(const NormalPoints& p, NormalState& s, int passes) {
    constexpr std::array<unsigned, 3> kAllComponents{0, 1, 2};
    for (int pass = 0; pass < passes && s.error > 0; ++pass) {
        bool improved = stepAxisCodes(p, s, kAllComponents);
        Model x = decodedModel(s);
        std::array<std::uint8_t, 16> combo = s.combo;
        refineModel(p, x, combo, 0, 3, s.error);
        if (tryNormals(p, esvo::encodeNormal(modelPart(x, 0)), s.axes, s)) improved = true;
        if (!improved) break;
    }
}

void searchCodesGuided(const NormalPoints& p, NormalState& s, int passes, unsigned measured,
                       double enough);

void polishCodes(const NormalPoints& p, NormalState& s, const CodeSearch& codes) {
    if (codes.passes <= 0 || s.error <= codes.enough) return;
    if (codes.measured == 0)
        searchCodes(p, s, codes.passes);
    else
        searchCodesGuided(p, s, codes.passes, codes.measured, codes.enough);
}

/// tryNormals of the codes a model rounds to.
void tryModel(const NormalPoints& p, const Model& y, NormalState& s) {
    const std::uint32_t axes =
        esvo::encodeAxis(modelPart(y, 1)) | (esvo::encodeAxis(modelPart(y, 2)) << 16);
    tryNormals(p, esvo::encodeNormal(modelPart(y, 0)), axes, s);
}

/// Replaces axis @p part of @p y by what its code decodes to.
void roundModelPart(Model& y, unsigned part) {
    const Vec3 q = esvo::decodeAxis(esvo::encodeAxis(modelPart(y, part)));
    for (unsigned c = 0; c < 3; ++c) y[3 * part + c] = q[c];
}

/// A model whose normals all take one weight of an axis (a lattice line: two directions, or
/// three in a plane) can spend both axes' codes on the other: with that axis' part moved into
/// the base, the lattice's diagonal b + c·(u + v) has u + v = Q(a) + Q(a − Q(a)), about
/// twice the mantissa bits. Tries those codes for each axis that qualifies.
void tryLatticeLines(const NormalPoints& p, const Model& x,
                     const std::array<std::uint8_t, 16>& combo, NormalState& s) {
    std::array<std::uint8_t, 16> c0 = combo;
    modelError(p, x, c0);
    for (unsigned line = 1; line <= 2; ++line) {
        const unsigned other = 3 - line;
        const auto weight = [&](std::uint8_t k) { return other == 1 ? (k & 3u) : (k >> 2); };
        bool single = true;
        for (unsigned i = 1; i < p.count; ++i) single = single && weight(c0[i]) == weight(c0[0]);
        if (!single) continue;
        Model y = x;
        for (unsigned k = 0; k < 3; ++k)
            y[k] += esvo::kAxisWeights[weight(c0[0])] * y[3 * other + k];
        roundModelPart(y, line);
        for (unsigned k = 0; k < 3; ++k) y[3 * other + k] = x[3 * line + k] - y[3 * line + k];
        roundModelPart(y, other);
        std::array<std::uint8_t, 16> c{};
        refineModel(p, y, c, 0, 3, modelError(p, y, c));
        tryModel(p, y, s);
    }
}

/// Quantises a model: all parts rounded at once, and each axis rounded in turn with the rest
/// refit to it (when not @p thorough, u only); then the search of the codes around the best.
NormalState quantiseModel(const NormalPoints& p, const Model& x,
                          const std::array<std::uint8_t, 16>& combo, bool thorough,
                          const CodeSearch& codes) {
    NormalState s;
    tryModel(p, x, s);
    if (s.error <= codes.enough) return s;
    tryLatticeLines(p, x, combo, s);
    for (unsigned first = 1; first <= (thorough ? 2u : 1u) && s.error > codes.enough; ++first) {
        Model y = x;
        std::array<std::uint8_t, 16> c = combo;
        roundModelPart(y, first);
        refineModel(p, y, c, first == 1 ? 2u : 1u, 4, modelError(p, y, c));
        roundModelPart(y, 3 - first);
        refineModel(p, y, c, 0, 3, modelError(p, y, c));
        tryModel(p, y, s);
    }
    polishCodes(p, s, codes);
    return s;
}

/// Up to sixteen codes of a 3-D axis @p a: at the smallest exponent that holds it and the next,
/// each component rounded down and up.
unsigned axisCandidates3(const Vec3& a, std::array<std::uint32_t, 16>& codes) {
    const int e0 = axisExponent(std::min({a[0], a[1], a[2], 0.0f}),
                                std::max({a[0], a[1], a[2], 0.0f}));  // encodeAxis's
    unsigned n = 0;
    for (int e = e0; e <= std::min(e0 + 1, 15); ++e) {
        const float step = axisStep(e);
        std::array<std::array<std::uint32_t, 2>, 3> m{};
        unsigned equal =
            0;  // components whose value is a whole number of steps: rounded down and up alike
        for (unsigned c = 0; c < 3; ++c) {
            const float q = a[c] / step;
            const int lo = std::clamp(static_cast<int>(std::floor(q)), -8, 7),
                      hi = std::clamp(static_cast<int>(std::ceil(q)), -8, 7);
            m[c] = {(static_cast<std::uint32_t>(lo) & 15u) << (4 * c),
                    (static_cast<std::uint32_t>(hi) & 15u) << (4 * c)};
            if (lo == hi) equal |= 1u << c;
        }
        // Every combination once, in the order of the bits (the duplicates a whole component makes
        // skipped).
        for (unsigned bits = 0; bits < 8; ++bits)
            if (!(bits & equal))
                codes[n++] = (static_cast<std::uint32_t>(e) << 12) | m[0][bits & 1u] |
                             m[1][(bits >> 1) & 1u] | m[2][(bits >> 2) & 1u];
    }
    return n;
}

/// The decoded error near a model x with its combos as a quadratic in the axes alone: the
/// Gauss–Newton quadratic E + 2gᵀδ + δᵀHδ with the base's minor components at their best for the
/// axes (the Schur complement), so that any change δa of the six axis components is scored in
/// constant time, 2ĝᵀδa + δaᵀĤδa, and the base that goes with it found by one product.
struct AxisQuadratic {
    Model x{};
    std::array<unsigned, 2> baseVar{};           ///< the base's minor components
    std::array<std::array<double, 6>, 2> hba{};  ///< Hba: base rows, axis columns
    std::array<double, 2> gb{};                  ///< the base's gradient
    double ib00 = 0, ib01 = 0, ib11 = 0;         ///< Hbb⁻¹
    std::array<std::array<double, 6>, 6> hh{};   ///< Ĥ = Haa − Hab Hbb⁻¹ Hba
    std::array<double, 6> gh{};                  ///< ĝ = ga − Hab Hbb⁻¹ gb

    /// False where the base's block is singular (no quadratic).
    bool init(const NormalPoints& p, const Model& model,
              const std::array<std::uint8_t, 16>& combo) {
        x = model;
        const unsigned a = dominantAxis(x);
        const NormalEquations ne = normalEquations(p, x, combo, 3);
        for (unsigned c = 0, n = 0; c < 3; ++c)
            if (c != a) baseVar[n++] = c;
        const double hb00 = ne.h(baseVar[0], baseVar[0]), hb01 = ne.h(baseVar[0], baseVar[1]),
                     hb11 = ne.h(baseVar[1], baseVar[1]);
        const double det = hb00 * hb11 - hb01 * hb01;
        if (!(det > 1e-300)) return false;
        ib00 = hb11 / det, ib01 = -hb01 / det, ib11 = hb00 / det;
        for (unsigned r = 0; r < 2; ++r) {
            gb[r] = ne.g[baseVar[r]];
            for (unsigned j = 0; j < 6; ++j) hba[r][j] = ne.h(baseVar[r], 3 + j);
        }
        // (Hbb⁻¹ Hba) column by column, then the Schur complement.
        std::array<std::array<double, 2>, 6> hbiT{};
        for (unsigned j = 0; j < 6; ++j)
            hbiT[j] = {ib00 * hba[0][j] + ib01 * hba[1][j], ib01 * hba[0][j] + ib11 * hba[1][j]};
        const double ig0 = ib00 * gb[0] + ib01 * gb[1], ig1 = ib01 * gb[0] + ib11 * gb[1];
        for (unsigned i = 0; i < 6; ++i) {
            for (unsigned j = 0; j < 6; ++j)
                hh[i][j] = ne.h(3 + i, 3 + j) - (hba[0][i] * hbiT[j][0] + hba[1][i] * hbiT[j][1]);
            gh[i] = ne.g[3 + i] - (hba[0][i] * ig0 + hba[1][i] * ig1);
        }
        return true;
    }

    /// The predicted change of the error for the change @p d of axis @p which (0: u, 1: v) alone
    /// (with the base at its best).
    [[nodiscard]] double score(unsigned which, const std::array<double, 3>& d) const {
        double q = 0;
        for (unsigned r = 0; r < 3; ++r) {
            const unsigned i = 3 * which + r;
            q += d[r] * (2 * gh[i] + hh[i][3 * which] * d[0] + hh[i][3 * which + 1] * d[1] +
                         hh[i][3 * which + 2] * d[2]);
        }
        return q;
    }

    /// The base that goes with axis change @p da: b + δb, δb = −Hbb⁻¹ (gb + Hba δa).
    [[nodiscard]] Vec3 base(const std::array<double, 6>& da) const {
        double r0 = gb[0], r1 = gb[1];
        for (unsigned j = 0; j < 6; ++j) r0 += hba[0][j] * da[j], r1 += hba[1][j] * da[j];
        Vec3 b = modelPart(x, 0);
        b[baseVar[0]] -= static_cast<float>(ib00 * r0 + ib01 * r1);
        b[baseVar[1]] -= static_cast<float>(ib01 * r0 + ib11 * r1);
        return b;
    }
};

/// Component @p c (0…2) of axis code @p bits, in steps (esvo::decodeAxis without the scale).
inline int axisDigit(std::uint32_t bits, unsigned c) {
    return static_cast<std::int32_t>(bits << (28 - 4 * c)) >> 28;
}

/// searchCodes guided by the AxisQuadratic of the current codes: each pass scores the moves
/// searchCodes measures one by one (each axis component one step either way, each axis one
/// exponent finer or coarser, re-rounded) and the base refit alone, each with the base at its
/// best, in constant time, and measures only the best @p measured (at most 4); stops when none
/// gains or the error is at most @p enough.
void searchCodesGuided(const NormalPoints& p, NormalState& s, int passes, unsigned measured,
                       double enough) {
    struct Move {
        std::uint32_t axes;
        unsigned which;
        std::array<double, 3> d;
    };
    for (int pass = 0; pass < passes && s.error > enough; ++pass) {
        AxisQuadratic q;
        if (!q.init(p, decodedModel(s), s.combo)) return;
        std::array<Move, 17> moves{};
        TopK top(measured);
        unsigned n = 0;
        const auto offer = [&](std::uint32_t axes, unsigned which, const std::array<double, 3>& d,
                               double score) {
            moves[n] = {axes, which, d};
            top.offer(score, n++);
        };
        offer(s.axes, 0, {}, 0.0);  // the base refit alone
        for (unsigned which = 0; which < 2; ++which) {
            const unsigned shift = 16 * which;
            const std::uint32_t bits = (s.axes >> shift) & 0xFFFFu;
            const int e = static_cast<int>(bits >> 12);
            const double step = axisStep(e);
            for (unsigned c = 0; c < 3; ++c)
                for (const int dir : {-1, 1}) {
                    const int value = axisDigit(bits, c) + dir;
                    if (value < -8 || value > 7) continue;
                    const std::uint32_t moved =
                        (bits & ~(15u << (4 * c))) |
                        ((static_cast<std::uint32_t>(value) & 15u) << (4 * c));
                    std::array<double, 3> d{};
                    d[c] = dir * step;
                    const unsigned i = 3 * which + c;
                    offer((s.axes & ~(0xFFFFu << shift)) | (moved << shift), which, d,
                          d[c] * (2 * q.gh[i] + q.hh[i][i] * d[c]));
                }
            const Vec3 decoded = esvo::decodeAxis(bits);
            for (const int ne : {e - 1, e + 1}) {
                if (ne < 0 || ne > 15) continue;
                const std::uint32_t rounded = roundAxis(decoded, ne);
                const Vec3 r = esvo::decodeAxis(rounded);
                const std::array<double, 3> d{double(r[0]) - decoded[0], double(r[1]) - decoded[1],
                                              double(r[2]) - decoded[2]};
                offer((s.axes & ~(0xFFFFu << shift)) | (rounded << shift), which, d,
                      q.score(which, d));
            }
        }
        bool improved = false;
        for (unsigned m = 0; m < top.n; ++m) {
            const Move& mv = moves[top.id[m]];
            std::array<double, 6> da{};
            for (unsigned c = 0; c < 3; ++c) da[3 * mv.which + c] = mv.d[c];
            if (tryNormals(p, esvo::encodeNormal(q.base(da)), mv.axes, s)) improved = true;
        }
        if (!improved) break;
    }
}

/// quantiseModel by enumeration: with the model's AxisQuadratic, every pair of candidate axis
/// codes (axisCandidates3) is scored in constant time, and the best @p measured are measured
/// with their base; then the lattice-line codes as quantiseModel tries them, and the search of
/// the codes around the best.
NormalState quantiseModelFast(const NormalPoints& p, const Model& x,
                              const std::array<std::uint8_t, 16>& combo, unsigned measured,
                              const CodeSearch& codes) {
    NormalState s;
    tryNormals(p, esvo::encodeNormal(modelPart(x, 0)),
               esvo::encodeAxis(modelPart(x, 1)) | (esvo::encodeAxis(modelPart(x, 2)) << 16), s);
    AxisQuadratic q;
    if (q.init(p, x, combo) && s.error > 0) {
        const auto& hh = q.hh;
        const auto& gh = q.gh;
        std::array<std::uint32_t, 16> uc{}, vc{};
        const unsigned nu = axisCandidates3(modelPart(x, 1), uc),
                       nv = axisCandidates3(modelPart(x, 2), vc);
        std::array<std::array<double, 3>, 16> du{}, dv{}, cv{};
        std::array<double, 16> au{}, bv{};
        // The score split into its u part, v part and cross term, so that the pairs cost little.
        for (unsigned i = 0; i < nu; ++i) {
            const Vec3 d = esvo::decodeAxis(uc[i]);
            for (unsigned c = 0; c < 3; ++c) du[i][c] = d[c] - x[3 + c];
            double sc = 0;
            for (unsigned r = 0; r < 3; ++r)
                sc += du[i][r] *
                      (2 * gh[r] + hh[r][0] * du[i][0] + hh[r][1] * du[i][1] + hh[r][2] * du[i][2]);
            au[i] = sc;
        }
        for (unsigned j = 0; j < nv; ++j) {
            const Vec3 d = esvo::decodeAxis(vc[j]);
            for (unsigned c = 0; c < 3; ++c) dv[j][c] = d[c] - x[6 + c];
            double sc = 0;
            for (unsigned r = 0; r < 3; ++r)
                sc += dv[j][r] * (2 * gh[3 + r] + hh[3 + r][3] * dv[j][0] +
                                  hh[3 + r][4] * dv[j][1] + hh[3 + r][5] * dv[j][2]);
            bv[j] = sc;
            for (unsigned r = 0; r < 3; ++r)
                cv[j][r] = hh[r][3] * dv[j][0] + hh[r][4] * dv[j][1] + hh[r][5] * dv[j][2];
        }
        TopK top(measured);  // (the earlier pair of equals first)
        for (unsigned i = 0; i < nu; ++i)
            for (unsigned j = 0; j < nv; ++j)
                top.offer(au[i] + bv[j] +
                              2 * (du[i][0] * cv[j][0] + du[i][1] * cv[j][1] + du[i][2] * cv[j][2]),
                          16 * i + j);
        for (unsigned m = 0; m < top.n; ++m) {
            const unsigned i = top.id[m] / 16, j = top.id[m] % 16;
            std::array<double, 6> da{};
            for (unsigned c = 0; c < 3; ++c) da[c] = du[i][c], da[3 + c] = dv[j][c];
            tryNormals(p, esvo::encodeNormal(q.base(da)), uc[i] | (vc[j] << 16), s);
        }
    }
    // The lattice-line codes.
    if (s.error > codes.enough) tryLatticeLines(p, x, combo, s);
    polishCodes(p, s, codes);
    return s;
}

Dir toDir(const Vec3& v) { return {v[0], v[1], v[2]}; }
double dot(const Dir& a, const Dir& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Dir unit(const Dir& a) {
    const double len = std::sqrt(dot(a, a));
    return len > 0 ? Dir{a[0] / len, a[1] / len, a[2] / len} : a;
}
double det3(const Dir& a, const Dir& b, const Dir& c) {
    return a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
           a[2] * (b[0] * c[1] - b[1] * c[0]);
}

/// The model whose lattice points at @p pos (cu, cv; not collinear) are @p points.
Model modelThrough(const std::array<Dir, 3>& points,
                   const std::array<std::array<double, 2>, 3>& pos) {
    // Rows (1, cu, cv) of the three points; (b, u, v) = L⁻¹ · points, per coordinate.
    const Dir r0{1, pos[0][0], pos[0][1]}, r1{1, pos[1][0], pos[1][1]}, r2{1, pos[2][0], pos[2][1]};
    const double det = det3(r0, r1, r2);
    // Inverse by cofactors: column j of L⁻¹ is (r_{j+1} × r_{j+2}) / det.
    const auto cross = [](const Dir& a, const Dir& b) {
        return Dir{a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
    };
    const std::array<Dir, 3> col{cross(r1, r2), cross(r2, r0), cross(r0, r1)};
    Model x{};
    for (unsigned part = 0; part < 3; ++part)
        for (unsigned c = 0; c < 3; ++c)
            x[3 * part + c] = (col[0][part] * points[0][c] + col[1][part] * points[1][c] +
                               col[2][part] * points[2][c]) /
                              det;
    return x;
}

/// Models through the points λ1·r1 at cu = −1 and λ2·r2 at cu = 1 (v = 0).
Model modelOnLine(const Dir& r1, double l1, const Dir& r2, double l2) {
    Model x{};
    for (unsigned c = 0; c < 3; ++c) {
        x[c] = 0.5 * (l1 * r1[c] + l2 * r2[c]);
        x[3 + c] = 0.5 * (l2 * r2[c] - l1 * r1[c]);
    }
    return x;
}

constexpr std::array<std::array<double, 2>, 3> kTriangle{{{-1, -1}, {1, -1}, {-1, 1}}};

/// The corner of the triangle the lattice's right angle (−1, −1) takes: the representative whose
/// two others sum longest (keeps the base, their midpoint, away from zero).
unsigned rightAngle(const std::array<Dir, 4>& r, const std::array<unsigned, 3>& of) {
    unsigned best = 0;
    double longest = -1;
    for (unsigned j = 0; j < 3; ++j) {
        const Dir& a = r[of[(j + 1) % 3]];
        const Dir& b = r[of[(j + 2) % 3]];
        const Dir s{a[0] + b[0], a[1] + b[1], a[2] + b[2]};
        if (dot(s, s) > longest) longest = dot(s, s), best = j;
    }
    return best;
}

/// Up to six models through k = 2…4 representatives @p r (unit) of clusters of the normals.
unsigned modelsThrough(const std::array<Dir, 4>& r, unsigned k, std::array<Model, 6>& out) {
    unsigned count = 0;
    if (k == 2) {
        const double c = dot(r[0], r[1]);
        if (c > -0.95) out[count++] = modelOnLine(r[0], 1, r[1], 1);
        if (c < 0) {
            out[count++] = modelOnLine(r[0], 3, r[1], 1);
            out[count++] = modelOnLine(r[0], 1, r[1], 3);
        }
    } else if (k == 3) {
        const unsigned j = rightAngle(r, {0, 1, 2});
        out[count++] = modelThrough({r[j], r[(j + 1) % 3], r[(j + 2) % 3]}, kTriangle);
        // Collinear on the u axis when one lies between the other two: r_m = α·r_a + β·r_b, α, β >
        // 0, at cu = ±1/3 between λa·r_a at −1 and λb·r_b at 1.
        for (unsigned m = 0; m < 3; ++m) {
            const Dir& ra = r[(m + 1) % 3];
            const Dir& rb = r[(m + 2) % 3];
            const double aa = dot(ra, ra), ab = dot(ra, rb), bb = dot(rb, rb), am = dot(ra, r[m]),
                         bm = dot(rb, r[m]);
            const double det = aa * bb - ab * ab;
            if (!(det > 1e-6)) continue;
            const double alpha = (bb * am - ab * bm) / det, beta = (aa * bm - ab * am) / det;
            if (!(alpha > 0.05 && beta > 0.05)) continue;
            // At +1/3: λa = α, λb = β/2; at −1/3: λa = α/2, λb = β. The more even pair.
            if (2 * alpha / beta < 2 * beta / alpha)
                out[count++] = modelOnLine(ra, alpha, rb, 0.5 * beta);
            else
                out[count++] = modelOnLine(ra, 0.5 * alpha, rb, beta);
        }
    } else if (k == 4) {
        // The linear dependency Σ α_m r_m = 0.
        std::array<double, 4> alpha{det3(r[1], r[2], r[3]), -det3(r[0], r[2], r[3]),
                                    det3(r[0], r[1], r[3]), -det3(r[0], r[1], r[2])};
        double largest = 0;
        unsigned positive = 0;
        for (const double a : alpha) largest = std::max(largest, std::fabs(a)), positive += a > 0;
        bool degenerate = !(largest > 0);
        for (const double a : alpha) degenerate = degenerate || std::fabs(a) < 0.02 * largest;
        if (!degenerate) {
            if (positive == 1) {
                for (double& a : alpha) a = -a;
                positive = 3;
            }
            if (positive == 3) {
                // One inside the cone of the other three: the corners, and the odd one at (−⅓, −⅓).
                unsigned odd = 0;
                while (alpha[odd] > 0) ++odd;
                std::array<unsigned, 3> corners{};
                for (unsigned m = 0, n = 0; m < 4; ++m)
                    if (m != odd) corners[n++] = m;
                const unsigned j = rightAngle(r, corners);
                std::array<Dir, 3> points{};
                for (unsigned n = 0; n < 3; ++n) {
                    const unsigned m = corners[(j + n) % 3];
                    for (unsigned c = 0; c < 3; ++c)
                        points[n][c] = 3 * alpha[m] / largest * r[m][c];
                }
                out[count++] = modelThrough(points, kTriangle);
            } else if (positive == 2) {
                // Two pairs whose segments cross: the diagonals of the outer square.
                std::array<unsigned, 2> plus{}, minus{};
                for (unsigned m = 0, np = 0, nm = 0; m < 4; ++m)
                    if (alpha[m] > 0)
                        plus[np++] = m;
                    else
                        minus[nm++] = m;
                std::array<Dir, 3> points{};
                const std::array<unsigned, 3> at{plus[0], minus[0], minus[1]};
                for (unsigned n = 0; n < 3; ++n)
                    for (unsigned c = 0; c < 3; ++c)
                        points[n][c] = std::fabs(alpha[at[n]]) / largest * r[at[n]][c];
                out[count++] = modelThrough(points, kTriangle);
            }
        }
    }
    return count;
}

/// The used normal farthest from the normals' mean (the first of equals).
unsigned outermost(const NormalPoints& p) {
    Dir mean{};
    for (unsigned i = 0; i < p.count; ++i)
        for (unsigned c = 0; c < 3; ++c) mean[c] += p.multiplicity[i] * p.n[i][c];
    unsigned first = 0;
    for (unsigned i = 1; i < p.count; ++i)
        if (dot(toDir(p.n[i]), mean) < dot(toDir(p.n[first]), mean)) first = i;
    return first;
}

/// Clusters of the normals for k = 2…4 by farthest-point seeding (each seed the normal farthest
/// from those before, the first the outermost) and a few k-means steps; calls
/// @p use(representatives, k) for each k whose new seed is a distinct direction.
template <typename Use>
void forClusters(const NormalPoints& p, Use use) {
    std::array<Dir, 4> seed{};
    std::array<double, 16> nearest{};
    seed[0] = toDir(p.n[outermost(p)]);
    for (unsigned i = 0; i < p.count; ++i) nearest[i] = dot(toDir(p.n[i]), seed[0]);
    for (unsigned k = 1; k < 4; ++k) {
        unsigned far = 0;
        for (unsigned i = 1; i < p.count; ++i)
            if (nearest[i] < nearest[far]) far = i;
        if (!(nearest[far] < kDistinctCos)) return;  // no further cluster
        seed[k] = toDir(p.n[far]);
        for (unsigned i = 0; i < p.count; ++i)
            nearest[i] = std::max(nearest[i], dot(toDir(p.n[i]), seed[k]));
        std::array<Dir, 4> centre = seed;
        for (int iteration = 0; iteration < 3; ++iteration) {
            std::array<Dir, 4> sum{};
            for (unsigned i = 0; i < p.count; ++i) {
                const Dir n = toDir(p.n[i]);
                unsigned best = 0;
                for (unsigned j = 1; j <= k; ++j)
                    if (dot(n, centre[j]) > dot(n, centre[best])) best = j;
                for (unsigned c = 0; c < 3; ++c) sum[best][c] += p.multiplicity[i] * n[c];
            }
            for (unsigned j = 0; j <= k; ++j)
                if (dot(sum[j], sum[j]) > 0) centre[j] = unit(sum[j]);
        }
        use(centre, k + 1);
    }
}

/// A continuous candidate: its model, combos and error.
struct Candidate {
    Model x{};
    std::array<std::uint8_t, 16> combo{};
    double error = std::numeric_limits<double>::max();
};

/// The face-plane fit as a model.
Model planeModel(const NormalPoints& p, const PlaneFit& f) {
    const unsigned a = p.axis, ua = (a + 1) % 3, va = (a + 2) % 3;
    Model x{};
    x[a] = p.sign;
    x[ua] = f.bx;
    x[va] = f.by;
    x[3 + ua] = f.ux;
    x[3 + va] = f.uy;
    x[6 + ua] = f.vx;
    x[6 + va] = f.vy;
    return x;
}

/// The candidates refined at all (those with the smallest unrefined error) and the iterations
/// each gets; the iterations the best two get after that (narrow blocks: their one candidate,
/// the face-plane fit's). The second best is quantised too when its error is within
/// kSecondRatio of the best's, or when the best quantised lost more than kQuantisationLoss times
/// the second's error (some lattices quantise far worse than others equally good: two axes of
/// one size against one axis on a line).
constexpr int kFirstIterations = 2, kNarrowMoreIterations = 2;
constexpr double kSecondRatio = 1.5, kQuantisationLoss = 4;

/// Sorts @p c[0…count) by error (stable, so deterministic on ties).
void sortCandidates(std::array<Candidate, 10>& c, unsigned count) {
    std::stable_sort(c.begin(), c.begin() + count,
                     [](const Candidate& a, const Candidate& b) { return a.error < b.error; });
}

}  // namespace

NormalSpread normalSpread(const NormalPoints& p, bool countFew) {
    const Dir first = toDir(p.n[outermost(p)]);
    bool spread = false;
    for (unsigned i = 0; i < p.count; ++i) spread = spread || dot(toDir(p.n[i]), first) < kWideCos;
    bool few = false;
    if (!spread || countFew) {
        std::array<Dir, 5> distinct{};
        unsigned count = 0;
        for (unsigned i = 0; i < p.count && count <= 4; ++i) {
            const Dir n = toDir(p.n[i]);
            bool known = false;
            for (unsigned j = 0; j < count && !known; ++j)
                known = dot(n, distinct[j]) >= kDistinctCos;
            if (!known) distinct[count++] = n;
        }
        few = count <= 4;
    }
    return {spread, few};
}

void fit3d(const NormalPoints& p, const PlaneFit& f, bool wide, const NormalSearch& search,
           NormalState& s) {
    std::array<Candidate, 10> all{};
    unsigned count = 0;
    const auto consider = [&](Model x) {
        if (count == all.size() || !normaliseModel(x)) return;
        Candidate& c = all[count++];
        c.x = x;
        c.error = modelError(p, c.x, c.combo);
    };
    if (f.error < std::numeric_limits<double>::max()) consider(planeModel(p, f));
    if (wide)
        forClusters(p, [&](const std::array<Dir, 4>& r, unsigned k) {
            std::array<Model, 6> models{};
            const unsigned n = modelsThrough(r, k, models);
            for (unsigned m = 0; m < n; ++m) consider(models[m]);
        });
    sortCandidates(all, count);
    count = std::min(count, search.refined);
    for (unsigned i = 0; i < count; ++i)
        all[i].error = refineModel(p, all[i].x, all[i].combo, 3, kFirstIterations, all[i].error);
    sortCandidates(all, count);
    count = std::min(count, 2u);
    for (unsigned i = 0; i < count; ++i)
        all[i].error =
            refineModel(p, all[i].x, all[i].combo, 3,
                        wide ? search.moreIterations : kNarrowMoreIterations, all[i].error);
    sortCandidates(all, count);
    const double enough = search.enoughPerNormal * p.total;
    for (unsigned i = 0; i < count && s.error > enough; ++i) {
        if (i > 0 && (!search.second || (all[i].error > kSecondRatio * all[0].error &&
                                         !(s.error > kQuantisationLoss * all[i].error))))
            break;
        if (i > 0 && !(s.error > search.secondAbove * all[0].error)) break;
        CodeSearch codes = wide ? search.modelCodes
                                : (search.enumerateModel ? CodeSearch{} : search.narrowModelCodes);
        codes.enough = enough;
        const NormalState q =
            search.enumerateModel
                ? quantiseModelFast(p, all[i].x, all[i].combo, 3, codes)
                : quantiseModel(p, all[i].x, all[i].combo, wide && search.roundBothAxes, codes);
        if (q.error < s.error) s = q;
    }
}

}  // namespace vox::detail::encode
