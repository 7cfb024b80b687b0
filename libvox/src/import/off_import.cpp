// ASCII OFF (Geomview's object file format): "[ST][C][N]OFF", the vertex, face and edge counts,
// one vertex per line (x y z, then a normal with N, a colour with C, texture coordinates with ST),
// one face per line (n, n vertex indices, an optional face colour); '#' starts a comment anywhere.
// libvox reads OFF itself: OpenMesh's reader reads each face's corner count with operator>>, so
// a negative or huge count (or one read from a mangled vertex line) made it push billions of
// corners (found by fuzz_mesh: 2 GB from a 1.5 KB file); it also knows no comments.
#include "importers.h"
#include "text_tokens.h"

#include <vox/texture.h>
#include <vox/util/timings.h>

#include <algorithm>
#include <string>
#include <string_view>

namespace vox::detail {
namespace {

/// Lines without their comments, skipping those left empty, with 1-based line numbers.
class OffLines {
public:
    explicit OffLines(std::string_view text) : text_(text) {}
    bool next(std::string_view& line, std::size_t& number) {
        while (pos_ < text_.size()) {
            std::size_t end = text_.find('\n', pos_);
            if (end == std::string_view::npos) end = text_.size();
            line = text_.substr(pos_, end - pos_);
            pos_ = end + 1;
            number = ++lineNumber_;
            line = trim(line.substr(0, line.find('#')));
            if (!line.empty()) return true;
        }
        return false;
    }
    /// Bytes consumed so far.
    [[nodiscard]] std::size_t position() const { return std::min(pos_, text_.size()); }

private:
    std::string_view text_;
    std::size_t pos_ = 0, lineNumber_ = 0;
};

bool parseCount(std::string_view token, std::uint64_t& value) {
    long long v = 0;
    if (!parseInt(token, v) || v < 0) return false;
    value = static_cast<std::uint64_t>(v);
    return true;
}

}  // namespace

void importOff(ImportContext& context, const std::vector<std::uint8_t>& bytes) {
    Timings::Scope timer(context.options().timings, "import.parse");
    std::string_view text(reinterpret_cast<const char*>(bytes.data()), bytes.size());
    if (text.starts_with("\xEF\xBB\xBF")) text.remove_prefix(3);
    OffLines lines(text);
    std::string_view line;
    std::size_t number = 0;
    const auto fail = [&](const std::string& problem) {
        context.fail("line " + std::to_string(number) + ": " + problem);
    };

    if (!lines.next(line, number)) context.fail("is empty");
    std::string_view rest = line;
    const std::string_view keyword = nextToken(rest);
    const std::size_t offAt = keyword.rfind("OFF");
    const std::string_view prefix =
        offAt == std::string_view::npos ? keyword : keyword.substr(0, offAt);
    if (offAt == std::string_view::npos || offAt + 3 != keyword.size() ||
        prefix.find_first_not_of("STCN4n") != std::string_view::npos)
        context.fail("is not an OFF file (no OFF keyword) despite its extension");
    if (prefix.find_first_of("4n") != std::string_view::npos)
        context.fail("OFF with 4D or n-dimensional vertices is not supported");
    const bool hasNormals = prefix.find('N') != std::string_view::npos,
               hasColors = prefix.find('C') != std::string_view::npos,
               hasUvs = prefix.find("ST") != std::string_view::npos;
    if (trim(rest) == "BINARY")
        context.fail("binary OFF is not supported (libvox reads ASCII OFF)");
    if (trim(rest).empty() && !lines.next(rest, number))
        context.fail("OFF header: no vertex/face counts");
    std::uint64_t vertices = 0, faces = 0, edges = 0;
    const std::string_view v = nextToken(rest), f = nextToken(rest), e = nextToken(rest);
    if (!parseCount(v, vertices) || !parseCount(f, faces) ||
        (!e.empty() && !parseCount(e, edges)) || !trim(rest).empty())
        fail("OFF header: malformed vertex/face counts");
    // Every vertex and face takes a line of at least 6 and 8 bytes: bound the counts by the file.
    const std::uint64_t available = text.size() - lines.position();
    if (vertices > available / 6 || faces > available / 8 || 6 * vertices + 8 * faces > available)
        context.fail("OFF header claims " + std::to_string(vertices) + " vertices and " +
                     std::to_string(faces) + " faces, more than the " + std::to_string(available) +
                     " bytes that follow can hold");

    Mesh mesh;
    mesh.name = context.input().stem().string();
    mesh.dynamic = context.isDynamicName(mesh.name);
    mesh.material = context.defaultMaterial();
    for (std::uint64_t i = 0; i < vertices; ++i) {
        if (!lines.next(line, number))
            context.fail("is truncated: " + std::to_string(i) + " of " + std::to_string(vertices) +
                         " vertices read");
        float values[12] = {};
        std::size_t count = 0;
        bool fractional = false;  // colours: "0.5" means [0, 1], "128" means [0, 255]
        for (std::string_view token = nextToken(line); !token.empty(); token = nextToken(line)) {
            if (count == std::size(values) || !parseFloat(token, values[count]))
                fail("malformed vertex '" + std::string(token.substr(0, 32)) + "'");
            if (count >= 3 + (hasNormals ? 3 : 0))
                fractional |= token.find_first_of(".eE") != std::string_view::npos;
            ++count;
        }
        const std::size_t colorAt = 3 + (hasNormals ? 3 : 0);
        const std::size_t colors = hasColors ? count - colorAt - (hasUvs ? 2 : 0) : 0;
        if (count < colorAt + (hasUvs ? 2 : 0) || (hasColors && colors != 3 && colors != 4))
            fail("vertex has " + std::to_string(count) + " numbers, not what '" +
                 std::string(keyword) + "' needs");
        mesh.positions.push_back({values[0], values[1], values[2]});
        if (hasNormals) mesh.normals.push_back({values[3], values[4], values[5]});
        if (hasColors) {
            const float scale = fractional ? 1.0f : 1.0f / 255.0f;
            const float* c = values + colorAt;
            // OFF colours are display-referred (sRGB-encoded), libvox's are linear.
            mesh.colors.push_back({srgbToLinear(c[0] * scale), srgbToLinear(c[1] * scale),
                                   srgbToLinear(c[2] * scale), colors == 4 ? c[3] * scale : 1.0f});
        }
    }
    std::size_t pointsAndLines = 0;
    std::vector<std::uint32_t> corners;
    for (std::uint64_t i = 0; i < faces; ++i) {
        if (!lines.next(line, number))
            context.fail("is truncated: " + std::to_string(i) + " of " + std::to_string(faces) +
                         " faces read");
        std::uint64_t n = 0;
        if (!parseCount(nextToken(line), n)) fail("malformed face: no corner count");
        corners.clear();
        for (std::uint64_t k = 0; k < n;
             ++k) {  // each corner a token of this line: n is bounded by its length
            const std::string_view token = nextToken(line);
            std::uint64_t index = 0;
            if (token.empty()) fail("face has fewer than its " + std::to_string(n) + " corners");
            if (!parseCount(token, index))
                fail("malformed vertex index '" + std::string(token.substr(0, 32)) + "'");
            if (index >= vertices)
                fail("vertex index " + std::to_string(index) + " out of range (" +
                     std::to_string(vertices) + " vertices)");
            corners.push_back(static_cast<std::uint32_t>(index));
        }
        // The rest of the line is the face's colour, which libvox does not use.
        if (n < 3) {
            ++pointsAndLines;
            continue;
        }
        for (std::size_t k = 1; k + 1 < n; ++k)
            mesh.indices.insert(mesh.indices.end(), {corners[0], corners[k], corners[k + 1]});
    }
    if (pointsAndLines)
        context.warn("skipped " + std::to_string(pointsAndLines) +
                     " face(s) with fewer than 3 corners (points and lines)");
    if (mesh.indices.empty()) context.fail("has no faces (a point cloud?)");
    context.scene().meshes.push_back(std::move(mesh));
}

}  // namespace vox::detail
