// glTF 2.0 / GLB import: tinygltf parses (after validateGltfJson), this file turns the model into
// world-space triangles, materials, textures and lights, checking every accessor against the
// bytes that back it.
#include "draco_decode.h"
#include "gltf_validate.h"
#include "import_context.h"
#include "importers.h"
#include "tinygltf.h"

#include <vox/util/timings.h>

#include <draco/attributes/geometry_attribute.h>

#include <cmath>
#include <cstring>
#include <numbers>
#include <optional>

namespace vox::detail {
namespace {

/// Extensions whose absence would change the result; a file requiring any other is rejected.
const std::vector<std::string> kSupportedRequiredExtensions = {
    "KHR_draco_mesh_compression", "KHR_materials_emissive_strength",
    "KHR_lights_punctual",        "KHR_texture_transform",
    "KHR_mesh_quantization",      "KHR_materials_pbrSpecularGlossiness",
};

std::string firstLine(const std::string& text) {
    std::string line = text.substr(0, text.find('\n'));
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
    return line;
}

std::string percentDecode(const std::string& uri) {
    std::string out;
    for (std::size_t i = 0; i < uri.size(); ++i) {
        if (uri[i] == '%' && i + 2 < uri.size() &&
            std::isxdigit(static_cast<unsigned char>(uri[i + 1])) &&
            std::isxdigit(static_cast<unsigned char>(uri[i + 2]))) {
            out.push_back(static_cast<char>(std::stoi(uri.substr(i + 1, 2), nullptr, 16)));
            i += 2;
        } else {
            out.push_back(uri[i]);
        }
    }
    return out;
}

// tinygltf filesystem callbacks: reads go through the context (recorded for depfiles, errors kept
// so a missing buffer becomes an I/O error naming it), and paths are never shell-expanded.
struct FileAccess {
    ImportContext* context;
    std::optional<IoError> ioError;
};

bool fsFileExists(const std::string& path, void* user) {
    std::error_code ec;
    const auto status = std::filesystem::status(path, ec);
    if (std::filesystem::is_regular_file(status)) return true;
    auto* access = static_cast<FileAccess*>(user);
    if (!access->ioError)
        access->ioError.emplace(access->context->input(), "cannot read '" + path + "': " +
                                                              (std::filesystem::exists(status)
                                                                   ? "is not a regular file"
                                                                   : "No such file or directory"));
    return false;
}
std::string fsExpandPath(const std::string& path, void*) { return percentDecode(path); }
bool fsReadWholeFile(std::vector<unsigned char>* out, std::string* err, const std::string& path,
                     void* user) {
    auto* access = static_cast<FileAccess*>(user);
    try {
        *out = access->context->readFile(path);
        return true;
    } catch (const IoError& e) {
        if (!access->ioError) access->ioError.emplace(e);
        if (err) *err += e.what();
        return false;
    }
}
bool fsWriteWholeFile(std::string*, const std::string&, const std::vector<unsigned char>&, void*) {
    return false;
}

// Images keep their encoded bytes; OpenImageIO decodes the ones materials use.
bool keepEncodedImage(tinygltf::Image* image, const int, std::string*, std::string*, int, int,
                      const unsigned char* bytes, int size, void*) {
    image->image.assign(bytes, bytes + size);
    image->as_is = true;
    return true;
}

int componentSize(int componentType) {
    switch (componentType) {
        case TINYGLTF_COMPONENT_TYPE_BYTE:
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
            return 1;
        case TINYGLTF_COMPONENT_TYPE_SHORT:
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT:
            return 2;
        case TINYGLTF_COMPONENT_TYPE_INT:
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
        case TINYGLTF_COMPONENT_TYPE_FLOAT:
            return 4;
        default:
            return 0;
    }
}

double readComponent(const std::uint8_t* p, int componentType, bool normalized) {
    switch (componentType) {
        case TINYGLTF_COMPONENT_TYPE_BYTE: {
            std::int8_t v;
            std::memcpy(&v, p, 1);
            return normalized ? std::max(v / 127.0, -1.0) : v;
        }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
            return normalized ? *p / 255.0 : *p;
        case TINYGLTF_COMPONENT_TYPE_SHORT: {
            std::int16_t v;
            std::memcpy(&v, p, 2);
            return normalized ? std::max(v / 32767.0, -1.0) : v;
        }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
            std::uint16_t v;
            std::memcpy(&v, p, 2);
            return normalized ? v / 65535.0 : v;
        }
        case TINYGLTF_COMPONENT_TYPE_INT: {
            std::int32_t v;
            std::memcpy(&v, p, 4);
            return normalized ? std::max(v / 2147483647.0, -1.0) : v;
        }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
            std::uint32_t v;
            std::memcpy(&v, p, 4);
            return normalized ? v / 4294967295.0 : v;
        }
        case TINYGLTF_COMPONENT_TYPE_FLOAT: {
            float v;
            std::memcpy(&v, p, 4);
            return v;
        }
        default:
            return 0.0;
    }
}

class GltfImporter {
public:
    GltfImporter(ImportContext& context, tinygltf::Model& model)
        : context_(context), model_(model) {
        baseDir_ = context.input().parent_path();
    }

