/// @file timings.h
/// @brief Per-stage wall-clock timings and peak memory, for --stats reports.
#pragma once

#include <chrono>
#include <cstdint>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

namespace vox {

/// Stage name → milliseconds, in first-seen order; repeated stages accumulate. Thread-safe.
class Timings {
public:
    void add(const std::string& stage, double milliseconds);
    [[nodiscard]] std::vector<std::pair<std::string, double>> entries() const;
    [[nodiscard]] double get(const std::string& stage) const;  ///< 0 if never recorded

    /// Times the enclosing scope into @p timings (which may be null: then it does nothing).
    class Scope {
    public:
        Scope(Timings* timings, std::string stage);
        ~Scope();
        Scope(const Scope&) = delete;
        Scope& operator=(const Scope&) = delete;

    private:
        Timings* timings_;
        std::string stage_;
        std::chrono::steady_clock::time_point start_;
    };

private:
    mutable std::mutex mutex_;
    std::vector<std::pair<std::string, double>> entries_;
};

/// Largest resident set size the process has had so far, in bytes.
[[nodiscard]] std::uint64_t peakRssBytes();
/// The process's resident set size now, in bytes (0 where /proc is not there).
[[nodiscard]] std::uint64_t currentRssBytes();

}  // namespace vox
