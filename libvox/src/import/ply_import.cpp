// PLY (ASCII, binary little and big endian) read straight into a Mesh. The header is read line
// by line and every count it claims is checked against the bytes that follow before anything is
// sized by it; the records are then decoded by a per-element plan (property → offset, type,
// destination) made once from the header, so the loop over records does no string work and
// allocates nothing per record. Polygons are fan-triangulated; elements other than the first
// "vertex" and "face" are skipped, as are unknown properties (by their size, or token count).
#include "importers.h"
#include "text_tokens.h"

#include <vox/texture.h>
#include <vox/util/timings.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <string>
#include <string_view>

namespace vox::detail {
namespace {

enum class PlyType : std::uint8_t {
    None,
    Int8,
    UInt8,
    Int16,
    UInt16,
    Int32,
    UInt32,
    Float32,
    Float64
};

PlyType plyType(std::string_view name) {
    if (name == "char" || name == "int8") return PlyType::Int8;
    if (name == "uchar" || name == "uint8") return PlyType::UInt8;
    if (name == "short" || name == "int16") return PlyType::Int16;
    if (name == "ushort" || name == "uint16") return PlyType::UInt16;
    if (name == "int" || name == "int32") return PlyType::Int32;
    if (name == "uint" || name == "uint32") return PlyType::UInt32;
    if (name == "float" || name == "float32") return PlyType::Float32;
    if (name == "double" || name == "float64") return PlyType::Float64;
    return PlyType::None;
}

constexpr int plyTypeSize(PlyType type) {
    switch (type) {
        case PlyType::Int8:
        case PlyType::UInt8:
            return 1;
        case PlyType::Int16:
        case PlyType::UInt16:
            return 2;
        case PlyType::Int32:
        case PlyType::UInt32:
        case PlyType::Float32:
            return 4;
        case PlyType::Float64:
            return 8;
        case PlyType::None:
            break;
    }
    return 0;
}

constexpr bool isFloatType(PlyType type) {
    return type == PlyType::Float32 || type == PlyType::Float64;
}

/// Where a vertex property's value goes.
enum class VertexSlot : std::uint8_t { X, Y, Z, NX, NY, NZ, Red, Green, Blue, Alpha, U, V, Skip };
constexpr int kVertexSlots = static_cast<int>(VertexSlot::Skip);

VertexSlot vertexSlot(std::string_view name) {
    if (name == "x") return VertexSlot::X;
    if (name == "y") return VertexSlot::Y;
    if (name == "z") return VertexSlot::Z;
    if (name == "nx") return VertexSlot::NX;
    if (name == "ny") return VertexSlot::NY;
    if (name == "nz") return VertexSlot::NZ;
    if (name == "red" || name == "diffuse_red" || name == "r") return VertexSlot::Red;
    if (name == "green" || name == "diffuse_green" || name == "g") return VertexSlot::Green;
    if (name == "blue" || name == "diffuse_blue" || name == "b") return VertexSlot::Blue;
    if (name == "alpha" || name == "diffuse_alpha" || name == "a") return VertexSlot::Alpha;
    if (name == "u" || name == "s" || name == "texture_u" || name == "texture_s")
        return VertexSlot::U;
    if (name == "v" || name == "t" || name == "texture_v" || name == "texture_t")
        return VertexSlot::V;
    return VertexSlot::Skip;
}

/// A property as the records store it: a scalar of @p type, or a list (a count of
/// @p countType, then that many items of @p type).
struct PlyProperty {
    std::string name;
    bool list = false;
    PlyType countType = PlyType::None;
    PlyType type = PlyType::None;
};

struct PlyElement {
    std::string name;
    std::uint64_t count = 0;
    std::uint64_t minBytes =
        0;  ///< the least one record takes (binary: scalars and list counts; ASCII: 2 per value)
    std::vector<PlyProperty> properties;
};

enum class PlyFormat : std::uint8_t { Ascii, BinaryLittleEndian, BinaryBigEndian };

struct PlyHeader {
    PlyFormat format = PlyFormat::Ascii;
    std::vector<PlyElement> elements;
    std::size_t dataOffset = 0;  ///< first byte after end_header's line
    std::string textureFile;     ///< "comment TextureFile NAME" (MeshLab's convention)
};

/// Lines of the header, without their line ends.
class LineReader {
public:
    explicit LineReader(std::string_view text) : text_(text) {}
    bool next(std::string_view& line) {
        if (pos_ >= text_.size()) return false;
        std::size_t end = text_.find('\n', pos_);
        const bool hasEnd = end != std::string_view::npos;
        if (!hasEnd) end = text_.size();
        line = text_.substr(pos_, end - pos_);
        if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
        pos_ = end + (hasEnd ? 1 : 0);
        return true;
    }
    [[nodiscard]] std::size_t position() const { return pos_; }

private:
    std::string_view text_;
    std::size_t pos_ = 0;
};

bool isSpace(std::uint8_t c) {
    return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f';
}

/// Whitespace-separated words of a header line (a handful: allocation does not matter here).
std::vector<std::string_view> words(std::string_view line) {
    std::vector<std::string_view> out;
    for (std::string_view word = nextToken(line); !word.empty(); word = nextToken(line))
        out.push_back(word);
    return out;
}

bool parseCount(std::string_view text, std::uint64_t& value) {
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    return ec == std::errc() && end == text.data() + text.size();
}

/// Whether @p text is a PLY version: a finite decimal number a float holds (the formats readers
/// expect; "inf", "nan", "1.01e39" and "uch1.0" are none).
bool isPlyVersion(std::string_view text) {
    if (text.find_first_not_of("0123456789+-.eE") != std::string_view::npos) return false;
    float version = 0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), version);
    return ec == std::errc() && end == text.data() + text.size() && std::isfinite(version);
}

