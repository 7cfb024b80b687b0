// Image decoding through OpenImageIO, from files or from memory (GLB buffer views, data URIs).
#include <vox/formats/error.h>
#include <vox/texture.h>

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <cerrno>
#include <fstream>

namespace vox {
namespace {

/// A file name whose extension makes OpenImageIO pick the right decoder for in-memory data.
std::string decoderHintName(std::span<const std::uint8_t> bytes, const std::string& mimeType) {
    auto startsWith = [&](std::initializer_list<std::uint8_t> magic) {
        return bytes.size() >= magic.size() && std::equal(magic.begin(), magic.end(), bytes.begin());
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
Texture decodeOpened(OIIO::ImageInput& input, const std::filesystem::path& file, const std::string& what,
                     ColorSpace colorSpace) {
    const std::string prefix = what.empty() ? std::string() : what + ": ";
    const OIIO::ImageSpec& spec = input.spec();
    if (spec.width < 1 || spec.height < 1 || spec.depth != 1 || spec.nchannels < 1)
        throw InvalidDataError(file, prefix + "image has no pixels or is a volume");
    if (spec.width > Texture::kMaxDimension || spec.height > Texture::kMaxDimension)
        throw InvalidDataError(file, prefix + "image is " + std::to_string(spec.width) + "x" +
                                              std::to_string(spec.height) + ", larger than the supported " +
                                              std::to_string(Texture::kMaxDimension) + " per side");
    const int channels = std::min(spec.nchannels, 4);
    const std::size_t rowValues = static_cast<std::size_t>(spec.width) * channels;
    std::vector<std::uint8_t> pixels(rowValues * spec.height);
    if (!spec.format.is_floating_point()) {
        // Integer formats hold encoded values (sRGB for colour textures): 8 bits directly.
        if (!input.read_image(0, 0, 0, channels, OIIO::TypeDesc::UINT8, pixels.data()))
            throw InvalidDataError(file, prefix + "cannot decode image: " + input.geterror());
    } else {
        // Floating-point formats hold linear values: encode them to the texture's colour space,
        // a band of rows at a time so a large HDR image never exists as floats all at once.
        constexpr int kBand = 64;
        std::vector<float> band(rowValues * kBand);
        for (int y0 = 0; y0 < spec.height; y0 += kBand) {
            const int y1 = std::min(spec.height, y0 + kBand);
            if (!input.read_scanlines(0, 0, y0, y1, 0, 0, channels, OIIO::TypeDesc::FLOAT, band.data()))
                throw InvalidDataError(file, prefix + "cannot decode image: " + input.geterror());
            for (std::size_t i = 0; i < rowValues * static_cast<std::size_t>(y1 - y0); ++i) {
                float v = std::isfinite(band[i]) ? std::clamp(band[i], 0.0f, 1.0f) : 0.0f;
                const std::size_t channel = i % static_cast<std::size_t>(channels);
                const bool isAlpha = (channels == 2 && channel == 1) || (channels == 4 && channel == 3);
                if (colorSpace == ColorSpace::SRGB && !isAlpha) v = linearToSrgb(v);
                pixels[rowValues * static_cast<std::size_t>(y0) + i] = static_cast<std::uint8_t>(std::lround(v * 255.0f));
            }
        }
    }
    return Texture(what.empty() ? file.filename().string() : what, spec.width, spec.height, channels, pixels, colorSpace);
}

}  // namespace

Texture loadTexture(const std::filesystem::path& file, ColorSpace colorSpace) {
    {
        std::ifstream probe(file, std::ios::binary);
        if (!probe) throw IoError(file, "cannot open image: " + errnoMessage(errno));
    }
    auto input = OIIO::ImageInput::open(file.string());
    if (!input) throw InvalidDataError(file, "cannot decode image: " + OIIO::geterror());
    return decodeOpened(*input, file, "", colorSpace);
}

Texture decodeTexture(std::span<const std::uint8_t> encoded, const std::filesystem::path& container,
                      const std::string& what, const std::string& mimeType, ColorSpace colorSpace) {
    OIIO::Filesystem::IOMemReader reader(encoded.data(), encoded.size());
    auto input = OIIO::ImageInput::open(decoderHintName(encoded, mimeType), nullptr, &reader);
    if (!input) throw InvalidDataError(container, what + ": cannot decode image: " + OIIO::geterror());
    return decodeOpened(*input, container, what, colorSpace);
}

}  // namespace vox
