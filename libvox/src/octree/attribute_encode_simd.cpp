// The block encoders' SIMD kernels (attribute_encode_internal.h): the colour palette's error and
// the ordered cluster fit's search, the normals' nearest-lattice-point kernels (the face-plane
// assignment and the decoded lattice's error) and the 3-D fit's single-precision normal
// equations. Each is written for SSE2 (the x86-64 baseline) with a scalar fallback that computes
// the same values lane by lane; the two nearest-lattice-point kernels also for AVX-512F, chosen
// at run time (util/cpu_features.h) where the CPU has it, the same operations sixteen lanes at
// once (this file is compiled without contraction into FMAs), so that all give the same bits.
// -DVOX_ENCODE_NO_SIMD builds the scalar fallbacks, -DVOX_ENCODE_NO_AVX512 leaves AVX-512 out.
#include "attribute_encode_internal.h"

#include "../util/cpu_features.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdint>

#if defined(__SSE2__) && \
    !defined(VOX_ENCODE_NO_SIMD)  // the scalar fallback computes the same values
#include <emmintrin.h>
#define VOX_ENCODE_SSE2 1
#else
#define VOX_ENCODE_SSE2 0
#endif
#if VOX_ENCODE_SSE2 && defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__)) && \
    !defined(VOX_ENCODE_NO_AVX512)
#include <immintrin.h>
#define VOX_ENCODE_AVX512 1
#define VOX_TARGET_AVX512 [[gnu::target("avx512f")]]
#if defined(__clang__)
#define VOX_AVX512_WARNINGS_OFF
#define VOX_AVX512_WARNINGS_ON
#else  // GCC 12 warns of the undefined source vectors inside its own AVX-512 intrinsics'
       // definitions
#define VOX_AVX512_WARNINGS_OFF                                                                \
    _Pragma("GCC diagnostic push") _Pragma("GCC diagnostic ignored \"-Wmaybe-uninitialized\"") \
        _Pragma("GCC diagnostic ignored \"-Wuninitialized\"")
#define VOX_AVX512_WARNINGS_ON _Pragma("GCC diagnostic pop")
#endif
#else
#define VOX_ENCODE_AVX512 0
#endif
#if defined(__GNUC__)
#define VOX_ENCODE_INLINE [[gnu::always_inline]] inline
#else
#define VOX_ENCODE_INLINE inline
#endif

