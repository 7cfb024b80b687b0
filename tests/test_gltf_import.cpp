#include <vox/base/error.h>
#include <vox/image_io.h>
#include <vox/import.h>

#include "gltf_builder.h"
#include "shapes.h"
#include "import_expect.h"
#include "test_support.h"

#include <draco/compression/encode.h>
#include <draco/mesh/triangle_soup_mesh_builder.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <functional>
#include <numbers>
#include <sys/stat.h>

using vox::scenes::BufferStorage;
using vox::scenes::GltfBuilder;
using vox::test::importError;
using vox::test::importOk;
using vox::test::ScratchDir;

namespace {

GltfBuilder::Primitive triangle(int material = -1) {
    GltfBuilder::Primitive p;
    p.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    p.normals = {0, 0, 1, 0, 0, 1, 0, 0, 1};
    p.material = material;
    return p;
}

std::filesystem::path writeSingleNode(const ScratchDir& dir, GltfBuilder& gltf,
                                      GltfBuilder::NodeDesc node,
                                      BufferStorage storage = BufferStorage::DataUri,
                                      const std::string& name = "scene.gltf") {
    gltf.setSceneRoots({gltf.addNode(node)});
    const auto file = dir / name;
    gltf.write(file, storage);
    return file;
}

bool near(vox::Vec3f a, vox::Vec3f b, float eps = 1e-5f) {
    return std::fabs(a.x - b.x) < eps && std::fabs(a.y - b.y) < eps && std::fabs(a.z - b.z) < eps;
}

vox::Vec3f faceNormal(const vox::Mesh& mesh, std::size_t t) {
    const vox::Vec3f a = mesh.positions[mesh.indices[3 * t]],
                     b = mesh.positions[mesh.indices[3 * t + 1]],
                     c = mesh.positions[mesh.indices[3 * t + 2]];
    return vox::normalize(vox::cross(b - a, c - a));
}

/// Signed volume of a closed mesh: positive when its triangles face outwards.
double signedVolume(const vox::Mesh& mesh) {
    double v = 0;
    for (std::size_t t = 0; t < mesh.triangleCount(); ++t) {
        const vox::Vec3f a = mesh.positions[mesh.indices[3 * t]],
                         b = mesh.positions[mesh.indices[3 * t + 1]],
                         c = mesh.positions[mesh.indices[3 * t + 2]];
        v += vox::dot(a, vox::cross(b, c)) / 6.0;
    }
    return v;
}

}  // namespace

TEST(GltfImport, NodeTransformsAreAppliedInOrderScaleRotateTranslate) {
    ScratchDir dir;
    GltfBuilder gltf;
    const int mesh = gltf.addMesh("tri", {triangle()});
    // 90 degrees about Z, then scale 2 first, then translate (10, 0, 0).
    const double s = std::sin(std::numbers::pi / 4), c = std::cos(std::numbers::pi / 4);
    const auto file =
        writeSingleNode(dir, gltf, {"node", mesh, -1, {10, 0, 0}, {0, 0, s, c}, {2, 2, 2}});
    const vox::Scene scene = importOk(file);
    ASSERT_EQ(scene.meshes.size(), 1u);
    const vox::Mesh& m = scene.meshes[0];
    // (1,0,0) -> scale (2,0,0) -> rotate (0,2,0) -> translate (10,2,0)
    EXPECT_TRUE(near(m.positions[1], {10, 2, 0})) << m.positions[1].x << " " << m.positions[1].y;
    EXPECT_TRUE(near(m.positions[2], {8, 0, 0}));
    EXPECT_TRUE(near(m.normals[0], {0, 0, 1}));
}

TEST(GltfImport, MatrixAndParentTransformsCompose) {
    ScratchDir dir;
    GltfBuilder gltf;
    const int mesh = gltf.addMesh("tri", {triangle()});
    const int child = gltf.addNode({"child", mesh, -1, {0, 0, 5}});
    const int parent = gltf.addNode({"parent"});
    gltf.json()["nodes"][parent]["children"] = {child};
    gltf.json()["nodes"][parent]["matrix"] = {3, 0, 0, 0, 0, 3, 0, 0, 0,
                                              0, 3, 0, 1, 2, 3, 1};  // scale 3, then move (1,2,3)
    gltf.setSceneRoots({parent});
    gltf.write(dir / "scene.gltf", BufferStorage::DataUri);
    const vox::Scene scene = importOk(dir / "scene.gltf");
    ASSERT_EQ(scene.meshes.size(), 1u);
    EXPECT_TRUE(near(scene.meshes[0].positions[0], {1, 2, 18}));
    EXPECT_TRUE(near(scene.meshes[0].positions[1], {4, 2, 18}));
}

TEST(GltfImport, MirroringTransformKeepsTrianglesFacingOutwards) {
    ScratchDir dir;
    GltfBuilder gltf;
    const int mesh = gltf.addMesh("box", {vox::scenes::boxPrimitive({0, 0, 0}, {1, 2, 3}, -1)});
    const auto file =
        writeSingleNode(dir, gltf, {"mirrored", mesh, -1, {0, 0, 0}, {0, 0, 0, 1}, {-1, 1, 1}});
    const vox::Scene scene = importOk(file);
    const vox::Mesh& m = scene.meshes.at(0);
    EXPECT_NEAR(signedVolume(m), 6.0, 1e-4);
    for (std::size_t t = 0; t < m.triangleCount(); ++t)
        EXPECT_GT(vox::dot(faceNormal(m, t), m.normals[m.indices[3 * t]]), 0.99f)
            << "triangle " << t;
}

