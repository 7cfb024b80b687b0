// Private helpers shared by the .rvol writer, reader and validator (formats/src/rvol_*.cpp).
#pragma once

#include <cstdint>
#include <cstring>

namespace vox::rvol::detail {

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
              "the .rvol format is little-endian, as is every supported host");

template <typename T>
[[nodiscard]] inline T load(const std::uint8_t* p) noexcept {
    T value;
    std::memcpy(&value, p, sizeof value);
    return value;
}
template <typename T>
inline void store(std::uint8_t* p, T value) noexcept {
    std::memcpy(p, &value, sizeof value);
}

/// Header field offsets (docs/rvol-format.md, "Header").
namespace hdr {
inline constexpr std::size_t kMagic = 0, kVersionMajor = 4, kVersionMinor = 6, kHeaderBytes = 8,
                             kDepth = 12, kLevelCount = 16, kBrickTexels = 20, kTexelFormat = 24,
                             kFlags = 28, kOrigin = 32, kSize = 56, kSceneBounds = 64,
                             kBounces = 88, kShadowAperture = 92, kAoLambda = 96,
                             kAttenuation = 100, kLights = 104, kGatherRays = 108,
                             kBrickCount = 112, kStaticVoxels = 120, kDynamicVoxels = 128,
                             kLevelTableOffset = 136, kLevelTableBytes = 144,
                             kLevelTableChecksum = 152, kDirectoryChecksum = 156,
                             kDirectoryOffset = 160, kDirectoryBytes = 168, kBrickDataOffset = 176,
                             kBrickDataBytes = 184, kStaticOffset = 192, kStaticBytes = 200,
                             kDynamicOffset = 208, kDynamicBytes = 216, kStaticChecksum = 224,
                             kDynamicChecksum = 228, kFileBytes = 232, kChecksum = 252;
}  // namespace hdr

}  // namespace vox::rvol::detail
