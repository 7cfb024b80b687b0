#include <vox/base/error.h>
#include <vox/image_io.h>
#include <vox/import.h>

#include "gltf_builder.h"
#include "import_expect.h"
#include "test_support.h"

#include <cmath>

using vox::test::importError;
using vox::test::importOk;
using vox::test::ScratchDir;
using vox::test::writeText;

namespace {

const char* kCube = R"(# unit cube with one normal per face
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 0 0 1
v 1 0 1
v 1 1 1
v 0 1 1
vn 0 0 -1
vn 0 0 1
vn 0 -1 0
vn 0 1 0
vn -1 0 0
vn 1 0 0
f 1//1 4//1 3//1 2//1
f 5//2 6//2 7//2 8//2
f 1//3 2//3 6//3 5//3
f 4//4 8//4 7//4 3//4
f 1//5 5//5 8//5 4//5
f 2//6 3//6 7//6 6//6
)";

}  // namespace

TEST(ObjImport, PerCornerNormalsKeepHardEdges) {
    ScratchDir dir;
    writeText(dir / "cube.obj", kCube);
    const vox::Scene scene = vox::importScene(dir / "cube.obj");
    ASSERT_EQ(scene.meshes.size(), 1u);
    const vox::Mesh& m = scene.meshes[0];
    EXPECT_EQ(m.triangleCount(), 12u);
    EXPECT_EQ(m.positions.size(), 24u) << "each corner position appears once per face normal";
    for (const vox::Vec3f& n : m.normals)
        EXPECT_FLOAT_EQ(std::fabs(n.x) + std::fabs(n.y) + std::fabs(n.z), 1.0f);
    for (std::size_t t = 0; t < m.triangleCount(); ++t) {
        const vox::Vec3f a = m.positions[m.indices[3 * t]], b = m.positions[m.indices[3 * t + 1]],
                         c = m.positions[m.indices[3 * t + 2]];
        EXPECT_GT(vox::dot(vox::cross(b - a, c - a), m.normals[m.indices[3 * t]]), 0.0f)
            << "triangle " << t;
    }
    EXPECT_TRUE(scene.warnings.empty());
}

TEST(ObjImport, NegativeIndicesContinuationLinesAndSmoothNormals) {
    ScratchDir dir;
    writeText(dir / "quad.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\\\n\nv 0 1 0\nf -4 -3 \\\n -2 -1\n");
    const vox::Mesh m = vox::importScene(dir / "quad.obj").meshes.at(0);
    EXPECT_EQ(m.triangleCount(), 2u);
    for (const vox::Vec3f& n : m.normals) EXPECT_NEAR(n.z, 1.0f, 1e-6f);
}

TEST(ObjImport, ConcavePolygonsAreEarClipped) {
    ScratchDir dir;
    // An L shape of area 3 (fan triangulation from vertex 0 would leave the notch covered).
    writeText(dir / "l.obj",
              "v 0 0 0\nv 2 0 0\nv 2 1 0\nv 1 1 0\nv 1 2 0\nv 0 2 0\nf 1 2 3 4 5 6\n");
    const vox::Mesh m = vox::importScene(dir / "l.obj").meshes.at(0);
    ASSERT_EQ(m.triangleCount(), 4u);
    double area = 0;
    for (std::size_t t = 0; t < 4; ++t) {
        const vox::Vec3f a = m.positions[m.indices[3 * t]], b = m.positions[m.indices[3 * t + 1]],
                         c = m.positions[m.indices[3 * t + 2]];
        const float z = vox::cross(b - a, c - a).z;
        EXPECT_GT(z, 0.0f) << "triangle " << t << " is flipped";
        area += z / 2;
        // No triangle covers the notch at (1.5, 1.5).
        const vox::Vec3f centroid = (a + b + c) / 3.0f;
        EXPECT_FALSE(centroid.x > 1 && centroid.y > 1) << "triangle " << t << " lies in the notch";
    }
    EXPECT_NEAR(area, 3.0, 1e-6);
}

