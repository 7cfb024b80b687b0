#include "import_context.h"

#include <vox/util/log.h>

#include <algorithm>
#include <cerrno>
#include <fstream>

namespace vox::detail {

ImportContext::ImportContext(std::filesystem::path input, const ImportOptions& options, Scene& scene)
    : input_(std::move(input)), options_(options), scene_(scene) {}

void ImportContext::warn(const std::string& problem) {
    if (options_.strict) fail(problem + " (an error under --strict)");
    scene_.warnings.push_back(problem);
    log::warning(input_.string() + ": " + problem);
}

void ImportContext::fail(const std::string& problem) const { throw InvalidDataError(input_, problem); }

void ImportContext::recordRead(const std::filesystem::path& file) {
    const std::filesystem::path normal = file.lexically_normal();
    if (std::find(scene_.sourceFiles.begin(), scene_.sourceFiles.end(), normal) == scene_.sourceFiles.end())
        scene_.sourceFiles.push_back(normal);
}

std::vector<std::uint8_t> ImportContext::readFile(const std::filesystem::path& file) {
    auto ioError = [&](const std::string& what) -> IoError {
        if (file.lexically_normal() == input_.lexically_normal()) return IoError(input_, what);
        return IoError(input_, "cannot read '" + file.string() + "': " + what);
    };
    std::error_code ec;
    if (std::filesystem::is_directory(file, ec)) throw ioError("is a directory");
    std::ifstream in(file, std::ios::binary | std::ios::ate);
    if (!in) throw ioError(errnoMessage(errno));
    const std::streamoff size = in.tellg();
    if (size < 0) throw ioError("cannot determine its size");
    std::vector<std::uint8_t> bytes(static_cast<std::size_t>(size));
    in.seekg(0);
    if (size > 0 && !in.read(reinterpret_cast<char*>(bytes.data()), size)) throw ioError("read failed");
    recordRead(file);
    bytesRead_ += bytes.size();
    return bytes;
}

bool ImportContext::isDynamicName(const std::string& name) {
    if (name.empty()) return false;
    const auto& names = options_.dynamicNames;
    if (std::find(names.begin(), names.end(), name) == names.end()) return false;
    usedDynamicNames_.insert(name);
    return true;
}

std::uint32_t ImportContext::defaultMaterial() {
    if (defaultMaterial_ < 0) {
        Material material;
        material.name = "default";
        scene_.materials.push_back(material);
        defaultMaterial_ = static_cast<std::int64_t>(scene_.materials.size() - 1);
    }
    return static_cast<std::uint32_t>(defaultMaterial_);
}

std::int32_t ImportContext::texture(const std::string& key, ColorSpace colorSpace,
                                    const std::function<Texture()>& load) {
    const auto mapKey = std::make_pair(key, colorSpace);
    if (auto it = textures_.find(mapKey); it != textures_.end()) return it->second;
    std::int32_t index = -1;
    if (options_.loadTextures) {
        scene_.textures.push_back(load());
        index = static_cast<std::int32_t>(scene_.textures.size() - 1);
    }
    textures_.emplace(mapKey, index);
    return index;
}

void ImportContext::finish(MissingNormals missingNormals) {
    for (const std::string& name : options_.dynamicNames)
        if (!usedDynamicNames_.count(name)) warn("--dynamic '" + name + "' matches nothing in the file");
    finalizeScene(*this, missingNormals);
}

std::string lowerExtension(const std::filesystem::path& file) {
    std::string ext = file.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return ext;
}

}  // namespace vox::detail
