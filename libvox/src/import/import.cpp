// Picks the importer from the extension, after checking that the contents are that format.
#include "importers.h"

#include <vox/import.h>
#include <vox/util/log.h>
#include <vox/util/timings.h>

#include <algorithm>
#include <cstring>

namespace vox {
namespace {

using detail::ImportContext;

bool startsWith(const std::vector<std::uint8_t>& bytes, std::string_view prefix) {
    return bytes.size() >= prefix.size() &&
           std::memcmp(bytes.data(), prefix.data(), prefix.size()) == 0;
}

/// Position of the first byte that is not whitespace, after a UTF-8 byte-order mark.
std::size_t firstContent(const std::vector<std::uint8_t>& bytes) {
    std::size_t i = startsWith(bytes, "\xEF\xBB\xBF") ? 3 : 0;
    while (i < bytes.size() && std::isspace(bytes[i])) ++i;
    return i;
}

/// Text files: UTF-16 gets its own message (a common export mistake); NUL bytes mean binary.
void requireText(const ImportContext& context, const std::vector<std::uint8_t>& bytes,
                 const char* format) {
    if (startsWith(bytes, "\xFE\xFF") || startsWith(bytes, "\xFF\xFE"))
        context.fail(std::string("is UTF-16 text; ") + format + " files must be ASCII or UTF-8");
    const std::size_t probe = std::min<std::size_t>(bytes.size(), 4096);
    if (std::find(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(probe), 0) !=
        bytes.begin() + static_cast<std::ptrdiff_t>(probe))
        context.fail(std::string("is not a text ") + format + " file (it holds binary data)");
}

bool isBinaryStl(const std::vector<std::uint8_t>& bytes) {
    if (bytes.size() < 84) return false;
    std::uint32_t triangles;
    std::memcpy(&triangles, bytes.data() + 80, 4);
    return bytes.size() == 84 + 50ull * triangles;
}

}  // namespace

const std::vector<std::string>& supportedSceneExtensions() {
    static const std::vector<std::string> extensions = {".gltf", ".glb", ".obj", ".ply",
                                                        ".stl",  ".off", ".drc"};
    return extensions;
}

Scene importScene(const std::filesystem::path& file, const ImportOptions& options) {
    Scene scene;
    ImportContext context(file, options, scene);
    const std::string ext = detail::lowerExtension(file);
    const auto& supported = supportedSceneExtensions();
    if (std::find(supported.begin(), supported.end(), ext) == supported.end()) {
        std::string list;
        for (const auto& e : supported) list += (list.empty() ? "" : " ") + e;
        context.fail("unsupported file type '" + ext + "' (libvox reads " + list + ")");
    }

    std::vector<std::uint8_t> bytes;
    {
        Timings::Scope timer(options.timings, "import.read");
        bytes = context.readFile(file);
    }
    if (bytes.empty()) context.fail("is empty");

    auto mismatch = [&](const char* expected) {
        context.fail(std::string("is not ") + expected + " despite its extension");
    };
    detail::MissingNormals missingNormals = detail::MissingNormals::Smooth;
    if (ext == ".glb") {
        if (!startsWith(bytes, "glTF")) mismatch("a GLB file (no 'glTF' magic)");
        detail::importGltf(context, bytes, true);
        missingNormals = detail::MissingNormals::Flat;  // glTF 2.0 §3.7.2.1 requires flat normals
    } else if (ext == ".gltf") {
        const std::size_t start = firstContent(bytes);
        if (startsWith(bytes, "glTF"))
            mismatch("a JSON glTF file (it is a binary GLB; rename it .glb)");
        if (start >= bytes.size() || bytes[start] != '{') mismatch("a JSON glTF file");
        detail::importGltf(context, bytes, false);
        missingNormals = detail::MissingNormals::Flat;
    } else if (ext == ".obj") {
        requireText(context, bytes, "OBJ");
        detail::importObj(context, bytes);
    } else if (ext == ".ply") {
        if (!startsWith(bytes, "ply\n") && !startsWith(bytes, "ply\r\n"))
            mismatch("a PLY file (no 'ply' header)");
        detail::importPly(context, bytes);
    } else if (ext == ".stl") {
        if (!isBinaryStl(bytes)) {
            const std::size_t start = firstContent(bytes);
            if (bytes.size() - start < 5 || std::memcmp(bytes.data() + start, "solid", 5) != 0)
                mismatch("an STL file (neither a binary STL of consistent size nor ASCII 'solid')");
            requireText(context, bytes, "ASCII STL");
        }
        detail::importStl(context, bytes);
        missingNormals =
            detail::MissingNormals::Flat;  // STL is faceted; its stored normals are often wrong
    } else if (ext == ".off") {
        detail::importOff(context, bytes);
    } else if (ext == ".drc") {
        if (!startsWith(bytes, "DRACO")) mismatch("a Draco file (no 'DRACO' magic)");
        detail::importDrc(context, bytes);
    }

    // The importers copied what they need: the file's bytes go before finalizing grows the meshes'
    // arrays, so that the peak of an import is the larger of the two, not their sum.
    std::vector<std::uint8_t>().swap(bytes);
    context.decodeTextures();
    {
        Timings::Scope timer(options.timings, "import.finalize");
        context.finish(missingNormals);
    }
    for (const std::string& warning : scene.warnings) log::warning(file.string() + ": " + warning);
    return scene;
}

}  // namespace vox
