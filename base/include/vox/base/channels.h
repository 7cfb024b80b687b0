/// @file channels.h
/// @brief The image channels of an octree rendering (`voxinspect render --channel`, voxview):
/// how a cast's per-pixel results become 8-bit RGB, shared by the CPU and GPU paths so that their
/// images compare byte for byte.
#pragma once

#include <vox/base/color.h>
#include <vox/base/math.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <string_view>
#include <vector>

namespace vox {

enum class Channel { Depth, Normal, FaceNormal, Color, Shaded, Iterations, Level };

/// The channel called @p name, or none for an unknown name.
[[nodiscard]] std::optional<Channel> channelNamed(std::string_view name);
/// The channel called @p name (depth, normal, face-normal, color, shaded, iterations, level).
/// @throws vox::ParameterError naming `channel` for any other name.
[[nodiscard]] Channel parseChannel(std::string_view name);
/// Whether @p channel shows decoded attributes (colour or shading normal): color, shaded, normal.
[[nodiscard]] bool channelNeedsAttributes(Channel channel);
/// Whether the channel's pixels are the linear colours the caller supplies (color, shaded).
[[nodiscard]] inline bool isColorChannel(Channel c) {
    return c == Channel::Color || c == Channel::Shaded;
}

/// The level channel's colour for voxels of @p level (a palette of 8, repeating).
[[nodiscard]] std::array<std::uint8_t, 3> levelColour(std::uint32_t level);

/// RGB8 of @p channel, row 0 at the top, over @p pixels pixels that @p frame describes:
///  - `frame.hit(i)`, `frame.depth(i)` (finite where hit), `frame.iterations(i)`,
///    `frame.level(i)`, `frame.faceNormal(i)`, `frame.shadingNormal(i)` and
///    `frame.hasAttributes(i)` (whether the voxel hit has a shading normal);
///  - `frame.linear(i)`: linear RGB of a color or shaded pixel (albedo, or shadeHeadlight()),
///    called for hit pixels of those channels only.
/// color/shaded: sRGB-encoded linear; normal: the shading normal (the face's where the voxel has
/// none) as 127.5·(n + 1); face-normal: the face's; depth: grey from near (255) to far (51);
/// iterations: blue–green–red heat map over all pixels; level: levelColour(). Misses are black.
template <typename Frame>
[[nodiscard]] std::vector<std::uint8_t> composeChannel(Channel channel, std::size_t pixels,
                                                       const Frame& frame) {
    std::vector<std::uint8_t> rgb(3 * pixels, 0);
    float nearest = std::numeric_limits<float>::infinity(), farthest = 0;
    std::uint32_t maxIterations = 1;
    for (std::size_t i = 0; i < pixels; ++i) {
        if (frame.hit(i))
            nearest = std::min(nearest, frame.depth(i)),
            farthest = std::max(farthest, frame.depth(i));
        maxIterations = std::max(maxIterations, frame.iterations(i));
    }
    for (std::size_t i = 0; i < pixels; ++i) {
        std::uint8_t* p = &rgb[3 * i];
        if (channel == Channel::Iterations) {
            // Heat map: blue (few) to red (many), linear in iterations.
            const float v = float(frame.iterations(i)) / float(maxIterations);
            p[0] = static_cast<std::uint8_t>(255 * std::clamp(2 * v - 0.5f, 0.0f, 1.0f));
            p[1] = static_cast<std::uint8_t>(255 * std::clamp(1 - std::abs(2 * v - 1), 0.0f, 1.0f));
            p[2] = static_cast<std::uint8_t>(255 * std::clamp(1.5f - 2 * v, 0.0f, 1.0f));
            continue;
        }
        if (!frame.hit(i)) continue;
        if (isColorChannel(channel)) {
            const Vec3f linear = frame.linear(i);
            for (int k = 0; k < 3; ++k)
                p[k] = static_cast<std::uint8_t>(
                    std::lround(255.0f * linearToSrgb(std::clamp(linear[k], 0.0f, 1.0f))));
        } else if (channel == Channel::Depth) {
            const float v =
                farthest > nearest ? (frame.depth(i) - nearest) / (farthest - nearest) : 0.0f;
            p[0] = p[1] = p[2] = static_cast<std::uint8_t>(std::lround(255 * (1 - 0.8f * v)));
        } else if (channel == Channel::Normal || channel == Channel::FaceNormal) {
            const Vec3f n = channel == Channel::Normal && frame.hasAttributes(i)
                                ? frame.shadingNormal(i)
                                : frame.faceNormal(i);
            p[0] = static_cast<std::uint8_t>(std::lround(127.5f * (n.x + 1)));
            p[1] = static_cast<std::uint8_t>(std::lround(127.5f * (n.y + 1)));
            p[2] = static_cast<std::uint8_t>(std::lround(127.5f * (n.z + 1)));
        } else {
            const auto colour = levelColour(frame.level(i));
            std::copy(colour.begin(), colour.end(), p);
        }
    }
    return rgb;
}

}  // namespace vox
