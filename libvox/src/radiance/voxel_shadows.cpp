#include "voxel_shadows.h"

#include "../util/segment_clip.h"

#include <vox/base/error.h>
#include <vox/formats/rvol.h>

#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

namespace vox::detail {

namespace {
constexpr std::uint32_t kBlock = 8;
}

SolidGrid::SolidGrid(std::uint32_t depth, std::span<const std::array<std::uint32_t, 3>> cells)
    : resolution_(1u << depth), blocksPerAxis_(std::max<std::uint32_t>(1, resolution_ / kBlock)) {
    const std::size_t n = std::size_t{resolution_} * resolution_ * resolution_;
    bits_.assign((n + 63) / 64, 0);
    blocks_.assign(std::size_t{blocksPerAxis_} * blocksPerAxis_ * blocksPerAxis_, 0);
    for (const auto& c : cells) {
        const std::size_t i = (std::size_t{c[2]} * resolution_ + c[1]) * resolution_ + c[0];
        bits_[i / 64] |= std::uint64_t{1} << (i % 64);
        blocks_[(std::size_t{c[2] / kBlock} * blocksPerAxis_ + c[1] / kBlock) * blocksPerAxis_ +
                c[0] / kBlock] = 1;
    }
}

bool SolidGrid::solid(std::int64_t x, std::int64_t y, std::int64_t z) const noexcept {
    const std::int64_t r = resolution_;
    if (x < 0 || y < 0 || z < 0 || x >= r || y >= r || z >= r) return false;
    const std::size_t i =
        (static_cast<std::size_t>(z) * resolution_ + static_cast<std::size_t>(y)) * resolution_ +
        static_cast<std::size_t>(x);
    return (bits_[i / 64] >> (i % 64)) & 1u;
}

bool SolidGrid::blockEmpty(std::int64_t x, std::int64_t y, std::int64_t z) const noexcept {
    const std::size_t bx = static_cast<std::size_t>(x) / kBlock,
                      by = static_cast<std::size_t>(y) / kBlock,
                      bz = static_cast<std::size_t>(z) / kBlock;
    return !blocks_[(bz * blocksPerAxis_ + by) * blocksPerAxis_ + bx];
}

bool SolidGrid::occluded(Vec3d origin, Vec3d dir, double maxT,
                         std::array<std::int64_t, 3>* hit) const noexcept {
    const double r = resolution_;
    double t0 = 0, t1 = maxT;
    if (!detail::clipSegmentToCube(origin, dir, r, t0, t1)) return false;
    const std::int64_t sx = static_cast<std::int64_t>(std::floor(origin.x)),
                       sy = static_cast<std::int64_t>(std::floor(origin.y)),
                       sz = static_cast<std::int64_t>(std::floor(origin.z));
    double t = t0;
    while (t < t1) {
        const Vec3d p = origin + dir * (t + 1e-9);
        std::int64_t c[3] = {static_cast<std::int64_t>(std::floor(p.x)),
                             static_cast<std::int64_t>(std::floor(p.y)),
                             static_cast<std::int64_t>(std::floor(p.z))};
        for (auto& v : c) v = std::clamp<std::int64_t>(v, 0, resolution_ - 1);
        // Skip an empty block in one jump, else walk cells to the block's boundary.
        const bool empty = blockEmpty(c[0], c[1], c[2]);
        const std::int64_t lo[3] = {empty ? c[0] / kBlock * kBlock : c[0],
                                    empty ? c[1] / kBlock * kBlock : c[1],
                                    empty ? c[2] / kBlock * kBlock : c[2]};
        const std::int64_t size = empty ? kBlock : 1;
        if (!empty && solid(c[0], c[1], c[2]) && !(c[0] == sx && c[1] == sy && c[2] == sz)) {
            if (hit) *hit = {c[0], c[1], c[2]};
            return true;
        }
        t = std::max(detail::exitOfCube(origin, dir, lo, size), t + 1e-7);
    }
    return false;
}

bool SolidGrid::anySolid(Vec3d lo, Vec3d hi) const noexcept {
    const double r = resolution_;
    std::int64_t first[3], last[3];
    // floor() as a cast of a value clamped into [−1, r] (where the cast truncates exactly): the
    // libm call cost as much as the bits' test.
    const auto floorIn = [r](double v) {
        v = std::clamp(v, -1.0, r);
        const auto t = static_cast<std::int64_t>(v);
        return t - (static_cast<double>(t) > v ? 1 : 0);
    };
    for (int axis = 0; axis < 3; ++axis) {
        if (!(hi[axis] >= 0 && lo[axis] <= r)) return false;  // (NaN: nothing)
        first[axis] = std::clamp<std::int64_t>(floorIn(lo[axis]), 0, resolution_ - 1);
        last[axis] = std::clamp<std::int64_t>(floorIn(hi[axis]), 0, resolution_ - 1);
    }
    const auto res = static_cast<std::size_t>(resolution_);
    for (std::int64_t bz = first[2] / kBlock; bz <= last[2] / kBlock; ++bz)
        for (std::int64_t by = first[1] / kBlock; by <= last[1] / kBlock; ++by)
            for (std::int64_t bx = first[0] / kBlock; bx <= last[0] / kBlock; ++bx) {
                if (blockEmpty(bx * kBlock, by * kBlock, bz * kBlock)) continue;
                const std::int64_t x0 = std::max<std::int64_t>(first[0], bx * kBlock),
                                   x1 = std::min<std::int64_t>(last[0], bx * kBlock + kBlock - 1);
                const std::int64_t y0 = std::max<std::int64_t>(first[1], by * kBlock),
                                   y1 = std::min<std::int64_t>(last[1], by * kBlock + kBlock - 1);
                const std::int64_t z0 = std::max<std::int64_t>(first[2], bz * kBlock),
                                   z1 = std::min<std::int64_t>(last[2], bz * kBlock + kBlock - 1);
                // A row's bits x0 … x1 lie in one word: a row starts at a multiple of the
                // resolution (a multiple of 8 from depth 3, else a single block) and x0 … x1 in
                // one block of 8.
                const std::uint64_t bits = (std::uint64_t{1} << (x1 - x0 + 1)) - 1;
                for (std::int64_t z = z0; z <= z1; ++z)
                    for (std::int64_t y = y0; y <= y1; ++y) {
                        const std::size_t i =
                            (static_cast<std::size_t>(z) * res + static_cast<std::size_t>(y)) *
                                res +
                            static_cast<std::size_t>(x0);
                        if (bits_[i / 64] & (bits << (i % 64))) return true;
                    }
            }
    return false;
}

namespace {

bool finite(Vec3d v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

/// The largest float ≤ @p v, and the smallest float ≥ @p v.
float floatBelow(double v) {
    const auto f = static_cast<float>(v);
    return double(f) > v ? std::nextafter(f, -std::numeric_limits<float>::infinity()) : f;
}
float floatAbove(double v) {
    const auto f = static_cast<float>(v);
    return double(f) < v ? std::nextafter(f, std::numeric_limits<float>::infinity()) : f;
}

/// The box of the points (1 − u)·a + u·b, a in [aLo, aHi], b in [bLo, bHi], for u in [u0, u1]
/// (0 ≤ u0 ≤ u1 ≤ 1): per axis, each bound is linear in u, so one of the two ends gives it.
void boxBetween(Vec3d aLo, Vec3d aHi, Vec3d bLo, Vec3d bHi, double u0, double u1, double pad,
                Vec3d& lo, Vec3d& hi) {
    for (int k = 0; k < 3; ++k) {
        lo[k] = std::min((1 - u0) * aLo[k] + u0 * bLo[k], (1 - u1) * aLo[k] + u1 * bLo[k]) - pad;
        hi[k] = std::max((1 - u0) * aHi[k] + u0 * bHi[k], (1 - u1) * aHi[k] + u1 * bHi[k]) + pad;
    }
}

}  // namespace

bool SolidGrid::beamClear(Vec3d fromLo, Vec3d fromHi, Vec3d toLo, Vec3d toHi) const noexcept {
    // Padding: the rays step 1e-9 past their samples, and the callers' boxes come from world
    // coordinates rounded differently than the rays' directions and lengths.
    constexpr double kPad = 1e-6;
    if (!finite(fromLo) || !finite(fromHi) || !finite(toLo) || !finite(toHi)) return false;
    double length = 0;
    for (int k = 0; k < 3; ++k)
        length = std::max({length, std::abs(toHi[k] - fromLo[k]), std::abs(toLo[k] - fromHi[k])});
    // One box per cell of length; the last one reaches past the end by the padding. Away from the
    // start, where the beam mostly crosses empty blocks, eight boxes are tried as one first.
    const auto slabs = static_cast<std::int64_t>(std::ceil(length)) + 1;
    const auto slabBox = [&](std::int64_t first, std::int64_t last, Vec3d& lo, Vec3d& hi) {
        const double u0 = double(first) / double(slabs);
        const double u1 = last == slabs ? 1.0 : double(last) / double(slabs);
        boxBetween(fromLo, fromHi, toLo, toHi, u0, u1, kPad, lo, hi);
        if (last == slabs) {
            // Past the end: the ray's samples lie up to 1e-9 beyond it.
            for (int axis = 0; axis < 3; ++axis) {
                const double reach = kPad * (1 + std::abs(toHi[axis] - fromLo[axis]) +
                                             std::abs(toLo[axis] - fromHi[axis]));
                lo[axis] -= reach;
                hi[axis] += reach;
            }
        }
    };
    constexpr std::int64_t kChunk = 8, kNear = 4;
    Vec3d lo, hi;
    for (std::int64_t k = 0; k < slabs;) {
        if (k >= kNear && k + kChunk <= slabs) {
            slabBox(k, k + kChunk, lo, hi);
            if (!anySolid(lo, hi)) {
                k += kChunk;
                continue;
            }
            for (std::int64_t j = k; j < k + kChunk; ++j) {
                slabBox(j, j + 1, lo, hi);
                if (anySolid(lo, hi)) return false;
            }
            k += kChunk;
            continue;
        }
        slabBox(k, k + 1, lo, hi);
        if (anySolid(lo, hi)) return false;
        ++k;
    }
    return true;
}

bool SolidGrid::allSolid(Vec3d lo, Vec3d hi) const noexcept {
    std::int64_t first[3], last[3];
    for (int axis = 0; axis < 3; ++axis) {
        if (!(lo[axis] <= hi[axis])) return false;  // (NaN too)
        // The cells whose closed cubes meet [lo, hi]; one outside the grid is empty.
        first[axis] = static_cast<std::int64_t>(std::ceil(lo[axis])) - 1;
        last[axis] = static_cast<std::int64_t>(std::floor(hi[axis]));
        if (first[axis] < 0 || last[axis] >= std::int64_t{resolution_}) return false;
    }
    for (std::int64_t z = first[2]; z <= last[2]; ++z)
        for (std::int64_t y = first[1]; y <= last[1]; ++y)
            for (std::int64_t x = first[0]; x <= last[0]; ++x)
                if (!solid(x, y, z)) return false;
    return true;
}

bool SolidGrid::layerBlocks(Vec3d fromLo, Vec3d fromHi, Vec3d toLo, Vec3d toHi, int axis,
                            std::int64_t layer) const noexcept {
    constexpr double kPad = 1e-6;
    if (!finite(fromLo) || !finite(fromHi) || !finite(toLo) || !finite(toHi)) return false;
    if (layer < 0 || layer >= std::int64_t{resolution_}) return false;
    // Mirror the axis so that the segments run towards +axis; they must start before the layer
    // (so that their first cell is not in it) and end past it.
    const bool positive = toLo[axis] > fromHi[axis];
    if (!positive && !(toHi[axis] < fromLo[axis])) return false;
    const double enter = positive ? double(layer) : -double(layer + 1), leave = enter + 1;
    const double aLo = positive ? fromLo[axis] : -fromHi[axis];
    const double aHi = positive ? fromHi[axis] : -fromLo[axis];
    const double bLo = positive ? toLo[axis] : -toHi[axis];
    const double bHi = positive ? toHi[axis] : -toLo[axis];
    if (!(aHi < enter - kPad) || !(bLo > leave + kPad)) return false;
    // The parameters at which a segment a + u·(b − a) is inside the layer, for every a and b.
    const double u0 = std::max(0.0, (enter - aHi) / (bHi - aLo) - kPad);
    const double u1 = std::min(1.0, (leave - aLo) / (bLo - aHi) + kPad);
    if (!(u0 <= u1)) return false;
    Vec3d lo, hi;
    boxBetween(fromLo, fromHi, toLo, toHi, u0, u1, kPad, lo, hi);
    lo[axis] = hi[axis] = double(layer) + 0.5;
    return allSolid(lo, hi);
}

ShadowRayGroups::ShadowRayGroups(const SolidGrid& grid,
                                 std::span<const std::array<std::uint32_t, 3>> cells,
                                 std::vector<Vec3f> normals, std::vector<Vec3d> lights)
    : grid_(grid),
      cells_(cells),
      normals_(std::move(normals)),
      lights_(std::move(lights)),
      groupOf_(cells.size()),
      originEmpty_(cells.size(), 0) {
    tbb::parallel_for(std::size_t{0}, cells.size(), [&](std::size_t i) {
        for (int s = 0; s < 2; ++s) {
            const Vec3d o = origin(i, s == 0 ? 1 : -1);
            if (!grid_.solid(static_cast<std::int64_t>(std::floor(o.x)),
                             static_cast<std::int64_t>(std::floor(o.y)),
                             static_cast<std::int64_t>(std::floor(o.z))))
                originEmpty_[i] = static_cast<std::uint8_t>(originEmpty_[i] | (1u << s));
        }
    });
    // Groups: the voxels sorted by block and by the axis direction their normal is closest to.
    // Apart from the direction, a block's two sides of a thin wall or floor would share boxes that
    // take in the wall itself. One order serves both levels: by coarse block (Morton, so that an
    // octree node's groups are contiguous: Verdicts keeps a cluster's as one range), direction,
    // then fine block within the coarse one.
    static_assert(kLevels == 2, "the sort key holds two block sizes");
    // The key (≤ 30 bits for cells below 1024) above the voxel's index, in one word to sort.
    for (const auto& c : cells)
        if (std::max({c[0], c[1], c[2]}) >= 1024 || cells.size() > 0xFFFFFFFFu)
            throw UsageError("ShadowRayGroups: cells must lie below 1024 on every axis");
    std::vector<std::uint64_t> order(cells.size());
    tbb::parallel_for(std::size_t{0}, cells.size(), [&](std::size_t i) {
        const Vec3f n = normals_[i];
        int axis = 0;
        for (int k = 1; k < 3; ++k)
            if (std::abs(n[k]) > std::abs(n[axis])) axis = k;
        const std::uint64_t facing = static_cast<std::uint64_t>(2 * axis + (n[axis] < 0 ? 1 : 0));
        const auto& c = cells[i];
        const std::uint64_t fine = rvol::morton3(c[0] >> 1, c[1] >> 1, c[2] >> 1);
        order[i] = ((((fine >> 3) << 6) | (facing << 3) | (fine & 7u)) << 32) | i;
    });
    tbb::parallel_sort(order.begin(), order.end());
    // Level 0 (blocks of 4) ignores the fine block's three bits; its groups come first.
    const auto keyOf = [&](std::size_t k, int level) { return order[k] >> (level == 0 ? 35 : 32); };
    std::array<std::size_t, kLevels + 1> first{};
    for (int level = 0; level < kLevels; ++level) {
        std::size_t count = 0;
        for (std::size_t k = 0; k < order.size(); ++k)
            count += k == 0 || keyOf(k - 1, level) != keyOf(k, level);
        first[std::size_t(level) + 1] = first[std::size_t(level)] + count;
    }
    // Sized once: the groups take as much memory as the voxels, and growing it would touch
    // several times that.
    groups_.resize(first[kLevels]);
    const auto buildLevel = [&](int level) {
        std::size_t g = first[std::size_t(level)];
        for (std::size_t k = 0; k < order.size(); ++k) {
            if (k > 0 && keyOf(k - 1, level) != keyOf(k, level)) ++g;
            const auto i = static_cast<std::uint32_t>(order[k] & 0xFFFFFFFFu);
            Group& group = groups_[g];
            groupOf_[i][static_cast<std::size_t>(level)] = static_cast<std::uint32_t>(g);
            for (std::size_t s = 0; s < 2; ++s) {
                if (!(originEmpty_[i] & (1u << s))) continue;
                const double side = s == 0 ? 1 : -1;
                const Vec3d o = origin(i, int(side));
                for (int axis = 0; axis < 3; ++axis) {
                    // Rounded outwards: the float boxes hold the double origins and ends.
                    group.originLo[s][axis] =
                        std::min(group.originLo[s][axis], floatBelow(o[axis]));
                    group.originHi[s][axis] =
                        std::max(group.originHi[s][axis], floatAbove(o[axis]));
                    const double end = side * double(normals_[i][axis]);
                    group.endLo[s][axis] = std::min(group.endLo[s][axis], floatBelow(end));
                    group.endHi[s][axis] = std::max(group.endHi[s][axis], floatAbove(end));
                }
            }
        }
    };
    // The levels write their own groups and their own slot of groupOf_.
    tbb::parallel_invoke([&] { buildLevel(0); }, [&] { buildLevel(1); });
}

Vec3d ShadowRayGroups::origin(std::size_t voxel, int side) const noexcept {
    const auto& c = cells_[voxel];
    const Vec3f n = normals_[voxel];
    return {c[0] + 0.5 + side * double(n.x), c[1] + 0.5 + side * double(n.y),
            c[2] + 0.5 + side * double(n.z)};
}

ShadowRayGroups::Verdicts::Verdicts(const ShadowRayGroups& groups,
                                    std::span<const std::uint32_t> members)
    : rowOf_(groups.lights_.size(), 0) {
    std::uint32_t slots = 0;
    for (std::size_t level = 0; level < kLevels; ++level) {
        std::uint32_t lo = ~std::uint32_t{0}, hi = 0;
        for (const std::uint32_t i : members) {
            lo = std::min(lo, groups.groupOf_[i][level]);
            hi = std::max(hi, groups.groupOf_[i][level]);
        }
        first_[level] = members.empty() ? 0 : lo;
        offset_[level] = slots;
        slots += members.empty() ? 0 : hi - lo + 1;
    }
    rowSize_ = 2 * std::size_t{slots};
}

std::uint8_t& ShadowRayGroups::Verdicts::at(int level, std::uint32_t group, std::uint32_t light,
                                            std::size_t side) {
    std::uint32_t& row = rowOf_[light];
    if (row == 0) {
        rows_.resize(rows_.size() + rowSize_, 0);
        row = static_cast<std::uint32_t>(rows_.size() / rowSize_);
    }
    const auto l = static_cast<std::size_t>(level);
    return rows_[(row - 1) * rowSize_ + 2 * (offset_[l] + group - first_[l]) + side];
}

bool ShadowRayGroups::occluded(std::size_t voxel, std::uint32_t light, int side, Vec3d dir,
                               double maxT, Verdicts& verdicts,
                               SharedVisibilityStats& counts) const {
    const std::size_t s = side > 0 ? 0 : 1;
    const Vec3d from = origin(voxel, side);
    const Vec3d target = light < lights_.size() ? lights_[light] : Vec3d{0, 0, 0};
    if (!(originEmpty_[voxel] & (1u << s)) || light >= lights_.size() || !std::isfinite(target.x) ||
        !std::isfinite(target.y) || !std::isfinite(target.z) || !std::isfinite(maxT))
        return grid_.occluded(from, dir, maxT);
    enum : std::uint8_t { kUntested = 0, kUndecided = 1, kClear = 2, kBlocked = 3 };
    // The voxel's own ray, traced at most once: it answers where no group can, and the cell that
    // stops it names the layers the blocked test tries.
    int own = -1;
    std::array<std::int64_t, 3> hit{};
    for (int level = 0; level < kLevels; ++level) {
        const std::uint32_t g = groupOf_[voxel][static_cast<std::size_t>(level)];
        std::uint8_t* verdict = &verdicts.at(level, g, light, s);
        if (*verdict == kUntested) {
            const Group& group = groups_[g];
            const Vec3d fromLo = vec3Cast<double>(group.originLo[s]),
                        fromHi = vec3Cast<double>(group.originHi[s]);
            const Vec3d toLo = target + vec3Cast<double>(group.endLo[s]),
                        toHi = target + vec3Cast<double>(group.endHi[s]);
            ++counts.tests;
            *verdict = kUndecided;
            if (grid_.beamClear(fromLo, fromHi, toLo, toHi)) {
                *verdict = kClear;
            } else {
                if (own < 0) own = grid_.occluded(from, dir, maxT, &hit) ? 1 : 0;
                // The hit cell's layer along each axis, and the next one the ray enters (a wall
                // a few cells thick is whole there where the ray only grazed its face).
                if (own == 1)
                    for (int step = 0; step < 2 && *verdict == kUndecided; ++step)
                        for (int axis = 0; axis < 3 && *verdict == kUndecided; ++axis) {
                            const std::int64_t layer =
                                hit[std::size_t(axis)] + (step == 0 ? 0
                                                                    : (dir[axis] > 0   ? 1
                                                                       : dir[axis] < 0 ? -1
                                                                                       : 0));
                            if ((step == 0 || layer != hit[std::size_t(axis)]) &&
                                grid_.layerBlocks(fromLo, fromHi, toLo, toHi, axis, layer))
                                *verdict = kBlocked;
                        }
            }
        }
        if (*verdict != kUndecided) {
            if (own < 0) ++counts.answered;
            return *verdict == kBlocked;
        }
    }
    if (own < 0) own = grid_.occluded(from, dir, maxT) ? 1 : 0;
    return own == 1;
}

}  // namespace vox::detail
