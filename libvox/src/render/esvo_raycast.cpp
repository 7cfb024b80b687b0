// The reference ray caster: Laine & Karras' traversal (tech report section 6 and appendix A),
// written against libvox's block layout. Octree coordinates are [1,2]³ so that POP can read the
// cube position off the float bit patterns.
#include <vox/base/error.h>
#include <vox/formats/esvo_attributes.h>
#include <vox/raycast.h>

#include "esvo_traversal.h"

#include <tbb/blocked_range.h>
#include <tbb/blocked_range2d.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>

namespace vox {

// ---- camera ----------------------------------------------------------------------------------

// ---- ray caster ------------------------------------------------------------------------------

EsvoRayCaster::EsvoRayCaster(const esvo::EsvoPool& pool) : pool_(pool) {
    const auto& m = pool.reader().header().worldToRoot;
    for (int i = 0; i < 12; ++i) a_[i] = m[i];
    const double det = a_[0] * (a_[5] * a_[10] - a_[6] * a_[9]) -
                       a_[1] * (a_[4] * a_[10] - a_[6] * a_[8]) +
                       a_[2] * (a_[4] * a_[9] - a_[5] * a_[8]);
    if (!(std::abs(det) > 0))
        throw InvalidDataError(pool.reader().path(), "header: world-to-root transform is singular");
    unitScale_ = std::cbrt(std::abs(det));
    rowNorm_ = 0;
    for (int i = 0; i < 3; ++i)
        rowNorm_ =
            std::max(rowNorm_, std::sqrt(a_[4 * i] * a_[4 * i] + a_[4 * i + 1] * a_[4 * i + 1] +
                                         a_[4 * i + 2] * a_[4 * i + 2]));
    leafSize_ = std::ldexp(1.0, -static_cast<int>(pool.reader().header().leafDepth)) / unitScale_;
}

bool EsvoRayCaster::start(const Ray& ray, const CastOptions& options,
                          detail::TraversalStart& s) const {
    constexpr float epsilon = 0x1p-23f;  // 2^-kScaleMax
    // To octree coordinates [1,2]³; t stays the world distance because the direction is
    // transformed without renormalising.
    const auto& o = ray.origin;
    const auto& dw = ray.direction;
    s.px = static_cast<float>(a_[0] * o.x + a_[1] * o.y + a_[2] * o.z + a_[3] + 1.0);
    s.py = static_cast<float>(a_[4] * o.x + a_[5] * o.y + a_[6] * o.z + a_[7] + 1.0);
    s.pz = static_cast<float>(a_[8] * o.x + a_[9] * o.y + a_[10] * o.z + a_[11] + 1.0);
    float dx = static_cast<float>(a_[0] * dw.x + a_[1] * dw.y + a_[2] * dw.z);
    float dy = static_cast<float>(a_[4] * dw.x + a_[5] * dw.y + a_[6] * dw.z);
    float dz = static_cast<float>(a_[8] * dw.x + a_[9] * dw.y + a_[10] * dw.z);
    if (std::abs(dx) < epsilon) dx = std::copysign(epsilon, dx);
    if (std::abs(dy) < epsilon) dy = std::copysign(epsilon, dy);
    if (std::abs(dz) < epsilon) dz = std::copysign(epsilon, dz);
    s.dx = dx, s.dy = dy, s.dz = dz;

    // t(x) = x·coef − bias, mirrored so that every direction component is negative.
    s.txCoef = 1.0f / -std::abs(dx), s.tyCoef = 1.0f / -std::abs(dy),
    s.tzCoef = 1.0f / -std::abs(dz);
    s.txBias = s.txCoef * s.px, s.tyBias = s.tyCoef * s.py, s.tzBias = s.tzCoef * s.pz;
    s.octantMask = 7;
    if (dx > 0.0f) s.octantMask ^= 1, s.txBias = 3.0f * s.txCoef - s.txBias;
    if (dy > 0.0f) s.octantMask ^= 2, s.tyBias = 3.0f * s.tyCoef - s.tyBias;
    if (dz > 0.0f) s.octantMask ^= 4, s.tzBias = 3.0f * s.tzCoef - s.tzBias;

    float tMin = std::max(
        {2.0f * s.txCoef - s.txBias, 2.0f * s.tyCoef - s.tyBias, 2.0f * s.tzCoef - s.tzBias});
    float tMax = std::min({s.txCoef - s.txBias, s.tyCoef - s.tyBias, s.tzCoef - s.tzBias});
    tMin = std::max(tMin, std::max(options.tStart, 0.0f));
    tMax = std::min(tMax, static_cast<float>(std::min(options.tMax, 3.0e38)));
    // The span only shrinks from here (tMin never decreases, tMax never exceeds this), so an
    // empty one is a miss: a ray beside the cube, or a beam start past everything.
    if (!(tMin <= tMax)) return false;
    s.tMin = tMin, s.tMax = tMax;
    // Footprint of a pixel at distance t, in root-cube units: t·lodCoef.
    s.lodCoef = static_cast<float>(options.lodAngle * unitScale_);
    s.idx = 0;
    s.posX = 1.0f, s.posY = 1.0f, s.posZ = 1.0f;
    if (1.5f * s.txCoef - s.txBias > tMin) s.idx ^= 1, s.posX = 1.5f;
    if (1.5f * s.tyCoef - s.tyBias > tMin) s.idx ^= 2, s.posY = 1.5f;
    if (1.5f * s.tzCoef - s.tzBias > tMin) s.idx ^= 4, s.posZ = 1.5f;
    return true;
}

CastHit EsvoRayCaster::cast(const Ray& ray, const CastOptions& options) const {
    if (options.beamRadius > 0) return castBeam(ray, options);
    using detail::kScaleMax;
    detail::TraversalStart s;
    if (!start(ray, options, s)) return CastHit{};
    const std::uint32_t* words = pool_.words();
    struct StackEntry {
        std::uint32_t parent;
        float tMax;
    } stack[kScaleMax + 1];

    const float px = s.px, py = s.py, pz = s.pz, dx = s.dx, dy = s.dy, dz = s.dz;
    const float txCoef = s.txCoef, tyCoef = s.tyCoef, tzCoef = s.tzCoef, txBias = s.txBias,
                tyBias = s.tyBias, tzBias = s.tzBias;
    const float lodCoef = s.lodCoef;
    const int octantMask = s.octantMask;
    float tMin = s.tMin, tMax = s.tMax;
    int idx = s.idx;
    float posX = s.posX, posY = s.posY, posZ = s.posZ;

    detail::TraversalStop stop;
    std::uint32_t parent = pool_.rootDescriptorWord();
    std::uint32_t descriptor = 0, descriptor2 = 0;  // the parent's two words: topology, contours
    bool haveDescriptor = false;
    int scale = kScaleMax - 1;
    float scaleExp2 = 0.5f;
    while (scale < kScaleMax) {
        ++stop.iterations;
        if (!haveDescriptor) {
            descriptor = words[parent];
            descriptor2 = words[parent + 1];
            haveDescriptor = true;
        }
        const float txCorner = posX * txCoef - txBias;
        const float tyCorner = posY * tyCoef - tyBias;
        const float tzCorner = posZ * tzCoef - tzBias;
        const float tcMax = std::min({txCorner, tyCorner, tzCorner});

        const int slot = idx ^ octantMask ^ 7;  // the child slot in unmirrored space
        const bool valid = (descriptor >> (8 + slot)) & 1u;
        if (valid && tMin <= tMax) {
            const auto level = static_cast<std::uint32_t>(kScaleMax - scale);
            if (lodCoef > 0 && tcMax * lodCoef >= scaleExp2) {  // voxel smaller than the pixel
                stop.hit = true;
                stop.level = level;
                stop.hitSlot = slot;
                break;
            }
            float tvMax = std::min(tMax, tcMax);
            const float half = scaleExp2 * 0.5f;
            // The centre planes are evaluated exactly as the children's corners will be
            // (position · coef − bias), not as half · coef + corner: then the child PUSH picks
            // is the one ADVANCE walks through at tMin, bit for bit, which is what makes a
            // traversal started at tStart reproduce the one started at 0 (see castBeam).
            const float txCenter = (posX + half) * txCoef - txBias;
            const float tyCenter = (posY + half) * tyCoef - tyBias;
            const float tzCenter = (posZ + half) * tzCoef - tzBias;
            // Contour: the voxel's slab, in its local coordinates u = (p − centre) / size.
            float tvMin = tMin;
            bool fromSlab = false;
            Vec3f slabN{0, 0, 0};
            if (options.contours && ((descriptor2 >> slot) & 1u)) {
                const std::uint32_t pointer = descriptor2 >> 8;
                const esvo::Contour c = esvo::Contour::decode(
                    words[parent + pointer + esvo::popc8(descriptor2 & ((1u << slot) - 1u))]);
                // Unmirrored centre of this voxel (a mirrored axis runs 3 − x).
                const float cx = (octantMask & 1) ? posX + half : 3.0f - posX - half;
                const float cy = (octantMask & 2) ? posY + half : 3.0f - posY - half;
                const float cz = (octantMask & 4) ? posZ + half : 3.0f - posZ - half;
                const float nd = float(c.nx) * dx + float(c.ny) * dy + float(c.nz) * dz;
                const float no =
                    float(c.nx) * (px - cx) + float(c.ny) * (py - cy) + float(c.nz) * (pz - cz);
                const float centreOffset =
                    scaleExp2 * float(c.position) * float(esvo::Contour::kStep);
                const float halfThickness =
                    scaleExp2 * float(c.thickness) * float(esvo::Contour::kStep) * 0.5f;
                const float lo = centreOffset - halfThickness - no,
                            hi = centreOffset + halfThickness - no;  // nd·t ∈ [lo, hi]
                if (nd != 0.0f) {
                    float t0 = lo / nd, t1 = hi / nd;
                    if (nd < 0.0f) std::swap(t0, t1);
                    if (t0 > tvMin) {
                        tvMin = t0;
                        fromSlab = true;
                        const float sign = nd > 0.0f ? -1.0f : 1.0f;  // face the ray
                        slabN = {sign * float(c.nx), sign * float(c.ny), sign * float(c.nz)};
                    }
                    tvMax = std::min(tvMax, t1);
                } else if (lo > 0.0f || hi < 0.0f) {
                    tvMax = -1.0f;  // parallel to the slab and outside it
                }
            }
            if (tvMin <= tvMax) {
                bool leaf = !((descriptor >> slot) & 1u) || level >= options.maxLevel;
                std::int32_t offset = static_cast<std::int32_t>(descriptor >> 17);
                if (!leaf && (descriptor & 0x10000u)) {
                    offset = static_cast<std::int32_t>(
                        words[parent + 2 * static_cast<std::uint32_t>(offset)]);
                    leaf =
                        offset == 0;  // child slice not loaded: this is the finest level there is
                }
                if (fromSlab) stop.slabT = tvMin, stop.slabNormal = slabN;
                if (leaf) {
                    stop.hit = true;
                    stop.level = level;
                    stop.hitSlot = slot;
                    tMin = tvMin;
                    break;
                }
                // PUSH
                // Always written. The paper skips the store when the child exits with its parent
                // (tcMax >= h), as no POP can then land on this scale; but when distinct planes
                // round to the same float t (rays from hundreds of root cubes away into a deep
                // octree) a POP can, and would read a stale entry or none. One store per PUSH.
                stack[scale] = {parent, tMax};
                offset += static_cast<std::int32_t>(esvo::popc8(descriptor & ((1u << slot) - 1u)));
                parent = static_cast<std::uint32_t>(static_cast<std::int64_t>(parent) +
                                                    2 * static_cast<std::int64_t>(offset));
                idx = 0;
                --scale;
                scaleExp2 = half;
                tMin = tvMin;  // the span carries this voxel's slab down to its children
                tMax = tvMax;
                if (txCenter > tMin) idx ^= 1, posX += scaleExp2;
                if (tyCenter > tMin) idx ^= 2, posY += scaleExp2;
                if (tzCenter > tMin) idx ^= 4, posZ += scaleExp2;
                haveDescriptor = false;
                continue;
            }
        }

        // ADVANCE
        int stepMask = 0;
        if (txCorner <= tcMax) stepMask ^= 1, posX -= scaleExp2;
        if (tyCorner <= tcMax) stepMask ^= 2, posY -= scaleExp2;
        if (tzCorner <= tcMax) stepMask ^= 4, posZ -= scaleExp2;
        tMin = tcMax;
        idx ^= stepMask;
        if ((idx & stepMask) != 0) {
            // POP: the highest bit where the old and new positions differ gives the scale.
            std::uint32_t differing = 0;
            if (stepMask & 1)
                differing |= std::bit_cast<std::uint32_t>(posX) ^
                             std::bit_cast<std::uint32_t>(posX + scaleExp2);
            if (stepMask & 2)
                differing |= std::bit_cast<std::uint32_t>(posY) ^
                             std::bit_cast<std::uint32_t>(posY + scaleExp2);
            if (stepMask & 4)
                differing |= std::bit_cast<std::uint32_t>(posZ) ^
                             std::bit_cast<std::uint32_t>(posZ + scaleExp2);
            scale = static_cast<int>(std::bit_cast<std::uint32_t>(static_cast<float>(differing)) >>
                                     23) -
                    127;
            if (scale >= kScaleMax) break;
            scaleExp2 =
                std::bit_cast<float>(static_cast<std::uint32_t>(scale - kScaleMax + 127) << 23);
            parent = stack[scale].parent;
            tMax = stack[scale].tMax;
            const std::uint32_t shx = std::bit_cast<std::uint32_t>(posX) >> scale;
            const std::uint32_t shy = std::bit_cast<std::uint32_t>(posY) >> scale;
            const std::uint32_t shz = std::bit_cast<std::uint32_t>(posZ) >> scale;
            posX = std::bit_cast<float>(shx << scale);
            posY = std::bit_cast<float>(shy << scale);
            posZ = std::bit_cast<float>(shz << scale);
            idx = static_cast<int>((shx & 1u) | ((shy & 1u) << 1) | ((shz & 1u) << 2));
            haveDescriptor = false;
        }
    }
    if (!stop.hit) {
        CastHit miss;
        miss.iterations = stop.iterations;
        return miss;
    }
    stop.t = tMin;
    stop.scale = scale;
    stop.scaleExp2 = scaleExp2;
    stop.posX = posX, stop.posY = posY, stop.posZ = posZ;
    stop.parent = parent;
    return finish(s, stop, options, &stack[0].parent, sizeof(StackEntry) / sizeof(std::uint32_t));
}

void EsvoRayCaster::castMany(const Ray* rays, const float* tStarts, std::size_t count,
                             const CastOptions& options, CastHit* hits) const {
    if (options.beamRadius > 0) throw UsageError("castMany: beamRadius must be 0");
    // The lanes index words with signed 32-bit gathers.
    if (detail::LaneCaster::available() && pool_.wordCount() < (std::size_t{1} << 31))
        return detail::LaneCaster::cast(*this, rays, tStarts, count, options, hits);
    CastOptions rayOptions = options;
    for (std::size_t i = 0; i < count; ++i) {
        if (tStarts) rayOptions.tStart = std::max(options.tStart, tStarts[i]);
        hits[i] = cast(rays[i], rayOptions);
    }
}

CastHit EsvoRayCaster::finish(const detail::TraversalStart& s, const detail::TraversalStop& stop,
                              const CastOptions& options, const std::uint32_t* stackParent,
                              std::size_t stackStride) const {
    using detail::kScaleMax;
    CastHit result;
    result.hit = true;
    result.t = stop.t;
    result.level = stop.level;
    result.iterations = stop.iterations;
    // The face the ray entered through: the axis whose entry plane it crossed last, or the
    // contour plane if that is where the span began.
    const float txEntry = (stop.posX + stop.scaleExp2) * s.txCoef - s.txBias;
    const float tyEntry = (stop.posY + stop.scaleExp2) * s.tyCoef - s.tyBias;
    const float tzEntry = (stop.posZ + stop.scaleExp2) * s.tzCoef - s.tzBias;
    Vec3d n{0, 0, 0};
    if (stop.slabT == stop.t && stop.slabT >= std::max({txEntry, tyEntry, tzEntry}))
        n = {stop.slabNormal.x, stop.slabNormal.y, stop.slabNormal.z};
    else if (txEntry >= tyEntry && txEntry >= tzEntry)
        n.x = s.dx > 0 ? -1 : 1;
    else if (tyEntry >= tzEntry)
        n.y = s.dy > 0 ? -1 : 1;
    else
        n.z = s.dz > 0 ? -1 : 1;
    // Normals transform with the inverse transpose; for libvox's uniform scale this is n itself,
    // but a general affine header is allowed.
    const Vec3d nw{a_[0] * n.x + a_[4] * n.y + a_[8] * n.z, a_[1] * n.x + a_[5] * n.y + a_[9] * n.z,
                   a_[2] * n.x + a_[6] * n.y + a_[10] * n.z};
    const Vec3d nn = normalize(nw);
    result.normal = {static_cast<float>(nn.x), static_cast<float>(nn.y), static_cast<float>(nn.z)};

    if (options.attributes) {
        // The hit voxel is child hitSlot of `parent`; where its value is omitted it inherits its
        // parent voxel's: child (position bits at that scale) of the descriptor the stack holds.
        const std::uint32_t* words = pool_.words();
        std::uint32_t descriptorWord = stop.parent;
        int slot = stop.hitSlot;
        for (int sc = stop.scale;;) {
            esvo::AttributeValue value;
            if (esvo::readAttribute(words, descriptorWord, static_cast<std::uint32_t>(slot),
                                    value)) {
                result.hasAttributes = true;
                result.color = value.color;
                result.shadingNormal = {value.normal[0], value.normal[1], value.normal[2]};
                break;
            }
            if (++sc >= kScaleMax) break;  // the root's own value is stored nowhere
            descriptorWord = stackParent[std::size_t(sc) * stackStride];
            const int idxAbove =
                static_cast<int>(((std::bit_cast<std::uint32_t>(stop.posX) >> sc) & 1u) |
                                 (((std::bit_cast<std::uint32_t>(stop.posY) >> sc) & 1u) << 1) |
                                 (((std::bit_cast<std::uint32_t>(stop.posZ) >> sc) & 1u) << 2));
            slot = idxAbove ^ s.octantMask ^ 7;
        }
    }
    return result;
}

// ---- beam optimisation: the coarse pass ---------------------------------------------------
//
// Why the image stays bit for bit the same (the fine pass, cast() with tStart):
//
// 1. Let P_a(p) = p·coef_a − bias_a be the float t at which the (mirrored) ray crosses the plane
//    at coordinate p of axis a. cast() evaluates every plane it compares this one way, the cell
//    corners in ADVANCE and the centres in PUSH alike, so P_a is a fixed, monotone function of p
//    (as long as the compiler rounds every instance alike: no FMA on baseline x86-64; a build
//    that contracted some instances and not others would show up in tests/test_esvo_beam.cpp).
//    By induction over PUSH, ADVANCE and POP, the span start tMin at the current cell X is
//        tMin = max(P-entries of X, slab entries of X's ancestors, T0),   T0 = max(tStart, 0),
//    and every corner of X is >= tMin: the traversal from T0 only raises each cell's tMin to
//    max(tMin, T0), and the cell PUSH picks at T0 is exactly the one ADVANCE passes through there.
// 2. So started at T0 < t (the hit distance of the ray started at 0), the traversal visits the
//    same cells after T0 with spans that are never wider, cannot stop anywhere the full traversal
//    does not, reaches the hit cell with the same span start max(t, T0) = t, records the same
//    contour (any slab start it skips is <= T0 < t) and so returns the same t, level and normal.
//    A miss stays a miss for any T0. T0 must be strictly below t: at T0 = t a cell the full
//    traversal hits over a zero-length span could be skipped. The stack is written on every
//    PUSH, so what a POP reads does not depend on the path that led there.
// 3. The hit distance t of a fine ray lies within its hit cell X's float entry and exit planes,
//    so the exact point of the float ray at t is inside X grown by eta = u·(18 + 4|p|) per axis
//    (u = 2^-24, p the float origin), whatever the direction: the rounding of P_a is relative to
//    |p|·|coef_a| and coef_a = 1/|d_a|. The same holds where the ray leaves X (tcMax), which the
//    level-of-detail cut compares.
// 4. A coarse ray with the same origin and a unit direction within chord r of the fine ray's is,
//    at the same t, within t·(r·rowNorm + rounding and clamping of the fine direction) +
//    origin rounding of the fine ray's point, per axis in octree units. So it is inside X dilated
//    by w(t) = k·t + e at the fine ray's hit distance, and at the fine ray's exit from X.
//    castBeam() finds the smallest t at which it enters a dilated cell at which some fine ray of
//    the beam could stop: a leaf, a maxLevel voxel, a voxel whose children are not loaded, or one
//    where the level-of-detail cut could fire (exit of the dilated cell · lodCoef >= size, with
//    slack). A dilated child lies inside its dilated parent, so the descent loses nothing, and
//    contours only shrink spans, so ignoring them only lowers the bound. The result is <= every
//    fine hit distance of the beam, and is returned as a float strictly below it (beamStartBelow).

namespace {

/// A float strictly below @p d: the largest at or below d − 2^-30·(1 + |d|); 0 if that is not
/// positive (a start of 0 is the single pass itself).
float beamStartBelow(double d) {
    const double x = d - 0x1p-30 * (1.0 + std::abs(d));  // clears the double rounding of d
    if (!(x > 0)) return 0.0f;
    float f = static_cast<float>(x);
    if (static_cast<double>(f) > x) f = std::nextafter(f, 0.0f);
    return f;
}

/// One axis of a dilated cell: the t ≥ 0 where o + d·t ∈ [lo − k·t − e, hi + k·t + e].
struct AxisBeam {
    double o, upCoef, upInv, downCoef, downInv,
        e;  // (d − k)·t ≤ hi + e − o; (−d − k)·t ≤ o − lo + e

