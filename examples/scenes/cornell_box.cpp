#include "cornell_box.h"
#include <vox/image_io.h>

#include "shapes.h"

#include <cmath>

namespace vox::scenes {

std::filesystem::path writeCornellBox(const std::filesystem::path& directory,
                                      BufferStorage storage) {
    std::filesystem::create_directories(directory);
    GltfBuilder gltf;

    // Checkerboard for the textured block: 64x64 texels, 8x8 squares.
    constexpr int kSize = 64;
    std::vector<std::uint8_t> checker(kSize * kSize * 3);
    for (int y = 0; y < kSize; ++y)
        for (int x = 0; x < kSize; ++x) {
            const bool light = ((x / 8) + (y / 8)) % 2 == 0;
            const std::uint8_t rgb[3] = {static_cast<std::uint8_t>(light ? 230 : 40),
                                         static_cast<std::uint8_t>(light ? 220 : 60),
                                         static_cast<std::uint8_t>(light ? 200 : 160)};
            std::copy(rgb, rgb + 3, checker.begin() + (y * kSize + x) * 3);
        }
    int image;
    if (storage == BufferStorage::External) {
        vox::writePng(directory / "checker.png", kSize, kSize, 3, checker);
        image = gltf.addImage("checker.png");
    } else {
        image = gltf.addBufferImage(vox::encodePng(kSize, kSize, 3, checker), "image/png");
    }
    const int checkerTexture = gltf.addTexture(image);

    // Classic Cornell box reflectances.
    const int white = gltf.addMaterial({"White", {0.73f, 0.73f, 0.73f, 1}});
    const int red = gltf.addMaterial({"Red", {0.63f, 0.065f, 0.05f, 1}});
    const int green = gltf.addMaterial({"Green", {0.14f, 0.45f, 0.091f, 1}});
    const int panel =
        gltf.addMaterial({"LightPanel", {0.78f, 0.78f, 0.78f, 1}, -1, {1.0f, 0.85f, 0.6f}, 8.0f});
    const int checkered = gltf.addMaterial({"Checker", {1, 1, 1, 1}, checkerTexture});
    const int sphere = gltf.addMaterial({"Sphere", {0.8f, 0.75f, 0.3f, 1}});

    std::vector<int> roots;
    auto boxNode = [&](const char* name, std::array<float, 3> lo, std::array<float, 3> hi,
                       int material) {
        const int mesh = gltf.addMesh(name, {boxPrimitive(lo, hi, material)});
        roots.push_back(gltf.addNode({name, mesh}));
    };
    constexpr float t = 0.05f;  // wall thickness
    boxNode("Floor", {-1 - t, -t, -1 - t}, {1 + t, 0, 1}, white);
    boxNode("Ceiling", {-1 - t, 2, -1 - t}, {1 + t, 2 + t, 1}, white);
    boxNode("BackWall", {-1 - t, 0, -1 - t}, {1 + t, 2, -1}, white);
    boxNode("RedWall", {-1 - t, 0, -1}, {-1, 2, 1}, red);
    boxNode("GreenWall", {1, 0, -1}, {1 + t, 2, 1}, green);
    boxNode("LightPanel", {-0.3f, 1.97f, -0.3f}, {0.3f, 1.99f, 0.3f}, panel);
    boxNode("ShortBlock", {0.15f, 0, -0.75f}, {0.75f, 0.6f, -0.15f}, white);

    // The textured block, turned 20 degrees about Y.
    const double angle = 20.0 * 3.14159265358979 / 180.0;
    const int blockMesh = gltf.addMesh(
        "CheckerBlock", {boxPrimitive({-0.3f, 0, -0.3f}, {0.3f, 1.2f, 0.3f}, checkered)});
    roots.push_back(gltf.addNode({CornellBoxFacts::kTexturedNode,
                                  blockMesh,
                                  -1,
                                  {-0.4, 0, -0.35},
                                  {0, std::sin(angle / 2), 0, std::cos(angle / 2)}}));

    // The dynamic object: a runtime moves it, so static bakes leave it out.
    const int sphereMesh = gltf.addMesh("Sphere", {spherePrimitive(0.3f, 16, 24, sphere)});
    GltfBuilder::NodeDesc dynamicNode{
        CornellBoxFacts::kDynamicNode, sphereMesh, -1, {0.45, 0.3, 0.45}};
    dynamicNode.dynamic = true;
    roots.push_back(gltf.addNode(dynamicNode));

    // Three punctual lights.
    const int point = gltf.addLight({"CeilingPoint", "point", {1.0f, 0.9f, 0.75f}, 6.0f, 10.0f});
    roots.push_back(gltf.addNode({"CeilingPoint", -1, point, {0, 1.8, 0}}));
    const int spot =
        gltf.addLight({"BlockSpot", "spot", {0.9f, 0.95f, 1.0f}, 15.0f, 0.0f, 0.25f, 0.45f});
    roots.push_back(gltf.addNode(
        {"BlockSpot", -1, spot, {0.8, 1.8, 0.9}, rotationFromMinusZ({-1.2, -1.2, -1.25})}));
    const int sun = gltf.addLight({"Sun", "directional", {1.0f, 0.98f, 0.95f}, 2.0f});
    roots.push_back(
        gltf.addNode({"Sun", -1, sun, {0, 3, 3}, rotationFromMinusZ({0.2, -0.6, -1.0})}));

    gltf.setSceneRoots(roots);
    const std::filesystem::path file =
        directory / (storage == BufferStorage::Glb ? "cornell_box.glb" : "cornell_box.gltf");
    gltf.write(file, storage);
    return file;
}

}  // namespace vox::scenes
