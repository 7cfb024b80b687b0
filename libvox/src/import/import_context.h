// State shared by the importers while one file is imported: what was read (for depfiles),
// warnings (errors under --strict), dynamic-name matching, texture de-duplication.
#pragma once

#include <vox/base/error.h>
#include <vox/import.h>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <set>
#include <string>
#include <vector>

namespace vox::detail {

/// Which normals an importer asks for where a mesh has none.
enum class MissingNormals {
    Flat,    ///< per-triangle normals, vertices unwelded (glTF requires this; STL is faceted)
    Smooth,  ///< angle-weighted average of the triangles around each position
};

class ImportContext {
public:
    ImportContext(std::filesystem::path input, const ImportOptions& options, Scene& scene);

    [[nodiscard]] const std::filesystem::path& input() const noexcept { return input_; }
    [[nodiscard]] const ImportOptions& options() const noexcept { return options_; }
    [[nodiscard]] Scene& scene() noexcept { return scene_; }

    /// Reports a repair. Under --strict it is an InvalidDataError instead.
    void warn(const std::string& problem);
    /// An InvalidDataError naming the input file.
    [[noreturn]] void fail(const std::string& problem) const;

    /// Reads a whole file and records it as read. @throws IoError naming @p file, or the input
    /// file when @p file is something it references ("scene.gltf: cannot read 'a.bin': ...").
    [[nodiscard]] std::vector<std::uint8_t> readFile(const std::filesystem::path& file);
    /// Records a file read by a library on our behalf.
    void recordRead(const std::filesystem::path& file);
    /// Size of everything read so far: the bound for sizes the data itself claims.
    [[nodiscard]] std::uint64_t bytesRead() const noexcept { return bytesRead_; }

    /// True if @p name is one of the --dynamic names (and remembers that it was used).
    [[nodiscard]] bool isDynamicName(const std::string& name);

    /// Index of a material with glTF's defaults, created on first use.
    [[nodiscard]] std::uint32_t defaultMaterial();

    /// An image to decode: its encoded bytes and where they came from (for messages).
    struct EncodedImage {
        std::vector<std::uint8_t> bytes;
        std::filesystem::path file;  ///< the image file, or the scene file holding it
        std::string what;            ///< "" for an image file, else e.g. "image 2 'logo'"
        std::string mimeType;
    };

    /// Index of the texture known by @p key in @p colorSpace. On first use @p read supplies the
    /// encoded image (reading files in import order, so depfiles are deterministic); decoding
    /// happens later, in parallel, in decodeTextures(). Returns -1 without calling @p read when
    /// textures are off.
    [[nodiscard]] std::int32_t texture(const std::string& key, ColorSpace colorSpace,
                                       const std::function<EncodedImage()>& read);

    /// Decodes every texture registered so far into Scene::textures, in parallel. A failure
    /// fails the import with the error of the first failing texture in registration order.
    void decodeTextures();

    /// Validates and repairs the meshes (see finalizeScene) and warns about unused --dynamic
    /// names. Called after the importer and decodeTextures().
    void finish(MissingNormals missingNormals);

private:
    std::filesystem::path input_;
    const ImportOptions& options_;
    Scene& scene_;
    std::uint64_t bytesRead_ = 0;
    std::set<std::string> usedDynamicNames_;
    std::map<std::pair<std::string, ColorSpace>, std::int32_t> textures_;
    std::vector<std::pair<EncodedImage, ColorSpace>> pendingTextures_;
    std::int64_t defaultMaterial_ = -1;
};

/// Drops degenerate triangles, rejects non-finite positions, generates missing normals and
/// repairs invalid ones, removes empty meshes; fails if no triangle is left.
void finalizeScene(ImportContext& context, MissingNormals missingNormals);

/// Adds angle-weighted smooth normals (welding by position) or flat normals (unwelding) to a
/// mesh that has none.
void generateNormals(Mesh& mesh, MissingNormals mode);

/// Per vertex, the angle-weighted average of the normals of the triangles around its position
/// (vertices at equal positions weld, so UV seams do not split the shading); zero where no
/// triangle touches the position. Positions must be finite. The same bits for any thread count.
[[nodiscard]] std::vector<Vec3f> smoothNormals(const Mesh& mesh);
/// The unnormalised face normal of @p triangle in double precision (its length is twice the
/// triangle's area).
[[nodiscard]] Vec3d faceNormal(const Mesh& mesh, std::size_t triangle);

/// Lower-case extension with its dot.
[[nodiscard]] std::string lowerExtension(const std::filesystem::path& file);

}  // namespace vox::detail