    void run();

private:
    [[noreturn]] void fail(const std::string& problem) const { context_.fail(problem); }

    /// A validated view of the bytes behind an accessor-like range.
    struct ByteRange {
        const std::uint8_t* data = nullptr;
        std::size_t stride = 0;
    };
    ByteRange viewBytes(int bufferViewIndex, std::uint64_t byteOffset, std::uint64_t count,
                        std::uint64_t elementSize, std::uint64_t stride,
                        const std::string& what) const;
    std::vector<double> readAccessor(int accessorIndex,
                                     std::initializer_list<int> allowedComponents, int& components,
                                     const std::string& what) const;
    std::vector<float> readFloats(int accessorIndex, std::initializer_list<int> allowedComponents,
                                  int& components, const std::string& what) const;
    std::vector<std::uint32_t> readIndices(int accessorIndex, const std::string& what) const;

    void importMaterials();
    TextureBinding bindTexture(int textureIndex, int texCoord,
                               const tinygltf::ExtensionMap& extensions, ColorSpace colorSpace,
                               const std::string& what);
    std::int32_t loadImage(int imageIndex, ColorSpace colorSpace);
    /// Imports a node's own mesh and light and queues it for its children.
    void importNode(int node, const Mat4d& parent, bool dynamic);
    /// Imports a root and everything below it, depth first, without recursion.
    void importHierarchy(int root);
    void importPrimitive(const tinygltf::Mesh& mesh, int meshIndex, int primitiveIndex,
                         const Mat4d& world, const std::string& nodeName, bool dynamic);
    void importLight(int lightIndex, const Mat4d& world, bool dynamic, const std::string& nodeName);
    static Mat4d localTransform(const tinygltf::Node& node);

    ImportContext& context_;
    tinygltf::Model& model_;
    std::filesystem::path baseDir_;
    std::vector<int> visitState_;  // 0 unvisited, 1 on the current path, 2 done
    struct PendingNode {
        int node;
        Mat4d world;
        bool dynamic;
        std::size_t nextChild;
    };
    std::vector<PendingNode> pending_;  // the depth-first path from the root
    std::size_t skippedPrimitives_ = 0;
    std::size_t missingUvSets_ = 0;
    std::size_t skinnedMeshes_ = 0;
};

GltfImporter::ByteRange GltfImporter::viewBytes(int bufferViewIndex, std::uint64_t byteOffset,
                                                std::uint64_t count, std::uint64_t elementSize,
                                                std::uint64_t stride,
                                                const std::string& what) const {
    if (bufferViewIndex < 0 ||
        static_cast<std::size_t>(bufferViewIndex) >= model_.bufferViews.size())
        fail(what + ": buffer view " + std::to_string(bufferViewIndex) + " out of range");
    const tinygltf::BufferView& view = model_.bufferViews[bufferViewIndex];
    if (view.buffer < 0 || static_cast<std::size_t>(view.buffer) >= model_.buffers.size())
        fail(what + ": buffer " + std::to_string(view.buffer) + " out of range");
    const tinygltf::Buffer& buffer = model_.buffers[view.buffer];
    if (view.byteOffset > buffer.data.size() ||
        view.byteLength > buffer.data.size() - view.byteOffset)
        fail(what + ": buffer view " + std::to_string(bufferViewIndex) + " exceeds buffer " +
             std::to_string(view.buffer) + " (" + std::to_string(buffer.data.size()) + " bytes)");
    if (view.byteStride) stride = view.byteStride;
    if (stride < elementSize)
        fail(what + ": byte stride " + std::to_string(stride) + " is smaller than an element (" +
             std::to_string(elementSize) + " bytes)");
    // Last element's end, computed without overflow: count and offsets come from the file.
    const std::uint64_t length = view.byteLength;
    if (byteOffset > length || count == 0 || (count - 1) > (length - byteOffset) / stride ||
        (count - 1) * stride + elementSize > length - byteOffset)
        fail(what + ": " + std::to_string(count) + " elements of " + std::to_string(elementSize) +
             " bytes at offset " + std::to_string(byteOffset) + " (stride " +
             std::to_string(stride) + ") exceed buffer view " + std::to_string(bufferViewIndex) +
             " (" + std::to_string(length) + " bytes)");
    return {buffer.data.data() + view.byteOffset + byteOffset, static_cast<std::size_t>(stride)};
}

