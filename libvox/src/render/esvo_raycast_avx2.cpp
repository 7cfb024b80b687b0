// EsvoRayCaster::castMany's eight-ray loop: cast()'s traversal run on eight rays at once, one
// ray per AVX2 lane. Every lane evaluates exactly the float operations cast() does, in the same
// order (no FMA: this file is built with -ffp-contract=off and without the fma target), so each
// ray's hit is bit for bit cast()'s; only the control flow becomes masks. Rays start with
// cast()'s prologue (EsvoRayCaster::start) and finish with its epilogue (EsvoRayCaster::finish).
//
// Why it pays: cast() runs one ray's loop as a chain of dependent, mostly well-predicted steps
// and leaves most of the core idle; eight lanes do eight rays' steps for little more than the
// instructions of one.
#include <vox/formats/esvo.h>
#include <vox/raycast.h>

#include "esvo_traversal.h"
#include "../util/cpu_features.h"

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define VOX_RAYCAST_AVX2 1
#include <immintrin.h>
#else
#define VOX_RAYCAST_AVX2 0
#endif

#include <algorithm>
#include <array>
#include <bit>
#include <cstring>

namespace vox::detail {

#if VOX_RAYCAST_AVX2

namespace {

constexpr int kLanes = 8;

/// Every lane's traversal state, one array per variable (lane i at index i), as the loop keeps
/// it in registers.
struct alignas(32) LaneState {
    float px[kLanes], py[kLanes], pz[kLanes], dx[kLanes], dy[kLanes], dz[kLanes];
    float txCoef[kLanes], tyCoef[kLanes], tzCoef[kLanes], txBias[kLanes], tyBias[kLanes],
        tzBias[kLanes];
    float tMin[kLanes], tMax[kLanes], posX[kLanes], posY[kLanes], posZ[kLanes], scaleExp2[kLanes];
    float slabT[kLanes], slabNx[kLanes], slabNy[kLanes], slabNz[kLanes];
    std::int32_t octantMask[kLanes], idx[kLanes], scale[kLanes], parent[kLanes], iterations[kLanes];
    std::int32_t level[kLanes], hitSlot[kLanes];
    std::int32_t active[kLanes], hit[kLanes];  // all ones / zero
    // The PUSH stack, [scale][lane], so that a POP gathers entry scale·8 + lane.
    std::int32_t stackParent[kScaleMax + 1][kLanes];
    float stackTMax[kScaleMax + 1][kLanes];
};

#define VOX_AVX2 [[gnu::target("avx2")]]

VOX_AVX2 inline __m256 loadF(const float* p) { return _mm256_load_ps(p); }
VOX_AVX2 inline __m256i loadI(const std::int32_t* p) {
    return _mm256_load_si256(reinterpret_cast<const __m256i*>(p));
}
VOX_AVX2 inline void storeI(std::int32_t* p, __m256i v) {
    _mm256_store_si256(reinterpret_cast<__m256i*>(p), v);
}
VOX_AVX2 inline __m256 asF(__m256i v) { return _mm256_castsi256_ps(v); }
VOX_AVX2 inline __m256i asI(__m256 v) { return _mm256_castps_si256(v); }
VOX_AVX2 inline __m256i andNot(__m256i mask, __m256i v) {
    return _mm256_andnot_si256(mask, v);
}  // v & ~mask
VOX_AVX2 inline __m256 selectF(__m256i mask, __m256 ifSet, __m256 otherwise) {
    return _mm256_blendv_ps(otherwise, ifSet, asF(mask));
}
VOX_AVX2 inline __m256i selectI(__m256i mask, __m256i ifSet, __m256i otherwise) {
    return _mm256_blendv_epi8(otherwise, ifSet, mask);
}
VOX_AVX2 inline bool any(__m256i mask) { return !_mm256_testz_si256(mask, mask); }
// std::min(a, b) picks a on ties; so does this (minps returns its second operand unless the
// first is smaller).
VOX_AVX2 inline __m256 minOf(__m256 a, __m256 b) { return _mm256_min_ps(b, a); }
VOX_AVX2 inline __m256i lessOrEqual(__m256 a, __m256 b) {
    return asI(_mm256_cmp_ps(a, b, _CMP_LE_OQ));
}
VOX_AVX2 inline __m256i greater(__m256 a, __m256 b) { return asI(_mm256_cmp_ps(a, b, _CMP_GT_OQ)); }
VOX_AVX2 inline __m256i bit(__m256i v, __m256i shift) {  // all ones where bit `shift` of v is set
    return _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_srlv_epi32(v, shift), _mm256_set1_epi32(1)),
                              _mm256_set1_epi32(1));
}
/// esvo::popc8 per lane.
VOX_AVX2 inline __m256i popc8(__m256i m) {
    m = _mm256_and_si256(m, _mm256_set1_epi32(0xFF));
    m = _mm256_sub_epi32(m, _mm256_and_si256(_mm256_srli_epi32(m, 1), _mm256_set1_epi32(0x55)));
    m = _mm256_add_epi32(_mm256_and_si256(m, _mm256_set1_epi32(0x33)),
                         _mm256_and_si256(_mm256_srli_epi32(m, 2), _mm256_set1_epi32(0x33)));
    return _mm256_and_si256(_mm256_add_epi32(m, _mm256_srli_epi32(m, 4)), _mm256_set1_epi32(0x0F));
}
/// Gathers words[index] where @p mask is set, 0 elsewhere.
VOX_AVX2 inline __m256i gather(const std::uint32_t* words, __m256i index, __m256i mask) {
    return _mm256_mask_i32gather_epi32(_mm256_setzero_si256(), reinterpret_cast<const int*>(words),
                                       index, mask, 4);
}
/// first = words[index], second = words[index + 1] where @p mask is set, as four 64-bit gathers
/// of two words each rather than sixteen single words.
VOX_AVX2 inline void gatherPairs(const std::uint32_t* words, __m256i index, __m256i mask,
                                 __m256i& first, __m256i& second) {
    const auto* base = reinterpret_cast<const long long*>(words);
    const __m256i low =
        _mm256_mask_i32gather_epi64(_mm256_setzero_si256(), base, _mm256_castsi256_si128(index),
                                    _mm256_cvtepi32_epi64(_mm256_castsi256_si128(mask)), 4);
    const __m256i high = _mm256_mask_i32gather_epi64(
        _mm256_setzero_si256(), base, _mm256_extracti128_si256(index, 1),
        _mm256_cvtepi32_epi64(_mm256_extracti128_si256(mask, 1)), 4);
    // Even words of low and high per 128-bit half, then the halves' quarters back in lane order.
    const __m256 even = _mm256_shuffle_ps(asF(low), asF(high), _MM_SHUFFLE(2, 0, 2, 0));
    const __m256 odd = _mm256_shuffle_ps(asF(low), asF(high), _MM_SHUFFLE(3, 1, 3, 1));
    first = _mm256_permute4x64_epi64(asI(even), _MM_SHUFFLE(3, 1, 2, 0));
    second = _mm256_permute4x64_epi64(asI(odd), _MM_SHUFFLE(3, 1, 2, 0));
}