    AxisBeam(double origin, double direction, double k, double pad)
        : o(origin),
          upCoef(direction - k),
          upInv(1.0 / upCoef),
          downCoef(-direction - k),
          downInv(1.0 / downCoef),
          e(pad) {}

    static void constrain(double coef, double inv, double rhs, double& t0, double& t1) {
        if (coef > 0)
            t1 = std::min(t1, rhs * inv);
        else if (coef < 0)
            t0 = std::max(t0, rhs * inv);
        else if (rhs < 0)
            t1 = -1.0;  // never inside
    }
    void span(double lo, double hi, double& t0, double& t1) const {
        t0 = 0.0;
        t1 = std::numeric_limits<double>::infinity();
        constrain(upCoef, upInv, hi + e - o, t0, t1);
        constrain(downCoef, downInv, o - lo + e, t0, t1);
    }
};

}  // namespace

CastHit EsvoRayCaster::castBeam(const Ray& ray, const CastOptions& options) const {
    const std::uint32_t* words = pool_.words();
    const Vec3d& ow = ray.origin;
    const Vec3d& dw = ray.direction;
    // The same expressions cast() rounds to float.
    const double o[3] = {a_[0] * ow.x + a_[1] * ow.y + a_[2] * ow.z + a_[3] + 1.0,
                         a_[4] * ow.x + a_[5] * ow.y + a_[6] * ow.z + a_[7] + 1.0,
                         a_[8] * ow.x + a_[9] * ow.y + a_[10] * ow.z + a_[11] + 1.0};
    const double d[3] = {a_[0] * dw.x + a_[1] * dw.y + a_[2] * dw.z,
                         a_[4] * dw.x + a_[5] * dw.y + a_[6] * dw.z,
                         a_[8] * dw.x + a_[9] * dw.y + a_[10] * dw.z};
    const double oMax = std::max({std::abs(o[0]), std::abs(o[1]), std::abs(o[2])});
    constexpr double u = 0x1p-24;  // float rounding
    // Per unit t: the beam's chord in octree units, the fine direction's rounding to float and
    // its clamp to 2^-23, and slack for the double arithmetic of the coarse ray itself.
    const double k =
        options.beamRadius * rowNorm_ * (1 + 1e-9) + u * rowNorm_ * 1.01 + 0x1p-23 + 1e-12;
    // Absolute: the fine caster's plane rounding (eta, point 3), its origin's rounding to float,
    // and a pad that absorbs this function's own double rounding for any t below ~1e6.
    const double e = u * (24.0 + 4.0 * oMax) + u * oMax + 1e-9;
    const AxisBeam axes[3] = {AxisBeam(o[0], d[0], k, e), AxisBeam(o[1], d[1], k, e),
                              AxisBeam(o[2], d[2], k, e)};
    const double lod =
        static_cast<double>(static_cast<float>(options.lodAngle * unitScale_));  // cast()'s lodCoef
    const double lodSlack = 1.0 + 0x1p-20;  // cast() rounds tcMax·lodCoef to float

    struct Node {
        std::uint32_t descriptor;  // word index of the node's child descriptor
        std::uint32_t level;
        double x, y, z;  // minimum corner in [1,2]³
        double size;     // edge
        double t0;       // entry into the dilated node
    };
    Node stack[8 * 24];
    int top = 0;
    stack[top++] = {pool_.rootDescriptorWord(), 0, 1.0, 1.0, 1.0, 1.0, 0.0};
    double best = std::numeric_limits<double>::infinity();
    CastHit result;
    while (top > 0) {
        const Node n = stack[--top];
        if (n.t0 >= best) continue;  // a nearer stop was found since it was pushed
        ++result.iterations;
        const std::uint32_t descriptor = words[n.descriptor];
        const std::uint32_t level = n.level + 1;
        const double size = 0.5 * n.size;  // a child's edge
        const double corner[3] = {n.x, n.y, n.z};
        double span[3][2][2];  // [axis][upper half][entry, exit]
        for (int a = 0; a < 3; ++a) {
            axes[a].span(corner[a], corner[a] + size, span[a][0][0], span[a][0][1]);
            axes[a].span(corner[a] + size, corner[a] + 2 * size, span[a][1][0], span[a][1][1]);
        }
        Node children[8];
        int count = 0;
        for (std::uint32_t valid = (descriptor >> 8) & 0xFFu; valid != 0; valid &= valid - 1) {
            const int slot = std::countr_zero(valid);
            const int bx = slot & 1, by = (slot >> 1) & 1, bz = slot >> 2;
            const double t0 = std::max({span[0][bx][0], span[1][by][0], span[2][bz][0]});
            const double t1 = std::min({span[0][bx][1], span[1][by][1], span[2][bz][1]});
            if (!(t0 <= t1) || t0 >= best) continue;
            // Where cast() could stop: the same tests, the level-of-detail one for any ray of
            // the beam (its exit from the cell is at most this dilated exit).
            // (Stopping at level 23 at the latest, cast()'s finest scale, also bounds the stack:
            // at most 7 entries wait per level.)
            bool stop = !((descriptor >> slot) & 1u) || level >= options.maxLevel || level >= 23;
            std::int64_t offset = static_cast<std::int32_t>(descriptor >> 17);
            if (!stop && (descriptor & 0x10000u)) {
                offset = static_cast<std::int32_t>(
                    words[n.descriptor + 2 * static_cast<std::uint32_t>(offset)]);
                stop = offset == 0;
            }
            if (!stop && lod > 0 && t1 * lod * lodSlack >= size) stop = true;
            if (stop) {
                best = t0;
                result.level = level;
                continue;
            }
            offset += esvo::popc8(descriptor & ((1u << slot) - 1u));
            children[count++] = {
                static_cast<std::uint32_t>(static_cast<std::int64_t>(n.descriptor) + 2 * offset),
                level,
                n.x + bx * size,
                n.y + by * size,
                n.z + bz * size,
                size,
                t0};
        }
        // Nearest on top of the stack: front to back, so a close stop prunes the rest early.
        for (int i = 1; i < count; ++i)  // insertion sort, farthest first
            for (int j = i; j > 0 && children[j - 1].t0 < children[j].t0; --j)
                std::swap(children[j - 1], children[j]);
        for (int i = 0; i < count; ++i)
            if (children[i].t0 < best) stack[top++] = children[i];
    }
    if (best == std::numeric_limits<double>::infinity()) return result;
    result.hit = true;
    result.t = beamStartBelow(best);
    return result;
}

// ---- images ----------------------------------------------------------------------------------

namespace {

RenderBuffers emptyBuffers(const PinholeCamera& camera) {
    RenderBuffers out;
    out.width = camera.width;
    out.height = camera.height;
    const std::size_t pixels = std::size_t(camera.width) * std::size_t(camera.height);
    out.depth.assign(pixels, std::numeric_limits<float>::infinity());
    out.normal.assign(pixels, Vec3f{0, 0, 0});
    out.iterations.assign(pixels, 0);
    out.level.assign(pixels, 0);
    out.color.assign(pixels, 0);
    out.shadingNormal.assign(pixels, Vec3f{0, 0, 0});
    return out;
}

/// Pixels [x0, x1) × [y0, y1) of the image.
struct PixelTile {
    int x0, x1, y0, y1;
    [[nodiscard]] std::size_t pixels() const { return std::size_t(x1 - x0) * std::size_t(y1 - y0); }
};

/// One cast per pixel in parallel, tile by tile: @p castTile(tile, hits) fills hits with the
/// tile's CastHits, row by row. Returns the seconds.
template <class CastTile>
double castPixels(const PinholeCamera& camera, RenderBuffers& out, const CastTile& castTile) {
    std::atomic<std::uint64_t> hits{0};
    const auto start = std::chrono::steady_clock::now();
    // Square tiles rather than rows: neighbouring rays walk the same nodes, so a tile reuses the
    // cache lines its first rays brought in.
    constexpr int kTile = 16;
    tbb::parallel_for(tbb::blocked_range2d<int>(0, camera.height, kTile, 0, camera.width, kTile),
                      [&](const tbb::blocked_range2d<int>& range) {
                          const PixelTile tile{range.cols().begin(), range.cols().end(),
                                               range.rows().begin(), range.rows().end()};
                          std::vector<CastHit> tileHits(tile.pixels());
                          castTile(tile, tileHits.data());
                          std::uint64_t localHits = 0;
                          const CastHit* h = tileHits.data();
                          for (int y = tile.y0; y != tile.y1; ++y)
                              for (int x = tile.x0; x != tile.x1; ++x, ++h) {
                                  const std::size_t i =
                                      std::size_t(y) * std::size_t(camera.width) + std::size_t(x);
                                  out.iterations[i] = h->iterations;
                                  if (!h->hit) continue;
                                  ++localHits;
                                  out.depth[i] = h->t;
                                  out.normal[i] = h->normal;
                                  out.level[i] = static_cast<std::uint8_t>(h->level);
                                  if (h->hasAttributes)
                                      out.color[i] = h->color,
                                      out.shadingNormal[i] = h->shadingNormal;
                              }
                          hits += localHits;
                      });
    out.hits = hits;
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

/// castPixels' tile caster for the octree: the tile's rays through EsvoRayCaster::castMany, each
/// starting where @p startOf(x, y) says.
template <class StartOf>
auto octreeTiles(const EsvoRayCaster& caster, const CameraBasis& basis, const CastOptions& options,
                 const StartOf& startOf) {
    return [&caster, &basis, &options, startOf](const PixelTile& tile, CastHit* hits) {
        std::vector<Ray> rays;
        std::vector<float> starts;
        rays.reserve(tile.pixels());
        starts.reserve(tile.pixels());
        for (int y = tile.y0; y != tile.y1; ++y)
            for (int x = tile.x0; x != tile.x1; ++x)
                rays.push_back(basis.ray(x, y)), starts.push_back(startOf(x, y));
        caster.castMany(rays.data(), starts.data(), rays.size(), options, hits);
    };
}

}  // namespace

RenderBuffers renderPixels(const PinholeCamera& camera,
                           const std::function<CastHit(const Ray&)>& cast) {
    camera.validate();
    RenderBuffers out = emptyBuffers(camera);
    const CameraBasis basis(camera);
    out.seconds = castPixels(camera, out, [&](const PixelTile& tile, CastHit* hits) {
        for (int y = tile.y0; y != tile.y1; ++y)
            for (int x = tile.x0; x != tile.x1; ++x) *hits++ = cast(basis.ray(x, y));
    });
    return out;
}

RenderBuffers renderEsvo(const EsvoRayCaster& caster, const PinholeCamera& camera,
                         const CastOptions& options, int beam) {
    camera.validate();
    if (beam < 0 || beam > 64) throw UsageError("beam: block size must be 0 (off) or 2..64 pixels");
    RenderBuffers out = emptyBuffers(camera);
    const CameraBasis basis(camera);
    if (beam <= 1) {
        out.seconds = castPixels(
            camera, out, octreeTiles(caster, basis, options, [](int, int) { return 0.0f; }));
        return out;
    }
    out.beam = beam;
    // Coarse pass: one cone through every block corner. A pixel's centre is at most (beam − 1)/2
    // pixels from its block's nearest corner along each axis, and one pixel is pixelAngle() on
    // the image plane at distance 1, where the chord between unit directions is at most the
    // distance between the plane points (projecting onto the unit sphere from outside it does
    // not stretch distances). That corner's start is below the pixel's hit, so the smallest of
    // the four is too.
    const int blocksX = (camera.width + beam - 1) / beam,
              blocksY = (camera.height + beam - 1) / beam;
    const int cornersX = blocksX + 1, cornersY = blocksY + 1;
    CastOptions coarse = options;
    coarse.contours = false;
    coarse.tStart = 0;
    coarse.beamRadius = camera.pixelAngle() * (beam - 1) * std::sqrt(0.5);
    std::vector<float> starts(std::size_t(cornersX) * std::size_t(cornersY));
    std::atomic<std::uint64_t> coarseIterations{0};
    const auto start = std::chrono::steady_clock::now();
    tbb::parallel_for(
        tbb::blocked_range<int>(0, cornersY), [&](const tbb::blocked_range<int>& rows) {
            std::uint64_t local = 0;
            for (int j = rows.begin(); j != rows.end(); ++j)
                for (int i = 0; i < cornersX; ++i) {
                    const CastHit h =
                        caster.cast(basis.rayAt(double(i) * beam, double(j) * beam), coarse);
                    starts[std::size_t(j) * std::size_t(cornersX) + std::size_t(i)] =
                        h.t;  // +inf: no ray of the beam hits
                    local += h.iterations;
                }
            coarseIterations += local;
        });
    out.coarseSeconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    out.coarseRays = starts.size();
    out.coarseIterations = coarseIterations;
    // Fine pass: every pixel from the smallest start of its block's corners.
    const double fineSeconds =
        castPixels(camera, out, octreeTiles(caster, basis, options, [&](int x, int y) {
                       const std::size_t bx = std::size_t(x / beam), by = std::size_t(y / beam);
                       const float* row0 = &starts[by * std::size_t(cornersX) + bx];
                       const float* row1 = row0 + cornersX;
                       // +inf where no ray of the block can hit: cast() then returns at once.
                       return std::min({row0[0], row0[1], row1[0], row1[1]});
                   }));
    out.seconds = out.coarseSeconds + fineSeconds;
    return out;
}

}  // namespace vox
