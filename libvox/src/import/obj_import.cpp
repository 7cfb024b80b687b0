// Wavefront OBJ + MTL. libvox reads OBJ itself: OpenMesh keeps one normal per vertex (hard
// edges lost), drops object/group names (needed by --dynamic) and emissive colours, and
// allocates by counts in the file. Faces are split into meshes by (object/group, material);
// vertices are shared within a mesh where position, UV and normal indices all match.
#include "importers.h"
#include "text_tokens.h"

#include <vox/util/progress.h>
#include <vox/util/timings.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <string_view>
#include <vector>

namespace vox::detail {
namespace {

/// Iterates over logical lines (joining backslash continuations), with 1-based line numbers.
class ObjLines {
public:
    explicit ObjLines(std::string_view text) : text_(text) {}
    bool next(std::string_view& line, std::size_t& number) {
        joined_.clear();
        bool continued = false;
        while (pos_ < text_.size()) {
            std::size_t end = text_.find('\n', pos_);
            if (end == std::string_view::npos) end = text_.size();
            std::string_view raw = text_.substr(pos_, end - pos_);
            pos_ = end + 1;
            ++lineNumber_;
            if (!continued) number = lineNumber_;
            if (!raw.empty() && raw.back() == '\r') raw.remove_suffix(1);
            if (!raw.empty() && raw.back() == '\\') {
                joined_.append(raw.substr(0, raw.size() - 1)).push_back(' ');
                continued = true;
                continue;
            }
            if (continued) {
                joined_.append(raw);
                line = joined_;
            } else {
                line = raw;
            }
            return true;
        }
        if (continued) {
            line = joined_;
            return true;
        }
        return false;
    }

