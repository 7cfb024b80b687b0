// Image decoding through OpenImageIO (in the image module, loaded on first use: image_module.h),
// from files or from memory (GLB buffer views, data URIs).
#include "image_module.h"

#include <vox/base/error.h>
#include <vox/texture.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <fstream>

namespace vox {
namespace {

/// A file name whose extension makes OpenImageIO pick the right decoder for in-memory data.
std::string decoderHintName(std::span<const std::uint8_t> bytes, const std::string& mimeType) {
    auto startsWith = [&](std::initializer_list<std::uint8_t> magic) {
        return bytes.size() >= magic.size() &&
               std::equal(magic.begin(), magic.end(), bytes.begin());
    };
    if (startsWith({0x89, 'P', 'N', 'G'})) return "image.png";
    if (startsWith({0xFF, 0xD8, 0xFF})) return "image.jpg";
    if (startsWith({'B', 'M'})) return "image.bmp";
    if (startsWith({'G', 'I', 'F', '8'})) return "image.gif";
    if (startsWith({0x76, 0x2F, 0x31, 0x01})) return "image.exr";
    if (startsWith({'R', 'I', 'F', 'F'})) return "image.webp";
    if (mimeType == "image/png") return "image.png";
    if (mimeType == "image/jpeg") return "image.jpg";
    return "image.png";
}

/// @p file: where errors point; @p what: the image within it ("" when the file is the image).
Texture decodeOpened(detail::ImageReader& input, const std::filesystem::path& file,
                     const std::string& what, ColorSpace colorSpace) {
    const std::string prefix = what.empty() ? std::string() : what + ": ";
    const int width = input.width(), height = input.height();
    if (width < 1 || height < 1 || input.depth() != 1 || input.channels() < 1)
        throw InvalidDataError(file, prefix + "image has no pixels or is a volume");
    if (width > Texture::kMaxDimension || height > Texture::kMaxDimension)
        throw InvalidDataError(file, prefix + "image is " + std::to_string(width) + "x" +
                                         std::to_string(height) + ", larger than the supported " +
                                         std::to_string(Texture::kMaxDimension) + " per side");
    const int channels = std::min(input.channels(), 4);
    const std::size_t rowValues = static_cast<std::size_t>(width) * channels;
    std::vector<std::uint8_t> pixels(rowValues * height);
    if (!input.floatingPoint()) {
        // Integer formats hold encoded values (sRGB for colour textures): 8 bits directly.
        if (!input.readUint8(channels, pixels.data()))
            throw InvalidDataError(file, prefix + "cannot decode image: " + input.error());
    } else {
        // Floating-point formats hold linear values: encode them to the texture's colour space,
        // a band of rows at a time so a large HDR image never exists as floats all at once.
        constexpr int kBand = 64;
        std::vector<float> band(rowValues * kBand);
        for (int y0 = 0; y0 < height; y0 += kBand) {
            const int y1 = std::min(height, y0 + kBand);
            if (!input.readFloatRows(y0, y1, channels, band.data()))
                throw InvalidDataError(file, prefix + "cannot decode image: " + input.error());
            for (std::size_t i = 0; i < rowValues * static_cast<std::size_t>(y1 - y0); ++i) {
                float v = std::isfinite(band[i]) ? std::clamp(band[i], 0.0f, 1.0f) : 0.0f;
                const std::size_t channel = i % static_cast<std::size_t>(channels);
                const bool isAlpha =
                    (channels == 2 && channel == 1) || (channels == 4 && channel == 3);
                if (colorSpace == ColorSpace::SRGB && !isAlpha) v = linearToSrgb(v);
                pixels[rowValues * static_cast<std::size_t>(y0) + i] =
                    static_cast<std::uint8_t>(std::lround(v * 255.0f));
            }
        }
    }
    return Texture(what.empty() ? file.filename().string() : what, width, height, channels, pixels,
                   colorSpace);
}

}  // namespace

Texture loadTexture(const std::filesystem::path& file, ColorSpace colorSpace) {
    {
        std::ifstream probe(file, std::ios::binary);
        if (!probe) throw IoError(file, "cannot open image: " + errnoMessage(errno));
    }
    std::string error;
    const auto input = detail::imageModule().openFile(file, error);
    if (!input) throw InvalidDataError(file, "cannot decode image: " + error);
    return decodeOpened(*input, file, "", colorSpace);
}

Texture decodeTexture(std::span<const std::uint8_t> encoded, const std::filesystem::path& container,
                      const std::string& what, const std::string& mimeType, ColorSpace colorSpace) {
    std::string error;
    const auto input =
        detail::imageModule().openMemory(encoded, decoderHintName(encoded, mimeType), error);
    if (!input) throw InvalidDataError(container, what + ": cannot decode image: " + error);
    return decodeOpened(*input, container, what, colorSpace);
}

}  // namespace vox
