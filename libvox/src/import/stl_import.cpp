// STL, binary and ASCII. libvox reads STL itself: OpenMesh's reader welds vertices through a
// std::map whose comparison is no strict weak order once a coordinate is NaN (undefined
// behaviour; in practice NaN triangles vanish as "degenerate") and merges vertices closer than
// FLT_MIN (a tiny model collapses to a point). STL is faceted: every triangle gets its own three
// corners and flat normals from the geometry; the stored facet normals are ignored.
#include "importers.h"
#include "text_tokens.h"

#include <vox/util/timings.h>

#include <cstring>
#include <string>
#include <string_view>

namespace vox::detail {
namespace {

/// One triangle per facet of 50 bytes after the 80-byte header and the 32-bit count.
void readBinary(Mesh& mesh, const std::vector<std::uint8_t>& bytes, std::uint32_t triangles) {
    mesh.positions.resize(3 * std::size_t{triangles});  // the file's size is 84 + 50 × triangles
    for (std::size_t t = 0; t < triangles; ++t) {
        const std::uint8_t* facet = bytes.data() + 84 + 50 * t + 12;  // past the facet normal
        for (std::size_t k = 0; k < 3; ++k)
            std::memcpy(&mesh.positions[3 * t + k], facet + 12 * k, 12);
    }
}

/// "solid NAME" … "facet normal … outer loop vertex x y z (×3) endloop endfacet" … "endsolid",
/// any number of solids. Tokens are read in order; names after solid/endsolid are skipped.
void readAscii(const ImportContext& context, Mesh& mesh, const std::vector<std::uint8_t>& bytes) {
    std::string_view text(reinterpret_cast<const char*>(bytes.data()), bytes.size());
    if (text.starts_with("\xEF\xBB\xBF")) text.remove_prefix(3);
    std::size_t line = 1, facetVertices = 0, facetLine = 0;
    bool inFacet = false;
    std::string_view rest = text;
    std::size_t counted = 0;  // bytes of text whose newlines are in line
    // The line of @p token; tokens come in order, so the text is scanned once.
    const auto lineAt = [&](std::string_view token) {
        const std::size_t at = static_cast<std::size_t>(token.data() - text.data());
        for (; counted < at; ++counted) line += text[counted] == '\n';
        return line;
    };
    const auto skipLine = [&] {
        const std::size_t end = rest.find('\n');
        rest.remove_prefix(end == std::string_view::npos ? rest.size() : end);
    };
    for (std::string_view token = nextToken(rest); !token.empty(); token = nextToken(rest)) {
        if (token == "solid" || token == "endsolid") {
            if (inFacet)
                context.fail("line " + std::to_string(lineAt(token)) + ": '" + std::string(token) +
                             "' inside a facet");
            skipLine();  // the solid's name, if any
        } else if (token == "facet") {
            if (inFacet)
                context.fail("line " + std::to_string(lineAt(token)) + ": facet inside a facet");
            inFacet = true;
            facetVertices = 0;
            facetLine = lineAt(token);
            skipLine();  // "normal nx ny nz": ignored, flat normals come from the geometry
        } else if (token == "vertex") {
            const std::size_t at = lineAt(token);
            if (!inFacet) context.fail("line " + std::to_string(at) + ": vertex outside a facet");
            Vec3f p;
            for (float* c : {&p.x, &p.y, &p.z})
                if (!parseFloat(nextToken(rest), *c))
                    context.fail("line " + std::to_string(at) + ": vertex needs three numbers");
            if (++facetVertices > 3)
                context.fail("line " + std::to_string(at) +
                             ": facet with more than three vertices");
            mesh.positions.push_back(p);
        } else if (token == "endfacet") {
            if (!inFacet)
                context.fail("line " + std::to_string(lineAt(token)) + ": endfacet without facet");
            if (facetVertices != 3)
                context.fail("line " + std::to_string(facetLine) + ": facet with " +
                             std::to_string(facetVertices) + " vertices, not 3");
            inFacet = false;
        } else if (token != "outer" && token != "loop" && token != "endloop") {
            context.fail("line " + std::to_string(lineAt(token)) + ": unexpected '" +
                         std::string(token.substr(0, 32)) + "'");
        }
    }
    if (inFacet)
        context.fail("line " + std::to_string(facetLine) + ": facet without endfacet (truncated?)");
}

}  // namespace

void importStl(ImportContext& context, const std::vector<std::uint8_t>& bytes) {
    Timings::Scope timer(context.options().timings, "import.parse");
    Mesh mesh;
    mesh.name = context.input().stem().string();
    mesh.dynamic = context.isDynamicName(mesh.name);
    mesh.material = context.defaultMaterial();
    std::uint32_t triangles = 0;
    if (bytes.size() >= 84) std::memcpy(&triangles, bytes.data() + 80, 4);
    // Binary when the count matches the size, even if the header starts with "solid" (many do).
    if (bytes.size() >= 84 && bytes.size() == 84 + 50ull * triangles)
        readBinary(mesh, bytes, triangles);
    else
        readAscii(context, mesh, bytes);
    if (mesh.positions.empty()) context.fail("has no faces (a point cloud?)");
    mesh.indices.resize(mesh.positions.size());
    for (std::uint32_t i = 0; i < mesh.indices.size(); ++i) mesh.indices[i] = i;
    context.scene().meshes.push_back(std::move(mesh));
}

}  // namespace vox::detail
