#include "attribute_corpus.h"

#include <vox/texture.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>  // stb_dxt uses memcpy without including it
#include <numbers>

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wshadow"
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wsign-compare"
#define STB_DXT_IMPLEMENTATION
#include <stb/stb_dxt.h>
#pragma GCC diagnostic pop

namespace vox::corpus {

using esvo::Vec3;

std::uint32_t randomMask(std::mt19937& rng, unsigned bits) {
    std::array<unsigned, 16> slots{};
    for (unsigned i = 0; i < 16; ++i) slots[i] = i;
    std::shuffle(slots.begin(), slots.end(), rng);
    std::uint32_t mask = 0;
    for (unsigned i = 0; i < bits; ++i) mask |= 1u << slots[i];
    return mask;
}

Vec3 normalised(double x, double y, double z) {
    const double len = std::sqrt(x * x + y * y + z * z);
    return {static_cast<float>(x / len), static_cast<float>(y / len), static_cast<float>(z / len)};
}

Vec3 randomDirection(std::mt19937& rng) {
    std::normal_distribution<double> g;
    for (;;) {
        const double x = g(rng), y = g(rng), z = g(rng);
        if (x * x + y * y + z * z > 1e-6) return normalised(x, y, z);
    }
}

double angle(const Vec3& a, const Vec3& b) {
    const double cx = double(a[1]) * b[2] - double(a[2]) * b[1],
                 cy = double(a[2]) * b[0] - double(a[0]) * b[2],
                 cz = double(a[0]) * b[1] - double(a[1]) * b[0];
    const double dot = double(a[0]) * b[0] + double(a[1]) * b[1] + double(a[2]) * b[2];
    return std::atan2(std::sqrt(cx * cx + cy * cy + cz * cz), dot);
}

std::array<Vec3, 16> randomCone(std::mt19937& rng, double halfAngle) {
    const Vec3 axis = randomDirection(rng);
    // An orthonormal basis around the axis.
    const Vec3 helper = std::fabs(axis[0]) < 0.9f ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
    const Vec3 t1 = normalised(axis[1] * helper[2] - axis[2] * helper[1],
                               axis[2] * helper[0] - axis[0] * helper[2],
                               axis[0] * helper[1] - axis[1] * helper[0]);
    const Vec3 t2{axis[1] * t1[2] - axis[2] * t1[1], axis[2] * t1[0] - axis[0] * t1[2],
                  axis[0] * t1[1] - axis[1] * t1[0]};
    std::uniform_real_distribution<double> unit(0, 1);
    std::array<Vec3, 16> normals{};
    for (auto& n : normals) {
        const double cosTheta = 1 - unit(rng) * (1 - std::cos(halfAngle)),
                     sinTheta = std::sqrt(1 - cosTheta * cosTheta);
        const double phi = 2 * std::numbers::pi * unit(rng);
        const double a = sinTheta * std::cos(phi), b = sinTheta * std::sin(phi);
        n = normalised(cosTheta * axis[0] + a * t1[0] + b * t2[0],
                       cosTheta * axis[1] + a * t1[1] + b * t2[1],
                       cosTheta * axis[2] + a * t1[2] + b * t2[2]);
    }
    return normals;
}

std::vector<ColorBlock> textureTiles(std::span<const std::filesystem::path> files,
                                     std::size_t perTexture, std::vector<std::string>* used) {
    std::vector<ColorBlock> tiles;
    for (const std::filesystem::path& path : files) {
        if (!std::filesystem::exists(path)) continue;
        const Texture texture = loadTexture(path, ColorSpace::SRGB);
        if (used) used->push_back(path.string());
        const int tx = texture.width() / 4, ty = texture.height() / 4;
        const std::size_t total = static_cast<std::size_t>(tx) * static_cast<std::size_t>(ty);
        const std::size_t stride = std::max<std::size_t>(1, total / perTexture) | 1;
        for (std::size_t t = 0; t < total; t += stride) {
            const int x0 = static_cast<int>(t % static_cast<std::size_t>(tx)) * 4,
                      y0 = static_cast<int>(t / static_cast<std::size_t>(tx)) * 4;
            ColorBlock b;
            for (unsigned s = 0; s < 16; ++s) {
                const Vec4f c =
                    texture.texel(0, x0 + static_cast<int>(s % 4), y0 + static_cast<int>(s / 4));
                const auto byte = [](float linear) {
                    return static_cast<std::uint32_t>(
                        std::lround(std::clamp(linearToSrgb(linear), 0.0f, 1.0f) * 255.0f));
                };
                b.colors[s] = esvo::packColor(byte(c.x), byte(c.y), byte(c.z));
            }
            tiles.push_back(b);
        }
    }
    return tiles;
}

std::array<std::uint32_t, 2> stbEncode(const ColorBlock& b, bool highQuality) {
    unsigned first = 0;
    while (!((b.mask >> first) & 1u)) ++first;
    unsigned char rgba[64];
    for (unsigned s = 0; s < 16; ++s) {
        const std::uint32_t c = ((b.mask >> s) & 1u) ? b.colors[s] : b.colors[first];
        for (unsigned ch = 0; ch < 3; ++ch)
            rgba[4 * s + ch] = static_cast<unsigned char>(esvo::colorChannel(c, ch));
        rgba[4 * s + 3] = 255;
    }
    unsigned char out[8];
    stb_compress_dxt_block(out, rgba, 0, highQuality ? STB_DXT_HIGHQUAL : STB_DXT_NORMAL);
    const auto word = [&](unsigned o) {
        return std::uint32_t{out[o]} | (std::uint32_t{out[o + 1]} << 8) |
               (std::uint32_t{out[o + 2]} << 16) | (std::uint32_t{out[o + 3]} << 24);
    };
    return {word(0), word(4)};
}

std::vector<SceneBlock> sceneBlocks(const SparseOctree& octree) {
    std::vector<std::vector<std::uint64_t>> firstChild(octree.leafDepth);
    for (std::uint32_t l = 0; l < octree.leafDepth; ++l) {
        std::uint64_t sum = 0;
        for (std::uint8_t m : octree.masks[l])
            firstChild[l].push_back(sum), sum += static_cast<unsigned>(std::popcount(unsigned(m)));
    }
    const auto fill = [&](std::uint32_t level, std::uint64_t index, unsigned base,
                          SceneBlock& block) {
        const std::uint32_t valid = octree.masks[level][index];
        std::uint64_t child = firstChild[level][index];
        for (unsigned slot = 0; slot < 8; ++slot)
            if (valid & (1u << slot)) {
                block.values[base + slot] = octree.attributes[level + 1][child++];
                block.mask |= 1u << (base + slot);
            }
    };
    std::vector<SceneBlock> blocks;
    const auto emit = [&](std::uint32_t level, const std::vector<std::uint64_t>& group) {
        for (std::size_t i = 0; i < group.size(); i += 2) {
            SceneBlock block;
            fill(level, group[i], 0, block);
            if (i + 1 < group.size()) fill(level, group[i + 1], 8, block);
            blocks.push_back(block);
        }
    };
    emit(0, {0});  // the root descriptor is a group of its own
    std::vector<std::uint64_t> group;
    for (std::uint32_t l = 0; l + 1 < octree.leafDepth; ++l)
        for (std::uint64_t p = 0; p < octree.masks[l].size(); ++p) {
            group.clear();
            std::uint64_t child = firstChild[l][p];
            for (unsigned slot = 0; slot < 8; ++slot)
                if (octree.masks[l][p] & (1u << slot)) {
                    if (octree.masks[l + 1][child]) group.push_back(child);
                    ++child;
                }
            emit(l + 1, group);
        }
    return blocks;
}

}  // namespace vox::corpus
