#include "gltf_builder.h"

#include <cstring>
#include <fstream>
#include <limits>
#include <stdexcept>

namespace vox::scenes {
namespace {

std::string base64(std::span<const std::uint8_t> bytes) {
    static const char* table = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    out.reserve((bytes.size() + 2) / 3 * 4);
    for (std::size_t i = 0; i < bytes.size(); i += 3) {
        const std::uint32_t n = (std::uint32_t{bytes[i]} << 16) |
                                (i + 1 < bytes.size() ? std::uint32_t{bytes[i + 1]} << 8 : 0u) |
                                (i + 2 < bytes.size() ? std::uint32_t{bytes[i + 2]} : 0u);
        out.push_back(table[(n >> 18) & 63]);
        out.push_back(table[(n >> 12) & 63]);
        out.push_back(i + 1 < bytes.size() ? table[(n >> 6) & 63] : '=');
        out.push_back(i + 2 < bytes.size() ? table[n & 63] : '=');
    }
    return out;
}

void writeBytes(const std::filesystem::path& file, std::span<const std::uint8_t> bytes) {
    std::ofstream out(file, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(bytes.data()),
              static_cast<std::streamsize>(bytes.size()));
    if (!out) throw std::runtime_error("cannot write " + file.string());
}

}  // namespace

GltfBuilder::GltfBuilder() {
    root_["asset"] = {{"version", "2.0"}, {"generator", "libvox example scenes"}};
    root_["scene"] = 0;
    root_["scenes"] = nlohmann::json::array({{{"nodes", nlohmann::json::array()}}});
}

int GltfBuilder::push(const char* array, nlohmann::json value) {
    if (!root_.contains(array)) root_[array] = nlohmann::json::array();
    root_[array].push_back(std::move(value));
    return static_cast<int>(root_[array].size() - 1);
}

void GltfBuilder::useExtension(const std::string& name) {
    auto& used = root_["extensionsUsed"];
    if (used.is_null()) used = nlohmann::json::array();
    for (const auto& e : used)
        if (e == name) return;
    used.push_back(name);
}

int GltfBuilder::addBufferView(std::span<const std::uint8_t> bytes, int byteStride) {
    while (buffer_.size() % 4) buffer_.push_back(0);
    nlohmann::json view = {
        {"buffer", 0}, {"byteOffset", buffer_.size()}, {"byteLength", bytes.size()}};
    if (byteStride) view["byteStride"] = byteStride;
    buffer_.insert(buffer_.end(), bytes.begin(), bytes.end());
    return push("bufferViews", view);
}

int GltfBuilder::addFloatAccessor(std::span<const float> values, int components, bool withBounds) {
    const int view =
        addBufferView({reinterpret_cast<const std::uint8_t*>(values.data()), values.size_bytes()});
    static const char* types[] = {"", "SCALAR", "VEC2", "VEC3", "VEC4"};
    nlohmann::json accessor = {{"bufferView", view},
                               {"componentType", 5126},
                               {"count", values.size() / static_cast<std::size_t>(components)},
                               {"type", types[components]}};
    if (withBounds) {
        std::vector<float> lo(components, std::numeric_limits<float>::max()),
            hi(components, -std::numeric_limits<float>::max());
        for (std::size_t i = 0; i < values.size(); ++i) {
            lo[i % components] = std::min(lo[i % components], values[i]);
            hi[i % components] = std::max(hi[i % components], values[i]);
        }
        accessor["min"] = lo;
        accessor["max"] = hi;
    }
    return push("accessors", accessor);
}

int GltfBuilder::addIndexAccessor(std::span<const std::uint32_t> indices) {
    const int view = addBufferView(
        {reinterpret_cast<const std::uint8_t*>(indices.data()), indices.size_bytes()});
    return push("accessors", {{"bufferView", view},
                              {"componentType", 5125},
                              {"count", indices.size()},
                              {"type", "SCALAR"}});
}

int GltfBuilder::addRawAccessor(std::span<const std::uint8_t> bytes, int componentType,
                                const std::string& type, int count, bool normalized) {
    const int view = addBufferView(bytes);
    nlohmann::json accessor = {
        {"bufferView", view}, {"componentType", componentType}, {"count", count}, {"type", type}};
    if (normalized) accessor["normalized"] = true;
    return push("accessors", accessor);
}

int GltfBuilder::addImage(const std::string& uri) { return push("images", {{"uri", uri}}); }

int GltfBuilder::addBufferImage(std::span<const std::uint8_t> encoded,
                                const std::string& mimeType) {
    return push("images", {{"bufferView", addBufferView(encoded)}, {"mimeType", mimeType}});
}

int GltfBuilder::addTexture(int image, int wrapS, int wrapT) {
    const int sampler = push("samplers", {{"wrapS", wrapS}, {"wrapT", wrapT}});
    return push("textures", {{"source", image}, {"sampler", sampler}});
}

int GltfBuilder::addMaterial(const MaterialDesc& m) {
    nlohmann::json pbr = {
        {"baseColorFactor", m.baseColor}, {"metallicFactor", 0.0}, {"roughnessFactor", 1.0}};
    if (m.baseColorTexture >= 0) pbr["baseColorTexture"] = {{"index", m.baseColorTexture}};
    nlohmann::json material = {{"name", m.name}, {"pbrMetallicRoughness", pbr}};
    if (m.emissive != std::array<float, 3>{0, 0, 0}) material["emissiveFactor"] = m.emissive;
    if (m.emissiveStrength != 1.0f) {
        material["extensions"]["KHR_materials_emissive_strength"] = {
            {"emissiveStrength", m.emissiveStrength}};
        useExtension("KHR_materials_emissive_strength");
    }
    return push("materials", material);
}

int GltfBuilder::addMesh(const std::string& name, const std::vector<Primitive>& primitives) {
    nlohmann::json prims = nlohmann::json::array();
    for (const Primitive& p : primitives) {
        nlohmann::json attributes = {{"POSITION", addFloatAccessor(p.positions, 3, true)}};
        if (!p.normals.empty()) attributes["NORMAL"] = addFloatAccessor(p.normals, 3);
        if (!p.uvs.empty()) attributes["TEXCOORD_0"] = addFloatAccessor(p.uvs, 2);
        nlohmann::json prim = {{"attributes", attributes}, {"mode", p.mode}};
        if (!p.indices.empty()) prim["indices"] = addIndexAccessor(p.indices);
        if (p.material >= 0) prim["material"] = p.material;
        prims.push_back(prim);
    }
    return push("meshes", {{"name", name}, {"primitives", prims}});
}

int GltfBuilder::addLight(const LightDesc& l) {
    useExtension("KHR_lights_punctual");
    nlohmann::json light = {
        {"name", l.name}, {"type", l.type}, {"color", l.color}, {"intensity", l.intensity}};
    if (l.range > 0) light["range"] = l.range;
    if (l.type == "spot")
        light["spot"] = {{"innerConeAngle", l.innerConeAngle},
                         {"outerConeAngle", l.outerConeAngle}};
    auto& lights = root_["extensions"]["KHR_lights_punctual"]["lights"];
    if (lights.is_null()) lights = nlohmann::json::array();
    lights.push_back(light);
    return static_cast<int>(lights.size() - 1);
}

int GltfBuilder::addNode(const NodeDesc& n) {
    nlohmann::json node = {{"name", n.name}};
    if (n.mesh >= 0) node["mesh"] = n.mesh;
    if (n.light >= 0) node["extensions"]["KHR_lights_punctual"] = {{"light", n.light}};
    if (n.translation != std::array<double, 3>{0, 0, 0}) node["translation"] = n.translation;
    if (n.rotation != std::array<double, 4>{0, 0, 0, 1}) node["rotation"] = n.rotation;
    if (n.scale != std::array<double, 3>{1, 1, 1}) node["scale"] = n.scale;
    if (n.dynamic) node["extras"] = {{"dynamic", true}};
    if (!n.children.empty()) node["children"] = n.children;
    return push("nodes", node);
}

void GltfBuilder::setSceneRoots(const std::vector<int>& nodes) {
    root_["scenes"][0]["nodes"] = nodes;
}

void GltfBuilder::write(const std::filesystem::path& file, BufferStorage storage) const {
    nlohmann::json doc = root_;
    if (!buffer_.empty()) {
        nlohmann::json buffer = {{"byteLength", buffer_.size()}};
        if (storage == BufferStorage::External) {
            const std::filesystem::path bin = file.parent_path() / (file.stem().string() + ".bin");
            writeBytes(bin, buffer_);
            buffer["uri"] = bin.filename().string();
        } else if (storage == BufferStorage::DataUri) {
            buffer["uri"] = "data:application/octet-stream;base64," + base64(buffer_);
        }
        doc["buffers"] = nlohmann::json::array({buffer});
    }
    if (storage != BufferStorage::Glb) {
        const std::string text = compactJson_ ? doc.dump() : doc.dump(1);
        writeBytes(file, {reinterpret_cast<const std::uint8_t*>(text.data()), text.size()});
        return;
    }
    std::string json = doc.dump();
    while (json.size() % 4) json.push_back(' ');
    std::vector<std::uint8_t> bin = buffer_;
    while (bin.size() % 4) bin.push_back(0);
    std::vector<std::uint8_t> out;
    auto u32 = [&](std::uint32_t v) {
        const auto* p = reinterpret_cast<const std::uint8_t*>(&v);
        out.insert(out.end(), p, p + 4);
    };
    const std::uint32_t total = 12 + 8 + static_cast<std::uint32_t>(json.size()) +
                                (bin.empty() ? 0 : 8 + static_cast<std::uint32_t>(bin.size()));
    out.insert(out.end(), {'g', 'l', 'T', 'F'});
    u32(2);
    u32(total);
    u32(static_cast<std::uint32_t>(json.size()));
    u32(0x4E4F534A);
    out.insert(out.end(), json.begin(), json.end());
    if (!bin.empty()) {
        u32(static_cast<std::uint32_t>(bin.size()));
        u32(0x004E4942);
        out.insert(out.end(), bin.begin(), bin.end());
    }
    writeBytes(file, out);
}

}  // namespace vox::scenes
