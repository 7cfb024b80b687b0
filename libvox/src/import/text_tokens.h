// Whitespace-separated tokens and numbers of the text formats libvox reads itself (OBJ, ASCII STL).
#pragma once

#include <cctype>
#include <charconv>
#include <string_view>

namespace vox::detail {

[[nodiscard]] inline std::string_view trim(std::string_view s) {
    while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
    while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
    return s;
}

/// Next whitespace-separated token of @p s, consumed from it (callers may call it to skip one).
inline std::string_view nextToken(std::string_view& s) {
    s = trim(s);
    std::size_t end = 0;
    while (end < s.size() && !std::isspace(static_cast<unsigned char>(s[end]))) ++end;
    std::string_view token = s.substr(0, end);
    s.remove_prefix(end);
    return token;
}

/// The whole of @p token as a float ("nan" and "inf" included: callers check finiteness).
[[nodiscard]] inline bool parseFloat(std::string_view token, float& value) {
    if (!token.empty() && token.front() == '+') token.remove_prefix(1);
    const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
    return ec == std::errc() && end == token.data() + token.size();
}

[[nodiscard]] inline bool parseInt(std::string_view token, long long& value) {
    if (!token.empty() && token.front() == '+') token.remove_prefix(1);
    const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
    return ec == std::errc() && end == token.data() + token.size();
}

}  // namespace vox::detail