TEST(ObjImport, ObjectsGroupsAndMaterialsSplitMeshes) {
    ScratchDir dir;
    const std::vector<std::uint8_t> pixels = {255, 0, 0, 0, 0, 255};
    vox::writePng(dir / "tex.png", 2, 1, 3, pixels);
    std::filesystem::create_directories(dir / "sub");
    std::filesystem::copy_file(dir / "tex.png", dir / "sub" / "tex2.png");
    writeText(dir / "m.mtl",
              "newmtl red\nKd 1 0 0\nd 0.5\nmap_Kd -s 2 2 1 -o 0.5 0 0 tex.png\n"
              "newmtl lamp\nKd 0.5\nKe 4 2 0\nmap_Ke sub\\tex2.png\n");
    writeText(dir / "s.obj",
              "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n"
              "o car\ng body\nusemtl red\nf 1/1 2/2 3/3\ng wheel\nusemtl lamp\nf 1/1 2/2 3/3\n"
              "o house\nusemtl red\nf 1/1 3/3 2/2\n");
    vox::ImportOptions options;
    options.dynamicNames = {"car"};
    const vox::Scene scene = vox::importScene(dir / "s.obj", options);
    ASSERT_EQ(scene.meshes.size(), 3u);
    EXPECT_EQ(scene.meshes[0].name, "car/body");
    EXPECT_EQ(scene.meshes[1].name, "car/wheel");
    EXPECT_EQ(scene.meshes[2].name, "house");
    EXPECT_TRUE(scene.meshes[0].dynamic);
    EXPECT_TRUE(scene.meshes[1].dynamic);
    EXPECT_FALSE(scene.meshes[2].dynamic);
    ASSERT_EQ(scene.materials.size(), 2u);
    const vox::Material& red = scene.materials[scene.meshes[0].material];
    EXPECT_EQ(red.baseColorFactor, (vox::Vec4f{1, 0, 0, 0.5f}));
    EXPECT_EQ(red.alphaMode, vox::AlphaMode::Blend);
    ASSERT_TRUE(red.baseColorTexture.valid());
    // OBJ v points up the image: uv (0, 0) is the bottom-left corner, libvox's (0, 1) before -s/-o.
    const vox::Vec2f uv = red.baseColorTexture.transformUv(scene.meshes[0].uvs[0][0]);
    EXPECT_FLOAT_EQ(uv.x, 0.5f);  // 2·0 + 0.5
    EXPECT_FLOAT_EQ(uv.y, 1.0f);  // 1 - (2·0 + 0)
    const vox::Material& lamp = scene.materials[scene.meshes[1].material];
    EXPECT_EQ(lamp.baseColorFactor, (vox::Vec4f{0.5f, 0.5f, 0.5f, 1}));
    EXPECT_EQ(lamp.emission(), (vox::Vec3f{4, 2, 0}));
    EXPECT_TRUE(lamp.emissiveTexture.valid());
    EXPECT_EQ(scene.textures.size(), 2u);
    EXPECT_EQ(scene.sourceFiles.size(), 4u);  // obj, mtl, two images
}

TEST(ObjImport, VertexColoursAreDisplayReferred) {
    ScratchDir dir;
    writeText(dir / "c.obj", "v 0 0 0 1 0.5 0\nv 1 0 0 0 0 1\nv 0 1 0 0.5 0.5 0.5\nf 1 2 3\n");
    const vox::Mesh m = vox::importScene(dir / "c.obj").meshes.at(0);
    ASSERT_EQ(m.colors.size(), 3u);
    EXPECT_FLOAT_EQ(m.colors[0].x, 1.0f);
    EXPECT_NEAR(m.colors[0].y, vox::srgbToLinear(0.5f), 1e-6f);
    EXPECT_FLOAT_EQ(m.colors[1].z, 1.0f);
}

TEST(ObjImport, UnknownMaterialIsAWarningOrAnErrorWhenStrict) {
    ScratchDir dir;
    writeText(dir / "u.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl nowhere\nf 1 2 3\n");
    const vox::Scene scene = vox::importScene(dir / "u.obj");
    ASSERT_EQ(scene.warnings.size(), 1u);
    EXPECT_NE(scene.warnings[0].find("nowhere"), std::string::npos);
    vox::ImportOptions strict;
    strict.strict = true;
    importError<vox::InvalidDataError>(dir / "u.obj", strict);
}

TEST(ObjImport, BadInputNamesTheLine) {
    ScratchDir dir;
    writeText(dir / "range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n");
    EXPECT_NE(importError<vox::InvalidDataError>(dir / "range.obj")
                  .find("line 4: vertex index 4 out of range (3 defined)"),
              std::string::npos);
    writeText(dir / "number.obj", "v 0 0 0\nv 1 zero 0\n");
    EXPECT_NE(importError<vox::InvalidDataError>(dir / "number.obj")
                  .find("line 2: malformed number 'zero'"),
              std::string::npos);
    writeText(dir / "zero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n");
    EXPECT_NE(importError<vox::InvalidDataError>(dir / "zero.obj").find("line 4"),
              std::string::npos);
    writeText(dir / "lines.obj", "v 0 0 0\nv 1 0 0\nl 1 2\n");
    EXPECT_NE(importError<vox::InvalidDataError>(dir / "lines.obj").find("contains no triangles"),
              std::string::npos);
    writeText(dir / "nan.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n");
    EXPECT_NE(importError<vox::InvalidDataError>(dir / "nan.obj").find("non-finite"),
              std::string::npos);
    writeText(dir / "binary.obj", std::string("v 0 0 0\n\0\0\0\x01", 12));
    EXPECT_NE(importError<vox::InvalidDataError>(dir / "binary.obj").find("binary data"),
              std::string::npos);
    writeText(dir / "utf16.obj", std::string("\xFF\xFEv\0 \0", 6));
    EXPECT_NE(importError<vox::InvalidDataError>(dir / "utf16.obj").find("UTF-16"),
              std::string::npos);
}

TEST(ObjImport, MissingMaterialLibraryOrTextureIsAnIoError) {
    ScratchDir dir;
    writeText(dir / "a.obj", "mtllib absent.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    EXPECT_NE(importError<vox::IoError>(dir / "a.obj").find("absent.mtl"), std::string::npos);
    writeText(dir / "b.mtl", "newmtl m\nmap_Kd gone.png\n");
    writeText(dir / "b.obj", "mtllib b.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl m\nf 1 2 3\n");
    EXPECT_NE(importError<vox::IoError>(dir / "b.obj").find("gone.png"), std::string::npos);
}