TEST(GltfImport, MissingNormalsAreFlatAsTheSpecificationRequires) {
    ScratchDir dir;
    GltfBuilder gltf;
    GltfBuilder::Primitive bent;  // two triangles folded along the x axis, sharing vertices
    bent.positions = {0, 0, 0, 1, 0, 0, 1, 1, 0, 1, 0, -1};
    bent.indices = {0, 1, 2, 0, 3, 1};
    const auto file = writeSingleNode(dir, gltf, {"bent", gltf.addMesh("bent", {bent})});
    const vox::Mesh m = importOk(file).meshes.at(0);
    ASSERT_EQ(m.triangleCount(), 2u);
    EXPECT_EQ(m.positions.size(), 6u) << "flat normals need unwelded vertices";
    for (std::size_t t = 0; t < 2; ++t)
        for (int k = 0; k < 3; ++k)
            EXPECT_TRUE(near(m.normals[m.indices[3 * t + k]], faceNormal(m, t)));
    EXPECT_TRUE(near(faceNormal(m, 0), {0, 0, 1}));
    EXPECT_TRUE(near(faceNormal(m, 1), {0, -1, 0}));
}

TEST(GltfImport, StripsAndFansBecomeConsistentlyWoundTriangles) {
    ScratchDir dir;
    GltfBuilder gltf;
    GltfBuilder::Primitive strip;
    strip.positions = {0, 0, 0, 0, 1, 0, 1, 0, 0, 1, 1, 0, 2, 0, 0};  // zig-zag in the z=0 plane
    strip.mode = 5;
    GltfBuilder::Primitive fan;
    fan.positions = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, -1, 1, 0};
    fan.mode = 6;
    const int stripMesh = gltf.addMesh("strip", {strip});
    const int fanMesh = gltf.addMesh("fan", {fan});
    gltf.setSceneRoots({gltf.addNode({"strip", stripMesh}), gltf.addNode({"fan", fanMesh})});
    gltf.write(dir / "modes.gltf", BufferStorage::DataUri);
    const vox::Scene scene = importOk(dir / "modes.gltf");
    ASSERT_EQ(scene.meshes.size(), 2u);
    EXPECT_EQ(scene.meshes[0].triangleCount(), 3u);
    EXPECT_EQ(scene.meshes[1].triangleCount(), 3u);
    // The strip starts clockwise seen from +z, so every triangle faces -z; the fan faces +z.
    for (std::size_t t = 0; t < 3; ++t) {
        EXPECT_TRUE(near(faceNormal(scene.meshes[0], t), {0, 0, -1})) << "strip triangle " << t;
        EXPECT_TRUE(near(faceNormal(scene.meshes[1], t), {0, 0, 1})) << "fan triangle " << t;
    }
}

TEST(GltfImport, SparseAccessorsSubstituteValues) {
    ScratchDir dir;
    GltfBuilder gltf;
    const int mesh = gltf.addMesh("tri", {triangle()});
    // Move vertex 2 from (0,1,0) to (0,7,0) through a sparse substitution.
    const std::vector<std::uint8_t> index = {2, 0, 0, 0};
    const std::vector<float> value = {0, 7, 0};
    const int indexView = gltf.addBufferView(index);
    const int valueView =
        gltf.addBufferView({reinterpret_cast<const std::uint8_t*>(value.data()), 12});
    auto& positionAccessor = gltf.json()["accessors"][0];
    positionAccessor["sparse"] = {{"count", 1},
                                  {"indices", {{"bufferView", indexView}, {"componentType", 5121}}},
                                  {"values", {{"bufferView", valueView}}}};
    positionAccessor.erase("max");
    positionAccessor.erase("min");
    const auto file = writeSingleNode(dir, gltf, {"n", mesh});
    const vox::Mesh m = importOk(file).meshes.at(0);
    EXPECT_TRUE(near(m.positions[2], {0, 7, 0}));
    EXPECT_TRUE(near(m.positions[1], {1, 0, 0}));
}

TEST(GltfImport, SparseAccessorWithoutBufferViewStartsFromZeros) {
    ScratchDir dir;
    GltfBuilder gltf;
    GltfBuilder::Primitive p = triangle();
    p.positions = {9, 9, 9, 9, 9, 9, 9, 9, 9};  // replaced below
    const int mesh = gltf.addMesh("tri", {p});
    const std::vector<std::uint8_t> indices = {1, 2};
    const std::vector<float> values = {1, 0, 0, 0, 1, 0};
    const int indexView = gltf.addBufferView(indices);
    const int valueView =
        gltf.addBufferView({reinterpret_cast<const std::uint8_t*>(values.data()), 24});
    auto& accessor = gltf.json()["accessors"][0];
    accessor.erase("bufferView");
    accessor.erase("max");
    accessor.erase("min");
    accessor["sparse"] = {{"count", 2},
                          {"indices", {{"bufferView", indexView}, {"componentType", 5121}}},
                          {"values", {{"bufferView", valueView}}}};
    const auto file = writeSingleNode(dir, gltf, {"n", mesh});
    const vox::Mesh m = importOk(file).meshes.at(0);
    EXPECT_TRUE(near(m.positions[0], {0, 0, 0}));
    EXPECT_TRUE(near(m.positions[1], {1, 0, 0}));
    EXPECT_TRUE(near(m.positions[2], {0, 1, 0}));
}

