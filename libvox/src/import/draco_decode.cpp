#include "draco_decode.h"

#include <vox/base/error.h>

#include <draco/compression/config/compression_shared.h>
#include <draco/compression/decode.h>
#include <draco/compression/point_cloud/point_cloud_decoder.h>
#include <draco/core/data_buffer.h>
#include <draco/core/decoder_buffer.h>
#include <draco/core/draco_types.h>
#include <draco/core/varint_decoding.h>
#include <draco/mesh/mesh.h>
#include <draco/metadata/geometry_metadata.h>
#include <draco/metadata/metadata_decoder.h>

#include <optional>

namespace vox::detail {

namespace {

// Draco sizes its connectivity tables by the face and vertex counts at the start of the stream,
// before it reads the data they describe: a 118-byte file declaring 640 million faces made it
// reserve 2.5 GB, and its corner table would have taken 15 GB more (found by fuzz_drc). The
// densest encodings measured, flat regular grids at compression level 7, hold 3 600 faces per
// byte (8.4 million faces) and 4 300 (33.5 million); beyond 16384 is refused before Draco sizes
// anything.
constexpr std::uint64_t kMaxElementsPerByte = 16384;
#ifdef FUZZING_BUILD_MODE_UNSAFE_FOR_PRODUCTION
// The fuzzers allow no allocation over 2 GB, and Draco takes about 44 bytes per declared face
// before it reads one: a 38 KB glTF buffer view could still declare 600 million.
constexpr std::uint64_t kMaxElements = std::uint64_t{1} << 22;
#else
constexpr std::uint64_t kMaxElements = ~std::uint64_t{0};
#endif

struct DeclaredCounts {
    std::uint64_t faces = 0;
    std::uint64_t vertices = 0;
};

std::uint16_t bitstreamVersion(int major, int minor) {
    return static_cast<std::uint16_t>(DRACO_BITSTREAM_VERSION(major, minor));
}

/// The face and vertex counts a Draco mesh stream declares, read the way Draco's decoder reads
/// them, or nullopt where the stream ends or is no mesh before them (Draco then reports it).
std::optional<DeclaredCounts> declaredCounts(std::span<const std::uint8_t> bytes) {
    draco::DecoderBuffer buffer;
    buffer.Init(reinterpret_cast<const char*>(bytes.data()), bytes.size());
    draco::DracoHeader header;
    if (!draco::PointCloudDecoder::DecodeHeader(&buffer, &header).ok() ||
        header.encoder_type != draco::TRIANGULAR_MESH)
        return std::nullopt;
    const std::uint16_t version = bitstreamVersion(header.version_major, header.version_minor);
    buffer.set_bitstream_version(version);
    if (version >= bitstreamVersion(1, 3) && (header.flags & METADATA_FLAG_MASK)) {
        draco::GeometryMetadata metadata;
        if (!draco::MetadataDecoder().DecodeGeometryMetadata(&buffer, &metadata))
            return std::nullopt;
    }
    bool complete = true;
    // A count is a raw little-endian uint32 in streams older than varintsSince, a varint after.
    auto count = [&](std::uint16_t varintsSince) -> std::uint64_t {
        std::uint32_t value = 0;
        complete = complete && (version < varintsSince ? buffer.Decode(&value)
                                                       : draco::DecodeVarint(&value, &buffer));
        return value;
    };
    DeclaredCounts counts;
    if (header.encoder_method == draco::MESH_SEQUENTIAL_ENCODING) {
        counts.faces = count(bitstreamVersion(2, 2));
        counts.vertices = count(bitstreamVersion(2, 2));
    } else if (header.encoder_method == draco::MESH_EDGEBREAKER_ENCODING) {
        std::uint8_t traversal = 0, attributeData = 0;
        complete = buffer.Decode(&traversal);
        if (version < bitstreamVersion(2, 2))  // new vertices, stored before 2.2
            counts.vertices += count(bitstreamVersion(2, 0));
        counts.vertices += count(bitstreamVersion(2, 0));  // encoded vertices
        counts.faces = count(bitstreamVersion(2, 0));
        complete = complete && buffer.Decode(&attributeData);
        (void)count(bitstreamVersion(2, 0));               // symbols, at most one per face
        counts.vertices += count(bitstreamVersion(2, 0));  // one more per split symbol
    } else {
        return std::nullopt;
    }
    return complete ? std::optional<DeclaredCounts>(counts) : std::nullopt;
}

}  // namespace

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
    if (const std::optional<DeclaredCounts> counts = declaredCounts(bytes)) {
        const std::uint64_t limit = kMaxElementsPerByte * bytes.size();
        if (counts->faces > limit || counts->vertices > limit)
            throw InvalidDataError(file, prefix + "Draco data declares " +
                                             std::to_string(counts->faces) + " faces and " +
                                             std::to_string(counts->vertices) + " vertices in " +
                                             std::to_string(bytes.size()) + " bytes, more than " +
                                             std::to_string(kMaxElementsPerByte) + " per byte");
        if (counts->faces > kMaxElements || counts->vertices > kMaxElements)
            throw InvalidDataError(file, prefix + "Draco data declares more than " +
                                             std::to_string(kMaxElements) +
                                             " faces or vertices (fuzzing build)");
    }
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
    // Draco's own accessors check neither the point-to-value map's length nor that a value's last
    // byte lies inside the attribute's buffer (only its first): both are checked once here, for
    // every index the loop below may read.
    if (!attribute.is_mapping_identity() && attribute.indices_map_size() < points)
        throw InvalidDataError(file_, prefix + " maps " +
                                          std::to_string(attribute.indices_map_size()) +
                                          " of the mesh's " + std::to_string(points) + " points");
    if (points > 0 && attribute.size() > 0) {
        const draco::DataBuffer* buffer = attribute.buffer();
        const std::int64_t lastEnd =
            attribute.byte_offset() +
            attribute.byte_stride() * static_cast<std::int64_t>(attribute.size() - 1) +
            std::int64_t{available} * draco::DataTypeLength(attribute.data_type());
        if (!buffer || attribute.byte_offset() < 0 || attribute.byte_stride() < 0 ||
            lastEnd > static_cast<std::int64_t>(buffer->data_size()))
            throw InvalidDataError(file_, prefix + " has " + std::to_string(attribute.size()) +
                                              " values but its buffer holds fewer");
    }
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
