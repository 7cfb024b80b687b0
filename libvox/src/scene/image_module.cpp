// Loads the image module (image_module.h) on first use.
#include "image_module.h"

#include <dlfcn.h>

#include <cstdlib>
#include <stdexcept>

namespace vox::detail {
namespace {

/// Where the module may be, in the order tried.
std::vector<std::filesystem::path> candidates() {
    std::vector<std::filesystem::path> out;
    if (const char* path = std::getenv("VOX_IMAGE_MODULE"); path != nullptr && *path != '\0')
        return {path};
    std::error_code ec;
    const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
    if (!ec)
        out.push_back(exe.parent_path().parent_path() / VOX_IMAGE_MODULE_LIBDIR /
                      VOX_IMAGE_MODULE_NAME);       // an installed tool
    out.emplace_back(VOX_IMAGE_MODULE_BUILD_PATH);  // this build
    out.push_back(std::filesystem::path(VOX_IMAGE_MODULE_INSTALL_LIBDIR) /
                  VOX_IMAGE_MODULE_NAME);  // as installed
    return out;
}

const ImageModule& load() {
    std::string tried;
    for (const std::filesystem::path& file : candidates()) {
        std::error_code ec;
        if (!std::filesystem::is_regular_file(file, ec)) {
            tried += "; " + file.string() + ": not found";
            continue;
        }
        void* handle = dlopen(file.c_str(), RTLD_NOW | RTLD_LOCAL);
        if (handle == nullptr) {
            const char* why = dlerror();
            tried += "; " + file.string() + ": " + (why ? why : "cannot load");
            continue;
        }
        const auto entry = reinterpret_cast<ImageModuleEntry>(dlsym(handle, kImageModuleEntry));
        const ImageModule* module = entry ? entry() : nullptr;
        if (module == nullptr || module->version != kImageModuleVersion) {
            tried += "; " + file.string() + ": not libvox's image module, version " +
                     std::to_string(kImageModuleVersion);
            continue;  // (left loaded: unloading a library of unknown state is not safe)
        }
        return *module;
    }
    throw std::runtime_error(
        "cannot load libvox's image module (" + std::string(VOX_IMAGE_MODULE_NAME) +
        "), which decodes and writes images (set VOX_IMAGE_MODULE to its path); tried " +
        tried.substr(2));
}

}  // namespace

const ImageModule& imageModule() {
    static const ImageModule& module = load();
    return module;
}

}  // namespace vox::detail
