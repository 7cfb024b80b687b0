#include "image_module.h"

#include <vox/formats/atomic_file.h>
#include <vox/base/error.h>
#include <vox/image_io.h>

#include <stdexcept>
#include <string>

namespace vox {

std::vector<std::uint8_t> encodePng(int width, int height, int channels,
                                    std::span<const std::uint8_t> pixels) {
    if (pixels.size() != std::size_t(width) * std::size_t(height) * std::size_t(channels))
        throw std::invalid_argument("encodePng: pixel count does not match the size");
    std::vector<std::uint8_t> png;
    std::string error;
    if (!detail::imageModule().encodePng(width, height, channels, pixels, png, error))
        throw std::runtime_error("cannot encode PNG: " + error);
    return png;
}

void writePng(const std::filesystem::path& file, int width, int height, int channels,
              std::span<const std::uint8_t> pixels) {
    const std::vector<std::uint8_t> png = encodePng(width, height, channels, pixels);
    AtomicFile out(file);
    out.write(png.data(), png.size());
    out.commit();
}

void writePfm(const std::filesystem::path& file, int width, int height,
              std::span<const float> values) {
    if (values.size() != std::size_t(width) * std::size_t(height))
        throw std::invalid_argument("writePfm: value count does not match the size");
    AtomicFile out(file);
    out.write("Pf\n" + std::to_string(width) + " " + std::to_string(height) + "\n-1.0\n");
    for (int y = height; y-- > 0;)
        out.write(values.data() + std::size_t(y) * std::size_t(width),
                  sizeof(float) * std::size_t(width));
    out.commit();
}

}  // namespace vox