TEST(GltfImport, NormalizedAndQuantizedAttributesAreDecoded) {
    ScratchDir dir;
    GltfBuilder gltf;
    // KHR_mesh_quantization: positions as unnormalized int16 VEC3 with the 8-byte stride vertex
    // attributes need, UVs as normalized uint8, colours as normalized uint16 VEC3.
    const std::vector<std::int16_t> positions = {0, 0, 0, 0, 100, 0, 0, 0, 0, -200, 0, 0};
    const std::vector<std::uint8_t> uvs = {0, 0, 255, 0, 128, 255};
    const std::vector<std::uint16_t> colors = {65535, 0, 0, 0, 32768, 0, 0, 0, 65535};
    const int p = gltf.addRawAccessor({reinterpret_cast<const std::uint8_t*>(positions.data()), 24},
                                      5122, "VEC3", 3);
    gltf.json()["bufferViews"][gltf.json()["accessors"][p]["bufferView"].get<int>()]["byteStride"] =
        8;
    const int t = gltf.addRawAccessor(uvs, 5121, "VEC2", 3, true);
    const int c = gltf.addRawAccessor({reinterpret_cast<const std::uint8_t*>(colors.data()), 18},
                                      5123, "VEC3", 3, true);
    gltf.json()["meshes"] = {
        {{"primitives", {{{"attributes", {{"POSITION", p}, {"TEXCOORD_0", t}, {"COLOR_0", c}}}}}}}};
    gltf.json()["extensionsUsed"] = {"KHR_mesh_quantization"};
    gltf.json()["extensionsRequired"] = {"KHR_mesh_quantization"};
    const auto file = writeSingleNode(dir, gltf, {"n", 0});
    const vox::Mesh m = importOk(file).meshes.at(0);
    ASSERT_EQ(m.positions.size(), 3u);
    EXPECT_TRUE(near(m.positions[1], {100, 0, 0}));
    EXPECT_TRUE(near(m.positions[2], {0, -200, 0}));
    ASSERT_EQ(m.uvs.size(), 1u);
    EXPECT_FLOAT_EQ(m.uvs[0][1].x, 1.0f);
    EXPECT_NEAR(m.uvs[0][2].x, 128.0f / 255.0f, 1e-6f);
    ASSERT_EQ(m.colors.size(), 3u);
    EXPECT_FLOAT_EQ(m.colors[0].x, 1.0f);
    EXPECT_NEAR(m.colors[1].y, 32768.0f / 65535.0f, 1e-6f);
    EXPECT_FLOAT_EQ(m.colors[2].w, 1.0f) << "VEC3 colours get alpha 1";
}

TEST(GltfImport, MaterialsTexturesAndExtensions) {
    ScratchDir dir;
    GltfBuilder gltf;
    const std::vector<std::uint8_t> pixels = {255, 0, 0, 0, 255, 0, 0, 0, 255, 255, 255, 255};
    vox::writePng(dir / "tex.png", 2, 2, 3, pixels);
    const int texture = gltf.addTexture(gltf.addImage("tex.png"), 33071, 33648);
    const int material =
        gltf.addMaterial({"glow", {0.5f, 0.25f, 1.0f, 0.5f}, texture, {1.0f, 0.5f, 0.0f}, 40.0f});
    auto& m = gltf.json()["materials"][material];
    m["alphaMode"] = "MASK";
    m["alphaCutoff"] = 0.3;
    m["doubleSided"] = true;
    m["pbrMetallicRoughness"]["baseColorTexture"]["extensions"]["KHR_texture_transform"] = {
        {"offset", {0.5, 0.25}}, {"rotation", std::numbers::pi / 2}, {"scale", {2, 3}}};
    m["emissiveTexture"] = {{"index", texture}};
    m["normalTexture"] = {{"index", texture}, {"scale", 0.5}};
    const auto file = writeSingleNode(dir, gltf, {"n", gltf.addMesh("tri", {triangle(material)})},
                                      BufferStorage::External);
    const vox::Scene scene = importOk(file);
    ASSERT_EQ(scene.materials.size(), 1u);
    const vox::Material& mat = scene.materials[0];
    EXPECT_EQ(mat.baseColorFactor, (vox::Vec4f{0.5f, 0.25f, 1.0f, 0.5f}));
    EXPECT_EQ(mat.emission(), (vox::Vec3f{40.0f, 20.0f, 0.0f}));
    EXPECT_EQ(mat.alphaMode, vox::AlphaMode::Mask);
    EXPECT_FLOAT_EQ(mat.alphaCutoff, 0.3f);
    EXPECT_TRUE(mat.doubleSided);
    EXPECT_FLOAT_EQ(mat.normalScale, 0.5f);
    ASSERT_TRUE(mat.baseColorTexture.valid());
    EXPECT_EQ(mat.baseColorTexture.wrapS, vox::WrapMode::ClampToEdge);
    EXPECT_EQ(mat.baseColorTexture.wrapT, vox::WrapMode::MirroredRepeat);
    // uv' = T·R·S·uv: (1, 0) -> scale (2, 0) -> rotate by 90 degrees as glTF does (0, -2) -> offset
    // (0.5, -1.75)
    const vox::Vec2f uv = mat.baseColorTexture.transformUv({1, 0});
    EXPECT_NEAR(uv.x, 0.5f, 1e-5f);
    EXPECT_NEAR(uv.y, -1.75f, 1e-5f);
    // The same image used as colour (sRGB) and as a normal map (linear) is two textures.
    ASSERT_EQ(scene.textures.size(), 2u);
    EXPECT_EQ(scene.textures[mat.baseColorTexture.texture].colorSpace(), vox::ColorSpace::SRGB);
    EXPECT_EQ(scene.textures[mat.normalTexture.texture].colorSpace(), vox::ColorSpace::Linear);
    EXPECT_EQ(mat.emissiveTexture.texture, mat.baseColorTexture.texture);
    EXPECT_EQ(scene.textures[0].texel(0, 0, 1).z, 1.0f);
}

