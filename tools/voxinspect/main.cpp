// voxinspect: looks inside the files libvox reads and writes. `scene` shows what the importer
// makes of a scene file; info, validate and render work on .esvo and .rvol files (by extension),
// dump on .esvo files, sample and slices on .rvol files.
#include "../common/reports.h"
#include "../common/tool_main.h"
#include "esvo_commands.h"
#include "rvol_commands.h"

#include <vox/base/error.h>
#include <vox/import.h>
#include <vox/version.h>

#include <cstdio>
#include <iostream>

namespace {

struct SceneCommand {
    std::string file;
    bool json = false;
    bool strict = false;
    std::vector<std::string> dynamicNames;
};

const char* alphaModeName(vox::AlphaMode mode) {
    switch (mode) {
        case vox::AlphaMode::Opaque:
            return "opaque";
        case vox::AlphaMode::Mask:
            return "mask";
        case vox::AlphaMode::Blend:
            return "blend";
    }
    return "?";
}

void inspectScene(const SceneCommand& command) {
    vox::ImportOptions options;
    options.strict = command.strict;
    options.dynamicNames = command.dynamicNames;
    const vox::Scene scene = vox::importScene(command.file, options);
    if (command.json) {
        nlohmann::json report = vox::tools::sceneReport(scene);
        nlohmann::json meshes = nlohmann::json::array();
        for (const vox::Mesh& mesh : scene.meshes)
            meshes.push_back({{"name", mesh.name},
                              {"triangles", mesh.triangleCount()},
                              {"vertices", mesh.positions.size()},
                              {"material", mesh.material},
                              {"dynamic", mesh.dynamic},
                              {"uv_sets", mesh.uvs.size()},
                              {"vertex_colors", !mesh.colors.empty()}});
        report["mesh_list"] = meshes;
        std::cout << report.dump(2) << "\n";
        return;
    }
    const vox::Bounds3f b = scene.bounds();
    std::printf(
        "%s\n  triangles  %zu (%zu dynamic, %zu degenerate dropped)\n  bounds     [%g, %g, %g] - "
        "[%g, %g, %g]\n",
        command.file.c_str(), scene.triangleCount(), scene.dynamicTriangleCount(),
        scene.degenerateTrianglesDropped, b.min.x, b.min.y, b.min.z, b.max.x, b.max.y, b.max.z);
    std::printf("  meshes     %zu\n", scene.meshes.size());
    for (const vox::Mesh& mesh : scene.meshes)
        std::printf("    %-28s %8zu triangles  material %u%s%s\n", mesh.name.c_str(),
                    mesh.triangleCount(), mesh.material, mesh.dynamic ? "  dynamic" : "",
                    mesh.colors.empty() ? "" : "  vertex colours");
    std::printf("  materials  %zu\n", scene.materials.size());
    for (std::size_t i = 0; i < scene.materials.size(); ++i) {
        const vox::Material& m = scene.materials[i];
        std::printf(
            "    %2zu %-25s base (%.3g %.3g %.3g %.3g)%s emission (%.3g %.3g %.3g)x%.3g%s %s\n", i,
            m.name.c_str(), m.baseColorFactor.x, m.baseColorFactor.y, m.baseColorFactor.z,
            m.baseColorFactor.w, m.baseColorTexture.valid() ? " x texture" : "", m.emissiveFactor.x,
            m.emissiveFactor.y, m.emissiveFactor.z, m.emissiveStrength,
            m.emissiveTexture.valid() ? " x texture" : "", alphaModeName(m.alphaMode));
    }
    std::printf("  textures   %zu\n", scene.textures.size());
    for (const vox::Texture& t : scene.textures)
        std::printf("    %-28s %dx%d, %d mip levels\n", t.name().c_str(), t.width(), t.height(),
                    t.levelCount());
    std::printf("  lights     %zu\n", scene.lights.size());
    for (const vox::Light& l : scene.lights)
        std::printf("    %-28s %s intensity %g colour (%.3g %.3g %.3g) at (%g %g %g)%s\n",
                    l.name.c_str(), vox::tools::lightTypeName(l.type), l.intensity, l.color.x,
                    l.color.y, l.color.z, l.position.x, l.position.y, l.position.z,
                    l.dynamic ? "  dynamic" : "");
}

}  // namespace

int main(int argc, char** argv) {
    vox::tools::CommonOptions common;
    CLI::App app{"Inspects the files libvox reads and writes.", "voxinspect"};
    app.set_version_flag("--version", std::string("voxinspect (libvox) ") + LIBVOX_VERSION_STRING);
    app.require_subcommand(1);
    app.fallthrough();
    vox::tools::addCommonOptions(app, common);

    SceneCommand scene;
    CLI::App* sceneApp = app.add_subcommand("scene", "Show what libvox imports from a scene file");
    sceneApp->add_option("file", scene.file, "Scene file")->required();
    sceneApp->add_flag("--json", scene.json, "Print JSON");
    sceneApp->add_flag("--strict", scene.strict, "Treat repaired input as an error");
    sceneApp->add_option("--dynamic", scene.dynamicNames,
                         "Mark a node, object or group dynamic; repeatable");

    vox::tools::EsvoCommands esvo;
    esvo.add(app);
    vox::tools::RvolCommands rvol;
    rvol.add(app, esvo);

    return vox::tools::runTool("voxinspect", app, argc, argv, common, [&] {
        if (sceneApp->parsed())
            inspectScene(scene);
        else if (!rvol.run())
            esvo.run();
    });
}
