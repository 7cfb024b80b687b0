#include "gltf_validate.h"

#include <vox/base/error.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstring>
#include <functional>
#include <vector>

namespace vox::detail {
namespace {

using json = nlohmann::json;

enum class Kind { Integer, Number, Boolean, String, Object, Array, Any };

const char* describe(const json& value) {
    switch (value.type()) {
        case json::value_t::null:
            return "null";
        case json::value_t::boolean:
            return "a boolean";
        case json::value_t::string:
            return "a string";
        case json::value_t::array:
            return "an array";
        case json::value_t::object:
            return "an object";
        case json::value_t::number_integer:
        case json::value_t::number_unsigned:
            return "an integer";
        case json::value_t::number_float:
            return "a number";
        default:
            return "an unknown value";
    }
}

class Checker {
public:
    Checker(const json& root, const std::filesystem::path& file) : root_(root), file_(file) {}

    [[noreturn]] void fail(const std::string& path, const std::string& problem) const {
        throw InvalidDataError(file_,
                               "invalid glTF: " + (path.empty() ? problem : path + ": " + problem));
    }

    static bool isKind(const json& v, Kind kind) {
        switch (kind) {
            case Kind::Integer:
                return v.is_number_integer() ||
                       (v.is_number_float() && std::isfinite(v.get<double>()) &&
                        v.get<double>() == std::floor(v.get<double>()));
            case Kind::Number:
                return v.is_number() && std::isfinite(v.get<double>());
            case Kind::Boolean:
                return v.is_boolean();
            case Kind::String:
                return v.is_string();
            case Kind::Object:
                return v.is_object();
            case Kind::Array:
                return v.is_array();
            case Kind::Any:
                return true;
        }
        return false;
    }
    static const char* kindName(Kind kind) {
        switch (kind) {
            case Kind::Integer:
                return "an integer";
            case Kind::Number:
                return "a finite number";
            case Kind::Boolean:
                return "a boolean";
            case Kind::String:
                return "a string";
            case Kind::Object:
                return "an object";
            case Kind::Array:
                return "an array";
            case Kind::Any:
                return "a value";
        }
        return "";
    }

    /// Returns the member if present (after checking its kind), or nullptr.
    const json* member(const json& object, const char* key, const std::string& path, Kind kind,
                       bool required = false) const {
        auto it = object.find(key);
        if (it == object.end()) {
            if (required) fail(path, std::string("required property '") + key + "' is missing");
            return nullptr;
        }
        const std::string at = join(path, key);
        if (!isKind(*it, kind))
            fail(at, std::string("expected ") + kindName(kind) + ", got " + describe(*it));
        return &*it;
    }

    std::int64_t integer(const json& object, const char* key, const std::string& path,
                         std::int64_t fallback, std::int64_t min, std::int64_t max,
                         bool required = false) const {
        const json* v = member(object, key, path, Kind::Integer, required);
        if (!v) return fallback;
        const double d = v->get<double>();
        if (d < static_cast<double>(min) || d > static_cast<double>(max))
            fail(join(path, key), "value " + v->dump() + " out of range [" + std::to_string(min) +
                                      ", " + std::to_string(max) + "]");
        return static_cast<std::int64_t>(d);
    }

    /// An index property that must refer into the root array @p target.
    std::int64_t index(const json& object, const char* key, const std::string& path,
                       const char* target, bool required = false) const {
        const std::int64_t count = arraySize(target);
        const json* v = member(object, key, path, Kind::Integer, required);
        if (!v) return -1;
        const double d = v->get<double>();
        if (d < 0 || d >= static_cast<double>(count))
            fail(join(path, key), "index " + v->dump() + " out of range (" + std::to_string(count) +
                                      " " + target + ")");
        return static_cast<std::int64_t>(d);
    }

    void numberArray(const json& object, const char* key, const std::string& path,
                     std::size_t length) const {
        const json* v = member(object, key, path, Kind::Array);
        if (!v) return;
        if (length && v->size() != length)
            fail(join(path, key), "expected " + std::to_string(length) + " numbers, got " +
                                      std::to_string(v->size()));
        for (std::size_t i = 0; i < v->size(); ++i)
            if (!isKind((*v)[i], Kind::Number))
                fail(join(path, key) + "[" + std::to_string(i) + "]",
                     std::string("expected a finite number, got ") + describe((*v)[i]));
    }