TEST(GltfImport, PunctualLightsTakeTheirNodesPositionAndDirection) {
    ScratchDir dir;
    GltfBuilder gltf;
    const int mesh = gltf.addMesh("tri", {triangle()});
    const int point = gltf.addLight({"bulb", "point", {1, 0.5f, 0.25f}, 12.0f, 4.0f});
    const int spot = gltf.addLight({"spot", "spot", {1, 1, 1}, 3.0f, 0.0f, 0.2f, 0.6f});
    const int sun = gltf.addLight({"sun", "directional", {1, 1, 1}, 2.0f});
    gltf.setSceneRoots(
        {gltf.addNode({"geo", mesh}), gltf.addNode({"bulbNode", -1, point, {1, 2, 3}}),
         gltf.addNode(
             {"spotNode", -1, spot, {0, 5, 0}, vox::scenes::rotationFromMinusZ({0, -1, 0})}),
         gltf.addNode(
             {"sunNode", -1, sun, {0, 0, 0}, vox::scenes::rotationFromMinusZ({1, 0, 0})})});
    gltf.write(dir / "lights.gltf", BufferStorage::DataUri);
    const vox::Scene scene = importOk(dir / "lights.gltf");
    ASSERT_EQ(scene.lights.size(), 3u);
    const vox::Light& bulb = scene.lights[0];
    EXPECT_EQ(bulb.type, vox::Light::Type::Point);
    EXPECT_EQ(bulb.name, "bulb");
    EXPECT_TRUE(near(bulb.position, {1, 2, 3}));
    EXPECT_EQ(bulb.color, (vox::Vec3f{1, 0.5f, 0.25f}));
    EXPECT_FLOAT_EQ(bulb.intensity, 12.0f);
    EXPECT_FLOAT_EQ(bulb.range, 4.0f);
    const vox::Light& spotLight = scene.lights[1];
    EXPECT_EQ(spotLight.type, vox::Light::Type::Spot);
    EXPECT_TRUE(near(spotLight.direction, {0, -1, 0}));
    EXPECT_FLOAT_EQ(spotLight.innerConeAngle, 0.2f);
    EXPECT_FLOAT_EQ(spotLight.outerConeAngle, 0.6f);
    EXPECT_TRUE(near(scene.lights[2].direction, {1, 0, 0}));
    EXPECT_EQ(scene.lights[2].type, vox::Light::Type::Directional);
}

TEST(GltfImport, InvalidLightParametersAreRejected) {
    ScratchDir dir;
    GltfBuilder gltf;
    const int spot =
        gltf.addLight({"bad", "spot", {1, 1, 1}, 1.0f, 0.0f, 0.7f, 0.5f});  // inner > outer
    gltf.setSceneRoots(
        {gltf.addNode({"geo", gltf.addMesh("tri", {triangle()})}), gltf.addNode({"s", -1, spot})});
    gltf.write(dir / "lights.gltf", BufferStorage::DataUri);
    EXPECT_NE(importError<vox::InvalidDataError>(dir / "lights.gltf").find("cone angles"),
              std::string::npos);

    // A light as far out as no vertex may be (issue 10: absurd scales).
    GltfBuilder far;
    const int bulb = far.addLight({"bulb", "point", {1, 1, 1}, 1.0f});
    far.setSceneRoots({far.addNode({"geo", far.addMesh("tri", {triangle()})}),
                       far.addNode({"b", -1, bulb, {0, 2e30, 0}})});
    far.write(dir / "far.gltf", BufferStorage::DataUri);
    EXPECT_NE(importError<vox::InvalidDataError>(dir / "far.gltf")
                  .find("light 'bulb' has a position beyond ±1e30 (absurd scale)"),
              std::string::npos);
}

