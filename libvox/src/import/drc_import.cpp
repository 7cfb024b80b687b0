// Raw Draco (.drc) import: one mesh with Draco's generic position/normal/UV/colour attributes.
#include "draco_decode.h"
#include "importers.h"

#include <vox/util/timings.h>

#include <draco/attributes/geometry_attribute.h>

namespace vox::detail {

void importDrc(ImportContext& context, const std::vector<std::uint8_t>& bytes) {
    Timings::Scope timer(context.options().timings, "import.parse");
    const DracoMesh decoded(bytes, context.input(), "");
    const std::size_t points = decoded.pointCount();
    const draco::PointAttribute* position =
        decoded.attributeByType(draco::GeometryAttribute::POSITION);
    if (!position) context.fail("Draco mesh has no position attribute");

    Mesh mesh;
    mesh.name = context.input().stem().string();
    mesh.dynamic = context.isDynamicName(mesh.name);
    mesh.material = context.defaultMaterial();
    mesh.indices = decoded.indices();
    const std::vector<float> p = decoded.floats(*position, 3);
    mesh.positions.resize(points);
    for (std::size_t i = 0; i < points; ++i)
        mesh.positions[i] = {p[3 * i], p[3 * i + 1], p[3 * i + 2]};
    if (const draco::PointAttribute* normal =
            decoded.attributeByType(draco::GeometryAttribute::NORMAL)) {
        const std::vector<float> n = decoded.floats(*normal, 3);
        mesh.normals.resize(points);
        for (std::size_t i = 0; i < points; ++i)
            mesh.normals[i] = {n[3 * i], n[3 * i + 1], n[3 * i + 2]};
    }
    if (const draco::PointAttribute* uv =
            decoded.attributeByType(draco::GeometryAttribute::TEX_COORD)) {
        const std::vector<float> t = decoded.floats(*uv, 2);
        mesh.uvs.emplace_back(points);
        // Raw .drc files come from OBJ/PLY, whose v points up the image; libvox's points down.
        for (std::size_t i = 0; i < points; ++i) mesh.uvs[0][i] = {t[2 * i], 1.0f - t[2 * i + 1]};
    }
    if (const draco::PointAttribute* color =
            decoded.attributeByType(draco::GeometryAttribute::COLOR)) {
        const std::vector<float> c = decoded.floats(*color, 4);
        mesh.colors.resize(points);
        // Display-referred (sRGB-encoded) like the PLY/OBJ colours .drc files are made from.
        for (std::size_t i = 0; i < points; ++i)
            mesh.colors[i] = {srgbToLinear(c[4 * i]), srgbToLinear(c[4 * i + 1]),
                              srgbToLinear(c[4 * i + 2]), c[4 * i + 3]};
    }
    context.scene().meshes.push_back(std::move(mesh));
}

}  // namespace vox::detail
