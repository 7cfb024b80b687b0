// A small glTF 2.0 writer for libvox's example and test scenes. It keeps the document as JSON so
// that tests can also write deliberately broken files by editing it before write().
#pragma once

#include <nlohmann/json.hpp>

#include <array>
#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

namespace vox::scenes {

/// How binary data is stored.
enum class BufferStorage {
    External,  ///< NAME.bin beside the .gltf
    DataUri,   ///< base64 inside the .gltf
    Glb,       ///< binary chunk of a .glb
};

class GltfBuilder {
public:
    GltfBuilder();

    /// Appends raw bytes to the buffer (4-byte aligned) as a new buffer view; returns its index.
    int addBufferView(std::span<const std::uint8_t> bytes, int byteStride = 0);
    /// Adds an accessor over a new buffer view holding @p values (tightly packed).
    int addFloatAccessor(std::span<const float> values, int components, bool withBounds = false);
    int addIndexAccessor(std::span<const std::uint32_t> indices);
    /// Adds an accessor with a given component type over raw bytes (normalized integers, ...).
    int addRawAccessor(std::span<const std::uint8_t> bytes, int componentType,
                       const std::string& type, int count, bool normalized = false);

    int addImage(const std::string& uri);
    /// An image stored in the buffer (GLB / embedded style) with its MIME type.
    int addBufferImage(std::span<const std::uint8_t> encoded, const std::string& mimeType);
    int addTexture(int image, int wrapS = 10497, int wrapT = 10497);

    struct MaterialDesc {
        std::string name;
        std::array<float, 4> baseColor{1, 1, 1, 1};
        int baseColorTexture = -1;
        std::array<float, 3> emissive{0, 0, 0};
        float emissiveStrength = 1.0f;  ///< written as KHR_materials_emissive_strength when != 1
    };
    int addMaterial(const MaterialDesc& material);

    struct Primitive {
        std::vector<float> positions;        ///< xyz per vertex
        std::vector<float> normals;          ///< optional
        std::vector<float> uvs;              ///< optional, TEXCOORD_0
        std::vector<std::uint32_t> indices;  ///< optional
        int material = -1;
        int mode = 4;
    };
    int addMesh(const std::string& name, const std::vector<Primitive>& primitives);

    struct LightDesc {
        std::string name;
        std::string type = "point";  ///< directional, point, spot
        std::array<float, 3> color{1, 1, 1};
        float intensity = 1.0f;
        float range = 0.0f;  ///< 0: not written
        float innerConeAngle = 0.0f, outerConeAngle = 0.7853982f;
    };
    int addLight(const LightDesc& light);

    struct NodeDesc {
        std::string name;
        int mesh = -1;
        int light = -1;
        std::array<double, 3> translation{0, 0, 0};
        std::array<double, 4> rotation{0, 0, 0, 1};  ///< quaternion xyzw
        std::array<double, 3> scale{1, 1, 1};
        bool dynamic = false;  ///< extras: {"dynamic": true}
        std::vector<int> children;
    };
    int addNode(const NodeDesc& node);
    /// Makes @p nodes the roots of the default scene.
    void setSceneRoots(const std::vector<int>& nodes);

    /// The document, to edit before write().
    nlohmann::json& json() { return root_; }

    /// Writes a .gltf's JSON on one line (as a .glb's always is) instead of indented: for
    /// documents with thousands of nodes and lights.
    void setCompactJson(bool compact) { compactJson_ = compact; }

    /// Writes @p file (.gltf or .glb); with External storage also "<stem>.bin" beside it.
    void write(const std::filesystem::path& file, BufferStorage storage) const;

private:
    int push(const char* array, nlohmann::json value);
    void useExtension(const std::string& name);

    nlohmann::json root_;
    std::vector<std::uint8_t> buffer_;
    bool compactJson_ = false;
};

}  // namespace vox::scenes