namespace vox::detail::encode {
namespace {

/// The lattice weights (cu, cv) of combo k = uIndex + 4·vIndex, as arrays the compiler can
/// vectorise loops over the 16 combos with.
alignas(16) constexpr std::array<float, 16> kComboU = [] {
    std::array<float, 16> w{};
    for (unsigned k = 0; k < 16; ++k) w[k] = esvo::kAxisWeights[k & 3];
    return w;
}();
alignas(16) constexpr std::array<float, 16> kComboV = [] {
    std::array<float, 16> w{};
    for (unsigned k = 0; k < 16; ++k) w[k] = esvo::kAxisWeights[k >> 2];
    return w;
}();

/// Index of the smallest of 16 non-negative values, the lowest on (near) ties: the index is put
/// in the low 4 mantissa bits, which keeps the order of non-negative floats, so that a plain
/// min reduction (vectorisable, unlike an argmin loop) finds both. Inlined into its callers'
/// loops (a call, with @p d stored and reloaded, cost as much as the distances).
[[maybe_unused]] VOX_ENCODE_INLINE unsigned argmin16(
    const std::array<float, 16>& d) {  // the SSE2 build uses the vector form
    std::array<float, 16> t{};
    for (unsigned k = 0; k < 16; ++k)
        t[k] = std::bit_cast<float>((std::bit_cast<std::uint32_t>(d[k]) & ~15u) | k);
    for (unsigned k = 0; k < 8; ++k) t[k] = std::min(t[k], t[k + 8]);
    for (unsigned k = 0; k < 4; ++k) t[k] = std::min(t[k], t[k + 4]);
    for (unsigned k = 0; k < 2; ++k) t[k] = std::min(t[k], t[k + 2]);
    return std::bit_cast<std::uint32_t>(std::min(t[0], t[1])) & 15u;
}

/// 16 points (the lattice points of the combos, in combo order), one array per coordinate.
struct alignas(16) Points16 {
    std::array<float, 16> x{}, y{}, z{};
};

#if VOX_ENCODE_SSE2
/// The lane of the smallest of four vectors of non-negative squared distances (as argmin16,
/// whose result it equals: the values carry their index in their low mantissa bits, so all are
/// distinct and the order of reduction does not matter).
VOX_ENCODE_INLINE unsigned argmin16(__m128 d0, __m128 d1, __m128 d2, __m128 d3) {
    const __m128i keep = _mm_set1_epi32(~15);
    const auto tag = [&](__m128 d, int k) {
        return _mm_castsi128_ps(_mm_or_si128(_mm_and_si128(_mm_castps_si128(d), keep),
                                             _mm_setr_epi32(k, k + 1, k + 2, k + 3)));
    };
    __m128 m = _mm_min_ps(_mm_min_ps(tag(d0, 0), tag(d1, 4)), _mm_min_ps(tag(d2, 8), tag(d3, 12)));
    m = _mm_min_ps(m, _mm_shuffle_ps(m, m, _MM_SHUFFLE(1, 0, 3, 2)));
    m = _mm_min_ps(m, _mm_shuffle_ps(m, m, _MM_SHUFFLE(2, 3, 0, 1)));
    return static_cast<unsigned>(_mm_cvtsi128_si32(_mm_castps_si128(m))) & 15u;
}
#endif

/// The nearest of the 16 points @p l to (x, y) in the plane (their z ignored), the lowest index
/// on (near) ties; its squared distance dx² + dy² goes to @p distance.
VOX_ENCODE_INLINE unsigned nearest2(const Points16& l, float x, float y, float& distance) {
    unsigned k = 0;
#if VOX_ENCODE_SSE2
    const __m128 px = _mm_set1_ps(x), py = _mm_set1_ps(y);
    __m128 d[4];
    for (unsigned j = 0; j < 4; ++j) {
        const __m128 dx = _mm_sub_ps(px, _mm_load_ps(l.x.data() + 4 * j)),
                     dy = _mm_sub_ps(py, _mm_load_ps(l.y.data() + 4 * j));
        d[j] = _mm_add_ps(_mm_mul_ps(dx, dx), _mm_mul_ps(dy, dy));
    }
    k = argmin16(d[0], d[1], d[2], d[3]);
#else
    std::array<float, 16> d{};
    for (unsigned j = 0; j < 16; ++j) {
        const float dx = x - l.x[j], dy = y - l.y[j];
        d[j] = dx * dx + dy * dy;
    }
    k = argmin16(d);
#endif
    const float dx = x - l.x[k], dy = y - l.y[k];
    distance = dx * dx + dy * dy;
    return k;
}

/// The nearest of the 16 points @p l to (x, y, z), the lowest index on (near) ties; its squared
/// distance dx² + dy² + dz² goes to @p distance.
VOX_ENCODE_INLINE unsigned nearest3(const Points16& l, float x, float y, float z, float& distance) {
    unsigned k = 0;
#if VOX_ENCODE_SSE2
    const __m128 px = _mm_set1_ps(x), py = _mm_set1_ps(y), pz = _mm_set1_ps(z);
    __m128 d[4];
    for (unsigned j = 0; j < 4; ++j) {
        const __m128 dx = _mm_sub_ps(px, _mm_load_ps(l.x.data() + 4 * j)),
                     dy = _mm_sub_ps(py, _mm_load_ps(l.y.data() + 4 * j)),
                     dz = _mm_sub_ps(pz, _mm_load_ps(l.z.data() + 4 * j));
        d[j] = _mm_add_ps(_mm_add_ps(_mm_mul_ps(dx, dx), _mm_mul_ps(dy, dy)), _mm_mul_ps(dz, dz));
    }
    k = argmin16(d[0], d[1], d[2], d[3]);
#else
    std::array<float, 16> d{};
    for (unsigned j = 0; j < 16; ++j) {
        const float dx = x - l.x[j], dy = y - l.y[j], dz = z - l.z[j];
        d[j] = dx * dx + dy * dy + dz * dz;
    }
    k = argmin16(d);
#endif
    const float dx = x - l.x[k], dy = y - l.y[k], dz = z - l.z[k];
    distance = dx * dx + dy * dy + dz * dz;
    return k;
}

#if VOX_ENCODE_AVX512
VOX_AVX512_WARNINGS_OFF
/// argmin16 of the 16 lanes of @p d, reduced in the SSE2 form's order (its four quarters are
/// its four vectors), so that the two agree whatever the values.
VOX_TARGET_AVX512 VOX_ENCODE_INLINE unsigned argmin16(__m512 d) {
    const __m512i tagged =
        _mm512_or_si512(_mm512_and_si512(_mm512_castps_si512(d), _mm512_set1_epi32(~15)),
                        _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15));
    const __m512 t = _mm512_castsi512_ps(tagged);
    const __m128 t0 = _mm512_castps512_ps128(t), t1 = _mm512_extractf32x4_ps(t, 1),
                 t2 = _mm512_extractf32x4_ps(t, 2), t3 = _mm512_extractf32x4_ps(t, 3);
    __m128 m = _mm_min_ps(_mm_min_ps(t0, t1), _mm_min_ps(t2, t3));
    m = _mm_min_ps(m, _mm_shuffle_ps(m, m, _MM_SHUFFLE(1, 0, 3, 2)));
    m = _mm_min_ps(m, _mm_shuffle_ps(m, m, _MM_SHUFFLE(2, 3, 0, 1)));
    return static_cast<unsigned>(_mm_cvtsi128_si32(_mm_castps_si128(m))) & 15u;
}
VOX_AVX512_WARNINGS_ON
#endif

/// The 16 directions normalise(b + cu·u + cv·v) as esvo::decodeBlockNormal computes them (up to
/// its division by the length, here a multiplication by its inverse), a zero vector as +z.
VOX_ENCODE_INLINE void decodedLattice(const Vec3& b, const Vec3& u, const Vec3& v, Points16& l) {
#if VOX_ENCODE_SSE2
    const __m128 zero = _mm_setzero_ps(), one = _mm_set1_ps(1.0f);
    for (unsigned j = 0; j < 4; ++j) {
        const __m128 cu = _mm_load_ps(kComboU.data() + 4 * j),
                     cv = _mm_load_ps(kComboV.data() + 4 * j);
        const auto part = [&](unsigned c) {
            return _mm_add_ps(_mm_add_ps(_mm_set1_ps(b[c]), _mm_mul_ps(cu, _mm_set1_ps(u[c]))),
                              _mm_mul_ps(cv, _mm_set1_ps(v[c])));
        };
        const __m128 x = part(0), y = part(1), z = part(2);
        const __m128 len2 =
            _mm_add_ps(_mm_add_ps(_mm_mul_ps(x, x), _mm_mul_ps(y, y)), _mm_mul_ps(z, z));
        const __m128 nonzero = _mm_cmpgt_ps(len2, zero);  // false for 0 and NaN
        const __m128 inv = _mm_div_ps(
            one, _mm_sqrt_ps(_mm_or_ps(_mm_and_ps(nonzero, len2), _mm_andnot_ps(nonzero, one))));
        _mm_store_ps(l.x.data() + 4 * j, _mm_and_ps(nonzero, _mm_mul_ps(x, inv)));
        _mm_store_ps(l.y.data() + 4 * j, _mm_and_ps(nonzero, _mm_mul_ps(y, inv)));
        _mm_store_ps(l.z.data() + 4 * j, _mm_or_ps(_mm_and_ps(nonzero, _mm_mul_ps(z, inv)),
                                                   _mm_andnot_ps(nonzero, one)));
    }
#else
    for (unsigned k = 0; k < 16; ++k) {
        l.x[k] = b[0] + kComboU[k] * u[0] + kComboV[k] * v[0];
        l.y[k] = b[1] + kComboU[k] * u[1] + kComboV[k] * v[1];
        l.z[k] = b[2] + kComboU[k] * u[2] + kComboV[k] * v[2];
    }
    for (unsigned k = 0; k < 16; ++k) {
        const float len2 = l.x[k] * l.x[k] + l.y[k] * l.y[k] + l.z[k] * l.z[k];
        // A zero vector decodes as +z (lattices through the origin are among the 3-D fit's).
        const bool zero = !(len2 > 0);
        const float inv = 1.0f / std::sqrt(zero ? 1.0f : len2);
        l.x[k] = zero ? 0.0f : l.x[k] * inv;
        l.y[k] = zero ? 0.0f : l.y[k] * inv;
        l.z[k] = zero ? 1.0f : l.z[k] * inv;
    }
#endif
}

#if VOX_ENCODE_AVX512
/// Whether the AVX-512 kernels run (setEncoderAvx512): initially wherever they can.
std::atomic<bool> g_avx512{cpuFeatures().avx512f};

VOX_AVX512_WARNINGS_OFF
/// The combos' (b + cu·u) + cv·v in one coordinate, for all sixteen combos (the SSE2 kernels'
/// order).
VOX_TARGET_AVX512 VOX_ENCODE_INLINE __m512 comboCoordinate(float b, float u, float v) {
    const __m512 cu = _mm512_loadu_ps(kComboU.data()), cv = _mm512_loadu_ps(kComboV.data());
    return _mm512_add_ps(_mm512_add_ps(_mm512_set1_ps(b), _mm512_mul_ps(cu, _mm512_set1_ps(u))),
                         _mm512_mul_ps(cv, _mm512_set1_ps(v)));
}

/// assignPlane with the sixteen lattice points in one vector.
VOX_TARGET_AVX512 bool assignPlaneAvx512(const NormalPoints& p, PlaneFit& f) {
    const __m512 lx = comboCoordinate(f.bx, f.ux, f.vx), ly = comboCoordinate(f.by, f.uy, f.vy);
    alignas(64) std::array<float, 16> d{};
    bool changed = false;
    double error = 0;
    for (unsigned i = 0; i < p.count; ++i) {
        const __m512 dx = _mm512_sub_ps(_mm512_set1_ps(p.px[i]), lx),
                     dy = _mm512_sub_ps(_mm512_set1_ps(p.py[i]), ly);
        const __m512 d2 = _mm512_add_ps(_mm512_mul_ps(dx, dx), _mm512_mul_ps(dy, dy));
        const unsigned bestK = argmin16(d2);
        _mm512_store_ps(d.data(), d2);
        changed = changed || f.combo[i] != bestK;
        f.combo[i] = static_cast<std::uint8_t>(bestK);
        error += double(p.weight[i]) * d[bestK];
    }
    f.error = error;
    return changed;
}

/// evalLattice with the sixteen decoded directions in one vector each coordinate.
VOX_TARGET_AVX512 double evalLatticeAvx512(const NormalPoints& p, const Vec3& b, const Vec3& u,
                                           const Vec3& v, std::array<std::uint8_t, 16>& combo,
                                           double bound) {
    const __m512 x = comboCoordinate(b[0], u[0], v[0]), y = comboCoordinate(b[1], u[1], v[1]),
                 z = comboCoordinate(b[2], u[2], v[2]);
    const __m512 one = _mm512_set1_ps(1.0f);
    const __m512 len2 =
        _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(x, x), _mm512_mul_ps(y, y)), _mm512_mul_ps(z, z));
    const __mmask16 nonzero =
        _mm512_cmp_ps_mask(len2, _mm512_setzero_ps(), _CMP_GT_OQ);  // false for 0 and NaN
    const __m512 inv = _mm512_div_ps(one, _mm512_sqrt_ps(_mm512_mask_blend_ps(nonzero, one, len2)));
    const __m512 lx = _mm512_maskz_mov_ps(nonzero, _mm512_mul_ps(x, inv)),
                 ly = _mm512_maskz_mov_ps(nonzero, _mm512_mul_ps(y, inv));
    const __m512 lz = _mm512_mask_blend_ps(nonzero, one, _mm512_mul_ps(z, inv));
    alignas(64) std::array<float, 16> d{};
    double total = 0;
    for (unsigned i = 0; i < p.count; ++i) {
        const __m512 dx = _mm512_sub_ps(_mm512_set1_ps(p.n[i][0]), lx),
                     dy = _mm512_sub_ps(_mm512_set1_ps(p.n[i][1]), ly),
                     dz = _mm512_sub_ps(_mm512_set1_ps(p.n[i][2]), lz);
        const __m512 d2 = _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(dx, dx), _mm512_mul_ps(dy, dy)),
                                        _mm512_mul_ps(dz, dz));
        const unsigned bestK = argmin16(d2);
        _mm512_store_ps(d.data(), d2);
        combo[i] = static_cast<std::uint8_t>(bestK);
        total += double(p.multiplicity[i]) * d[bestK];
        if (total > bound) return total;
    }
    return total;
}
VOX_AVX512_WARNINGS_ON
#endif

}  // namespace

