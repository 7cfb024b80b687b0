/// @file esvo_attributes.h
/// @brief Bit layouts of the .esvo shading attributes (docs/esvo-format.md, "Attributes"):
/// the 32-bit colour, the 32-bit cube-face normal, the uncompressed ("palette") lookup entry and
/// the 6-word compressed ("DXT") block that holds colours and normals of 16 child slots.
/// Decoders are here, beside the layout, so the runtime needs nothing else; the encoders that
/// search for good blocks are build-side (libvox).
#pragma once

#include <vox/base/math.h>

#include <array>
#include <cstdint>

namespace vox::esvo {

/// A normal or axis vector in object space.
using Vec3 = Vec3f;

// ---- colour: 8 bits per channel, R in the low byte, A in the high byte (ABGR) ---------------

/// RGB channels hold sRGB-encoded values (so 8 bits are spent where the eye needs them); alpha
/// is linear coverage.
[[nodiscard]] constexpr std::uint32_t packColor(std::uint32_t r, std::uint32_t g, std::uint32_t b,
                                                std::uint32_t a = 255) noexcept {
    return (r & 0xFFu) | ((g & 0xFFu) << 8) | ((b & 0xFFu) << 16) | ((a & 0xFFu) << 24);
}
[[nodiscard]] constexpr std::uint32_t colorChannel(std::uint32_t color, unsigned channel) noexcept {
    return (color >> (8 * channel)) & 0xFFu;
}

// ---- cube-face normal: 32 bits ----------------------------------------------------------------
// bit 31 sign of the dominant component (1: negative); bits 29-30 dominant axis (0 x, 1 y, 2 z);
// bits 14-28 u, 15-bit signed, component (axis+1)%3 over the dominant one, in units of 2^-14;
// bits 0-13 v, 14-bit signed, component (axis+2)%3 over the dominant one, in units of 2^-13.

/// Encodes @p n (any non-zero vector; the zero vector encodes as +z) to the nearest cube-face
/// point. Exact for the face's own axis; the angular error is below 2^-13 radians.
[[nodiscard]] std::uint32_t encodeNormal(const Vec3& n) noexcept;
/// Decodes to the point on the cube [−1, 1]³ (±1 on the dominant axis); not unit length.
[[nodiscard]] Vec3 decodeNormal(std::uint32_t encoded) noexcept;
/// decodeNormal, normalised.
[[nodiscard]] Vec3 decodeUnitNormal(std::uint32_t encoded) noexcept;

// ---- uncompressed attachment lookup entry -----------------------------------------------------

/// One per 64-bit unit of the block's descriptor area: bits 0-7 mask of the slots that store a
/// value (a clear bit inherits the parent voxel's value), bits 8-31 word offset of the first of
/// those values from the attachment's start.
struct PaletteLookup {
    std::uint32_t word = 0;
    [[nodiscard]] constexpr std::uint32_t mask() const noexcept { return word & 0xFFu; }
    [[nodiscard]] constexpr std::uint32_t valuePointer() const noexcept { return word >> 8; }
    [[nodiscard]] static constexpr PaletteLookup make(std::uint32_t mask,
                                                      std::uint32_t pointer) noexcept {
        return {(pointer << 8) | (mask & 0xFFu)};
    }
    static constexpr std::uint32_t kMaxPointer = 0xFFFFFFu;
};

// ---- compressed block: 6 words of 16 values -----------------------------------------------
// In a Dxt attachment, one block per pair of descriptor units (16 child slots); in a DxtLookup
// attachment, one block per 16 consecutive stored values (value k: slot k % 16 of block k / 16).
// word 0: colour endpoints c0 (bits 0-15) and c1 (bits 16-31), RGB565 (R in bits 11-15)
// word 1: 2-bit colour index per slot, slot s in bits 2s..2s+1
// word 2: base normal, cube-face encoding
// word 3: 2-bit U index per slot
// word 4: axis u in bits 0-15, axis v in bits 16-31 (see encodeAxis)
// word 5: 2-bit V index per slot
// Slot s of the block covering units 2p and 2p+1 is child slot (s & 7) of the descriptor in
// unit 2p + (s >> 3).

inline constexpr std::uint32_t kCompressedBlockWords = 6;
using CompressedBlock = std::array<std::uint32_t, kCompressedBlockWords>;

/// RGB565 with R in the high bits, as DXT1.
[[nodiscard]] constexpr std::uint32_t packRgb565(std::uint32_t r8, std::uint32_t g8,
                                                 std::uint32_t b8) noexcept {
    return ((r8 >> 3) << 11) | ((g8 >> 2) << 5) | (b8 >> 3);
}
/// Expands an RGB565 endpoint to 8 bits per channel by bit replication; returns packColor(r, g, b).
[[nodiscard]] constexpr std::uint32_t expandRgb565(std::uint32_t c) noexcept {
    const std::uint32_t r = (c >> 11) & 31u, g = (c >> 5) & 63u, b = c & 31u;
    return packColor((r << 3) | (r >> 2), (g << 2) | (g >> 4), (b << 3) | (b >> 2));
}
/// The four palette colours of endpoints @p c0, @p c1 (RGB565): {c0, c1, ⅔c0+⅓c1, ⅓c0+⅔c1},
/// each channel (2a + b + 1) / 3 in integers on the expanded 8-bit values.
[[nodiscard]] std::array<std::uint32_t, 4> colorPalette(std::uint32_t c0,
                                                        std::uint32_t c1) noexcept;

/// The palette weights of the 2-bit axis indices: {−1, −⅓, ⅓, 1}.
inline constexpr std::array<float, 4> kAxisWeights{-1.0f, -1.0f / 3.0f, 1.0f / 3.0f, 1.0f};

/// An axis vector: three 4-bit signed components (x bits 0-3, y 4-7, z 8-11) and a 4-bit
/// exponent e (bits 12-15); component value = c · 2^(e − 13).
[[nodiscard]] Vec3 decodeAxis(std::uint32_t bits16) noexcept;
/// Nearest encoding of @p axis with the smallest exponent that holds its largest component.
[[nodiscard]] std::uint32_t encodeAxis(const Vec3& axis) noexcept;

/// The 2-bit index of @p slot in an index word.
[[nodiscard]] constexpr std::uint32_t blockIndex(std::uint32_t word, unsigned slot) noexcept {
    return (word >> (2 * slot)) & 3u;
}

/// Words in a DxtLookup attachment before its first block: the lookup array (one word per
/// descriptor-area unit), padded to a whole unit.
[[nodiscard]] constexpr std::uint32_t lookupArrayWords(std::uint32_t descriptorUnits) noexcept {
    return descriptorUnits + (descriptorUnits & 1u);
}

/// Colour of @p slot (0-15) of a compressed block: packColor(r, g, b, 255).
[[nodiscard]] std::uint32_t decodeBlockColor(const std::uint32_t* block, unsigned slot) noexcept;
/// Unit normal of @p slot (0-15): normalise(base + cu·u + cv·v).
[[nodiscard]] Vec3 decodeBlockNormal(const std::uint32_t* block, unsigned slot) noexcept;

// ---- reading a voxel's value from loaded blocks ------------------------------------------------

/// A voxel's shading attributes as decoded.
struct AttributeValue {
    std::uint32_t color = 0;  ///< packColor word (compressed blocks decode with alpha 255)
    Vec3 normal{0, 0, 1};     ///< unit
};

/// The value that child @p slot of the descriptor at word @p descriptorWord of @p words stores,
/// found through the descriptor's page header, info section and attachment directory (the block
/// must be one that validateBlock accepts, 8 KB aligned in @p words). Returns false where it
/// stores none: the voxel then inherits its parent voxel's value (or the block has no colours).
bool readAttribute(const std::uint32_t* words, std::uint32_t descriptorWord, std::uint32_t slot,
                   AttributeValue& out) noexcept;

}  // namespace vox::esvo