std::vector<double> GltfImporter::readAccessor(int accessorIndex,
                                               std::initializer_list<int> allowedComponents,
                                               int& components, const std::string& what) const {
    const std::string label = what + " (accessor " + std::to_string(accessorIndex) + ")";
    if (accessorIndex < 0 || static_cast<std::size_t>(accessorIndex) >= model_.accessors.size())
        fail(what + ": accessor " + std::to_string(accessorIndex) + " out of range");
    const tinygltf::Accessor& accessor = model_.accessors[accessorIndex];
    components = tinygltf::GetNumComponentsInType(static_cast<std::uint32_t>(accessor.type));
    if (std::find(allowedComponents.begin(), allowedComponents.end(), components) ==
        allowedComponents.end())
        fail(label + ": unexpected accessor type with " + std::to_string(components) +
             " components");
    const int size = componentSize(accessor.componentType);
    if (size == 0)
        fail(label + ": unknown component type " + std::to_string(accessor.componentType));
    const std::uint64_t count = accessor.count;
    const std::uint64_t elementSize = static_cast<std::uint64_t>(size) * components;

    std::vector<double> values;
    if (accessor.bufferView >= 0) {
        const ByteRange range = viewBytes(accessor.bufferView, accessor.byteOffset, count,
                                          elementSize, elementSize, label);
        values.resize(count * components);
        for (std::uint64_t i = 0; i < count; ++i)
            for (int c = 0; c < components; ++c)
                values[i * components + c] = readComponent(
                    range.data + i * range.stride + static_cast<std::size_t>(c) * size,
                    accessor.componentType, accessor.normalized);
    } else {
        // No buffer view: zeros (typically under a sparse substitution). Nothing in the file backs
        // the count, so it is bounded by the bytes read rather than trusted.
        if (count > context_.bytesRead())
            fail(label + ": count " + std::to_string(count) +
                 " without a buffer view exceeds the file's size");
        values.assign(count * components, 0.0);
    }

    if (accessor.sparse.isSparse) {
        const auto& sparse = accessor.sparse;
        if (sparse.count < 1 || static_cast<std::uint64_t>(sparse.count) > count)
            fail(label + ": sparse count " + std::to_string(sparse.count) +
                 " exceeds the accessor's " + std::to_string(count));
        const int indexSize = componentSize(sparse.indices.componentType);
        if (indexSize == 0 || sparse.indices.componentType == TINYGLTF_COMPONENT_TYPE_FLOAT)
            fail(label + ": invalid sparse index component type");
        const ByteRange indices =
            viewBytes(sparse.indices.bufferView,
                      static_cast<std::uint64_t>(std::max(0, sparse.indices.byteOffset)),
                      sparse.count, indexSize, indexSize, label + " sparse indices");
        const ByteRange substitutes =
            viewBytes(sparse.values.bufferView,
                      static_cast<std::uint64_t>(std::max(0, sparse.values.byteOffset)),
                      sparse.count, elementSize, elementSize, label + " sparse values");
        for (int i = 0; i < sparse.count; ++i) {
            const auto target = static_cast<std::uint64_t>(
                readComponent(indices.data + static_cast<std::size_t>(i) * indexSize,
                              sparse.indices.componentType, false));
            if (target >= count)
                fail(label + ": sparse index " + std::to_string(target) + " out of range (" +
                     std::to_string(count) + ")");
            for (int c = 0; c < components; ++c)
                values[target * components + c] =
                    readComponent(substitutes.data + static_cast<std::size_t>(i) * elementSize +
                                      static_cast<std::size_t>(c) * size,
                                  accessor.componentType, accessor.normalized);
        }
    }
    return values;
}

std::vector<float> GltfImporter::readFloats(int accessorIndex,
                                            std::initializer_list<int> allowedComponents,
                                            int& components, const std::string& what) const {
    const std::vector<double> values =
        readAccessor(accessorIndex, allowedComponents, components, what);
    return {values.begin(), values.end()};
}

std::vector<std::uint32_t> GltfImporter::readIndices(int accessorIndex,
                                                     const std::string& what) const {
    const tinygltf::Accessor& accessor = model_.accessors.at(accessorIndex);
    const int type = accessor.componentType;
    if (type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE &&
        type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
        type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)
        fail(what + ": indices must be unsigned byte, short or int (accessor " +
             std::to_string(accessorIndex) + ")");
    if (accessor.normalized) fail(what + ": indices must not be normalized");
    int components = 0;
    const std::vector<double> values = readAccessor(accessorIndex, {1}, components, what);
    std::vector<std::uint32_t> indices(values.size());
    for (std::size_t i = 0; i < values.size(); ++i)
        indices[i] = static_cast<std::uint32_t>(values[i]);
    return indices;
}

Mat4d GltfImporter::localTransform(const tinygltf::Node& node) {
    Mat4d m;
    if (node.matrix.size() == 16) {
        for (int c = 0; c < 4; ++c)
            for (int r = 0; r < 4; ++r) m.m[c][r] = node.matrix[c * 4 + r];
        return m;
    }
    Mat4d t, r, s;
    if (node.translation.size() == 3)
        t.m[3] = {node.translation[0], node.translation[1], node.translation[2], 1};
    if (node.rotation.size() == 4) {
        double x = node.rotation[0], y = node.rotation[1], z = node.rotation[2],
               w = node.rotation[3];
        const double len = std::sqrt(x * x + y * y + z * z + w * w);
        if (len > 0) {
            x /= len;
            y /= len;
            z /= len;
            w /= len;
        }
        r.m[0] = {1 - 2 * (y * y + z * z), 2 * (x * y + z * w), 2 * (x * z - y * w), 0};
        r.m[1] = {2 * (x * y - z * w), 1 - 2 * (x * x + z * z), 2 * (y * z + x * w), 0};
        r.m[2] = {2 * (x * z + y * w), 2 * (y * z - x * w), 1 - 2 * (x * x + y * y), 0};
    }
    if (node.scale.size() == 3) {
        s.m[0][0] = node.scale[0];
        s.m[1][1] = node.scale[1];
        s.m[2][2] = node.scale[2];
    }
    return t * r * s;
}

