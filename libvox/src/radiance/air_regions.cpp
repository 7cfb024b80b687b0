#include "air_regions.h"

#include <algorithm>
#include <cmath>

namespace vox::detail {

AirRegions::AirRegions(const SolidGrid& solid, std::uint32_t depth, std::array<std::int64_t, 3> lo,
                       std::array<std::int64_t, 3> hi)
    : resolution_(1u << depth) {
    const std::size_t r = resolution_;
    labels_.assign(r * r * r, kSolid);
    const auto clamped = [r](std::int64_t v) {
        return static_cast<std::size_t>(std::clamp<std::int64_t>(v, 0, std::int64_t(r)));
    };
    const std::size_t x0 = clamped(lo[0]), x1 = clamped(hi[0]);
    for (std::size_t z = clamped(lo[2]); z < clamped(hi[2]); ++z)
        for (std::size_t y = clamped(lo[1]); y < clamped(hi[1]); ++y) {
            std::uint16_t* row = &labels_[(z * r + y) * r];
            for (std::size_t x = x0; x < x1; ++x)
                if (!solid.solid(std::int64_t(x), std::int64_t(y), std::int64_t(z))) row[x] = kNone;
        }
    // Components through runs of air along x: each run is joined to the runs it overlaps in the
    // rows below (y − 1) and behind (z − 1), and the components are numbered in the order of
    // their first runs, which is the scan order of their first cells (what a flood fill from
    // seeds in scan order numbers). A few runs per row instead of a visit per cell.
    struct Run {
        std::uint32_t begin, end;  // x range [begin, end)
    };
    std::vector<Run> runs;
    std::vector<std::size_t> rowRuns(r * r + 1, 0);  // runs of row (z·r + y): [rowRuns[row], next)
    for (std::size_t row = 0; row < r * r; ++row) {
        rowRuns[row] = runs.size();
        const std::uint16_t* cells = &labels_[row * r];
        for (std::size_t x = 0; x < r;) {
            if (cells[x] != kNone) {
                ++x;
                continue;
            }
            const std::size_t begin = x;
            while (x < r && cells[x] == kNone) ++x;
            runs.push_back({static_cast<std::uint32_t>(begin), static_cast<std::uint32_t>(x)});
        }
    }
    rowRuns[r * r] = runs.size();
    // Union–find; the root of a set is its earliest run.
    std::vector<std::size_t> parent(runs.size());
    for (std::size_t i = 0; i < parent.size(); ++i) parent[i] = i;
    const auto find = [&](std::size_t i) {
        while (parent[i] != i) {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        return i;
    };
    const auto joinRows = [&](std::size_t row, std::size_t other) {
        std::size_t j = rowRuns[other];
        const std::size_t jEnd = rowRuns[other + 1];
        for (std::size_t i = rowRuns[row]; i < rowRuns[row + 1]; ++i) {
            while (j < jEnd && runs[j].end <= runs[i].begin) ++j;
            // Every run of the other row that overlaps run i (face-connected cells share x).
            for (std::size_t k = j; k < jEnd && runs[k].begin < runs[i].end; ++k) {
                const std::size_t a = find(i), b = find(k);
                if (a != b) parent[std::max(a, b)] = std::min(a, b);
            }
        }
    };
    for (std::size_t z = 0; z < r; ++z)
        for (std::size_t y = 0; y < r; ++y) {
            if (y > 0) joinRows(z * r + y, z * r + y - 1);
            if (z > 0) joinRows(z * r + y, (z - 1) * r + y);
        }
    std::vector<std::uint16_t> regionOf(runs.size(), kNone);
    for (std::size_t row = 0; row < r * r; ++row)
        for (std::size_t i = rowRuns[row]; i < rowRuns[row + 1]; ++i) {
            const std::size_t root = find(i);
            if (root == i && count_ < kNone) regionOf[i] = static_cast<std::uint16_t>(count_++);
            // Out of labels: the later components stay kNone.
            const std::uint16_t region = regionOf[root];
            std::fill(labels_.begin() + static_cast<std::ptrdiff_t>(row * r + runs[i].begin),
                      labels_.begin() + static_cast<std::ptrdiff_t>(row * r + runs[i].end), region);
        }
}

std::uint16_t AirRegions::label(std::int64_t x, std::int64_t y, std::int64_t z) const noexcept {
    const std::int64_t r = resolution_;
    if (x < 0 || y < 0 || z < 0 || x >= r || y >= r || z >= r) return kNone;
    return labels_[(static_cast<std::size_t>(z) * resolution_ + static_cast<std::size_t>(y)) *
                       resolution_ +
                   static_cast<std::size_t>(x)];
}

std::uint16_t AirRegions::facing(std::uint32_t x, std::uint32_t y, std::uint32_t z,
                                 Vec3f normal) const noexcept {
    // Walk out along the normal: a surface on a cell boundary makes both cells beside it solid.
    for (double k = 1; k <= 3; k += 1) {
        const std::int64_t c[3] = {static_cast<std::int64_t>(std::floor(x + 0.5 + k * normal.x)),
                                   static_cast<std::int64_t>(std::floor(y + 0.5 + k * normal.y)),
                                   static_cast<std::int64_t>(std::floor(z + 0.5 + k * normal.z))};
        const std::uint16_t l = label(c[0], c[1], c[2]);
        if (l != kSolid) return l;
    }
    return kNone;
}

bool AirRegions::touches(std::uint32_t x, std::uint32_t y, std::uint32_t z,
                         std::uint16_t region) const noexcept {
    for (int axis = 0; axis < 3; ++axis)
        for (int sign : {-1, 1}) {
            std::int64_t c[3] = {x, y, z};
            c[axis] += sign;
            if (label(c[0], c[1], c[2]) == region) return true;
        }
    return false;
}

}  // namespace vox::detail
