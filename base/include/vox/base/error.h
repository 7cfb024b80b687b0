/// @file error.h
/// @brief Typed exceptions shared by every libvox layer, each tied to the exit code the
/// tools report for it (docs/cli.md). Messages name the file and the problem so that a
/// tool can print them as one line: "FILE: problem".
#pragma once

#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>

namespace vox {

/// Exit codes of voxelize and voxinspect; stable, documented in docs/cli.md.
enum class ExitCode : int {
    Ok = 0,
    Usage = 1,        ///< bad command line
    Io = 2,           ///< a file cannot be read or written
    InvalidData = 3,  ///< a file was read but its contents are not acceptable
    Internal = 4,     ///< a bug or an unexpected failure inside libvox
};

/// Base of all libvox errors.
class Error : public std::runtime_error {
public:
    [[nodiscard]] virtual ExitCode exitCode() const noexcept = 0;

protected:
    explicit Error(const std::string& message) : std::runtime_error(message) {}
    Error(const std::filesystem::path& file, std::string_view problem)
        : std::runtime_error(file.string() + ": " + std::string(problem)) {}
};

/// The command line is wrong (unknown option, missing argument, conflicting options).
class UsageError : public Error {
public:
    explicit UsageError(const std::string& message) : Error(message) {}
    [[nodiscard]] ExitCode exitCode() const noexcept override { return ExitCode::Usage; }
};

/// A library function was given an argument outside its contract. parameter() names it as the
/// API does (a function parameter or an options field: `depth`, `eye`, …); the tools translate
/// the name to their flag (tools/common/tool_main.h). what() is "parameter problem".
class ParameterError : public UsageError {
public:
    ParameterError(std::string parameter, const std::string& problem)
        : UsageError(parameter + " " + problem),
          parameter_(std::move(parameter)),
          problem_(problem) {}
    [[nodiscard]] const std::string& parameter() const noexcept { return parameter_; }
    [[nodiscard]] const std::string& problem() const noexcept { return problem_; }
    /// The message with the parameter spelled as libvox's command-line tools spell its flag:
    /// camelCase becomes --kebab-case, and the few flags named otherwise are looked up
    /// (fovYDegrees: --fov, size: --width/--height, specularApertureDegrees: --spec-aperture,
    /// shadowApertureDegrees: --shadow-aperture).
    [[nodiscard]] std::string commandLineMessage() const;

private:
    std::string parameter_, problem_;
};

/// A file could not be opened, read, written or renamed.
class IoError : public Error {
public:
    IoError(const std::filesystem::path& file, std::string_view problem) : Error(file, problem) {}
    [[nodiscard]] ExitCode exitCode() const noexcept override { return ExitCode::Io; }
};

/// A file was read but is malformed, inconsistent, or describes something libvox rejects.
class InvalidDataError : public Error {
public:
    InvalidDataError(const std::filesystem::path& file, std::string_view problem)
        : Error(file, problem) {}
    [[nodiscard]] ExitCode exitCode() const noexcept override { return ExitCode::InvalidData; }
};

/// The text of errno as "No such file or directory", for IoError messages.
[[nodiscard]] std::string errnoMessage(int errnum);

}  // namespace vox
