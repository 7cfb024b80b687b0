// PLY through OpenMesh. OpenMesh reserves memory by the counts a header claims and
// reports success on files it could not parse, so the header is checked here first (every
// claimed count must fit the bytes that follow it) and the result is checked afterwards.
#include "importers.h"

#include <vox/util/timings.h>

#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <OpenMesh/Core/System/omstream.hh>

#include <iostream>

#include <charconv>
#include <cmath>
#include <cstring>
#include <mutex>
#include <sstream>
#include <streambuf>
#include <unordered_map>

namespace vox::detail {
namespace {

struct MeshTraits : OpenMesh::DefaultTraits {
    VertexAttributes(OpenMesh::Attributes::Normal | OpenMesh::Attributes::Color | OpenMesh::Attributes::TexCoord2D);
    FaceAttributes(OpenMesh::Attributes::Normal);
    typedef OpenMesh::Vec4f Color;
};
using OmMesh = OpenMesh::TriMesh_ArrayKernelT<MeshTraits>;

/// An istream over bytes already in memory, so OpenMesh parses exactly what was checked.
class MemoryBuffer : public std::streambuf {
public:
    explicit MemoryBuffer(const std::vector<std::uint8_t>& bytes) {
        char* begin = const_cast<char*>(reinterpret_cast<const char*>(bytes.data()));
        setg(begin, begin, begin + bytes.size());
    }

protected:
    // OpenMesh's binary readers seek; a bare streambuf cannot.
    pos_type seekoff(off_type offset, std::ios_base::seekdir dir, std::ios_base::openmode) override {
        const off_type base = dir == std::ios_base::beg ? 0 : (dir == std::ios_base::cur ? gptr() - eback() : egptr() - eback());
        const off_type target = base + offset;
        if (target < 0 || target > egptr() - eback()) return pos_type(off_type(-1));
        setg(eback(), eback() + target, egptr());
        return pos_type(target);
    }
    pos_type seekpos(pos_type position, std::ios_base::openmode mode) override {
        return seekoff(off_type(position), std::ios_base::beg, mode);
    }
};

/// Splits text into whitespace-separated tokens, line by line.
class LineReader {
public:
    explicit LineReader(const std::vector<std::uint8_t>& bytes) : bytes_(bytes) {}
    bool next(std::string& line) {
        if (pos_ >= bytes_.size()) return false;
        const auto* start = bytes_.data() + pos_;
        const auto* end = static_cast<const std::uint8_t*>(std::memchr(start, '\n', bytes_.size() - pos_));
        const std::size_t len = end ? static_cast<std::size_t>(end - start) : bytes_.size() - pos_;
        line.assign(reinterpret_cast<const char*>(start), len);
        if (!line.empty() && line.back() == '\r') line.pop_back();
        pos_ += len + (end ? 1 : 0);
        return true;
    }
    [[nodiscard]] std::size_t position() const { return pos_; }

private:
    const std::vector<std::uint8_t>& bytes_;
    std::size_t pos_ = 0;
};

std::vector<std::string> tokens(const std::string& line) {
    std::vector<std::string> out;
    std::istringstream in(line);
    for (std::string t; in >> t;) out.push_back(t);
    return out;
}

bool parseCount(const std::string& text, std::uint64_t& value) {
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    return ec == std::errc() && end == text.data() + text.size();
}

/// Whether @p text is a version OpenMesh's header reader takes: it reads it into a float with
/// operator>>, which fails on what is no decimal number (from_chars also reads "inf" and "nan")
/// and on what a float cannot hold (1.01e39).
bool isPlyVersion(const std::string& text) {
    if (text.find_first_not_of("0123456789+-.eE") != std::string::npos) return false;
    float version = 0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), version);
    return ec == std::errc() && end == text.data() + text.size() && std::isfinite(version);
}

int plyTypeSize(const std::string& type) {
    if (type == "char" || type == "uchar" || type == "int8" || type == "uint8") return 1;
    if (type == "short" || type == "ushort" || type == "int16" || type == "uint16") return 2;
    if (type == "int" || type == "uint" || type == "int32" || type == "uint32" || type == "float" || type == "float32") return 4;
    if (type == "double" || type == "float64") return 8;
    return 0;
}