/// Bits 0, 1, 2 from the low bits of the three masks.
VOX_AVX2 inline __m256i axisBits(__m256i x, __m256i y, __m256i z) {
    return _mm256_or_si256(_mm256_and_si256(x, _mm256_set1_epi32(1)),
                           _mm256_or_si256(_mm256_and_si256(y, _mm256_set1_epi32(2)),
                                           _mm256_and_si256(z, _mm256_set1_epi32(4))));
}

/// One group of eight lanes' traversal state in registers.
struct LaneRegs {
    __m256 px, py, pz, dx, dy, dz, txCoef, tyCoef, tzCoef, txBias, tyBias, tzBias;
    __m256i octantMask;
    __m256 tMin, tMax, posX, posY, posZ, scaleExp2, slabT, slabNx, slabNy, slabNz;
    __m256i idx, scale, parent, iterations, level, hitSlot, active, hit;
};

VOX_AVX2 inline LaneRegs loadLanes(const LaneState& L) {
    return {loadF(L.px),         loadF(L.py),     loadF(L.pz),         loadF(L.dx),
            loadF(L.dy),         loadF(L.dz),     loadF(L.txCoef),     loadF(L.tyCoef),
            loadF(L.tzCoef),     loadF(L.txBias), loadF(L.tyBias),     loadF(L.tzBias),
            loadI(L.octantMask), loadF(L.tMin),   loadF(L.tMax),       loadF(L.posX),
            loadF(L.posY),       loadF(L.posZ),   loadF(L.scaleExp2),  loadF(L.slabT),
            loadF(L.slabNx),     loadF(L.slabNy), loadF(L.slabNz),     loadI(L.idx),
            loadI(L.scale),      loadI(L.parent), loadI(L.iterations), loadI(L.level),
            loadI(L.hitSlot),    loadI(L.active), loadI(L.hit)};
}