std::uint32_t evalColors(const ColorPoints& p, std::uint32_t c0, std::uint32_t c1,
                         std::array<std::uint8_t, 16>& index, std::uint32_t bound) {
    // esvo::colorPalette's arithmetic, here where it inlines: c0, c1, (2a + b + 1)/3, (a + 2b +
    // 1)/3.
    std::array<int, 4> pr{}, pg{}, pb{};
    const auto entries = [](int a, int b, std::array<int, 4>& e) {
        e = {a, b, (2 * a + b + 1) / 3, (a + 2 * b + 1) / 3};
    };
    entries(expand5(static_cast<int>(c0 >> 11) & 31), expand5(static_cast<int>(c1 >> 11) & 31), pr);
    entries(expand6(static_cast<int>(c0 >> 5) & 63), expand6(static_cast<int>(c1 >> 5) & 63), pg);
    entries(expand5(static_cast<int>(c0) & 31), expand5(static_cast<int>(c1) & 31), pb);
#if VOX_ENCODE_SSE2
    // Four colours per vector, squared differences in floats (exact: integers below 2^24), each
    // as 4·d + k, so that a plain min finds the nearest entry and the first of equals (k is the
    // palette index). No early exit: it cost more than it saved.
    (void)bound;
    const unsigned vectors = (p.count + 3) / 4;
    alignas(16) std::array<std::int32_t, 16> packed{};
    for (unsigned j = 0; j < vectors; ++j) {
        const __m128 r = _mm_load_ps(p.channel[0].data() + 4 * j),
                     g = _mm_load_ps(p.channel[1].data() + 4 * j),
                     b = _mm_load_ps(p.channel[2].data() + 4 * j);
        __m128 best = _mm_setzero_ps();
        for (unsigned k = 0; k < 4; ++k) {
            const __m128 dr = _mm_sub_ps(r, _mm_set1_ps(static_cast<float>(pr[k]))),
                         dg = _mm_sub_ps(g, _mm_set1_ps(static_cast<float>(pg[k]))),
                         db = _mm_sub_ps(b, _mm_set1_ps(static_cast<float>(pb[k])));
            const __m128 d =
                _mm_add_ps(_mm_add_ps(_mm_mul_ps(dr, dr), _mm_mul_ps(dg, dg)), _mm_mul_ps(db, db));
            const __m128 tagged =
                _mm_add_ps(_mm_mul_ps(d, _mm_set1_ps(4.0f)), _mm_set1_ps(static_cast<float>(k)));
            best = k == 0 ? tagged : _mm_min_ps(best, tagged);
        }
        _mm_store_si128(reinterpret_cast<__m128i*>(packed.data() + 4 * j), _mm_cvttps_epi32(best));
    }
    std::uint32_t total = 0;
    for (unsigned i = 0; i < p.count; ++i) {
        index[i] = static_cast<std::uint8_t>(packed[i] & 3);
        total += static_cast<std::uint32_t>(packed[i] >> 2);
    }
    return total;
#else
    std::uint32_t total = 0;
    for (unsigned i = 0; i < p.count; ++i) {
        int best = std::numeric_limits<int>::max();
        unsigned bestK = 0;
        for (unsigned k = 0; k < 4; ++k) {
            const int dr = p.rgb[i][0] - pr[k], dg = p.rgb[i][1] - pg[k], db = p.rgb[i][2] - pb[k];
            const int d = dr * dr + dg * dg + db * db;
            if (d < best) {
                best = d;
                bestK = k;
            }
        }
        index[i] = static_cast<std::uint8_t>(bestK);
        total += static_cast<std::uint32_t>(best);
        if (total > bound) return total;
    }
    return total;
#endif
}