PlyHeader readHeader(const ImportContext& context, std::string_view text) {
    LineReader reader(text);
    std::string_view line;
    reader.next(line);  // "ply", checked by the caller
    PlyHeader header;
    bool ended = false, hasFormat = false;
    const auto quoted = [](std::string_view l) {
        std::string out(
            1, '\'');  // not "'" + std::string(l): GCC 12 warns of a bogus overlap (-Wrestrict)
        out.append(l);
        out += '\'';
        return out;
    };
    while (reader.next(line)) {
        const auto t = words(line);
        if (t.empty()) continue;
        // The format line comes first, as the PLY format has it (a reader that took the words
        // after whatever first word as the format looped for good on "fo\x94mat … uch1.0").
        if (!hasFormat && t[0] != "format")
            context.fail("PLY header: the line after 'ply' is " + quoted(line) +
                         ", not its format line (e.g. 'format ascii 1.0')");
        if (t[0] == "end_header") {
            ended = true;
            break;
        }
        if (t[0] == "format") {
            if (t.size() < 2 ||
                (t[1] != "ascii" && t[1] != "binary_little_endian" && t[1] != "binary_big_endian"))
                context.fail("PLY header: unknown format " + quoted(line));
            if (t.size() != 3 || !isPlyVersion(t[2]))
                context.fail("PLY header: malformed format line " + quoted(line) +
                             " (expected e.g. 'format ascii 1.0')");
            header.format = t[1] == "ascii"                  ? PlyFormat::Ascii
                            : t[1] == "binary_little_endian" ? PlyFormat::BinaryLittleEndian
                                                             : PlyFormat::BinaryBigEndian;
            hasFormat = true;
        } else if (t[0] == "comment") {
            if (t.size() >= 3 && t[1] == "TextureFile")
                header.textureFile = std::string(line.substr(line.find("TextureFile") + 12));
        } else if (t[0] == "element") {
            std::uint64_t count = 0;
            if (t.size() != 3 || !parseCount(t[2], count))
                context.fail("PLY header: malformed element line " + quoted(line));
            header.elements.push_back({std::string(t[1]), count, 0, {}});
        } else if (t[0] == "property") {
            if (header.elements.empty()) context.fail("PLY header: property before any element");
            PlyElement& e = header.elements.back();
            const bool binary = header.format != PlyFormat::Ascii;
            if (t.size() == 5 && t[1] == "list") {
                const PlyType countType = plyType(t[2]), itemType = plyType(t[3]);
                if (countType == PlyType::None || itemType == PlyType::None)
                    context.fail("PLY header: unknown list type in " + quoted(line));
                if (isFloatType(countType))
                    context.fail("PLY header: list count type is not an integer type in " +
                                 quoted(line));
                e.minBytes += binary ? plyTypeSize(countType) : 2;
                e.properties.push_back({std::string(t[4]), true, countType, itemType});
            } else if (t.size() == 3) {
                const PlyType type = plyType(t[1]);
                if (type == PlyType::None)
                    context.fail("PLY header: unknown property type in " + quoted(line));
                e.minBytes += binary ? plyTypeSize(type) : 2;
                e.properties.push_back({std::string(t[2]), false, PlyType::None, type});
            } else {
                context.fail("PLY header: malformed property line " + quoted(line));
            }
        } else {
            // obj_info and free text (Blender writes its name on a line of its own) are skipped,
            // but a keyword inside such a line means a mangled header ("junk element vertex
            // list ...", found by fuzz_mesh), not a comment.
            for (std::string_view word : t)
                if (word == "element" || word == "property" || word == "end_header")
                    context.fail("PLY header: line " + quoted(line) + " holds the keyword '" +
                                 std::string(word) + "' but does not start with it");
        }
    }
    if (!ended) context.fail("PLY header has no end_header");
    if (!hasFormat) context.fail("PLY header has no format line");
    header.dataOffset = reader.position();
    return header;
}