bool isPlyFloat(const std::string& type) { return type == "float" || type == "float32" || type == "double" || type == "float64"; }
bool isPlySigned(const std::string& type) {
    return type == "char" || type == "int8" || type == "short" || type == "int16" || type == "int" || type == "int32";
}

/// A property as the records store it: a scalar of @p size bytes, or a list (a count, then that
/// many items of @p size bytes).
struct PlyProperty {
    bool list = false;
    int countSize = 0;
    bool countSigned = false;
    int size = 0;
};

struct HeaderFacts {
    std::uint64_t vertices = 0;
    std::uint64_t faces = 0;      // faces (polygons)
    bool binary = false;
    std::string textureFile;  // PLY "comment TextureFile" (MeshLab's convention)
};

HeaderFacts checkPlyHeader(const ImportContext& context, const std::vector<std::uint8_t>& bytes) {
    LineReader reader(bytes);
    std::string line;
    reader.next(line);  // "ply", checked by the caller
    HeaderFacts facts;
    struct Element {
        std::string name;
        std::uint64_t count = 0;
        std::uint64_t minBytes = 0;
        std::vector<PlyProperty> properties;
    };
    std::vector<Element> elements;
    bool ended = false, hasFormat = false;
    std::string plyFormat;
    while (reader.next(line)) {
        const auto t = tokens(line);
        if (t.empty()) continue;
        // OpenMesh takes the words after the first as the format and version, whatever the first
        // word is, and loops for good on a version it cannot read ("fo\x94mat … uch1.0", found by
        // fuzz_mesh): the format line must come first, as the PLY format has it.
        if (!hasFormat && t[0] != "format")
            context.fail("PLY header: the line after 'ply' is '" + line + "', not its format line (e.g. 'format ascii 1.0')");
        if (t[0] == "end_header") {
            ended = true;
            break;
        }
        if (t[0] == "format") {
            if (t.size() < 2 || (t[1] != "ascii" && t[1] != "binary_little_endian" && t[1] != "binary_big_endian"))
                context.fail("PLY header: unknown format '" + line + "'");
            // A version OpenMesh cannot read leaves its stream failed, and its header loop then
            // never sees end_header (found by fuzz_mesh: "uch1.0", then "1.01e39").
            if (t.size() != 3 || !isPlyVersion(t[2]))
                context.fail("PLY header: malformed format line '" + line + "' (expected e.g. 'format ascii 1.0')");
            facts.binary = t[1] != "ascii";
            plyFormat = t[1];
            hasFormat = true;
        } else if (t[0] == "comment") {
            if (t.size() >= 3 && t[1] == "TextureFile") facts.textureFile = line.substr(line.find("TextureFile") + 12);
        } else if (t[0] == "element") {
            std::uint64_t count = 0;
            if (t.size() != 3 || !parseCount(t[2], count)) context.fail("PLY header: malformed element line '" + line + "'");
            elements.push_back({t[1], count, 0, {}});
        } else if (t[0] == "property") {
            if (elements.empty()) context.fail("PLY header: property before any element");
            Element& e = elements.back();
            if (t.size() == 5 && t[1] == "list") {
                const int countSize = plyTypeSize(t[2]), itemSize = plyTypeSize(t[3]);
                if (!countSize || !itemSize) context.fail("PLY header: unknown list type in '" + line + "'");
                if (isPlyFloat(t[2])) context.fail("PLY header: list count type is not an integer type in '" + line + "'");
                e.minBytes += facts.binary ? countSize : 2;
                e.properties.push_back({true, countSize, isPlySigned(t[2]), itemSize});
            } else if (t.size() == 3) {
                const int size = plyTypeSize(t[1]);
                if (!size) context.fail("PLY header: unknown property type in '" + line + "'");
                e.minBytes += facts.binary ? size : 2;
                e.properties.push_back({false, 0, false, size});
            } else {
                context.fail("PLY header: malformed property line '" + line + "'");
            }
        } else {
            // obj_info and free text (Blender writes its name on a line of its own): OpenMesh reads
            // the header as a stream of words, not lines, and skips words it does not know, so
            // these are harmless unless one of their words is a keyword it acts on. "junk element
            // vertex list ..." became an element whose count failed to parse, and OpenMesh's element
            // list grew without end (found by fuzz_mesh).
            for (const std::string& word : t)
                if (word == "element" || word == "property" || word == "end_header")
                    context.fail("PLY header: line '" + line + "' holds the keyword '" + word + "' but does not start with it");
        }
    }
    if (!ended) context.fail("PLY header has no end_header");
    if (!hasFormat) context.fail("PLY header has no format line");
    const std::uint64_t available = bytes.size() - reader.position();
    std::uint64_t needed = 0;
    for (const Element& e : elements) {
        // An element of no properties takes no bytes, but OpenMesh still loops over its count,
        // which it reads as a 32-bit integer: beyond that its stream fails and its header loop
        // never ends (99999999999, found by checking the fix for the version). Such a count may
        // not exceed the bytes that follow either.
        if (e.count > available / std::max<std::uint64_t>(e.minBytes, 1))
            context.fail("PLY header claims " + std::to_string(e.count) + " " + e.name + " elements, more than the " +
                         std::to_string(available) + " bytes after the header can hold");
        needed += e.count * e.minBytes;
        if (e.name == "vertex") facts.vertices = e.count;
        if (e.name == "face") facts.faces = e.count;
    }
    if (needed > available)
        context.fail("PLY header claims elements needing at least " + std::to_string(needed) + " bytes, but only " +
                     std::to_string(available) + " follow the header");
    if (facts.faces == 0) context.fail("has no faces (a point cloud?)");
    // OpenMesh sizes each list (a face's corners) by the count it reads, unchecked: a count of
    // 4 000 000 000 is 16 GB of corners (found by fuzz_mesh for OFF, whose reader libvox replaced).
    // Walk the records as OpenMesh reads them and check every count against what follows.
    const std::uint8_t* at = bytes.data() + reader.position();
    const std::uint8_t* const end = bytes.data() + bytes.size();
    const bool bigEndian = facts.binary && plyFormat == "binary_big_endian";
    const auto truncated = [&](const Element& e, std::uint64_t record) {
        context.fail("is truncated: " + e.name + " " + std::to_string(record) + " of " + std::to_string(e.count) +
                     " ends past the end of the file");
    };
    // ASCII: every value is one whitespace-separated token, records and lines notwithstanding.
    const auto nextToken = [&]() -> std::string_view {
        while (at < end && std::isspace(*at)) ++at;
        const std::uint8_t* start = at;
        while (at < end && !std::isspace(*at)) ++at;
        return {reinterpret_cast<const char*>(start), static_cast<std::size_t>(at - start)};
    };
    for (const Element& e : elements)
        for (std::uint64_t record = 0; record < e.count; ++record)
            for (const PlyProperty& property : e.properties) {
                std::uint64_t values = 1;
                if (property.list) {
                    std::int64_t count = 0;
                    if (facts.binary) {
                        if (end - at < property.countSize) truncated(e, record);
                        std::uint8_t raw[8] = {};
                        for (int b = 0; b < property.countSize; ++b) raw[bigEndian ? property.countSize - 1 - b : b] = at[b];
                        std::uint64_t word = 0;
                        std::memcpy(&word, raw, 8);
                        const int bits = 8 * property.countSize;
                        count = property.countSigned && (word >> (bits - 1)) & 1 ? -1 : static_cast<std::int64_t>(word);
                        at += property.countSize;
                    } else {
                        const std::string_view token = nextToken();
                        if (token.empty()) truncated(e, record);
                        if (std::from_chars(token.data(), token.data() + token.size(), count).ptr != token.data() + token.size()) count = -1;
                    }
                    if (count < 0) context.fail(e.name + " " + std::to_string(record) + ": malformed list count");
                    values = static_cast<std::uint64_t>(count);
                    if (facts.binary ? values > static_cast<std::uint64_t>(end - at) / property.size
                                     : values > static_cast<std::uint64_t>(end - at) / 2 + 1)
                        context.fail(e.name + " " + std::to_string(record) + ": a list of " + std::to_string(values) +
                                     " values, more than the rest of the file holds");
                }
                if (facts.binary) {
                    if (static_cast<std::uint64_t>(end - at) < values * property.size) truncated(e, record);
                    at += values * property.size;
                } else {
                    // Each value one whole number: OpenMesh's stream would read "3-1" as 3 and
                    // then take "-1" for the next face's corner count (found by fuzz_mesh).
                    for (std::uint64_t v = 0; v < values; ++v) {
                        const std::string_view token = nextToken();
                        if (token.empty()) truncated(e, record);
                        double number = 0;
                        if (std::from_chars(token.data(), token.data() + token.size(), number).ptr != token.data() + token.size())
                            context.fail(e.name + " " + std::to_string(record) + ": malformed value '" + std::string(token) + "'");
                    }
                }
            }
    return facts;
}

