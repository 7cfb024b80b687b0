// The normal encoder (attribute_encode.h's encodeNormalBlock): the block's distinct normals, the
// search of each effort, the choice between the face-plane fit (normal_encode_face.cpp) and the
// 3-D fit (normal_encode_3d.cpp) that follows it where the error is worth the time, a cache of
// the last searches, and the measuring and stepping of the codes that both fits share.
#include "attribute_encode_internal.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <span>

namespace vox::detail::encode {

// ---- The codes, measured and stepped (both fits) ----------------------------------------------

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

std::uint32_t roundAxis(const Vec3& a, int e) {
    const float step = std::ldexp(1.0f, e - 13);
    std::uint32_t bits = static_cast<std::uint32_t>(e) << 12;
    for (unsigned c = 0; c < 3; ++c) {
        const long q = std::clamp(std::lround(a[c] / step), -8l, 7l);
        bits |= (static_cast<std::uint32_t>(q) & 15u) << (4 * c);
    }
    return bits;
}

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

// ---- The search ------------------------------------------------------------------------------

namespace {

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
/// on the real blocks of bench/attribute_encode_bench --scene (docs/internals/esvo-writer.md).
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

/// The search of a block of more than one direction (encodeNormals).
NormalState searchNormals(NormalPoints& p, AttributeEffort effort) {
    const NormalSearch search = normalSearch(effort);
    // Wide: some normal more than 30° from the outermost one; or few distinct directions.
    const NormalSpread spread = normalSpread(p, search.lightBelow > 0);
    const bool few = spread.few;
    const bool wide = spread.spread || few;
    // (Not where few directions are far apart: both sides of a sheet put the lattice through the
    // origin, where single precision cannot follow the steps.)
    p.singleEquations = search.singleEquations && !few;
    // Early exit (Fast): where the first start already fits within the threshold, the others are
    // not tried.
    const PlaneFit f =
        fitNormals(p, search.startMask, search.planeOnCodes, search.earlyBelow * p.total);
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
}  // namespace vox::detail::encode

namespace vox::detail {

std::array<std::uint32_t, 4> encodeNormalBlock(const std::array<esvo::Vec3, 16>& normals,
                                               std::uint32_t usedMask, AttributeEffort effort) {
    encode::NormalPoints p;
    std::array<std::uint8_t, 16> pointOf{};  // per used slot: its distinct normal
    for (unsigned slot = 0; slot < 16; ++slot) {
        if (!((usedMask >> slot) & 1u)) continue;
        const esvo::Vec3 n = encode::unitOrZ(normals[slot]);
        unsigned i = 0;
        while (i < p.count && !(p.n[i] == n))
            ++i;  // bit-identical normals share a point (unitOrZ gives no NaN)
        if (i == p.count) p.n[p.count++] = n;
        pointOf[slot] = static_cast<std::uint8_t>(i);
        p.multiplicity[i] += 1;
        ++p.total;
    }
    if (p.count == 0) return {esvo::encodeNormal({0, 0, 1}), 0, 0, 0};
    const encode::NormalState s = encode::encodeNormals(p, effort);
    std::uint32_t uIndices = 0, vIndices = 0;
    for (unsigned slot = 0; slot < 16; ++slot) {
        if (!((usedMask >> slot) & 1u)) continue;
        const std::uint32_t combo = s.combo[pointOf[slot]];
        uIndices |= (combo & 3u) << (2 * slot);
        vIndices |= (combo >> 2) << (2 * slot);
    }
    return {s.base, uIndices, s.axes, vIndices};
}

}  // namespace vox::detail
