/// @file image_io.h
/// @brief Writing images: PNG through OpenImageIO (the image module, loaded on first use), and the
/// PFM float format, both atomically.
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <vector>

namespace vox {

/// Encodes 8-bit pixels (@p channels per pixel, row 0 at the top) as PNG bytes.
[[nodiscard]] std::vector<std::uint8_t> encodePng(int width, int height, int channels,
                                                  std::span<const std::uint8_t> pixels);

/// Writes 8-bit pixels as a PNG file, atomically. @throws IoError.
void writePng(const std::filesystem::path& file, int width, int height, int channels,
              std::span<const std::uint8_t> pixels);

/// Writes one float channel as a greyscale PFM ("Pf", little-endian scale −1), atomically.
/// @p values has row 0 at the top; PFM stores rows bottom to top, and this writes them so.
void writePfm(const std::filesystem::path& file, int width, int height,
              std::span<const float> values);

}  // namespace vox
