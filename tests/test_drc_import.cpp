#include <vox/base/error.h>
#include <vox/import.h>

#include "import_expect.h"
#include "test_support.h"

#include <draco/compression/encode.h>
#include <draco/mesh/triangle_soup_mesh_builder.h>
#include <draco/point_cloud/point_cloud_builder.h>

using vox::test::ScratchDir;

namespace {

std::vector<std::uint8_t> encode(const draco::PointCloud& cloud, bool mesh) {
    draco::Encoder encoder;
    draco::EncoderBuffer buffer;
    const draco::Status status =
        mesh ? encoder.EncodeMeshToBuffer(static_cast<const draco::Mesh&>(cloud), &buffer)
             : encoder.EncodePointCloudToBuffer(cloud, &buffer);
    EXPECT_TRUE(status.ok()) << status.error_msg_string();
    return {buffer.data(), buffer.data() + buffer.size()};
}

/// A quad's two triangles, Draco-encoded with @p method (draco::MeshEncoderMethod).
std::vector<std::uint8_t> encodedQuad(int method) {
    draco::TriangleSoupMeshBuilder builder;
    builder.Start(2);
    const int pos = builder.AddAttribute(draco::GeometryAttribute::POSITION, 3, draco::DT_FLOAT32);
    const float p[4][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
    builder.SetAttributeValuesForFace(pos, draco::FaceIndex(0), p[0], p[1], p[2]);
    builder.SetAttributeValuesForFace(pos, draco::FaceIndex(1), p[0], p[2], p[3]);
    draco::Encoder encoder;
    encoder.SetEncodingMethod(method);
    draco::EncoderBuffer buffer;
    EXPECT_TRUE(encoder.EncodeMeshToBuffer(*builder.Finalize(), &buffer).ok());
    return {buffer.data(), buffer.data() + buffer.size()};
}

/// The offset just past the unsigned LEB128 varint at @p offset.
std::size_t afterVarint(const std::vector<std::uint8_t>& bytes, std::size_t offset) {
    while (bytes.at(offset) & 0x80) ++offset;
    return offset + 1;
}

/// @p bytes with the unsigned LEB128 varint at @p offset replaced by @p value.
std::vector<std::uint8_t> withVarint(std::vector<std::uint8_t> bytes, std::size_t offset,
                                     std::uint32_t value) {
    const std::size_t end = afterVarint(bytes, offset);
    std::vector<std::uint8_t> encoded;
    do {
        encoded.push_back(static_cast<std::uint8_t>((value & 0x7f) | (value > 0x7f ? 0x80 : 0)));
        value >>= 7;
    } while (value);
    bytes.erase(bytes.begin() + std::ptrdiff_t(offset), bytes.begin() + std::ptrdiff_t(end));
    bytes.insert(bytes.begin() + std::ptrdiff_t(offset), encoded.begin(), encoded.end());
    return bytes;
}

}  // namespace

TEST(DrcImport, TriangleMeshWithColoursAndUvs) {
    ScratchDir dir;
    draco::TriangleSoupMeshBuilder builder;
    builder.Start(2);
    const int pos = builder.AddAttribute(draco::GeometryAttribute::POSITION, 3, draco::DT_FLOAT32);
    const int col = builder.AddAttribute(draco::GeometryAttribute::COLOR, 3, draco::DT_UINT8);
    const int tex = builder.AddAttribute(draco::GeometryAttribute::TEX_COORD, 2, draco::DT_FLOAT32);
    const float p[4][3] = {{0, 0, 0}, {4, 0, 0}, {4, 4, 0}, {0, 4, 0}};
    const std::uint8_t c[4][3] = {{255, 0, 0}, {0, 255, 0}, {0, 0, 255}, {255, 255, 255}};
    const float t[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    const int faces[2][3] = {{0, 1, 2}, {0, 2, 3}};
    for (int f = 0; f < 2; ++f) {
        const draco::FaceIndex face(f);
        builder.SetAttributeValuesForFace(pos, face, p[faces[f][0]], p[faces[f][1]],
                                          p[faces[f][2]]);
        builder.SetAttributeValuesForFace(col, face, c[faces[f][0]], c[faces[f][1]],
                                          c[faces[f][2]]);
        builder.SetAttributeValuesForFace(tex, face, t[faces[f][0]], t[faces[f][1]],
                                          t[faces[f][2]]);
    }
    auto mesh = builder.Finalize();
    mesh->attribute(col)->set_normalized(true);
    vox::test::writeBinary(dir / "quad.drc", encode(*mesh, true));

    const vox::Scene scene = vox::importScene(dir / "quad.drc");
    ASSERT_EQ(scene.meshes.size(), 1u);
    const vox::Mesh& m = scene.meshes[0];
    EXPECT_EQ(m.triangleCount(), 2u);
    EXPECT_EQ(m.name, "quad");
    const vox::Bounds3f b = scene.bounds();
    EXPECT_NEAR(b.max.x, 4.0f, 1e-3f);
    EXPECT_NEAR(b.max.y, 4.0f, 1e-3f);
    ASSERT_EQ(m.colors.size(), m.positions.size());
    ASSERT_EQ(m.uvs.size(), 1u);
    for (std::size_t v = 0; v < m.positions.size(); ++v) {
        const float sum = m.colors[v].x + m.colors[v].y + m.colors[v].z;
        EXPECT_GE(sum, 0.99f);  // every corner has one full channel or white
        EXPECT_NEAR(m.uvs[0][v].y, 1.0f - m.positions[v].y / 4.0f, 1e-3f)
            << "v flipped to libvox's convention";
    }
}

TEST(DrcImport, PointCloudsAndGarbageAreInvalid) {
    ScratchDir dir;
    draco::PointCloudBuilder builder;
    builder.Start(2);
    const int pos = builder.AddAttribute(draco::GeometryAttribute::POSITION, 3, draco::DT_FLOAT32);
    const float a[3] = {0, 0, 0}, b[3] = {1, 1, 1};
    builder.SetAttributeValueForPoint(pos, draco::PointIndex(0), a);
    builder.SetAttributeValueForPoint(pos, draco::PointIndex(1), b);
    vox::test::writeBinary(dir / "points.drc", encode(*builder.Finalize(false), false));
    try {
        (void)vox::importScene(dir / "points.drc");
        FAIL();
    } catch (const vox::InvalidDataError& e) {
        EXPECT_NE(std::string(e.what()).find("point cloud"), std::string::npos) << e.what();
    }
    vox::test::writeText(dir / "junk.drc", "DRACO and then nonsense bytes that decode to nothing");
    EXPECT_THROW((void)vox::importScene(dir / "junk.drc"), vox::InvalidDataError);
    vox::test::writeText(dir / "nodraco.drc", "plain text");
    EXPECT_THROW((void)vox::importScene(dir / "nodraco.drc"), vox::InvalidDataError);
}

TEST(DrcImport, BooleanAttributesAreInvalidData) {
    // Found by fuzz_drc: a position attribute stored as Draco booleans, whose bytes Draco loads as
    // bool when converting them (undefined behaviour for bytes other than 0 and 1).
    const std::string message = vox::test::importError<vox::InvalidDataError>(
        std::filesystem::path(LIBVOX_FUZZ_CORPUS) / "drc" / "found-bool-attribute.drc");
    EXPECT_NE(message.find("has data type 11, not numbers"), std::string::npos) << message;
}

TEST(DrcImport, CountsBeyondWhatTheDataCanHoldAreInvalidData) {
    // Found by fuzz_drc: 118 bytes whose edgebreaker header declares 640 million faces, for
    // which Draco reserved 2.5 GB before reading a symbol.
    const std::string message = vox::test::importError<vox::InvalidDataError>(
        std::filesystem::path(LIBVOX_FUZZ_CORPUS) / "drc" / "found-declared-faces.drc");
    EXPECT_NE(message.find("in 118 bytes, more than 16384 per byte"), std::string::npos) << message;
}

TEST(DrcImport, CurrentBitstreamCountsAreCheckedForBothMethods) {
    // Today's bitstream (2.2) stores the counts as varints after the 11-byte header: the
    // sequential method the face count first, then the point count; edgebreaker a traversal byte,
    // the encoded vertices, then the faces.
    ScratchDir dir;
    constexpr std::size_t kHeader = 11;
    const std::vector<std::uint8_t> sequential = encodedQuad(draco::MESH_SEQUENTIAL_ENCODING);
    const std::vector<std::uint8_t> edgebreaker = encodedQuad(draco::MESH_EDGEBREAKER_ENCODING);
    ASSERT_EQ(sequential.at(8), draco::MESH_SEQUENTIAL_ENCODING);
    ASSERT_EQ(edgebreaker.at(8), draco::MESH_EDGEBREAKER_ENCODING);
    ASSERT_EQ(sequential.at(kHeader), 2u) << "faces";
    ASSERT_EQ(sequential.at(afterVarint(sequential, kHeader)), 4u) << "points";
    const std::size_t edgebreakerFaces = afterVarint(edgebreaker, kHeader + 1);
    ASSERT_EQ(edgebreaker.at(edgebreakerFaces), 2u) << "faces";

    // Unchanged, both import.
    vox::test::writeBinary(dir / "seq.drc", sequential);
    vox::test::writeBinary(dir / "eb.drc", edgebreaker);
    EXPECT_EQ(vox::importScene(dir / "seq.drc").triangleCount(), 2u);
    EXPECT_EQ(vox::importScene(dir / "eb.drc").triangleCount(), 2u);

    const auto refused = [&](const std::vector<std::uint8_t>& bytes, const std::string& expected) {
        vox::test::writeBinary(dir / "big.drc", bytes);
        const std::string message = vox::test::importError<vox::InvalidDataError>(dir / "big.drc");
        EXPECT_NE(message.find(expected), std::string::npos) << message;
        EXPECT_NE(message.find("per byte"), std::string::npos) << message;
    };
    constexpr std::uint32_t kHuge = 1u << 28;  // beyond 16384 per byte of any of these streams
    refused(withVarint(sequential, kHeader, kHuge), "declares 268435456 faces and 4 vertices");
    refused(withVarint(sequential, afterVarint(sequential, kHeader), kHuge),
            "declares 2 faces and 268435456 vertices");
    refused(withVarint(edgebreaker, edgebreakerFaces, kHuge), "declares 268435456 faces");
}
