/// @file progress.h
/// @brief A progress bar on stderr for long steps. It draws only when enabled (the tools enable
/// it when stderr is a terminal and -q was not given), so logs and pipes stay clean.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <mutex>
#include <string>

namespace vox {

class Progress {
public:
    /// Starts a bar labelled @p label that completes at @p total units.
    Progress(std::string label, std::uint64_t total);
    ~Progress();
    Progress(const Progress&) = delete;
    Progress& operator=(const Progress&) = delete;

    /// Adds @p units of completed work; callable from any thread.
    void advance(std::uint64_t units = 1);

    static void setEnabled(bool enabled);
    [[nodiscard]] static bool enabled();

private:
    void draw(bool final);

    std::string label_;
    std::uint64_t total_;
    std::atomic<std::uint64_t> done_{0};
    std::atomic<std::int64_t> nextDrawNs_{0};
    std::chrono::steady_clock::time_point start_;
    std::mutex drawMutex_;
    bool drawn_ = false;
};

}  // namespace vox
