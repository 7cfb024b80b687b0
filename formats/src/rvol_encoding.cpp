// The .rvol texel and attribute encodings (docs/rvol-format.md, "Encodings"): RGB9E5, A8, sRGB8,
// octahedral normals, the attribute record, and brick decoding.
#include <vox/formats/rvol_io.h>

#include "rvol_internal.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <stdexcept>
#include <string>

namespace vox::rvol {
namespace {

constexpr int kExponentBias = 15;
constexpr int kMantissaBits = 9;
constexpr int kMaxBiasedExponent = 31;

// Clamps to [0, 65408]; NaN (every comparison false) becomes 0, as in OpenGL.
double clampRgb9e5(float v) noexcept {
    return v > 0 ? std::min(static_cast<double>(v), double{kRgb9e5Max}) : 0.0;
}

// floor(x · 2^shift + 0.5): the spec's round-to-nearest; exact in double for these magnitudes.
std::uint32_t roundScaled(double x, int shift) noexcept {
    return static_cast<std::uint32_t>(std::floor(std::ldexp(x, shift) + 0.5));
}

std::uint32_t snorm12(double c) noexcept {
    return static_cast<std::uint32_t>(std::lround(std::clamp(c, -1.0, 1.0) * 2047.0) + 2048);
}
double unsnorm12(std::uint32_t q) noexcept {
    return std::max(-1.0, (static_cast<double>(q & 0xFFFu) - 2048.0) / 2047.0);
}
double signNotZero(double v) noexcept { return v < 0 ? -1.0 : 1.0; }

}  // namespace

std::uint32_t encodeRgb9e5(float r, float g, float b) noexcept {
    const double rc = clampRgb9e5(r), gc = clampRgb9e5(g), bc = clampRgb9e5(b);
    const double maxc = std::max({rc, gc, bc});
    // exp_shared_p = max(−B − 1, ⌊log2(max_c)⌋) + 1 + B; frexp gives ⌊log2⌋ exactly (max_c =
    // m·2^e with m in [0.5, 1), so ⌊log2⌋ = e − 1). max_c = 0 takes the −B − 1 branch.
    int floorLog2 = -kExponentBias - 1;
    if (maxc > 0) {
        int e = 0;
        (void)std::frexp(maxc, &e);
        floorLog2 = std::max(floorLog2, e - 1);
    }
    int exponent = floorLog2 + 1 + kExponentBias;
    // A maximum that rounds up to 2^9 needs the next exponent.
    if (roundScaled(maxc, kExponentBias + kMantissaBits - exponent) == (1u << kMantissaBits))
        ++exponent;
    exponent = std::min(
        exponent, kMaxBiasedExponent);  // unreachable after the clamp to 65408; kept for safety
    const int shift = kExponentBias + kMantissaBits - exponent;
    return roundScaled(rc, shift) | roundScaled(gc, shift) << 9 | roundScaled(bc, shift) << 18 |
           static_cast<std::uint32_t>(exponent) << 27;
}

std::array<float, 3> decodeRgb9e5(std::uint32_t packed) noexcept {
    const int shift = static_cast<int>(packed >> 27) - kExponentBias - kMantissaBits;
    return {std::ldexp(static_cast<float>(packed & 0x1FFu), shift),
            std::ldexp(static_cast<float>((packed >> 9) & 0x1FFu), shift),
            std::ldexp(static_cast<float>((packed >> 18) & 0x1FFu), shift)};
}

std::uint8_t encodeUnorm8(float v) noexcept {
    const double c = v > 0 ? std::min(static_cast<double>(v), 1.0) : 0.0;
    return static_cast<std::uint8_t>(std::floor(c * 255.0 + 0.5));
}

std::uint8_t encodeSrgb8(float linear) noexcept {
    const double c = linear > 0 ? std::min(static_cast<double>(linear), 1.0) : 0.0;
    const double s = c <= 0.0031308 ? 12.92 * c : 1.055 * std::pow(c, 1.0 / 2.4) - 0.055;
    return static_cast<std::uint8_t>(std::floor(std::clamp(s, 0.0, 1.0) * 255.0 + 0.5));
}

float decodeSrgb8(std::uint8_t srgb) noexcept {
    const double s = srgb / 255.0;
    return static_cast<float>(s <= 0.04045 ? s / 12.92 : std::pow((s + 0.055) / 1.055, 2.4));
}

std::uint32_t encodeOctahedral(const std::array<float, 3>& n) noexcept {
    double x = n[0], y = n[1], z = n[2];
    const double l1 = std::abs(x) + std::abs(y) + std::abs(z);
    if (!(l1 > 0) || !std::isfinite(l1)) return snorm12(0) | snorm12(0) << 12;  // +z
    x /= l1, y /= l1, z /= l1;
    if (z < 0) {
        // Fold the lower hemisphere over the diagonals of the octahedron's square.
        const double fx = (1 - std::abs(y)) * signNotZero(x),
                     fy = (1 - std::abs(x)) * signNotZero(y);
        x = fx, y = fy;
    }
    return snorm12(x) | snorm12(y) << 12;
}

std::array<float, 3> decodeOctahedral(std::uint32_t packed) noexcept {
    double x = unsnorm12(packed), y = unsnorm12(packed >> 12);
    const double z = 1 - std::abs(x) - std::abs(y);
    if (z < 0) {
        const double fx = (1 - std::abs(y)) * signNotZero(x),
                     fy = (1 - std::abs(x)) * signNotZero(y);
        x = fx, y = fy;
    }
    const double length = std::sqrt(x * x + y * y + z * z);  // ≥ 1/√3: |x| + |y| + |z| = 1
    return {static_cast<float>(x / length), static_cast<float>(y / length),
            static_cast<float>(z / length)};
}

AttributeRecord encodeAttributes(const VoxelAttributes& v) noexcept {
    AttributeRecord r;
    r.morton = static_cast<std::uint32_t>(morton3(v.x, v.y, v.z));
    for (int c = 0; c < 3; ++c) r.albedoCoverage[c] = encodeSrgb8(v.albedo[c]);
    r.albedoCoverage[3] = encodeUnorm8(v.coverage);
    r.normalOcclusion = encodeOctahedral(v.normal) | std::uint32_t{encodeUnorm8(v.occlusion)} << 24;
    r.emission = encodeRgb9e5(v.emission[0], v.emission[1], v.emission[2]);
    return r;
}

VoxelAttributes decodeAttributes(const AttributeRecord& r) noexcept {
    VoxelAttributes v;
    const auto [x, y, z] = demorton3(r.morton);
    v.x = x, v.y = y, v.z = z;
    for (int c = 0; c < 3; ++c) v.albedo[c] = decodeSrgb8(r.albedoCoverage[c]);
    v.coverage = decodeUnorm8(r.albedoCoverage[3]);
    v.normal = decodeOctahedral(r.normalOcclusion);
    v.occlusion = decodeUnorm8(static_cast<std::uint8_t>(r.normalOcclusion >> 24));
    v.emission = decodeRgb9e5(r.emission);
    return v;
}

namespace {

/// The planes of a dense brick: offset and bytes per texel of each (RGB9E5 planes, then A8).
struct PlaneLayout {
    std::uint32_t count = 0, rgb = 0;
    std::array<std::uint64_t, 16> offset{};
    [[nodiscard]] std::uint32_t texelBytes(std::uint32_t plane) const noexcept {
        return plane < rgb ? 4u : 1u;
    }
};

PlaneLayout planeLayout(const char* who, std::uint32_t brickTexels, std::uint32_t channels,
                        bool binaryOpacity) {
    if (channels != 1 && channels != kDirections)
        throw std::invalid_argument(std::string(who) + ": a brick has 1 or 6 channels");
    if (brickTexels < kMinBrickTexels || brickTexels > kMaxBrickTexels)
        throw std::invalid_argument(std::string(who) + ": brick size out of range");
    PlaneLayout layout;
    layout.rgb = channels;
    const std::uint32_t alpha = alphaPlanes(channels, binaryOpacity);
    layout.count = channels + alpha;
    for (std::uint32_t c = 0; c < channels; ++c) layout.offset[c] = rgbPlaneOffset(brickTexels, c);
    for (std::uint32_t p = 0; p < alpha; ++p)
        layout.offset[channels + p] = alphaPlaneOffset(brickTexels, channels, p);
    return layout;
}

}  // namespace

PackedBrick packBrick(std::span<const std::uint8_t> dense, std::uint32_t brickTexels,
                      std::uint32_t channels, bool binaryOpacity) {
    const PlaneLayout layout = planeLayout("packBrick", brickTexels, channels, binaryOpacity);
    if (dense.size() != brickBytes(brickTexels, channels, binaryOpacity))
        throw std::invalid_argument("packBrick: byte count does not match the brick size");
    const std::size_t n3 = std::size_t{brickTexels} * brickTexels * brickTexels;
    const auto nonZero = [&](std::uint32_t plane, std::size_t t) {
        const std::uint32_t size = layout.texelBytes(plane);
        const std::uint8_t* v = dense.data() + layout.offset[plane] + size * t;
        return std::any_of(v, v + size, [](std::uint8_t b) { return b != 0; });
    };
    PackedBrick out;
    std::vector<std::uint8_t> mask(brickMaskBytes(brickTexels), 0);
    for (std::size_t t = 0; t < n3; ++t)
        for (std::uint32_t p = 0; p < layout.count; ++p)
            if (nonZero(p, t)) {
                out.planes = static_cast<std::uint16_t>(out.planes | 1u << p);
                if ((mask[t / 8] & 1u << (t % 8)) == 0) ++out.texels;
                mask[t / 8] = static_cast<std::uint8_t>(mask[t / 8] | 1u << (t % 8));
            }
    if (out.texels == 0) return out;
    std::uint32_t rgbStored = 0, alphaStored = 0;
    for (std::uint32_t p = 0; p < layout.count; ++p)
        if (out.planes & 1u << p) ++(p < layout.rgb ? rgbStored : alphaStored);
    out.bytes.assign(storedBrickBytes(brickTexels, rgbStored, alphaStored, out.texels), 0);
    std::copy(mask.begin(), mask.end(), out.bytes.begin());
    std::uint8_t* at = out.bytes.data() + mask.size();
    // Planes in plane order, each the mask's texels in texel order.
    for (std::uint32_t p = 0; p < layout.count; ++p) {
        if ((out.planes & 1u << p) == 0) continue;
        const std::uint32_t size = layout.texelBytes(p);
        for (std::size_t t = 0; t < n3; ++t)
            if (mask[t / 8] & 1u << (t % 8)) {
                std::copy_n(dense.data() + layout.offset[p] + size * t, size, at);
                at += size;
            }
    }
    return out;
}

std::vector<std::uint8_t> expandBrick(std::span<const std::uint8_t> stored,
                                      std::uint32_t brickTexels, std::uint32_t channels,
                                      bool binaryOpacity, std::uint16_t planes,
                                      std::uint32_t texels) {
    const PlaneLayout layout = planeLayout("expandBrick", brickTexels, channels, binaryOpacity);
    const std::size_t n3 = std::size_t{brickTexels} * brickTexels * brickTexels;
    if ((planes >> layout.count) != 0)
        throw std::invalid_argument("expandBrick: plane bits of planes the level does not have");
    if (texels > n3) throw std::invalid_argument("expandBrick: more texels than the brick has");
    std::uint32_t rgbStored = 0, alphaStored = 0;
    for (std::uint32_t p = 0; p < layout.count; ++p)
        if (planes & 1u << p) ++(p < layout.rgb ? rgbStored : alphaStored);
    if (stored.size() != storedBrickBytes(brickTexels, rgbStored, alphaStored, texels))
        throw std::invalid_argument("expandBrick: stored size does not match the directory entry");
    const std::uint64_t maskBytes = brickMaskBytes(brickTexels);
    std::uint64_t count = 0;
    for (std::size_t i = 0; i < maskBytes; ++i) count += std::popcount(stored[i]);
    for (std::size_t t = n3; t < maskBytes * 8; ++t)
        if (stored[t / 8] & 1u << (t % 8))
            throw std::invalid_argument("expandBrick: occupancy mask bits past the brick's texels");
    if (count != texels)
        throw std::invalid_argument("expandBrick: occupancy mask does not hold the entry's texels");
    std::vector<std::uint8_t> dense(brickBytes(brickTexels, channels, binaryOpacity), 0);
    const std::uint8_t* at = stored.data() + maskBytes;
    for (std::uint32_t p = 0; p < layout.count; ++p) {
        if ((planes & 1u << p) == 0) continue;
        const std::uint32_t size = layout.texelBytes(p);
        for (std::size_t t = 0; t < n3; ++t)
            if (stored[t / 8] & 1u << (t % 8)) {
                std::copy_n(at, size, dense.data() + layout.offset[p] + size * t);
                at += size;
            }
    }
    return dense;
}

std::vector<Texel> decodeBrick(std::span<const std::uint8_t> bytes, std::uint32_t brickTexels,
                               std::uint32_t channels, bool binaryOpacity) {
    if (channels != 1 && channels != kDirections)
        throw std::invalid_argument("decodeBrick: a brick has 1 or 6 channels");
    if (brickTexels < kMinBrickTexels || brickTexels > kMaxBrickTexels ||
        bytes.size() != brickBytes(brickTexels, channels, binaryOpacity))
        throw std::invalid_argument("decodeBrick: byte count does not match the brick size");
    const std::size_t n3 = std::size_t{brickTexels} * brickTexels * brickTexels;
    std::vector<Texel> texels(channels * n3);
    if (alphaPlanes(channels, binaryOpacity) == 0) {
        // Level 0 with binary opacity: the RGB9E5 plane alone; a non-zero word is a solid cell.
        for (std::size_t i = 0; i < n3; ++i) {
            const std::uint32_t word = detail::load<std::uint32_t>(bytes.data() + 4 * i);
            const auto [r, g, b] = decodeRgb9e5(word);
            texels[i] = {r, g, b, word != 0 ? 1.0f : 0.0f};
        }
        return texels;
    }
    for (std::uint32_t c = 0; c < channels; ++c) {
        const std::uint8_t* rgb = bytes.data() + rgbPlaneOffset(brickTexels, c);
        // The ± channels of an axis share its opacity plane.
        const std::uint8_t* alpha =
            bytes.data() + alphaPlaneOffset(brickTexels, channels, alphaPlaneOf(c));
        for (std::size_t i = 0; i < n3; ++i) {
            const auto [r, g, b] = decodeRgb9e5(detail::load<std::uint32_t>(rgb + 4 * i));
            texels[c * n3 + i] = {r, g, b, decodeUnorm8(alpha[i])};
        }
    }
    return texels;
}

}  // namespace vox::rvol
