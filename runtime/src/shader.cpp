#include <vox/runtime/gl_context.h>
#include <vox/runtime/shader.h>

#include <GL/glcorearb.h>

#include <utility>

namespace vox::runtime {
namespace {
/// The info log on one line, so that the exception is one line of stderr.
std::string oneLine(std::string log) {
    while (!log.empty() && (log.back() == '\n' || log.back() == ' ' || log.back() == '\0'))
        log.pop_back();
    for (char& c : log)
        if (c == '\n') c = ' ';
    return log;
}
}  // namespace

ComputeProgram::ComputeProgram(const std::string& name, const std::string& source) {
    const GLuint shader = glCreateShader(GL_COMPUTE_SHADER);
    const char* text = source.c_str();
    glShaderSource(shader, 1, &text, nullptr);
    glCompileShader(shader);
    GLint ok = 0, length = 0;
    glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
    if (ok != GL_TRUE) {
        glGetShaderiv(shader, GL_INFO_LOG_LENGTH, &length);
        std::string log(static_cast<std::size_t>(std::max(length, 1)), '\0');
        glGetShaderInfoLog(shader, length, nullptr, log.data());
        glDeleteShader(shader);
        throw RuntimeError(name + ": compile failed: " + oneLine(log));
    }
    program_ = glCreateProgram();
    glAttachShader(program_, shader);
    glLinkProgram(program_);
    glDeleteShader(shader);  // flagged; freed with the program
    glGetProgramiv(program_, GL_LINK_STATUS, &ok);
    if (ok != GL_TRUE) {
        glGetProgramiv(program_, GL_INFO_LOG_LENGTH, &length);
        std::string log(static_cast<std::size_t>(std::max(length, 1)), '\0');
        glGetProgramInfoLog(program_, length, nullptr, log.data());
        glDeleteProgram(program_);
        program_ = 0;
        throw RuntimeError(name + ": link failed: " + oneLine(log));
    }
    glObjectLabel(GL_PROGRAM, program_, static_cast<GLsizei>(name.size()), name.c_str());
}

ComputeProgram::~ComputeProgram() {
    if (program_ != 0) glDeleteProgram(program_);
}

ComputeProgram::ComputeProgram(ComputeProgram&& other) noexcept
    : program_(std::exchange(other.program_, 0)) {}

ComputeProgram& ComputeProgram::operator=(ComputeProgram&& other) noexcept {
    if (this != &other) {
        if (program_ != 0) glDeleteProgram(program_);
        program_ = std::exchange(other.program_, 0);
    }
    return *this;
}

int ComputeProgram::uniform(const char* name) const { return glGetUniformLocation(program_, name); }

}  // namespace vox::runtime
