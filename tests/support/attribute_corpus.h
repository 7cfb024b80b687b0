// Block corpora and the stb_dxt peer shared by the compressed-attribute test
// (tests/test_attribute_encode.cpp) and benchmark (bench/attribute_encode_bench.cpp), so the two
// measure the encoder on the same blocks against the same peer.
#pragma once

#include <vox/formats/esvo_attributes.h>
#include <vox/octree.h>

#include <array>
#include <cstdint>
#include <filesystem>
#include <random>
#include <span>
#include <string>
#include <vector>

namespace vox::corpus {

/// 16 colour words (esvo::packColor, sRGB) and the slots that matter.
struct ColorBlock {
    std::array<std::uint32_t, 16> colors{};
    std::uint32_t mask = 0xFFFFu;
};

/// A random mask with @p bits of the 16 slots set.
[[nodiscard]] std::uint32_t randomMask(std::mt19937& rng, unsigned bits);

[[nodiscard]] esvo::Vec3 normalised(double x, double y, double z);
/// Uniform over the sphere.
[[nodiscard]] esvo::Vec3 randomDirection(std::mt19937& rng);
/// Angle in radians between two (not necessarily unit) vectors, accurate for tiny angles.
[[nodiscard]] double angle(const esvo::Vec3& a, const esvo::Vec3& b);
/// 16 directions uniformly distributed within @p halfAngle (radians) of a random axis.
[[nodiscard]] std::array<esvo::Vec3, 16> randomCone(std::mt19937& rng, double halfAngle);

/// 4×4 tiles of the texture @p files (sRGB bytes as stored), at most about @p perTexture per
/// texture, spread over it. Files that do not exist are skipped; @p used lists those read.
[[nodiscard]] std::vector<ColorBlock> textureTiles(std::span<const std::filesystem::path> files,
                                                   std::size_t perTexture,
                                                   std::vector<std::string>* used = nullptr);

/// A compressed attribute block's 16 slots as writeEsvo fills them from an octree: values as
/// SparseOctree::attributes holds them (colour word | cube-face normal word << 32) and the slots
/// that hold a voxel.
struct SceneBlock {
    std::array<std::uint64_t, 16> values{};
    std::uint32_t mask = 0;
};

/// The blocks writeEsvo forms from @p octree (which must have attributes) for
/// AttributeEncoding::Compressed: each parent's children that have descriptors, in slot order,
/// paired consecutively (an odd one out pairs with padding), the root descriptor alone.
[[nodiscard]] std::vector<SceneBlock> sceneBlocks(const SparseOctree& octree);

/// stb_dxt's (Debian's libstb-dev) block for the used slots, the unused ones filled with the
/// first used colour, as our words 0 and 1 (the same layout); @p highQuality: STB_DXT_HIGHQUAL.
[[nodiscard]] std::array<std::uint32_t, 2> stbEncode(const ColorBlock& block, bool highQuality);

}  // namespace vox::corpus
