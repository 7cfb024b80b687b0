#include "attribute_encode.h"

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <numbers>
#include <span>

#if defined(__SSE2__) && \
    !defined(VOX_ENCODE_NO_SIMD)  // the scalar fallback computes the same values
#include <emmintrin.h>
#define VOX_ENCODE_SSE2 1
#else
#define VOX_ENCODE_SSE2 0
#endif
// AVX-512 kernels, chosen at run time where the CPU has AVX-512F: the same operations lane by
// lane as the SSE2 ones (the file is compiled without contraction into FMAs), sixteen lanes at
// once, so that both give the same bits.
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

namespace vox::detail {
namespace {

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

constexpr int expand5(int c) { return (c << 3) | (c >> 2); }
constexpr int expand6(int c) { return (c << 2) | (c >> 4); }

/// Lookup tables built once: the code whose expansion is nearest to each 8-bit value, and for
/// single-colour blocks the endpoint pair whose ⅔a + ⅓b palette entry (with colorPalette's
/// rounding) is nearest; the pair a = b also covers the endpoints themselves.
struct ColorTables {
    std::array<std::uint8_t, 256> nearest5{}, nearest6{};
    std::array<std::array<std::uint8_t, 2>, 256> single5{}, single6{};
};

template <int Bits>
void fillTables(std::array<std::uint8_t, 256>& nearest,
                std::array<std::array<std::uint8_t, 2>, 256>& single) {
    constexpr int kCodes = 1 << Bits;
    const auto expand = [](int c) { return Bits == 5 ? expand5(c) : expand6(c); };
    for (int value = 0; value < 256; ++value) {
        int best = 0;
        for (int c = 1; c < kCodes; ++c)
            if (std::abs(expand(c) - value) < std::abs(expand(best) - value)) best = c;
        nearest[value] = static_cast<std::uint8_t>(best);
        int bestError = std::numeric_limits<int>::max();
        for (int a = 0; a < kCodes; ++a)
            for (int b = 0; b < kCodes; ++b) {
                const int error = std::abs((2 * expand(a) + expand(b) + 1) / 3 - value);
                if (error < bestError) {
                    bestError = error;
                    single[value] = {static_cast<std::uint8_t>(a), static_cast<std::uint8_t>(b)};
                }
            }
    }
}

const ColorTables& colorTables() {
    static const ColorTables tables = [] {
        ColorTables t;
        fillTables<5>(t.nearest5, t.single5);
        fillTables<6>(t.nearest6, t.single6);
        return t;
    }();
    return tables;
}

/// std::clamp(std::lround(x), 0, 255) (rounding half away from zero, NaN to 0) without the
/// library call.
inline std::size_t roundByte(float x) {
    if (!(x > 0)) return 0;  // also NaN, as lround's LONG_MIN clamped
    if (!(x < 255)) return 255;
    const int t = static_cast<int>(x);  // truncation, exact for 0 < x < 255
    return static_cast<std::size_t>(t + (x - static_cast<float>(t) >= 0.5f ? 1 : 0));
}

/// Nearest RGB565 code of a float RGB endpoint.
std::uint32_t quantise565(const std::array<float, 3>& c, const ColorTables& t) {
    const auto channel = [](float x) { return roundByte(x); };
    return (std::uint32_t{t.nearest5[channel(c[0])]} << 11) |
           (std::uint32_t{t.nearest6[channel(c[1])]} << 5) | t.nearest5[channel(c[2])];
}

/// Endpoints, their error over the used colours, and each used colour's palette index.
struct ColorState {
    std::uint32_t c0 = 0, c1 = 0;
    std::uint32_t error = std::numeric_limits<std::uint32_t>::max();
    std::array<std::uint8_t, 16> index{};
};

/// Summed squared error of the used colours against the palette of (c0, c1), each taking its
/// nearest entry (the lowest index on ties). Stops early once the sum exceeds @p bound.
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

/// Replaces @p s by endpoints (c0, c1) if they decode with a smaller error.
bool tryColors(const ColorPoints& p, std::uint32_t c0, std::uint32_t c1, ColorState& s) {
    if (s.error != std::numeric_limits<std::uint32_t>::max() &&
        ((c0 == s.c0 && c1 == s.c1) || (c0 == s.c1 && c1 == s.c0)))
        return false;
    std::array<std::uint8_t, 16> index{};
    const std::uint32_t error = evalColors(p, c0, c1, index, s.error);
    if (error >= s.error) return false;
    s.c0 = c0;
    s.c1 = c1;
    s.error = error;
    s.index = index;
    return true;
}

/// Least-squares endpoints for fixed indices (the cluster-fit step); false when the indices do
/// not determine both endpoints (every colour on one palette entry).
bool refitColors(const ColorPoints& p, const std::array<std::uint8_t, 16>& index,
                 std::array<float, 3>& a, std::array<float, 3>& b) {
    static constexpr std::array<float, 4> kWeight{1.0f, 0.0f, 2.0f / 3.0f, 1.0f / 3.0f};
    float aa = 0, ab = 0, bb = 0;
    std::array<float, 3> xa{}, xb{};
    for (unsigned i = 0; i < p.count; ++i) {
        const float alpha = kWeight[index[i]], beta = 1.0f - alpha;
        aa += alpha * alpha;
        ab += alpha * beta;
        bb += beta * beta;
        for (unsigned ch = 0; ch < 3; ++ch) {
            xa[ch] += alpha * static_cast<float>(p.rgb[i][ch]);
            xb[ch] += beta * static_cast<float>(p.rgb[i][ch]);
        }
    }
    const float det = aa * bb - ab * ab;
    if (!(det > 1e-3f)) return false;
    for (unsigned ch = 0; ch < 3; ++ch) {
        a[ch] = (bb * xa[ch] - ab * xb[ch]) / det;
        b[ch] = (aa * xb[ch] - ab * xa[ch]) / det;
    }
    return true;
}

/// Alternates index assignment and least-squares endpoints (rounded to RGB565) while it helps.
void clusterFit(const ColorPoints& p, const ColorTables& t, ColorState& s, int iterations = 8) {
    for (int iteration = 0; iteration < iterations && s.error > 0; ++iteration) {
        std::array<float, 3> a{}, b{};
        if (!refitColors(p, s.index, a, b)) return;
        if (!tryColors(p, quantise565(a, t), quantise565(b, t), s)) return;
    }
}

/// Greedy descent over the six endpoint channels, one code step at a time. @p guided: each
/// channel steps only towards its least-squares value for the current indices (refitColors),
/// half the measurements, where the indices determine both endpoints.
void stepColors(const ColorPoints& p, ColorState& s, int passes = 16, bool guided = false) {
    static constexpr std::array<unsigned, 3> kShift{11, 5, 0};
    static constexpr std::array<std::uint32_t, 3> kMax{31, 63, 31};
    for (int pass = 0; pass < passes && s.error > 0; ++pass) {
        std::array<std::array<float, 3>, 2> target{};
        const bool towards = guided && refitColors(p, s.index, target[0], target[1]);
        bool improved = false;
        for (unsigned endpoint = 0; endpoint < 2; ++endpoint)
            for (unsigned ch = 0; ch < 3; ++ch)
                for (const int step : {-1, 1}) {
                    const std::uint32_t c = endpoint ? s.c1 : s.c0;
                    const std::uint32_t value = (c >> kShift[ch]) & kMax[ch];
                    if ((step < 0 && value == 0) || (step > 0 && value == kMax[ch])) continue;
                    if (towards) {
                        const int expanded = ch == 1 ? expand6(static_cast<int>(value))
                                                     : expand5(static_cast<int>(value));
                        if ((target[endpoint][ch] - static_cast<float>(expanded)) *
                                static_cast<float>(step) <=
                            0)
                            continue;
                    }
                    const std::uint32_t moved =
                        (c & ~(kMax[ch] << kShift[ch])) |
                        ((static_cast<std::uint32_t>(static_cast<int>(value) + step))
                         << kShift[ch]);
                    if (endpoint ? tryColors(p, s.c0, moved, s) : tryColors(p, moved, s.c1, s))
                        improved = true;
                }
        if (!improved) break;
    }
}

/// Principal axis of the colours' covariance (power iteration from the bounding-box diagonal).
std::array<float, 3> principalAxis(const ColorPoints& p, const std::array<float, 3>& mean,
                                   const std::array<float, 3>& diagonal) {
    std::array<float, 6> cov{};  // xx xy xz yy yz zz
    for (unsigned i = 0; i < p.count; ++i) {
        const float x = static_cast<float>(p.rgb[i][0]) - mean[0],
                    y = static_cast<float>(p.rgb[i][1]) - mean[1],
                    z = static_cast<float>(p.rgb[i][2]) - mean[2];
        cov[0] += x * x;
        cov[1] += x * y;
        cov[2] += x * z;
        cov[3] += y * y;
        cov[4] += y * z;
        cov[5] += z * z;
    }
    std::array<float, 3> v = diagonal;
    for (int iteration = 0; iteration < 8; ++iteration) {
        const std::array<float, 3> w{cov[0] * v[0] + cov[1] * v[1] + cov[2] * v[2],
                                     cov[1] * v[0] + cov[3] * v[1] + cov[4] * v[2],
                                     cov[2] * v[0] + cov[4] * v[1] + cov[5] * v[2]};
        const float len = std::max({std::fabs(w[0]), std::fabs(w[1]), std::fabs(w[2])});
        if (!(len > 0)) break;
        v = {w[0] / len, w[1] / len, w[2] / len};
    }
    const float len = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (!(len > 0)) return {1, 0, 0};
    return {v[0] / len, v[1] / len, v[2] / len};
}

/// Exhaustive cluster fit along the principal axis (as squish's ClusterFit): the colours sorted
/// by their projection, every split of that order into the four palette entries in line
/// (c0, ⅔c0+⅓c1, ⅓c0+⅔c1, c1) and its least-squares endpoints; returns the endpoints of the
/// split with the smallest unquantised error. False when no split determines both endpoints.
bool orderedClusterFit(const ColorPoints& p, const std::array<float, 3>& mean,
                       const std::array<float, 3>& axis, std::array<float, 3>& a,
                       std::array<float, 3>& b) {
    const unsigned n = p.count;
    std::array<float, 16> proj{};
    std::array<unsigned, 16> order{};
    for (unsigned i = 0; i < n; ++i) {
        order[i] = i;
        for (unsigned ch = 0; ch < 3; ++ch)
            proj[i] += (static_cast<float>(p.rgb[i][ch]) - mean[ch]) * axis[ch];
    }
    std::sort(order.begin(), order.begin() + n, [&](unsigned x, unsigned y) {
        return proj[x] < proj[y] || (proj[x] == proj[y] && x < y);
    });
    // Prefix sums of the sorted colours per channel, laid out so that the compiler can vectorise
    // the inner loop (over the start of the last cluster).
    // (Padded past n with the total, so that four lanes can always be loaded.)
    alignas(16) std::array<std::array<float, 20>, 3> prefix{};
    for (unsigned ch = 0; ch < 3; ++ch) {
        for (unsigned i = 0; i < n; ++i)
            prefix[ch][i + 1] = prefix[ch][i] + static_cast<float>(p.rgb[order[i]][ch]);
        for (unsigned i = n + 1; i < 20; ++i) prefix[ch][i] = prefix[ch][n];
    }
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
    std::array<std::uint8_t, 16> index{};
    for (unsigned i = 0; i < n; ++i)
        index[order[i]] = i < best0 ? 0 : (i < best1 ? 2 : (i < best2 ? 3 : 1));
    return refitColors(p, index, a, b);
}

/// Summed squared error per used colour above which orderedClusterFit is tried.
constexpr std::uint32_t kOrderedFitThreshold = 20;

/// How hard the colour encoder searches (see AttributeEffort): start pairs tried (of three),
/// cluster-fit iterations, the error per colour above which the ordered cluster fit runs, and
/// passes of the endpoint descent, and whether it steps only towards the least-squares
/// endpoints. Best is the original search.
struct ColorSearch {
    unsigned startPairs = 3;
    int clusterIterations = 8;
    std::uint32_t orderedThreshold = kOrderedFitThreshold;
    int stepPasses = 16;
    bool guidedStep = false;
};

ColorSearch colorSearch(AttributeEffort effort) {
    ColorSearch s;
    if (effort == AttributeEffort::Best) return s;
    s.startPairs = 1;
    s.clusterIterations = 2;
    s.stepPasses = 1;
    s.guidedStep = true;
    // (The ordered fit costs about as much as the rest of the search where it runs.)
    s.orderedThreshold =
        effort == AttributeEffort::Fast ? 2 * kOrderedFitThreshold : kOrderedFitThreshold + 5;
    return s;
}

ColorState encodeColors(const ColorPoints& p, AttributeEffort effort) {
    const ColorSearch search = colorSearch(effort);
    const ColorTables& t = colorTables();
    ColorState best;

    std::array<int, 3> lo{255, 255, 255}, hi{0, 0, 0};
    std::array<float, 3> mean{};
    bool single = true;
    for (unsigned i = 0; i < p.count; ++i) {
        for (unsigned ch = 0; ch < 3; ++ch) {
            lo[ch] = std::min(lo[ch], p.rgb[i][ch]);
            hi[ch] = std::max(hi[ch], p.rgb[i][ch]);
            mean[ch] += static_cast<float>(p.rgb[i][ch]);
        }
        single = single && p.rgb[i] == p.rgb[0];
    }
    for (float& m : mean) m /= static_cast<float>(p.count);

    // One colour: per channel the best endpoint pair of the precomputed tables (optimal).
    const auto singleFit = [&](const std::array<int, 3>& c) {
        const auto& r = t.single5[static_cast<std::size_t>(c[0])];
        const auto& g = t.single6[static_cast<std::size_t>(c[1])];
        const auto& b = t.single5[static_cast<std::size_t>(c[2])];
        tryColors(p, (std::uint32_t{r[0]} << 11) | (std::uint32_t{g[0]} << 5) | b[0],
                  (std::uint32_t{r[1]} << 11) | (std::uint32_t{g[1]} << 5) | b[1], best);
    };
    singleFit(single ? p.rgb[0]
                     : std::array<int, 3>{static_cast<int>(std::lround(mean[0])),
                                          static_cast<int>(std::lround(mean[1])),
                                          static_cast<int>(std::lround(mean[2]))});
    if (single || best.error == 0) return best;

    // Start points: the principal axis' extent through the mean, the two colours at its ends,
    // and the bounding-box diagonal along it; each improved by cluster fitting.
    const std::array<float, 3> axis =
        principalAxis(p, mean,
                      {static_cast<float>(hi[0] - lo[0]), static_cast<float>(hi[1] - lo[1]),
                       static_cast<float>(hi[2] - lo[2])});
    float tMin = std::numeric_limits<float>::max(), tMax = -tMin;
    unsigned iMin = 0, iMax = 0;
    for (unsigned i = 0; i < p.count; ++i) {
        float proj = 0;
        for (unsigned ch = 0; ch < 3; ++ch)
            proj += (static_cast<float>(p.rgb[i][ch]) - mean[ch]) * axis[ch];
        if (proj < tMin) tMin = proj, iMin = i;
        if (proj > tMax) tMax = proj, iMax = i;
    }
    const auto toFloat = [](const std::array<int, 3>& c) {
        return std::array<float, 3>{static_cast<float>(c[0]), static_cast<float>(c[1]),
                                    static_cast<float>(c[2])};
    };
    std::array<std::array<float, 3>, 6> starts{};
    for (unsigned ch = 0; ch < 3; ++ch) {
        starts[0][ch] = mean[ch] + tMin * axis[ch];
        starts[1][ch] = mean[ch] + tMax * axis[ch];
        const bool rising = axis[ch] >= 0;
        starts[4][ch] = static_cast<float>(rising ? lo[ch] : hi[ch]);
        starts[5][ch] = static_cast<float>(rising ? hi[ch] : lo[ch]);
    }
    starts[2] = toFloat(p.rgb[iMin]);
    starts[3] = toFloat(p.rgb[iMax]);
    for (unsigned s = 0; s < 2 * search.startPairs && best.error > 0; s += 2) {
        ColorState candidate;
        tryColors(p, quantise565(starts[s], t), quantise565(starts[s + 1], t), candidate);
        clusterFit(p, t, candidate, search.clusterIterations);
        if (candidate.error < best.error) best = candidate;
    }
    // Blocks still far off (RMS above ~2.6 per channel) are worth the exhaustive ordered fit.
    if (best.error > search.orderedThreshold * p.count) {
        std::array<float, 3> a{}, b{};
        if (orderedClusterFit(p, mean, axis, a, b)) {
            ColorState candidate;
            tryColors(p, quantise565(a, t), quantise565(b, t), candidate);
            clusterFit(p, t, candidate, search.clusterIterations);
            if (candidate.error < best.error) best = candidate;
        }
    }
    stepColors(p, best, search.stepPasses, search.guidedStep);
    clusterFit(p, t, best, search.clusterIterations);
    return best;
}

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

#if defined(__GNUC__)
#define VOX_ENCODE_INLINE [[gnu::always_inline]] inline
#else
#define VOX_ENCODE_INLINE inline
#endif

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

/// A fit in the face plane: p ≈ b + cu·u + cv·v, combo k = uIndex + 4·vIndex.
struct PlaneFit {
    float bx = 0, by = 0, ux = 0, uy = 0, vx = 0, vy = 0;
    double error = std::numeric_limits<double>::max();
    std::array<std::uint8_t, 16> combo{};
};

#if VOX_ENCODE_AVX512
/// Whether the CPU (and the OS, which __builtin_cpu_supports also asks) has AVX-512F.
bool avx512Available() { return __builtin_cpu_supports("avx512f") != 0; }

/// Whether the AVX-512 kernels run (setEncoderAvx512): initially wherever they can.
std::atomic<bool> g_avx512{avx512Available()};

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
VOX_AVX512_WARNINGS_ON
#endif

/// Assigns every point its nearest of the 16 lattice points; true when a combo changed.
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

/// A quantised normal block: words 2 (base) and 4 (axes), the summed squared chord error of the
/// used normals (see evalNormals) and their combos.
struct NormalState {
    std::uint32_t base = 0, axes = 0;
    double error = std::numeric_limits<double>::max();
    std::array<std::uint8_t, 16> combo{};
};

#if VOX_ENCODE_AVX512
VOX_AVX512_WARNINGS_OFF
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

/// Summed squared chord |n − d|² = 2 (1 − cos) between each used normal n and the nearest d of
/// the 16 directions normalise(b + cu·u + cv·v), computed as esvo::decodeBlockNormal computes
/// them; the nearest one's combo goes to @p combo. Stops early beyond @p bound.
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

/// evalLattice of the decoded (base, axes) words.
double evalNormals(const NormalPoints& p, std::uint32_t base, std::uint32_t axes,
                   std::array<std::uint8_t, 16>& combo, double bound) {
    return evalLattice(p, esvo::decodeNormal(base), esvo::decodeAxis(axes & 0xFFFFu),
                       esvo::decodeAxis(axes >> 16), combo, bound);
}

bool tryNormals(const NormalPoints& p, std::uint32_t base, std::uint32_t axes, NormalState& s) {
    if (s.error != std::numeric_limits<double>::max() && base == s.base && axes == s.axes)
        return false;
    std::array<std::uint8_t, 16> combo{};
    const double error = evalNormals(p, base, axes, combo, s.error);
    if (!(error < s.error)) return false;
    s.base = base;
    s.axes = axes;
    s.error = error;
    s.combo = combo;
    return true;
}

/// Re-rounds a 16-bit axis at exponent @p e (components clamped to −8 … 7).
std::uint32_t roundAxis(const Vec3& a, int e) {
    const float step = std::ldexp(1.0f, e - 13);
    std::uint32_t bits = static_cast<std::uint32_t>(e) << 12;
    for (unsigned c = 0; c < 3; ++c) {
        const long q = std::clamp(std::lround(a[c] / step), -8l, 7l);
        bits |= (static_cast<std::uint32_t>(q) & 15u) << (4 * c);
    }
    return bits;
}

/// One pass over the axis codes around @p s: each of the @p components of either axis one step
/// either way, and each axis one exponent finer or coarser (re-rounded). True if any improved.
bool stepAxisCodes(const NormalPoints& p, NormalState& s, std::span<const unsigned> components) {
    bool improved = false;
    for (unsigned which = 0; which < 2; ++which) {
        const unsigned shift = 16 * which;
        for (const unsigned c : components)
            for (const int step : {-1, 1}) {
                const std::uint32_t bits = (s.axes >> shift) & 0xFFFFu;
                const int value =
                    static_cast<int>(static_cast<std::int32_t>(bits << (28 - 4 * c)) >> 28) + step;
                if (value < -8 || value > 7) continue;
                const std::uint32_t moved = (bits & ~(15u << (4 * c))) |
                                            ((static_cast<std::uint32_t>(value) & 15u) << (4 * c));
                if (tryNormals(p, s.base, (s.axes & ~(0xFFFFu << shift)) | (moved << shift), s))
                    improved = true;
            }
        const std::uint32_t bits = (s.axes >> shift) & 0xFFFFu;
        const int e = static_cast<int>(bits >> 12);
        const Vec3 decoded = esvo::decodeAxis(bits);
        for (const int ne : {e - 1, e + 1}) {
            if (ne < 0 || ne > 15) continue;
            if (tryNormals(p, s.base,
                           (s.axes & ~(0xFFFFu << shift)) | (roundAxis(decoded, ne) << shift), s))
                improved = true;
        }
    }
    return improved;
}

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

/// Component @p c (0…2) of axis code @p bits, in steps (esvo::decodeAxis without the scale).
inline int axisDigit(std::uint32_t bits, unsigned c) {
    return static_cast<std::int32_t>(bits << (28 - 4 * c)) >> 28;
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

/// The codes of a face-plane fit (planeBase and planeAxes).
NormalState planeCodes(const NormalPoints& p, const PlaneFit& f) {
    NormalState s;
    float scale = 1;
    s.base = planeBase(p, f.bx, f.by, scale);
    s.axes = planeAxes(p, f, scale);
    return s;
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

/// Quantises a plane fit: the base through encodeNormal (rescaling the axes when the base falls
/// off its face), the axes through encodeAxis; then refits the base to the quantised axes and
/// searches neighbouring axis codes, all measured against the decoded normals.
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

/// Projects the normals onto their face plane and fits the lattice there (fitPlane, or
/// fitPlaneOnCodes when @p onCodes) from the starts in @p startMask (bit i: start i; start 0
/// always), keeping the lowest error;
/// @p afterFirst(fit) is called with the first start's fit, and when it returns true, the others
/// are not tried.
template <typename AfterFirst>
PlaneFit fitNormals(NormalPoints& p, unsigned startMask, bool onCodes, AfterFirst afterFirst) {
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
        if (i == 0 && afterFirst(fit)) break;
    }
    return best;
}

// ---- The 3-D fit ------------------------------------------------------------------------------
// The face-plane fit cannot serve blocks whose normals span 90° or more: the voxels along the
// edges and corners where walls meet (+x, +y and their average), or both sides of a thin sheet
// (+y and −y). The decoded directions are the central projection of a planar lattice
// b + cu·u + cv·v that may lie anywhere in space, and the fit below works with that lattice
// directly: unquantised models built exactly through up to four cluster representatives of the
// normals (and the face-plane fit lifted to 3-D), each refined by Levenberg–Marquardt on the
// decoded error; the best are quantised and refined on the codes.
//
// The search costs several times the face-plane fit, so it runs only where that fit leaves an
// error worth the time, and builds the cluster models only for blocks wide enough to need them.

/// Blocks whose normals span more than 30° ("wide"), or that hold at most four distinct
/// directions (more than ~1° apart), get models through clusters of their normals; others only
/// the face-plane fit lifted to 3-D.
constexpr double kWideCos = 0.8660254, kDistinctCos = 0.99985;

/// Summed squared chord per used normal (≈ squared angle) above which the face-plane fit is
/// followed by the 3-D search: (1°)² for narrow blocks, where the face-plane fit is nearly always
/// as good, (0.3°)² for wide ones.
constexpr double kDegree2 = (std::numbers::pi / 180) * (std::numbers::pi / 180);
constexpr double kNarrowThreshold = 1.0 * 1.0 * kDegree2, kWideThreshold = 0.3 * 0.3 * kDegree2;

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
constexpr double kEnough = 0.02 * 0.02 * kDegree2;

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

/// The 3-D search of blocks of at most four distinct directions: the code-search quantiser
/// (quantiseModel, whose lattice-line codes, rounding with the rest refit and second candidate
/// keep any two directions within about a degree); for the faster efforts with fewer refined
/// candidates, u rounded first only, and the code search guided.
NormalSearch fewSearch(AttributeEffort effort) {
    NormalSearch s;
    if (effort == AttributeEffort::Best) return s;
    const bool fast = effort == AttributeEffort::Fast;
    s.wideThreshold = (fast ? 0.7 * 0.7 : 0.5 * 0.5) * kDegree2;
    s.refined = 2;
    s.moreIterations = fast ? 2 : 3;
    s.modelCodes = {fast ? 1 : 3, 3};
    s.enoughPerNormal = kEnough;
    s.secondAbove = 1.2;
    s.roundBothAxes = false;  // (the guided code search finds most of what rounding v first does)
    return s;
}

/// The search of each effort (@p light: of the 3-D search of a block whose face-plane fit is
/// already within lightBelow). Best is the original exhaustive search; the others were chosen
/// on the real blocks of bench/attribute_encode_bench --scene (docs/esvo-format.md §14).
NormalSearch normalSearch(AttributeEffort effort, bool light = false) {
    NormalSearch s;
    if (effort == AttributeEffort::Best) return s;
    const bool fast = effort == AttributeEffort::Fast;
    // The face-plane fit on the codes: Default from the ¾-size start, the two 45° ones and the
    // one-dimensional one, Fast from the ¾-size and the 45° one; neither tries the others where
    // the first already fits within 0.05° (Fast 0.1°).
    s.planeOnCodes = true;
    s.singleEquations = true;
    s.startMask = fast ? 0b10001u : 0b111001u;
    s.earlyBelow = (fast ? 0.1 * 0.1 : 0.05 * 0.05) * kDegree2;
    s.wideThreshold = (fast ? 0.7 * 0.7 : 0.5 * 0.5) * kDegree2;
    s.enumerateModel = true;
    s.modelCodes = {fast ? 1 : 3, 3};
    s.lightBelow = (fast ? 2.0 * 2.0 : 1.0 * 1.0) * kDegree2;
    s.enoughPerNormal = kEnough;
    s.moreIterations = 3;
    s.secondAbove = 1.2;
    if (light) {
        s.refined = 2;
        s.moreIterations = 2;
        s.second = false;
        s.modelCodes = {};
    }
    return s;
}

/// An unquantised lattice: base b = x[0…2], axes u = x[3…5], v = x[6…8].
using Model = std::array<double, 9>;
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

/// Solves m·y = r (r becomes y) for a symmetric positive definite m of order N ≤ 9 by Cholesky
/// (lower triangle of m used and overwritten); false when m is not numerically positive definite.
template <unsigned N>
bool solveSpd(std::array<std::array<double, 9>, 9>& m, std::array<double, 9>& r) {
    static_assert(N <= 9);
    // (Unrolled: the loop counts are small and known, and the loops' overhead cost more than their
    // arithmetic.)
#pragma GCC unroll 9
    for (unsigned j = 0; j < N; ++j) {
        double d = m[j][j];
#pragma GCC unroll 9
        for (unsigned k = 0; k < j; ++k) d -= m[j][k] * m[j][k];
        if (!(d > 0)) return false;
        d = std::sqrt(d);
        m[j][j] = d;
#pragma GCC unroll 9
        for (unsigned i = j + 1; i < N; ++i) {
            double s = m[i][j];
#pragma GCC unroll 9
            for (unsigned k = 0; k < j; ++k) s -= m[i][k] * m[j][k];
            m[i][j] = s / d;
        }
    }
#pragma GCC unroll 9
    for (unsigned i = 0; i < N; ++i) {
        double s = r[i];
#pragma GCC unroll 9
        for (unsigned k = 0; k < i; ++k) s -= m[i][k] * r[k];
        r[i] = s / m[i][i];
    }
#pragma GCC unroll 9
    for (unsigned t = 0; t < N; ++t) {
        const unsigned i = N - 1 - t;
        double s = r[i];
#pragma GCC unroll 9
        for (unsigned k = i + 1; k < N; ++k) s -= m[k][i] * r[k];
        r[i] = s / m[i][i];
    }
    return true;
}

/// solveSpd of the orders refineModel solves (the base's two minor components, with none, one
/// or both axes), each unrolled by the compiler.
bool solveSpd(std::array<std::array<double, 9>, 9>& m, std::array<double, 9>& r, unsigned n) {
    switch (n) {
        case 2:
            return solveSpd<2>(m, r);
        case 5:
            return solveSpd<5>(m, r);
        case 8:
            return solveSpd<8>(m, r);
        default:
            return false;
    }
}

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

/// normalEquations in single precision, four points at a time (lane by lane, which the compiler
/// vectorises; a lane past the points contributes nothing), the lanes summed in double at the end.
/// For the faster efforts: a Levenberg–Marquardt step only has to lead downhill (whether it is
/// taken is decided by the exact decoded error) and the quantisers' quadratics only rank codes
/// that are then measured, and this costs a quarter of the double-precision sums.
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

/// normalEquations with the free axes' loops specialised.
NormalEquations normalEquations(const NormalPoints& p, const Model& x,
                                const std::array<std::uint8_t, 16>& combo, unsigned freeAxes) {
    if (p.singleEquations) {
        switch (freeAxes) {
            case 0:
                return normalEquationsSingle<0>(p, x, combo);
            case 1:
                return normalEquationsSingle<1>(p, x, combo);
            case 2:
                return normalEquationsSingle<2>(p, x, combo);
            default:
                return normalEquationsSingle<3>(p, x, combo);
        }
    }
    switch (freeAxes) {
        case 0:
            return normalEquations<0>(p, x, combo);
        case 1:
            return normalEquations<1>(p, x, combo);
        case 2:
            return normalEquations<2>(p, x, combo);
        default:
            return normalEquations<3>(p, x, combo);
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

/// The 3-D search: candidate models from the face-plane fit @p f and (for wide blocks, see
/// kWideCos) from clusters of the normals, the best refined; the best one or two quantised.
/// Replaces @p s where one decodes better.
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

/// The search of a block of more than one direction (encodeNormals).
NormalState searchNormals(NormalPoints& p, AttributeEffort effort) {
    const NormalSearch search = normalSearch(effort);
    // Wide: some normal more than 30° from the outermost one; or few distinct directions.
    const Dir first = toDir(p.n[outermost(p)]);
    bool spread = false;
    for (unsigned i = 0; i < p.count; ++i) spread = spread || dot(toDir(p.n[i]), first) < kWideCos;
    bool few = false;
    if (!spread || search.lightBelow > 0) {
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
    const bool wide = spread || few;
    // (Not where few directions are far apart: both sides of a sheet put the lattice through the
    // origin, where single precision cannot follow the steps.)
    p.singleEquations = search.singleEquations && !few;
    // Early exit (Fast): where the first start already fits within the threshold, the others are
    // not tried.
    const PlaneFit f = fitNormals(
        p, search.startMask, search.planeOnCodes,
        [&](const PlaneFit& firstFit) { return firstFit.error <= search.earlyBelow * p.total; });
    NormalState s;
    if (search.planeOnCodes) {
        const NormalState codes = planeCodes(p, f);
        tryNormals(p, codes.base, codes.axes, s);
    } else {
        s = quantiseFit(p, f);
    }
    // Few distinct directions (edges, corners, sheets, any two directions) have near-exact
    // lattices, which the lighter searches miss: every effort quantises them as Best does.
    if (few) {
        const NormalSearch fs = fewSearch(effort);
        if (s.error > fs.wideThreshold * p.total) fit3d(p, f, true, fs, s);
    } else if (s.error > (wide ? search.wideThreshold : search.narrowThreshold) * p.total) {
        fit3d(p, f, wide,
              s.error < search.lightBelow * p.total ? normalSearch(effort, true) : search, s);
    }
    return s;
}

/// The last searches of this thread, direct-mapped by a hash of their normals' bits. The search
/// is a pure function of the normals (in order) and the effort, and blocks repeat exactly along
/// straight edges and on flat-shaded faces (about one in six of the 3-D searches of the
/// assimp-testmodels engine at depth 10): a hit returns the value the search would compute, so
/// outputs do not depend on what a thread encoded before.
class NormalSearchCache {
public:
    /// searchNormals(p, effort), from the cache where it holds the block.
    NormalState find(NormalPoints& p, AttributeEffort effort) {
        std::uint64_t hash = 0x9E3779B97F4A7C15ull ^ (std::uint64_t{p.count} << 8) ^
                             static_cast<std::uint64_t>(effort);
        for (unsigned i = 0; i < p.count; ++i) {
            for (unsigned c = 0; c < 3; ++c)
                hash = (hash ^ std::bit_cast<std::uint32_t>(p.n[i][c])) * 0x100000001B3ull;
            hash = (hash ^ std::bit_cast<std::uint32_t>(p.multiplicity[i])) * 0x100000001B3ull;
        }
        Entry& e = entries_[(hash ^ (hash >> 29)) % entries_.size()];
        if (e.valid && e.hash == hash && e.count == p.count && e.effort == effort &&
            std::memcmp(e.n.data(), p.n.data(), sizeof(Vec3) * p.count) == 0 &&
            std::memcmp(e.multiplicity.data(), p.multiplicity.data(), sizeof(float) * p.count) == 0)
            return e.state;
        e.state = searchNormals(p, effort);
        e.valid = true;
        e.hash = hash;
        e.count = p.count;
        e.effort = effort;
        std::memcpy(e.n.data(), p.n.data(), sizeof(Vec3) * p.count);
        std::memcpy(e.multiplicity.data(), p.multiplicity.data(), sizeof(float) * p.count);
        return e.state;
    }

private:
    struct Entry {
        bool valid = false;
        std::uint64_t hash = 0;
        unsigned count = 0;
        AttributeEffort effort = AttributeEffort::Default;
        std::array<Vec3, 16> n;
        std::array<float, 16> multiplicity;
        NormalState state;
    };
    std::array<Entry, 1024> entries_;
};

NormalState encodeNormals(NormalPoints& p, AttributeEffort effort) {
    // One direction (flat surfaces: common): the cube-face code itself, zero axes.
    if (p.count == 1) {
        NormalState s;
        s.base = esvo::encodeNormal(p.n[0]);
        s.error = 0;
        return s;
    }
    thread_local const std::unique_ptr<NormalSearchCache> cache =
        std::make_unique<NormalSearchCache>();
    return cache->find(p, effort);
}

esvo::Vec3 unitOrZ(const esvo::Vec3& n) {
    const float len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (!(len > 0) || !std::isfinite(len)) return {0, 0, 1};
    return {n[0] / len, n[1] / len, n[2] / len};
}

}  // namespace

std::array<std::uint32_t, 2> encodeColorBlock(const std::array<std::uint32_t, 16>& colors,
                                              std::uint32_t usedMask, AttributeEffort effort) {
    ColorPoints p;
    for (unsigned slot = 0; slot < 16; ++slot) {
        if (!((usedMask >> slot) & 1u)) continue;
        p.slot[p.count] = slot;
        for (unsigned ch = 0; ch < 3; ++ch)
            p.rgb[p.count][ch] = static_cast<int>(esvo::colorChannel(colors[slot], ch));
        ++p.count;
    }
    if (p.count == 0) return {0, 0};
    for (unsigned i = 0; i < 16; ++i)
        for (unsigned ch = 0; ch < 3; ++ch)
            p.channel[ch][i] = static_cast<float>(p.rgb[i < p.count ? i : 0][ch]);
    const ColorState s = encodeColors(p, effort);
    std::uint32_t indices = 0;
    for (unsigned i = 0; i < p.count; ++i) indices |= std::uint32_t{s.index[i]} << (2 * p.slot[i]);
    return {s.c0 | (s.c1 << 16), indices};
}

std::array<std::uint32_t, 4> encodeNormalBlock(const std::array<esvo::Vec3, 16>& normals,
                                               std::uint32_t usedMask, AttributeEffort effort) {
    NormalPoints p;
    std::array<std::uint8_t, 16> pointOf{};  // per used slot: its distinct normal
    for (unsigned slot = 0; slot < 16; ++slot) {
        if (!((usedMask >> slot) & 1u)) continue;
        const Vec3 n = unitOrZ(normals[slot]);
        unsigned i = 0;
        while (i < p.count && !(p.n[i] == n))
            ++i;  // bit-identical normals share a point (unitOrZ gives no NaN)
        if (i == p.count) p.n[p.count++] = n;
        pointOf[slot] = static_cast<std::uint8_t>(i);
        p.multiplicity[i] += 1;
        ++p.total;
    }
    if (p.count == 0) return {esvo::encodeNormal({0, 0, 1}), 0, 0, 0};
    const NormalState s = encodeNormals(p, effort);
    std::uint32_t uIndices = 0, vIndices = 0;
    for (unsigned slot = 0; slot < 16; ++slot) {
        if (!((usedMask >> slot) & 1u)) continue;
        const std::uint32_t combo = s.combo[pointOf[slot]];
        uIndices |= (combo & 3u) << (2 * slot);
        vIndices |= (combo >> 2) << (2 * slot);
    }
    return {s.base, uIndices, s.axes, vIndices};
}

esvo::CompressedBlock encodeCompressedBlock(const std::array<std::uint64_t, 16>& values,
                                            std::uint32_t usedMask, AttributeEffort effort) {
    std::array<std::uint32_t, 16> colors{};
    std::array<esvo::Vec3, 16> normals{};
    for (unsigned slot = 0; slot < 16; ++slot) {
        if (!((usedMask >> slot) & 1u)) continue;  // (the encoders read used slots only)
        colors[slot] = static_cast<std::uint32_t>(values[slot]);
        normals[slot] = esvo::decodeNormal(static_cast<std::uint32_t>(values[slot] >> 32));
    }
    const auto c = encodeColorBlock(colors, usedMask, effort);
    const auto n = encodeNormalBlock(normals, usedMask, effort);
    return {c[0], c[1], n[0], n[1], n[2], n[3]};
}

bool setEncoderAvx512(bool enabled) noexcept {
#if VOX_ENCODE_AVX512
    const bool on = enabled && avx512Available();
    g_avx512.store(on);
    return on;
#else
    (void)enabled;
    return false;
#endif
}

bool encoderAvx512() noexcept {
#if VOX_ENCODE_AVX512
    return g_avx512.load();
#else
    return false;
#endif
}

std::uint64_t colorBlockError(const std::array<std::uint32_t, 16>& colors, std::uint32_t usedMask,
                              std::uint32_t word0, std::uint32_t word1) noexcept {
    const auto palette = esvo::colorPalette(word0 & 0xFFFFu, word0 >> 16);
    std::uint64_t total = 0;
    for (unsigned slot = 0; slot < 16; ++slot) {
        if (!((usedMask >> slot) & 1u)) continue;
        const std::uint32_t decoded = palette[esvo::blockIndex(word1, slot)];
        for (unsigned ch = 0; ch < 3; ++ch) {
            const int d = static_cast<int>(esvo::colorChannel(colors[slot], ch)) -
                          static_cast<int>(esvo::colorChannel(decoded, ch));
            total += static_cast<std::uint64_t>(d * d);
        }
    }
    return total;
}

}  // namespace vox::detail

namespace vox {

const char* attributeEncoderKernels() noexcept {
    return detail::encoderAvx512() ? "avx512" : (VOX_ENCODE_SSE2 ? "sse2" : "scalar");
}

}  // namespace vox
