#include "voxel_shadows.h"

#include "../util/segment_clip.h"

#include <vox/formats/rvol.h>

#include <tbb/parallel_for.h>

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
    // Per level, the members sorted by (block, facing): a group is a run of equal keys. Apart
    // from the facing, a block's two sides of a thin wall or floor would share boxes that take in
    // the wall itself.
    std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed(members.size());
    members_.resize(members.size());
    for (std::size_t k = 0; k < members.size(); ++k) members_[k].first = members[k];
    std::sort(members_.begin(), members_.end());
    for (int level = 0; level < kLevels; ++level) {
        const auto shift = static_cast<std::uint32_t>(kLevels - level);  // blocks of 4, then 2
        for (std::size_t k = 0; k < members_.size(); ++k) {
            const std::uint32_t i = members_[k].first;
            const Vec3f n = groups.normals_[i];
            int axis = 0;
            for (int a = 1; a < 3; ++a)
                if (std::abs(n[a]) > std::abs(n[axis])) axis = a;
            const auto& c = groups.cells_[i];
            const std::uint64_t block = rvol::morton3(c[0] >> shift, c[1] >> shift, c[2] >> shift);
            keyed[k] = {(block << 3) | std::uint64_t(2 * axis + (n[axis] < 0 ? 1 : 0)),
                        std::uint32_t(k)};
        }
        std::sort(keyed.begin(), keyed.end());
        for (std::size_t k = 0; k < keyed.size(); ++k) {
            if (k == 0 || keyed[k - 1].first != keyed[k].first) groups_.emplace_back();
            Group& g = groups_.back();
            auto& [i, of] = members_[keyed[k].second];
            of[std::size_t(level)] = static_cast<std::uint32_t>(groups_.size() - 1);
            for (std::size_t s = 0; s < 2; ++s) {
                if (!(groups.originEmpty_[i] & (1u << s))) continue;
                const double side = s == 0 ? 1 : -1;
                const Vec3d o = groups.origin(i, int(side));
                for (int a = 0; a < 3; ++a) {
                    g.originLo[s][a] = std::min(g.originLo[s][a], o[a]);
                    g.originHi[s][a] = std::max(g.originHi[s][a], o[a]);
                    const double end = side * double(groups.normals_[i][a]);
                    g.endLo[s][a] = std::min(g.endLo[s][a], end);
                    g.endHi[s][a] = std::max(g.endHi[s][a], end);
                }
            }
        }
    }
}

const std::array<std::uint32_t, ShadowRayGroups::kLevels>& ShadowRayGroups::Verdicts::groupsOf(
    std::size_t voxel) {
    if (last_ >= members_.size() || members_[last_].first != voxel)
        last_ = static_cast<std::size_t>(
            std::lower_bound(members_.begin(), members_.end(), voxel,
                             [](const auto& m, std::size_t v) { return m.first < v; }) -
            members_.begin());
    return members_[last_].second;
}

std::uint8_t& ShadowRayGroups::Verdicts::at(std::uint32_t group, std::uint32_t light,
                                            std::size_t side) {
    const std::size_t rowSize = 2 * groups_.size();
    std::uint32_t& row = rowOf_[light];
    if (row == 0) {
        rows_.resize(rows_.size() + rowSize, 0);
        row = static_cast<std::uint32_t>(rows_.size() / rowSize);
    }
    return rows_[(row - 1) * rowSize + 2 * std::size_t{group} + side];
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
    const std::array<std::uint32_t, kLevels>& of = verdicts.groupsOf(voxel);
    for (int level = 0; level < kLevels; ++level) {
        const std::uint32_t g = of[static_cast<std::size_t>(level)];
        std::uint8_t* verdict = &verdicts.at(g, light, s);
        if (*verdict == kUntested) {
            const Verdicts::Group& group = verdicts.groups_[g];
            const Vec3d fromLo = group.originLo[s], fromHi = group.originHi[s];
            const Vec3d toLo = target + group.endLo[s], toHi = target + group.endHi[s];
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