    void indexArray(const json& object, const char* key, const std::string& path,
                    const char* target) const {
        const json* v = member(object, key, path, Kind::Array);
        if (!v) return;
        const std::int64_t count = arraySize(target);
        for (std::size_t i = 0; i < v->size(); ++i) {
            const std::string at = join(path, key) + "[" + std::to_string(i) + "]";
            const json& e = (*v)[i];
            if (!isKind(e, Kind::Integer))
                fail(at, std::string("expected an integer, got ") + describe(e));
            const double d = e.get<double>();
            if (d < 0 || d >= static_cast<double>(count))
                fail(at, "index " + e.dump() + " out of range (" + std::to_string(count) + " " +
                             target + ")");
        }
    }

    /// Calls @p each for every element of the root or nested array, checking each is an object.
    void objects(const json& parent, const char* key, const std::string& path,
                 const std::function<void(const json&, const std::string&)>& each,
                 bool required = false) const {
        const json* v = member(parent, key, path, Kind::Array, required);
        if (!v) return;
        for (std::size_t i = 0; i < v->size(); ++i) {
            const std::string at = join(path, key) + "[" + std::to_string(i) + "]";
            if (!(*v)[i].is_object())
                fail(at, std::string("expected an object, got ") + describe((*v)[i]));
            each((*v)[i], at);
        }
    }

    const json* object(const json& parent, const char* key, const std::string& path) const {
        return member(parent, key, path, Kind::Object);
    }

    std::int64_t arraySize(const char* key) const {
        auto it = root_.find(key);
        return it != root_.end() && it->is_array() ? static_cast<std::int64_t>(it->size()) : 0;
    }

    static std::string join(const std::string& path, const char* key) {
        return path.empty() ? key : path + "." + key;
    }

