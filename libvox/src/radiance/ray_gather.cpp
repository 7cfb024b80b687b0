// Bounce light gathered by rays against the triangles (ray_gather.h).
#include "ray_gather.h"

#include <vox/formats/rvol.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <stdexcept>

namespace vox::detail {

namespace {

constexpr double kPi = 3.14159265358979323846;
/// How far off its surface point a voxel's rays start, in cells: clear of the float intersection's
/// rounding on that surface, far below anything a cell resolves.
constexpr double kOriginOffsetCells = 1e-3;
/// Most bytes of remembered ray hits (a leaf index and a side per ray, bit-packed); beyond it every
/// bounce traces again. setRayGatherHitBudget changes it (tests).
std::atomic<std::size_t> g_hitBudget{kRayGatherHitBudget};
/// The fixed-point unit of the sums of hit normals (RayGather::trace).
constexpr double kNormalFixedPoint = double(1 << 24);
/// How far outside its cell a voxel's surface point may lie, in cells (float rounding).
constexpr double kFaceSlackCells = 1e-4;
/// How far back along the ray a hit is looked up, in cells: the cell the ray arrives through where
/// the hit lies on a cell boundary.
constexpr double kHitBackoffCells = 1e-4;

/// Bits of a kept hit among @p leaves leaves: the leaf in the fewest bits that hold every index
/// and one more (all ones: no leaf), and a bit for the side.
unsigned hitBitsFor(std::size_t leaves) {
    return static_cast<unsigned>(std::bit_width(leaves)) + 1;
}

/// Whether @p entries entries of @p wordsPerEntry words of kept hits fit the budget.
bool fitsHitBudget(std::size_t entries, std::size_t wordsPerEntry) {
    return entries * wordsPerEntry * sizeof(std::uint64_t) <= g_hitBudget.load();
}

}  // namespace

std::size_t setRayGatherHitBudget(std::size_t bytes) noexcept {
    return g_hitBudget.exchange(bytes);
}

RayGather::RayGather(const Scene& scene, std::span<const LeafMaterial> leaves, Vec3d origin,
                     double cell, std::uint32_t depth, std::uint32_t strata)
    : leaves_(leaves),
      caster_(scene),
      origin_(origin),
      cell_(cell),
      cells_(std::int64_t{1} << depth),
      codes_(leaves.size()),
      from_(leaves.size()),
      normal_(leaves.size()) {
    if (leaves.size() >= kBackSide) throw std::length_error("RayGather: 2^31 leaves or more");
    // Each voxel's rays start on its own surface: where the line along its mean normal through
    // its centre first meets a triangle from the front, inside the cell (the cones start off the
    // centre instead, which may lie behind the surface or inside a wall).
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, leaves.size(), 1024),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                          for (std::size_t i = r.begin(); i != r.end(); ++i) {
                              const LeafMaterial& v = leaves[i];
                              codes_[i] = rvol::morton3(v.x, v.y, v.z);
                              normal_[i] = vec3Cast<double>(v.normals.mean);
                              from_[i] = rayOrigin(v, normal_[i]);
                          }
                      });
    // At least as many buckets as leaves (a power of two), at most one per cell.
    const auto codeBits = static_cast<unsigned>(3 * depth);
    const unsigned bucketBits =
        std::min(codeBits, static_cast<unsigned>(std::bit_width(leaves.size())));
    bucketShift_ = codeBits - bucketBits;
    bucketStart_.resize((std::size_t{1} << bucketBits) + 1);
    std::size_t next = 0;
    for (std::size_t b = 0; b < bucketStart_.size(); ++b) {
        while (next < codes_.size() && (codes_[next] >> bucketShift_) < b) ++next;
        bucketStart_[b] = static_cast<std::uint32_t>(next);
    }
    // Cosine-distributed directions about +z (Malley's method) at the centres of strata² strata
    // of the unit square, the same for every voxel: a per-voxel random shift of the strata
    // (unbiased) scattered the voxels' estimates by more than the fixed pattern errs
    // (docs/internals/rvol-writer.md).
    strata = std::max<std::uint32_t>(strata, 1);
    for (std::uint32_t k = 0; k < strata * strata; ++k) {
        const double u = (double(k % strata) + 0.5) / strata;
        const double v = (double(k / strata) + 0.5) / strata;
        const double radius = std::sqrt(u), phi = 2 * kPi * v;
        pattern_.push_back({radius * std::cos(phi), radius * std::sin(phi), std::sqrt(1.0 - u)});
    }
    hitBits_ = hitBitsFor(leaves.size());
    noLeaf_ = (std::uint64_t{1} << (hitBits_ - 1)) - 1;
    wordsPerEntry_ = (pattern_.size() * hitBits_ + 63) / 64;
}