/// Every count the header claims must fit the bytes after it, before anything is sized by it.
void checkCounts(const ImportContext& context, const PlyHeader& header, std::uint64_t available) {
    std::uint64_t needed = 0;
    for (const PlyElement& e : header.elements) {
        // An element of no properties takes no bytes, yet its records are still counted through:
        // such a count may not exceed the bytes that follow either.
        if (e.count > available / std::max<std::uint64_t>(e.minBytes, 1))
            context.fail("PLY header claims " + std::to_string(e.count) + " " + e.name +
                         " elements, more than the " + std::to_string(available) +
                         " bytes after the header can hold");
        needed += e.count * e.minBytes;
    }
    if (needed > available)
        context.fail("PLY header claims elements needing at least " + std::to_string(needed) +
                     " bytes, but only " + std::to_string(available) + " follow the header");
}

/// Reads one value of @p type at @p at (binary, in the file's byte order).
template <bool BigEndian>
inline double readBinary(const std::uint8_t* at, PlyType type) {
    const auto load = [at]<typename T>(T) {
        T value;
        std::memcpy(&value, at, sizeof(T));
        if constexpr (BigEndian && sizeof(T) == 2) value = __builtin_bswap16(value);
        if constexpr (BigEndian && sizeof(T) == 4) value = __builtin_bswap32(value);
        if constexpr (BigEndian && sizeof(T) == 8) value = __builtin_bswap64(value);
        return value;
    };
    switch (type) {
        case PlyType::Int8:
            return static_cast<std::int8_t>(*at);
        case PlyType::UInt8:
            return *at;
        case PlyType::Int16:
            return static_cast<std::int16_t>(load(std::uint16_t{}));
        case PlyType::UInt16:
            return load(std::uint16_t{});
        case PlyType::Int32:
            return static_cast<std::int32_t>(load(std::uint32_t{}));
        case PlyType::UInt32:
            return load(std::uint32_t{});
        case PlyType::Float32:
            return std::bit_cast<float>(load(std::uint32_t{}));
        case PlyType::Float64:
            return std::bit_cast<double>(load(std::uint64_t{}));
        case PlyType::None:
            break;
    }
    return 0;
}

/// @p value as a float, beyond float's range as infinity (which the import then rejects as a
/// position), not undefined behaviour.
float narrow(double value) {
    if (std::abs(value) > std::numeric_limits<float>::max())
        return static_cast<float>(std::copysign(HUGE_VAL, value));
    return static_cast<float>(value);
}

/// The scale that maps a colour of @p type onto [0, 1].
float colorScale(PlyType type) {
    switch (type) {
        case PlyType::Float32:
        case PlyType::Float64:
            return 1.0f;
        case PlyType::Int16:
        case PlyType::UInt16:
            return 1.0f / 65535.0f;
        default:
            return 1.0f / 255.0f;
    }
}

/// The records of the PLY data section, decoded element by element into one Mesh.
class PlyReader {
public:
    PlyReader(ImportContext& context, const PlyHeader& header, const std::uint8_t* begin,
              const std::uint8_t* end)
        : context_(context), header_(header), at_(begin), end_(end) {}