/// Sends OpenMesh's error stream (normally stderr) to @p sink while it lives, and silences its
/// log and info streams: libvox reports what went wrong in its own words. OpenMesh's stream
/// multiplexer leaks a target on every disconnect, so one forwarding stream is connected once
/// for the life of the process and only its destination changes.
class OpenMeshErrorCapture {
public:
    /// The caller holds openMeshMutex(): OpenMesh's streams are global.
    explicit OpenMeshErrorCapture(std::ostream& sink) { router().buffer.target = &sink; }
    ~OpenMeshErrorCapture() { router().buffer.target = nullptr; }
    OpenMeshErrorCapture(const OpenMeshErrorCapture&) = delete;
    OpenMeshErrorCapture& operator=(const OpenMeshErrorCapture&) = delete;

private:
    struct ForwardingBuffer : std::streambuf {
        std::ostream* target = nullptr;
        int overflow(int c) override {
            if (target && c != traits_type::eof()) target->put(static_cast<char>(c));
            return traits_type::not_eof(c);
        }
        std::streamsize xsputn(const char* text, std::streamsize count) override {
            if (target) target->write(text, count);
            return count;
        }
    };
    struct Router {
        ForwardingBuffer buffer;
        std::ostream stream{&buffer};
        Router() {
            omerr().disconnect(std::cerr);
            omerr().connect(stream);
            omlog().disable();
            omout().disable();
        }
    };
    static Router& router() {
        static Router instance;
        return instance;
    }
};