TEST(GltfImport, DynamicFlagFromExtrasAndFromNamesIsInherited) {
    ScratchDir dir;
    GltfBuilder gltf;
    const int mesh = gltf.addMesh("tri", {triangle()});
    const int light = gltf.addLight({"l", "point"});
    const int child = gltf.addNode({"child", mesh, light});
    GltfBuilder::NodeDesc parent{"car", -1};
    parent.dynamic = true;
    parent.children = {child};
    const int car = gltf.addNode(parent);
    const int door = gltf.addNode({"door", mesh});
    const int building = gltf.addNode({"building", mesh});
    gltf.setSceneRoots({car, door, building});
    gltf.write(dir / "dyn.gltf", BufferStorage::DataUri);

    vox::ImportOptions options;
    options.dynamicNames = {"door"};
    const vox::Scene scene = importOk(dir / "dyn.gltf", options);
    ASSERT_EQ(scene.meshes.size(), 3u);
    EXPECT_TRUE(scene.meshes[0].dynamic) << "child of an extras-dynamic node";
    EXPECT_TRUE(scene.lights.at(0).dynamic);
    EXPECT_TRUE(scene.meshes[1].dynamic) << "named by --dynamic";
    EXPECT_FALSE(scene.meshes[2].dynamic);
    EXPECT_EQ(scene.dynamicTriangleCount(), 2u);

    options.dynamicNames = {"no-such-node"};
    const vox::Scene warned = importOk(dir / "dyn.gltf", options);
    ASSERT_EQ(warned.warnings.size(), 1u);
    EXPECT_NE(warned.warnings[0].find("no-such-node"), std::string::npos);
    options.strict = true;
    importError<vox::InvalidDataError>(dir / "dyn.gltf", options);
}

TEST(GltfImport, ExternalEmbeddedAndGlbStorageGiveTheSameScene) {
    ScratchDir dir;
    std::vector<std::size_t> counts;
    for (BufferStorage storage :
         {BufferStorage::External, BufferStorage::DataUri, BufferStorage::Glb}) {
        GltfBuilder gltf;
        const std::vector<std::uint8_t> pixels(4 * 4 * 3, 200);
        const int image =
            storage == BufferStorage::External
                ? (vox::writePng(dir / "t.png", 4, 4, 3, pixels), gltf.addImage("t.png"))
                : gltf.addBufferImage(vox::encodePng(4, 4, 3, pixels), "image/png");
        const int material = gltf.addMaterial({"m", {1, 1, 1, 1}, gltf.addTexture(image)});
        GltfBuilder::Primitive box = vox::scenes::boxPrimitive({0, 0, 0}, {1, 1, 1}, material);
        const auto file = writeSingleNode(dir, gltf, {"box", gltf.addMesh("box", {box})}, storage,
                                          storage == BufferStorage::Glb ? "s.glb" : "s.gltf");
        const vox::Scene scene = importOk(file);
        counts.push_back(scene.triangleCount());
        ASSERT_EQ(scene.textures.size(), 1u);
        EXPECT_EQ(scene.textures[0].width(), 4);
        EXPECT_NEAR(scene.textures[0].texel(0, 0, 0).x, vox::srgbToLinear(200.0f / 255.0f), 1e-6f);
        std::vector<std::filesystem::path> expected = {file.lexically_normal()};
        if (storage == BufferStorage::External)
            expected = {file.lexically_normal(), (dir / "s.bin").lexically_normal(),
                        (dir / "t.png").lexically_normal()};
        EXPECT_EQ(scene.sourceFiles, expected);
    }
    EXPECT_EQ(counts, (std::vector<std::size_t>{12, 12, 12}));
}

TEST(GltfImport, MissingReferencedFilesAreIoErrors) {
    ScratchDir dir;
    GltfBuilder gltf;
    const int material =
        gltf.addMaterial({"m", {1, 1, 1, 1}, gltf.addTexture(gltf.addImage("missing.png"))});
    writeSingleNode(dir, gltf, {"n", gltf.addMesh("tri", {triangle(material)})},
                    BufferStorage::External);
    const std::string imageError = importError<vox::IoError>(dir / "scene.gltf");
    EXPECT_NE(imageError.find("missing.png"), std::string::npos) << imageError;
    // Without textures the image is not needed.
    vox::ImportOptions noTextures;
    noTextures.loadTextures = false;
    EXPECT_EQ(importOk(dir / "scene.gltf", noTextures).triangleCount(), 1u);
    std::filesystem::remove(dir / "scene.bin");
    const std::string binError = importError<vox::IoError>(dir / "scene.gltf", noTextures);
    EXPECT_NE(binError.find("scene.bin"), std::string::npos) << binError;
    // A buffer or image that is a FIFO (or a device: "uri": "/dev/stdin") is refused, not read:
    // reading would block the import until something writes to it, or never end.
    ASSERT_EQ(::mkfifo((dir / "scene.bin").c_str(), 0600), 0);
    const std::string fifoError = importError<vox::IoError>(dir / "scene.gltf", noTextures);
    EXPECT_NE(
        fifoError.find("cannot read '" + (dir / "scene.bin").string() + "': is not a regular file"),
        std::string::npos)
        << fifoError;
    std::filesystem::remove(dir / "scene.bin");
    writeSingleNode(dir, gltf, {"n", gltf.addMesh("tri", {triangle(material)})},
                    BufferStorage::External);
    ASSERT_EQ(::mkfifo((dir / "missing.png").c_str(), 0600), 0);
    const std::string imageFifoError = importError<vox::IoError>(dir / "scene.gltf");
    EXPECT_NE(imageFifoError.find("missing.png': is not a regular file"), std::string::npos)
        << imageFifoError;
}