bool orderedSplit(const std::array<std::array<float, 20>, 3>& prefix, unsigned n,
                  std::array<unsigned, 3>& split) {
    // Maximise Σ_ch (C X² − 2B XY + A Y²) / det, which is Σ|x|² minus the least-squares error.
    float bestRatio = 0;
    unsigned best0 = 0, best1 = 0, best2 = 0;
    bool found = false;
    const float nf = static_cast<float>(n);
    alignas(16) std::array<float, 20> index2{};
    for (unsigned i = 0; i < 20; ++i) index2[i] = static_cast<float>(i);
    for (unsigned i0 = 0; i0 <= n; ++i0)
        for (unsigned i1 = i0; i1 <= n; ++i1) {
            const float n0 = static_cast<float>(i0), n2 = static_cast<float>(i1 - i0);
            alignas(16) std::array<float, 20> ratio{};
#if VOX_ENCODE_SSE2
            // Four i2 at a time, the same arithmetic as below lane by lane (lanes past n unused).
            {
                const __m128 vn0 = _mm_set1_ps(n0), vn2 = _mm_set1_ps(n2),
                             vi1 = _mm_set1_ps(static_cast<float>(i1)), vnf = _mm_set1_ps(nf);
                const __m128 ninth = _mm_set1_ps(1.0f / 9.0f), twoNinths = _mm_set1_ps(2.0f / 9.0f),
                             third = _mm_set1_ps(1.0f / 3.0f);
                const __m128 two = _mm_set1_ps(2.0f), four = _mm_set1_ps(4.0f),
                             guard = _mm_set1_ps(0.1f);
                for (unsigned i2 = i1; i2 <= n; i2 += 4) {
                    const __m128 idx = _mm_loadu_ps(index2.data() + i2);
                    const __m128 n3 = _mm_sub_ps(idx, vi1), n1 = _mm_sub_ps(vnf, idx);
                    const __m128 aa =
                        _mm_add_ps(vn0, _mm_mul_ps(_mm_add_ps(_mm_mul_ps(four, vn2), n3), ninth));
                    const __m128 ab = _mm_mul_ps(_mm_add_ps(vn2, n3), twoNinths);
                    const __m128 bb =
                        _mm_add_ps(n1, _mm_mul_ps(_mm_add_ps(vn2, _mm_mul_ps(four, n3)), ninth));
                    const __m128 det = _mm_sub_ps(_mm_mul_ps(aa, bb), _mm_mul_ps(ab, ab));
                    __m128 q = _mm_setzero_ps();
                    for (unsigned ch = 0; ch < 3; ++ch) {
                        const float p0 = prefix[ch][i0], p1 = prefix[ch][i1], pn = prefix[ch][n];
                        const __m128 pi2 = _mm_loadu_ps(prefix[ch].data() + i2);
                        const __m128 s0 = _mm_set1_ps(p0), s2 = _mm_set1_ps(p1 - p0),
                                     s3 = _mm_sub_ps(pi2, _mm_set1_ps(p1)),
                                     s1 = _mm_sub_ps(_mm_set1_ps(pn), pi2);
                        const __m128 x =
                            _mm_add_ps(s0, _mm_mul_ps(_mm_add_ps(_mm_mul_ps(two, s2), s3), third));
                        const __m128 y =
                            _mm_add_ps(s1, _mm_mul_ps(_mm_add_ps(s2, _mm_mul_ps(two, s3)), third));
                        const __m128 t = _mm_add_ps(
                            _mm_sub_ps(_mm_mul_ps(_mm_mul_ps(bb, x), x),
                                       _mm_mul_ps(_mm_mul_ps(_mm_mul_ps(two, ab), x), y)),
                            _mm_mul_ps(_mm_mul_ps(aa, y), y));
                        q = _mm_add_ps(q, t);
                    }
                    _mm_storeu_ps(ratio.data() + i2, _mm_div_ps(q, _mm_max_ps(det, guard)));
                }
            }
#else
            for (unsigned i2 = i1; i2 <= n; ++i2) {
                const float n3 = index2[i2] - static_cast<float>(i1), n1 = nf - index2[i2];
                const float aa = n0 + (4.0f * n2 + n3) * (1.0f / 9.0f),
                            ab = (n2 + n3) * (2.0f / 9.0f),
                            bb = n1 + (n2 + 4.0f * n3) * (1.0f / 9.0f);
                const float det = aa * bb - ab * ab;
                float q = 0;
                for (unsigned ch = 0; ch < 3; ++ch) {
                    const float s0 = prefix[ch][i0], s2 = prefix[ch][i1] - s0,
                                s3 = prefix[ch][i2] - prefix[ch][i1],
                                s1 = prefix[ch][n] - prefix[ch][i2];
                    const float x = s0 + (2.0f * s2 + s3) * (1.0f / 3.0f),
                                y = s1 + (s2 + 2.0f * s3) * (1.0f / 3.0f);
                    q += bb * x * x - 2.0f * ab * x * y + aa * y * y;
                }
                // det = Σ over pairs of (αi − αj)² (Lagrange's identity) is ≥ 1/9 unless every
                // colour is on one entry, where det and q vanish: a branch-free guard the compiler
                // can vectorise.
                ratio[i2] = q / std::max(det, 0.1f);
            }
#endif
            for (unsigned i2 = i1; i2 <= n; ++i2)
                if (ratio[i2] > bestRatio) {
                    bestRatio = ratio[i2];
                    best0 = i0;
                    best1 = i1;
                    best2 = i2;
                    found = true;
                }
        }
    if (!found) return false;
    split = {best0, best1, best2};
    return true;
}

