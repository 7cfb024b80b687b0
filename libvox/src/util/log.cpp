#include <vox/util/log.h>
#include <vox/util/progress.h>

#include <atomic>
#include <cstdio>
#include <mutex>

namespace vox::log {
namespace {

std::mutex& outputMutex() {
    static std::mutex mutex;
    return mutex;
}
std::string& nameStorage() {
    static std::string name = "libvox";
    return name;
}
std::atomic<int> currentVerbosity{static_cast<int>(Verbosity::Normal)};

void write(std::string_view kind, std::string_view message) {
    std::lock_guard lock(outputMutex());
    // A progress bar may own the terminal line: clear it first; the bar redraws below.
    std::fprintf(stderr, "%s%s: %.*s%.*s\n", Progress::enabled() ? "\r\033[K" : "",
                 nameStorage().c_str(), static_cast<int>(kind.size()), kind.data(),
                 static_cast<int>(message.size()), message.data());
    std::fflush(stderr);
}

}  // namespace

void setProgramName(std::string name) {
    std::lock_guard lock(outputMutex());
    nameStorage() = std::move(name);
}
const std::string& programName() { return nameStorage(); }
void setVerbosity(Verbosity verbosity) { currentVerbosity = static_cast<int>(verbosity); }
Verbosity verbosity() { return static_cast<Verbosity>(currentVerbosity.load()); }

void error(std::string_view message) { write("error: ", message); }
void warning(std::string_view message) {
    if (currentVerbosity >= static_cast<int>(Verbosity::Normal)) write("warning: ", message);
}
void info(std::string_view message) {
    if (currentVerbosity >= static_cast<int>(Verbosity::Verbose)) write("", message);
}
void debug(std::string_view message) {
    if (currentVerbosity >= static_cast<int>(Verbosity::Debug)) write("debug: ", message);
}

}  // namespace vox::log