    void read(Mesh& mesh) {
        const PlyElement* vertexElement = nullptr;
        const PlyElement* faceElement = nullptr;
        for (const PlyElement& e : header_.elements) {
            if (e.name == "vertex" && !vertexElement) vertexElement = &e;
            if (e.name == "face" && !faceElement) faceElement = &e;
        }
        if (!faceElement || faceElement->count == 0) context_.fail("has no faces (a point cloud?)");
        vertexCount_ = vertexElement ? vertexElement->count : 0;
        if (vertexCount_ > std::numeric_limits<std::uint32_t>::max())
            context_.fail("has more than 2^32 vertices");
        for (const PlyElement& e : header_.elements) {
            if (&e == vertexElement)
                readVertices(e, mesh);
            else if (&e == faceElement)
                readFaces(e, mesh);
            else
                skipElement(e);
        }
        if (pointsAndLines_)
            context_.warn("skipped " + std::to_string(pointsAndLines_) +
                          " face(s) with fewer than 3 corners (points and lines)");
        if (mesh.indices.empty()) context_.fail("has no faces (a point cloud?)");
    }

private:
    [[nodiscard]] bool binary() const { return header_.format != PlyFormat::Ascii; }
    [[nodiscard]] bool bigEndian() const { return header_.format == PlyFormat::BinaryBigEndian; }

    [[noreturn]] void truncated(const PlyElement& e, std::uint64_t record) const {
        context_.fail("is truncated: " + e.name + " " + std::to_string(record) + " of " +
                      std::to_string(e.count) + " ends past the end of the file");
    }

    /// ASCII: the next whitespace-separated token, records and lines notwithstanding.
    std::string_view nextToken() {
        while (at_ < end_ && isSpace(*at_)) ++at_;
        const std::uint8_t* start = at_;
        while (at_ < end_ && !isSpace(*at_)) ++at_;
        return {reinterpret_cast<const char*>(start), static_cast<std::size_t>(at_ - start)};
    }

    /// ASCII: the next token as one whole number (a token such as "3-1" is malformed, not two).
    double nextAsciiValue(const PlyElement& e, std::uint64_t record) {
        std::string_view token = nextToken();
        if (token.empty()) truncated(e, record);
        const std::string_view original = token;
        if (token.size() > 1 && token.front() == '+') token.remove_prefix(1);
        double value = 0;
        const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
        if (end != token.data() + token.size() ||
            (ec != std::errc() && ec != std::errc::result_out_of_range))
            context_.fail(e.name + " " + std::to_string(record) + ": malformed value '" +
                          std::string(original.substr(0, 32)) + "'");
        if (ec == std::errc::result_out_of_range)
            value = std::strtod(std::string(token).c_str(), nullptr);  // ±HUGE_VAL or tiny
        return value;
    }

    /// A list's item count, checked against the bytes left.
    std::uint64_t listCount(const PlyElement& e, const PlyProperty& property,
                            std::uint64_t record) {
        std::int64_t count = 0;
        if (binary()) {
            const int size = plyTypeSize(property.countType);
            if (end_ - at_ < size) truncated(e, record);
            const double value = bigEndian() ? readBinary<true>(at_, property.countType)
                                             : readBinary<false>(at_, property.countType);
            count = value < 0 ? -1 : static_cast<std::int64_t>(value);
            at_ += size;
        } else {
            const std::string_view token = nextToken();
            if (token.empty()) truncated(e, record);
            if (std::from_chars(token.data(), token.data() + token.size(), count).ptr !=
                token.data() + token.size())
                count = -1;
        }
        if (count < 0)
            context_.fail(e.name + " " + std::to_string(record) + ": malformed list count");
        const auto values = static_cast<std::uint64_t>(count);
        const auto left = static_cast<std::uint64_t>(end_ - at_);
        if (binary() ? values > left / plyTypeSize(property.type) : values > left / 2 + 1)
            context_.fail(e.name + " " + std::to_string(record) + ": a list of " +
                          std::to_string(values) + " values, more than the rest of the file holds");
        return values;
    }

    void skipValues(const PlyElement& e, const PlyProperty& property, std::uint64_t values,
                    std::uint64_t record) {
        if (binary()) {
            const std::uint64_t bytes = values * plyTypeSize(property.type);
            if (static_cast<std::uint64_t>(end_ - at_) < bytes) truncated(e, record);
            at_ += bytes;
        } else {
            for (std::uint64_t v = 0; v < values; ++v) nextAsciiValue(e, record);
        }
    }

