/// @file shader.h
/// @brief Compute programs compiled from GLSL source, with the info log in the exception.
#pragma once

#include <string>

namespace vox::runtime {

/// A linked GL program holding one compute shader. Needs a current GL context.
class ComputeProgram {
public:
    /// Compiles and links @p source (a complete GLSL 4.50 compute shader). @p name labels the
    /// program in errors and in KHR_debug output.
    /// @throws RuntimeError "NAME: compile failed: LOG" (or link failed), the log on one line.
    ComputeProgram(const std::string& name, const std::string& source);
    ~ComputeProgram();
    ComputeProgram(const ComputeProgram&) = delete;
    ComputeProgram& operator=(const ComputeProgram&) = delete;
    ComputeProgram(ComputeProgram&& other) noexcept;
    ComputeProgram& operator=(ComputeProgram&& other) noexcept;

    [[nodiscard]] unsigned id() const noexcept { return program_; }
    /// Uniform location; -1 where the compiler removed or never had it.
    [[nodiscard]] int uniform(const char* name) const;

private:
    unsigned program_ = 0;
};

}  // namespace vox::runtime
