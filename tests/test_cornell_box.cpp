#include <vox/import.h>

#include "cornell_box.h"
#include "test_support.h"

using vox::scenes::CornellBoxFacts;

namespace {

const vox::Mesh& meshNamed(const vox::Scene& scene, const std::string& name) {
    for (const vox::Mesh& mesh : scene.meshes)
        if (mesh.name == name) return mesh;
    throw std::runtime_error("no mesh " + name);
}

}  // namespace

TEST(CornellBox, GeneratedSceneImportsWithEverythingTheExampleNeeds) {
    vox::test::ScratchDir dir;
    for (auto storage : {vox::scenes::BufferStorage::External, vox::scenes::BufferStorage::Glb}) {
        const auto file = vox::scenes::writeCornellBox(dir.path(), storage);
        const vox::Scene scene = vox::importScene(file);
        EXPECT_EQ(scene.triangleCount(), CornellBoxFacts::kTriangles);
        EXPECT_EQ(scene.materials.size(), static_cast<std::size_t>(CornellBoxFacts::kMaterials));
        EXPECT_EQ(scene.lights.size(), static_cast<std::size_t>(CornellBoxFacts::kLights));
        EXPECT_EQ(scene.textures.size(), 1u);
        EXPECT_EQ(scene.dynamicTriangleCount(), CornellBoxFacts::kSphereTriangles);
        EXPECT_TRUE(meshNamed(scene, CornellBoxFacts::kDynamicNode).dynamic);
        EXPECT_TRUE(scene.warnings.empty());

        const vox::Material& red = scene.materials[meshNamed(scene, "RedWall").material];
        const vox::Material& green = scene.materials[meshNamed(scene, "GreenWall").material];
        EXPECT_GT(red.baseColorFactor.x, 5 * red.baseColorFactor.y);
        EXPECT_GT(green.baseColorFactor.y, 2 * green.baseColorFactor.x);
        EXPECT_LT(meshNamed(scene, "RedWall").positions[0].x,
                  meshNamed(scene, "GreenWall").positions[0].x);
        EXPECT_TRUE(scene.materials[meshNamed(scene, "LightPanel").material].isEmissive());
        EXPECT_TRUE(scene.materials[meshNamed(scene, CornellBoxFacts::kTexturedNode).material]
                        .baseColorTexture.valid());

        // Every closed part faces outwards and agrees with its normals.
        for (const vox::Mesh& mesh : scene.meshes) {
            double volume = 0;
            for (std::size_t t = 0; t < mesh.triangleCount(); ++t) {
                const vox::Vec3f a = mesh.positions[mesh.indices[3 * t]],
                                 b = mesh.positions[mesh.indices[3 * t + 1]],
                                 c = mesh.positions[mesh.indices[3 * t + 2]];
                const vox::Vec3f n = vox::cross(b - a, c - a);
                volume += vox::dot(a, vox::cross(b, c)) / 6.0;
                EXPECT_GT(vox::dot(n, mesh.normals[mesh.indices[3 * t]]), 0.0f)
                    << mesh.name << " triangle " << t;
            }
            EXPECT_GT(volume, 0.0) << mesh.name;
        }
        // The spot light aims into the box, at the textured block.
        const vox::Light& spot = scene.lights[1];
        EXPECT_EQ(spot.type, vox::Light::Type::Spot);
        EXPECT_LT(spot.direction.y, 0.0f);
        EXPECT_LT(spot.direction.x, 0.0f);
    }
}