std::mutex& openMeshMutex() {
    static std::mutex mutex;  // OpenMesh's log streams are process-wide
    return mutex;
}

/// OpenMesh adds each face that would make its mesh non-manifold again on copies of its vertices,
/// appended after the file's own, without their normals, colours or UVs. libvox needs no
/// manifold: point such faces back at the file's vertex with the same position.
void remapNonManifoldCopies(Mesh& mesh, std::uint64_t fileVertices) {
    if (fileVertices == 0 || mesh.positions.size() <= fileVertices) return;
    std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> byPosition;
    auto key = [](const Vec3f& p) {
        std::uint32_t x, y, z;
        std::memcpy(&x, &p.x, 4);
        std::memcpy(&y, &p.y, 4);
        std::memcpy(&z, &p.z, 4);
        return (std::uint64_t{x} * 0x9E3779B97F4A7C15ull) ^ (std::uint64_t{y} * 0xC2B2AE3D27D4EB4Full) ^ z;
    };
    for (std::uint32_t v = 0; v < fileVertices; ++v) byPosition[key(mesh.positions[v])].push_back(v);
    for (std::uint32_t& index : mesh.indices) {
        if (index < fileVertices) continue;
        for (std::uint32_t original : byPosition[key(mesh.positions[index])])
            if (mesh.positions[original] == mesh.positions[index]) {
                index = original;
                break;
            }
    }
    auto truncate = [&](auto& values) {
        if (values.size() > fileVertices) values.resize(fileVertices);
    };
    truncate(mesh.positions);
    truncate(mesh.normals);
    truncate(mesh.colors);
    for (auto& set : mesh.uvs) truncate(set);
}

}  // namespace

