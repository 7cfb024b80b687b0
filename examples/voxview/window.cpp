#include "window.h"

#include <vox/runtime/gl_context.h>

#define GLFW_INCLUDE_NONE
#include <GL/glcorearb.h>
#include <GLFW/glfw3.h>

#include <cstdlib>
#include <cstring>

namespace voxview {

bool displayAvailable() {
    const char* x11 = std::getenv("DISPLAY");
    const char* wayland = std::getenv("WAYLAND_DISPLAY");
    return (x11 != nullptr && *x11 != '\0') || (wayland != nullptr && *wayland != '\0');
}

Window::Window(int width, int height, const std::string& title) {
    if (glfwInit() != GLFW_TRUE) {
        const char* why = nullptr;
        glfwGetError(&why);
        throw vox::runtime::RuntimeError(std::string("GLFW: cannot initialise (") +
                                         (why ? why : "no reason given") + ")");
    }
    glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 4);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 5);
    glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
    glfwWindowHint(GLFW_OPENGL_DEBUG_CONTEXT, GLFW_TRUE);
    glfwWindowHint(GLFW_RESIZABLE, GLFW_FALSE);
    window_ = glfwCreateWindow(width, height, title.c_str(), nullptr, nullptr);
    if (window_ == nullptr) {
        const char* why = nullptr;
        glfwGetError(&why);
        glfwTerminate();
        throw vox::runtime::RuntimeError(
            std::string("GLFW: no window with an OpenGL 4.5 core context (") +
            (why ? why : "no reason given") + ")");
    }
    glfwMakeContextCurrent(window_);
    glfwSwapInterval(0);
}

Window::~Window() {
    if (framebuffer_ != 0) glDeleteFramebuffers(1, &framebuffer_);
    if (texture_ != 0) glDeleteTextures(1, &texture_);
    glfwDestroyWindow(window_);
    glfwTerminate();
}

bool Window::present(const std::vector<std::uint8_t>& rgb, int width, int height) {
    if (texture_ == 0 || width != textureWidth_ || height != textureHeight_) {
        if (framebuffer_ != 0) glDeleteFramebuffers(1, &framebuffer_);
        if (texture_ != 0) glDeleteTextures(1, &texture_);
        glCreateTextures(GL_TEXTURE_2D, 1, &texture_);
        glTextureStorage2D(texture_, 1, GL_RGB8, width, height);
        glCreateFramebuffers(1, &framebuffer_);
        glNamedFramebufferTexture(framebuffer_, GL_COLOR_ATTACHMENT0, texture_, 0);
        textureWidth_ = width;
        textureHeight_ = height;
    }
    GLint alignment = 4;
    glGetIntegerv(GL_UNPACK_ALIGNMENT, &alignment);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glTextureSubImage2D(texture_, 0, 0, 0, width, height, GL_RGB, GL_UNSIGNED_BYTE, rgb.data());
    glPixelStorei(GL_UNPACK_ALIGNMENT, alignment);
    // Row 0 of the image is the top: flip while blitting to the window (GL's row 0 is the bottom).
    int fbWidth = 0, fbHeight = 0;
    glfwGetFramebufferSize(window_, &fbWidth, &fbHeight);
    glBlitNamedFramebuffer(framebuffer_, 0, 0, height, width, 0, 0, 0, fbWidth, fbHeight,
                           GL_COLOR_BUFFER_BIT, GL_NEAREST);
    glfwSwapBuffers(window_);
    glfwPollEvents();
    if (glfwGetKey(window_, GLFW_KEY_ESCAPE) == GLFW_PRESS)
        glfwSetWindowShouldClose(window_, GLFW_TRUE);
    return glfwWindowShouldClose(window_) == GLFW_FALSE;
}

}  // namespace voxview
