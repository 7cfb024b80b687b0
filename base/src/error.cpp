#include <vox/formats/error.h>

#include <cstring>

namespace vox {

std::string errnoMessage(int errnum) {
    char buffer[256];
    // GNU strerror_r may return a static string instead of filling the buffer.
    const char* text = strerror_r(errnum, buffer, sizeof buffer);
    return text ? std::string(text) : std::string("error ") + std::to_string(errnum);
}

}  // namespace vox