TEST(GltfImport, MalformedDocumentsAreInvalidData) {
    ScratchDir dir;
    auto base = [] {
        GltfBuilder gltf;
        gltf.setSceneRoots({gltf.addNode({"n", gltf.addMesh("tri", {triangle()})})});
        return gltf;
    };
    struct Case {
        const char* name;
        std::function<void(nlohmann::json&)> edit;
        const char* expected;
    };
    const std::vector<Case> cases = {
        {"wrong type", [](nlohmann::json& j) { j["nodes"][0]["name"] = 5; },
         "nodes[0].name: expected a string"},
        {"index out of range", [](nlohmann::json& j) { j["nodes"][0]["mesh"] = 7; },
         "nodes[0].mesh: index 7 out of range"},
        {"accessor past its view", [](nlohmann::json& j) { j["accessors"][0]["count"] = 4; },
         "exceed buffer view"},
        {"view past its buffer",
         [](nlohmann::json& j) { j["bufferViews"][0]["byteLength"] = 4000; }, "exceed buffer 0"},
        {"unsupported required extension",
         [](nlohmann::json& j) { j["extensionsRequired"] = {"EXT_meshopt_compression"}; },
         "EXT_meshopt_compression"},
        {"glTF 1", [](nlohmann::json& j) { j["asset"]["version"] = "1.0"; }, "version '1.0'"},
        {"node cycle", [](nlohmann::json& j) { j["nodes"][0]["children"] = {0}; }, "cycle"},
        {"only points", [](nlohmann::json& j) { j["meshes"][0]["primitives"][0]["mode"] = 0; },
         "contains no triangles"},
        {"non-finite position",
         [](nlohmann::json& j) {
             j["accessors"][0].erase("min");
             j["accessors"][0].erase("max");
             j["nodes"][0]["scale"] = {1e39, 1, 1};
         },
         "non-finite"},
        {"component type", [](nlohmann::json& j) { j["accessors"][0]["componentType"] = 5130; },
         "unknown component type"},
        {"bad alpha mode",
         [](nlohmann::json& j) {
             j["materials"] = {{{"alphaMode", "SOMETIMES"}}};
             j["meshes"][0]["primitives"][0]["material"] = 0;
         },
         "alphaMode"},
    };
    for (const Case& c : cases) {
        GltfBuilder gltf = base();
        c.edit(gltf.json());
        const auto file = dir / (std::string(c.name) + ".gltf");
        gltf.write(file, BufferStorage::DataUri);
        const std::string message = importError<vox::InvalidDataError>(file);
        EXPECT_NE(message.find(c.expected), std::string::npos) << c.name << ": " << message;
    }
    vox::test::writeText(dir / "truncated.gltf", R"({"asset": {"version": "2.0"}, "nodes": [)");
    EXPECT_NE(importError<vox::InvalidDataError>(dir / "truncated.gltf").find("malformed JSON"),
              std::string::npos);
    // Found by fuzz_gltf: a number beyond double is nlohmann's out_of_range, not a parse_error,
    // and escaped as an internal error (exit 4).
    vox::test::writeText(dir / "overflow.gltf",
                         R"({"asset": {"version": "2.0"}, "scene": 0.8e39929})");
    EXPECT_NE(importError<vox::InvalidDataError>(dir / "overflow.gltf")
                  .find("malformed JSON: number overflow parsing '0.8e39929'"),
              std::string::npos);
}

TEST(GltfImport, VertexIndexOutOfRangeNamesThePrimitive) {
    ScratchDir dir;
    GltfBuilder gltf;
    GltfBuilder::Primitive p = triangle();
    p.indices = {0, 1, 3};
    writeSingleNode(dir, gltf, {"n", gltf.addMesh("broken", {p})});
    const std::string message = importError<vox::InvalidDataError>(dir / "scene.gltf");
    EXPECT_NE(message.find("mesh 0 'broken' primitive 0: vertex index 3 out of range (3 vertices)"),
              std::string::npos)
        << message;
}

