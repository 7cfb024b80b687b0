#include "air_regions.h"

#include <cmath>

namespace vox::detail {

AirRegions::AirRegions(const SolidGrid& solid, std::uint32_t depth, std::array<std::int64_t, 3> lo,
                       std::array<std::int64_t, 3> hi)
    : resolution_(1u << depth) {
    const std::size_t r = resolution_;
    labels_.assign(r * r * r, kNone);
    for (std::size_t z = 0; z < r; ++z)
        for (std::size_t y = 0; y < r; ++y)
            for (std::size_t x = 0; x < r; ++x) {
                const std::int64_t c[3] = {static_cast<std::int64_t>(x),
                                           static_cast<std::int64_t>(y),
                                           static_cast<std::int64_t>(z)};
                bool outside = false;
                for (int a = 0; a < 3; ++a) outside = outside || c[a] < lo[a] || c[a] >= hi[a];
                if (outside || solid.solid(c[0], c[1], c[2])) labels_[(z * r + y) * r + x] = kSolid;
            }
    std::vector<std::uint32_t> stack;
    for (std::size_t seed = 0; seed < labels_.size(); ++seed) {
        if (labels_[seed] != kNone) continue;
        if (count_ >= kNone) break;  // out of labels: the rest stay kNone
        const auto region = static_cast<std::uint16_t>(count_++);
        labels_[seed] = region;
        stack.push_back(static_cast<std::uint32_t>(seed));
        while (!stack.empty()) {
            const std::size_t i = stack.back();
            stack.pop_back();
            const std::size_t x = i % r, y = (i / r) % r, z = i / (r * r);
            const auto visit = [&](std::size_t j) {
                if (labels_[j] == kNone) {
                    labels_[j] = region;
                    stack.push_back(static_cast<std::uint32_t>(j));
                }
            };
            if (x > 0) visit(i - 1);
            if (x + 1 < r) visit(i + 1);
            if (y > 0) visit(i - r);
            if (y + 1 < r) visit(i + r);
            if (z > 0) visit(i - r * r);
            if (z + 1 < r) visit(i + r * r);
        }
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
