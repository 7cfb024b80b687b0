// The normals' face-plane fit: the normals projected onto the plane of the cube face they
// share, and a 4×4 lattice b + cu·u + cv·v fitted to them there by alternating assignment and
// weighted least squares from several starts, unquantised or on the codes; then quantised.
#include "attribute_encode_internal.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>

namespace vox::detail::encode {
namespace {

/// Weighted least squares for b, u, v given the combos (ridge-regularised so that an axis no
/// combo varies along comes out zero).
void solvePlane(const NormalPoints& p, PlaneFit& f) {
    double m[3][3]{}, rx[3]{}, ry[3]{}, wsum = 0;
    for (unsigned i = 0; i < p.count; ++i) {
        const double row[3]{1.0, esvo::kAxisWeights[f.combo[i] & 3],
                            esvo::kAxisWeights[f.combo[i] >> 2]};
        const double w = p.weight[i];
        wsum += w;
        for (unsigned r = 0; r < 3; ++r) {
            for (unsigned c = 0; c < 3; ++c) m[r][c] += w * row[r] * row[c];
            rx[r] += w * row[r] * p.px[i];
            ry[r] += w * row[r] * p.py[i];
        }
    }
    const double ridge = 1e-7 * wsum;
    m[1][1] += ridge;
    m[2][2] += ridge;
    const double c00 = m[1][1] * m[2][2] - m[1][2] * m[2][1],
                 c01 = m[1][2] * m[2][0] - m[1][0] * m[2][2],
                 c02 = m[1][0] * m[2][1] - m[1][1] * m[2][0];
    const double det = m[0][0] * c00 + m[0][1] * c01 + m[0][2] * c02;
    if (!(std::fabs(det) > 1e-30)) return;
    // Inverse by cofactors (m is symmetric).
    const double inv[3][3]{
        {c00, c01, c02},
        {c01, m[0][0] * m[2][2] - m[0][2] * m[2][0], m[0][1] * m[2][0] - m[0][0] * m[2][1]},
        {c02, m[0][1] * m[2][0] - m[0][0] * m[2][1], m[0][0] * m[1][1] - m[0][1] * m[1][0]}};
    double sx[3], sy[3];
    for (unsigned r = 0; r < 3; ++r) {
        sx[r] = (inv[r][0] * rx[0] + inv[r][1] * rx[1] + inv[r][2] * rx[2]) / det;
        sy[r] = (inv[r][0] * ry[0] + inv[r][1] * ry[1] + inv[r][2] * ry[2]) / det;
    }
    f.bx = static_cast<float>(sx[0]);
    f.by = static_cast<float>(sy[0]);
    f.ux = static_cast<float>(sx[1]);
    f.uy = static_cast<float>(sy[1]);
    f.vx = static_cast<float>(sx[2]);
    f.vy = static_cast<float>(sy[2]);
}

/// Alternates assignment and least squares from the start in @p f until the combos settle.
void fitPlane(const NormalPoints& p, PlaneFit& f) {
    assignPlane(p, f);
    for (int iteration = 0; iteration < 12; ++iteration) {
        solvePlane(p, f);
        if (!assignPlane(p, f)) break;
    }
}

/// What esvo::encodeAxis rounds the axis (0, @p x, @p y) (in the face plane's two components) to,
/// decoded: the same exponent and the same rounding (half away from zero, clamped to −8 … 7),
/// without the library calls, for the face-plane fit's every iteration.
inline std::array<float, 2> roundedPlaneAxis(float x, float y) {
    const float step = axisStep(axisExponent(std::min({x, y, 0.0f}), std::max({x, y, 0.0f})));
    const auto digit = [step](float v) {
        const float q = v / step;
        if (!(q > -8.5f)) return -8.0f;  // (also NaN, as lround's LONG_MIN clamped)
        if (!(q < 7.5f)) return 7.0f;
        const float t = static_cast<float>(static_cast<int>(q));  // truncation, exact here
        return q - t >= 0.5f ? t + 1 : (q - t <= -0.5f ? t - 1 : t);
    };
    return {digit(x) * step, digit(y) * step};
}

/// The base code of a face-plane point (bx, by): the cube-face point (±1 on the face's axis),
/// through encodeNormal; @p scale gets the factor that takes the fit's axes to that base's
/// scale, 1 unless the point falls off the face (a component beyond ±1).
std::uint32_t planeBase(const NormalPoints& p, float bx, float by, float& scale) {
    const unsigned a = p.axis, ua = (a + 1) % 3, va = (a + 2) % 3;
    Vec3 b{};
    b[a] = p.sign;
    b[ua] = bx;
    b[va] = by;
    scale = 1.0f / std::max({1.0f, std::fabs(bx), std::fabs(by)});
    return esvo::encodeNormal(b);
}

/// The axis codes (word 4) of a face-plane fit's axes at @p scale (planeBase's).
std::uint32_t planeAxes(const NormalPoints& p, const PlaneFit& f, float scale) {
    const unsigned ua = (p.axis + 1) % 3, va = (p.axis + 2) % 3;
    Vec3 u{}, v{};
    u[ua] = f.ux * scale;
    u[va] = f.uy * scale;
    v[ua] = f.vx * scale;
    v[va] = f.vy * scale;
    return esvo::encodeAxis(u) | (esvo::encodeAxis(v) << 16);
}

/// fitPlane on the codes: after each least-squares solve the axes are rounded to what their
/// codes decode to and the base refit to them (the weighted mean of p − cu·u − cv·v), so that
/// the alternation settles where a quantised lattice fits rather than where an unquantised one
/// does, which quantising then spoils (on the real blocks of four scenes its lattices are
/// 2–7 % closer than the least-squares fit's quantised by enumeration, from fewer starts).
void fitPlaneOnCodes(const NormalPoints& p, PlaneFit& f) {
    assignPlane(p, f);
    for (int iteration = 0; iteration < 12; ++iteration) {
        solvePlane(p, f);
        // (planeBase's scale and planeAxes' codes, decoded.)
        const float scale = 1.0f / std::max({1.0f, std::fabs(f.bx), std::fabs(f.by)});
        const auto u = roundedPlaneAxis(f.ux * scale, f.uy * scale),
                   v = roundedPlaneAxis(f.vx * scale, f.vy * scale);
        f.ux = u[0] / scale;
        f.uy = u[1] / scale;
        f.vx = v[0] / scale;
        f.vy = v[1] / scale;
        double sx = 0, sy = 0, sw = 0;
        for (unsigned i = 0; i < p.count; ++i) {
            const float cu = esvo::kAxisWeights[f.combo[i] & 3],
                        cv = esvo::kAxisWeights[f.combo[i] >> 2];
            const double w = p.weight[i];
            sx += w * (p.px[i] - cu * f.ux - cv * f.vx);
            sy += w * (p.py[i] - cu * f.uy - cv * f.vy);
            sw += w;
        }
        f.bx = static_cast<float>(sx / sw);
        f.by = static_cast<float>(sy / sw);
        if (!assignPlane(p, f)) break;
    }
}

/// The face plane's frame of a block's normals: the principal axes (e1, e2 = e1 turned by 90°)
/// and half-extents h1, h2 of the projected points about the centre of their bounding box in
/// that frame, from which the face-plane fit's starts are built.
struct PlaneFrame {
    double cx = 0, cy = 0, e1x = 1, e1y = 0, h1 = 0, h2 = 0;
    unsigned startCount = 1;  ///< how many of the starts (planeStart) apply
};

/// Picks the face (the dominant axis of the mean normal, of the first normal if they cancel),
/// projects the normals onto its plane (setting p's axis, sign, px, py and weight) and returns
/// the frame of the projected points.
PlaneFrame projectNormals(NormalPoints& p) {
    Vec3 mean{};
    for (unsigned i = 0; i < p.count; ++i)
        for (unsigned c = 0; c < 3; ++c) mean[c] += p.multiplicity[i] * p.n[i][c];
    if (!(mean[0] * mean[0] + mean[1] * mean[1] + mean[2] * mean[2] >
          1e-6f * static_cast<float>(p.total * p.total)))
        mean = p.n[0];
    const float ax = std::fabs(mean[0]), ay = std::fabs(mean[1]), az = std::fabs(mean[2]);
    p.axis = ax >= ay && ax >= az ? 0u : (ay >= az ? 1u : 2u);
    p.sign = mean[p.axis] < 0 ? -1.0f : 1.0f;
    const unsigned a = p.axis, ua = (a + 1) % 3, va = (a + 2) % 3;

    // Project onto the face plane. Normals further than ~78° from the face axis (beyond 90° they
    // have no projection) are pushed out to that radius in their in-plane direction.
    constexpr float kMinDot = 0.2f;
    for (unsigned i = 0; i < p.count; ++i) {
        const float d = p.sign * p.n[i][a];
        float x = p.n[i][ua], y = p.n[i][va];
        if (d >= kMinDot) {
            x /= d;
            y /= d;
        } else {
            const float len = std::sqrt(x * x + y * y);
            const float s = len > 0 ? 1.0f / (kMinDot * len) : 0.0f;
            x *= s;
            y *= s;
        }
        p.px[i] = x;
        p.py[i] = y;
        // A step in the plane turns the normal by about cos² (radially) to cos (tangentially).
        const float c = std::max(d, kMinDot);
        p.weight[i] = c * c * c * p.multiplicity[i];
    }

    // Principal axes of the projected points.
    double wsum = 0, mx = 0, my = 0;
    for (unsigned i = 0; i < p.count; ++i) {
        wsum += p.weight[i];
        mx += p.weight[i] * p.px[i];
        my += p.weight[i] * p.py[i];
    }
    mx /= wsum;
    my /= wsum;
    double sxx = 0, sxy = 0, syy = 0;
    for (unsigned i = 0; i < p.count; ++i) {
        const double dx = p.px[i] - mx, dy = p.py[i] - my;
        sxx += p.weight[i] * dx * dx;
        sxy += p.weight[i] * dx * dy;
        syy += p.weight[i] * dy * dy;
    }
    const double half = 0.5 * (sxx - syy);
    const double l1 = 0.5 * (sxx + syy) + std::sqrt(half * half + sxy * sxy);
    PlaneFrame fr;
    if (std::fabs(sxy) > 1e-12 * (sxx + syy)) {
        fr.e1x = sxy;
        fr.e1y = l1 - sxx;
        const double len = std::sqrt(fr.e1x * fr.e1x + fr.e1y * fr.e1y);
        fr.e1x /= len;
        fr.e1y /= len;
    } else if (syy > sxx) {
        fr.e1x = 0;
        fr.e1y = 1;
    }
    const double e2x = -fr.e1y, e2y = fr.e1x;
    double t1lo = 0, t1hi = 0, t2lo = 0, t2hi = 0;
    for (unsigned i = 0; i < p.count; ++i) {
        const double dx = p.px[i] - mx, dy = p.py[i] - my;
        const double t1 = dx * fr.e1x + dy * fr.e1y, t2 = dx * e2x + dy * e2y;
        t1lo = std::min(t1lo, t1);
        t1hi = std::max(t1hi, t1);
        t2lo = std::min(t2lo, t2);
        t2hi = std::max(t2hi, t2);
    }
    fr.cx = mx + fr.e1x * 0.5 * (t1lo + t1hi) + e2x * 0.5 * (t2lo + t2hi);
    fr.cy = my + fr.e1y * 0.5 * (t1lo + t1hi) + e2y * 0.5 * (t2lo + t2hi);
    fr.h1 = 0.5 * (t1hi - t1lo);
    fr.h2 = 0.5 * (t2hi - t2lo);
    fr.startCount = !(fr.h1 > 1e-6) ? 1 : (fr.h2 < 0.5 * fr.h1 ? 6 : 5);  // equal normals need one
    return fr;
}

/// Start @p i of the face-plane fit (the alternation only finds a local optimum): 4×4 lattices
/// along the principal axes at three scales (0: ¾ of the extent, 1: 0.4, 2: all of it) and
/// turned by 45° at two (3: 0.4, 4: all), and for nearly one-dimensional sets (5) 16 levels along
/// the principal axis (u = ¾ h1 and v = 3⁄16 h1 interleave).
PlaneFit planeStart(const PlaneFrame& fr, unsigned i) {
    const double diagonal = std::sqrt(0.5), h1 = fr.h1, h2 = fr.h2;
    struct Start {
        double u1, u2, v1, v2;  // u and v in the principal frame (e1, e2)
    };
    const Start starts[] = {
        {0.75 * h1, 0, 0, 0.75 * h2},
        {0.4 * h1, 0, 0, 0.4 * h2},
        {h1, 0, 0, h2},
        {0.4 * diagonal * h1, 0.4 * diagonal * h2, -0.4 * diagonal * h1, 0.4 * diagonal * h2},
        {diagonal * h1, diagonal * h2, -diagonal * h1, diagonal * h2},
        {0.75 * h1, 0, 0.1875 * h1, 0}};
    const Start& st = starts[i];
    const double e2x = -fr.e1y, e2y = fr.e1x;
    PlaneFit fit;
    fit.bx = static_cast<float>(fr.cx);
    fit.by = static_cast<float>(fr.cy);
    fit.ux = static_cast<float>(st.u1 * fr.e1x + st.u2 * e2x);
    fit.uy = static_cast<float>(st.u1 * fr.e1y + st.u2 * e2y);
    fit.vx = static_cast<float>(st.v1 * fr.e1x + st.v2 * e2x);
    fit.vy = static_cast<float>(st.v1 * fr.e1y + st.v2 * e2y);
    return fit;
}

}  // namespace

NormalState planeCodes(const NormalPoints& p, const PlaneFit& f) {
    NormalState s;
    float scale = 1;
    s.base = planeBase(p, f.bx, f.by, scale);
    s.axes = planeAxes(p, f, scale);
    return s;
}

NormalState quantiseFit(const NormalPoints& p, const PlaneFit& f) {
    const unsigned a = p.axis, ua = (a + 1) % 3, va = (a + 2) % 3;
    const auto toBase = [&](float bx, float by, float& scale) {
        return planeBase(p, bx, by, scale);
    };
    float scale = 1;
    const std::uint32_t base = toBase(f.bx, f.by, scale);
    NormalState s;
    tryNormals(p, base, planeAxes(p, f, scale), s);
    if (s.error <= 0) return s;

    // Base refit: with the axes fixed at their quantised values, the best base for the combos is
    // the weighted mean of p − cu·u − cv·v (in the face plane, where the rescaled axes live ×
    // 1/scale).
    for (int round = 0; round < 2; ++round) {
        const Vec3 qu = esvo::decodeAxis(s.axes & 0xFFFFu), qv = esvo::decodeAxis(s.axes >> 16);
        const Vec3 qb = esvo::decodeNormal(s.base);
        const float k = 1.0f / std::fabs(qb[a]);  // back to the face plane of the fit
        double sx = 0, sy = 0, sw = 0;
        for (unsigned i = 0; i < p.count; ++i) {
            const float cu = esvo::kAxisWeights[s.combo[i] & 3],
                        cv = esvo::kAxisWeights[s.combo[i] >> 2];
            const double w = p.weight[i];
            sx += w * (p.px[i] - k * (cu * qu[ua] + cv * qv[ua]));
            sy += w * (p.py[i] - k * (cu * qu[va] + cv * qv[va]));
            sw += w;
        }
        float refitScale = 1;
        const std::uint32_t refit =
            toBase(static_cast<float>(sx / sw), static_cast<float>(sy / sw), refitScale);
        if (!tryNormals(p, refit, s.axes, s)) break;
    }

    // Neighbouring axis codes: each in-plane component ±1, and each axis one exponent finer or
    // coarser (re-rounded).
    const std::array<unsigned, 2> inPlane{ua, va};
    for (int pass = 0; pass < 3 && s.error > 0; ++pass)
        if (!stepAxisCodes(p, s, inPlane)) break;

    // Cluster-fit step: the unquantised least squares for the combos the quantised block chose,
    // quantised again.
    for (int round = 0; round < 2; ++round) {
        PlaneFit g = f;
        g.combo = s.combo;
        solvePlane(p, g);
        float refitScale = 1;
        const std::uint32_t refitBase = toBase(g.bx, g.by, refitScale);
        if (!tryNormals(p, refitBase, planeAxes(p, g, refitScale), s)) break;
    }
    return s;
}

PlaneFit fitNormals(NormalPoints& p, unsigned startMask, bool onCodes, double enough) {
    const PlaneFrame fr = projectNormals(p);
    PlaneFit best;
    for (unsigned i = 0; i < fr.startCount; ++i) {
        if (i > 0 && !((startMask >> i) & 1u)) continue;
        PlaneFit fit = planeStart(fr, i);
        if (onCodes)
            fitPlaneOnCodes(p, fit);
        else
            fitPlane(p, fit);
        if (fit.error < best.error) best = fit;
        if (i == 0 && fit.error <= enough) break;
    }
    return best;
}

}  // namespace vox::detail::encode