    void skipElement(const PlyElement& e) {
        for (std::uint64_t record = 0; record < e.count; ++record)
            for (const PlyProperty& property : e.properties)
                skipValues(e, property, property.list ? listCount(e, property, record) : 1, record);
    }

    void readVertices(const PlyElement& e, Mesh& mesh) {
        // The plan: each property's slot, and (binary) its byte offset in a record.
        std::vector<VertexSlot> slots;
        std::array<PlyType, kVertexSlots> types{};
        std::array<std::uint32_t, kVertexSlots> offsets{};
        bool fixedSize = true;
        std::uint32_t recordBytes = 0;
        for (const PlyProperty& p : e.properties) {
            VertexSlot slot = p.list ? VertexSlot::Skip : vertexSlot(p.name);
            if (slot != VertexSlot::Skip && types[static_cast<int>(slot)] != PlyType::None)
                slot = VertexSlot::Skip;  // first one wins
            slots.push_back(slot);
            if (slot != VertexSlot::Skip) {
                types[static_cast<int>(slot)] = p.type;
                offsets[static_cast<int>(slot)] = recordBytes;
            }
            fixedSize &= !p.list;
            recordBytes += p.list ? 0 : plyTypeSize(p.type);
        }
        const auto has = [&](VertexSlot s) { return types[static_cast<int>(s)] != PlyType::None; };
        if (!has(VertexSlot::X) || !has(VertexSlot::Y) || !has(VertexSlot::Z))
            context_.fail("PLY vertex element lacks one of the properties x, y and z");
        const bool normals = has(VertexSlot::NX) && has(VertexSlot::NY) && has(VertexSlot::NZ);
        const bool colors = has(VertexSlot::Red) && has(VertexSlot::Green) && has(VertexSlot::Blue);
        const bool uvs = has(VertexSlot::U) && has(VertexSlot::V);
        const std::size_t n = e.count;
        mesh.positions.resize(n);
        if (normals) mesh.normals.resize(n);
        if (colors) mesh.colors.resize(n);
        if (uvs) mesh.uvs.assign(1, std::vector<Vec2f>(n));
        std::array<float, kVertexSlots> scales{};
        for (int s = 0; s < kVertexSlots; ++s) scales[s] = colorScale(types[s]);

        // One vertex from its values by slot.
        const auto store = [&](std::size_t v, const double* value) {
            const auto at = [&](VertexSlot s) { return value[static_cast<int>(s)]; };
            mesh.positions[v] = {narrow(at(VertexSlot::X)), narrow(at(VertexSlot::Y)),
                                 narrow(at(VertexSlot::Z))};
            if (normals)
                mesh.normals[v] = {narrow(at(VertexSlot::NX)), narrow(at(VertexSlot::NY)),
                                   narrow(at(VertexSlot::NZ))};
            if (uvs)
                mesh.uvs[0][v] = {
                    narrow(at(VertexSlot::U)),
                    1.0f -
                        narrow(at(VertexSlot::V))};  // PLY's v points up the image, libvox's down
            if (colors) {
                const auto channel = [&](VertexSlot s) {
                    return narrow(at(s)) * scales[static_cast<int>(s)];
                };
                // PLY colours are display-referred (sRGB-encoded), libvox's are linear.
                mesh.colors[v] = {srgbToLinear(channel(VertexSlot::Red)),
                                  srgbToLinear(channel(VertexSlot::Green)),
                                  srgbToLinear(channel(VertexSlot::Blue)),
                                  has(VertexSlot::Alpha) ? channel(VertexSlot::Alpha) : 1.0f};
            }
        };

        if (binary() && fixedSize) {
            // Fixed-size records: the file's bytes are checked once, and the records decode in
            // parallel (each vertex writes only its own entries).
            if (static_cast<std::uint64_t>(end_ - at_) < n * recordBytes)
                truncated(e, (end_ - at_) / std::max<std::uint32_t>(recordBytes, 1));
            const std::uint8_t* base = at_;
            const auto decode = [&]<bool BigEndian>(std::size_t first, std::size_t last) {
                double value[kVertexSlots] = {};
                for (std::size_t v = first; v < last; ++v) {
                    const std::uint8_t* record = base + v * recordBytes;
                    for (int s = 0; s < kVertexSlots; ++s)
                        if (types[s] != PlyType::None)
                            value[s] = readBinary<BigEndian>(record + offsets[s], types[s]);
                    store(v, value);
                }
            };
            tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1 << 14),
                              [&](const tbb::blocked_range<std::size_t>& r) {
                                  if (bigEndian())
                                      decode.template operator()<true>(r.begin(), r.end());
                                  else
                                      decode.template operator()<false>(r.begin(), r.end());
                              });
            at_ += n * recordBytes;
            return;
        }
        double value[kVertexSlots + 1] = {};  // the last entry takes the skipped properties
        for (std::size_t v = 0; v < n; ++v) {
            for (std::size_t i = 0; i < e.properties.size(); ++i) {
                const PlyProperty& p = e.properties[i];
                if (p.list) {
                    skipValues(e, p, listCount(e, p, v), v);
                    continue;
                }
                double& out = value[static_cast<int>(slots[i])];
                if (binary()) {
                    const int size = plyTypeSize(p.type);
                    if (end_ - at_ < size) truncated(e, v);
                    out = bigEndian() ? readBinary<true>(at_, p.type)
                                      : readBinary<false>(at_, p.type);
                    at_ += size;
                } else {
                    out = nextAsciiValue(e, v);
                }
            }
            store(v, value);
        }
    }

    void readFaces(const PlyElement& e, Mesh& mesh) {
        std::size_t indicesAt = e.properties.size();
        for (std::size_t i = 0; i < e.properties.size(); ++i)
            if (e.properties[i].list && (e.properties[i].name == "vertex_indices" ||
                                         e.properties[i].name == "vertex_index")) {
                indicesAt = i;
                break;
            }
        if (indicesAt == e.properties.size())
            context_.fail("PLY face element has no 'list … vertex_indices' property");
        const PlyProperty& indices = e.properties[indicesAt];
        if (binary() && e.properties.size() == 1 && tryTriangleRecords(e, indices, mesh)) return;
        mesh.indices.reserve(3 * e.count);
        for (std::uint64_t f = 0; f < e.count; ++f)
            for (std::size_t i = 0; i < e.properties.size(); ++i) {
                const PlyProperty& p = e.properties[i];
                const std::uint64_t values = p.list ? listCount(e, p, f) : 1;
                if (i != indicesAt) {
                    skipValues(e, p, values, f);
                    continue;
                }
                if (binary() &&
                    static_cast<std::uint64_t>(end_ - at_) < values * plyTypeSize(p.type))
                    truncated(e, f);
                // Fan: (c0, c1, c2), (c0, c2, c3), …
                std::uint32_t first = 0, previous = 0;
                for (std::uint64_t k = 0; k < values; ++k) {
                    const std::uint32_t corner = vertexIndex(e, f, nextIndexValue(e, p, f));
                    if (k == 0) first = corner;
                    if (k >= 2) mesh.indices.insert(mesh.indices.end(), {first, previous, corner});
                    previous = corner;
                }
                if (values < 3) ++pointsAndLines_;
            }
    }

    double nextIndexValue(const PlyElement& e, const PlyProperty& p, std::uint64_t record) {
        if (!binary()) return nextAsciiValue(e, record);
        const double value =
            bigEndian() ? readBinary<true>(at_, p.type) : readBinary<false>(at_, p.type);
        at_ += plyTypeSize(p.type);
        return value;
    }

    std::uint32_t vertexIndex(const PlyElement& e, std::uint64_t record, double value) const {
        if (!(value >= 0 && value < static_cast<double>(vertexCount_)) ||
            value != std::floor(value)) {
            char text[32];
            std::snprintf(text, sizeof text, "%.17g", value);
            context_.fail(e.name + " " + std::to_string(record) + ": vertex index " + text +
                          " out of range (" + std::to_string(vertexCount_) + " vertices)");
        }
        return static_cast<std::uint32_t>(value);
    }

    /// Binary faces of only a triangle list each (what most writers emit): records of one size,
    /// decoded in parallel once a first pass has seen every count be 3. Returns false, having
    /// consumed nothing, where a count is not 3 or the records do not fit.
    bool tryTriangleRecords(const PlyElement& e, const PlyProperty& indices, Mesh& mesh) {
        const std::uint64_t countBytes = plyTypeSize(indices.countType),
                            indexBytes = plyTypeSize(indices.type);
        const std::uint64_t recordBytes = countBytes + 3 * indexBytes;
        const std::size_t n = e.count;
        if (static_cast<std::uint64_t>(end_ - at_) / recordBytes < n) return false;
        const std::uint8_t* base = at_;
        const bool big = bigEndian();
        std::atomic<bool> allTriangles{true};
        tbb::parallel_for(
            tbb::blocked_range<std::size_t>(0, n, 1 << 15),
            [&](const tbb::blocked_range<std::size_t>& r) {
                for (std::size_t f = r.begin();
                     f != r.end() && allTriangles.load(std::memory_order_relaxed); ++f) {
                    const std::uint8_t* record = base + f * recordBytes;
                    const double count = big ? readBinary<true>(record, indices.countType)
                                             : readBinary<false>(record, indices.countType);
                    if (count != 3) allTriangles.store(false, std::memory_order_relaxed);
                }
            });
        if (!allTriangles) return false;
        mesh.indices.resize(3 * n);
        // The first bad index by record order, whatever the threads' order, for a deterministic
        // message.
        std::atomic<std::uint64_t> firstBad{n};
        tbb::parallel_for(
            tbb::blocked_range<std::size_t>(0, n, 1 << 15),
            [&](const tbb::blocked_range<std::size_t>& r) {
                const auto decode = [&]<bool BigEndian>() {
                    for (std::size_t f = r.begin(); f != r.end(); ++f) {
                        const std::uint8_t* record = base + f * recordBytes + countBytes;
                        for (int k = 0; k < 3; ++k) {
                            const double value =
                                readBinary<BigEndian>(record + k * indexBytes, indices.type);
                            if (!(value >= 0 && value < static_cast<double>(vertexCount_)) ||
                                value != std::floor(value)) {
                                for (std::uint64_t seen = firstBad.load();
                                     f < seen && !firstBad.compare_exchange_weak(seen, f);) {}
                                return;
                            }
                            mesh.indices[3 * f + k] = static_cast<std::uint32_t>(value);
                        }
                    }
                };
                if (big)
                    decode.template operator()<true>();
                else
                    decode.template operator()<false>();
            });
        if (firstBad.load() < n) {
            // Decode that record again, serially, for its message.
            at_ = base + firstBad.load() * recordBytes + countBytes;
            for (int k = 0; k < 3; ++k)
                vertexIndex(e, firstBad.load(), nextIndexValue(e, indices, firstBad.load()));
        }
        at_ = base + n * recordBytes;
        return true;
    }

    ImportContext& context_;
    const PlyHeader& header_;
    const std::uint8_t* at_;
    const std::uint8_t* const end_;
    std::uint64_t vertexCount_ = 0;
    std::size_t pointsAndLines_ = 0;
};

}  // namespace