bool assignPlane(const NormalPoints& p, PlaneFit& f) {
#if VOX_ENCODE_AVX512
    if (g_avx512.load(std::memory_order_relaxed)) return assignPlaneAvx512(p, f);
#endif
    Points16 l;
    for (unsigned k = 0; k < 16; ++k) {
        l.x[k] = f.bx + kComboU[k] * f.ux + kComboV[k] * f.vx;
        l.y[k] = f.by + kComboU[k] * f.uy + kComboV[k] * f.vy;
    }
    bool changed = false;
    double error = 0;
    for (unsigned i = 0; i < p.count; ++i) {
        float d = 0;
        const unsigned bestK = nearest2(l, p.px[i], p.py[i], d);
        changed = changed || f.combo[i] != bestK;
        f.combo[i] = static_cast<std::uint8_t>(bestK);
        error += double(p.weight[i]) * d;
    }
    f.error = error;
    return changed;
}

double evalLattice(const NormalPoints& p, const Vec3& b, const Vec3& u, const Vec3& v,
                   std::array<std::uint8_t, 16>& combo, double bound) {
#if VOX_ENCODE_AVX512
    if (g_avx512.load(std::memory_order_relaxed))
        return evalLatticeAvx512(p, b, u, v, combo, bound);
#endif
    // The 16 decoded directions, in arrays the compiler can vectorise over.
    Points16 l;
    decodedLattice(b, u, v, l);
    // |n − d|² = 2 (1 − cos): the same order, but precise for tiny angles, where 1 − cos in
    // float is not.
    double total = 0;
    for (unsigned i = 0; i < p.count; ++i) {
        float d = 0;
        const unsigned bestK = nearest3(l, p.n[i][0], p.n[i][1], p.n[i][2], d);
        combo[i] = static_cast<std::uint8_t>(bestK);
        total += double(p.multiplicity[i]) * d;
        if (total > bound) return total;
    }
    return total;
}