std::int32_t GltfImporter::loadImage(int imageIndex, ColorSpace colorSpace) {
    const tinygltf::Image& image = model_.images.at(imageIndex);
    const std::string what =
        "image " + std::to_string(imageIndex) + (image.name.empty() ? "" : " '" + image.name + "'");
    return context_.texture(
        "image:" + std::to_string(imageIndex), colorSpace, [&]() -> ImportContext::EncodedImage {
            if (!image.image.empty()) return {image.image, context_.input(), what, image.mimeType};
            if (image.uri.empty()) fail(what + " has neither data nor a URI");
            const std::filesystem::path file = baseDir_ / percentDecode(image.uri);
            return {context_.readFile(file), file, "", image.mimeType};
        });
}

TextureBinding GltfImporter::bindTexture(int textureIndex, int texCoord,
                                         const tinygltf::ExtensionMap& extensions,
                                         ColorSpace colorSpace, const std::string& what) {
    TextureBinding binding;
    if (textureIndex < 0) return binding;
    if (static_cast<std::size_t>(textureIndex) >= model_.textures.size())
        fail(what + ": texture " + std::to_string(textureIndex) + " out of range");
    const tinygltf::Texture& texture = model_.textures[textureIndex];
    if (texture.source < 0) {
        context_.warn(what + ": texture " + std::to_string(textureIndex) +
                      " has no image libvox can decode; ignored");
        return binding;
    }
    binding.uvSet = static_cast<std::uint32_t>(std::max(0, texCoord));
    if (texture.sampler >= 0) {
        const tinygltf::Sampler& sampler = model_.samplers.at(texture.sampler);
        auto wrap = [&](int mode) {
            switch (mode) {
                case TINYGLTF_TEXTURE_WRAP_REPEAT:
                    return WrapMode::Repeat;
                case TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE:
                    return WrapMode::ClampToEdge;
                case TINYGLTF_TEXTURE_WRAP_MIRRORED_REPEAT:
                    return WrapMode::MirroredRepeat;
                default:
                    fail("sampler " + std::to_string(texture.sampler) + ": unknown wrap mode " +
                         std::to_string(mode));
            }
        };
        binding.wrapS = wrap(sampler.wrapS);
        binding.wrapT = wrap(sampler.wrapT);
    }
    if (auto it = extensions.find("KHR_texture_transform"); it != extensions.end()) {
        const tinygltf::Value& t = it->second;
        auto number = [&](const tinygltf::Value& v) {
            return static_cast<float>(v.GetNumberAsDouble());
        };
        float ox = 0, oy = 0, rotation = 0, sx = 1, sy = 1;
        if (t.Has("offset")) {
            ox = number(t.Get("offset").Get(0));
            oy = number(t.Get("offset").Get(1));
        }
        if (t.Has("scale")) {
            sx = number(t.Get("scale").Get(0));
            sy = number(t.Get("scale").Get(1));
        }
        if (t.Has("rotation")) rotation = number(t.Get("rotation"));
        if (t.Has("texCoord"))
            binding.uvSet = static_cast<std::uint32_t>(t.Get("texCoord").GetNumberAsInt());
        const float c = std::cos(rotation), s = std::sin(rotation);
        binding.uvTransform = {c * sx, s * sy, ox, -s * sx, c * sy, oy};
    }
    binding.texture = loadImage(texture.source, colorSpace);
    return binding;
}

