// voxview's window: a GLFW window with an OpenGL 4.5 core (debug) context, showing each frame's
// image. The runtime renders into its own buffers and works in whatever context is current; the
// window only shows the result.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

struct GLFWwindow;

namespace voxview {

/// Whether a window can be opened here: a display is named (DISPLAY or WAYLAND_DISPLAY).
[[nodiscard]] bool displayAvailable();

class Window {
public:
    /// Opens a window of @p width × @p height with an OpenGL 4.5 core debug context and makes the
    /// context current. @throws vox::runtime::RuntimeError when GLFW or the context fails.
    Window(int width, int height, const std::string& title);
    ~Window();
    Window(const Window&) = delete;
    Window& operator=(const Window&) = delete;

    /// Shows @p rgb (8-bit RGB, row 0 at the top, width × height of the window's image), swaps,
    /// and handles events. False once the window was asked to close (or Escape was pressed).
    bool present(const std::vector<std::uint8_t>& rgb, int width, int height);

private:
    GLFWwindow* window_ = nullptr;
    unsigned texture_ = 0, framebuffer_ = 0;
    int textureWidth_ = 0, textureHeight_ = 0;
};

}  // namespace voxview