TEST(GltfImport, ContentsMustMatchTheExtension) {
    ScratchDir dir;
    GltfBuilder gltf;
    writeSingleNode(dir, gltf, {"n", gltf.addMesh("tri", {triangle()})}, BufferStorage::Glb,
                    "real.glb");
    std::filesystem::copy_file(dir / "real.glb", dir / "fake.gltf");
    EXPECT_NE(importError<vox::InvalidDataError>(dir / "fake.gltf").find("binary GLB"),
              std::string::npos);
    vox::test::writeText(dir / "fake.glb", "{\"asset\":{\"version\":\"2.0\"}}");
    EXPECT_NE(importError<vox::InvalidDataError>(dir / "fake.glb").find("not a GLB"),
              std::string::npos);
    // A GLB whose JSON chunk claims more bytes than the file has.
    auto bytes = std::vector<std::uint8_t>(std::filesystem::file_size(dir / "real.glb"));
    std::ifstream(dir / "real.glb", std::ios::binary)
        .read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    const std::uint32_t huge = 0x7fffffff;
    std::memcpy(bytes.data() + 12, &huge, 4);
    vox::test::writeBinary(dir / "chunk.glb", bytes);
    EXPECT_NE(importError<vox::InvalidDataError>(dir / "chunk.glb").find("JSON chunk"),
              std::string::npos);
    // Found by fuzz_gltf: a total length below the headers' 20 bytes wrapped `length - 20` around,
    // and the JSON chunk's claimed length then passed, reading past the file.
    const std::uint32_t zero = 0, chunk = static_cast<std::uint32_t>(bytes.size() + 100);
    std::memcpy(bytes.data() + 8, &zero, 4);
    std::memcpy(bytes.data() + 12, &chunk, 4);
    vox::test::writeBinary(dir / "length.glb", bytes);
    EXPECT_NE(importError<vox::InvalidDataError>(dir / "length.glb")
                  .find("less than its own 20-byte headers"),
              std::string::npos);
    // Found by fuzz_gltf: a binary chunk 8 bytes longer than the header's length leaves (tinygltf
    // forgets the chunk's own header) made tinygltf read past the container rewritten for Draco.
    (void)importOk(dir / "real.glb");
    std::ifstream(dir / "real.glb", std::ios::binary)
        .read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    std::uint32_t json = 0, binary = 0;
    std::memcpy(&json, bytes.data() + 12, 4);
    std::memcpy(&binary, bytes.data() + 20 + json, 4);
    ASSERT_EQ(bytes.size(), 20u + json + 8 + binary);
    const auto shortLength = static_cast<std::uint32_t>(bytes.size() - 8);
    std::memcpy(bytes.data() + 8, &shortLength, 4);
    vox::test::writeBinary(dir / "binary.glb", bytes);
    EXPECT_NE(importError<vox::InvalidDataError>(dir / "binary.glb")
                  .find("second chunk claims " + std::to_string(binary) +
                        " bytes but the header's length leaves " + std::to_string(binary - 8)),
              std::string::npos);
    vox::test::writeText(dir / "scene.fbx", "whatever");
    EXPECT_NE(
        importError<vox::InvalidDataError>(dir / "scene.fbx").find("unsupported file type '.fbx'"),
        std::string::npos);
    EXPECT_THROW((void)vox::importScene(dir / "absent.gltf"), vox::IoError);
}

TEST(GltfImport, MissingUvSetReadsZeroWithAWarning) {
    ScratchDir dir;
    GltfBuilder gltf;
    const std::vector<std::uint8_t> pixels(3, 255);
    const int material = gltf.addMaterial(
        {"m",
         {1, 1, 1, 1},
         gltf.addTexture(gltf.addBufferImage(vox::encodePng(1, 1, 3, pixels), "image/png"))});
    gltf.json()["materials"][material]["pbrMetallicRoughness"]["baseColorTexture"]["texCoord"] = 1;
    writeSingleNode(dir, gltf, {"n", gltf.addMesh("tri", {triangle(material)})});
    const vox::Scene scene = importOk(dir / "scene.gltf");
    ASSERT_EQ(scene.meshes.at(0).uvs.size(), 2u);
    EXPECT_EQ(scene.meshes[0].uvs[1][2], (vox::Vec2f{0, 0}));
    ASSERT_EQ(scene.warnings.size(), 1u);
    EXPECT_NE(scene.warnings[0].find("UV set"), std::string::npos);
}

TEST(GltfImport, DegenerateTrianglesAreDroppedWithAWarningOrRejectedWhenStrict) {
    ScratchDir dir;
    GltfBuilder gltf;
    GltfBuilder::Primitive p = triangle();
    p.positions.insert(p.positions.end(), {2, 0, 0, 3, 0, 0, 4, 0, 0});  // collinear: no area
    p.normals.insert(p.normals.end(), {0, 0, 1, 0, 0, 1, 0, 0, 1});
    p.indices = {0, 1, 2, 3, 4, 5, 0, 0, 1};
    writeSingleNode(dir, gltf, {"n", gltf.addMesh("tri", {p})});
    const vox::Scene scene = importOk(dir / "scene.gltf");
    EXPECT_EQ(scene.triangleCount(), 1u);
    EXPECT_EQ(scene.degenerateTrianglesDropped, 2u);
    vox::ImportOptions strict;
    strict.strict = true;
    EXPECT_NE(importError<vox::InvalidDataError>(dir / "scene.gltf", strict).find("degenerate"),
              std::string::npos);
}

