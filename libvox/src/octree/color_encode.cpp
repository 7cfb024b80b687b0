// The colour encoder (attribute_encode.h's encodeColorBlock): RGB565 endpoints c0, c1 and 2-bit
// indices into the palette {c0, c1, ⅔c0+⅓c1, ⅓c0+⅔c1}, searched from a single-colour table
// fit, start pairs along the colours' principal axis improved by cluster fitting, an exhaustive
// ordered cluster fit for blocks still far off, and a descent over the endpoints' channels.
#include "attribute_encode_internal.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>

namespace vox::detail::encode {
namespace {

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
    std::array<unsigned, 3> split{};
    if (!orderedSplit(prefix, n, split)) return false;
    std::array<std::uint8_t, 16> index{};
    for (unsigned i = 0; i < n; ++i)
        index[order[i]] = i < split[0] ? 0 : (i < split[1] ? 2 : (i < split[2] ? 3 : 1));
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

}  // namespace
}  // namespace vox::detail::encode

namespace vox::detail {

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

std::array<std::uint32_t, 2> encodeColorBlock(const std::array<std::uint32_t, 16>& colors,
                                              std::uint32_t usedMask, AttributeEffort effort) {
    encode::ColorPoints p;
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
    const encode::ColorState s = encode::encodeColors(p, effort);
    std::uint32_t indices = 0;
    for (unsigned i = 0; i < p.count; ++i) indices |= std::uint32_t{s.index[i]} << (2 * p.slot[i]);
    return {s.c0 | (s.c1 << 16), indices};
}

}  // namespace vox::detail
