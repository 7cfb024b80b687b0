// encodeCompressedBlock: the colour encoder (color_encode.cpp) and the normal encoder
// (normal_encode.cpp) on one block. What the encoders' files share is in
// attribute_encode_internal.h.
#include "attribute_encode.h"

#include <array>
#include <cstdint>

namespace vox::detail {

esvo::CompressedBlock encodeCompressedBlock(const std::array<std::uint64_t, 16>& values,
                                            std::uint32_t usedMask, AttributeEffort effort) {
    std::array<std::uint32_t, 16> colors{};
    std::array<esvo::Vec3, 16> normals{};
    for (unsigned slot = 0; slot < 16; ++slot) {
        if (!((usedMask >> slot) & 1u)) continue;  // (the encoders read used slots only)
        colors[slot] = static_cast<std::uint32_t>(values[slot]);
        normals[slot] = esvo::decodeNormal(static_cast<std::uint32_t>(values[slot] >> 32));
    }
    const auto c = encodeColorBlock(colors, usedMask, effort);
    const auto n = encodeNormalBlock(normals, usedMask, effort);
    return {c[0], c[1], n[0], n[1], n[2], n[3]};
}

}  // namespace vox::detail
