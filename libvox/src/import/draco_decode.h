// Draco mesh decoding shared by the .drc importer and glTF's KHR_draco_mesh_compression.
#pragma once

#include <vox/base/math.h>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace draco {
class Mesh;
class PointAttribute;
}  // namespace draco

namespace vox::detail {

/// A decoded Draco mesh with validated faces.
class DracoMesh {
public:
    /// Decodes @p bytes; @p what names the data in messages ("" for a whole .drc file).
    /// @throws InvalidDataError if the data is not a Draco triangle mesh.
    DracoMesh(std::span<const std::uint8_t> bytes, const std::filesystem::path& file,
              const std::string& what);
    ~DracoMesh();
    DracoMesh(DracoMesh&&) noexcept;

    [[nodiscard]] std::size_t pointCount() const;
    /// Three point indices per face.
    [[nodiscard]] std::vector<std::uint32_t> indices() const;
    /// The attribute with Draco's unique id, or nullptr.
    [[nodiscard]] const draco::PointAttribute* attributeById(std::uint32_t uniqueId) const;
    /// The first attribute of a Draco semantic (draco::GeometryAttribute::Type), or nullptr.
    [[nodiscard]] const draco::PointAttribute* attributeByType(int type) const;
    /// Per-point values of @p attribute as floats, @p components per point (missing components
    /// are 0, or 1 for a fourth colour component). Normalized integer data become [0,1]/[-1,1].
    [[nodiscard]] std::vector<float> floats(const draco::PointAttribute& attribute,
                                            int components) const;

private:
    std::unique_ptr<draco::Mesh> mesh_;
    std::filesystem::path file_;
    std::string what_;
};

}  // namespace vox::detail