VOX_AVX2 inline void storeLanes(LaneState& L, const LaneRegs& r) {
    _mm256_store_ps(L.tMin, r.tMin), _mm256_store_ps(L.tMax, r.tMax);
    _mm256_store_ps(L.posX, r.posX), _mm256_store_ps(L.posY, r.posY),
        _mm256_store_ps(L.posZ, r.posZ);
    _mm256_store_ps(L.scaleExp2, r.scaleExp2), _mm256_store_ps(L.slabT, r.slabT);
    _mm256_store_ps(L.slabNx, r.slabNx), _mm256_store_ps(L.slabNy, r.slabNy),
        _mm256_store_ps(L.slabNz, r.slabNz);
    storeI(L.idx, r.idx), storeI(L.scale, r.scale), storeI(L.parent, r.parent),
        storeI(L.iterations, r.iterations);
    storeI(L.level, r.level), storeI(L.hitSlot, r.hitSlot), storeI(L.active, r.active),
        storeI(L.hit, r.hit);
}

/// One iteration of cast()'s loop for every active lane of @p r (@p L holds its stack).
VOX_AVX2 [[gnu::always_inline]] inline void step(LaneRegs& r, LaneState& L,
                                                 const std::uint32_t* words,
                                                 const CastOptions& options, float lodCoefScalar) {
    const __m256 px = r.px, py = r.py, pz = r.pz, dx = r.dx, dy = r.dy, dz = r.dz;
    const __m256 txCoef = r.txCoef, tyCoef = r.tyCoef, tzCoef = r.tzCoef, txBias = r.txBias,
                 tyBias = r.tyBias, tzBias = r.tzBias;
    const __m256i octantMask = r.octantMask;
    __m256 &tMin = r.tMin, &tMax = r.tMax, &posX = r.posX, &posY = r.posY, &posZ = r.posZ,
           &scaleExp2 = r.scaleExp2;
    __m256 &slabT = r.slabT, &slabNx = r.slabNx, &slabNy = r.slabNy, &slabNz = r.slabNz;
    __m256i &idx = r.idx, &scale = r.scale, &parent = r.parent, &iterations = r.iterations,
            &level = r.level, &hitSlot = r.hitSlot;
    __m256i &active = r.active, &hit = r.hit;

    const __m256i one = _mm256_set1_epi32(1), seven = _mm256_set1_epi32(7),
                  allOnes = _mm256_set1_epi32(-1);
    const __m256i scaleMax = _mm256_set1_epi32(kScaleMax);
    const __m256i laneIndex = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    const __m256 lodCoef = _mm256_set1_ps(lodCoefScalar);
    const bool lodCut = lodCoefScalar > 0;
    // level >= maxLevel as level > maxLevel − 1 (levels are at most 23).
    const __m256i maxLevelMinusOne = _mm256_set1_epi32(
        static_cast<std::int32_t>(std::min<std::uint32_t>(options.maxLevel, 64)) - 1);
    const __m256 half0 = _mm256_set1_ps(0.5f), three = _mm256_set1_ps(3.0f),
                 contourStep = _mm256_set1_ps(float(esvo::Contour::kStep));
    const __m256 zero = _mm256_setzero_ps();

    iterations = _mm256_sub_epi32(iterations, active);
    __m256i descriptor, descriptor2;
    gatherPairs(words, parent, active, descriptor, descriptor2);
    const __m256 txCorner = _mm256_sub_ps(_mm256_mul_ps(posX, txCoef), txBias);
    const __m256 tyCorner = _mm256_sub_ps(_mm256_mul_ps(posY, tyCoef), tyBias);
    const __m256 tzCorner = _mm256_sub_ps(_mm256_mul_ps(posZ, tzCoef), tzBias);
    const __m256 tcMax = minOf(minOf(txCorner, tyCorner), tzCorner);

    const __m256i slot = _mm256_xor_si256(_mm256_xor_si256(idx, octantMask), seven);
    const __m256i valid = bit(descriptor, _mm256_add_epi32(slot, _mm256_set1_epi32(8)));
    const __m256i inSpan =
        _mm256_and_si256(_mm256_and_si256(active, valid), lessOrEqual(tMin, tMax));
    const __m256i levelHere = _mm256_sub_epi32(scaleMax, scale);
    __m256i lodStop = _mm256_setzero_si256();
    if (lodCut)
        lodStop = _mm256_and_si256(
            inSpan, asI(_mm256_cmp_ps(_mm256_mul_ps(tcMax, lodCoef), scaleExp2, _CMP_GE_OQ)));
    const __m256i descend = andNot(lodStop, inSpan);

    __m256 tvMax = minOf(tMax, tcMax);
    const __m256 half = _mm256_mul_ps(scaleExp2, half0);
    __m256 tvMin = tMin;
    __m256i fromSlab = _mm256_setzero_si256();
    __m256 candNx = zero, candNy = zero, candNz = zero;
    if (options.contours) {
        const __m256i withContour = _mm256_and_si256(descend, bit(descriptor2, slot));
        if (any(withContour)) {
            const __m256i below =
                _mm256_and_si256(descriptor2, _mm256_sub_epi32(_mm256_sllv_epi32(one, slot), one));
            const __m256i word = _mm256_add_epi32(
                _mm256_add_epi32(parent, _mm256_srli_epi32(descriptor2, 8)), popc8(below));
            const __m256i c = gather(words, word, withContour);
            // esvo::Contour::decode: sign-extended bit fields.
            const __m256 nx = _mm256_cvtepi32_ps(_mm256_srai_epi32(_mm256_slli_epi32(c, 14), 26));
            const __m256 ny = _mm256_cvtepi32_ps(_mm256_srai_epi32(_mm256_slli_epi32(c, 20), 26));
            const __m256 nz = _mm256_cvtepi32_ps(_mm256_srai_epi32(_mm256_slli_epi32(c, 26), 26));
            const __m256 position =
                _mm256_cvtepi32_ps(_mm256_srai_epi32(_mm256_slli_epi32(c, 7), 25));
            const __m256 thickness = _mm256_cvtepi32_ps(_mm256_srli_epi32(c, 25));
            const __m256 upperX = _mm256_add_ps(posX, half), upperY = _mm256_add_ps(posY, half),
                         upperZ = _mm256_add_ps(posZ, half);
            const __m256 cx = selectF(bit(octantMask, _mm256_setzero_si256()), upperX,
                                      _mm256_sub_ps(_mm256_sub_ps(three, posX), half));
            const __m256 cy = selectF(bit(octantMask, one), upperY,
                                      _mm256_sub_ps(_mm256_sub_ps(three, posY), half));
            const __m256 cz = selectF(bit(octantMask, _mm256_set1_epi32(2)), upperZ,
                                      _mm256_sub_ps(_mm256_sub_ps(three, posZ), half));
            const __m256 nd = _mm256_add_ps(
                _mm256_add_ps(_mm256_mul_ps(nx, dx), _mm256_mul_ps(ny, dy)), _mm256_mul_ps(nz, dz));
            const __m256 no = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(nx, _mm256_sub_ps(px, cx)),
                                                          _mm256_mul_ps(ny, _mm256_sub_ps(py, cy))),
                                            _mm256_mul_ps(nz, _mm256_sub_ps(pz, cz)));
            const __m256 centreOffset =
                _mm256_mul_ps(_mm256_mul_ps(scaleExp2, position), contourStep);
            const __m256 halfThickness = _mm256_mul_ps(
                _mm256_mul_ps(_mm256_mul_ps(scaleExp2, thickness), contourStep), half0);
            const __m256 lo = _mm256_sub_ps(_mm256_sub_ps(centreOffset, halfThickness), no);
            const __m256 hi = _mm256_sub_ps(_mm256_add_ps(centreOffset, halfThickness), no);
            const __m256i slanted =
                _mm256_and_si256(withContour, asI(_mm256_cmp_ps(nd, zero, _CMP_NEQ_UQ)));
            const __m256i facing = asI(_mm256_cmp_ps(nd, zero, _CMP_LT_OQ));
            const __m256 q0 = _mm256_div_ps(lo, nd), q1 = _mm256_div_ps(hi, nd);
            const __m256 t0 = selectF(facing, q1, q0), t1 = selectF(facing, q0, q1);
            fromSlab = _mm256_and_si256(slanted, greater(t0, tvMin));
            tvMin = selectF(fromSlab, t0, tvMin);
            const __m256 sign =
                selectF(greater(nd, zero), _mm256_set1_ps(-1.0f), _mm256_set1_ps(1.0f));
            candNx = _mm256_mul_ps(sign, nx), candNy = _mm256_mul_ps(sign, ny),
            candNz = _mm256_mul_ps(sign, nz);
            tvMax = selectF(slanted, minOf(tvMax, t1), tvMax);
            const __m256i outside =
                _mm256_or_si256(greater(lo, zero), asI(_mm256_cmp_ps(hi, zero, _CMP_LT_OQ)));
            tvMax = selectF(_mm256_and_si256(andNot(slanted, withContour), outside),
                            _mm256_set1_ps(-1.0f), tvMax);
        }
    }
    const __m256i nonEmpty = _mm256_and_si256(descend, lessOrEqual(tvMin, tvMax));
    __m256i leaf = _mm256_or_si256(_mm256_xor_si256(bit(descriptor, slot), allOnes),
                                   _mm256_cmpgt_epi32(levelHere, maxLevelMinusOne));
    __m256i offset = _mm256_srli_epi32(descriptor, 17);
    const __m256i far = andNot(
        leaf,
        _mm256_and_si256(
            nonEmpty, _mm256_cmpeq_epi32(_mm256_and_si256(descriptor, _mm256_set1_epi32(0x10000)),
                                         _mm256_set1_epi32(0x10000))));
    if (any(far)) {
        const __m256i farOffset =
            gather(words, _mm256_add_epi32(parent, _mm256_add_epi32(offset, offset)), far);
        offset = selectI(far, farOffset, offset);
        // Child slice not loaded: this is the finest level there is.
        leaf = _mm256_or_si256(
            leaf, _mm256_and_si256(far, _mm256_cmpeq_epi32(farOffset, _mm256_setzero_si256())));
    }
    const __m256i recordSlab = _mm256_and_si256(nonEmpty, fromSlab);
    slabT = selectF(recordSlab, tvMin, slabT);
    slabNx = selectF(recordSlab, candNx, slabNx), slabNy = selectF(recordSlab, candNy, slabNy),
    slabNz = selectF(recordSlab, candNz, slabNz);
    const __m256i leafHit = _mm256_and_si256(nonEmpty, leaf);
    const __m256i stopped = _mm256_or_si256(lodStop, leafHit);
    hit = _mm256_or_si256(hit, stopped);
    level = selectI(stopped, levelHere, level);
    hitSlot = selectI(stopped, slot, hitSlot);
    tMin = selectF(leafHit, tvMin, tMin);

    // PUSH
    const __m256i push = andNot(leaf, nonEmpty);
    if (any(push)) {
        const unsigned pushLanes = static_cast<unsigned>(_mm256_movemask_ps(asF(push)));
        const int firstScale = _mm256_cvtsi256_si32(
            _mm256_permutevar8x32_epi32(scale, _mm256_set1_epi32(std::countr_zero(pushLanes))));
        const unsigned sameScale = static_cast<unsigned>(
            _mm256_movemask_ps(asF(_mm256_cmpeq_epi32(scale, _mm256_set1_epi32(firstScale)))));
        if ((sameScale & pushLanes) == pushLanes) {
            // Neighbouring rays mostly push at the same scale: one masked store per array.
            _mm256_maskstore_epi32(L.stackParent[firstScale], push, parent);
            _mm256_maskstore_ps(L.stackTMax[firstScale], push, tMax);
        } else {
            alignas(32) std::int32_t scaleOf[kLanes], parentOf[kLanes];
            alignas(32) float tMaxOf[kLanes];
            storeI(scaleOf, scale), storeI(parentOf, parent), _mm256_store_ps(tMaxOf, tMax);
            for (unsigned lanes = pushLanes; lanes != 0; lanes &= lanes - 1) {
                const int lane = std::countr_zero(lanes);
                L.stackParent[scaleOf[lane]][lane] = parentOf[lane];
                L.stackTMax[scaleOf[lane]][lane] = tMaxOf[lane];
            }
        }
        const __m256i below =
            _mm256_and_si256(descriptor, _mm256_sub_epi32(_mm256_sllv_epi32(one, slot), one));
        const __m256i childOffset = _mm256_add_epi32(offset, popc8(below));
        parent = selectI(push, _mm256_add_epi32(parent, _mm256_add_epi32(childOffset, childOffset)),
                         parent);
        scale = selectI(push, _mm256_sub_epi32(scale, one), scale);
        tMin = selectF(push, tvMin, tMin);
        tMax = selectF(push, tvMax, tMax);
        const __m256 txCenter =
            _mm256_sub_ps(_mm256_mul_ps(_mm256_add_ps(posX, half), txCoef), txBias);
        const __m256 tyCenter =
            _mm256_sub_ps(_mm256_mul_ps(_mm256_add_ps(posY, half), tyCoef), tyBias);
        const __m256 tzCenter =
            _mm256_sub_ps(_mm256_mul_ps(_mm256_add_ps(posZ, half), tzCoef), tzBias);
        const __m256i upX = greater(txCenter, tMin), upY = greater(tyCenter, tMin),
                      upZ = greater(tzCenter, tMin);
        idx = selectI(push, axisBits(upX, upY, upZ), idx);
        posX = selectF(push, _mm256_add_ps(posX, _mm256_and_ps(half, asF(upX))), posX);
        posY = selectF(push, _mm256_add_ps(posY, _mm256_and_ps(half, asF(upY))), posY);
        posZ = selectF(push, _mm256_add_ps(posZ, _mm256_and_ps(half, asF(upZ))), posZ);
        scaleExp2 = selectF(push, half, scaleExp2);
    }

    // ADVANCE
    const __m256i advance = andNot(_mm256_or_si256(stopped, push), active);
    const __m256i stepX = lessOrEqual(txCorner, tcMax), stepY = lessOrEqual(tyCorner, tcMax),
                  stepZ = lessOrEqual(tzCorner, tcMax);
    const __m256i stepMask = axisBits(stepX, stepY, stepZ);
    const __m256 nextX = _mm256_sub_ps(posX, _mm256_and_ps(scaleExp2, asF(stepX)));
    const __m256 nextY = _mm256_sub_ps(posY, _mm256_and_ps(scaleExp2, asF(stepY)));
    const __m256 nextZ = _mm256_sub_ps(posZ, _mm256_and_ps(scaleExp2, asF(stepZ)));
    posX = selectF(advance, nextX, posX), posY = selectF(advance, nextY, posY),
    posZ = selectF(advance, nextZ, posZ);
    tMin = selectF(advance, tcMax, tMin);
    idx = selectI(advance, _mm256_xor_si256(idx, stepMask), idx);
    const __m256i pop = andNot(
        _mm256_cmpeq_epi32(_mm256_and_si256(idx, stepMask), _mm256_setzero_si256()), advance);
    __m256i exited = _mm256_setzero_si256();
    if (any(pop)) {
        // POP: the highest bit where the old and new positions differ gives the scale.
        const __m256i differing = _mm256_or_si256(
            _mm256_and_si256(_mm256_xor_si256(asI(posX), asI(_mm256_add_ps(posX, scaleExp2))),
                             stepX),
            _mm256_or_si256(
                _mm256_and_si256(_mm256_xor_si256(asI(posY), asI(_mm256_add_ps(posY, scaleExp2))),
                                 stepY),
                _mm256_and_si256(_mm256_xor_si256(asI(posZ), asI(_mm256_add_ps(posZ, scaleExp2))),
                                 stepZ)));
        const __m256i popScale = _mm256_sub_epi32(
            _mm256_srli_epi32(asI(_mm256_cvtepi32_ps(differing)), 23), _mm256_set1_epi32(127));
        exited =
            _mm256_and_si256(pop, _mm256_cmpgt_epi32(popScale, _mm256_set1_epi32(kScaleMax - 1)));
        const __m256i popped = andNot(exited, pop);
        scale = selectI(popped, popScale, scale);
        scaleExp2 =
            selectF(popped,
                    asF(_mm256_slli_epi32(
                        _mm256_add_epi32(popScale, _mm256_set1_epi32(127 - kScaleMax)), 23)),
                    scaleExp2);
        const __m256i entry = _mm256_add_epi32(_mm256_slli_epi32(popScale, 3), laneIndex);
        parent = selectI(
            popped, _mm256_mask_i32gather_epi32(parent, &L.stackParent[0][0], entry, popped, 4),
            parent);
        tMax = selectF(popped,
                       _mm256_mask_i32gather_ps(tMax, &L.stackTMax[0][0], entry, asF(popped), 4),
                       tMax);
        const __m256i shx = _mm256_srlv_epi32(asI(posX), popScale);
        const __m256i shy = _mm256_srlv_epi32(asI(posY), popScale);
        const __m256i shz = _mm256_srlv_epi32(asI(posZ), popScale);
        posX = selectF(popped, asF(_mm256_sllv_epi32(shx, popScale)), posX);
        posY = selectF(popped, asF(_mm256_sllv_epi32(shy, popScale)), posY);
        posZ = selectF(popped, asF(_mm256_sllv_epi32(shz, popScale)), posZ);
        idx = selectI(
            popped,
            _mm256_or_si256(_mm256_and_si256(shx, one),
                            _mm256_or_si256(_mm256_slli_epi32(_mm256_and_si256(shy, one), 1),
                                            _mm256_slli_epi32(_mm256_and_si256(shz, one), 2))),
            idx);
    }
    active = andNot(_mm256_or_si256(stopped, exited), active);
}