void GltfImporter::importMaterials() {
    Scene& scene = context_.scene();
    for (std::size_t i = 0; i < model_.materials.size(); ++i) {
        const tinygltf::Material& in = model_.materials[i];
        const std::string what =
            "material " + std::to_string(i) + (in.name.empty() ? "" : " '" + in.name + "'");
        Material out;
        out.name = in.name;
        const auto& pbr = in.pbrMetallicRoughness;
        if (pbr.baseColorFactor.size() == 4)
            out.baseColorFactor = {static_cast<float>(pbr.baseColorFactor[0]),
                                   static_cast<float>(pbr.baseColorFactor[1]),
                                   static_cast<float>(pbr.baseColorFactor[2]),
                                   static_cast<float>(pbr.baseColorFactor[3])};
        out.baseColorTexture = bindTexture(
            pbr.baseColorTexture.index, pbr.baseColorTexture.texCoord,
            pbr.baseColorTexture.extensions, ColorSpace::SRGB, what + " baseColorTexture");
        // Specular-glossiness materials (a retired extension many exporters still write): the
        // diffuse colour is the albedo.
        if (auto it = in.extensions.find("KHR_materials_pbrSpecularGlossiness");
            it != in.extensions.end()) {
            const tinygltf::Value& sg = it->second;
            if (sg.Has("diffuseFactor")) {
                const tinygltf::Value& f = sg.Get("diffuseFactor");
                out.baseColorFactor = {static_cast<float>(f.Get(0).GetNumberAsDouble()),
                                       static_cast<float>(f.Get(1).GetNumberAsDouble()),
                                       static_cast<float>(f.Get(2).GetNumberAsDouble()),
                                       static_cast<float>(f.Get(3).GetNumberAsDouble())};
            }
            if (sg.Has("diffuseTexture")) {
                const tinygltf::Value& t = sg.Get("diffuseTexture");
                tinygltf::ExtensionMap ext;
                if (t.Has("extensions") && t.Get("extensions").Has("KHR_texture_transform"))
                    ext["KHR_texture_transform"] = t.Get("extensions").Get("KHR_texture_transform");
                out.baseColorTexture =
                    bindTexture(t.Get("index").GetNumberAsInt(),
                                t.Has("texCoord") ? t.Get("texCoord").GetNumberAsInt() : 0, ext,
                                ColorSpace::SRGB, what + " diffuseTexture");
            }
        }
        if (in.emissiveFactor.size() == 3)
            out.emissiveFactor = {static_cast<float>(in.emissiveFactor[0]),
                                  static_cast<float>(in.emissiveFactor[1]),
                                  static_cast<float>(in.emissiveFactor[2])};
        if (auto it = in.extensions.find("KHR_materials_emissive_strength");
            it != in.extensions.end() && it->second.Has("emissiveStrength"))
            out.emissiveStrength =
                static_cast<float>(it->second.Get("emissiveStrength").GetNumberAsDouble());
        out.emissiveTexture =
            bindTexture(in.emissiveTexture.index, in.emissiveTexture.texCoord,
                        in.emissiveTexture.extensions, ColorSpace::SRGB, what + " emissiveTexture");
        out.normalTexture =
            bindTexture(in.normalTexture.index, in.normalTexture.texCoord,
                        in.normalTexture.extensions, ColorSpace::Linear, what + " normalTexture");
        out.normalScale = static_cast<float>(in.normalTexture.scale);
        if (in.alphaMode == "OPAQUE")
            out.alphaMode = AlphaMode::Opaque;
        else if (in.alphaMode == "MASK")
            out.alphaMode = AlphaMode::Mask;
        else if (in.alphaMode == "BLEND")
            out.alphaMode = AlphaMode::Blend;
        else
            fail(what + ": unknown alphaMode '" + in.alphaMode + "'");
        out.alphaCutoff = static_cast<float>(in.alphaCutoff);
        out.doubleSided = in.doubleSided;

        for (float v : {out.baseColorFactor.x, out.baseColorFactor.y, out.baseColorFactor.z,
                        out.baseColorFactor.w})
            if (v < 0 || v > 1) fail(what + ": baseColorFactor components must lie in [0, 1]");
        for (float v : {out.emissiveFactor.x, out.emissiveFactor.y, out.emissiveFactor.z})
            if (v < 0 || v > 1) fail(what + ": emissiveFactor components must lie in [0, 1]");
        if (out.emissiveStrength < 0) fail(what + ": emissiveStrength must not be negative");
        if (out.alphaCutoff < 0) fail(what + ": alphaCutoff must not be negative");
        scene.materials.push_back(std::move(out));
    }
}

void GltfImporter::importLight(int lightIndex, const Mat4d& world, bool dynamic,
                               const std::string& nodeName) {
    const tinygltf::Light& in = model_.lights.at(lightIndex);
    const std::string what =
        "light " + std::to_string(lightIndex) + (in.name.empty() ? "" : " '" + in.name + "'");
    Light out;
    out.name = in.name.empty() ? nodeName : in.name;
    if (in.type == "directional")
        out.type = Light::Type::Directional;
    else if (in.type == "point")
        out.type = Light::Type::Point;
    else if (in.type == "spot")
        out.type = Light::Type::Spot;
    else
        fail(what + ": unknown light type '" + in.type + "'");
    if (in.color.size() == 3)
        out.color = {static_cast<float>(in.color[0]), static_cast<float>(in.color[1]),
                     static_cast<float>(in.color[2])};
    if (in.color.size() != 0 && in.color.size() != 3) fail(what + ": color needs 3 components");
    if (out.color.x < 0 || out.color.y < 0 || out.color.z < 0)
        fail(what + ": color must not be negative");
    out.intensity = static_cast<float>(in.intensity);
    if (!(out.intensity >= 0) || !std::isfinite(out.intensity))
        fail(what + ": intensity must be a finite number >= 0");
    out.range = static_cast<float>(in.range);
    if (out.range < 0 || !std::isfinite(out.range))
        fail(what + ": range must be a positive number");
    if (out.type == Light::Type::Spot) {
        out.innerConeAngle = static_cast<float>(in.spot.innerConeAngle);
        out.outerConeAngle = static_cast<float>(in.spot.outerConeAngle);
        if (!(out.innerConeAngle >= 0 && out.innerConeAngle < out.outerConeAngle &&
              out.outerConeAngle <= std::numbers::pi / 2 + 1e-6))
            fail(what + ": spot cone angles must satisfy 0 <= inner < outer <= pi/2");
    }
    const Vec3d position = world.transformPoint({0, 0, 0});
    const Vec3d direction = normalize(world.transformVector({0, 0, -1}));
    if (!isFinite(position) || !isFinite(direction) || length(direction) == 0)
        fail(what + ": the node transform gives it no valid position or direction");
    out.position = {static_cast<float>(position.x), static_cast<float>(position.y),
                    static_cast<float>(position.z)};
    out.direction = {static_cast<float>(direction.x), static_cast<float>(direction.y),
                     static_cast<float>(direction.z)};
    out.dynamic = dynamic;
    context_.scene().lights.push_back(std::move(out));
}

