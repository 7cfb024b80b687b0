#include <vox/base/error.h>
#include <vox/import.h>

#include "import_expect.h"
#include "test_support.h"

#include <chrono>
#include <cstring>

using vox::test::importError;
using vox::test::importOk;
using vox::test::ScratchDir;
using vox::test::writeBinary;
using vox::test::writeText;

namespace {

std::vector<std::uint8_t> bytesOf(const std::string& text) { return {text.begin(), text.end()}; }

template <typename T>
void append(std::vector<std::uint8_t>& out, T value) {
    const auto* p = reinterpret_cast<const std::uint8_t*>(&value);
    out.insert(out.end(), p, p + sizeof(T));
}

}  // namespace

TEST(OpenMeshImport, AsciiPlyWithVertexColoursAndQuads) {
    ScratchDir dir;
    writeText(dir / "q.ply",
              "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float "
              "y\nproperty float z\n"
              "property uchar red\nproperty uchar green\nproperty uchar blue\nelement face 1\n"
              "property list uchar int vertex_indices\nend_header\n"
              "0 0 0 255 0 0\n1 0 0 0 255 0\n1 1 0 0 0 255\n0 1 0 128 128 128\n4 0 1 2 3\n");
    const vox::Scene scene = vox::importScene(dir / "q.ply");
    ASSERT_EQ(scene.meshes.size(), 1u);
    const vox::Mesh& m = scene.meshes[0];
    EXPECT_EQ(m.triangleCount(), 2u);
    ASSERT_EQ(m.colors.size(), 4u);
    EXPECT_FLOAT_EQ(m.colors[0].x, 1.0f);
    EXPECT_FLOAT_EQ(m.colors[1].y, 1.0f);
    EXPECT_NEAR(m.colors[3].x, vox::srgbToLinear(128.0f / 255.0f), 1e-6f);
    for (const vox::Vec3f& n : m.normals) EXPECT_NEAR(n.z, 1.0f, 1e-6f);
}

TEST(OpenMeshImport, BinaryPly) {
    ScratchDir dir;
    auto bytes = bytesOf(
        "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float "
        "y\n"
        "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n");
    for (float v : {0.f, 0.f, 0.f, 2.f, 0.f, 0.f, 0.f, 3.f, 0.f}) append(bytes, v);
    append<std::uint8_t>(bytes, 3);
    for (std::int32_t i : {0, 1, 2}) append(bytes, i);
    writeBinary(dir / "b.ply", bytes);
    const vox::Scene scene = vox::importScene(dir / "b.ply");
    EXPECT_EQ(scene.triangleCount(), 1u);
    EXPECT_EQ(scene.bounds().max, (vox::Vec3f{2, 3, 0}));
}

TEST(OpenMeshImport, NonManifoldFacesKeepTheirVertexAttributes) {
    ScratchDir dir;
    // Three triangles on one edge (0-1): OpenMesh re-adds the third on copied vertices; libvox
    // maps it back so that its vertex colours survive.
    writeText(dir / "fin.ply",
              "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float "
              "y\nproperty float z\n"
              "property uchar red\nproperty uchar green\nproperty uchar blue\nelement face 3\n"
              "property list uchar int vertex_indices\nend_header\n"
              "0 0 0 255 255 255\n1 0 0 255 255 255\n0 1 0 255 0 0\n0 -1 0 0 255 0\n0 0 1 0 0 255\n"
              "3 0 1 2\n3 1 0 3\n3 0 1 4\n");
    const vox::Scene scene = vox::importScene(dir / "fin.ply");
    const vox::Mesh& m = scene.meshes.at(0);
    EXPECT_EQ(m.triangleCount(), 3u);
    EXPECT_EQ(m.positions.size(), 5u);
    for (const vox::Vec4f& c : m.colors)
        EXPECT_GT(c.x + c.y + c.z, 0.99f) << "a vertex lost its colour";
}

TEST(OpenMeshImport, HeaderCountsBeyondTheFileAreRejectedWithoutAllocating) {
    ScratchDir dir;
    writeText(
        dir / "huge.ply",
        "ply\nformat ascii 1.0\nelement vertex 999999999999\nproperty float x\nproperty float y\n"
        "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 "
        "0\n");
    writeText(dir / "huge.off", "OFF\n3 999999999999 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
    for (const char* name : {"huge.ply", "huge.off"}) {
        const auto start = std::chrono::steady_clock::now();
        const std::string message = importError<vox::InvalidDataError>(dir / name);
        EXPECT_NE(message.find("999999999999"), std::string::npos) << message;
        EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(2)) << name;
    }
}