void importPly(ImportContext& context, const std::vector<std::uint8_t>& bytes) {
    Timings::Scope timer(context.options().timings, "import.parse");
    const HeaderFacts facts = checkPlyHeader(context, bytes);
    const std::string ext = "ply";
    if (facts.faces == 0) context.fail("has no faces (a point cloud?)");


    OmMesh mesh;
    OpenMesh::IO::Options options = OpenMesh::IO::Options::VertexNormal | OpenMesh::IO::Options::VertexColor |
                                    OpenMesh::IO::Options::VertexTexCoord | OpenMesh::IO::Options::ColorAlpha |
                                    OpenMesh::IO::Options::ColorFloat;
    if (facts.binary) options += OpenMesh::IO::Options::Binary;
    std::ostringstream openMeshErrors;
    bool ok = false;
    {
        std::lock_guard lock(openMeshMutex());
        OpenMeshErrorCapture capture(openMeshErrors);
        MemoryBuffer buffer(bytes);
        std::istream stream(&buffer);
        try {
            ok = OpenMesh::IO::read_mesh(mesh, stream, ext, options);
        } catch (const std::bad_alloc&) {
            context.fail("cannot be read: it claims more data than memory holds");
        } catch (const std::exception& e) {
            context.fail(std::string("cannot be read: ") + e.what());
        }
    }
    const std::string errors = openMeshErrors.str();
    auto countLines = [&](std::string_view what) {
        std::size_t n = 0;
        for (std::size_t at = errors.find(what); at != std::string::npos; at = errors.find(what, at + what.size())) ++n;
        return n;
    };
    auto firstError = [&]() {
        std::string line = errors.substr(0, errors.find('\n'));
        return line.empty() ? std::string() : " (" + line + ")";
    };
    if (!ok) context.fail("cannot be parsed" + firstError());
    if (countLines("invalid vertex index")) context.fail("a face refers to a vertex that does not exist");
    if (mesh.n_faces() == 0) context.fail("has no faces (a point cloud?)");
    if (facts.vertices && mesh.n_vertices() < facts.vertices)
        context.fail("is truncated: " + std::to_string(mesh.n_vertices()) + " of " + std::to_string(facts.vertices) + " vertices read");
    // OpenMesh drops faces with repeated vertices — they are degenerate.
    context.scene().degenerateTrianglesDropped += countLines("equal vertices");

    Mesh out;
    out.name = context.input().stem().string();
    out.dynamic = context.isDynamicName(out.name);
    out.positions.reserve(mesh.n_vertices());
    for (auto v : mesh.vertices()) {
        const auto p = mesh.point(v);
        out.positions.push_back({p[0], p[1], p[2]});
    }
    if (options.check(OpenMesh::IO::Options::VertexNormal)) {
        for (auto v : mesh.vertices()) {
            const auto n = mesh.normal(v);
            out.normals.push_back({n[0], n[1], n[2]});
        }
    }
    if (options.check(OpenMesh::IO::Options::VertexTexCoord)) {
        out.uvs.emplace_back();
        for (auto v : mesh.vertices()) {
            const auto t = mesh.texcoord2D(v);
            out.uvs[0].push_back({t[0], 1.0f - t[1]});  // PLY's v points up the image, libvox's down
        }
    }
    if (options.check(OpenMesh::IO::Options::VertexColor)) {
        const bool alpha = options.check(OpenMesh::IO::Options::ColorAlpha);
        for (auto v : mesh.vertices()) {
            const auto c = mesh.color(v);
            // PLY colours are display-referred (sRGB-encoded), libvox's are linear.
            out.colors.push_back({srgbToLinear(c[0]), srgbToLinear(c[1]), srgbToLinear(c[2]), alpha ? c[3] : 1.0f});
        }
    }
    out.indices.reserve(mesh.n_faces() * 3);
    for (auto f : mesh.faces())
        for (auto v : mesh.fv_range(f)) out.indices.push_back(static_cast<std::uint32_t>(v.idx()));
    remapNonManifoldCopies(out, facts.vertices);

    if (!facts.textureFile.empty() && !out.uvs.empty()) {
        Material material;
        material.name = facts.textureFile;
        const std::filesystem::path image = context.input().parent_path() / facts.textureFile;
        material.baseColorTexture.texture = context.texture("file:" + image.string(), ColorSpace::SRGB, [&]() -> ImportContext::EncodedImage {
            return {context.readFile(image), image, "", ""};
        });
        context.scene().materials.push_back(material);
        out.material = static_cast<std::uint32_t>(context.scene().materials.size() - 1);
    } else {
        out.material = context.defaultMaterial();
    }
    context.scene().meshes.push_back(std::move(out));
}

}  // namespace vox::detail
