// The image channels of `voxinspect render` (tools/voxinspect/esvo_commands.cpp, render() and
// libvox/src/render/shading.cpp), repeated in float arithmetic of the same order so that the
// PNGs of voxview and voxinspect compare byte for byte where the casts agree.
#include <vox/formats/error.h>
#include <vox/runtime/channels.h>

#include <algorithm>
#include <array>
#include <cmath>

namespace vox::runtime {
namespace {
struct V3 {
    float x, y, z;
};
float dot(V3 a, V3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
V3 scale(V3 a, float s) { return {a.x * s, a.y * s, a.z * s}; }
V3 minus(V3 a, V3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
V3 plus(V3 a, V3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }

const std::array<std::string, 7> kChannels{"depth", "normal", "iterations", "level",
                                           "color", "shaded", "face-normal"};

std::uint8_t toByte(float linear) {
    return static_cast<std::uint8_t>(
        std::lround(255.0f * linearToSrgb(std::clamp(linear, 0.0f, 1.0f))));
}
}  // namespace

float srgbToLinear(float v) {
    return v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f);
}
float linearToSrgb(float v) {
    return v <= 0.0031308f ? v * 12.92f : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
}

bool isChannel(const std::string& channel) {
    return std::find(kChannels.begin(), kChannels.end(), channel) != kChannels.end();
}

bool channelNeedsAttributes(const std::string& channel) {
    return channel == "color" || channel == "shaded" || channel == "normal";
}

std::vector<std::uint8_t> composeChannel(const GpuFrame& frame, const Camera& camera,
                                         const std::string& channel) {
    if (!isChannel(channel))
        throw UsageError(
            "--channel must be depth, normal, face-normal, color, shaded, iterations or level");
    const std::size_t pixels = frame.depth.size();
    std::vector<std::uint8_t> rgb(3 * pixels, 0);
    float nearest = std::numeric_limits<float>::infinity(), farthest = 0;
    std::uint32_t maxIterations = 1;
    for (std::size_t i = 0; i < pixels; ++i) {
        if (std::isfinite(frame.depth[i]))
            nearest = std::min(nearest, frame.depth[i]),
            farthest = std::max(farthest, frame.depth[i]);
        maxIterations = std::max(maxIterations, frame.iterations[i]);
    }
    const CameraBasis basis(camera);
    for (std::size_t i = 0; i < pixels; ++i) {
        std::uint8_t* p = &rgb[3 * i];
        if (channel == "iterations") {
            // Heat map: blue (few) to red (many), linear in iterations.
            const float v = float(frame.iterations[i]) / float(maxIterations);
            p[0] = static_cast<std::uint8_t>(255 * std::clamp(2 * v - 0.5f, 0.0f, 1.0f));
            p[1] = static_cast<std::uint8_t>(255 * std::clamp(1 - std::abs(2 * v - 1), 0.0f, 1.0f));
            p[2] = static_cast<std::uint8_t>(255 * std::clamp(1.5f - 2 * v, 0.0f, 1.0f));
            continue;
        }
        if (!frame.hit(i)) continue;
        const bool attributes = frame.hasAttributes(i);
        const V3 shading{frame.shadingNormal[3 * i], frame.shadingNormal[3 * i + 1],
                         frame.shadingNormal[3 * i + 2]};
        const V3 face{frame.normal[3 * i], frame.normal[3 * i + 1], frame.normal[3 * i + 2]};
        V3 albedo{0, 0, 0};
        if (attributes) {
            const std::uint32_t c = frame.color[i];
            albedo = {srgbToLinear(float(c & 0xFFu) / 255.0f),
                      srgbToLinear(float((c >> 8) & 0xFFu) / 255.0f),
                      srgbToLinear(float((c >> 16) & 0xFFu) / 255.0f)};
        }
        if (channel == "color") {
            p[0] = toByte(albedo.x), p[1] = toByte(albedo.y), p[2] = toByte(albedo.z);
        } else if (channel == "shaded") {
            // Phong under a headlight (libvox shadeHeadlight).
            const int x = static_cast<int>(i % std::size_t(frame.width)),
                      y = static_cast<int>(i / std::size_t(frame.width));
            const Vec3d d = basis.direction(x, y);
            const V3 toEye{static_cast<float>(-d[0]), static_cast<float>(-d[1]),
                           static_cast<float>(-d[2])};
            V3 n = attributes ? shading : face;
            if (dot(n, toEye) < 0)
                n = {-n.x, -n.y, -n.z};  // a sheet seen from behind shades like its front
            const float diffuse = std::max(0.0f, dot(n, toEye));
            const V3 reflected = minus(scale(n, 2 * dot(n, toEye)), toEye);
            const float specular = 0.25f * std::pow(std::max(0.0f, dot(reflected, toEye)), 32.0f);
            const V3 base = attributes ? albedo : V3{0.8f, 0.8f, 0.8f};
            const V3 lit =
                plus(scale(base, 0.1f + 0.9f * diffuse), V3{specular, specular, specular});
            p[0] = toByte(lit.x), p[1] = toByte(lit.y), p[2] = toByte(lit.z);
        } else if (channel == "depth") {
            const float v =
                farthest > nearest ? (frame.depth[i] - nearest) / (farthest - nearest) : 0.0f;
            p[0] = p[1] = p[2] = static_cast<std::uint8_t>(std::lround(255 * (1 - 0.8f * v)));
        } else if (channel == "normal" || channel == "face-normal") {
            const V3 n = channel == "normal" && attributes ? shading : face;
            p[0] = static_cast<std::uint8_t>(std::lround(127.5f * (n.x + 1)));
            p[1] = static_cast<std::uint8_t>(std::lround(127.5f * (n.y + 1)));
            p[2] = static_cast<std::uint8_t>(std::lround(127.5f * (n.z + 1)));
        } else {
            static constexpr std::array<std::array<std::uint8_t, 3>, 8> palette{{{230, 25, 75},
                                                                                 {60, 180, 75},
                                                                                 {255, 225, 25},
                                                                                 {0, 130, 200},
                                                                                 {245, 130, 48},
                                                                                 {145, 30, 180},
                                                                                 {70, 240, 240},
                                                                                 {240, 50, 230}}};
            const auto& colour = palette[frame.level[i] % palette.size()];
            std::copy(colour.begin(), colour.end(), p);
        }
    }
    return rgb;
}

}  // namespace vox::runtime