template <unsigned FreeAxes>
NormalEquations normalEquationsSingle(const NormalPoints& p, const Model& x,
                                      const std::array<std::uint8_t, 16>& combo) {
    constexpr bool used[3]{true, (FreeAxes & 1u) != 0, (FreeAxes & 2u) != 0};
    std::array<float, 9> xf{};
    for (unsigned j = 0; j < 9; ++j) xf[j] = static_cast<float>(x[j]);
    alignas(16) float block[6][6][4]{};
    alignas(16) float g[9][4]{};
    for (unsigned first = 0; first < p.count; first += 4) {
        // The group's points, lane by lane (a lane past the points has weight 0).
        alignas(16) float k[3][4], n[3][4], multiplicity[4];
        for (unsigned l = 0; l < 4; ++l) {
            const unsigned i = std::min(first + l, p.count - 1);
            k[0][l] = 1.0f;
            k[1][l] = esvo::kAxisWeights[combo[i] & 3];
            k[2][l] = esvo::kAxisWeights[combo[i] >> 2];
            for (unsigned c = 0; c < 3; ++c) n[c][l] = p.n[i][c];
            multiplicity[l] = first + l < p.count ? p.multiplicity[i] : 0.0f;
        }
#if VOX_ENCODE_SSE2
        __m128 kv[3], nv[3], q[3];
        for (unsigned c = 0; c < 3; ++c) kv[c] = _mm_load_ps(k[c]), nv[c] = _mm_load_ps(n[c]);
        for (unsigned c = 0; c < 3; ++c)
            q[c] = _mm_add_ps(
                _mm_add_ps(_mm_set1_ps(xf[c]), _mm_mul_ps(kv[1], _mm_set1_ps(xf[3 + c]))),
                _mm_mul_ps(kv[2], _mm_set1_ps(xf[6 + c])));
        const __m128 len2 = _mm_add_ps(_mm_add_ps(_mm_mul_ps(q[0], q[0]), _mm_mul_ps(q[1], q[1])),
                                       _mm_mul_ps(q[2], q[2]));
        const __m128 valid = _mm_cmpgt_ps(len2, _mm_set1_ps(1e-24f)), one = _mm_set1_ps(1.0f);
        const __m128 inv = _mm_div_ps(
            one, _mm_sqrt_ps(_mm_or_ps(_mm_and_ps(valid, len2), _mm_andnot_ps(valid, one))));
        const __m128 weight = _mm_and_ps(valid, _mm_load_ps(multiplicity)),
                     inv2 = _mm_mul_ps(_mm_mul_ps(inv, inv), weight);
        for (unsigned c = 0; c < 3; ++c) q[c] = _mm_mul_ps(q[c], inv);
        const __m128 nd = _mm_add_ps(_mm_add_ps(_mm_mul_ps(nv[0], q[0]), _mm_mul_ps(nv[1], q[1])),
                                     _mm_mul_ps(nv[2], q[2]));
        const __m128 zero = _mm_setzero_ps();
        const __m128 m[6]{_mm_mul_ps(_mm_sub_ps(one, _mm_mul_ps(q[0], q[0])), inv2),
                          _mm_mul_ps(_mm_mul_ps(_mm_sub_ps(zero, q[1]), q[0]), inv2),
                          _mm_mul_ps(_mm_sub_ps(one, _mm_mul_ps(q[1], q[1])), inv2),
                          _mm_mul_ps(_mm_mul_ps(_mm_sub_ps(zero, q[2]), q[0]), inv2),
                          _mm_mul_ps(_mm_mul_ps(_mm_sub_ps(zero, q[2]), q[1]), inv2),
                          _mm_mul_ps(_mm_sub_ps(one, _mm_mul_ps(q[2], q[2])), inv2)};
        __m128 r[3];
        for (unsigned c = 0; c < 3; ++c)
            r[c] = _mm_mul_ps(
                _mm_mul_ps(_mm_sub_ps(zero, _mm_sub_ps(nv[c], _mm_mul_ps(nd, q[c]))), inv), weight);
        for (unsigned st = 0, si = 0; si < 3; ++si)
            for (unsigned ti = 0; ti <= si; ++ti, ++st) {
                if (!used[si] || !used[ti]) continue;
                const __m128 kk = _mm_mul_ps(kv[si], kv[ti]);
                for (unsigned e = 0; e < 6; ++e)
                    _mm_store_ps(block[st][e],
                                 _mm_add_ps(_mm_load_ps(block[st][e]), _mm_mul_ps(kk, m[e])));
            }
        for (unsigned c = 0; c < 3; ++c)
            for (unsigned si = 0; si < 3; ++si)
                _mm_store_ps(g[3 * si + c],
                             _mm_add_ps(_mm_load_ps(g[3 * si + c]), _mm_mul_ps(kv[si], r[c])));
#else
        for (unsigned l = 0; l < 4;
             ++l) {  // the same operations as the vectors above, lane by lane
            float q[3];
            for (unsigned c = 0; c < 3; ++c)
                q[c] = (xf[c] + k[1][l] * xf[3 + c]) + k[2][l] * xf[6 + c];
            const float len2 = (q[0] * q[0] + q[1] * q[1]) + q[2] * q[2];
            const bool valid = len2 > 1e-24f;
            const float inv = 1.0f / std::sqrt(valid ? len2 : 1.0f);
            const float weight = valid ? multiplicity[l] : 0.0f, inv2 = (inv * inv) * weight;
            for (float& c : q) c *= inv;
            const float nd = (n[0][l] * q[0] + n[1][l] * q[1]) + n[2][l] * q[2];
            const float m[6]{(1.0f - q[0] * q[0]) * inv2,   ((0.0f - q[1]) * q[0]) * inv2,
                             (1.0f - q[1] * q[1]) * inv2,   ((0.0f - q[2]) * q[0]) * inv2,
                             ((0.0f - q[2]) * q[1]) * inv2, (1.0f - q[2] * q[2]) * inv2};
            for (unsigned st = 0, si = 0; si < 3; ++si)
                for (unsigned ti = 0; ti <= si; ++ti, ++st) {
                    if (!used[si] || !used[ti]) continue;
                    const float kk = k[si][l] * k[ti][l];
                    for (unsigned e = 0; e < 6; ++e) block[st][e][l] += kk * m[e];
                }
            for (unsigned c = 0; c < 3; ++c) {
                const float r = ((0.0f - (n[c][l] - nd * q[c])) * inv) * weight;
                for (unsigned si = 0; si < 3; ++si) g[3 * si + c][l] += k[si][l] * r;
            }
        }
#endif
    }
    NormalEquations ne;
    const auto sum = [](const float(&lanes)[4]) {
        return (double(lanes[0]) + double(lanes[1])) + (double(lanes[2]) + double(lanes[3]));
    };
    for (unsigned st = 0; st < 6; ++st)
        for (unsigned e = 0; e < 6; ++e) ne.block[st][e] = sum(block[st][e]);
    for (unsigned j = 0; j < 9; ++j) ne.g[j] = sum(g[j]);
    return ne;
}

