#include <vox/runtime/channels.h>

namespace vox::runtime {
namespace {

/// GpuFrame's per-pixel arrays as vox::composeChannel reads them.
struct FramePixels {
    const GpuFrame& frame;
    CameraBasis basis;
    Channel channel;

    [[nodiscard]] bool hit(std::size_t i) const { return frame.hit(i); }
    [[nodiscard]] float depth(std::size_t i) const { return frame.depth[i]; }
    [[nodiscard]] std::uint32_t iterations(std::size_t i) const { return frame.iterations[i]; }
    [[nodiscard]] std::uint32_t level(std::size_t i) const { return frame.level[i]; }
    [[nodiscard]] bool hasAttributes(std::size_t i) const { return frame.hasAttributes(i); }
    [[nodiscard]] Vec3f faceNormal(std::size_t i) const {
        return {frame.normal[3 * i], frame.normal[3 * i + 1], frame.normal[3 * i + 2]};
    }
    [[nodiscard]] Vec3f shadingNormal(std::size_t i) const {
        return {frame.shadingNormal[3 * i], frame.shadingNormal[3 * i + 1],
                frame.shadingNormal[3 * i + 2]};
    }
    [[nodiscard]] Vec3f albedo(std::size_t i) const {
        const std::uint32_t c = frame.color[i];
        return {srgbToLinear(float(c & 0xFFu) / 255.0f),
                srgbToLinear(float((c >> 8) & 0xFFu) / 255.0f),
                srgbToLinear(float((c >> 16) & 0xFFu) / 255.0f)};
    }
    [[nodiscard]] Vec3f linear(std::size_t i) const {
        const bool attributes = hasAttributes(i);
        const Vec3f colour = attributes ? albedo(i) : Vec3f{0, 0, 0};
        if (channel == Channel::Color) return colour;
        const int x = static_cast<int>(i % std::size_t(frame.width)),
                  y = static_cast<int>(i / std::size_t(frame.width));
        const Vec3f toEye = -vec3Cast<float>(basis.direction(x, y));
        return attributes ? shadeHeadlight(shadingNormal(i), toEye, colour)
                          : shadeHeadlight(faceNormal(i), toEye, Vec3f{0.8f, 0.8f, 0.8f});
    }
};

}  // namespace

std::vector<std::uint8_t> composeChannel(const GpuFrame& frame, const PinholeCamera& camera,
                                         Channel channel) {
    return vox::composeChannel(channel, frame.depth.size(),
                               FramePixels{frame, CameraBasis(camera), channel});
}

}  // namespace vox::runtime