bool RayGather::keepsHits(std::size_t leaves, std::uint32_t rays) noexcept {
    return fitsHitBudget(leaves, (rays * std::size_t{hitBitsFor(leaves)} + 63) / 64);
}

Vec3d RayGather::direction(const OrthonormalFrame& frame, std::size_t k) const {
    return frame.toWorld(pattern_[k].x, pattern_[k].y, pattern_[k].z);
}

Vec3d RayGather::rayOrigin(const LeafMaterial& v, Vec3d n) const {
    const double halfDiagonal = 0.5 * std::sqrt(3.0) * cell_;
    const Vec3d centre = origin_ + Vec3d{v.x + 0.5, v.y + 0.5, v.z + 0.5} * cell_;
    const SurfaceHit h =
        caster_.castSurface({centre + n * halfDiagonal, n * -1.0}, 2 * halfDiagonal);
    const Vec3d onSurface = centre + n * (halfDiagonal - h.t);
    const Vec3d off = (onSurface - centre) / cell_;
    // A surface on the cell's face is in the cell: the float intersection may put it a rounding
    // error outside. A point outside the cell on the far side of the centre (a surface that clips
    // a corner, another surface) is not taken: that lost accuracy on the house
    // (docs/internals/rvol-writer.md).
    const bool inCell = h.hit && std::max({std::abs(off.x), std::abs(off.y), std::abs(off.z)}) <=
                                     0.5 + kFaceSlackCells;
    // A surface on the normal's side of the centre, though outside the cell, puts the centre
    // behind it: rays from the centre would meet its back and read nothing, so they start on it.
    const bool centreBehind = h.hit && h.t < halfDiagonal;
    return (inCell || centreBehind ? onSurface : centre) + n * (kOriginOffsetCells * cell_);
}

std::uint32_t RayGather::leafAt(Vec3d p) const noexcept {
    std::uint32_t c[3];
    for (int a = 0; a < 3; ++a) {
        const double g = std::floor((p[a] - origin_[a]) / cell_);
        if (!(g >= 0 && g < double(cells_))) return kNone;
        c[a] = static_cast<std::uint32_t>(g);
    }
    const std::uint64_t code = rvol::morton3(c[0], c[1], c[2]);
    const std::size_t bucket = code >> bucketShift_;
    const auto last = codes_.begin() + bucketStart_[bucket + 1];
    const auto it = std::lower_bound(codes_.begin() + bucketStart_[bucket], last, code);
    return it != last && *it == code ? static_cast<std::uint32_t>(it - codes_.begin()) : kNone;
}

std::uint64_t RayGather::pack(std::uint32_t hit) const noexcept {
    if (hit == kNone) return noLeaf_;
    return hit & kBackSide ? (hit & ~kBackSide) | (noLeaf_ + 1) : hit;
}

std::uint32_t RayGather::unpack(std::uint64_t code) const noexcept {
    const auto leaf = static_cast<std::uint32_t>(code & noLeaf_);
    if (leaf == noLeaf_) return kNone;
    return code & (noLeaf_ + 1) ? leaf | kBackSide : leaf;
}

const std::uint64_t* RayGather::entryWords(std::size_t e) const {
    return e < leaves_.size() ? leafHitWords_.data() + e * wordsPerEntry_
                              : backHitWords_.data() + (e - leaves_.size()) * wordsPerEntry_;
}