void GltfImporter::importPrimitive(const tinygltf::Mesh& mesh, int meshIndex, int primitiveIndex,
                                   const Mat4d& world, const std::string& nodeName, bool dynamic) {
    const tinygltf::Primitive& primitive = mesh.primitives[primitiveIndex];
    const std::string what = "mesh " + std::to_string(meshIndex) +
                             (mesh.name.empty() ? "" : " '" + mesh.name + "'") + " primitive " +
                             std::to_string(primitiveIndex);
    int mode = primitive.mode;
    if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP &&
        mode != TINYGLTF_MODE_TRIANGLE_FAN) {
        ++skippedPrimitives_;  // points and lines have no surface to voxelize
        return;
    }
    if (!primitive.attributes.count("POSITION")) fail(what + ": has no POSITION attribute");

    Mesh out;
    out.name = nodeName.empty() ? mesh.name : nodeName;
    out.dynamic = dynamic;
    if (primitive.material >= 0) {
        if (static_cast<std::size_t>(primitive.material) >= model_.materials.size())
            fail(what + ": material " + std::to_string(primitive.material) + " out of range");
        out.material = static_cast<std::uint32_t>(primitive.material);
    } else {
        out.material = context_.defaultMaterial();
    }

    std::vector<float> positions, normals, colors;
    std::vector<std::vector<float>> uvs;
    int colorComponents = 4;
    std::vector<std::uint32_t> indices;
    std::size_t vertexCount = 0;

    if (auto draco = primitive.extensions.find("KHR_draco_mesh_compression");
        draco != primitive.extensions.end()) {
        const tinygltf::Value& ext = draco->second;
        const int viewIndex = ext.Get("bufferView").GetNumberAsInt();
        const tinygltf::BufferView& view = model_.bufferViews.at(viewIndex);
        const ByteRange range =
            viewBytes(viewIndex, 0, 1, view.byteLength, view.byteLength, what + " Draco data");
        const DracoMesh decoded({range.data, view.byteLength}, context_.input(), what);
        vertexCount = decoded.pointCount();
        indices = decoded.indices();
        mode = TINYGLTF_MODE_TRIANGLES;  // Draco decodes to a triangle list whatever the
                                         // primitive's mode
        const tinygltf::Value& attributes = ext.Get("attributes");
        auto dracoAttribute = [&](const std::string& semantic,
                                  int components) -> std::vector<float> {
            if (!attributes.Has(semantic)) return {};
            const auto id = static_cast<std::uint32_t>(attributes.Get(semantic).GetNumberAsInt());
            const draco::PointAttribute* attribute = decoded.attributeById(id);
            if (!attribute)
                fail(what + ": Draco attribute " + std::to_string(id) + " for " + semantic +
                     " does not exist");
            return decoded.floats(*attribute, components);
        };
        positions = dracoAttribute("POSITION", 3);
        if (positions.empty()) fail(what + ": Draco data has no POSITION attribute");
        normals = dracoAttribute("NORMAL", 3);
        for (int set = 0; attributes.Has("TEXCOORD_" + std::to_string(set)); ++set)
            uvs.push_back(dracoAttribute("TEXCOORD_" + std::to_string(set), 2));
        if (attributes.Has("COLOR_0")) {
            if (auto a = primitive.attributes.find("COLOR_0"); a != primitive.attributes.end())
                colorComponents = tinygltf::GetNumComponentsInType(static_cast<std::uint32_t>(
                                      model_.accessors.at(a->second).type)) == 3
                                      ? 3
                                      : 4;
            colors = dracoAttribute("COLOR_0", colorComponents);
        }
    } else {
        int components = 0;
        positions =
            readFloats(primitive.attributes.at("POSITION"), {3}, components, what + " POSITION");
        vertexCount = positions.size() / 3;
        auto attribute = [&](const std::string& semantic, std::initializer_list<int> allowed,
                             int& comps) -> std::vector<float> {
            auto it = primitive.attributes.find(semantic);
            if (it == primitive.attributes.end()) return {};
            std::vector<float> values =
                readFloats(it->second, allowed, comps, what + " " + semantic);
            if (values.size() / static_cast<std::size_t>(comps) != vertexCount)
                fail(what + ": " + semantic + " has " + std::to_string(values.size() / comps) +
                     " elements but POSITION has " + std::to_string(vertexCount));
            return values;
        };
        normals = attribute("NORMAL", {3}, components);
        for (int set = 0; primitive.attributes.count("TEXCOORD_" + std::to_string(set)); ++set)
            uvs.push_back(attribute("TEXCOORD_" + std::to_string(set), {2}, components));
        colors = attribute("COLOR_0", {3, 4}, colorComponents);
        if (primitive.indices >= 0) {
            indices = readIndices(primitive.indices, what + " indices");
        } else {
            indices.resize(vertexCount);
            for (std::size_t i = 0; i < vertexCount; ++i)
                indices[i] = static_cast<std::uint32_t>(i);
        }
    }
    if (vertexCount > std::numeric_limits<std::uint32_t>::max()) fail(what + ": too many vertices");
    for (std::uint32_t index : indices)
        if (index >= vertexCount)
            fail(what + ": vertex index " + std::to_string(index) + " out of range (" +
                 std::to_string(vertexCount) + " vertices)");

    // Primitive topology to a triangle list (glTF 2.0 §3.7.2.1).
    std::vector<std::uint32_t> triangles;
    const std::size_t n = indices.size();
    if (mode == TINYGLTF_MODE_TRIANGLES) {
        if (n % 3 != 0)
            context_.warn(what + ": " + std::to_string(n) +
                          " indices is not a multiple of 3; the last " + std::to_string(n % 3) +
                          " ignored");
        triangles.assign(indices.begin(), indices.begin() + static_cast<std::ptrdiff_t>(n - n % 3));
    } else if (n >= 3) {
        triangles.reserve((n - 2) * 3);
        for (std::size_t i = 0; i + 2 < n; ++i) {
            if (mode == TINYGLTF_MODE_TRIANGLE_STRIP)
                triangles.insert(triangles.end(),
                                 {indices[i], indices[i + 1 + i % 2], indices[i + 2 - i % 2]});
            else
                triangles.insert(triangles.end(), {indices[i + 1], indices[i + 2], indices[0]});
        }
    }

    const bool mirrored = world.determinant3() < 0;
    const Mat4d normalMatrix = world.normalMatrix();
    out.positions.resize(vertexCount);
    for (std::size_t v = 0; v < vertexCount; ++v) {
        const Vec3d p =
            world.transformPoint({positions[3 * v], positions[3 * v + 1], positions[3 * v + 2]});
        out.positions[v] = {static_cast<float>(p.x), static_cast<float>(p.y),
                            static_cast<float>(p.z)};
    }
    if (!normals.empty()) {
        out.normals.resize(vertexCount);
        for (std::size_t v = 0; v < vertexCount; ++v) {
            const Vec3d nv = normalMatrix.transformVector(
                {normals[3 * v], normals[3 * v + 1], normals[3 * v + 2]});
            out.normals[v] = {static_cast<float>(nv.x), static_cast<float>(nv.y),
                              static_cast<float>(nv.z)};
        }
    }
    for (const auto& set : uvs) {
        out.uvs.emplace_back(vertexCount);
        for (std::size_t v = 0; v < vertexCount; ++v)
            out.uvs.back()[v] = {set[2 * v], set[2 * v + 1]};
    }
    // A material may read a UV set the primitive lacks: such lookups read (0, 0), as renderers do.
    const Material& material = context_.scene().materials.at(out.material);
    std::uint32_t neededSets = 0;
    for (const TextureBinding* b :
         {&material.baseColorTexture, &material.emissiveTexture, &material.normalTexture})
        if (b->valid()) neededSets = std::max(neededSets, b->uvSet + 1);
    while (out.uvs.size() < neededSets) {
        out.uvs.emplace_back(vertexCount, Vec2f{0, 0});
        ++missingUvSets_;
    }
    if (!colors.empty()) {
        out.colors.resize(vertexCount);
        for (std::size_t v = 0; v < vertexCount; ++v) {
            const float* c = &colors[v * colorComponents];
            out.colors[v] = {c[0], c[1], c[2], colorComponents == 4 ? c[3] : 1.0f};
        }
    }
    if (mirrored)
        for (std::size_t t = 0; t + 2 < triangles.size(); t += 3)
            std::swap(triangles[t + 1], triangles[t + 2]);
    out.indices = std::move(triangles);
    context_.scene().meshes.push_back(std::move(out));
}