/// Runs every active lane until it stops.
VOX_AVX2 void runLanes(LaneState& L, const std::uint32_t* words, const CastOptions& options,
                       float lodCoef) {
    LaneRegs r = loadLanes(L);
    while (any(r.active)) step(r, L, words, options, lodCoef);
    storeLanes(L, r);
}

/// The same loop built for AVX-512VL: the same eight-lane instructions, with 32 vector registers
/// instead of 16 to keep the lanes' state in.
[[gnu::target("avx2,avx512f,avx512vl")]] void runLanesWideRegisters(LaneState& L,
                                                                    const std::uint32_t* words,
                                                                    const CastOptions& options,
                                                                    float lodCoef) {
    LaneRegs r = loadLanes(L);
    while (any(r.active)) step(r, L, words, options, lodCoef);
    storeLanes(L, r);
}

}  // namespace

bool LaneCaster::available() { return cpuFeatures().avx2; }

#else

bool LaneCaster::available() { return false; }

#endif

void LaneCaster::cast(const EsvoRayCaster& caster, const Ray* rays, const float* tStarts,
                      std::size_t count, const CastOptions& options, CastHit* hits) {
#if VOX_RAYCAST_AVX2
    LaneState L;
    std::memset(static_cast<void*>(&L), 0, sizeof L);
    std::array<TraversalStart, kLanes> starts;
    std::array<std::size_t, kLanes> rayOf;
    const std::uint32_t* words = caster.pool_.words();
    const std::uint32_t root = caster.pool_.rootDescriptorWord();
    const bool wideRegisters = cpuFeatures().avx512vl;
    float lodCoef = 0;  // start()'s, the same for every ray
    std::size_t next = 0;
    CastOptions rayOptions = options;
    // Rounds of eight rays: the lanes start together and run until the last one stops, which
    // measured faster than refilling lanes as they stop (neighbouring rays take similar paths).
    while (next < count) {
        bool any = false;
        for (int lane = 0; lane < kLanes; ++lane) {
            L.active[lane] = 0;
            rayOf[std::size_t(lane)] = count;
            // Rays that miss the root cube finish here.
            while (next < count) {
                const std::size_t i = next++;
                rayOptions.tStart = tStarts ? std::max(options.tStart, tStarts[i]) : options.tStart;
                TraversalStart& s = starts[std::size_t(lane)];
                if (!caster.start(rays[i], rayOptions, s)) {
                    hits[i] = CastHit{};
                    continue;
                }
                lodCoef = s.lodCoef;
                L.px[lane] = s.px, L.py[lane] = s.py, L.pz[lane] = s.pz, L.dx[lane] = s.dx,
                L.dy[lane] = s.dy, L.dz[lane] = s.dz;
                L.txCoef[lane] = s.txCoef, L.tyCoef[lane] = s.tyCoef, L.tzCoef[lane] = s.tzCoef;
                L.txBias[lane] = s.txBias, L.tyBias[lane] = s.tyBias, L.tzBias[lane] = s.tzBias;
                L.tMin[lane] = s.tMin, L.tMax[lane] = s.tMax;
                L.posX[lane] = s.posX, L.posY[lane] = s.posY, L.posZ[lane] = s.posZ;
                L.octantMask[lane] = s.octantMask, L.idx[lane] = s.idx;
                L.scale[lane] = kScaleMax - 1, L.scaleExp2[lane] = 0.5f;
                L.parent[lane] = static_cast<std::int32_t>(root);
                L.slabT[lane] = -1.0f, L.slabNx[lane] = L.slabNy[lane] = L.slabNz[lane] = 0.0f;
                L.iterations[lane] = 0, L.level[lane] = 0, L.hitSlot[lane] = 0;
                L.hit[lane] = 0, L.active[lane] = -1;
                rayOf[std::size_t(lane)] = i;
                any = true;
                break;
            }
        }
        if (!any) break;
        if (wideRegisters)
            runLanesWideRegisters(L, words, options, lodCoef);
        else
            runLanes(L, words, options, lodCoef);
        // Complete each ray as cast() does.
        for (int lane = 0; lane < kLanes; ++lane) {
            if (rayOf[std::size_t(lane)] == count) continue;
            CastHit& out = hits[rayOf[std::size_t(lane)]];
            if (!L.hit[lane]) {
                out = CastHit{};
                out.iterations = static_cast<std::uint32_t>(L.iterations[lane]);
                continue;
            }
            TraversalStop stop;
            stop.hit = true;
            stop.t = L.tMin[lane];
            stop.scale = L.scale[lane];
            stop.scaleExp2 = L.scaleExp2[lane];
            stop.posX = L.posX[lane], stop.posY = L.posY[lane], stop.posZ = L.posZ[lane];
            stop.parent = static_cast<std::uint32_t>(L.parent[lane]);
            stop.hitSlot = L.hitSlot[lane];
            stop.level = static_cast<std::uint32_t>(L.level[lane]);
            stop.slabT = L.slabT[lane];
            stop.slabNormal = {L.slabNx[lane], L.slabNy[lane], L.slabNz[lane]};
            stop.iterations = static_cast<std::uint32_t>(L.iterations[lane]);
            out = caster.finish(starts[std::size_t(lane)], stop, options,
                                reinterpret_cast<const std::uint32_t*>(&L.stackParent[0][lane]),
                                kLanes);
        }
    }
#else
    (void)caster, (void)rays, (void)tStarts, (void)count, (void)options, (void)hits;
#endif
}

}  // namespace vox::detail