/// A binary PLY of one triangle whose header has @p format as its format line and @p faceList as
/// the face element's property line.
std::vector<std::uint8_t> binaryPlyTriangle(
    const std::string& format,
    const std::string& faceList = "property list uchar int vertex_indices") {
    std::vector<std::uint8_t> bytes =
        bytesOf("ply\n" + format +
                "\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                "element face 1\n" +
                faceList + "\nend_header\n");
    for (float v : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f}) append(bytes, v);
    append<std::uint8_t>(bytes, 3);
    for (std::int32_t i : {0, 1, 2}) append(bytes, i);
    return bytes;
}

TEST(OpenMeshImport, PlyFormatLinesOpenMeshWouldLoopOnAreInvalid) {
    // Found by fuzz_mesh: OpenMesh's PLY header loop never ends once the version fails to parse.
    // It reads the version into a float: a double's range is not enough ("1.01e39", found by
    // fuzz_mesh), and neither is from_chars' spelling of infinity and NaN.
    ScratchDir dir;
    for (const char* format :
         {"format binary_little_endian uch1.0", "format ascii", "format ascii 1.0 extra",
          "format ascii 1.0x", "format binary_little_endian 1.01e39", "format ascii inf",
          "format ascii -INF", "format ascii nan"}) {
        writeBinary(dir / "format.ply", binaryPlyTriangle(format));
        const std::string message = importError<vox::InvalidDataError>(dir / "format.ply");
        EXPECT_NE(message.find(std::string("PLY header: malformed format line '") + format),
                  std::string::npos)
            << message;
    }
    // OpenMesh reads the line after "ply" as the format line whatever its first word: the format
    // line must come first ("fo\x94mat binary_little_endian uch1.0" hung it, found by fuzz_mesh).
    for (const char* first :
         {"fo\x94mat binary_little_endian uch1.0\nformat binary_little_endian 1.0",
          "comment first\nformat binary_little_endian 1.0"}) {
        writeBinary(dir / "format.ply", binaryPlyTriangle(first));
        const std::string message = importError<vox::InvalidDataError>(dir / "format.ply");
        EXPECT_NE(message.find("PLY header: the line after 'ply' is '"), std::string::npos)
            << message;
    }
    // Plain versions still read.
    for (const char* format : {"format binary_little_endian 1.0", "format binary_little_endian 1",
                               "format binary_little_endian 2.5e0"}) {
        writeBinary(dir / "format.ply", binaryPlyTriangle(format));
        EXPECT_EQ(vox::importScene(dir / "format.ply").triangleCount(), 1u) << format;
    }
}

TEST(OpenMeshImport, PlyElementsOfNoPropertiesMayNotCountBeyondTheFile) {
    // OpenMesh reads an element count as a 32-bit integer: 99999999999 failed its stream and its
    // header loop never ended, even for an element that holds nothing.
    ScratchDir dir;
    for (const char* count : {"99999999999", "4294967297", "1000"}) {
        writeBinary(
            dir / "count.ply",
            binaryPlyTriangle(
                "format binary_little_endian 1.0",
                std::string("property list uchar int vertex_indices\nelement junk ") + count));
        const std::string message = importError<vox::InvalidDataError>(dir / "count.ply");
        EXPECT_NE(message.find(std::string("PLY header claims ") + count + " junk elements"),
                  std::string::npos)
            << message;
    }
    writeBinary(dir / "count.ply",
                binaryPlyTriangle("format binary_little_endian 1.0",
                                  "property list uchar int vertex_indices\nelement junk 3"));
    EXPECT_EQ(vox::importScene(dir / "count.ply").triangleCount(), 1u);
}

