#include "import_context.h"

#include <vox/util/log.h>
#include <vox/util/progress.h>
#include <vox/util/timings.h>

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cerrno>
#include <fstream>

namespace vox::detail {

ImportContext::ImportContext(std::filesystem::path input, const ImportOptions& options,
                             Scene& scene)
    : input_(std::move(input)), options_(options), scene_(scene) {}

void ImportContext::warn(const std::string& problem) {
    if (options_.strict) fail(problem + " (an error in strict mode)");
    // Printed by importScene once the import has succeeded: a failed import reports one line.
    scene_.warnings.push_back(problem);
}

void ImportContext::fail(const std::string& problem) const {
    throw InvalidDataError(input_, problem);
}

void ImportContext::recordRead(const std::filesystem::path& file) {
    const std::filesystem::path normal = file.lexically_normal();
    if (std::find(scene_.sourceFiles.begin(), scene_.sourceFiles.end(), normal) ==
        scene_.sourceFiles.end())
        scene_.sourceFiles.push_back(normal);
}

std::vector<std::uint8_t> ImportContext::readFile(const std::filesystem::path& file) {
    auto ioError = [&](const std::string& what) -> IoError {
        if (file.lexically_normal() == input_.lexically_normal()) return IoError(input_, what);
        return IoError(input_, "cannot read '" + file.string() + "': " + what);
    };
    std::error_code ec;
    const auto status = std::filesystem::status(file, ec);
    if (std::filesystem::is_directory(status)) throw ioError("is a directory");
    // A FIFO, socket or device named by a file (a glTF buffer "uri": "/dev/stdin", say) would
    // block the import or never end.
    if (std::filesystem::exists(status) && !std::filesystem::is_regular_file(status))
        throw ioError("is not a regular file");
    std::ifstream in(file, std::ios::binary | std::ios::ate);
    if (!in) throw ioError(errnoMessage(errno));
    const std::streamoff size = in.tellg();
    if (size < 0) throw ioError("cannot determine its size");
    std::vector<std::uint8_t> bytes(static_cast<std::size_t>(size));
    in.seekg(0);
    if (size > 0 && !in.read(reinterpret_cast<char*>(bytes.data()), size))
        throw ioError("read failed");
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
                                    const std::function<EncodedImage()>& read) {
    if (!options_.loadTextures) return -1;
    const auto mapKey = std::make_pair(key, colorSpace);
    if (auto it = textures_.find(mapKey); it != textures_.end()) return it->second;
    pendingTextures_.emplace_back(read(), colorSpace);
    const auto index =
        static_cast<std::int32_t>(scene_.textures.size() + pendingTextures_.size() - 1);
    textures_.emplace(mapKey, index);
    return index;
}

void ImportContext::decodeTextures() {
    if (pendingTextures_.empty()) return;
    Timings::Scope timer(options_.timings, "import.textures");
    const std::size_t first = scene_.textures.size(), count = pendingTextures_.size();
    scene_.textures.resize(first + count);
    std::vector<std::exception_ptr> errors(count);
    Progress progress("decoding textures", count);
    tbb::parallel_for(std::size_t{0}, count, [&](std::size_t i) {
        const auto& [image, colorSpace] = pendingTextures_[i];
        try {
            scene_.textures[first + i] =
                decodeTexture(image.bytes, image.file, image.what, image.mimeType, colorSpace);
        } catch (...) {
            errors[i] = std::current_exception();
        }
        progress.advance();
    });
    pendingTextures_.clear();
    for (const auto& error : errors)
        if (error) std::rethrow_exception(error);
}

void ImportContext::finish(MissingNormals missingNormals) {
    for (const std::string& name : options_.dynamicNames)
        if (!usedDynamicNames_.count(name))
            warn("dynamic mesh name '" + name + "' matches nothing in the file");
    finalizeScene(*this, missingNormals);
}

std::string lowerExtension(const std::filesystem::path& file) {
    std::string ext = file.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return ext;
}

}  // namespace vox::detail
