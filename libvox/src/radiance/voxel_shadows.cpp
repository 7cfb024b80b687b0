#include "voxel_shadows.h"

#include <algorithm>
#include <cmath>
#include <limits>

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

bool SolidGrid::occluded(Vec3d origin, Vec3d dir, double maxT) const noexcept {
    const double r = resolution_;
    // Clip the segment to the grid.
    double t0 = 0, t1 = maxT;
    for (int axis = 0; axis < 3; ++axis) {
        if (dir[axis] == 0) {
            if (origin[axis] < 0 || origin[axis] >= r) return false;
            continue;
        }
        double a = (0 - origin[axis]) / dir[axis], b = (r - origin[axis]) / dir[axis];
        if (a > b) std::swap(a, b);
        t0 = std::max(t0, a);
        t1 = std::min(t1, b);
    }
    if (t0 >= t1) return false;
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
        if (!empty && solid(c[0], c[1], c[2]) && !(c[0] == sx && c[1] == sy && c[2] == sz))
            return true;
        double exit = std::numeric_limits<double>::infinity();
        for (int axis = 0; axis < 3; ++axis) {
            if (dir[axis] > 0)
                exit = std::min(exit, (double(lo[axis] + size) - origin[axis]) / dir[axis]);
            else if (dir[axis] < 0)
                exit = std::min(exit, (double(lo[axis]) - origin[axis]) / dir[axis]);
        }
        t = std::max(exit, t + 1e-7);
    }
    return false;
}

}  // namespace vox::detail
