// Helpers shared by libvox's tests: per-test scratch directories, small file writers, and
// running the tools as real processes.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

namespace vox::test {

/// A fresh, empty directory for the running test (removed when the fixture ends).
class ScratchDir {
public:
    ScratchDir();
    ~ScratchDir();
    ScratchDir(const ScratchDir&) = delete;
    ScratchDir& operator=(const ScratchDir&) = delete;
    [[nodiscard]] const std::filesystem::path& path() const { return path_; }
    [[nodiscard]] std::filesystem::path operator/(const std::string& name) const {
        return path_ / name;
    }
    /// Names of the files in the directory, sorted.
    [[nodiscard]] std::vector<std::string> files() const;

private:
    std::filesystem::path path_;
};

void writeText(const std::filesystem::path& file, const std::string& text);
void writeBinary(const std::filesystem::path& file, const std::vector<std::uint8_t>& bytes);
[[nodiscard]] std::string readText(const std::filesystem::path& file);

/// Result of running a program.
struct ProcessResult {
    int exitCode = -1;  ///< exit status, or 128 + signal number
    std::string out;    ///< stdout
    std::string err;    ///< stderr
    /// stderr split into lines (without the newline).
    [[nodiscard]] std::vector<std::string> errLines() const;
};

/// Runs @p program with @p args (no shell), waiting at most @p timeoutSeconds.
ProcessResult runProcess(const std::filesystem::path& program, const std::vector<std::string>& args,
                         int timeoutSeconds = 120);

/// Paths of the tools and data, set by CMake.
[[nodiscard]] std::filesystem::path voxelizePath();
[[nodiscard]] std::filesystem::path voxinspectPath();
[[nodiscard]] std::filesystem::path assimpModels();  ///< /usr/share/assimp/models

}  // namespace vox::test