void GltfImporter::importNode(int nodeIndex, const Mat4d& parent, bool dynamic) {
    const tinygltf::Node& node = model_.nodes[nodeIndex];
    const std::string what =
        "node " + std::to_string(nodeIndex) + (node.name.empty() ? "" : " '" + node.name + "'");
    const Mat4d world = parent * localTransform(node);
    if (!world.isFinite()) fail(what + ": transform is not finite");

    if (node.extras.IsObject() && node.extras.Has("dynamic")) {
        const tinygltf::Value& flag = node.extras.Get("dynamic");
        if (flag.IsBool())
            dynamic = dynamic || flag.Get<bool>();
        else
            context_.warn(what + ": extras.dynamic is not a boolean; ignored");
    }
    dynamic = context_.isDynamicName(node.name) || dynamic;

    if (node.mesh >= 0) {
        const tinygltf::Mesh& mesh = model_.meshes.at(node.mesh);
        if (node.skin >= 0 && skinnedMeshes_++ == 0)
            context_.warn(what + ": skinning is ignored; meshes are taken in their bind pose");
        bool morphed = false;
        for (double w : node.weights.empty() ? mesh.weights : node.weights)
            morphed = morphed || w != 0;
        if (morphed)
            context_.warn(what + ": morph target weights are not applied; the base shape is used");
        for (std::size_t p = 0; p < mesh.primitives.size(); ++p)
            importPrimitive(mesh, node.mesh, static_cast<int>(p), world, node.name, dynamic);
    }
    if (auto it = node.extensions.find("KHR_lights_punctual");
        it != node.extensions.end() && it->second.Has("light"))
        importLight(it->second.Get("light").GetNumberAsInt(), world, dynamic, node.name);

    // Children are queued by the caller's explicit stack: hierarchies deeper than the call stack
    // (hostile files, or long chains from some exporters) cannot overflow it.
    pending_.push_back({nodeIndex, world, dynamic, 0});
}

