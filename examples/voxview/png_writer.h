// A minimal PNG writer for voxview: 8-bit RGB, zlib "stored" (uncompressed) deflate blocks.
// The runtime must not link OpenImageIO (libvox's image_io), and no other image library is a
// dependency; an uncompressed PNG is valid, lossless and a few dozen lines.
#pragma once

#include <cstdint>
#include <filesystem>
#include <vector>

namespace voxview {

/// Writes @p rgb (width × height × 3 bytes, row 0 at the top) to @p file atomically.
/// @throws vox::IoError.
void writePngRgb8(const std::filesystem::path& file, int width, int height,
                  const std::vector<std::uint8_t>& rgb);

}  // namespace voxview
