// The in-memory radiance volume (rvol.h): Morton codes, cell lookup in sparse levels, and the
// directional sample that combines a cone's three facing channels.
#include <vox/formats/rvol.h>

#include <algorithm>
#include <cmath>

namespace vox::rvol {
namespace {

// Spreads the low 21 bits of @p a to every third bit (bit i → bit 3i).
std::uint64_t spread3(std::uint32_t a) noexcept {
    std::uint64_t x = a & 0x1FFFFFu;
    x = (x | x << 32) & 0x001F00000000FFFFull;
    x = (x | x << 16) & 0x001F0000FF0000FFull;
    x = (x | x << 8) & 0x100F00F00F00F00Full;
    x = (x | x << 4) & 0x10C30C30C30C30C3ull;
    x = (x | x << 2) & 0x1249249249249249ull;
    return x;
}

// Inverse of spread3: gathers every third bit, starting at bit 0.
std::uint32_t compact3(std::uint64_t x) noexcept {
    x &= 0x1249249249249249ull;
    x = (x ^ (x >> 2)) & 0x10C30C30C30C30C3ull;
    x = (x ^ (x >> 4)) & 0x100F00F00F00F00Full;
    x = (x ^ (x >> 8)) & 0x001F0000FF0000FFull;
    x = (x ^ (x >> 16)) & 0x001F00000000FFFFull;
    x = (x ^ (x >> 32)) & 0x1FFFFFull;
    return static_cast<std::uint32_t>(x);
}

}  // namespace

std::uint64_t morton3(std::uint32_t x, std::uint32_t y, std::uint32_t z) noexcept {
    return spread3(x) | spread3(y) << 1 | spread3(z) << 2;
}

std::array<std::uint32_t, 3> demorton3(std::uint64_t code) noexcept {
    return {compact3(code), compact3(code >> 1), compact3(code >> 2)};
}

std::int64_t Level::findBlock(std::uint32_t x, std::uint32_t y, std::uint32_t z) const noexcept {
    if (x >= resolution || y >= resolution || z >= resolution) return -1;
    const std::uint64_t code = morton3(x / kBlockCells, y / kBlockCells, z / kBlockCells);
    const auto it = std::lower_bound(blocks.begin(), blocks.end(), code);
    if (it == blocks.end() || *it != code) return -1;
    return it - blocks.begin();
}

Texel Level::at(std::uint32_t x, std::uint32_t y, std::uint32_t z,
                std::uint32_t channel) const noexcept {
    if (channel >= channels) return {};
    const std::int64_t block = findBlock(x, y, z);
    if (block < 0) return {};
    const std::size_t index =
        texelIndex(static_cast<std::size_t>(block), channels, channel, x, y, z);
    // A level whose texel array is shorter than its block list is malformed; read it as empty
    // rather than past the end.
    return index < texels.size() ? texels[index] : Texel{};
}

Texel combineDirectional(const std::array<Texel, 3>& facing,
                         const std::array<double, 3>& direction) noexcept {
    const double length2 =
        direction[0] * direction[0] + direction[1] * direction[1] + direction[2] * direction[2];
    const double sumAbs = std::abs(direction[0]) + std::abs(direction[1]) + std::abs(direction[2]);
    if (!(length2 > 0) || !std::isfinite(length2)) return {};
    double rgb[3] = {0, 0, 0}, alphaBlend = 0, logTransmittance = 0;
    for (int a = 0; a < 3; ++a) {
        if (direction[a] == 0) continue;
        const double w = direction[a] * direction[a] / length2;
        const Texel& t = facing[a];
        rgb[0] += w * t.r;
        rgb[1] += w * t.g;
        rgb[2] += w * t.b;
        alphaBlend += w * t.a;
        // A clear channel adds log(1) = 0: skip the logarithm (most samples of a cone are clear).
        if (t.a > 0)
            logTransmittance += std::abs(direction[a]) / sumAbs *
                                std::log(std::max(1.0 - std::min(double(t.a), 1.0), 1e-12));
    }
    const double alpha = logTransmittance < 0 ? 1 - std::exp(logTransmittance) : 0.0;
    const double scale = alphaBlend > 1e-12 ? alpha / alphaBlend : 0.0;
    return {static_cast<float>(rgb[0] * scale), static_cast<float>(rgb[1] * scale),
            static_cast<float>(rgb[2] * scale), static_cast<float>(alpha)};
}

}  // namespace vox::rvol
