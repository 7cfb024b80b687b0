// voxelize and voxinspect as a content build meets them: exit codes, one-line errors, no
// output on failure, --stats and --depfile.
#include <vox/formats/atomic_file.h>

#include "assimp_models.h"
#include "cornell_box.h"
#include "test_support.h"

#include <nlohmann/json.hpp>

using vox::test::ProcessResult;
using vox::test::runProcess;
using vox::test::ScratchDir;

namespace {

ProcessResult voxelize(const std::vector<std::string>& args) { return runProcess(vox::test::voxelizePath(), args); }
ProcessResult voxinspect(const std::vector<std::string>& args) { return runProcess(vox::test::voxinspectPath(), args); }

/// A failed run: the exit code, exactly one stderr line in the documented form, naming @p mention.
void expectOneLineError(const ProcessResult& r, int code, const std::string& mention, const std::string& program = "voxelize") {
    EXPECT_EQ(r.exitCode, code) << r.err;
    const auto lines = r.errLines();
    ASSERT_EQ(lines.size(), 1u) << r.err;
    EXPECT_EQ(lines[0].rfind(program + ": error: ", 0), 0u) << lines[0];
    EXPECT_NE(lines[0].find(mention), std::string::npos) << lines[0];
}

}  // namespace

TEST(Tools, HelpAndVersion) {
    for (const auto& tool : {vox::test::voxelizePath(), vox::test::voxinspectPath()}) {
        const ProcessResult help = runProcess(tool, {"--help"});
        EXPECT_EQ(help.exitCode, 0);
        EXPECT_NE(help.out.find("--threads"), std::string::npos);
        const ProcessResult version = runProcess(tool, {"--version"});
        EXPECT_EQ(version.exitCode, 0);
        EXPECT_NE(version.out.find("(libvox) 0.1.0"), std::string::npos) << version.out;
    }
}

TEST(Tools, UsageErrorsExitWithOneNotCli11Codes) {
    expectOneLineError(voxelize({}), 1, "input is required");
    expectOneLineError(voxelize({"a.gltf", "--no-such-option"}), 1, "--no-such-option");
    expectOneLineError(voxelize({"a.gltf", "--threads", "0"}), 1, "--threads");
    expectOneLineError(voxinspect({}), 1, "subcommand", "voxinspect");
    ScratchDir dir;
    const auto scene = vox::scenes::writeCornellBox(dir.path());
    expectOneLineError(voxelize({scene.string(), "--depfile", (dir / "x.d").string()}), 1, "--depfile needs");
}

TEST(Tools, BadInputFailsCleanlyWithNoOutputLeftBehind) {
    ScratchDir dir;
    const auto models = vox::test::assimpModels();
    vox::test::writeText(dir / "truncated.gltf", "{\"asset\": {\"version\": \"2.0\"");
    vox::test::writeText(dir / "text.glb", "this is not binary glTF");
    struct Case {
        std::filesystem::path input;
        int code;
        std::string mention;
    };
    const std::vector<Case> cases = {
        {dir / "missing.gltf", 2, "missing.gltf"},
        {dir / "truncated.gltf", 3, "malformed JSON"},
        {dir / "text.glb", 3, "not a GLB"},
        {models / "glTF2/wrongTypes/badString.gltf", 3, "expected a string"},
        {models / "glTF2/IndexOutOfRange/IndexOutOfRange.gltf", 3, "out of range"},
        {models / "glTF2/BoxWithInfinites-glTF-Binary/BoxWithInfinites.glb", 3, "non-finite"},
        {models / "glTF2/MissingBin/BoxTextured.gltf", 2, "BoxTextured0.bin"},
        {models / "glTF2/RecursiveNodes/RecursiveNodes.gltf", 3, "cycle"},
        {models / "glTF2/TestNoRootNode/SceneWithoutNodes.gltf", 3, "no triangles"},
        {models / "glTF2/IncorrectVertexArrays/Cube.gltf", 3, "exceed"},
        {models / "OFF/invalid.off", 3, "invalid.off"},
        {models / "invalid/OutOfMemory.off", 3, "OutOfMemory.off"},
        {models / "invalid/empty.ply", 3, "is empty"},
        {models / "invalid/malformed.obj", 3, "out of range"},
        {models / "invalid/empty.x", 3, "unsupported file type"},
    };
    for (const Case& c : cases) {
        SCOPED_TRACE(c.input.string());
        const ProcessResult r = voxelize({c.input.string(), "--stats", (dir / "out.json").string(), "--depfile", (dir / "out.d").string()});
        expectOneLineError(r, c.code, c.mention);
        EXPECT_LT(r.exitCode, 100) << "no signal, no CLI11 code";
        EXPECT_FALSE(std::filesystem::exists(dir / "out.json"));
        EXPECT_FALSE(std::filesystem::exists(dir / "out.d"));
        for (const std::string& name : dir.files()) EXPECT_FALSE(vox::AtomicFile::isTemporaryName(name)) << name;
    }
}

