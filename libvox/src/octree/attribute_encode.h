// Encoders of the .esvo compressed attribute block (Laine & Karras, "Efficient Sparse Voxel
// Octrees", 5.5): the colours and normals of the 16 child slots of two sibling descriptors in the
// 6-word esvo::CompressedBlock whose layout and decoders are in vox/formats/esvo_attributes.h.
// The encoders search for the block that decodes closest to the input, measured with the
// decoders' own arithmetic: squared 8-bit sRGB error for colour, angle for normals. They are
// deterministic (no randomness, no dependence on threads; the AVX-512 and SSE2 kernels and the
// scalar fallbacks compute the same values). How hard they search is an AttributeEffort: on the
// real blocks of depth-10 scenes, Default takes 12–32 thousand instructions a normal block (about
// 1.8–3.4 µs; Best 2–3 times that) for 0–1 % more mean normal error than the Default before it,
// and 2.5–12 thousand a colour block for at most 0.03 dB less colour PSNR; see
// docs/internals/esvo-writer.md.
#pragma once

#include <vox/formats/esvo_attributes.h>
#include <vox/octree.h>

#include <array>
#include <cstdint>

namespace vox::detail {

/// How hard the block encoders search. Best is the full search (the encoder before efforts
/// existed, output unchanged). Default — what writeEsvo uses — fits the normals' face-plane
/// lattice on the codes (the alternation rounds the axes to their codes at every step) from four
/// starts, none more where the first is within 0.05°; searches the codes around a quantised 3-D
/// model guided by its Gauss–Newton quadratic, measuring only the best moves it predicts; stops
/// every 3-D search once within 0.02° per normal; refines fewer 3-D candidates, lighter where
/// the face-plane fit is already within 1°; and tries one colour start pair and one descent pass
/// that steps only towards the least-squares endpoints. Fast tries two face-plane starts (none
/// more within 0.1°), fewer code-search passes and the ordered colour fit on fewer blocks.
/// Blocks of at most four distinct normal directions get the code-search 3-D quantiser at
/// every effort, and single colours and two RGB565 colours are treated alike by all three
/// (exact cases stay exact).
using vox::AttributeEffort;  // vox/octree.h

/// Encodes 16 colours (esvo::packColor words, sRGB RGB; alpha ignored) into words 0-1 of a
/// compressed block: RGB565 endpoints and 2-bit indices. Only slots whose bit is set in
/// @p usedMask (bits 0-15) matter; unused slots get index 0, and a mask of 0 gives {0, 0}.
/// Minimises the summed squared RGB error over the used slots as esvo::colorPalette decodes
/// them; one colour, or two that are RGB565 values, come out exact.
[[nodiscard]] std::array<std::uint32_t, 2> encodeColorBlock(
    const std::array<std::uint32_t, 16>& colors, std::uint32_t usedMask,
    AttributeEffort effort = AttributeEffort::Default);

/// Encodes 16 normals (any non-zero vectors; normalised first, a zero or non-finite one counts
/// as +z) into words 2-5: base normal, U indices, axes, V indices. Only used slots matter;
/// unused slots get index 0, and a mask of 0 gives a +z base with zero axes. Minimises the
/// summed 1 − cos of the angle between each used normal and its esvo::decodeBlockNormal
/// (≈ half the summed squared angle). Blocks whose normals span widely (where walls meet at an
/// edge or corner, both sides of a thin sheet) are fit as a lattice in 3-D: axis-aligned
/// edges, corners and sheets come out within hundredths of a degree, any two directions
/// within about a degree.
[[nodiscard]] std::array<std::uint32_t, 4> encodeNormalBlock(
    const std::array<esvo::Vec3, 16>& normals, std::uint32_t usedMask,
    AttributeEffort effort = AttributeEffort::Default);

/// Both: @p values hold colour word | (cube-face normal word << 32) per slot (the layout of the
/// uncompressed attachment's values).
[[nodiscard]] esvo::CompressedBlock encodeCompressedBlock(
    const std::array<std::uint64_t, 16>& values, std::uint32_t usedMask,
    AttributeEffort effort = AttributeEffort::Default);

/// Whether encodeNormalBlock's nearest-lattice-point kernels (the face-plane assignment and the
/// decoded lattice's error, most of its time) run on AVX-512 (16 lattice points a vector) or
/// SSE2 (4). Chosen once at start-up: AVX-512 wherever the CPU and OS support AVX-512F. Both
/// compute the same operations lane by lane, so the blocks are bit-identical either way (test:
/// AttributeEncode/ByEffort.Avx512KernelsGiveTheSameBlocks).
[[nodiscard]] bool encoderAvx512() noexcept;
/// Turns the AVX-512 kernels on or off for every thread (tests and benchmarks compare the two);
/// returns whether they are now on (never where unsupported). Not to be called while blocks
/// are being encoded.
bool setEncoderAvx512(bool enabled) noexcept;

/// Summed squared RGB error (8-bit units, alpha ignored) of the used slots of @p colors against
/// colour words @p word0 (endpoints) and @p word1 (indices), decoded with esvo::colorPalette.
[[nodiscard]] std::uint64_t colorBlockError(const std::array<std::uint32_t, 16>& colors,
                                            std::uint32_t usedMask, std::uint32_t word0,
                                            std::uint32_t word1) noexcept;

}  // namespace vox::detail