    const json& root_;
    const std::filesystem::path& file_;
};

constexpr std::int64_t kMaxInt = std::int64_t{1} << 53;  // integers JSON numbers hold exactly

int componentSize(std::int64_t componentType) {
    switch (componentType) {
        case 5120:
        case 5121:
            return 1;
        case 5122:
        case 5123:
            return 2;
        case 5125:
        case 5126:
            return 4;
        default:
            return 0;
    }
}

int componentCount(const std::string& type) {
    if (type == "SCALAR") return 1;
    if (type == "VEC2") return 2;
    if (type == "VEC3") return 3;
    if (type == "VEC4" || type == "MAT2") return 4;
    if (type == "MAT3") return 9;
    if (type == "MAT4") return 16;
    return 0;
}

void checkTextureInfo(const Checker& c, const json& parent, const char* key,
                      const std::string& path) {
    const json* info = c.object(parent, key, path);
    if (!info) return;
    const std::string at = Checker::join(path, key);
    c.index(*info, "index", at, "textures", true);
    c.integer(*info, "texCoord", at, 0, 0, 64);
    c.member(*info, "scale", at, Kind::Number);
    c.member(*info, "strength", at, Kind::Number);
    if (const json* ext = c.object(*info, "extensions", at)) {
        const std::string extPath = at + ".extensions";
        if (const json* transform = c.object(*ext, "KHR_texture_transform", extPath)) {
            const std::string tp = extPath + ".KHR_texture_transform";
            c.numberArray(*transform, "offset", tp, 2);
            c.numberArray(*transform, "scale", tp, 2);
            c.member(*transform, "rotation", tp, Kind::Number);
            c.integer(*transform, "texCoord", tp, 0, 0, 64);
        }
    }
}

void checkRoot(const Checker& c, const json& root) {
    if (!root.is_object())
        c.fail("", std::string("the document is ") + describe(root) + ", not an object");
    const json* asset = c.member(root, "asset", "", Kind::Object, true);
    const std::string version =
        c.member(*asset, "version", "asset", Kind::String, true)->get<std::string>();
    if (version.rfind("2.", 0) != 0)
        c.fail("asset.version", "glTF version '" + version + "' is not supported (only 2.x)");

    for (const char* list : {"extensionsUsed", "extensionsRequired"})
        if (const json* names = c.member(root, list, "", Kind::Array))
            for (std::size_t i = 0; i < names->size(); ++i)
                if (!(*names)[i].is_string())
                    c.fail(std::string(list) + "[" + std::to_string(i) + "]",
                           std::string("expected a string, got ") + describe((*names)[i]));

    c.objects(root, "buffers", "", [&](const json& b, const std::string& p) {
        c.member(b, "uri", p, Kind::String);
        c.integer(b, "byteLength", p, 0, 1, kMaxInt, true);
        c.member(b, "name", p, Kind::String);
    });
    const json* buffers = c.member(root, "buffers", "", Kind::Array);
    c.objects(root, "bufferViews", "", [&](const json& v, const std::string& p) {
        const std::int64_t buffer = c.index(v, "buffer", p, "buffers", true);
        const std::int64_t offset = c.integer(v, "byteOffset", p, 0, 0, kMaxInt);
        const std::int64_t length = c.integer(v, "byteLength", p, 0, 1, kMaxInt, true);
        c.integer(v, "byteStride", p, 0, 4, 252);
        c.integer(v, "target", p, 0, 0, kMaxInt);
        c.member(v, "name", p, Kind::String);
        const std::int64_t bufferLength =
            (*buffers)[static_cast<std::size_t>(buffer)].value("byteLength", std::int64_t{0});
        if (offset + length > bufferLength)
            c.fail(p, "bytes [" + std::to_string(offset) + ", " + std::to_string(offset + length) +
                          ") exceed buffer " + std::to_string(buffer) + " (" +
                          std::to_string(bufferLength) + " bytes)");
    });
    c.objects(root, "accessors", "", [&](const json& a, const std::string& p) {
        c.index(a, "bufferView", p, "bufferViews");
        c.integer(a, "byteOffset", p, 0, 0, kMaxInt);
        const std::int64_t type = c.integer(a, "componentType", p, 0, 0, kMaxInt, true);
        if (!componentSize(type))
            c.fail(p + ".componentType", "unknown component type " + std::to_string(type));
        c.member(a, "normalized", p, Kind::Boolean);
        c.integer(a, "count", p, 0, 1, kMaxInt, true);
        const json* t = c.member(a, "type", p, Kind::String, true);
        if (!componentCount(t->get<std::string>()))
            c.fail(p + ".type", "unknown accessor type '" + t->get<std::string>() + "'");
        c.numberArray(a, "min", p, 0);
        c.numberArray(a, "max", p, 0);
        c.member(a, "name", p, Kind::String);
        if (const json* sparse = c.object(a, "sparse", p)) {
            const std::string sp = p + ".sparse";
            c.integer(*sparse, "count", sp, 0, 1, kMaxInt, true);
            const json* indices = c.member(*sparse, "indices", sp, Kind::Object, true);
            c.index(*indices, "bufferView", sp + ".indices", "bufferViews", true);
            c.integer(*indices, "byteOffset", sp + ".indices", 0, 0, kMaxInt);
            const std::int64_t it =
                c.integer(*indices, "componentType", sp + ".indices", 0, 0, kMaxInt, true);
            if (it != 5121 && it != 5123 && it != 5125)
                c.fail(sp + ".indices.componentType",
                       "sparse indices must be unsigned byte, short or int");
            const json* values = c.member(*sparse, "values", sp, Kind::Object, true);
            c.index(*values, "bufferView", sp + ".values", "bufferViews", true);
            c.integer(*values, "byteOffset", sp + ".values", 0, 0, kMaxInt);
        }
    });
    c.objects(root, "images", "", [&](const json& i, const std::string& p) {
        c.member(i, "uri", p, Kind::String);
        c.member(i, "mimeType", p, Kind::String);
        c.index(i, "bufferView", p, "bufferViews");
        c.member(i, "name", p, Kind::String);
    });
    c.objects(root, "samplers", "", [&](const json& s, const std::string& p) {
        for (const char* key : {"magFilter", "minFilter", "wrapS", "wrapT"})
            c.integer(s, key, p, 0, 0, kMaxInt);
        c.member(s, "name", p, Kind::String);
    });
    c.objects(root, "textures", "", [&](const json& t, const std::string& p) {
        c.index(t, "sampler", p, "samplers");
        c.index(t, "source", p, "images");
        c.member(t, "name", p, Kind::String);
        c.object(t, "extensions", p);
    });
    c.objects(root, "materials", "", [&](const json& m, const std::string& p) {
        c.member(m, "name", p, Kind::String);
        if (const json* pbr = c.object(m, "pbrMetallicRoughness", p)) {
            const std::string pp = p + ".pbrMetallicRoughness";
            c.numberArray(*pbr, "baseColorFactor", pp, 4);
            checkTextureInfo(c, *pbr, "baseColorTexture", pp);
            c.member(*pbr, "metallicFactor", pp, Kind::Number);
            c.member(*pbr, "roughnessFactor", pp, Kind::Number);
            checkTextureInfo(c, *pbr, "metallicRoughnessTexture", pp);
        }
        checkTextureInfo(c, m, "normalTexture", p);
        checkTextureInfo(c, m, "occlusionTexture", p);
        checkTextureInfo(c, m, "emissiveTexture", p);
        c.numberArray(m, "emissiveFactor", p, 3);
        c.member(m, "alphaMode", p, Kind::String);
        c.member(m, "alphaCutoff", p, Kind::Number);
        c.member(m, "doubleSided", p, Kind::Boolean);
        if (const json* ext = c.object(m, "extensions", p)) {
            const std::string ep = p + ".extensions";
            if (const json* strength = c.object(*ext, "KHR_materials_emissive_strength", ep))
                c.member(*strength, "emissiveStrength", ep + ".KHR_materials_emissive_strength",
                         Kind::Number);
            if (const json* sg = c.object(*ext, "KHR_materials_pbrSpecularGlossiness", ep)) {
                const std::string sp = ep + ".KHR_materials_pbrSpecularGlossiness";
                c.numberArray(*sg, "diffuseFactor", sp, 4);
                checkTextureInfo(c, *sg, "diffuseTexture", sp);
            }
        }
    });
    c.objects(root, "meshes", "", [&](const json& m, const std::string& p) {
        c.member(m, "name", p, Kind::String);
        c.numberArray(m, "weights", p, 0);
        c.objects(
            m, "primitives", p,
            [&](const json& prim, const std::string& pp) {
                const json* attributes = c.member(prim, "attributes", pp, Kind::Object, true);
                for (auto it = attributes->begin(); it != attributes->end(); ++it) {
                    const std::string at = pp + ".attributes." + it.key();
                    if (!Checker::isKind(*it, Kind::Integer))
                        c.fail(at, std::string("expected an integer, got ") + describe(*it));
                    const double d = it->get<double>();
                    if (d < 0 || d >= static_cast<double>(c.arraySize("accessors")))
                        c.fail(at, "index " + it->dump() + " out of range (" +
                                       std::to_string(c.arraySize("accessors")) + " accessors)");
                }
                c.index(prim, "indices", pp, "accessors");
                c.index(prim, "material", pp, "materials");
                c.integer(prim, "mode", pp, 4, 0, 6);
                c.member(prim, "targets", pp, Kind::Array);
                if (const json* ext = c.object(prim, "extensions", pp)) {
                    const std::string ep = pp + ".extensions";
                    if (const json* draco = c.object(*ext, "KHR_draco_mesh_compression", ep)) {
                        const std::string dp = ep + ".KHR_draco_mesh_compression";
                        c.index(*draco, "bufferView", dp, "bufferViews", true);
                        const json* da = c.member(*draco, "attributes", dp, Kind::Object, true);
                        for (auto it = da->begin(); it != da->end(); ++it)
                            if (!Checker::isKind(*it, Kind::Integer) || it->get<double>() < 0)
                                c.fail(dp + ".attributes." + it.key(),
                                       std::string("expected a Draco attribute id, got ") +
                                           describe(*it));
                    }
                }
            },
            true);
    });
    c.objects(root, "nodes", "", [&](const json& n, const std::string& p) {
        c.member(n, "name", p, Kind::String);
        c.index(n, "mesh", p, "meshes");
        c.index(n, "camera", p, "cameras");
        c.index(n, "skin", p, "skins");
        c.indexArray(n, "children", p, "nodes");
        c.numberArray(n, "matrix", p, 16);
        c.numberArray(n, "rotation", p, 4);
        c.numberArray(n, "scale", p, 3);
        c.numberArray(n, "translation", p, 3);
        c.numberArray(n, "weights", p, 0);
        if (const json* ext = c.object(n, "extensions", p))
            if (const json* light = c.object(*ext, "KHR_lights_punctual", p + ".extensions")) {
                std::int64_t lightCount = 0;
                if (auto e = c.root_.find("extensions"); e != c.root_.end() && e->is_object())
                    if (auto l = e->find("KHR_lights_punctual"); l != e->end() && l->is_object())
                        if (auto ls = l->find("lights"); ls != l->end() && ls->is_array())
                            lightCount = static_cast<std::int64_t>(ls->size());
                const std::string lp = p + ".extensions.KHR_lights_punctual";
                const std::int64_t index = c.integer(*light, "light", lp, -1, 0, kMaxInt, true);
                if (index >= lightCount)
                    c.fail(lp + ".light", "index " + std::to_string(index) + " out of range (" +
                                              std::to_string(lightCount) + " lights)");
            }
    });
    c.objects(root, "scenes", "", [&](const json& s, const std::string& p) {
        c.member(s, "name", p, Kind::String);
        c.indexArray(s, "nodes", p, "nodes");
    });
    c.index(root, "scene", "", "scenes");
    if (const json* ext = c.object(root, "extensions", ""))
        if (const json* lights = c.object(*ext, "KHR_lights_punctual", "extensions"))
            c.objects(*lights, "lights", "extensions.KHR_lights_punctual",
                      [&](const json& l, const std::string& p) {
                          c.member(l, "name", p, Kind::String);
                          c.member(l, "type", p, Kind::String, true);
                          c.numberArray(l, "color", p, 3);
                          c.member(l, "intensity", p, Kind::Number);
                          c.member(l, "range", p, Kind::Number);
                          if (const json* spot = c.object(l, "spot", p)) {
                              c.member(*spot, "innerConeAngle", p + ".spot", Kind::Number);
                              c.member(*spot, "outerConeAngle", p + ".spot", Kind::Number);
                          }
                      });
}

std::uint32_t readU32(const std::uint8_t* p) {
    std::uint32_t v;
    std::memcpy(&v, p, 4);  // GLB is little-endian, as is every target libvox supports
    return v;
}

}  // namespace

std::string validateGltfJson(std::string_view jsonText, const std::filesystem::path& file) {
    // glTF nests a dozen levels at most; parsers and tinygltf's extras conversion recurse per
    // level, so absurd nesting is rejected by a scan that does not.
    constexpr int kMaxJsonDepth = 256;
    int depth = 0;
    bool inString = false;
    for (std::size_t i = 0; i < jsonText.size(); ++i) {
        const char c = jsonText[i];
        if (inString) {
            if (c == '\\')
                ++i;
            else if (c == '"')
                inString = false;
        } else if (c == '"') {
            inString = true;
        } else if (c == '[' || c == '{') {
            if (++depth > kMaxJsonDepth)
                throw InvalidDataError(
                    file, "JSON nests deeper than " + std::to_string(kMaxJsonDepth) + " levels");
        } else if (c == ']' || c == '}') {
            --depth;
        }
    }
    json root = json::parse(jsonText.begin(), jsonText.end(), nullptr, false);
    if (root.is_discarded()) {
        // Parse again with exceptions for the position of the error.
        try {
            root = json::parse(jsonText.begin(), jsonText.end());
        } catch (const json::exception& e) {
            // parse_error, and out_of_range for a number beyond double (found by fuzz_gltf:
            // "1e39929" escaped as an internal error).
            std::string what = e.what();
            if (auto pos = what.find("] "); pos != std::string::npos) what = what.substr(pos + 2);
            throw InvalidDataError(file, "malformed JSON: " + what);
        }
    }
    Checker checker(root, file);
    checkRoot(checker, root);

    bool rewritten = false;
    if (auto meshes = root.find("meshes"); meshes != root.end())
        for (json& mesh : *meshes)
            for (json& primitive : mesh["primitives"])
                if (primitive.contains("extensions") &&
                    primitive["extensions"].contains("KHR_draco_mesh_compression") &&
                    primitive.erase("indices"))
                    rewritten = true;
    return rewritten ? root.dump() : std::string();
}

std::vector<std::uint8_t> replaceGlbJson(std::span<const std::uint8_t> glb, std::string_view json) {
    const std::uint32_t oldChunk = readU32(glb.data() + 12);
    const std::uint32_t totalLength = readU32(glb.data() + 8);
    const std::size_t restOffset = 20 + static_cast<std::size_t>(oldChunk);
    const std::size_t restLength = totalLength > restOffset ? totalLength - restOffset : 0;
    const std::uint32_t newChunk = static_cast<std::uint32_t>((json.size() + 3) & ~std::size_t{3});
    std::vector<std::uint8_t> out(20 + newChunk + restLength, ' ');
    std::memcpy(out.data(), glb.data(), 12);
    const std::uint32_t newTotal = static_cast<std::uint32_t>(out.size());
    std::memcpy(out.data() + 8, &newTotal, 4);
    std::memcpy(out.data() + 12, &newChunk, 4);
    std::memcpy(out.data() + 16, glb.data() + 16, 4);
    std::memcpy(out.data() + 20, json.data(), json.size());
    if (restLength) std::memcpy(out.data() + 20 + newChunk, glb.data() + restOffset, restLength);
    return out;
}

std::string_view glbJsonChunk(std::span<const std::uint8_t> glb,
                              const std::filesystem::path& file) {
    if (glb.size() < 20 || std::memcmp(glb.data(), "glTF", 4) != 0)
        throw InvalidDataError(file, "not a GLB file (no 'glTF' magic)");
    const std::uint32_t version = readU32(glb.data() + 4);
    if (version != 2)
        throw InvalidDataError(
            file, "GLB version " + std::to_string(version) + " is not supported (only 2)");
    const std::uint32_t length = readU32(glb.data() + 8);
    if (length > glb.size())
        throw InvalidDataError(file, "GLB header claims " + std::to_string(length) +
                                         " bytes but the file has " + std::to_string(glb.size()));
    // Found by fuzz_gltf: a length below the two headers made `length - 20` wrap around.
    if (length < 20)
        throw InvalidDataError(file, "GLB header claims " + std::to_string(length) +
                                         " bytes, less than its own 20-byte headers");
    const std::uint32_t chunkLength = readU32(glb.data() + 12);
    const std::uint32_t chunkType = readU32(glb.data() + 16);
    if (chunkType != 0x4E4F534Au) throw InvalidDataError(file, "GLB's first chunk is not JSON");
    if (chunkLength > length - 20)
        throw InvalidDataError(file, "GLB JSON chunk runs past the end of the file");
    // The binary chunk, if any, must fit inside the length the header claims, its own 8-byte
    // header included. tinygltf's check leaves that header out, so a chunk 8 bytes too long read
    // past the container (found by fuzz_gltf: a rewritten container ends at the claimed length).
    const std::uint32_t rest = length - 20 - chunkLength;
    if (rest > 0) {
        if (rest < 8)
            throw InvalidDataError(file, "GLB has " + std::to_string(rest) +
                                             " bytes after its JSON chunk, too few for a chunk");
        const std::uint32_t binLength = readU32(glb.data() + 20 + chunkLength);
        if (binLength > rest - 8)
            throw InvalidDataError(file, "GLB's second chunk claims " + std::to_string(binLength) +
                                             " bytes but the header's length leaves " +
                                             std::to_string(rest - 8));
    }
    return {reinterpret_cast<const char*>(glb.data() + 20), chunkLength};
}

}  // namespace vox::detail
