#include "radiance_mips.h"

#include <tbb/parallel_for.h>

#include <algorithm>

namespace vox::detail {

using rvol::kBlockCells;
using rvol::kBlockTexels;
using rvol::kDirections;
using rvol::Texel;

void allocateVolume(rvol::Volume& volume, std::span<const std::array<std::uint32_t, 3>> cells,
                    std::vector<std::size_t>& cellTexel) {
    volume.levels.assign(volume.depth + 1, {});
    rvol::Level& base = volume.levels[0];
    base.resolution = 1u << volume.depth;
    base.channels = 1;
    cellTexel.resize(cells.size());
    for (std::size_t i = 0; i < cells.size(); ++i) {
        const auto& c = cells[i];
        const std::uint64_t block =
            rvol::morton3(c[0] / kBlockCells, c[1] / kBlockCells, c[2] / kBlockCells);
        if (base.blocks.empty() || base.blocks.back() != block) {
            if (!base.blocks.empty() && block < base.blocks.back())
                throw std::logic_error("allocateVolume: cells out of Morton order");
            base.blocks.push_back(block);
        }
        cellTexel[i] = rvol::Level::texelIndex(base.blocks.size() - 1, 1, 0, c[0], c[1], c[2]);
    }
    base.texels.assign(base.blocks.size() * kBlockTexels, Texel{});
    for (std::uint32_t l = 1; l <= volume.depth; ++l) {
        const rvol::Level& child = volume.levels[l - 1];
        rvol::Level& level = volume.levels[l];
        level.resolution = child.resolution / 2;
        level.channels = kDirections;
        for (std::uint64_t code : child.blocks) {
            // Blocks at coarse levels (under 8 cells per axis) stay block 0.
            const std::uint64_t parent = code >> 3;
            if (level.blocks.empty() || level.blocks.back() != parent)
                level.blocks.push_back(parent);
        }
        level.texels.assign(level.blocks.size() * kDirections * kBlockTexels, Texel{});
    }
}

namespace {

/// Front-to-back "over" of premultiplied texels.
inline Texel over(const Texel& front, const Texel& back) {
    const float k = 1 - front.a;
    return {front.r + k * back.r, front.g + k * back.g, front.b + k * back.b, front.a + k * back.a};
}

}  // namespace

void filterMips(rvol::Volume& volume, const RadianceField& field,
                const std::vector<std::uint8_t>& hidden) {
    const rvol::Level& base = volume.levels[0];
    for (std::uint32_t l = 1; l <= volume.depth; ++l) {
        rvol::Level& level = volume.levels[l];
        const bool fromBase = l == 1;
        tbb::parallel_for(std::size_t{0}, level.blocks.size(), [&](std::size_t b) {
            const auto bc = rvol::demorton3(level.blocks[b]);
            const std::uint32_t extent = std::min(kBlockCells, level.resolution);
            for (std::uint32_t lz = 0; lz < extent; ++lz)
                for (std::uint32_t ly = 0; ly < extent; ++ly)
                    for (std::uint32_t lx = 0; lx < extent; ++lx) {
                        const std::uint32_t x = bc[0] * kBlockCells + lx,
                                            y = bc[1] * kBlockCells + ly,
                                            z = bc[2] * kBlockCells + lz;
                        // The eight children's texels per channel (null: empty).
                        const Texel* child[8];
                        std::uint8_t childHidden[8] = {};
                        bool any = false;
                        for (std::uint32_t s = 0; s < 8; ++s) {
                            const std::uint32_t cx = 2 * x + (s & 1u), cy = 2 * y + ((s >> 1) & 1u),
                                                cz = 2 * z + (s >> 2);
                            child[s] = field.cellTexels(l - 1, cx, cy, cz);
                            if (child[s] && fromBase)
                                childHidden[s] =
                                    hidden[static_cast<std::size_t>(child[s] - base.texels.data())];
                            any = any || child[s];
                        }
                        if (!any) continue;
                        for (std::uint32_t k = 0; k < kDirections; ++k) {
                            const std::uint32_t axis = k / 2;
                            const bool negative = k & 1u;
                            const auto childValue = [&](std::uint32_t s) -> Texel {
                                if (!child[s]) return {};
                                if (fromBase) {
                                    Texel t = child[s][0];
                                    if (childHidden[s] & (1u << k)) t.r = t.g = t.b = 0;
                                    return t;
                                }
                                return child[s][std::size_t{k} * kBlockTexels];
                            };
                            Texel sum{};
                            for (std::uint32_t column = 0; column < 4; ++column) {
                                // Slot bits of the other two axes from the column; this axis' bit
                                // picks front (towards the cone's origin) and back.
                                std::uint32_t s0 = 0, bit = 0;
                                for (std::uint32_t a = 0; a < 3; ++a) {
                                    if (a == axis) continue;
                                    if (column & (1u << bit)) s0 |= 1u << a;
                                    ++bit;
                                }
                                const std::uint32_t lowSlot = s0, highSlot = s0 | (1u << axis);
                                const Texel v =
                                    negative ? over(childValue(highSlot), childValue(lowSlot))
                                             : over(childValue(lowSlot), childValue(highSlot));
                                sum.r += v.r;
                                sum.g += v.g;
                                sum.b += v.b;
                                sum.a += v.a;
                            }
                            Texel& out =
                                level.texels[rvol::Level::texelIndex(b, kDirections, k, x, y, z)];
                            out = {0.25f * sum.r, 0.25f * sum.g, 0.25f * sum.b, 0.25f * sum.a};
                        }
                    }
        });
    }
}

}  // namespace vox::detail
