// Writes the generated part of the fuzzers' seed corpora (docs/fuzzing.md): small glTF/GLB scenes
// covering what the importer reads (data URIs, node transforms, lights, strips and fans, sparse
// and quantized accessors, Draco compression) and Draco .drc meshes and point clouds. The .esvo
// and .rvol seeds are written by voxelize from the Cornell box written here (fuzz/CMakeLists.txt).
// Usage: make_fuzz_seeds OUTPUT_DIR (writes OUTPUT_DIR/gltf and OUTPUT_DIR/drc).
#include "cornell_box.h"
#include "gltf_builder.h"
#include "shapes.h"

#include <draco/compression/encode.h>
#include <draco/mesh/triangle_soup_mesh_builder.h>
#include <draco/point_cloud/point_cloud_builder.h>

#include <cstdio>
#include <fstream>
#include <stdexcept>

namespace {

namespace fs = std::filesystem;
using vox::scenes::BufferStorage;
using vox::scenes::GltfBuilder;

void writeBytes(const fs::path& file, const draco::EncoderBuffer& buffer) {
    std::ofstream out(file, std::ios::binary);
    out.write(buffer.data(), static_cast<std::streamsize>(buffer.size()));
    if (!out) throw std::runtime_error("cannot write " + file.string());
}

GltfBuilder::Primitive triangle() {
    GltfBuilder::Primitive p;
    p.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    p.normals = {0, 0, 1, 0, 0, 1, 0, 0, 1};
    p.uvs = {0, 0, 1, 0, 0, 1};
    p.indices = {0, 1, 2};
    return p;
}

void writeGltfSeeds(const fs::path& dir) {
    fs::create_directories(dir);
    vox::scenes::writeCornellBox(dir, BufferStorage::Glb);
    {
        GltfBuilder gltf;
        GltfBuilder::MaterialDesc material;
        material.baseColor = {0.8f, 0.2f, 0.1f, 1};
        auto p = triangle();
        p.material = gltf.addMaterial(material);
        gltf.setSceneRoots({gltf.addNode({"tri", gltf.addMesh("tri", {p})})});
        gltf.write(dir / "triangle.gltf", BufferStorage::DataUri);
        gltf.write(dir / "triangle.glb", BufferStorage::Glb);
    }
    {
        // Strips, fans, unindexed triangles, a hierarchy with TRS and matrix transforms, lights of
        // every type, a dynamic node, an emissive material with a strength.
        GltfBuilder gltf;
        GltfBuilder::MaterialDesc glow;
        glow.emissive = {1, 0.5f, 0};
        glow.emissiveStrength = 4;
        GltfBuilder::Primitive strip, fan, soup;
        strip.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0, 0, 2, 0};
        strip.mode = 5;
        fan.positions = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, -1, 1, 0};
        fan.mode = 6;
        fan.material = gltf.addMaterial(glow);
        soup.positions = {0, 0, 1, 1, 0, 1, 0, 1, 1, 2, 0, 1, 3, 0, 1, 2, 1, 1};
        const int mesh = gltf.addMesh("shapes", {strip, fan, soup});
        GltfBuilder::LightDesc point{"bulb", "point", {1, 0.9f, 0.8f}, 20, 10};
        GltfBuilder::LightDesc spot{"spot", "spot", {1, 1, 1}, 50, 0, 0.2f, 0.6f};
        GltfBuilder::LightDesc sun{"sun", "directional", {1, 1, 0.9f}, 3};
        const int bulb = gltf.addNode({"bulb", -1, gltf.addLight(point), {0, 3, 0}});
        const int lamp = gltf.addNode(
            {"lamp", -1, gltf.addLight(spot), {2, 3, 0}, {0.7071068, 0, 0, 0.7071068}});
        const int sky = gltf.addNode({"sky", -1, gltf.addLight(sun)});
        GltfBuilder::NodeDesc child{"child",  mesh, -1, {1, 0, 0}, {0, 0, 0.3826834, 0.9238795},
                                    {2, 1, 1}};
        child.dynamic = true;
        const int moving = gltf.addNode(child);
        const int parent = gltf.addNode(
            {"parent", mesh, -1, {0, 0, -2}, {0, 0, 0, 1}, {1, 1, 1}, false, {moving, bulb, lamp}});
        gltf.json()["nodes"][sky]["matrix"] = {1, 0, 0, 0, 0, 0, -1, 0, 0, 1, 0, 0, 5, 6, 7, 1};
        gltf.setSceneRoots({parent, sky});
        gltf.write(dir / "hierarchy.gltf", BufferStorage::DataUri);
    }
    {
        // A sparse accessor moving one vertex, and KHR_mesh_quantization's normalized shorts.
        GltfBuilder gltf;
        auto p = triangle();
        const int mesh = gltf.addMesh("tri", {p});
        const std::uint32_t index = 2;
        const float moved[3] = {0, 2, 0};
        const int indexView =
            gltf.addBufferView({reinterpret_cast<const std::uint8_t*>(&index), sizeof index});
        const int valueView =
            gltf.addBufferView({reinterpret_cast<const std::uint8_t*>(moved), sizeof moved});
        auto& position =
            gltf.json()["accessors"]
                       [gltf.json()["meshes"][mesh]["primitives"][0]["attributes"]["POSITION"]
                            .get<int>()];
        position["sparse"] = {{"count", 1},
                              {"indices", {{"bufferView", indexView}, {"componentType", 5125}}},
                              {"values", {{"bufferView", valueView}}}};
        const std::int16_t shorts[12] = {0, 0, 0, 0,     32767, 0,
                                         0, 0, 0, 32767, 0,     0};  // VEC3 padded to 8 bytes
        const int view =
            gltf.addBufferView({reinterpret_cast<const std::uint8_t*>(shorts), sizeof shorts}, 8);
        gltf.json()["accessors"].push_back({{"bufferView", view},
                                            {"componentType", 5122},
                                            {"normalized", true},
                                            {"type", "VEC3"},
                                            {"count", 3}});
        const int quantizedMesh = static_cast<int>(gltf.json()["meshes"].size());
        nlohmann::json primitive;
        primitive["attributes"]["POSITION"] = gltf.json()["accessors"].size() - 1;
        nlohmann::json quantized;
        quantized["name"] = "quantized";
        quantized["primitives"] = nlohmann::json::array({primitive});
        gltf.json()["meshes"].push_back(quantized);
        gltf.json()["extensionsUsed"].push_back("KHR_mesh_quantization");
        gltf.json()["extensionsRequired"] = {"KHR_mesh_quantization"};
        gltf.setSceneRoots(
            {gltf.addNode({"sparse", mesh}), gltf.addNode({"quantized", quantizedMesh})});
        gltf.write(dir / "accessors.gltf", BufferStorage::DataUri);
    }
    {
        // KHR_draco_mesh_compression: a Draco-compressed box.
        const auto box = vox::scenes::boxPrimitive({0, 0, 0}, {1, 2, 3}, -1);
        draco::TriangleSoupMeshBuilder builder;
        builder.Start(static_cast<int>(box.indices.size() / 3));
        const int pos =
            builder.AddAttribute(draco::GeometryAttribute::POSITION, 3, draco::DT_FLOAT32);
        const int nor =
            builder.AddAttribute(draco::GeometryAttribute::NORMAL, 3, draco::DT_FLOAT32);
        for (std::size_t t = 0; t < box.indices.size() / 3; ++t) {
            const float* v[3];
            const float* n[3];
            for (int k = 0; k < 3; ++k) {
                v[k] = &box.positions[3 * box.indices[3 * t + k]];
                n[k] = &box.normals[3 * box.indices[3 * t + k]];
            }
            const draco::FaceIndex face(static_cast<std::uint32_t>(t));
            builder.SetAttributeValuesForFace(pos, face, v[0], v[1], v[2]);
            builder.SetAttributeValuesForFace(nor, face, n[0], n[1], n[2]);
        }
        const auto mesh = builder.Finalize();
        draco::Encoder encoder;
        draco::EncoderBuffer buffer;
        if (!encoder.EncodeMeshToBuffer(*mesh, &buffer).ok())
            throw std::runtime_error("Draco encoding failed");
        GltfBuilder gltf;
        const int view = gltf.addBufferView(
            {reinterpret_cast<const std::uint8_t*>(buffer.data()), buffer.size()});
        const int count = static_cast<int>(box.indices.size());
        gltf.json()["accessors"] = {
            {{"componentType", 5126}, {"count", count}, {"type", "VEC3"}},
            {{"componentType", 5126}, {"count", count}, {"type", "VEC3"}},
            {{"componentType", 5125}, {"count", count}, {"type", "SCALAR"}}};
        const nlohmann::json draco = {{"bufferView", view},
                                      {"attributes",
                                       {{"POSITION", mesh->attribute(pos)->unique_id()},
                                        {"NORMAL", mesh->attribute(nor)->unique_id()}}}};
        gltf.json()["meshes"] = {{{"primitives",
                                   {{{"attributes", {{"POSITION", 0}, {"NORMAL", 1}}},
                                     {"indices", 2},
                                     {"extensions", {{"KHR_draco_mesh_compression", draco}}}}}}}};
        gltf.json()["extensionsUsed"] = {"KHR_draco_mesh_compression"};
        gltf.json()["extensionsRequired"] = {"KHR_draco_mesh_compression"};
        gltf.setSceneRoots({gltf.addNode({"box", 0})});
        gltf.write(dir / "draco.glb", BufferStorage::Glb);
    }
}

