/// @file log.h
/// @brief Messages to stderr as "PROGRAM: warning: text". Thread-safe. The tools set the
/// program name and verbosity; library code only calls warning()/info()/debug().
#pragma once

#include <string>
#include <string_view>

namespace vox::log {

enum class Verbosity : int {
    Quiet = -1,   ///< errors only (-q)
    Normal = 0,   ///< errors and warnings
    Verbose = 1,  ///< plus progress notes (-v)
    Debug = 2,    ///< plus details (-vv)
};

void setProgramName(std::string name);
[[nodiscard]] const std::string& programName();
void setVerbosity(Verbosity verbosity);
[[nodiscard]] Verbosity verbosity();

void error(std::string_view message);
void warning(std::string_view message);
void info(std::string_view message);
void debug(std::string_view message);

}  // namespace vox::log
