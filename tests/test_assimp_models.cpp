// Every model of Debian's assimp-testmodels that libvox's formats cover: the valid ones import
// with the asserted triangle counts, the broken ones fail with the asserted error kind.
#include <vox/base/error.h>
#include <vox/import.h>

#include "assimp_models.h"
#include "test_support.h"

#include <cmath>

namespace {

using vox::test::ModelCase;

class AssimpModel : public ::testing::TestWithParam<ModelCase> {};

std::string caseName(const ::testing::TestParamInfo<ModelCase>& info) {
    std::string name = info.param.path;
    for (char& c : name)
        if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
    return name;
}

}  // namespace

TEST_P(AssimpModel, ImportsOrFailsAsExpected) {
    const ModelCase& c = GetParam();
    const std::filesystem::path file = vox::test::assimpModels() / c.path;
    ASSERT_TRUE(std::filesystem::exists(file))
        << file << " missing: is assimp-testmodels installed (scripts/install-deps.sh)?";
    if (c.error == vox::ExitCode::Ok) {
        vox::Scene scene;
        ASSERT_NO_THROW(scene = vox::importScene(file));
        EXPECT_EQ(scene.triangleCount(), c.triangles);
        EXPECT_EQ(scene.degenerateTrianglesDropped, c.degenerate);
        const vox::Bounds3f bounds = scene.bounds();
        EXPECT_FALSE(bounds.empty());
        for (const vox::Mesh& mesh : scene.meshes) {
            ASSERT_EQ(mesh.normals.size(), mesh.positions.size());
            for (const vox::Vec3f& n : mesh.normals) ASSERT_NEAR(vox::length(n), 1.0f, 1e-4f);
            ASSERT_LT(mesh.material, scene.materials.size());
        }
        return;
    }
    try {
        (void)vox::importScene(file);
        FAIL() << "imported, but should fail with: " << c.message;
    } catch (const vox::Error& e) {
        EXPECT_EQ(e.exitCode(), c.error) << e.what();
        EXPECT_NE(std::string(e.what()).find(c.message), std::string::npos) << e.what();
        EXPECT_EQ(std::string(e.what()).rfind(file.string(), 0), 0u)
            << "message must start with the file: " << e.what();
    }
}

INSTANTIATE_TEST_SUITE_P(Models, AssimpModel, ::testing::ValuesIn(vox::test::kAssimpModels),
                         caseName);

TEST(AssimpModels, DracoEngineHoldsExactlyTheUncompressedEnginesTriangles) {
    // Draco's encoder drops degenerate triangles itself; its quantisation then collapses a few
    // more to zero area, which libvox drops on import.
    const auto models = vox::test::assimpModels() / "glTF2";
    const vox::Scene plain =
        vox::importScene(models / "2CylinderEngine-glTF-Binary/2CylinderEngine.glb");
    const vox::Scene draco = vox::importScene(models / "draco/2CylinderEngine.gltf");
    EXPECT_EQ(plain.triangleCount(), draco.triangleCount() + draco.degenerateTrianglesDropped);
    EXPECT_EQ(plain.meshes.size(), draco.meshes.size());
    const vox::Bounds3f a = plain.bounds(), b = draco.bounds();
    const float tolerance = 0.001f * vox::length(a.extent());  // quantisation error
    for (int axis = 0; axis < 3; ++axis) {
        EXPECT_NEAR(a.min[axis], b.min[axis], tolerance);
        EXPECT_NEAR(a.max[axis], b.max[axis], tolerance);
    }
}

TEST(AssimpModels, TheSameModelInFourFormatsHasTheSameSurface) {
    const auto models = vox::test::assimpModels();
    std::vector<vox::Bounds3f> bounds;
    for (const char* path :
         {"OBJ/WusonOBJ.obj", "PLY/Wuson.ply", "STL/Wuson.stl", "OFF/Wuson.off"}) {
        const vox::Scene scene = vox::importScene(models / path);
        EXPECT_EQ(scene.triangleCount(), 3732u) << path;
        bounds.push_back(scene.bounds());
    }
    for (const vox::Bounds3f& b : bounds) {
        EXPECT_NEAR(b.min.z, bounds[0].min.z, 1e-4f);
        EXPECT_NEAR(b.max.y, bounds[0].max.y, 1e-4f);
    }
}

TEST(AssimpModels, StripFanAndListEncodingsOfOneSquareAgree) {
    const auto dir = vox::test::assimpModels() / "glTF2/glTF-Asset-Generator/Mesh_PrimitiveMode";
    for (const char* n : {"04", "05", "06", "11", "12", "13", "14", "15"}) {
        const vox::Scene scene =
            vox::importScene(dir / (std::string("Mesh_PrimitiveMode_") + n + ".gltf"));
        const vox::Mesh& m = scene.meshes.at(0);
        double area = 0;
        for (std::size_t t = 0; t < m.triangleCount(); ++t) {
            const vox::Vec3f a = m.positions[m.indices[3 * t]],
                             b = m.positions[m.indices[3 * t + 1]],
                             c = m.positions[m.indices[3 * t + 2]];
            const vox::Vec3f normal = vox::cross(b - a, c - a);
            area += vox::length(normal) / 2;
            EXPECT_GT(normal.z, 0.0f) << n << " triangle " << t << " faces away from +z";
        }
        EXPECT_NEAR(area, 1.0, 1e-6) << n;
    }
}

TEST(AssimpModels, TexturesOfRealFilesDecode) {
    const auto models = vox::test::assimpModels();
    const vox::Scene box = vox::importScene(models / "glTF2/BoxTextured-glTF/BoxTextured.gltf");
    ASSERT_EQ(box.textures.size(), 1u);
    EXPECT_EQ(box.textures[0].width(), 211);     // CesiumLogoFlat.png, a palette PNG
    EXPECT_EQ(box.textures[0].levelCount(), 8);  // 211 105 52 26 13 6 3 1
    const vox::Scene spider = vox::importScene(models / "OBJ/spider.obj");
    EXPECT_EQ(spider.textures.size(), 5u);  // .\name.jpg paths from Windows
}