TEST(Tools, EveryBrokenAssimpModelFailsCleanly) {
    ScratchDir dir;
    int broken = 0;
    for (const vox::test::ModelCase& model : vox::test::kAssimpModels) {
        if (model.error == vox::ExitCode::Ok) continue;
        ++broken;
        const auto input = vox::test::assimpModels() / model.path;
        SCOPED_TRACE(input.string());
        const ProcessResult r = voxelize({input.string(), "--stats", (dir / "out.json").string(), "--depfile", (dir / "out.d").string()});
        expectOneLineError(r, static_cast<int>(model.error), input.string() + ": ");
        EXPECT_EQ(dir.files(), std::vector<std::string>{}) << "no output, no temporary";
    }
    EXPECT_GE(broken, 30);  // the table's broken files, so the loop cannot silently test nothing
}

TEST(Tools, StatsReportTheSceneWithStableKeys) {
    ScratchDir dir;
    const auto scene = vox::scenes::writeCornellBox(dir.path());
    const ProcessResult r = voxelize({scene.string(), "--stats", (dir / "stats.json").string(), "--threads", "1"});
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(r.err.empty()) << "a clean import prints nothing by default: " << r.err;
    const auto stats = nlohmann::json::parse(vox::test::readText(dir / "stats.json"));
    for (const char* key : {"inputs", "triangles", "materials", "lights", "bounds", "timings_ms", "peak_rss_bytes"})
        EXPECT_TRUE(stats.contains(key)) << key;
    EXPECT_EQ(stats["triangles"], vox::scenes::CornellBoxFacts::kTriangles);
    EXPECT_EQ(stats["dynamic_triangles"], vox::scenes::CornellBoxFacts::kSphereTriangles);
    EXPECT_EQ(stats["materials"], vox::scenes::CornellBoxFacts::kMaterials);
    EXPECT_EQ(stats["lights"].size(), 3u);
    EXPECT_EQ(stats["textures"], 1);
    EXPECT_EQ(stats["inputs"].size(), 3u);  // .gltf, .bin, checker.png
    EXPECT_EQ(stats["bounds"]["min"][1].get<double>(), -0.05f);
    EXPECT_GT(stats["timings_ms"]["import"].get<double>(), 0.0);
    EXPECT_GT(stats["peak_rss_bytes"].get<std::uint64_t>(), 1u << 20);
    EXPECT_EQ(stats["threads"], 1);
}

TEST(Tools, DepfileOfARealExternalBufferAndTextureGltf) {
    ScratchDir dir;
    const auto model = vox::test::assimpModels() / "glTF2/BoxTextured-glTF/BoxTextured.gltf";
    const ProcessResult r = voxelize({model.string(), "--stats", (dir / "s.json").string(), "--depfile", (dir / "s.d").string()});
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const std::string depfile = vox::test::readText(dir / "s.d");
    const auto folder = model.parent_path();
    EXPECT_EQ(depfile, (dir / "s.json").string() + ": \\\n  " + model.string() + " \\\n  " + (folder / "BoxTextured0.bin").string() +
                           " \\\n  " + (folder / "CesiumLogoFlat.png").string() + "\n");
}