void RayGather::keepHit(std::size_t e, std::size_t k, std::uint32_t hit) {
    auto* words = const_cast<std::uint64_t*>(entryWords(e));  // into this object's own vectors
    const std::uint64_t code = pack(hit);
    const std::size_t bit = k * hitBits_, word = bit / 64;
    const unsigned shift = bit % 64;
    words[word] |= code << shift;
    if (shift + hitBits_ > 64) words[word + 1] |= code >> (64 - shift);
}

void RayGather::entryHits(std::size_t e, std::span<std::uint32_t> out) const {
    if (e >= keptEntries_) {
        const OrthonormalFrame frame(normal_[e]);
        for (std::size_t k = 0; k < out.size(); ++k)
            out[k] = castRay(from_[e], direction(frame, k));
        return;
    }
    const std::uint64_t* words = entryWords(e);
    for (std::size_t k = 0; k < out.size(); ++k) {
        const std::size_t bit = k * hitBits_, word = bit / 64;
        const unsigned shift = bit % 64;
        std::uint64_t code = words[word] >> shift;
        if (shift + hitBits_ > 64) code |= words[word + 1] << (64 - shift);
        out[k] = unpack(code);
    }
}

void RayGather::NormalSums::add(bool back, Vec3d normal) {
    const std::size_t side = back ? 3 : 0;
    if (back) reachedFromBehind.store(true, std::memory_order_relaxed);
    for (std::size_t a = 0; a < 3; ++a)
        sums[side + a].fetch_add(std::llround(normal[a] * kNormalFixedPoint),
                                 std::memory_order_relaxed);
}

void RayGather::traceEntries(std::size_t first, std::size_t last, bool keep, NormalSums* seen,
                             bool fronts, Progress* progress) {
    const std::size_t rays = pattern_.size();
    // Kept bit-packed: each entry's hits in whole words, so that no two threads write one word.
    // The leaves' and the back sides' words are apart, so that keeping the back sides does not
    // move (and for a moment double) the leaves'.
    if (keep) (first == 0 ? leafHitWords_ : backHitWords_).resize((last - first) * wordsPerEntry_);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(first, last, 64),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                          for (std::size_t e = r.begin(); e != r.end(); ++e) {
                              const OrthonormalFrame frame(normal_[e]);
                              for (std::size_t k = 0; k < rays; ++k) {
                                  Vec3d normal;
                                  const std::uint32_t hit =
                                      castRay(from_[e], direction(frame, k), &normal);
                                  if (keep) keepHit(e, k, hit);
                                  if (hit == kNone || !seen || !(fronts || (hit & kBackSide)))
                                      continue;
                                  seen[hit & ~kBackSide].add((hit & kBackSide) != 0, normal);
                              }
                          }
                          if (progress) progress->advance(r.size());
                      });
    if (keep) keptEntries_ = last;
}

void RayGather::sumTwoSidedFronts(NormalSums* seen) const {
    // The leaves reached from behind as bits: a few kilobytes, where seen[] is tens of megabytes.
    std::vector<std::uint64_t> twoSided((leaves_.size() + 63) / 64);
    for (std::size_t i = 0; i < leaves_.size(); ++i)
        if (seen[i].reachedFromBehind.load(std::memory_order_relaxed))
            twoSided[i / 64] |= std::uint64_t{1} << (i % 64);
    const std::size_t rays = pattern_.size();
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, leaves_.size(), 64),
        [&](const tbb::blocked_range<std::size_t>& r) {
            std::vector<std::uint32_t> hits(rays);
            for (std::size_t e = r.begin(); e != r.end(); ++e) {
                entryHits(e, hits);
                const OrthonormalFrame frame(normal_[e]);
                for (std::size_t k = 0; k < rays; ++k) {
                    const std::uint32_t h = hits[k];
                    if (h == kNone || (h & kBackSide) || !(twoSided[h / 64] >> (h % 64) & 1))
                        continue;
                    // The same ray as the trace's: the same hit, and its normal.
                    Vec3d normal;
                    (void)castRay(from_[e], direction(frame, k), &normal);
                    seen[h].add(false, normal);
                }
            }
        });
}