    /// Bytes consumed so far.
    [[nodiscard]] std::size_t position() const { return std::min(pos_, text_.size()); }

private:
    std::string_view text_;
    std::size_t pos_ = 0, lineNumber_ = 0;
    std::string joined_;
};

struct Corner {
    std::uint32_t position, uv, normal;  // 0 = absent; otherwise 1-based
    bool operator==(const Corner&) const = default;
};
struct CornerHash {
    std::size_t operator()(const Corner& c) const noexcept {
        return (static_cast<std::size_t>(c.position) * 0x9E3779B97F4A7C15ull) ^
               (static_cast<std::size_t>(c.uv) * 0xC2B2AE3D27D4EB4Full) ^
               static_cast<std::size_t>(c.normal);
    }
};

/// Corner → vertex, open addressing in flat arrays: a node-based map allocated once per
/// distinct corner, which for a big OBJ is once per vertex.
class CornerTable {
public:
    /// The vertex of @p corner, or @p vertex (recorded for it) if the corner is new; @p inserted
    /// says which.
    std::uint32_t findOrInsert(const Corner& corner, std::uint32_t vertex, bool& inserted) {
        if (2 * (count_ + 1) > slots_.size()) grow();
        const std::size_t mask = slots_.size() - 1;
        for (std::size_t i = CornerHash{}(corner)&mask;; i = (i + 1) & mask) {
            Slot& slot = slots_[i];
            if (slot.corner.position == 0) {  // empty: every stored corner has a position
                slot = {corner, vertex};
                ++count_;
                inserted = true;
                return vertex;
            }
            if (slot.corner == corner) {
                inserted = false;
                return slot.vertex;
            }
        }
    }

private:
    struct Slot {
        Corner corner{0, 0, 0};
        std::uint32_t vertex = 0;
    };
    void grow() {
        std::vector<Slot> old = std::move(slots_);
        slots_.assign(std::max<std::size_t>(64, 2 * old.size()), Slot{});
        count_ = 0;
        bool inserted = false;
        for (const Slot& slot : old)
            if (slot.corner.position != 0) (void)findOrInsert(slot.corner, slot.vertex, inserted);
    }
    std::vector<Slot> slots_;
    std::size_t count_ = 0;
};

struct MeshBuilder {
    Mesh mesh;
    CornerTable corners;
    bool anyUv = false, anyNormal = false;
};

/// Largest polygon ear-clipped; clipping costs O(n³) at worst, so larger faces (which real
/// exporters do not write) are fanned to keep hostile input from hanging the import.
constexpr std::size_t kMaxEarClippedCorners = 256;

/// Ear clipping in the plane of the polygon's Newell normal; a fan if clipping gets stuck
/// (self-intersecting input) or the polygon is huge. Appends triangles as indices into @p points.
void triangulatePolygon(const std::vector<Vec3f>& points,
                        std::vector<std::array<std::size_t, 3>>& out) {
    const std::size_t n = points.size();
    if (n > kMaxEarClippedCorners) {
        for (std::size_t i = 1; i + 1 < n; ++i) out.push_back({0, i, i + 1});
        return;
    }
    Vec3d normal{};
    for (std::size_t i = 0; i < n; ++i) {
        const Vec3f a = points[i], b = points[(i + 1) % n];
        normal += Vec3d{(a.y - b.y) * (static_cast<double>(a.z) + b.z),
                        (a.z - b.z) * (static_cast<double>(a.x) + b.x),
                        (a.x - b.x) * (static_cast<double>(a.y) + b.y)};
    }
    const int axis = std::fabs(normal.x) > std::fabs(normal.y)
                         ? (std::fabs(normal.x) > std::fabs(normal.z) ? 0 : 2)
                         : (std::fabs(normal.y) > std::fabs(normal.z) ? 1 : 2);
    const int u = (axis + 1) % 3, v = (axis + 2) % 3;
    const double orientation = normal[axis] >= 0 ? 1.0 : -1.0;
    auto area2 = [&](std::size_t a, std::size_t b, std::size_t c) {
        const Vec3f& pa = points[a];
        const Vec3f& pb = points[b];
        const Vec3f& pc = points[c];
        return orientation *
               ((static_cast<double>(pb[u]) - pa[u]) * (static_cast<double>(pc[v]) - pa[v]) -
                (static_cast<double>(pb[v]) - pa[v]) * (static_cast<double>(pc[u]) - pa[u]));
    };
    std::vector<std::size_t> ring(n);
    for (std::size_t i = 0; i < n; ++i) ring[i] = i;
    std::size_t guard = 0;
    while (ring.size() > 3 && guard < 2 * n * n) {
        bool clipped = false;
        for (std::size_t i = 0; i < ring.size() && !clipped; ++i) {
            const std::size_t a = ring[(i + ring.size() - 1) % ring.size()], b = ring[i],
                              c = ring[(i + 1) % ring.size()];
            ++guard;
            if (area2(a, b, c) <= 0) continue;  // reflex corner
            bool containsOther = false;
            for (std::size_t p : ring) {
                if (p == a || p == b || p == c) continue;
                if (area2(a, b, p) >= 0 && area2(b, c, p) >= 0 && area2(c, a, p) >= 0) {
                    containsOther = true;
                    break;
                }
            }
            if (containsOther) continue;
            out.push_back({a, b, c});
            ring.erase(ring.begin() + static_cast<std::ptrdiff_t>(i));
            clipped = true;
        }
        if (!clipped) break;
    }
    for (std::size_t i = 1; i + 1 < ring.size(); ++i)
        out.push_back({ring[0], ring[i], ring[i + 1]});
}

class ObjImporter {
public:
    explicit ObjImporter(ImportContext& context) : context_(context) {}
    void run(std::string_view text);

private:
    [[noreturn]] void fail(std::size_t line, const std::string& problem) const {
        context_.fail("line " + std::to_string(line) + ": " + problem);
    }
    void readMtl(const std::filesystem::path& file);
    TextureBinding readMap(std::string_view args, ColorSpace colorSpace,
                           const std::filesystem::path& mtl, std::size_t line);
    void addFace(std::string_view args, std::size_t line);
    MeshBuilder& currentBuilder();
    Corner parseCorner(std::string_view token, std::size_t line) const;

