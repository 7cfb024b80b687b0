// Headless EGL context creation and KHR_debug collection.
#include <vox/runtime/gl_context.h>

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GL/glcorearb.h>

#include <cstring>
#include <string_view>
#include <vector>

namespace vox::runtime {
namespace {

bool hasExtension(const char* list, std::string_view name) {
    if (list == nullptr) return false;
    std::string_view all(list);
    for (std::size_t start = 0; start < all.size();) {
        const std::size_t end = std::min(all.find(' ', start), all.size());
        if (all.substr(start, end - start) == name) return true;
        start = end + 1;
    }
    return false;
}

std::string eglErrorName(EGLint error) {
    switch (error) {
        case EGL_SUCCESS:
            return "EGL_SUCCESS";
        case EGL_NOT_INITIALIZED:
            return "EGL_NOT_INITIALIZED";
        case EGL_BAD_ACCESS:
            return "EGL_BAD_ACCESS";
        case EGL_BAD_ALLOC:
            return "EGL_BAD_ALLOC";
        case EGL_BAD_ATTRIBUTE:
            return "EGL_BAD_ATTRIBUTE";
        case EGL_BAD_CONFIG:
            return "EGL_BAD_CONFIG";
        case EGL_BAD_CONTEXT:
            return "EGL_BAD_CONTEXT";
        case EGL_BAD_DISPLAY:
            return "EGL_BAD_DISPLAY";
        case EGL_BAD_MATCH:
            return "EGL_BAD_MATCH";
        case EGL_BAD_PARAMETER:
            return "EGL_BAD_PARAMETER";
        case EGL_BAD_SURFACE:
            return "EGL_BAD_SURFACE";
        default:
            return "EGL error " + std::to_string(error);
    }
}

const char* debugTypeName(GLenum type) {
    switch (type) {
        case GL_DEBUG_TYPE_ERROR:
            return "error";
        case GL_DEBUG_TYPE_DEPRECATED_BEHAVIOR:
            return "deprecated";
        case GL_DEBUG_TYPE_UNDEFINED_BEHAVIOR:
            return "undefined behaviour";
        case GL_DEBUG_TYPE_PORTABILITY:
            return "portability";
        case GL_DEBUG_TYPE_PERFORMANCE:
            return "performance";
        default:
            return "other";
    }
}

void APIENTRY debugCallback(GLenum source, GLenum type, GLuint id, GLenum severity, GLsizei length,
                            const GLchar* message, const void* user) {
    const std::string text =
        length >= 0 ? std::string(message, static_cast<std::size_t>(length)) : std::string(message);
    static_cast<GlContext*>(const_cast<void*>(user))
        ->onDebugMessage(source, type, id, severity, text.c_str());
}

/// Tries to initialise @p display; terminates it again on failure.
bool initialise(EGLDisplay display) {
    if (display == EGL_NO_DISPLAY) return false;
    EGLint major = 0, minor = 0;
    return eglInitialize(display, &major, &minor) == EGL_TRUE;
}

}  // namespace

HeadlessGlContext::HeadlessGlContext(std::optional<EglPlatform> only) {
    // Client extensions (EGL 1.5 or EGL_EXT_client_extensions): which platforms exist.
    const char* client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    const auto wanted = [&](EglPlatform p) { return !only || *only == p; };
    std::string tried;  // why each platform tried gave no display, "; "-separated
    const auto note = [&](const std::string& why) { tried += (tried.empty() ? "" : "; ") + why; };
    // The EGL devices, GPUs apart from Mesa's software device (EGL_MESA_device_software).
    std::vector<EGLDeviceEXT> gpus, softwareDevices;
    if (wanted(EglPlatform::Device) && hasExtension(client, "EGL_EXT_platform_device")) {
        auto queryDevices =
            reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
        auto queryDeviceString = reinterpret_cast<PFNEGLQUERYDEVICESTRINGEXTPROC>(
            eglGetProcAddress("eglQueryDeviceStringEXT"));
        EGLDeviceEXT devices[16];
        EGLint count = 0;
        if (queryDevices != nullptr && queryDevices(16, devices, &count) == EGL_TRUE)
            for (EGLint i = 0; i < count; ++i) {
                const char* deviceExtensions = queryDeviceString != nullptr
                                                   ? queryDeviceString(devices[i], EGL_EXTENSIONS)
                                                   : nullptr;
                (hasExtension(deviceExtensions, "EGL_MESA_device_software") ? softwareDevices
                                                                            : gpus)
                    .push_back(devices[i]);
            }
        note("device: " + std::to_string(gpus.size()) + " GPUs and " +
             std::to_string(softwareDevices.size()) + " software devices");
    } else if (wanted(EglPlatform::Device)) {
        note("device: no EGL_EXT_platform_device");
    }
    const auto firstDevice = [&](const std::vector<EGLDeviceEXT>& devices) {
        for (EGLDeviceEXT device : devices) {
            EGLDisplay d = eglGetPlatformDisplay(EGL_PLATFORM_DEVICE_EXT, device, nullptr);
            if (initialise(d)) {
                platform_ = EglPlatform::Device;
                return d;
            }
        }
        return EGL_NO_DISPLAY;
    };
    // A GPU's device first: where NVIDIA's driver sits beside Mesa (glvnd), Mesa's surfaceless
    // platform would answer too, with llvmpipe.
    EGLDisplay display = firstDevice(gpus);
    if (display == EGL_NO_DISPLAY && wanted(EglPlatform::Surfaceless)) {
        if (hasExtension(client, "EGL_MESA_platform_surfaceless")) {
            display =
                eglGetPlatformDisplay(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
            if (initialise(display))
                platform_ = EglPlatform::Surfaceless;
            else
                display = EGL_NO_DISPLAY, note("surfaceless: " + eglErrorName(eglGetError()));
        } else {
            note("surfaceless: no EGL_MESA_platform_surfaceless");
        }
    }
    if (display == EGL_NO_DISPLAY) display = firstDevice(softwareDevices);
    if (display == EGL_NO_DISPLAY && wanted(EglPlatform::Default)) {
        display = eglGetDisplay(EGL_DEFAULT_DISPLAY);
        if (initialise(display))
            platform_ = EglPlatform::Default;
        else
            display = EGL_NO_DISPLAY, note("default: " + eglErrorName(eglGetError()));
    }
    if (display == EGL_NO_DISPLAY)
        throw RuntimeError("OpenGL: no EGL display could be initialised (" + tried + ")");
    display_ = display;

    const char* extensions = eglQueryString(display, EGL_EXTENSIONS);
    const auto fail = [&](const std::string& what) {
        const std::string error = eglErrorName(eglGetError());
        if (context_ != nullptr) eglDestroyContext(display, context_);
        if (surface_ != nullptr) eglDestroySurface(display, surface_);
        eglTerminate(display);
        throw RuntimeError("OpenGL: " + what + " (" + error + ", EGL platform " + platformName() +
                           ")");
    };
    if (eglBindAPI(EGL_OPENGL_API) != EGL_TRUE) fail("this EGL has no desktop OpenGL API");

    const bool surfaceless = hasExtension(extensions, "EGL_KHR_surfaceless_context");
    EGLConfig config = nullptr;
    const EGLint configAttribs[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_SURFACE_TYPE,
                                    surfaceless ? 0 : EGL_PBUFFER_BIT, EGL_NONE};
    EGLint configs = 0;
    if (!(hasExtension(extensions, "EGL_KHR_no_config_context") && surfaceless)) {
        if (eglChooseConfig(display, configAttribs, &config, 1, &configs) != EGL_TRUE ||
            configs < 1)
            fail("no EGL config renders with OpenGL");
    }
    const EGLint contextAttribs[] = {EGL_CONTEXT_MAJOR_VERSION,
                                     4,
                                     EGL_CONTEXT_MINOR_VERSION,
                                     5,
                                     EGL_CONTEXT_OPENGL_PROFILE_MASK,
                                     EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                                     EGL_CONTEXT_OPENGL_DEBUG,
                                     EGL_TRUE,
                                     EGL_NONE};
    context_ = eglCreateContext(display, config == nullptr ? EGL_NO_CONFIG_KHR : config,
                                EGL_NO_CONTEXT, contextAttribs);
    if (context_ == EGL_NO_CONTEXT) {
        context_ = nullptr;
        fail("no OpenGL 4.5 core context (the driver offers less)");
    }
    if (!surfaceless) {
        const EGLint pbufferAttribs[] = {EGL_WIDTH, 1, EGL_HEIGHT, 1, EGL_NONE};
        surface_ = eglCreatePbufferSurface(display, config, pbufferAttribs);
        if (surface_ == EGL_NO_SURFACE)
            surface_ = nullptr, fail("no surfaceless contexts and no pbuffer");
    }
    EGLSurface surface = surface_ != nullptr ? surface_ : EGL_NO_SURFACE;
    if (eglMakeCurrent(display, surface, surface, context_) != EGL_TRUE)
        fail("cannot make the OpenGL context current");

    attachToCurrent(fail);
}

HeadlessGlContext::~HeadlessGlContext() {
    auto display = static_cast<EGLDisplay>(display_);
    detachFromCurrent();
    eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    if (surface_ != nullptr) eglDestroySurface(display, surface_);
    eglDestroyContext(display, context_);
    eglTerminate(display);
    eglReleaseThread();
}

const char* HeadlessGlContext::platformName() const noexcept {
    switch (platform_) {
        case EglPlatform::Surfaceless:
            return "surfaceless";
        case EglPlatform::Device:
            return "device";
        default:
            return "default";
    }
}

GlContext::~GlContext() = default;

void GlContext::attachToCurrent(const std::function<void(const std::string&)>& fail) {
    const auto str = [](GLenum name) {
        const auto* s = reinterpret_cast<const char*>(glGetString(name));
        return std::string(s != nullptr ? s : "");
    };
    renderer_ = str(GL_RENDERER);
    version_ = str(GL_VERSION);
    vendor_ = str(GL_VENDOR);
    glGetIntegerv(GL_MAJOR_VERSION, &major_);
    glGetIntegerv(GL_MINOR_VERSION, &minor_);
    if (major_ * 10 + minor_ < 45)
        fail("OpenGL " + version_ + " on " + renderer_ + ": 4.5 core needed");

    // Synchronous output: the callback runs inside the failing call, on this thread, so the
    // count is exact when a call returns (and a debugger stops in the right place).
    glEnable(GL_DEBUG_OUTPUT);
    glEnable(GL_DEBUG_OUTPUT_SYNCHRONOUS);
    glDebugMessageCallback(debugCallback, this);
    glDebugMessageControl(GL_DONT_CARE, GL_DONT_CARE, GL_DONT_CARE, 0, nullptr, GL_TRUE);
    attached_ = true;
}

void GlContext::detachFromCurrent() noexcept {
    if (attached_) glDebugMessageCallback(nullptr, nullptr);
    attached_ = false;
}

CurrentGlContext::CurrentGlContext() {
    // (With no context current, glvnd's dispatch returns null: the toolkit's may be GLX, not EGL.)
    if (glGetString(GL_VERSION) == nullptr)
        throw RuntimeError("OpenGL: no context is current on this thread");
    attachToCurrent([](const std::string& what) -> void { throw RuntimeError("OpenGL: " + what); });
}

CurrentGlContext::~CurrentGlContext() { detachFromCurrent(); }

void GlContext::onDebugMessage(std::uint32_t source, std::uint32_t type, std::uint32_t id,
                               std::uint32_t severity, const char* text) {
    std::lock_guard lock(mutex_);
    if (type == GL_DEBUG_TYPE_ERROR) ++errors_;
    if (messages_.size() < 256) messages_.push_back({source, type, id, severity, text});
}

std::uint64_t GlContext::errorCount() const {
    std::lock_guard lock(mutex_);
    return errors_;
}

std::vector<GlDebugMessage> GlContext::debugMessages() const {
    std::lock_guard lock(mutex_);
    return messages_;
}

std::string GlContext::errorSummary() const {
    std::lock_guard lock(mutex_);
    std::string out;
    for (const GlDebugMessage& m : messages_) {
        if (m.type != GL_DEBUG_TYPE_ERROR) continue;
        if (!out.empty()) out += "; ";
        std::string text = m.text;
        while (!text.empty() && (text.back() == '\n' || text.back() == ' ')) text.pop_back();
        out += std::string(debugTypeName(m.type)) + " " + std::to_string(m.id) + ": " + text;
    }
    return out;
}

void GlContext::clearDebugMessages() {
    std::lock_guard lock(mutex_);
    messages_.clear();
    errors_ = 0;
}

void GlContext::throwOnErrors(const std::string& what) const {
    if (errorCount() == 0) return;
    std::string summary = errorSummary();
    for (char& c : summary)
        if (c == '\n') c = ' ';
    throw RuntimeError(what + ": GL error: " + summary);
}

}  // namespace vox::runtime
