/// @file gl_context.h
/// @brief A headless OpenGL 4.5 core context through EGL, with KHR_debug error collection.
#pragma once

#include <vox/base/error.h>

#include <cstdint>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace vox::runtime {

/// A GL-side failure: no usable OpenGL 4.5 context, a shader that does not compile, a resource
/// the implementation cannot provide. Exit code 4 in voxview (docs/runtime.md).
class RuntimeError : public vox::Error {
public:
    explicit RuntimeError(const std::string& message) : vox::Error(message) {}
    [[nodiscard]] ExitCode exitCode() const noexcept override { return ExitCode::Internal; }
};

/// One message the GL implementation reported through KHR_debug.
struct GlDebugMessage {
    std::uint32_t source = 0, type = 0, id = 0,
                  severity = 0;  ///< GL_DEBUG_SOURCE_*, GL_DEBUG_TYPE_*, id, GL_DEBUG_SEVERITY_*
    std::string text;
};

/// Which EGL display the context came from.
enum class EglPlatform { Surfaceless, Device, Default };

/// An OpenGL 4.5 core context the runtime works in, current on the calling thread: what every
/// runtime object takes. It reports the implementation (renderer, version) and collects KHR_debug
/// output (synchronous: the callback runs inside the failing call), so a GL error is never
/// silent. Two kinds: HeadlessGlContext makes its own through EGL; CurrentGlContext adopts the one
/// an application made (GLFW, SDL, Qt ...). Not copyable or movable (the debug callback holds its
/// address).
class GlContext {
public:
    virtual ~GlContext();
    GlContext(const GlContext&) = delete;
    GlContext& operator=(const GlContext&) = delete;

    [[nodiscard]] const std::string& renderer() const noexcept {
        return renderer_;
    }                                                                               ///< GL_RENDERER
    [[nodiscard]] const std::string& version() const noexcept { return version_; }  ///< GL_VERSION
    [[nodiscard]] const std::string& vendor() const noexcept { return vendor_; }    ///< GL_VENDOR
    [[nodiscard]] int majorVersion() const noexcept { return major_; }
    [[nodiscard]] int minorVersion() const noexcept { return minor_; }
    /// How the context came about: "surfaceless", "device" or "default" (EGL), "current" (adopted).
    [[nodiscard]] virtual const char* platformName() const noexcept = 0;

    /// GL errors (KHR_debug messages of type GL_DEBUG_TYPE_ERROR) since construction or the
    /// last clearDebugMessages(). Tests assert this is 0 after every frame.
    [[nodiscard]] std::uint64_t errorCount() const;
    /// Every message received (the first 256 kept), errors and others (performance,
    /// portability...).
    [[nodiscard]] std::vector<GlDebugMessage> debugMessages() const;
    /// The kept error messages joined by "; " (for a test failure or an exception).
    [[nodiscard]] std::string errorSummary() const;
    void clearDebugMessages();
    /// Throws RuntimeError "WHAT: GL error: ..." if any GL error was reported since the last
    /// clearDebugMessages(); the runtime calls it after each operation so that an error is
    /// never silent.
    void throwOnErrors(const std::string& what) const;

    /// KHR_debug callback target (public for the C callback only).
    void onDebugMessage(std::uint32_t source, std::uint32_t type, std::uint32_t id,
                        std::uint32_t severity, const char* text);

protected:
    GlContext() = default;
    /// Reads the current context's version and strings and installs the debug callback.
    /// @throws RuntimeError (via @p fail, which must throw) below OpenGL 4.5.
    void attachToCurrent(const std::function<void(const std::string&)>& fail);
    /// Removes the debug callback (before the context goes).
    void detachFromCurrent() noexcept;

private:
    std::string renderer_, version_, vendor_;
    int major_ = 0, minor_ = 0;
    bool attached_ = false;
    mutable std::mutex
        mutex_;  // GL may call back from a driver thread when output is not synchronous
    std::vector<GlDebugMessage> messages_;
    std::uint64_t errors_ = 0;
};

/// An OpenGL 4.5 core profile context without a window, made current on the constructing
/// thread. Displays are tried in order: a GPU through the device platform (EGL_EXT_platform_device
/// with EGL_EXT_device_enumeration: NVIDIA's headless path; the first device that initialises and
/// is not Mesa's software one), Mesa's surfaceless platform (EGL_MESA_platform_surfaceless:
/// llvmpipe in CI, any Mesa driver), Mesa's software device, then EGL_DEFAULT_DISPLAY. The
/// context is a debug context. EGL displays are per process and the destructor terminates the
/// display: one HeadlessGlContext at a time per process.
class HeadlessGlContext final : public GlContext {
public:
    /// @p only: try that platform alone (voxview --egl-platform), else all in the order above.
    /// @throws RuntimeError naming why no OpenGL 4.5 core context could be made (no EGL display,
    /// no OpenGL API, version below 4.5 ...), in one line.
    explicit HeadlessGlContext(std::optional<EglPlatform> only = std::nullopt);
    ~HeadlessGlContext() override;

    [[nodiscard]] EglPlatform platform() const noexcept { return platform_; }
    [[nodiscard]] const char* platformName() const noexcept override;

private:
    void* display_ = nullptr;  // EGLDisplay
    void* context_ = nullptr;  // EGLContext
    void* surface_ =
        nullptr;  // EGLSurface: a 1×1 pbuffer when EGL_KHR_surfaceless_context is missing
    EglPlatform platform_ = EglPlatform::Default;
};

/// The OpenGL context current on the constructing thread, made by the application (a window
/// toolkit's): the runtime works in it. Debug output is enabled on it; errors are counted fully
/// only where the application made a debug context.
class CurrentGlContext final : public GlContext {
public:
    /// @throws RuntimeError when no context is current or it is below OpenGL 4.5 core.
    CurrentGlContext();
    ~CurrentGlContext() override;
    [[nodiscard]] const char* platformName() const noexcept override { return "current"; }
};

}  // namespace vox::runtime