namespace {

/// Draco-encodes a box and returns the bytes, with the attribute ids of position and normal.
std::vector<std::uint8_t> dracoBox(int& positionId, int& normalId) {
    const auto box = vox::scenes::boxPrimitive({0, 0, 0}, {1, 2, 3}, -1);
    draco::TriangleSoupMeshBuilder builder;
    builder.Start(static_cast<int>(box.indices.size() / 3));
    positionId = builder.AddAttribute(draco::GeometryAttribute::POSITION, 3, draco::DT_FLOAT32);
    normalId = builder.AddAttribute(draco::GeometryAttribute::NORMAL, 3, draco::DT_FLOAT32);
    for (std::size_t t = 0; t < box.indices.size() / 3; ++t) {
        const float* v[3];
        const float* n[3];
        for (int k = 0; k < 3; ++k) {
            v[k] = &box.positions[3 * box.indices[3 * t + k]];
            n[k] = &box.normals[3 * box.indices[3 * t + k]];
        }
        builder.SetAttributeValuesForFace(
            positionId, draco::FaceIndex(static_cast<std::uint32_t>(t)), v[0], v[1], v[2]);
        builder.SetAttributeValuesForFace(normalId, draco::FaceIndex(static_cast<std::uint32_t>(t)),
                                          n[0], n[1], n[2]);
    }
    auto mesh = builder.Finalize();
    draco::Encoder encoder;
    encoder.SetAttributeQuantization(draco::GeometryAttribute::POSITION, 14);
    draco::EncoderBuffer buffer;
    if (!encoder.EncodeMeshToBuffer(*mesh, &buffer).ok()) return {};
    positionId = static_cast<int>(mesh->attribute(positionId)->unique_id());
    normalId = static_cast<int>(mesh->attribute(normalId)->unique_id());
    return {buffer.data(), buffer.data() + buffer.size()};
}

}  // namespace

TEST(GltfImport, DracoCompressedPrimitivesDecode) {
    ScratchDir dir;
    int positionId = 0, normalId = 0;
    const std::vector<std::uint8_t> draco = dracoBox(positionId, normalId);
    ASSERT_FALSE(draco.empty());
    for (BufferStorage storage : {BufferStorage::External, BufferStorage::Glb}) {
        GltfBuilder gltf;
        const int view = gltf.addBufferView(draco);
        gltf.json()["accessors"] = {{{"componentType", 5126}, {"count", 24}, {"type", "VEC3"}},
                                    {{"componentType", 5126}, {"count", 24}, {"type", "VEC3"}},
                                    {{"componentType", 5125}, {"count", 36}, {"type", "SCALAR"}}};
        gltf.json()["meshes"] = {
            {{"primitives",
              {{{"attributes", {{"POSITION", 0}, {"NORMAL", 1}}},
                {"indices", 2},
                {"extensions",
                 {{"KHR_draco_mesh_compression",
                   {{"bufferView", view},
                    {"attributes", {{"POSITION", positionId}, {"NORMAL", normalId}}}}}}}}}}}};
        gltf.json()["extensionsUsed"] = {"KHR_draco_mesh_compression"};
        gltf.json()["extensionsRequired"] = {"KHR_draco_mesh_compression"};
        const auto file = writeSingleNode(dir, gltf, {"box", 0}, storage,
                                          storage == BufferStorage::Glb ? "d.glb" : "d.gltf");
        const vox::Scene scene = importOk(file);
        ASSERT_EQ(scene.triangleCount(), 12u);
        const vox::Mesh& m = scene.meshes[0];
        EXPECT_NEAR(signedVolume(m), 6.0, 1e-2);
        const vox::Bounds3f b = scene.bounds();
        EXPECT_TRUE(near(b.max, {1, 2, 3}, 1e-3f));
        for (std::size_t t = 0; t < m.triangleCount(); ++t)
            EXPECT_GT(vox::dot(faceNormal(m, t), m.normals[m.indices[3 * t]]), 0.99f);

        // An attribute id the Draco data does not have is invalid data, not a crash.
        gltf.json()["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"]
                   ["attributes"]["NORMAL"] = 77;
        const auto broken = writeSingleNode(dir, gltf, {"box", 0}, storage,
                                            storage == BufferStorage::Glb ? "bad.glb" : "bad.gltf");
        EXPECT_NE(importError<vox::InvalidDataError>(broken).find("Draco attribute 77"),
                  std::string::npos);
    }
}

TEST(GltfImport, DeepHierarchiesAndNestingNeitherRecurseNorCrash) {
    ScratchDir dir;
    // A chain of 200000 nodes: deeper than any call stack would take recursively.
    GltfBuilder gltf;
    const int mesh = gltf.addMesh("tri", {triangle()});
    constexpr int kDepth = 200000;
    auto& nodes = gltf.json()["nodes"];
    nodes = nlohmann::json::array();
    for (int i = 0; i < kDepth; ++i) {
        nlohmann::json node = {{"translation", {0.0, 0.0, 1e-4}}};
        if (i + 1 < kDepth)
            node["children"] = {i + 1};
        else
            node["mesh"] = mesh;
        nodes.push_back(node);
    }
    gltf.setSceneRoots({0});
    gltf.write(dir / "deep.gltf", BufferStorage::DataUri);
    const vox::Scene scene = importOk(dir / "deep.gltf");
    ASSERT_EQ(scene.triangleCount(), 1u);
    EXPECT_NEAR(scene.meshes[0].positions[0].z, kDepth * 1e-4f, 1e-2f);

    // JSON nested a million levels deep in extras.
    std::string deep = R"({"asset": {"version": "2.0"}, "extras": )";
    deep += std::string(1000000, '[') + std::string(1000000, ']') + "}";
    vox::test::writeText(dir / "nested.gltf", deep);
    EXPECT_NE(importError<vox::InvalidDataError>(dir / "nested.gltf").find("nests deeper"),
              std::string::npos);
}