std::vector<RayGather::TwoSidedLeaf> RayGather::trace(Progress* progress) {
    if (traced_) throw std::logic_error("RayGather::trace called twice");
    std::vector<NormalSums> seen(leaves_.size());
    // Where the hits are kept, the fronts' sums come after, from the kept hits, for the two-sided
    // leaves alone; else the trace sums every hit's normal.
    const bool keep = fitsHitBudget(leaves_.size(), wordsPerEntry_);
    traceEntries(0, leaves_.size(), keep, seen.data(), !keep, progress);
    if (keep) sumTwoSidedFronts(seen.data());
    std::vector<TwoSidedLeaf> twoSided;
    for (std::size_t i = 0; i < leaves_.size(); ++i) {
        if (!seen[i].reachedFromBehind.load(std::memory_order_relaxed)) continue;
        const auto sum = [&](std::size_t side) {
            return Vec3d{double(seen[i].sums[side].load()), double(seen[i].sums[side + 1].load()),
                         double(seen[i].sums[side + 2].load())};
        };
        const Vec3d frontSum = sum(0), backSum = sum(3);
        const Vec3d mean = vec3Cast<double>(leaves_[i].normals.mean);
        const auto sideNormal = [&](Vec3d s, Vec3d fallback) {
            return length(s) > 0.01 * kNormalFixedPoint ? normalize(s) : fallback;
        };
        twoSided.push_back({static_cast<std::uint32_t>(i), sideNormal(frontSum, mean),
                            sideNormal(backSum, mean * -1.0)});
    }
    // The back sides' own rays, about the back's normal from the back's surface.
    for (const TwoSidedLeaf& t : twoSided) {
        normal_.push_back(t.back);
        from_.push_back(rayOrigin(leaves_[t.leaf], t.back));
    }
    traceEntries(leaves_.size(), from_.size(), keep && fitsHitBudget(from_.size(), wordsPerEntry_),
                 nullptr, false, nullptr);
    traced_ = true;
    return twoSided;
}

RayGather::Irradiance RayGather::gather(std::span<const Vec3f> front, std::span<const Vec3f> back,
                                        Progress* progress) const {
    if (!traced_) throw std::logic_error("RayGather::gather before trace");
    std::vector<Vec3f> out(from_.size());
    const std::size_t rays = pattern_.size();
    const double weight = kPi / double(rays);  // cosine-distributed: E = π · mean L
    const std::size_t leaves = leaves_.size();
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, from_.size(), 64),
        [&](const tbb::blocked_range<std::size_t>& r) {
            std::vector<std::uint32_t> hits(rays);
            for (std::size_t e = r.begin(); e != r.end(); ++e) {
                entryHits(e, hits);
                Vec3d sum{0, 0, 0};
                for (const std::uint32_t h : hits) {
                    if (h == kNone) continue;
                    sum += vec3Cast<double>(h & kBackSide ? back[h & ~kBackSide] : front[h]);
                }
                out[e] = vec3Cast<float>(sum * weight);
            }
            if (progress && r.begin() < leaves)
                progress->advance(std::min(r.end(), leaves) - r.begin());
        });
    Irradiance irradiance;
    irradiance.backs.assign(out.begin() + static_cast<std::ptrdiff_t>(leaves), out.end());
    out.resize(leaves);
    irradiance.leaves = std::move(out);
    return irradiance;
}

std::uint32_t RayGather::castRay(Vec3d from, Vec3d dir, Vec3d* normal) const {
    const SurfaceHit h = caster_.castSurface({from, dir});
    if (normal) *normal = h.geometricNormal;
    // The back of a triangle: the inside of a closed surface (a ray from a thin part's cell centre)
    // or the unlit side of a sheet. Nothing is read.
    if (!h.hit || dot(h.geometricNormal, dir) > 0) return kNone;
    const Vec3d hit = from + dir * h.t;
    std::uint32_t leaf = leafAt(hit - dir * (kHitBackoffCells * cell_));
    if (leaf == kNone) leaf = leafAt(hit);
    if (leaf == kNone) return kNone;
    // A triangle facing away from the leaf's mean normal is the other side of a voxel that holds
    // both sides of a thin part: its radiance is not the front's (a sunlit wall's inside is dark).
    return dot(h.geometricNormal, normal_[leaf]) < 0 ? leaf | kBackSide : leaf;
}

}  // namespace vox::detail
