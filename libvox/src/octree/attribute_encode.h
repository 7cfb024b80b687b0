// Encoders of the .esvo compressed attribute block (Laine & Karras, "Efficient Sparse Voxel
// Octrees", 5.5): the colours and normals of the 16 child slots of two sibling descriptors in the
// 6-word esvo::CompressedBlock whose layout and decoders are in vox/formats/esvo_attributes.h.
// The encoders search for the block that decodes closest to the input, measured with the
// decoders' own arithmetic: squared 8-bit sRGB error for colour, angle for normals. They are
// deterministic (no randomness, no dependence on threads; the SSE2 kernels and their scalar
// fallbacks compute the same values). How hard they search is an AttributeEffort: on the real
// blocks of depth-10 scenes, Default takes about 5–6 µs a block (most of it the normals; Best
// about 8, the encoder before efforts 9–10.5) for 1–2 % more mean normal error and 0.02 dB less
// colour PSNR than Best; see docs/esvo-format.md §14.
#pragma once

#include <vox/formats/esvo_attributes.h>
#include <vox/octree.h>

#include <array>
#include <cstdint>

namespace vox::detail {

/// How hard the block encoders search. Best is the full search (the encoder before efforts
/// existed, output unchanged). Default — what writeEsvo uses — quantises the normals' fits by
/// enumerating axis codes scored in constant time instead of searching code by code, runs the
/// 3-D search on fewer blocks and lighter where the face-plane fit is already within 1°, and
/// tries one colour start pair and one descent pass. Fast also tries two of the six face-plane
/// starts (none more when the first fits within 0.1°) and the ordered colour fit on fewer blocks.
/// Blocks of at most four distinct normal directions, single colours and two RGB565 colours
/// are treated alike by all three (exact cases stay exact).
using vox::AttributeEffort;  // vox/octree.h

/// Encodes 16 colours (esvo::packColor words, sRGB RGB; alpha ignored) into words 0-1 of a
/// compressed block: RGB565 endpoints and 2-bit indices. Only slots whose bit is set in
/// @p usedMask (bits 0-15) matter; unused slots get index 0, and a mask of 0 gives {0, 0}.
/// Minimises the summed squared RGB error over the used slots as esvo::colorPalette decodes
/// them; one colour, or two that are RGB565 values, come out exact.
[[nodiscard]] std::array<std::uint32_t, 2> encodeColorBlock(const std::array<std::uint32_t, 16>& colors, std::uint32_t usedMask,
                                                           AttributeEffort effort = AttributeEffort::Default);

/// Encodes 16 normals (any non-zero vectors; normalised first, a zero or non-finite one counts
/// as +z) into words 2-5: base normal, U indices, axes, V indices. Only used slots matter;
/// unused slots get index 0, and a mask of 0 gives a +z base with zero axes. Minimises the
/// summed 1 − cos of the angle between each used normal and its esvo::decodeBlockNormal
/// (≈ half the summed squared angle). Blocks whose normals span widely (where walls meet at an
/// edge or corner, both sides of a thin sheet) are fit as a lattice in 3-D: axis-aligned
/// edges, corners and sheets come out within hundredths of a degree, any two directions
/// within about a degree.
[[nodiscard]] std::array<std::uint32_t, 4> encodeNormalBlock(const std::array<esvo::Vec3, 16>& normals, std::uint32_t usedMask,
                                                            AttributeEffort effort = AttributeEffort::Default);

/// Both: @p values hold colour word | (cube-face normal word << 32) per slot (the layout of the
/// uncompressed attachment's values).
[[nodiscard]] esvo::CompressedBlock encodeCompressedBlock(const std::array<std::uint64_t, 16>& values, std::uint32_t usedMask,
                                                         AttributeEffort effort = AttributeEffort::Default);

/// Summed squared RGB error (8-bit units, alpha ignored) of the used slots of @p colors against
/// colour words @p word0 (endpoints) and @p word1 (indices), decoded with esvo::colorPalette.
[[nodiscard]] std::uint64_t colorBlockError(const std::array<std::uint32_t, 16>& colors, std::uint32_t usedMask, std::uint32_t word0,
                                            std::uint32_t word1) noexcept;

}  // namespace vox::detail
