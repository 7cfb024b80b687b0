#include "draco_decode.h"

#include <vox/base/error.h>

#include <draco/compression/decode.h>
#include <draco/core/decoder_buffer.h>
#include <draco/mesh/mesh.h>

namespace vox::detail {

DracoMesh::DracoMesh(std::span<const std::uint8_t> bytes, const std::filesystem::path& file,
                     const std::string& what)
    : file_(file), what_(what) {
    const std::string prefix = what.empty() ? std::string() : what + ": ";
    draco::DecoderBuffer buffer;
    buffer.Init(reinterpret_cast<const char*>(bytes.data()), bytes.size());
    auto type = draco::Decoder::GetEncodedGeometryType(&buffer);
    if (!type.ok())
        throw InvalidDataError(file,
                               prefix + "not Draco data: " + type.status().error_msg_string());
    if (type.value() != draco::TRIANGULAR_MESH)
        throw InvalidDataError(file, prefix + "Draco data is a point cloud, not a triangle mesh");
    draco::Decoder decoder;
    auto decoded = decoder.DecodeMeshFromBuffer(&buffer);
    if (!decoded.ok())
        throw InvalidDataError(
            file, prefix + "cannot decode Draco mesh: " + decoded.status().error_msg_string());
    mesh_ = std::move(decoded).value();
    const std::uint32_t points = mesh_->num_points();
    for (draco::FaceIndex f(0); f < mesh_->num_faces(); ++f)
        for (int k = 0; k < 3; ++k)
            if (mesh_->face(f)[k].value() >= points)
                throw InvalidDataError(file, prefix + "Draco face " + std::to_string(f.value()) +
                                                 " refers to point " +
                                                 std::to_string(mesh_->face(f)[k].value()) +
                                                 " of " + std::to_string(points));
}

DracoMesh::~DracoMesh() = default;
DracoMesh::DracoMesh(DracoMesh&&) noexcept = default;

std::size_t DracoMesh::pointCount() const { return mesh_->num_points(); }

std::vector<std::uint32_t> DracoMesh::indices() const {
    std::vector<std::uint32_t> out;
    out.reserve(static_cast<std::size_t>(mesh_->num_faces()) * 3);
    for (draco::FaceIndex f(0); f < mesh_->num_faces(); ++f)
        for (int k = 0; k < 3; ++k) out.push_back(mesh_->face(f)[k].value());
    return out;
}

const draco::PointAttribute* DracoMesh::attributeById(std::uint32_t uniqueId) const {
    return mesh_->GetAttributeByUniqueId(uniqueId);
}

const draco::PointAttribute* DracoMesh::attributeByType(int type) const {
    return mesh_->GetNamedAttribute(static_cast<draco::GeometryAttribute::Type>(type));
}

std::vector<float> DracoMesh::floats(const draco::PointAttribute& attribute, int components) const {
    const std::string prefix = (what_.empty() ? std::string() : what_ + ": ") + "Draco attribute " +
                               std::to_string(attribute.unique_id());
    // Booleans are no coordinates, and Draco converts their stored bytes by loading them as bool,
    // undefined behaviour for any byte but 0 and 1 (found by fuzz_drc).
    if (attribute.data_type() < draco::DT_INT8 || attribute.data_type() > draco::DT_FLOAT64)
        throw InvalidDataError(file_, prefix + " has data type " +
                                          std::to_string(attribute.data_type()) + ", not numbers");
    const std::size_t points = mesh_->num_points();
    const int available = std::min<int>(attribute.num_components(), components);
    std::vector<float> out(points * static_cast<std::size_t>(components), 0.0f);
    float value[16] = {};
    for (draco::PointIndex p(0); p < mesh_->num_points(); ++p) {
        const draco::AttributeValueIndex index = attribute.mapped_index(p);
        if (index.value() >= attribute.size() ||
            !attribute.ConvertValue<float>(index, static_cast<std::int8_t>(available), value))
            throw InvalidDataError(file_, prefix + " cannot be read as numbers");
        for (int c = 0; c < components; ++c)
            out[p.value() * static_cast<std::size_t>(components) + c] =
                c < available ? value[c] : (c == 3 ? 1.0f : 0.0f);
    }
    return out;
}

}  // namespace vox::detail