void GltfImporter::importHierarchy(int root) {
    if (visitState_[root] != 0)
        fail("node " + std::to_string(root) +
             " is listed in the scene more than once or has a parent");
    visitState_[root] = 1;
    importNode(root, Mat4d::identity(), false);
    while (!pending_.empty()) {
        PendingNode& top = pending_.back();
        const auto& children = model_.nodes[top.node].children;
        if (top.nextChild == children.size()) {
            visitState_[top.node] = 2;
            pending_.pop_back();
            continue;
        }
        const int child = children[top.nextChild++];
        if (visitState_[child] == 1)
            fail("node " + std::to_string(child) +
                 " is its own ancestor (the node hierarchy has a cycle)");
        if (visitState_[child] == 2)
            fail("node " + std::to_string(child) + " has more than one parent");
        visitState_[child] = 1;
        const Mat4d world = top.world;  // importNode may grow pending_, moving top
        importNode(child, world, top.dynamic);
    }
}

void GltfImporter::run() {
    for (const std::string& ext : model_.extensionsRequired)
        if (std::find(kSupportedRequiredExtensions.begin(), kSupportedRequiredExtensions.end(),
                      ext) == kSupportedRequiredExtensions.end())
            fail("requires extension " + ext + ", which libvox does not support");

    importMaterials();

    visitState_.assign(model_.nodes.size(), 0);
    std::vector<int> roots;
    if (!model_.scenes.empty()) {
        const int scene = model_.defaultScene >= 0 ? model_.defaultScene : 0;
        roots = model_.scenes.at(scene).nodes;
    } else {
        // No scene: every node without a parent is a root (glTF leaves this to the application).
        std::vector<bool> isChild(model_.nodes.size(), false);
        for (const auto& node : model_.nodes)
            for (int child : node.children) isChild.at(child) = true;
        for (std::size_t i = 0; i < model_.nodes.size(); ++i)
            if (!isChild[i]) roots.push_back(static_cast<int>(i));
    }
    for (int root : roots) importHierarchy(root);

    if (skippedPrimitives_)
        context_.warn("skipped " + std::to_string(skippedPrimitives_) +
                      " primitive(s) of points or lines");
    if (missingUvSets_)
        context_.warn(
            std::to_string(missingUvSets_) +
            " primitive(s) lack a UV set their material's textures use; those lookups read (0, 0)");
}

}  // namespace

void importGltf(ImportContext& context, const std::vector<std::uint8_t>& bytes, bool binary) {
    Timings::Scope timer(context.options().timings, "import.parse");
    const std::string_view json =
        binary ? glbJsonChunk(bytes, context.input())
               : std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size());
    const std::string rewrittenJson = validateGltfJson(json, context.input());
    std::vector<std::uint8_t> rewrittenGlb;
    const std::uint8_t* data = bytes.data();
    std::size_t size = bytes.size();
    if (!rewrittenJson.empty()) {
        if (binary) {
            rewrittenGlb = replaceGlbJson(bytes, rewrittenJson);
            data = rewrittenGlb.data();
            size = rewrittenGlb.size();
        } else {
            data = reinterpret_cast<const std::uint8_t*>(rewrittenJson.data());
            size = rewrittenJson.size();
        }
    }
    if (size > std::numeric_limits<unsigned>::max())
        context.fail("is larger than the 4 GiB tinygltf can load");

    tinygltf::TinyGLTF loader;
    FileAccess access{&context, std::nullopt};
    loader.SetFsCallbacks(
        {&fsFileExists, &fsExpandPath, &fsReadWholeFile, &fsWriteWholeFile, &access});
    loader.SetImageLoader(&keepEncodedImage, nullptr);
    loader.SetStoreOriginalJSONForExtrasAndExtensions(false);

    tinygltf::Model model;
    std::string err, warn;
    const std::string baseDir = context.input().parent_path().string();
    const bool ok = binary ? loader.LoadBinaryFromMemory(&model, &err, &warn, data,
                                                         static_cast<unsigned>(size), baseDir)
                           : loader.LoadASCIIFromString(&model, &err, &warn,
                                                        reinterpret_cast<const char*>(data),
                                                        static_cast<unsigned>(size), baseDir);
    if (access.ioError) throw *access.ioError;
    if (!ok)
        context.fail("invalid glTF: " +
                     (err.empty() ? std::string("tinygltf rejected the file") : firstLine(err)));

    GltfImporter importer(context, model);
    importer.run();
}

}  // namespace vox::detail
