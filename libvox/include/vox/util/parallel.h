/// @file parallel.h
/// @brief Thread-count control for libvox's TBB parallelism.
#pragma once

#include <memory>

namespace vox {

/// Limits every parallel loop in the process to a number of threads while it lives.
class ThreadLimit {
public:
    /// @p threads: 1 or more; 0 means all available cores.
    explicit ThreadLimit(int threads);
    ~ThreadLimit();
    ThreadLimit(const ThreadLimit&) = delete;
    ThreadLimit& operator=(const ThreadLimit&) = delete;

    /// Threads parallel loops may use now.
    [[nodiscard]] static int active();
    /// Cores available to the process.
    [[nodiscard]] static int hardwareThreads();

private:
    struct Control;
    std::unique_ptr<Control> control_;
};

}  // namespace vox
