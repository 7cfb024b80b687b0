#include <vox/base/channels.h>
#include <vox/base/error.h>

#include <string>

namespace vox {
namespace {
constexpr std::array<std::pair<std::string_view, Channel>, 7> kChannels{{
    {"depth", Channel::Depth},
    {"normal", Channel::Normal},
    {"face-normal", Channel::FaceNormal},
    {"color", Channel::Color},
    {"shaded", Channel::Shaded},
    {"iterations", Channel::Iterations},
    {"level", Channel::Level},
}};
}  // namespace

std::optional<Channel> channelNamed(std::string_view name) {
    for (const auto& [text, channel] : kChannels)
        if (text == name) return channel;
    return std::nullopt;
}

Channel parseChannel(std::string_view name) {
    if (const auto channel = channelNamed(name)) return *channel;
    throw ParameterError("channel",
                         "must be depth, normal, face-normal, color, shaded, iterations or level");
}

bool channelNeedsAttributes(Channel c) {
    return c == Channel::Color || c == Channel::Shaded || c == Channel::Normal;
}

std::array<std::uint8_t, 3> levelColour(std::uint32_t level) {
    static constexpr std::array<std::array<std::uint8_t, 3>, 8> palette{{{230, 25, 75},
                                                                         {60, 180, 75},
                                                                         {255, 225, 25},
                                                                         {0, 130, 200},
                                                                         {245, 130, 48},
                                                                         {145, 30, 180},
                                                                         {70, 240, 240},
                                                                         {240, 50, 230}}};
    return palette[level % palette.size()];
}

}  // namespace vox
