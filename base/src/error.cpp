#include <vox/base/error.h>

#include <array>
#include <cctype>
#include <cstring>
#include <utility>

namespace vox {

std::string errnoMessage(int errnum) {
    char buffer[256];
    // GNU strerror_r may return a static string instead of filling the buffer.
    const char* text = strerror_r(errnum, buffer, sizeof buffer);
    return text ? std::string(text) : std::string("error ") + std::to_string(errnum);
}

std::string ParameterError::commandLineMessage() const {
    static constexpr std::array<std::pair<std::string_view, std::string_view>, 4> kIrregular{{
        {"fovYDegrees", "--fov"},
        {"size", "--width/--height"},
        {"specularApertureDegrees", "--spec-aperture"},
        {"shadowApertureDegrees", "--shadow-aperture"},
    }};
    std::string flag;
    for (const auto& [name, spelled] : kIrregular)
        if (name == parameter_) flag = spelled;
    if (flag.empty()) {
        flag = "--";
        for (const char c : parameter_) {
            if (std::isupper(static_cast<unsigned char>(c))) {
                flag += '-';
                flag += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
            } else {
                flag += c;
            }
        }
    }
    return flag + " " + problem_;
}

}  // namespace vox