TEST(Tools, DepfileListsEveryFileRead) {
    ScratchDir dir;
    const auto sceneDir = dir / "my scenes";
    const auto scene = vox::scenes::writeCornellBox(sceneDir);
    const auto stats = dir / "out stats.json";
    const ProcessResult r = voxelize({scene.string(), "--stats", stats.string(), "--depfile", (dir / "out.d").string()});
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const std::string depfile = vox::test::readText(dir / "out.d");
    auto escaped = [](std::string path) {
        std::string out;
        for (char c : path) {
            if (c == ' ') out.push_back('\\');
            out.push_back(c);
        }
        return out;
    };
    EXPECT_EQ(depfile.rfind(escaped(stats.string()) + ":", 0), 0u) << depfile;
    for (const char* name : {"cornell_box.gltf", "cornell_box.bin", "checker.png"})
        EXPECT_NE(depfile.find(escaped((sceneDir / name).string())), std::string::npos) << name << " missing from\n" << depfile;
}

TEST(Tools, WarningsQuietAndStrict) {
    ScratchDir dir;
    vox::test::writeText(dir / "d.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\n");
    const ProcessResult normal = voxelize({(dir / "d.obj").string()});
    EXPECT_EQ(normal.exitCode, 0);
    ASSERT_EQ(normal.errLines().size(), 1u) << normal.err;
    EXPECT_EQ(normal.errLines()[0].rfind("voxelize: warning: ", 0), 0u);
    EXPECT_NE(normal.err.find("degenerate"), std::string::npos);
    const ProcessResult quiet = voxelize({(dir / "d.obj").string(), "-q"});
    EXPECT_EQ(quiet.exitCode, 0);
    EXPECT_TRUE(quiet.err.empty()) << quiet.err;
    expectOneLineError(voxelize({(dir / "d.obj").string(), "--strict"}), 3, "degenerate");
    const ProcessResult verbose = voxelize({(dir / "d.obj").string(), "-v"});
    EXPECT_NE(verbose.err.find("1 triangles"), std::string::npos) << verbose.err;
    EXPECT_EQ(verbose.err.find('\r'), std::string::npos) << "no progress bar when stderr is not a terminal";
}

TEST(Tools, UnwritableOutputIsAnIoError) {
    ScratchDir dir;
    const auto scene = vox::scenes::writeCornellBox(dir.path());
    expectOneLineError(voxelize({scene.string(), "--stats", (dir / "no/such/dir/stats.json").string()}), 2, "stats.json");
}

TEST(Tools, VoxinspectSceneDescribesWhatWasImported) {
    ScratchDir dir;
    const auto scene = vox::scenes::writeCornellBox(dir.path());
    const ProcessResult json = voxinspect({"scene", scene.string(), "--json"});
    ASSERT_EQ(json.exitCode, 0) << json.err;
    const auto report = nlohmann::json::parse(json.out);
    EXPECT_EQ(report["triangles"], vox::scenes::CornellBoxFacts::kTriangles);
    EXPECT_EQ(report["mesh_list"].size(), 9u);
    const ProcessResult text = voxinspect({"scene", scene.string()});
    ASSERT_EQ(text.exitCode, 0);
    EXPECT_NE(text.out.find("DynamicSphere"), std::string::npos);
    EXPECT_NE(text.out.find("dynamic"), std::string::npos);
    expectOneLineError(voxinspect({"scene", (dir / "none.obj").string()}), 2, "none.obj", "voxinspect");
}

TEST(Tools, ProgressBarAppearsOnlyOnATerminal) {
    ScratchDir dir;
    const auto scene = vox::scenes::writeCornellBox(dir.path());
    // `script` gives the tool a pseudo-terminal as stderr.
    const ProcessResult tty = runProcess("/usr/bin/script", {"-q", "-e", "-c", vox::test::voxelizePath().string() + " " + scene.string(), "/dev/null"});
    EXPECT_EQ(tty.exitCode, 0) << tty.out << tty.err;
    EXPECT_NE(tty.out.find("decoding textures"), std::string::npos) << tty.out;
    EXPECT_NE(tty.out.find('\r'), std::string::npos);
    const ProcessResult quiet = runProcess("/usr/bin/script", {"-q", "-e", "-c", vox::test::voxelizePath().string() + " -q " + scene.string(), "/dev/null"});
    EXPECT_EQ(quiet.exitCode, 0);
    EXPECT_EQ(quiet.out.find("decoding textures"), std::string::npos) << quiet.out;
}