TEST(OpenMeshImport, PlyFreeTextLinesHoldingKeywordsAreInvalid) {
    // Found by fuzz_mesh: OpenMesh reads the header word by word, so a stray line's words became
    // an element whose count failed to parse, and its element list grew until memory ran out.
    // (Free text of other words is accepted: Wuson.ply of assimp-testmodels has a line of it.)
    ScratchDir dir;
    writeBinary(dir / "stray.ply",
                binaryPlyTriangle("format binary_little_endian 1.0",
                                  "pryrpteo element vertex list uchar int vertex_indices"));
    const std::string message = importError<vox::InvalidDataError>(dir / "stray.ply");
    EXPECT_NE(message.find("PLY header: line 'pryrpteo element vertex list uchar int "
                           "vertex_indices' holds the keyword 'element'"),
              std::string::npos)
        << message;
}

TEST(OpenMeshImport, TruncatedAndDanglingFilesAreInvalid) {
    ScratchDir dir;
    auto bytes = bytesOf(
        "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float "
        "y\n"
        "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n");
    for (float v : {0.f, 0.f, 0.f, 2.f, 0.f}) append(bytes, v);  // 5 of 9 floats
    writeBinary(dir / "short.ply", bytes);
    importError<vox::InvalidDataError>(dir / "short.ply");
    writeText(dir / "dangling.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n");
    importError<vox::InvalidDataError>(dir / "dangling.off");
    writeText(dir / "points.ply",
              "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float "
              "y\nproperty float z\nend_header\n0 0 0\n");
    EXPECT_NE(importError<vox::InvalidDataError>(dir / "points.ply").find("no faces"),
              std::string::npos);
    writeText(dir / "noply.ply", "solid x\nendsolid x\n");
    EXPECT_NE(importError<vox::InvalidDataError>(dir / "noply.ply").find("not a PLY"),
              std::string::npos);
    writeText(dir / "nooff.off", "3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
    EXPECT_NE(importError<vox::InvalidDataError>(dir / "nooff.off").find("not an OFF"),
              std::string::npos);
}

TEST(OpenMeshImport, BinaryAndAsciiStlCountDegenerateTriangles) {
    ScratchDir dir;
    std::vector<std::uint8_t> bytes(80, ' ');
    std::memcpy(bytes.data(), "solid but actually binary",
                25);  // binary files may start with "solid"
    append<std::uint32_t>(bytes, 2);
    const float triangles[2][12] = {{0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0},
                                    {0, 0, 1, 0, 0, 0, 0, 0, 0, 1, 0, 0}};
    for (const auto& t : triangles) {
        for (float v : t) append(bytes, v);
        append<std::uint16_t>(bytes, 0);
    }
    writeBinary(dir / "b.stl", bytes);
    const vox::Scene binary = vox::importScene(dir / "b.stl");
    EXPECT_EQ(binary.triangleCount(), 1u);
    EXPECT_EQ(binary.degenerateTrianglesDropped, 1u);
    for (const vox::Vec3f& n : binary.meshes[0].normals) EXPECT_NEAR(n.z, 1.0f, 1e-6f);

    writeText(dir / "a.stl",
              "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 "
              "0\nendloop\nendfacet\nendsolid t\n");
    EXPECT_EQ(vox::importScene(dir / "a.stl").triangleCount(), 1u);
    writeText(dir / "bad.stl", "not an stl");
    EXPECT_NE(importError<vox::InvalidDataError>(dir / "bad.stl").find("not an STL"),
              std::string::npos);
}

TEST(StlImport, MalformedAsciiNamesTheLine) {
    // libvox reads STL itself (not OpenMesh): every problem is invalid data naming the line.
    ScratchDir dir;
    const std::string facet =
        "facet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 "
        "0\nendloop\nendfacet\n";
    struct Case {
        std::string text, message;
    };
    const Case cases[] = {
        {"solid t\n" + facet + "facet normal 0 0 1\nouter loop\nvertex 0 0 x\n",
         "line 11: vertex needs three numbers"},
        {"solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 "
         "0\nvertex 1 1 0\nendloop\nendfacet\n",
         "line 7: facet with more than three vertices"},
        {"solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nendloop\nendfacet\n",
         "line 2: facet with 2 vertices, not 3"},
        {"solid t\n" + facet + "facet normal 0 0 1\nouter loop\nvertex 0 0 0\n",
         "line 9: facet without endfacet (truncated?)"},
        {"solid t\nvertex 0 0 0\n", "line 2: vertex outside a facet"},
        {"solid t\n" + facet + "polygon 3\n", "line 9: unexpected 'polygon'"},
        {"solid t\nendsolid t\n", "has no faces"},
        {"solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 nan 0\nvertex 0 1 "
         "0\nendloop\nendfacet\n",
         "vertex 1 has a non-finite position"},
    };
    for (const Case& c : cases) {
        vox::test::writeText(dir / "bad.stl", c.text);
        const std::string message = importError<vox::InvalidDataError>(dir / "bad.stl");
        EXPECT_NE(message.find(c.message), std::string::npos) << message;
    }
    // Facet normals, names and several solids are fine; every facet keeps its own corners.
    vox::test::writeText(dir / "two.stl", "solid a b c\n" + facet + "endsolid a b c\nsolid\n" +
                                              facet + "endsolid\n");
    const vox::Scene scene = vox::importScene(dir / "two.stl");
    EXPECT_EQ(scene.triangleCount(), 2u);
    EXPECT_EQ(scene.meshes[0].positions.size(), 6u);
}

TEST(OffImport, HugeOrMalformedCornerCountsAreInvalidWithoutAllocating) {
    // Found by fuzz_mesh: OpenMesh's OFF reader pushed as many corners as a face's count said
    // (2 GB from a 1.5 KB file). libvox reads OFF itself; a face's corners are tokens of its line.
    ScratchDir dir;
    const std::string header = "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n";
    struct Case {
        std::string face, message;
    };
    const Case cases[] = {
        {"4000000000 0 1 2", "line 6: face has fewer than its 4000000000 corners"},
        {"-1 0 1 2", "line 6: malformed face: no corner count"},
        {"3 0 1 -2", "line 6: malformed vertex index '-2'"},
        {"3 0 1 3", "line 6: vertex index 3 out of range (3 vertices)"},
        {"3 0 1 x", "line 6: malformed vertex index 'x'"},
    };
    for (const Case& c : cases) {
        writeText(dir / "bad.off", header + c.face + "\n");
        const std::string message = importError<vox::InvalidDataError>(dir / "bad.off");
        EXPECT_NE(message.find(c.message), std::string::npos) << message;
    }
    writeText(dir / "short.off",
              "OFF\n3 2 0\n0.000000 0.000000 0.000000\n1.000000 0.000000 0.000000\n0.000000 "
              "1.000000 0.000000\n3 0 1 2\n");
    EXPECT_NE(importError<vox::InvalidDataError>(dir / "short.off")
                  .find("is truncated: 1 of 2 faces read"),
              std::string::npos);
    writeText(dir / "vertex.off",
              "OFF\n3 1 0\n0.000000 0.000000 0.000000\n1.000000 0.000000\n0.000000 1.000000 "
              "0.000000\n3 0 1 2\n");
    EXPECT_NE(
        importError<vox::InvalidDataError>(dir / "vertex.off").find("line 4: vertex has 2 numbers"),
        std::string::npos);
    writeText(dir / "binary.off", "OFF BINARY\n3 1 0\n");
    EXPECT_NE(
        importError<vox::InvalidDataError>(dir / "binary.off").find("binary OFF is not supported"),
        std::string::npos);
}

TEST(OffImport, ColoursNormalsPolygonsAndPointsAndLines) {
    ScratchDir dir;
    // COFF with 0–255 integer colours on one vertex line and 0–1 floats on another, a quad (two
    // triangles), a line and a point (skipped with a warning), comments anywhere.
    writeText(
        dir / "c.off",
        "# colours\nCOFF 4 3 0\n0 0 0 255 0 0 255 # red\n1 0 0 0.0 1.0 0.0 1.0\n1 1 0 0 0 255 255\n"
        "0 1 0 255 255 255 128\n4 0 1 2 3 9 9 9\n2 0 1\n1 3\n");
    const vox::Scene scene = vox::importScene(dir / "c.off");
    ASSERT_EQ(scene.meshes.size(), 1u);
    const vox::Mesh& m = scene.meshes[0];
    EXPECT_EQ(m.triangleCount(), 2u);
    ASSERT_EQ(m.colors.size(), 4u);
    EXPECT_FLOAT_EQ(m.colors[0].x, 1.0f);
    EXPECT_FLOAT_EQ(m.colors[0].y, 0.0f);
    EXPECT_FLOAT_EQ(m.colors[1].y, 1.0f);
    EXPECT_FLOAT_EQ(m.colors[2].z, 1.0f);
    EXPECT_NEAR(m.colors[3].w, 128.0f / 255.0f, 1e-6f);
    ASSERT_EQ(scene.warnings.size(), 1u);
    EXPECT_EQ(scene.warnings[0], "skipped 2 face(s) with fewer than 3 corners (points and lines)");
    // NOFF: the file's normals.
    writeText(dir / "n.off", "NOFF\n3 1 0\n0 0 0 0 0 2\n1 0 0 0 0 2\n0 1 0 0 0 2\n3 0 1 2\n");
    const vox::Scene normals = vox::importScene(dir / "n.off");
    EXPECT_EQ(normals.meshes[0].normals[1].z, 1.0f);
}

TEST(OpenMeshImport, PlyListCountsBeyondTheFileAreInvalidWithoutAllocating) {
    // OpenMesh sizes a face's corner list by its count, unchecked; libvox walks the records first.
    ScratchDir dir;
    const std::string vertices =
        "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n";
    writeText(dir / "a.ply", "ply\nformat ascii 1.0\n" + vertices +
                                 "element face 1\nproperty list uint int vertex_indices\n"
                                 "end_header\n0 0 0\n1 0 0\n0 1 0\n4000000000 0 1 2\n");
    EXPECT_NE(
        importError<vox::InvalidDataError>(dir / "a.ply")
            .find("face 0: a list of 4000000000 values, more than the rest of the file holds"),
        std::string::npos);
    writeText(dir / "n.ply", "ply\nformat ascii 1.0\n" + vertices +
                                 "element face 1\nproperty list int int vertex_indices\n"
                                 "end_header\n0 0 0\n1 0 0\n0 1 0\n-3 0 1 2\n");
    EXPECT_NE(
        importError<vox::InvalidDataError>(dir / "n.ply").find("face 0: malformed list count"),
        std::string::npos);
    // "3-1" is one token to a whitespace split but 3 and then a count of -1 to OpenMesh's stream.
    writeText(dir / "m.ply", "ply\nformat ascii 1.0\n" + vertices +
                                 "element face 2\nproperty list uchar int vertex_indices\n"
                                 "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2-1\n3 0 1 2\n");
    EXPECT_NE(
        importError<vox::InvalidDataError>(dir / "m.ply").find("face 0: malformed value '2-1'"),
        std::string::npos);
    auto bytes = bytesOf("ply\nformat binary_big_endian 1.0\n" + vertices +
                         "element face 1\nproperty list uint int vertex_indices\nend_header\n");
    for (int i = 0; i < 36; ++i) bytes.push_back(0);
    for (std::uint8_t b : {0xFF, 0xFF, 0xFF, 0xF0}) bytes.push_back(b);  // 4294967280 corners
    for (int i = 0; i < 12; ++i) bytes.push_back(0);
    writeBinary(dir / "b.ply", bytes);
    EXPECT_NE(importError<vox::InvalidDataError>(dir / "b.ply")
                  .find("face 0: a list of 4294967280 values"),
              std::string::npos);
    writeText(dir / "f.ply", "ply\nformat ascii 1.0\n" + vertices +
                                 "element face 1\nproperty list float int vertex_indices\n"
                                 "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
    EXPECT_NE(importError<vox::InvalidDataError>(dir / "f.ply")
                  .find("list count type is not an integer type"),
              std::string::npos);
}

TEST(OpenMeshImport, OffWithCommentsAndPlyTextureFile) {
    ScratchDir dir;
    writeText(
        dir / "c.off",
        "# comment\nOFF\n# counts follow\n4 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n");
    EXPECT_EQ(vox::importScene(dir / "c.off").triangleCount(), 2u);

    writeText(
        dir / "t.ply",
        "ply\nformat ascii 1.0\ncomment TextureFile missing.png\nelement vertex 3\nproperty float "
        "x\n"
        "property float y\nproperty float z\nproperty float s\nproperty float t\nelement face 1\n"
        "property list uchar int vertex_indices\nend_header\n0 0 0 0 0\n1 0 0 1 0\n0 1 0 0 1\n3 0 "
        "1 2\n");
    EXPECT_NE(importError<vox::IoError>(dir / "t.ply").find("missing.png"), std::string::npos);
}