void writeDrcSeeds(const fs::path& dir) {
    fs::create_directories(dir);
    // A quad with colours, texture coordinates and normals, in both of Draco's mesh encodings.
    draco::TriangleSoupMeshBuilder builder;
    builder.Start(2);
    const int pos = builder.AddAttribute(draco::GeometryAttribute::POSITION, 3, draco::DT_FLOAT32);
    const int nor = builder.AddAttribute(draco::GeometryAttribute::NORMAL, 3, draco::DT_FLOAT32);
    const int col = builder.AddAttribute(draco::GeometryAttribute::COLOR, 3, draco::DT_UINT8);
    const int tex = builder.AddAttribute(draco::GeometryAttribute::TEX_COORD, 2, draco::DT_FLOAT32);
    const float p[4][3] = {{0, 0, 0}, {4, 0, 0}, {4, 4, 0}, {0, 4, 0}};
    const float n[3] = {0, 0, 1};
    const std::uint8_t c[4][3] = {{255, 0, 0}, {0, 255, 0}, {0, 0, 255}, {255, 255, 255}};
    const float t[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    const int faces[2][3] = {{0, 1, 2}, {0, 2, 3}};
    for (int f = 0; f < 2; ++f) {
        const draco::FaceIndex face(f);
        const int* v = faces[f];
        builder.SetAttributeValuesForFace(pos, face, p[v[0]], p[v[1]], p[v[2]]);
        builder.SetAttributeValuesForFace(nor, face, n, n, n);
        builder.SetAttributeValuesForFace(col, face, c[v[0]], c[v[1]], c[v[2]]);
        builder.SetAttributeValuesForFace(tex, face, t[v[0]], t[v[1]], t[v[2]]);
    }
    const auto quad = builder.Finalize();
    for (const auto& [name, method] :
         {std::pair{"quad_edgebreaker.drc", draco::MESH_EDGEBREAKER_ENCODING},
          std::pair{"quad_sequential.drc", draco::MESH_SEQUENTIAL_ENCODING}}) {
        draco::Encoder encoder;
        encoder.SetEncodingMethod(method);
        draco::EncoderBuffer buffer;
        if (!encoder.EncodeMeshToBuffer(*quad, &buffer).ok())
            throw std::runtime_error("Draco encoding failed");
        writeBytes(dir / name, buffer);
    }
    {
        // Unquantized (lossless) positions take another decoder path.
        draco::Encoder encoder;
        encoder.SetAttributeQuantization(draco::GeometryAttribute::POSITION, 0);
        encoder.SetSpeedOptions(10, 10);
        draco::EncoderBuffer buffer;
        if (!encoder.EncodeMeshToBuffer(*quad, &buffer).ok())
            throw std::runtime_error("Draco encoding failed");
        writeBytes(dir / "quad_lossless.drc", buffer);
    }
    {
        // A point cloud: no triangles, which import rejects.
        draco::PointCloudBuilder points;
        points.Start(3);
        const int at =
            points.AddAttribute(draco::GeometryAttribute::POSITION, 3, draco::DT_FLOAT32);
        for (std::uint32_t i = 0; i < 3; ++i)
            points.SetAttributeValueForPoint(at, draco::PointIndex(i), p[i]);
        draco::Encoder encoder;
        draco::EncoderBuffer buffer;
        if (!encoder.EncodePointCloudToBuffer(*points.Finalize(false), &buffer).ok())
            throw std::runtime_error("Draco encoding failed");
        writeBytes(dir / "points.drc", buffer);
    }
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 2) {
        std::fprintf(stderr, "usage: make_fuzz_seeds OUTPUT_DIR\n");
        return 1;
    }
    try {
        writeGltfSeeds(fs::path(argv[1]) / "gltf");
        writeDrcSeeds(fs::path(argv[1]) / "drc");
    } catch (const std::exception& e) {
        std::fprintf(stderr, "make_fuzz_seeds: error: %s\n", e.what());
        return 2;
    }
    return 0;
}