    ImportContext& context_;
    std::vector<Vec3f> positions_, normals_;
    std::vector<Vec2f> uvs_;
    std::vector<Vec3f> vertexColors_;  // parallel to positions_ once any vertex has a colour
    bool anyVertexColor_ = false;
    std::map<std::string, std::uint32_t> materials_;
    std::string objectName_, groupName_;
    bool currentDynamic_ = false;
    std::int64_t currentMaterial_ = -1;
    std::map<std::pair<std::string, std::int64_t>, std::size_t> builderIndex_;
    std::vector<MeshBuilder> builders_;
    std::map<std::string, bool> unknownMaterials_;
    std::size_t skippedElements_ = 0;
    std::vector<Corner> faceCorners_;
    std::vector<Vec3f> facePoints_;
    std::vector<std::array<std::size_t, 3>> faceTriangles_;
};

TextureBinding ObjImporter::readMap(std::string_view args, ColorSpace colorSpace,
                                    const std::filesystem::path& mtl, std::size_t line) {
    TextureBinding binding;
    // Options come before the file name: -o/-s/-t take up to 3 numbers, the others one value.
    float offset[2] = {0, 0}, scale[2] = {1, 1};
    std::string_view rest = trim(args);
    for (; !rest.empty() && rest.front() == '-'; rest = trim(rest)) {
        std::string_view option = nextToken(rest);
        if (option == "-o" || option == "-s" || option == "-t") {
            for (int i = 0; i < 3; ++i) {
                std::string_view save = rest;
                float value = 0;
                std::string_view token = nextToken(rest);
                if (!parseFloat(token, value)) {
                    rest = save;
                    break;
                }
                if (i < 2 && option == "-o") offset[i] = value;
                if (i < 2 && option == "-s") scale[i] = value;
            }
        } else if (option == "-mm") {
            nextToken(rest);
            nextToken(rest);
        } else if (option == "-clamp") {
            if (nextToken(rest) == "on") binding.wrapS = binding.wrapT = WrapMode::ClampToEdge;
        } else {
            nextToken(rest);  // -blendu/-blendv/-cc/-bm/-boost/-imfchan/-texres value
        }
    }
    std::string name(trim(rest));
    if (name.empty())
        context_.fail(mtl.filename().string() + " line " + std::to_string(line) +
                      ": texture map without a file name");
    std::replace(name.begin(), name.end(), '\\', '/');
    const std::filesystem::path image = (mtl.parent_path() / name).lexically_normal();
    // -s/-o act on OBJ's v (up the image); the mesh's v is already libvox's 1 - v_obj, so in
    // libvox terms v' = 1 - (s·(1 - v) + o) = s·v + (1 - s - o).
    binding.uvTransform = {scale[0], 0, offset[0], 0, scale[1], 1 - scale[1] - offset[1]};
    binding.texture = context_.texture("file:" + image.string(), colorSpace,
                                       [&]() -> ImportContext::EncodedImage {
                                           return {context_.readFile(image), image, "", ""};
                                       });
    return binding;
}

void ObjImporter::readMtl(const std::filesystem::path& file) {
    const std::vector<std::uint8_t> bytes = context_.readFile(file);
    ObjLines lines({reinterpret_cast<const char*>(bytes.data()), bytes.size()});
    std::string_view line;
    std::size_t number = 0;
    std::int64_t currentIndex = -1;  // index, not pointer: the materials vector grows
    auto mtlFail = [&](const std::string& problem) {
        context_.fail(file.filename().string() + " line " + std::to_string(number) + ": " +
                      problem);
    };
    auto readColor = [&](std::string_view args) {
        Vec3f c{};
        for (int i = 0; i < 3; ++i) {
            std::string_view token = nextToken(args);
            if (token.empty() && i > 0) {
                c[i] = c[0];
                continue;
            }  // "Kd 0.5" is grey
            if (!parseFloat(token, c[i]) || !std::isfinite(c[i]) || c[i] < 0)
                mtlFail("malformed colour");
        }
        return c;
    };
    while (lines.next(line, number)) {
        std::string_view args = trim(line);
        if (args.empty() || args.front() == '#') continue;
        const std::string_view keyword = nextToken(args);
        if (keyword == "newmtl") {
            const std::string name(trim(args));
            Material material;
            material.name = name;
            context_.scene().materials.push_back(material);
            currentIndex = static_cast<std::int64_t>(context_.scene().materials.size() - 1);
            materials_[name] = static_cast<std::uint32_t>(currentIndex);
            continue;
        }
        if (currentIndex < 0)
            continue;  // statements before the first newmtl have nothing to apply to
        Material* current = &context_.scene().materials[static_cast<std::size_t>(currentIndex)];
        if (keyword == "Kd") {
            const Vec3f c = readColor(args);
            current->baseColorFactor = {std::min(c.x, 1.0f), std::min(c.y, 1.0f),
                                        std::min(c.z, 1.0f), current->baseColorFactor.w};
        } else if (keyword == "Ke") {
            const Vec3f c = readColor(args);
            const float peak = std::max({c.x, c.y, c.z});
            current->emissiveStrength = std::max(peak, 1.0f);
            current->emissiveFactor = c / current->emissiveStrength;
        } else if (keyword == "d" || keyword == "Tr") {
            float value = 1;
            std::string_view token = nextToken(args);
            if (token == "-halo") token = nextToken(args);
            if (!parseFloat(token, value) || value < 0 || value > 1)
                mtlFail("malformed dissolve value");
            current->baseColorFactor.w = keyword == "d" ? value : 1 - value;
            if (current->baseColorFactor.w < 1) current->alphaMode = AlphaMode::Blend;
        } else if (keyword == "map_Kd") {
            const TextureBinding binding = readMap(args, ColorSpace::SRGB, file, number);
            context_.scene().materials[static_cast<std::size_t>(currentIndex)].baseColorTexture =
                binding;
        } else if (keyword == "map_Ke") {
            const TextureBinding binding = readMap(args, ColorSpace::SRGB, file, number);
            current = &context_.scene().materials[static_cast<std::size_t>(currentIndex)];
            current->emissiveTexture = binding;
            if (!current->isEmissive()) current->emissiveFactor = {1, 1, 1};
        }
        // Ka, Ks, Ns, Ni, illum, bump/normal maps (height fields in OBJ) do not affect voxels.
    }
}

MeshBuilder& ObjImporter::currentBuilder() {
    const std::string name =
        objectName_.empty() ? groupName_
                            : (groupName_.empty() ? objectName_ : objectName_ + "/" + groupName_);
    const auto key = std::make_pair(name, currentMaterial_);
    auto it = builderIndex_.find(key);
    if (it != builderIndex_.end()) return builders_[it->second];
    MeshBuilder builder;
    builder.mesh.name = name.empty() ? context_.input().stem().string() : name;
    builder.mesh.dynamic = currentDynamic_;
    builder.mesh.material = currentMaterial_ >= 0 ? static_cast<std::uint32_t>(currentMaterial_)
                                                  : context_.defaultMaterial();
    builders_.push_back(std::move(builder));
    builderIndex_.emplace(key, builders_.size() - 1);
    return builders_.back();
}

Corner ObjImporter::parseCorner(std::string_view token, std::size_t line) const {
    Corner corner{0, 0, 0};
    const std::size_t sizes[3] = {positions_.size(), uvs_.size(), normals_.size()};
    std::uint32_t* fields[3] = {&corner.position, &corner.uv, &corner.normal};
    for (int part = 0; part < 3; ++part) {
        const std::size_t slash = token.find('/');
        const std::string_view text = token.substr(0, slash);
        if (!text.empty()) {
            long long index = 0;
            if (!parseInt(text, index) || index == 0)
                fail(line, "malformed face corner '" + std::string(token) + "'");
            // Negative indices count back from the latest element.
            const long long resolved =
                index < 0 ? static_cast<long long>(sizes[part]) + index + 1 : index;
            if (resolved < 1 || resolved > static_cast<long long>(sizes[part]))
                fail(line, std::string(part == 0   ? "vertex"
                                       : part == 1 ? "texture coordinate"
                                                   : "normal") +
                               " index " + std::to_string(index) + " out of range (" +
                               std::to_string(sizes[part]) + " defined)");
            *fields[part] = static_cast<std::uint32_t>(resolved);
        } else if (part == 0) {
            fail(line, "face corner '" + std::string(token) + "' has no vertex index");
        }
        if (slash == std::string_view::npos) break;
        token.remove_prefix(slash + 1);
    }
    return corner;
}

void ObjImporter::addFace(std::string_view args, std::size_t line) {
    faceCorners_.clear();
    for (std::string_view token = nextToken(args); !token.empty(); token = nextToken(args))
        faceCorners_.push_back(parseCorner(token, line));
    if (faceCorners_.size() < 3) {
        ++skippedElements_;  // a face with fewer than 3 corners has no surface; skip it like a line
        return;
    }
    MeshBuilder& builder = currentBuilder();
    Mesh& mesh = builder.mesh;
    auto vertexOf = [&](const Corner& corner) -> std::uint32_t {
        bool inserted = false;
        const std::uint32_t vertex = builder.corners.findOrInsert(
            corner, static_cast<std::uint32_t>(mesh.positions.size()), inserted);
        if (inserted) {
            mesh.positions.push_back(positions_[corner.position - 1]);
            mesh.normals.push_back(corner.normal ? normals_[corner.normal - 1] : Vec3f{});
            if (mesh.uvs.empty()) mesh.uvs.emplace_back();
            const Vec2f uv = corner.uv ? uvs_[corner.uv - 1] : Vec2f{0, 0};
            mesh.uvs[0].push_back(uv);
            if (anyVertexColor_) {
                const Vec3f c = corner.position - 1 < vertexColors_.size()
                                    ? vertexColors_[corner.position - 1]
                                    : Vec3f{1, 1, 1};
                mesh.colors.resize(mesh.positions.size() - 1, Vec4f{1, 1, 1, 1});
                mesh.colors.push_back({c.x, c.y, c.z, 1});
            }
            builder.anyUv = builder.anyUv || corner.uv;
            builder.anyNormal = builder.anyNormal || corner.normal;
        }
        return vertex;
    };
    if (faceCorners_.size() == 3) {
        for (const Corner& c : faceCorners_) mesh.indices.push_back(vertexOf(c));
        return;
    }
    facePoints_.clear();
    for (const Corner& c : faceCorners_) facePoints_.push_back(positions_[c.position - 1]);
    faceTriangles_.clear();
    triangulatePolygon(facePoints_, faceTriangles_);
    for (const auto& tri : faceTriangles_)
        for (std::size_t k : tri) mesh.indices.push_back(vertexOf(faceCorners_[k]));
}

void ObjImporter::run(std::string_view text) {
    ObjLines lines(text);
    std::string_view line;
    std::size_t number = 0;
    Progress progress("reading OBJ", text.size());
    constexpr std::size_t kProgressStep = 1 << 20;
    std::size_t reported = 0;
    while (lines.next(line, number)) {
        if (lines.position() - reported >= kProgressStep) {
            progress.advance(lines.position() - reported);
            reported = lines.position();
        }
        std::string_view args = trim(line);
        if (args.empty() || args.front() == '#') continue;
        const std::string_view keyword = nextToken(args);
        if (keyword == "v") {
            float values[6];
            int count = 0;
            for (std::string_view token = nextToken(args); !token.empty() && count < 7;
                 token = nextToken(args)) {
                if (count == 6) fail(number, "a vertex has more than 6 numbers");
                if (!parseFloat(token, values[count]))
                    fail(number, "malformed number '" + std::string(token) + "' in a vertex");
                ++count;
            }
            if (count < 3) fail(number, "a vertex needs 3 coordinates");
            positions_.push_back({values[0], values[1], values[2]});
            if (count == 6) {  // "v x y z r g b": display-referred colour
                anyVertexColor_ = true;
                vertexColors_.resize(positions_.size() - 1, Vec3f{1, 1, 1});
                vertexColors_.push_back({values[3], values[4], values[5]});
            }
        } else if (keyword == "vt") {
            Vec2f uv{};
            std::string_view token = nextToken(args);
            if (!parseFloat(token, uv.x))
                fail(number,
                     "malformed number '" + std::string(token) + "' in a texture coordinate");
            token = nextToken(args);
            if (!token.empty() && !parseFloat(token, uv.y))
                fail(number,
                     "malformed number '" + std::string(token) + "' in a texture coordinate");
            uvs_.push_back({uv.x, 1.0f - uv.y});  // OBJ's v points up the image, libvox's down
        } else if (keyword == "vn") {
            Vec3f n{};
            for (int i = 0; i < 3; ++i) {
                const std::string_view token = nextToken(args);
                if (!parseFloat(token, n[i]))
                    fail(number, "malformed number '" + std::string(token) + "' in a normal");
            }
            normals_.push_back(n);
        } else if (keyword == "f") {
            addFace(args, number);
        } else if (keyword == "o" || keyword == "g") {
            std::string& name = keyword == "o" ? objectName_ : groupName_;
            name = std::string(trim(args));
            if (keyword == "o") groupName_.clear();
            currentDynamic_ = context_.isDynamicName(objectName_);
            // A group line may list several names; any of them marks the faces dynamic.
            for (std::string_view names = groupName_, g = nextToken(names); !g.empty();
                 g = nextToken(names))
                currentDynamic_ = context_.isDynamicName(std::string(g)) || currentDynamic_;
        } else if (keyword == "usemtl") {
            const std::string name(trim(args));
            auto it = materials_.find(name);
            if (it != materials_.end()) {
                currentMaterial_ = it->second;
            } else {
                unknownMaterials_[name] = true;
                currentMaterial_ = -1;
            }
        } else if (keyword == "mtllib") {
            // Names may contain spaces: try the whole rest as one file before splitting it.
            const std::string whole(trim(args));
            const std::filesystem::path dir = context_.input().parent_path();
            std::error_code ec;
            if (std::filesystem::is_regular_file(dir / whole, ec)) {
                readMtl(dir / whole);
            } else {
                for (std::string_view token = nextToken(args); !token.empty();
                     token = nextToken(args))
                    readMtl(dir / std::string(token));
            }
        } else if (keyword == "l" || keyword == "p" || keyword == "curv" || keyword == "surf") {
            ++skippedElements_;
        }
        // s, vp, cstype, deg, ... do not affect a surface voxelization.
    }
    progress.advance(text.size() - reported);
    for (const auto& [name, unused] : unknownMaterials_)
        context_.warn("usemtl '" + name +
                      "' names no material in the .mtl files; the default material is used");
    if (skippedElements_)
        context_.warn("skipped " + std::to_string(skippedElements_) +
                      " point, line, curve or surface element(s)");
    for (MeshBuilder& builder : builders_) {
        Mesh& mesh = builder.mesh;
        if (!builder.anyUv) mesh.uvs.clear();
        // Corners without a normal get generated ones; "vn" everywhere keeps the file's normals.
        if (!builder.anyNormal) mesh.normals.clear();
        if (anyVertexColor_) {
            mesh.colors.resize(mesh.positions.size(), Vec4f{1, 1, 1, 1});
            for (Vec4f& c : mesh.colors)
                c = {srgbToLinear(c.x), srgbToLinear(c.y), srgbToLinear(c.z), c.w};
        }
        context_.scene().meshes.push_back(std::move(mesh));
    }
}

}  // namespace

void importObj(ImportContext& context, const std::vector<std::uint8_t>& bytes) {
    Timings::Scope timer(context.options().timings, "import.parse");
    ObjImporter importer(context);
    importer.run({reinterpret_cast<const char*>(bytes.data()), bytes.size()});
}

}  // namespace vox::detail