template NormalEquations normalEquationsSingle<0>(const NormalPoints&, const Model&,
                                                  const std::array<std::uint8_t, 16>&);
template NormalEquations normalEquationsSingle<1>(const NormalPoints&, const Model&,
                                                  const std::array<std::uint8_t, 16>&);
template NormalEquations normalEquationsSingle<2>(const NormalPoints&, const Model&,
                                                  const std::array<std::uint8_t, 16>&);
template NormalEquations normalEquationsSingle<3>(const NormalPoints&, const Model&,
                                                  const std::array<std::uint8_t, 16>&);

}  // namespace vox::detail::encode

namespace vox::detail {

bool setEncoderAvx512(bool enabled) noexcept {
#if VOX_ENCODE_AVX512
    const bool on = enabled && cpuFeatures().avx512f;
    encode::g_avx512.store(on);
    return on;
#else
    (void)enabled;
    return false;
#endif
}

bool encoderAvx512() noexcept {
#if VOX_ENCODE_AVX512
    return encode::g_avx512.load();
#else
    return false;
#endif
}

}  // namespace vox::detail

namespace vox {

const char* attributeEncoderKernels() noexcept {
    return detail::encoderAvx512() ? "avx512" : (VOX_ENCODE_SSE2 ? "sse2" : "scalar");
}

}  // namespace vox