void importPly(ImportContext& context, const std::vector<std::uint8_t>& bytes) {
    Timings::Scope timer(context.options().timings, "import.parse");
    const std::string_view text(reinterpret_cast<const char*>(bytes.data()), bytes.size());
    const PlyHeader header = readHeader(context, text);
    checkCounts(context, header, bytes.size() - header.dataOffset);

    Mesh mesh;
    mesh.name = context.input().stem().string();
    mesh.dynamic = context.isDynamicName(mesh.name);
    PlyReader(context, header, bytes.data() + header.dataOffset, bytes.data() + bytes.size())
        .read(mesh);

    if (!header.textureFile.empty() && !mesh.uvs.empty()) {
        Material material;
        material.name = header.textureFile;
        const std::filesystem::path image = context.input().parent_path() / header.textureFile;
        material.baseColorTexture.texture = context.texture(
            "file:" + image.string(), ColorSpace::SRGB, [&]() -> ImportContext::EncodedImage {
                return {context.readFile(image), image, "", ""};
            });
        context.scene().materials.push_back(material);
        mesh.material = static_cast<std::uint32_t>(context.scene().materials.size() - 1);
    } else {
        mesh.material = context.defaultMaterial();
    }
    context.scene().meshes.push_back(std::move(mesh));
}

}  // namespace vox::detail
