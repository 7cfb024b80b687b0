// Hostile numbers in every importer (issue 10), checked the same way whatever the format: NaN or
// infinite positions and coordinates beyond ±1e30 are invalid data, and so is a scene whose
// longest side is below 1e-30 (zero or denormal size); NaN or infinite normals and texture
// coordinates are repaired with a warning (an error in strict mode) (docs/import.md).
#include <vox/base/error.h>
#include <vox/import.h>

#include "gltf_builder.h"
#include "import_expect.h"
#include "test_support.h"

#include <draco/compression/encode.h>
#include <draco/mesh/triangle_soup_mesh_builder.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <optional>

using vox::test::importError;
using vox::test::importOk;
using vox::test::ScratchDir;

namespace {

using Vec3 = std::array<float, 3>;
using Vec2 = std::array<float, 2>;

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr int kFaces[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};  // outward

/// A tetrahedron with optional per-vertex normals and texture coordinates, written in any format.
struct Tetrahedron {
    std::array<Vec3, 4> positions{{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
    std::optional<std::array<Vec3, 4>> normals;
    std::optional<std::array<Vec2, 4>> uvs;

    [[nodiscard]] Tetrahedron scaled(float s) const {
        Tetrahedron t = *this;
        for (Vec3& p : t.positions)
            for (float& c : p) c *= s;
        return t;
    }
    [[nodiscard]] Tetrahedron withNormals() const {
        Tetrahedron t = *this;
        t.normals = std::array<Vec3, 4>{{{-1, -1, -1}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
        return t;
    }
    [[nodiscard]] Tetrahedron withUvs() const {
        Tetrahedron t = *this;
        t.uvs = std::array<Vec2, 4>{{{0, 0}, {1, 0}, {0, 1}, {0.5f, 0.5f}}};
        return t;
    }
};

enum class Format { Obj, Ply, Stl, Off, Gltf, Drc };
constexpr Format kAllFormats[] = {Format::Obj, Format::Ply,  Format::Stl,
                                  Format::Off, Format::Gltf, Format::Drc};
/// The formats that store normals and texture coordinates.
constexpr Format kAttributeFormats[] = {Format::Obj, Format::Ply, Format::Gltf, Format::Drc};

const char* extensionOf(Format f) {
    switch (f) {
        case Format::Obj:
            return ".obj";
        case Format::Ply:
            return ".ply";
        case Format::Stl:
            return ".stl";
        case Format::Off:
            return ".off";
        case Format::Gltf:
            return ".gltf";
        case Format::Drc:
            return ".drc";
    }
    return "";
}

std::string number(float v) {
    char text[32];
    std::snprintf(text, sizeof text, "%.9g", double(v));
    return text;
}

template <typename T>
void append(std::string& bytes, const T& value) {
    bytes.append(reinterpret_cast<const char*>(&value), sizeof value);
}

void writeObj(const std::filesystem::path& file, const Tetrahedron& t) {
    std::string text;
    for (const Vec3& p : t.positions)
        text += "v " + number(p[0]) + " " + number(p[1]) + " " + number(p[2]) + "\n";
    if (t.normals)
        for (const Vec3& n : *t.normals)
            text += "vn " + number(n[0]) + " " + number(n[1]) + " " + number(n[2]) + "\n";
    if (t.uvs)
        for (const Vec2& uv : *t.uvs) text += "vt " + number(uv[0]) + " " + number(uv[1]) + "\n";
    for (const auto& face : kFaces) {
        text += "f";
        for (int v : face) {
            const std::string i = std::to_string(v + 1);
            text += " " + i + (t.uvs || t.normals ? "/" + (t.uvs ? i : "") : "") +
                    (t.normals ? "/" + i : "");
        }
        text += "\n";
    }
    vox::test::writeText(file, text);
}

void writePly(const std::filesystem::path& file, const Tetrahedron& t) {
    // Binary, so that NaN and infinity are stored exactly.
    std::string bytes =
        "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float "
        "y\nproperty float z\n";
    if (t.normals) bytes += "property float nx\nproperty float ny\nproperty float nz\n";
    if (t.uvs) bytes += "property float s\nproperty float t\n";
    bytes += "element face 4\nproperty list uchar int vertex_indices\nend_header\n";
    for (int v = 0; v < 4; ++v) {
        for (float c : t.positions[v]) append(bytes, c);
        if (t.normals)
            for (float c : (*t.normals)[v]) append(bytes, c);
        if (t.uvs)
            for (float c : (*t.uvs)[v]) append(bytes, c);
    }
    for (const auto& face : kFaces) {
        append(bytes, std::uint8_t{3});
        for (int v : face) append(bytes, std::int32_t{v});
    }
    vox::test::writeText(file, bytes);
}

void writeStl(const std::filesystem::path& file, const Tetrahedron& t) {
    std::string bytes(80, ' ');
    append(bytes, std::uint32_t{4});
    for (const auto& face : kFaces) {
        for (int i = 0; i < 3; ++i)
            append(bytes, 0.0f);  // STL normals are ignored (flat from the geometry)
        for (int v : face)
            for (float c : t.positions[v]) append(bytes, c);
        append(bytes, std::uint16_t{0});
    }
    vox::test::writeText(file, bytes);
}

void writeOff(const std::filesystem::path& file, const Tetrahedron& t) {
    std::string text = "OFF\n4 4 0\n";
    for (const Vec3& p : t.positions)
        text += number(p[0]) + " " + number(p[1]) + " " + number(p[2]) + "\n";
    for (const auto& face : kFaces)
        text += "3 " + std::to_string(face[0]) + " " + std::to_string(face[1]) + " " +
                std::to_string(face[2]) + "\n";
    vox::test::writeText(file, text);
}

void writeGltf(const std::filesystem::path& file, const Tetrahedron& t) {
    vox::scenes::GltfBuilder gltf;
    vox::scenes::GltfBuilder::Primitive p;
    for (int v = 0; v < 4; ++v) {
        p.positions.insert(p.positions.end(), t.positions[v].begin(), t.positions[v].end());
        if (t.normals)
            p.normals.insert(p.normals.end(), (*t.normals)[v].begin(), (*t.normals)[v].end());
        if (t.uvs) p.uvs.insert(p.uvs.end(), (*t.uvs)[v].begin(), (*t.uvs)[v].end());
    }
    for (const auto& face : kFaces) p.indices.insert(p.indices.end(), face, face + 3);
    const int mesh = gltf.addMesh("tetrahedron", {p});
    // The accessor's min/max would be JSON null for NaN (a JSON error, not the one tested here).
    gltf.json()["accessors"][0].erase("min");
    gltf.json()["accessors"][0].erase("max");
    gltf.setSceneRoots({gltf.addNode({"tetrahedron", mesh})});
    gltf.write(file, vox::scenes::BufferStorage::DataUri);
}

void writeDrc(const std::filesystem::path& file, const Tetrahedron& t) {
    draco::TriangleSoupMeshBuilder builder;
    builder.Start(4);
    const int pos = builder.AddAttribute(draco::GeometryAttribute::POSITION, 3, draco::DT_FLOAT32);
    const int nor =
        t.normals ? builder.AddAttribute(draco::GeometryAttribute::NORMAL, 3, draco::DT_FLOAT32)
                  : -1;
    const int tex =
        t.uvs ? builder.AddAttribute(draco::GeometryAttribute::TEX_COORD, 2, draco::DT_FLOAT32)
              : -1;
    for (int f = 0; f < 4; ++f) {
        const draco::FaceIndex face(f);
        const int* v = kFaces[f];
        builder.SetAttributeValuesForFace(pos, face, t.positions[v[0]].data(),
                                          t.positions[v[1]].data(), t.positions[v[2]].data());
        if (t.normals)
            builder.SetAttributeValuesForFace(nor, face, (*t.normals)[v[0]].data(),
                                              (*t.normals)[v[1]].data(), (*t.normals)[v[2]].data());
        if (t.uvs)
            builder.SetAttributeValuesForFace(tex, face, (*t.uvs)[v[0]].data(),
                                              (*t.uvs)[v[1]].data(), (*t.uvs)[v[2]].data());
    }
    const auto mesh = builder.Finalize();
    ASSERT_TRUE(mesh);
    draco::Encoder encoder;
    // Unquantized: the values as given, NaN and infinity included.
    encoder.SetEncodingMethod(draco::MESH_SEQUENTIAL_ENCODING);
    for (auto type : {draco::GeometryAttribute::POSITION, draco::GeometryAttribute::NORMAL,
                      draco::GeometryAttribute::TEX_COORD})
        encoder.SetAttributeQuantization(type, 0);
    draco::EncoderBuffer buffer;
    const draco::Status status = encoder.EncodeMeshToBuffer(*mesh, &buffer);
    ASSERT_TRUE(status.ok()) << status.error_msg_string();
    vox::test::writeText(file, std::string(buffer.data(), buffer.size()));
}

std::filesystem::path write(const ScratchDir& dir, const std::string& name, Format format,
                            const Tetrahedron& t) {
    const auto file = dir / (name + extensionOf(format));
    switch (format) {
        case Format::Obj:
            writeObj(file, t);
            break;
        case Format::Ply:
            writePly(file, t);
            break;
        case Format::Stl:
            writeStl(file, t);
            break;
        case Format::Off:
            writeOff(file, t);
            break;
        case Format::Gltf:
            writeGltf(file, t);
            break;
        case Format::Drc:
            writeDrc(file, t);
            break;
    }
    return file;
}

bool containsWarning(const vox::Scene& scene, const std::string& text) {
    for (const std::string& warning : scene.warnings)
        if (warning.find(text) != std::string::npos) return true;
    return false;
}

vox::ImportOptions strict() {
    vox::ImportOptions options;
    options.strict = true;
    return options;
}

}  // namespace

TEST(ImportLimits, TheSameTetrahedronImportsFromEveryFormat) {
    // The baseline the other tests change one number of.
    ScratchDir dir;
    for (Format format : kAllFormats) {
        const auto file = write(dir, "plain", format, Tetrahedron{});
        SCOPED_TRACE(file.string());
        const vox::Scene scene = importOk(file);
        EXPECT_EQ(scene.triangleCount(), 4u);
        EXPECT_TRUE(scene.warnings.empty()) << scene.warnings.front();
        const vox::Bounds3f b = scene.bounds();
        EXPECT_EQ(b.max.x, 1.0f);
        EXPECT_EQ(b.min.y, 0.0f);
    }
}

TEST(ImportLimits, NonFinitePositionsAreInvalidInEveryFormat) {
    ScratchDir dir;
    for (Format format : kAllFormats)
        for (float bad : {kNaN, kInf, -kInf}) {
            if (format == Format::Off && !std::isnan(bad))
                continue;  // "inf" is no number to OpenMesh's OFF reader: tested below
            Tetrahedron t;
            t.positions[2][1] = bad;
            const auto file = write(dir, "bad", format, t);
            SCOPED_TRACE(file.string() + " with " + number(bad));
            const std::string message = importError<vox::InvalidDataError>(file);
            if (format != Format::Off) {
                EXPECT_NE(message.find("has a non-finite position"), std::string::npos) << message;
            }
        }
}

TEST(ImportLimits, CoordinatesBeyondOneE30AreInvalidInEveryFormat) {
    ScratchDir dir;
    for (Format format : kAllFormats) {
        SCOPED_TRACE(extensionOf(format));
        // 1e30 itself is accepted (the largest scene libvox takes), 1.0001e30 is not.
        const vox::Scene largest =
            importOk(write(dir, "largest", format, Tetrahedron{}.scaled(1e30f)));
        EXPECT_EQ(largest.bounds().max.z, 1e30f);
        Tetrahedron t;
        t.positions[3][2] = -1.0001e30f;
        const std::string message =
            importError<vox::InvalidDataError>(write(dir, "huge", format, t));
        EXPECT_NE(message.find(" has a coordinate beyond ±1e30 (absurd scale)"), std::string::npos)
            << message;
        const std::string scaled = importError<vox::InvalidDataError>(
            write(dir, "scaled", format, Tetrahedron{}.scaled(3e38f)));
        EXPECT_NE(scaled.find("beyond ±1e30"), std::string::npos) << scaled;
    }
}

TEST(ImportLimits, AScenesLongestSideBelowOneEMinus30IsInvalidInEveryFormat) {
    ScratchDir dir;
    for (Format format : kAllFormats) {
        SCOPED_TRACE(extensionOf(format));
        const vox::Scene smallest =
            importOk(write(dir, "smallest", format, Tetrahedron{}.scaled(1e-30f)));
        EXPECT_EQ(smallest.bounds().max.x, 1e-30f);
        EXPECT_EQ(smallest.triangleCount(), 4u);
        for (float s : {9e-31f, 1e-38f, 1e-44f}) {  // normal, and denormal floats
            const std::string message = importError<vox::InvalidDataError>(
                write(dir, "tiny", format, Tetrahedron{}.scaled(s)));
            EXPECT_NE(message.find("the scene's longest side is "), std::string::npos) << message;
            EXPECT_NE(message.find(", below 1e-30 (absurd scale: zero or denormal size)"),
                      std::string::npos)
                << message;
        }
        // Far from the origin but small: the extent counts, not the coordinates.
        Tetrahedron offset = Tetrahedron{}.scaled(1e-3f);
        for (Vec3& p : offset.positions) p[0] += 1000.0f;
        EXPECT_EQ(importOk(write(dir, "offset", format, offset)).triangleCount(), 4u);
    }
}

TEST(ImportLimits, NonFiniteNormalsAreRepairedWithAWarningInEveryFormatThatHasNormals) {
    ScratchDir dir;
    for (Format format : kAttributeFormats)
        for (float bad : {kNaN, kInf}) {
            Tetrahedron t = Tetrahedron{}.withNormals();
            (*t.normals)[1] = {bad, 0, 0};
            const auto file = write(dir, "normal", format, t);
            SCOPED_TRACE(file.string() + " with " + number(bad));
            const vox::Scene scene = importOk(file);
            EXPECT_TRUE(containsWarning(scene, "zero or non-finite normal(s)"))
                << (scene.warnings.empty() ? "" : scene.warnings.front());
            for (const vox::Mesh& mesh : scene.meshes)
                for (const vox::Vec3f& n : mesh.normals) {
                    EXPECT_TRUE(vox::isFinite(n));
                    EXPECT_NEAR(vox::length(n), 1.0f, 1e-5f);
                }
            const std::string message = importError<vox::InvalidDataError>(file, strict());
            EXPECT_NE(message.find("non-finite normal(s) (an error in strict mode)"),
                      std::string::npos)
                << message;
        }
}

TEST(ImportLimits, HugeAndTinyFiniteNormalsKeepTheirDirection) {
    ScratchDir dir;
    for (Format format : {Format::Obj, Format::Ply,
                          Format::Gltf}) {  // Draco quantizes normals to directions anyway
        Tetrahedron t = Tetrahedron{}.withNormals();
        (*t.normals)[1] = {1e30f, 0, 0};
        (*t.normals)[2] = {0, 1e-30f, 0};
        const auto file = write(dir, "normals", format, t);
        SCOPED_TRACE(file.string());
        const vox::Scene scene = importOk(file, strict());
        ASSERT_EQ(scene.meshes.size(), 1u);
        const vox::Mesh& mesh = scene.meshes[0];
        // Each vertex with the huge normal now has (1, 0, 0); with the tiny one (0, 1, 0).
        int huge = 0, tiny = 0;
        for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
            if (mesh.positions[v].x == 1.0f) {
                EXPECT_EQ(mesh.normals[v].x, 1.0f);
                ++huge;
            }
            if (mesh.positions[v].y == 1.0f) {
                EXPECT_EQ(mesh.normals[v].y, 1.0f);
                ++tiny;
            }
        }
        EXPECT_GT(huge, 0);
        EXPECT_GT(tiny, 0);
    }
}

TEST(ImportLimits,
     NonFiniteTextureCoordinatesAreReplacedByZeroWithAWarningInEveryFormatThatHasThem) {
    ScratchDir dir;
    for (Format format : kAttributeFormats)
        for (float bad : {kNaN, -kInf}) {
            Tetrahedron t = Tetrahedron{}.withUvs();
            (*t.uvs)[3] = {0.25f, bad};
            const auto file = write(dir, "uv", format, t);
            SCOPED_TRACE(file.string() + " with " + number(bad));
            const vox::Scene scene = importOk(file);
            EXPECT_TRUE(containsWarning(scene, "non-finite texture coordinate(s) by 0"));
            int replaced = 0;
            for (const vox::Mesh& mesh : scene.meshes) {
                ASSERT_EQ(mesh.uvs.size(), 1u);
                for (const vox::Vec2f& uv : mesh.uvs[0]) {
                    EXPECT_TRUE(std::isfinite(uv.x) && std::isfinite(uv.y));
                    replaced += uv.x == 0 && uv.y == 0 &&
                                mesh.positions[&uv - mesh.uvs[0].data()].z == 1.0f;
                }
            }
            EXPECT_GT(replaced, 0) << "the bad vertex's coordinate is (0, 0)";
            const std::string message = importError<vox::InvalidDataError>(file, strict());
            EXPECT_NE(
                message.find("non-finite texture coordinate(s) by 0 (an error in strict mode)"),
                std::string::npos)
                << message;
        }
}
