// voxelize and voxinspect as a content build meets them: exit codes, one-line errors, no
// output on failure, --stats and --depfile.
#include <vox/formats/atomic_file.h>
#include <vox/formats/rvol_io.h>
#include <vox/formats/rvol_tiles.h>
#include <vox/octree.h>
#include <vox/texture.h>

#include "assimp_models.h"
#include "cornell_box.h"
#include "corridor.h"
#include "light_grid.h"
#include "test_support.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstring>
#include <fcntl.h>
#include <fstream>
#include <iostream>
#include <iterator>
#include <map>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

extern char** environ;

using vox::test::ProcessResult;
using vox::test::runProcess;
using vox::test::ScratchDir;

namespace {

ProcessResult voxelize(const std::vector<std::string>& args) {
    return runProcess(vox::test::voxelizePath(), args);
}
ProcessResult voxinspect(const std::vector<std::string>& args) {
    return runProcess(vox::test::voxinspectPath(), args);
}

/// A failed run: the exit code, exactly one stderr line in the documented form, naming @p mention.
void expectOneLineError(const ProcessResult& r, int code, const std::string& mention,
                        const std::string& program = "voxelize") {
    EXPECT_EQ(r.exitCode, code) << r.err;
    const auto lines = r.errLines();
    ASSERT_EQ(lines.size(), 1u) << r.err;
    EXPECT_EQ(lines[0].rfind(program + ": error: ", 0), 0u) << lines[0];
    EXPECT_NE(lines[0].find(mention), std::string::npos) << lines[0];
}

/// The names in @p folder, sorted.
std::vector<std::string> filesIn(const std::filesystem::path& folder) {
    std::vector<std::string> names;
    for (const auto& entry : std::filesystem::directory_iterator(folder))
        names.push_back(entry.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
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
    expectOneLineError(voxelize({scene.string(), "--depfile", (dir / "x.d").string()}), 1,
                       "--depfile needs");
}

TEST(Tools, BadInputFailsCleanlyWithNoOutputLeftBehind) {
    ScratchDir dir;
    const auto models = vox::test::assimpModels();
    vox::test::writeText(dir / "truncated.gltf", "{\"asset\": {\"version\": \"2.0\"");
    vox::test::writeText(dir / "text.glb", "this is not binary glTF");
    vox::test::writeText(dir / "huge.obj", "v 0 0 0\nv 2e30 0 0\nv 0 1 0\nf 1 2 3\n");
    vox::test::writeText(dir / "tiny.stl",
                         "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1e-31 0 0\n"
                         "vertex 0 1e-31 0\nendloop\nendfacet\nendsolid t\n");
    ASSERT_EQ(::mkfifo((dir / "fifo.obj").c_str(), 0600), 0);
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
        {dir / "huge.obj", 3, "vertex 1 has a coordinate beyond ±1e30 (absurd scale)"},
        {dir / "tiny.stl", 3,
         "longest side is 1e-31, below 1e-30 (absurd scale: zero or denormal size)"},
        {dir / "fifo.obj", 2, "fifo.obj: is not a regular file"},  // read, it would block forever
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
        const ProcessResult r = voxelize({c.input.string(), "--stats", (dir / "out.json").string(),
                                          "--depfile", (dir / "out.d").string()});
        expectOneLineError(r, c.code, c.mention);
        EXPECT_LT(r.exitCode, 100) << "no signal, no CLI11 code";
        EXPECT_FALSE(std::filesystem::exists(dir / "out.json"));
        EXPECT_FALSE(std::filesystem::exists(dir / "out.d"));
        for (const std::string& name : dir.files())
            EXPECT_FALSE(vox::AtomicFile::isTemporaryName(name)) << name;
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
        const ProcessResult r = voxelize({input.string(), "--stats", (dir / "out.json").string(),
                                          "--depfile", (dir / "out.d").string()});
        expectOneLineError(r, static_cast<int>(model.error), input.string() + ": ");
        EXPECT_EQ(dir.files(), std::vector<std::string>{}) << "no output, no temporary";
    }
    EXPECT_GE(broken, 30);  // the table's broken files, so the loop cannot silently test nothing
}

TEST(Tools, MaxTrianglesRejectsALargerSceneBeforeWritingAnything) {
    ScratchDir dir;
    const auto scene = vox::scenes::writeCornellBox(dir / "scene");
    const auto out = dir / "out";
    std::filesystem::create_directories(out);
    const std::size_t triangles = vox::scenes::CornellBoxFacts::kTriangles;
    const auto job = [&](std::size_t limit) {
        return std::vector<std::string>{scene.string(),
                                        "-o",
                                        (out / "box.esvo").string(),
                                        "--radiance",
                                        (out / "box.rvol").string(),
                                        "--stats",
                                        (out / "stats.json").string(),
                                        "--depfile",
                                        (out / "box.d").string(),
                                        "--depth",
                                        "3",
                                        "--radiance-depth",
                                        "2",
                                        "--bounces",
                                        "0",
                                        "--max-triangles",
                                        std::to_string(limit)};
    };
    // At the limit: accepted (the limit counts the triangles kept after import, dynamic ones
    // included).
    const ProcessResult atLimit = voxelize(job(triangles));
    ASSERT_EQ(atLimit.exitCode, 0) << atLimit.err;
    const auto stats = nlohmann::json::parse(vox::test::readText(out / "stats.json"));
    EXPECT_EQ(stats["triangles"], triangles);
    std::map<std::string, std::string> previous;
    for (const char* name : {"box.esvo", "box.rvol", "stats.json", "box.d"})
        previous[name] = vox::test::readText(out / name);

    // One below: invalid input, one line naming the file and both counts, and the previous outputs
    // untouched.
    const ProcessResult over = voxelize(job(triangles - 1));
    expectOneLineError(over, 3,
                       scene.string() + ": " + std::to_string(triangles) +
                           " triangles, more than --max-triangles " +
                           std::to_string(triangles - 1));
    for (const auto& [name, contents] : previous)
        EXPECT_EQ(vox::test::readText(out / name), contents) << name;
    EXPECT_EQ(filesIn(out),
              (std::vector<std::string>{"box.d", "box.esvo", "box.rvol", "stats.json"}));

    // Without outputs it fails the same way; 0 and negative limits are usage errors.
    expectOneLineError(voxelize({scene.string(), "--max-triangles", "10"}), 3,
                       "more than --max-triangles 10");
    expectOneLineError(voxelize({scene.string(), "--max-triangles", "0"}), 1, "--max-triangles");
    expectOneLineError(voxelize({scene.string(), "--max-triangles", "-5"}), 1, "--max-triangles");
}

TEST(Tools, StatsReportTheSceneWithStableKeys) {
    ScratchDir dir;
    const auto scene = vox::scenes::writeCornellBox(dir.path());
    const ProcessResult r =
        voxelize({scene.string(), "--stats", (dir / "stats.json").string(), "--threads", "1"});
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(r.err.empty()) << "a clean import prints nothing by default: " << r.err;
    const auto stats = nlohmann::json::parse(vox::test::readText(dir / "stats.json"));
    for (const char* key :
         {"inputs", "triangles", "materials", "lights", "bounds", "timings_ms", "peak_rss_bytes"})
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
    const ProcessResult r = voxelize({model.string(), "--stats", (dir / "s.json").string(),
                                      "--depfile", (dir / "s.d").string()});
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const std::string depfile = vox::test::readText(dir / "s.d");
    const auto folder = model.parent_path();
    EXPECT_EQ(depfile, (dir / "s.json").string() + ": \\\n  " + model.string() + " \\\n  " +
                           (folder / "BoxTextured0.bin").string() + " \\\n  " +
                           (folder / "CesiumLogoFlat.png").string() + "\n");
}

// OpenImageIO is in a module of its own (libvox/src/scene/image_module.h), loaded when an
// image is first decoded: what links vox::core does not load it (this test links vox::core),
// a scene without textures never needs it, and one with textures fails in one line, exit 4,
// without output, where the module cannot be found.
TEST(Tools, OnlyScenesWithImagesLoadTheImageModule) {
    {
        std::ifstream maps("/proc/self/maps");
        const std::string mapped((std::istreambuf_iterator<char>(maps)),
                                 std::istreambuf_iterator<char>());
        EXPECT_EQ(mapped.find("libOpenImageIO"), std::string::npos)
            << "vox::core links OpenImageIO";
    }
    ScratchDir dir;
    const auto textured = vox::test::assimpModels() / "glTF2/BoxTextured-glTF/BoxTextured.gltf";
    ::setenv("VOX_IMAGE_MODULE", (dir / "missing" / "libvox_image_oiio.so").c_str(), 1);
    const ProcessResult plain = voxelize({(vox::test::assimpModels() / "OFF/Cube.off").string(),
                                          "-o", (dir / "cube.esvo").string(), "--depth", "4"});
    const ProcessResult withImages =
        voxelize({textured.string(), "-o", (dir / "box.esvo").string(), "--depth", "4"});
    ::unsetenv("VOX_IMAGE_MODULE");
    EXPECT_EQ(plain.exitCode, 0) << plain.err;
    expectOneLineError(withImages, 4,
                       (dir / "missing" / "libvox_image_oiio.so").string() + ": not found");
    EXPECT_FALSE(std::filesystem::exists(dir / "box.esvo"));
    const ProcessResult found =
        voxelize({textured.string(), "-o", (dir / "box.esvo").string(), "--depth", "4"});
    EXPECT_EQ(found.exitCode, 0) << found.err;
}

TEST(Tools, DepfileListsEveryFileRead) {
    ScratchDir dir;
    const auto sceneDir = dir / "my scenes";
    const auto scene = vox::scenes::writeCornellBox(sceneDir);
    const auto stats = dir / "out stats.json";
    const ProcessResult r = voxelize(
        {scene.string(), "--stats", stats.string(), "--depfile", (dir / "out.d").string()});
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
        EXPECT_NE(depfile.find(escaped((sceneDir / name).string())), std::string::npos)
            << name << " missing from\n"
            << depfile;
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
    EXPECT_EQ(verbose.err.find('\r'), std::string::npos)
        << "no progress bar when stderr is not a terminal";
}

TEST(Tools, UnwritableOutputIsAnIoError) {
    ScratchDir dir;
    const auto scene = vox::scenes::writeCornellBox(dir.path());
    expectOneLineError(
        voxelize({scene.string(), "--stats", (dir / "no/such/dir/stats.json").string()}), 2,
        "stats.json");
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
    expectOneLineError(voxinspect({"scene", (dir / "none.obj").string()}), 2, "none.obj",
                       "voxinspect");
}

TEST(Tools, ProgressBarAppearsOnlyOnATerminal) {
    ScratchDir dir;
    const auto scene = vox::scenes::writeCornellBox(dir.path());
    // `script` gives the tool a pseudo-terminal as stderr.
    const ProcessResult tty = runProcess(
        "/usr/bin/script",
        {"-q", "-e", "-c", vox::test::voxelizePath().string() + " " + scene.string(), "/dev/null"});
    EXPECT_EQ(tty.exitCode, 0) << tty.out << tty.err;
    EXPECT_NE(tty.out.find("decoding textures"), std::string::npos) << tty.out;
    EXPECT_NE(tty.out.find('\r'), std::string::npos);
    const ProcessResult quiet =
        runProcess("/usr/bin/script",
                   {"-q", "-e", "-c", vox::test::voxelizePath().string() + " -q " + scene.string(),
                    "/dev/null"});
    EXPECT_EQ(quiet.exitCode, 0);
    EXPECT_EQ(quiet.out.find("decoding textures"), std::string::npos) << quiet.out;
}

// ---- .esvo through the tools ----------------------------------------------------------------

namespace {

std::vector<std::uint8_t> readBytes(const std::filesystem::path& file) {
    const std::string text = vox::test::readText(file);
    return {text.begin(), text.end()};
}

}  // namespace

TEST(Tools, VoxelizeWritesAnEsvoThatValidatesAndReportsItself) {
    ScratchDir dir;
    const auto scene = vox::scenes::writeCornellBox(dir.path());
    const auto esvo = dir / "box.esvo";
    const ProcessResult r = voxelize({scene.string(), "-o", esvo.string(), "--depth", "6",
                                      "--stats", (dir / "s.json").string(), "--depfile",
                                      (dir / "s.d").string(), "--threads", "1"});
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const auto stats = nlohmann::json::parse(vox::test::readText(dir / "s.json"));
    const auto& octree = stats["octree"];
    EXPECT_EQ(octree["depth"], 6);
    EXPECT_EQ(octree["voxels_per_level"].size(), 7u);
    EXPECT_EQ(octree["voxels_per_level"][0], 1);
    EXPECT_GT(octree["voxels_per_second"].get<double>(), 0.0);
    // The encoders' kernels, which decide the build's time but not its bytes, as this CPU runs
    // them.
    EXPECT_EQ(octree["attribute_kernels"], vox::attributeEncoderKernels());
    EXPECT_GT(stats["timings_ms"]["voxelize"].get<double>(), 0.0);
    EXPECT_EQ(vox::test::readText(dir / "s.d").rfind(esvo.string() + ":", 0), 0u)
        << "the depfile's target is the -o output";

    const ProcessResult valid = voxinspect({"validate", esvo.string()});
    EXPECT_EQ(valid.exitCode, 0) << valid.err;

    const ProcessResult info = voxinspect({"info", esvo.string(), "--json"});
    ASSERT_EQ(info.exitCode, 0) << info.err;
    const auto report = nlohmann::json::parse(info.out);
    for (const char* key : {"depth", "voxels", "voxels_per_level", "slices", "far_pointers",
                            "file_bytes", "bytes_per_voxel"})
        EXPECT_TRUE(report.contains(key)) << key;
    EXPECT_EQ(report["depth"], 6);
    EXPECT_EQ(report["voxels"], octree["voxels"]);
    EXPECT_EQ(report["voxels_per_level"], octree["voxels_per_level"]);
    EXPECT_EQ(report["file_bytes"].get<std::uint64_t>(), std::filesystem::file_size(esvo));
    const auto& perVoxel = report["bytes_per_voxel"];
    EXPECT_NEAR(perVoxel["total"].get<double>(),
                double(std::filesystem::file_size(esvo)) / report["voxels"].get<double>(), 1e-9);
    double parts = 0;
    for (const auto& [part, value] : perVoxel.items())
        if (part != "total") parts += value.get<double>();
    EXPECT_EQ(report["attributes"], "dxt") << "colours and normals are compressed by default";
    EXPECT_GT(perVoxel["attribute_blocks"].get<double>(), 1.0);
    EXPECT_NEAR(parts, perVoxel["total"].get<double>(), 1e-9) << "the parts add up to the file";
    // Static geometry only: the dynamic sphere is left out unless asked for.
    const auto withDynamic = dir / "all.esvo";
    ASSERT_EQ(
        voxelize({scene.string(), "-o", withDynamic.string(), "--depth", "6", "--include-dynamic"})
            .exitCode,
        0);
    EXPECT_GT(std::filesystem::file_size(withDynamic), std::filesystem::file_size(esvo));
}

TEST(Tools, EsvoIsByteIdenticalWhateverTheThreadCount) {
    ScratchDir dir;
    const auto scene = vox::scenes::writeCornellBox(dir.path());
    for (const char* threads : {"1", "2", "3"})
        ASSERT_EQ(
            voxelize({scene.string(), "-o", (dir / (std::string("t") + threads + ".esvo")).string(),
                      "--depth", "7", "--slice-bytes", "16384", "--threads", threads})
                .exitCode,
            0);
    EXPECT_EQ(readBytes(dir / "t1.esvo"), readBytes(dir / "t2.esvo"));
    EXPECT_EQ(readBytes(dir / "t1.esvo"), readBytes(dir / "t3.esvo"));
    // The other colour/normal encodings too (dxt above is the default).
    for (const char* attributes : {"raw", "dxt-lookup"})
        for (const char* threads : {"1", "2"})
            ASSERT_EQ(voxelize({scene.string(), "-o",
                                (dir / (std::string(attributes) + threads + ".esvo")).string(),
                                "--depth", "7", "--slice-bytes", "16384", "--threads", threads,
                                "--attributes", attributes})
                          .exitCode,
                      0);
    EXPECT_EQ(readBytes(dir / "raw1.esvo"), readBytes(dir / "raw2.esvo"));
    EXPECT_EQ(readBytes(dir / "dxt-lookup1.esvo"), readBytes(dir / "dxt-lookup2.esvo"));
}

TEST(Tools, EightPartitionRunsMergeIntoTheBytesOfOneBuild) {
    ScratchDir dir;
    const auto scene = vox::scenes::writeCornellBox(dir.path());
    const std::vector<std::string> build{scene.string(),  "--depth", "7", "--partition-level", "3",
                                         "--slice-bytes", "16384"};
    const auto with = [&](std::vector<std::string> extra) {
        std::vector<std::string> args = build;
        args.insert(args.end(), extra.begin(), extra.end());
        return voxelize(args);
    };
    ASSERT_EQ(with({"-o", (dir / "whole.esvo").string(), "--stats", (dir / "whole.json").string()})
                  .exitCode,
              0);
    std::vector<std::string> merge{"merge"};
    for (int k = 1; k <= 8; ++k) {
        const auto part = dir / ("run" + std::to_string(k) + ".esvopart");
        const ProcessResult r =
            with({"-o", part.string(), "--partition", std::to_string(k) + "/8", "-q"});
        ASSERT_EQ(r.exitCode, 0) << r.err;
        EXPECT_EQ(r.err, "");
        merge.push_back(part.string());
    }
    const auto mergedStats = dir / "merged.json";
    std::vector<std::string> mergeAll = merge;
    mergeAll.insert(mergeAll.end(),
                    {"-o", (dir / "merged.esvo").string(), "--stats", mergedStats.string()});
    const ProcessResult merged = voxelize(mergeAll);
    ASSERT_EQ(merged.exitCode, 0) << merged.err;
    EXPECT_EQ(readBytes(dir / "merged.esvo"), readBytes(dir / "whole.esvo"));
    const auto whole = nlohmann::json::parse(vox::test::readText(dir / "whole.json"));
    const auto report = nlohmann::json::parse(vox::test::readText(mergedStats));
    EXPECT_EQ(report["octree"]["voxels"], whole["octree"]["voxels"]);
    EXPECT_EQ(report["octree"]["slices"], whole["octree"]["slices"]);
    EXPECT_EQ(whole["octree"]["partition_level"], 3);
    EXPECT_GT(whole["octree"]["partitions"].get<int>(), 8);

    // A missing run, a corrupt part: one line, exit 3, no output.
    std::vector<std::string> missing(merge.begin(), merge.begin() + 8);  // runs 1-7
    missing.insert(missing.end(), {"-o", (dir / "bad.esvo").string()});
    expectOneLineError(voxelize(missing), 3, "run 8 of 8 is missing");
    auto bytes = readBytes(dir / "run4.esvopart");
    bytes[bytes.size() / 2] = static_cast<char>(bytes[bytes.size() / 2] ^ 1);
    vox::test::writeBinary(dir / "run4.esvopart",
                           std::vector<std::uint8_t>(bytes.begin(), bytes.end()));
    std::vector<std::string> corrupt = merge;
    corrupt.insert(corrupt.end(), {"-o", (dir / "bad.esvo").string()});
    expectOneLineError(voxelize(corrupt), 3, "run4.esvopart");
    EXPECT_FALSE(std::filesystem::exists(dir / "bad.esvo"));

    // Usage: K outside 1 … N, a part file without the part extension, runs without partitions,
    // a size that is no size, a limit below what the scene takes.
    expectOneLineError(with({"-o", (dir / "x.esvopart").string(), "--partition", "0/8"}), 1,
                       "--partition");
    expectOneLineError(with({"-o", (dir / "x.esvopart").string(), "--partition", "9/8"}), 1,
                       "--partition");
    expectOneLineError(with({"-o", (dir / "x.esvo").string(), "--partition", "2/8"}), 1,
                       ".esvopart");
    expectOneLineError(voxelize({scene.string(), "--depth", "7", "-o",
                                 (dir / "x.esvopart").string(), "--partition", "2/8"}),
                       1, "--partition");
    expectOneLineError(with({"-o", (dir / "x.esvo").string(), "--memory-limit", "lots"}), 1,
                       "--memory-limit");
    expectOneLineError(with({"-o", (dir / "x.esvo").string(), "--memory-limit", "1M"}), 1,
                       "--memory-limit");
    EXPECT_FALSE(std::filesystem::exists(dir / "x.esvo"));
    EXPECT_FALSE(std::filesystem::exists(dir / "x.esvopart"));
    ASSERT_EQ(with({"-o", (dir / "limited.esvo").string(), "--memory-limit", "4G"}).exitCode, 0);
    EXPECT_EQ(readBytes(dir / "limited.esvo"), readBytes(dir / "whole.esvo"));
}

TEST(Tools, SmallSlicesAndShortPointersStillValidate) {
    ScratchDir dir;
    const auto scene = vox::scenes::writeCornellBox(dir.path());
    const auto esvo = dir / "small.esvo";
    // Cubes only and no attributes, so that descriptor runs fill whole pages of the small slices.
    ASSERT_EQ(
        voxelize({scene.string(), "-o", esvo.string(), "--depth", "8", "--slice-bytes", "16384",
                  "--no-contours", "--attributes", "none", "--debug-near-pointer-limit", "32"})
            .exitCode,
        0);
    EXPECT_EQ(voxinspect({"validate", esvo.string()}).exitCode, 0);
    const auto report = nlohmann::json::parse(voxinspect({"info", esvo.string(), "--json"}).out);
    EXPECT_GT(report["slices"].get<int>(), 10);
    EXPECT_LE(report["largest_slice_bytes"].get<int>(), 16384);
    EXPECT_GT(report["far_pointers"].get<int>(), 100);
    EXPECT_GT(report["bytes"]["page_headers"].get<int>(), 8 * report["slices"].get<int>())
        << "page headers inside slices";
    const ProcessResult dump = voxinspect({"dump", esvo.string(), "--json"});
    ASSERT_EQ(dump.exitCode, 0) << dump.err;
    EXPECT_EQ(nlohmann::json::parse(dump.out)["slices"].size(),
              report["slices"].get<std::size_t>());
    const ProcessResult slice = voxinspect({"dump", esvo.string(), "--slice", "1", "--json"});
    ASSERT_EQ(slice.exitCode, 0) << slice.err;
    EXPECT_FALSE(nlohmann::json::parse(slice.out)["units"].empty());
}

TEST(Tools, ValidateLocatesTheFirstViolation) {
    ScratchDir dir;
    const auto scene = vox::scenes::writeCornellBox(dir.path());
    const auto esvo = dir / "box.esvo";
    ASSERT_EQ(voxelize({scene.string(), "-o", esvo.string(), "--depth", "6"}).exitCode, 0);
    auto bytes = readBytes(esvo);
    const auto corrupt = dir / "corrupt.esvo";
    bytes[bytes.size() - 100] ^= 0x10;  // inside the last slice
    vox::test::writeBinary(corrupt, bytes);
    expectOneLineError(voxinspect({"validate", corrupt.string()}), 3, "slice", "voxinspect");
    bytes.resize(bytes.size() - 7);
    vox::test::writeBinary(corrupt, bytes);
    expectOneLineError(voxinspect({"validate", corrupt.string()}), 3, corrupt.string(),
                       "voxinspect");
    expectOneLineError(voxinspect({"info", (dir / "missing.esvo").string()}), 2, "missing.esvo",
                       "voxinspect");
    expectOneLineError(voxinspect({"validate", scene.string()}), 3, "bad magic", "voxinspect");
}

TEST(Tools, RenderWritesPngAndPfmFromTheCamera) {
    ScratchDir dir;
    const auto scene = vox::scenes::writeCornellBox(dir.path());
    const auto esvo = dir / "box.esvo";
    ASSERT_EQ(voxelize({scene.string(), "-o", esvo.string(), "--depth", "7"}).exitCode, 0);
    const auto png = dir / "v.png", pfm = dir / "v.pfm";
    const ProcessResult r =
        voxinspect({"render", esvo.string(), "-o", png.string(), "--eye", "0,1,5", "--target",
                    "0,1,0", "--fov", "40", "--width", "64", "--height", "48", "--channel",
                    "normal", "--depth-out", pfm.string()});
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const auto image = readBytes(png);
    ASSERT_GT(image.size(), 24u);
    EXPECT_EQ((image[16] << 24) | (image[17] << 16) | (image[18] << 8) | image[19],
              64);  // IHDR width
    EXPECT_EQ((image[20] << 24) | (image[21] << 16) | (image[22] << 8) | image[23], 48);
    const std::string depth = vox::test::readText(pfm);
    const std::string header = "Pf\n64 48\n-1.0\n";
    ASSERT_EQ(depth.size(), header.size() + 4 * 64 * 48);
    EXPECT_EQ(depth.substr(0, header.size()), header);
    const auto at = [&](int x, int yFromTop) {
        float v;
        std::memcpy(&v, depth.data() + header.size() + 4 * ((47 - yFromTop) * 64 + x), 4);
        return v;
    };
    EXPECT_TRUE(std::isinf(at(0, 0))) << "the corner ray passes beside the box";
    // The centre ray enters the open front and meets the back wall (z = -1.0 to -1.05) or the
    // boxes in front of it: 5 − (−1.05) = 6.05 at most.
    EXPECT_GT(at(32, 24), 4.0f);
    EXPECT_LT(at(32, 24), 6.1f);
    for (const char* channel : {"depth", "iterations", "level"})
        EXPECT_EQ(
            voxinspect({"render", esvo.string(), "-o", png.string(), "--eye", "0,1,5", "--target",
                        "0,1,0", "--width", "16", "--height", "16", "--channel", channel})
                .exitCode,
            0)
            << channel;
    for (const char* channel : {"shaded", "color", "normal", "face-normal"})
        for (const bool filter : {false, true}) {
            if (filter && std::string(channel).find("normal") != std::string::npos) continue;
            std::vector<std::string> args{
                "render", esvo.string(), "-o", png.string(), "--eye", "0,1,5",     "--target",
                "0,1,0",  "--width",     "16", "--height",   "16",    "--channel", channel};
            if (filter) args.push_back("--filter");
            EXPECT_EQ(voxinspect(args).exitCode, 0) << channel;
        }
    expectOneLineError(voxinspect({"render", esvo.string(), "-o", png.string(), "--eye", "0,1,5",
                                   "--target", "0,1,0", "--channel", "depth", "--filter"}),
                       1, "--filter", "voxinspect");
    const auto bare = dir / "bare.esvo";
    ASSERT_EQ(
        voxelize({scene.string(), "-o", bare.string(), "--depth", "5", "--attributes", "none"})
            .exitCode,
        0);
    expectOneLineError(voxinspect({"render", bare.string(), "-o", png.string(), "--eye", "0,1,5",
                                   "--target", "0,1,0", "--channel", "color"}),
                       1, "no colours", "voxinspect");
    EXPECT_EQ(voxinspect({"render", bare.string(), "-o", png.string(), "--eye", "0,1,5", "--target",
                          "0,1,0", "--width", "16", "--height", "16", "--channel", "shaded"})
                  .exitCode,
              0)
        << "shading falls back to face normals and grey";
    expectOneLineError(voxelize({scene.string(), "-o", bare.string(), "--attributes", "bc7"}), 1,
                       "--attributes");
    expectOneLineError(voxinspect({"render", esvo.string(), "-o", png.string(), "--eye", "0,1,5",
                                   "--target", "0,1,5"}),
                       1, "same point", "voxinspect");
    expectOneLineError(voxelize({scene.string(), "-o", (dir / "x.obj").string()}), 1,
                       "expected .esvo");
}

TEST(Tools, ContoursAreOnByDefaultAndRefinementIsErrorBounded) {
    ScratchDir dir;
    const auto scene = vox::scenes::writeCornellBox(dir.path());
    const auto build = [&](const std::vector<std::string>& extra, nlohmann::json* stats = nullptr) {
        std::vector<std::string> args{
            scene.string(),           "-o", (dir / "c.esvo").string(), "--depth", "8", "--stats",
            (dir / "s.json").string()};
        args.insert(args.end(), extra.begin(), extra.end());
        EXPECT_EQ(voxelize(args).exitCode, 0);
        EXPECT_EQ(voxinspect({"validate", (dir / "c.esvo").string()}).exitCode, 0);
        if (stats) *stats = nlohmann::json::parse(vox::test::readText(dir / "s.json"));
        return nlohmann::json::parse(voxinspect({"info", (dir / "c.esvo").string(), "--json"}).out);
    };
    nlohmann::json defaultStats, fullStats;
    const auto cubes = build({"--no-contours"});
    const auto full = build({"--full-refinement"}, &fullStats);
    const auto bounded = build({}, &defaultStats);
    const auto zero = build({"--contour-error", "0"});
    EXPECT_EQ(cubes["bytes"]["contours"], 0);
    EXPECT_EQ(cubes["contour_voxels"], 0);
    EXPECT_GT(full["bytes"]["contours"].get<std::uint64_t>(), 0u);
    EXPECT_EQ(full["voxels"], cubes["voxels"])
        << "fully refined, contours do not change the voxels";
    EXPECT_EQ(full["leaves"], full["voxels_per_level"][8])
        << "fully refined, every leaf is at --depth";
    EXPECT_EQ(zero["voxels"], full["voxels"]) << "--contour-error 0 is full refinement";
    EXPECT_EQ(fullStats["octree"]["refinement"]["full"], true);
    EXPECT_EQ(defaultStats["octree"]["refinement"]["full"], false);
    EXPECT_EQ(defaultStats["octree"]["refinement"]["contour_error"], vox::kDefaultContourError);
    EXPECT_EQ(defaultStats["octree"]["refinement"]["normal_error_degrees"],
              vox::kDefaultNormalErrorDegrees);
    EXPECT_EQ(defaultStats["octree"]["refinement"]["color_error"], vox::kDefaultColorError);
    // The Cornell box is made of flat faces: by default a slab bounds them within the error long
    // before the leaf depth; leaves above it are where refinement stopped.
    EXPECT_LT(bounded["voxels"].get<double>(), 0.3 * full["voxels"].get<double>());
    EXPECT_LT(bounded["file_bytes"].get<double>(), 0.3 * full["file_bytes"].get<double>());
    EXPECT_GT(bounded["leaves"].get<std::uint64_t>(),
              bounded["voxels_per_level"][8].get<std::uint64_t>());
    // Contours are counted where they are stored: 4 bytes each.
    EXPECT_EQ(bounded["bytes"]["contours"].get<std::uint64_t>(),
              4 * bounded["contour_voxels"].get<std::uint64_t>());
    std::uint64_t perLevel = 0;
    for (const auto& n : bounded["contour_voxels_per_level"]) perLevel += n.get<std::uint64_t>();
    EXPECT_EQ(perLevel, bounded["contour_voxels"].get<std::uint64_t>());
}

// ---- .rvol through the tools ----------------------------------------------------------------

namespace {

/// Bakes the Cornell box's radiance volume at depth 5 with one bounce (well under a second).
std::filesystem::path bakeCornellRvol(const ScratchDir& dir) {
    const auto scene = vox::scenes::writeCornellBox(dir.path());
    const auto rvol = dir / "box.rvol";
    const ProcessResult r = voxelize(
        {scene.string(), "--radiance", rvol.string(), "--radiance-depth", "5", "--bounces", "1"});
    EXPECT_EQ(r.exitCode, 0) << r.err;
    return rvol;
}

nlohmann::json sampleJson(const std::filesystem::path& rvol,
                          const std::vector<std::string>& extra) {
    std::vector<std::string> args{"sample", rvol.string(), "--json"};
    args.insert(args.end(), extra.begin(), extra.end());
    const ProcessResult r = voxinspect(args);
    EXPECT_EQ(r.exitCode, 0) << r.err;
    return r.exitCode == 0 ? nlohmann::json::parse(r.out) : nlohmann::json::object();
}

}  // namespace

TEST(Tools, RadianceBakeIsByteIdenticalWhateverTheThreadCountAndRejectsBadOptions) {
    ScratchDir dir;
    const auto scene = vox::scenes::writeCornellBox(dir.path());
    std::vector<std::vector<std::uint8_t>> rvols, vdbs;
    for (const char* threads : {"1", "2"}) {
        const auto rvol = dir / (std::string("t") + threads + ".rvol");
        const auto vdb = dir / (std::string("t") + threads + ".vdb");
        const ProcessResult r = voxelize(
            {scene.string(), "--radiance", rvol.string(), "--radiance-depth", "5", "--bounces", "2",
             "--bounce-gather", "cones", "--export-vdb", vdb.string(), "--threads", threads});
        ASSERT_EQ(r.exitCode, 0) << r.err;
        rvols.push_back(readBytes(rvol));
        vdbs.push_back(readBytes(vdb));
    }
    EXPECT_TRUE(rvols[0] == rvols[1]);
    EXPECT_TRUE(vdbs[0] == vdbs[1]);
    // Bounces gathered by rays: the same bytes too, and the header says how they were gathered.
    std::vector<std::vector<std::uint8_t>> rayRvols;
    for (const char* threads : {"1", "2"}) {
        const auto rvol = dir / (std::string("rays") + threads + ".rvol");
        const ProcessResult r =
            voxelize({scene.string(), "--radiance", rvol.string(), "--radiance-depth", "5",
                      "--bounce-gather", "rays", "--gather-rays", "16", "--threads", threads});
        ASSERT_EQ(r.exitCode, 0) << r.err;
        rayRvols.push_back(readBytes(rvol));
        EXPECT_EQ(vox::rvol::RvolReader(rvol).header().bake.gatherRays, 16u);
    }
    EXPECT_TRUE(rayRvols[0] == rayRvols[1]);
    // Past the header, which records the gather either way: the radiance itself differs.
    const auto pastHeader = [](const std::vector<std::uint8_t>& file) {
        return std::vector<std::uint8_t>(file.begin() + vox::rvol::kHeaderBytes, file.end());
    };
    EXPECT_FALSE(pastHeader(rayRvols[0]) == pastHeader(rvols[0]))
        << "rays and cones gather different light";
    EXPECT_EQ(vox::rvol::RvolReader(dir / "t1.rvol").header().bake.gatherRays, 0u);
    // The default (auto) gathers a volume this small with rays, 256 per voxel.
    const auto automatic = dir / "auto.rvol";
    ASSERT_EQ(voxelize({scene.string(), "--radiance", automatic.string(), "--radiance-depth", "5"})
                  .exitCode,
              0);
    EXPECT_EQ(vox::rvol::RvolReader(automatic).header().bake.gatherRays, 256u);
    expectOneLineError(voxelize({scene.string(), "--radiance", (dir / "x.rvol").string(),
                                 "--bounce-gather", "rays", "--gather-rays", "200"}),
                       1, "--gather-rays: 200 is not a square number");
    expectOneLineError(voxelize({scene.string(), "--radiance", (dir / "x.rvol").string(),
                                 "--bounce-gather", "rays", "--radiance-tile-depth", "4"}),
                       1, "--bounce-gather rays: not for a tiled bake");
    expectOneLineError(voxelize({scene.string(), "--radiance", (dir / "x.txt").string()}), 1,
                       ".rvol");
    expectOneLineError(voxelize({scene.string(), "--export-vdb", (dir / "x.vdb").string()}), 1,
                       "--export-vdb needs --radiance");
    expectOneLineError(voxelize({scene.string(), "--radiance", (dir / "x.rvol").string(),
                                 "--radiance-depth", "14"}),
                       1, "--radiance-depth");
    EXPECT_FALSE(std::filesystem::exists(dir / "x.rvol"));
}

// Determinism (issue 9): the default thread count (no --threads: all cores) and a repeated run
// give the very bytes of --threads 1, for every attribute encoding with contours (and with
// contour-driven refinement), and for a radiance bake with bounces through Lightcuts' light
// forest (256 lights). Whole files are compared; a control shows that differing options do
// give differing bytes, so the comparison can fail.
TEST(Tools, OutputsAreByteIdenticalForTheDefaultThreadCountAndRepeatedRuns) {
    ScratchDir dir;
    const auto cornell = vox::scenes::writeCornellBox(dir.path());
    // --threads 1, then the default twice (or only --threads 1 for a control); returns the bytes.
    const auto runs = [&](const std::filesystem::path& scene, const std::string& name,
                          const std::string& outputOption, std::vector<std::string> options,
                          bool control = false) {
        std::vector<std::vector<std::uint8_t>> bytes;
        for (const char* run : {"threads1", "default", "again"}) {
            if (control && bytes.size() == 1) break;
            const auto file = dir / (name + "-" + run + (outputOption == "-o" ? ".esvo" : ".rvol"));
            std::vector<std::string> args{scene.string(), outputOption, file.string()};
            args.insert(args.end(), options.begin(), options.end());
            if (std::string(run) == "threads1") args.insert(args.end(), {"--threads", "1"});
            const ProcessResult r = voxelize(args);
            EXPECT_EQ(r.exitCode, 0) << name << ": " << r.err;
            bytes.push_back(readBytes(file));
        }
        EXPECT_GT(bytes[0].size(), 1000u) << name;
        if (control) return bytes[0];
        EXPECT_TRUE(bytes[1] == bytes[0]) << name << ": the default thread count changed the bytes";
        EXPECT_TRUE(bytes[2] == bytes[1]) << name << ": a repeated run changed the bytes";
        return bytes[0];
    };
    std::vector<std::vector<std::uint8_t>> esvos;
    for (const char* attributes : {"dxt", "dxt-lookup", "raw", "none"})
        esvos.push_back(
            runs(cornell, attributes, "-o",
                 {"--depth", "7", "--slice-bytes", "16384", "--attributes", attributes}));
    runs(cornell, "contour-error", "-o",
         {"--depth", "7", "--contour-error", "1", "--color-error", "8", "--normal-error", "10"});
    for (std::size_t i = 1; i < esvos.size(); ++i)
        EXPECT_FALSE(esvos[i] == esvos[0]) << "control: encodings differ";
    const auto grid = vox::scenes::writeLightGrid(dir.path());
    const auto lightcuts = runs(grid, "lightcuts", "--radiance",
                                {"--radiance-depth", "5", "--bounces", "2", "--lightcuts", "on"});
    const auto bruteForce =
        runs(grid, "brute-force", "--radiance",
             {"--radiance-depth", "5", "--bounces", "2", "--lightcuts", "off"}, true);
    EXPECT_EQ(lightcuts.size(), bruteForce.size()) << "the same bricks";
    EXPECT_FALSE(lightcuts == bruteForce)
        << "control: Lightcuts' light is not brute force's to the bit";
}

TEST(Tools, RvolInfoAndValidate) {
    ScratchDir dir;
    const auto rvol = bakeCornellRvol(dir);
    const ProcessResult info = voxinspect({"info", rvol.string(), "--json"});
    ASSERT_EQ(info.exitCode, 0) << info.err;
    const auto report = nlohmann::json::parse(info.out);
    EXPECT_EQ(report["depth"], 5);
    EXPECT_EQ(report["resolution"], 32);
    EXPECT_GT(report["bricks"].get<int>(), 0);
    EXPECT_EQ(report["bake"]["bounces"], 1);
    EXPECT_EQ(report["bake"]["lights"], 3);
    EXPECT_GT(report["static_voxels"].get<int>(), 0);
    EXPECT_GT(report["dynamic_voxels"].get<int>(), 0) << "the sphere is dynamic";
    ASSERT_EQ(report["levels"].size(), 6u);
    std::uint64_t bricks = 0, levelBytes = 0, parts = 0;
    for (const auto& level : report["levels"]) {
        bricks += level["bricks"].get<std::uint64_t>();
        levelBytes += level["bytes"].get<std::uint64_t>();
    }
    EXPECT_EQ(bricks, report["bricks"].get<std::uint64_t>());
    EXPECT_EQ(levelBytes, report["bytes"]["radiance"].get<std::uint64_t>());
    for (const auto& [part, bytes] : report["bytes"].items()) parts += bytes.get<std::uint64_t>();
    EXPECT_EQ(parts, std::filesystem::file_size(rvol)) << "the parts add up to the file";
    EXPECT_EQ(report["file_bytes"].get<std::uint64_t>(), std::filesystem::file_size(rvol));
    const ProcessResult text = voxinspect({"info", rvol.string()});
    EXPECT_EQ(text.exitCode, 0) << text.err;
    EXPECT_NE(text.out.find("depth 5"), std::string::npos) << text.out;

    const ProcessResult valid = voxinspect({"validate", rvol.string()});
    EXPECT_EQ(valid.exitCode, 0) << valid.err;
    EXPECT_NE(valid.out.find("valid"), std::string::npos) << valid.out;
    // Flip a byte inside the first brick (brickDataOffset: header bytes 176-183).
    auto bytes = readBytes(rvol);
    std::uint64_t brickData = 0;
    std::memcpy(&brickData, bytes.data() + 176, 8);
    ASSERT_LT(brickData + 100, bytes.size());
    bytes[brickData + 100] ^= 0x10;
    const auto corrupt = dir / "corrupt.rvol";
    vox::test::writeBinary(corrupt, bytes);
    expectOneLineError(voxinspect({"validate", corrupt.string()}), 3, "checksum mismatch",
                       "voxinspect");
    expectOneLineError(voxinspect({"info", corrupt.string()}), 3, "brick", "voxinspect");
    expectOneLineError(voxinspect({"dump", rvol.string()}), 1, ".esvo", "voxinspect");
}

TEST(Tools, RvolSampleReadsRadianceAndOpacity) {
    ScratchDir dir;
    const auto rvol = bakeCornellRvol(dir);
    // On the floor beside the red wall: lit, and reddened by the wall.
    const auto floor = sampleJson(rvol, {"--at", "-0.9,0.02,0"});
    ASSERT_EQ(floor["radiance"].size(), 3u);
    EXPECT_GT(floor["radiance"][0].get<double>(), floor["radiance"][1].get<double>())
        << floor.dump();
    EXPECT_GT(floor["occlusion"].get<double>(), 0.0);
    EXPECT_EQ(floor["level"], 0);
    EXPECT_TRUE(floor["direction"].is_null());
    EXPECT_NEAR(floor["premultiplied"][0].get<double>(),
                floor["radiance"][0].get<double>() * floor["occlusion"].get<double>(), 1e-6);
    // Empty space, far from every surface.
    const auto air = sampleJson(rvol, {"--at", "0.3,1.5,0.5"});
    EXPECT_EQ(air["occlusion"].get<double>(), 0.0) << air.dump();
    EXPECT_EQ(air["radiance"], nlohmann::json({0.0, 0.0, 0.0}));
    // Coarser levels: one direction, or the mean of the six.
    const auto directional = sampleJson(rvol, {"--at", "-0.9,1,0", "--level", "2", "--dir", "-x"});
    EXPECT_EQ(directional["direction"], nlohmann::json({-1.0, 0.0, 0.0}));
    EXPECT_GT(directional["occlusion"].get<double>(), 0.0) << "the red wall is in the cone's way";
    EXPECT_EQ(sampleJson(rvol, {"--at", "0,1,0", "--level", "1"})["channel"], "mean of 6 channels");
    EXPECT_EQ(
        sampleJson(rvol, {"--at", "0,1,0", "--level", "5", "--dir", "1,1,0"})["direction"].size(),
        3u);

    expectOneLineError(voxinspect({"sample", rvol.string(), "--at", "0,1,0", "--level", "9"}), 1,
                       "--level 9", "voxinspect");
    expectOneLineError(voxinspect({"sample", rvol.string(), "--at", "0,1"}), 1, "--at",
                       "voxinspect");
    expectOneLineError(
        voxinspect({"sample", rvol.string(), "--at", "0,1,0", "--level", "1", "--dir", "+w"}), 1,
        "--dir", "voxinspect");
    expectOneLineError(
        voxinspect({"sample", rvol.string(), "--at", "0,1,0", "--level", "1", "--dir", "0,0,0"}), 1,
        "--dir", "voxinspect");
}

TEST(Tools, RvolSlicesWriteOnePngPerLevelAndChannel) {
    ScratchDir dir;
    const auto rvol = bakeCornellRvol(dir);
    const auto out = dir / "slices";
    const ProcessResult r =
        voxinspect({"slices", rvol.string(), "-o", out.string(), "--axis", "y", "--exposure", "2"});
    ASSERT_EQ(r.exitCode, 0) << r.err;
    std::size_t pngs = 0;
    for (const auto& entry : std::filesystem::directory_iterator(out))
        pngs += entry.path().extension() == ".png";
    EXPECT_EQ(pngs, 1u + 6u * 5u);
    EXPECT_TRUE(std::filesystem::exists(out / "L0_iso.png"));
    EXPECT_TRUE(std::filesystem::exists(out / "L1_px.png"));
    EXPECT_TRUE(std::filesystem::exists(out / "L5_nz.png"));
    const vox::Texture level0 = vox::loadTexture(out / "L0_iso.png", vox::ColorSpace::Linear);
    EXPECT_EQ(level0.width(), 32);
    EXPECT_EQ(level0.height(), 32);
    expectOneLineError(voxinspect({"slices", rvol.string(), "-o", out.string(), "--axis", "w"}), 1,
                       "--axis", "voxinspect");
    expectOneLineError(voxinspect({"slices", rvol.string(), "-o", out.string(), "--index", "32"}),
                       1, "--index", "voxinspect");
}

/// voxinspect render's camera looking into the Cornell box, 48 × 36 pixels.
const std::vector<std::string> kCornellCamera{"--eye", "0,1,3.2", "--target", "0,1,0",    "--fov",
                                              "50",    "--width", "48",       "--height", "36"};

/// A render with kCornellCamera that succeeded quietly and shows the box: bright enough, the red
/// wall on the left (the red excess r − g of the leftmost quarter above the rightmost's).
void expectCornellRender(const ProcessResult& r, const std::filesystem::path& png) {
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(r.err.empty()) << r.err;
    const vox::Texture image = vox::loadTexture(png, vox::ColorSpace::Linear);
    ASSERT_EQ(image.width(), 48);
    ASSERT_EQ(image.height(), 36);
    double mean = 0, leftRed = 0, rightRed = 0;
    for (int y = 0; y < image.height(); ++y)
        for (int x = 0; x < image.width(); ++x) {
            const vox::Vec4f p = image.texel(0, x, y);
            mean += (p.x + p.y + p.z) / 3;
            if (x < image.width() / 4) leftRed += p.x - p.y;
            if (x >= image.width() * 3 / 4) rightRed += p.x - p.y;
        }
    mean /= double(image.width()) * image.height();
    EXPECT_GT(mean, 0.05);
    EXPECT_GT(leftRed, rightRed + 0.1 * image.height())
        << "the red wall is on the left, the green one on the right";
}

TEST(Tools, RvolRenderFinalGathersTheScene) {
    ScratchDir dir;
    const auto rvol = bakeCornellRvol(dir);
    const auto scene = dir / "cornell_box.gltf";
    const auto png = dir / "final.png";
    const std::vector<std::string>& camera = kCornellCamera;
    const auto render = [&](const std::filesystem::path& out, std::vector<std::string> extra) {
        std::vector<std::string> args{"render", rvol.string(), "-o", out.string()};
        args.insert(args.end(), camera.begin(), camera.end());
        args.insert(args.end(), extra.begin(), extra.end());
        return voxinspect(args);
    };
    ASSERT_NO_FATAL_FAILURE(
        expectCornellRender(render(png, {"--scene", scene.string(), "--threads", "1"}), png));
    // Deterministic whatever the thread count.
    const auto threaded = dir / "threaded.png";
    ASSERT_EQ(render(threaded, {"--scene", scene.string(), "--threads", "3"}).exitCode, 0);
    EXPECT_EQ(readBytes(png), readBytes(threaded));
    // Every channel, with and without shadow cones.
    for (const char* channel : {"direct", "indirect", "specular", "ao", "albedo", "normal"})
        EXPECT_EQ(render(dir / "c.png",
                         {"--scene", scene.string(), "--channel", channel, "--no-shadow-cones"})
                      .exitCode,
                  0)
            << channel;
    // Primary hits from an octree instead: without --scene there are no lights, which it says.
    const auto esvo = dir / "box.esvo";
    ASSERT_EQ(voxelize({scene.string(), "-o", esvo.string(), "--depth", "6"}).exitCode, 0);
    const ProcessResult fromOctree = render(dir / "esvo.png", {"--esvo", esvo.string()});
    EXPECT_EQ(fromOctree.exitCode, 0) << fromOctree.err;
    EXPECT_NE(fromOctree.err.find("warning"), std::string::npos) << fromOctree.err;
    EXPECT_EQ(
        render(dir / "esvo.png", {"--esvo", esvo.string(), "--scene", scene.string()}).exitCode, 0);

    expectOneLineError(render(png, {}), 1, "--scene", "voxinspect");
    expectOneLineError(render(png, {"--scene", scene.string(), "--channel", "depth"}), 1,
                       "--channel", "voxinspect");
    expectOneLineError(render(png, {"--scene", scene.string(), "--beam", "4"}), 1, "--beam",
                       "voxinspect");
    expectOneLineError(render(png, {"--scene", scene.string(), "--spec-aperture", "0"}), 1,
                       "--spec-aperture", "voxinspect");
    expectOneLineError(render(png, {"--scene", scene.string(), "--exposure", "-1"}), 1,
                       "--exposure", "voxinspect");
    std::vector<std::string> esvoArgs{"render",     esvo.string(), "-o",
                                      png.string(), "--exposure",  "2"};
    esvoArgs.insert(esvoArgs.end(), camera.begin(), camera.end());
    expectOneLineError(voxinspect(esvoArgs), 1, "--exposure", "voxinspect");
}

TEST(Tools, RvolRenderTiledVolumeAcrossItsTiles) {
    ScratchDir dir;
    const auto scene = vox::scenes::writeCornellBox(dir.path());
    const auto index = dir / "tiled.rvol";
    const ProcessResult bake =
        voxelize({scene.string(), "--radiance", index.string(), "--radiance-depth", "6",
                  "--radiance-tile-depth", "4", "--bounces", "1"});
    ASSERT_EQ(bake.exitCode, 0) << bake.err;
    ASSERT_TRUE(vox::rvol::isTileIndex(index));
    const auto png = dir / "tiled.png";
    const auto render = [&](const std::filesystem::path& out, const std::string& threads) {
        std::vector<std::string> args{"render", index.string(), "--scene",   scene.string(),
                                      "-o",     out.string(),   "--threads", threads};
        args.insert(args.end(), kCornellCamera.begin(), kCornellCamera.end());
        return voxinspect(args);
    };
    ASSERT_NO_FATAL_FAILURE(expectCornellRender(render(png, "1"), png));
    // Tiles are opened as the cones first reach them, by whichever thread: the same image.
    const auto threaded = dir / "threaded.png";
    ASSERT_EQ(render(threaded, "2").exitCode, 0);
    EXPECT_EQ(readBytes(png), readBytes(threaded));
    // At most eight of the 57 tile files open: closed and reopened as the cones need them, the
    // same image.
    const auto bounded = dir / "bounded.png";
    const auto stats = dir / "bounded.json";
    std::vector<std::string> boundedArgs{"render",  index.string(),   "--scene",   scene.string(),
                                         "-o",      bounded.string(), "--threads", "2",
                                         "--stats", stats.string()};
    boundedArgs.insert(boundedArgs.end(), kCornellCamera.begin(), kCornellCamera.end());
    boundedArgs.insert(boundedArgs.end(), {"--max-open-tiles", "8"});
    ASSERT_EQ(voxinspect(boundedArgs).exitCode, 0);
    EXPECT_EQ(readBytes(png), readBytes(bounded));
    const auto openTiles = nlohmann::json::parse(vox::test::readText(stats))["open_tiles"];
    EXPECT_EQ(openTiles["max_open_tiles"], 8);
    EXPECT_LE(openTiles["most_open"].get<int>(), 8);
    EXPECT_GT(openTiles["closed"].get<int>(), 0);
    boundedArgs.back() = "0";
    expectOneLineError(voxinspect(boundedArgs), 1, "--max-open-tiles", "voxinspect");

    // A missing tile (the one holding most voxels: a wall the camera sees) is a file that cannot
    // be read: exit 2, one line naming it, no image.
    const vox::rvol::TileIndex tiles = vox::rvol::readTileIndex(index);
    const auto largest = std::max_element(
        tiles.tiles.begin(), tiles.tiles.end(),
        [](const auto& a, const auto& b) { return a.staticVoxels < b.staticVoxels; });
    ASSERT_NE(largest, tiles.tiles.end());
    const auto missing = vox::rvol::tilePath(index, largest->x, largest->y, largest->z);
    std::filesystem::remove(missing);
    std::filesystem::remove(png);
    expectOneLineError(render(png, "2"), 2, missing.string(), "voxinspect");
    EXPECT_FALSE(std::filesystem::exists(png));
    for (const std::string& name : dir.files())
        EXPECT_FALSE(vox::AtomicFile::isTemporaryName(name)) << name;
}

TEST(Tools, LightcutsLightTheBakeAndTheRenderAndReportTheirStatistics) {
    ScratchDir dir;
    const auto scene = vox::scenes::writeLightGrid(dir.path());
    const auto rvol = dir / "grid.rvol";
    const auto stats = dir / "bake.json";
    const ProcessResult bake =
        voxelize({scene.string(), "--radiance", rvol.string(), "--radiance-depth", "5", "--bounces",
                  "0", "--lightcuts", "on", "--lightcuts-compare", "--stats", stats.string()});
    ASSERT_EQ(bake.exitCode, 0) << bake.err;
    const auto report =
        nlohmann::json::parse(vox::test::readText(stats))["radiance"]["direct_light"];
    EXPECT_EQ(report["method"], "lightcuts");
    EXPECT_EQ(report["lights"], 256);
    EXPECT_EQ(report["criterion"], "rss");
    EXPECT_DOUBLE_EQ(report["relative_error"].get<double>(), 0.02);
    EXPECT_GT(report["trees"].get<int>(), 10);
    const auto& compare = report["compare"];
    EXPECT_EQ(compare["brute_force"]["method"], "brute-force");
    EXPECT_EQ(compare["classic"]["trees"], 1);
    EXPECT_GE(compare["lightcuts"]["error"]["fraction_within"].get<double>(), 0.99);
    EXPECT_LT(compare["search_steps_vs_classic"].get<double>(), -0.2);
    EXPECT_EQ(compare["lightcuts"]["points"], report["points"]);

    // The render's direct light through Lightcuts and summed over every light: the same image
    // within the error, and the statistics of the one used.
    const std::vector<std::string> camera{"--eye",   "0,20,28", "--target", "0,0,0",
                                          "--width", "40",      "--height", "30"};
    const auto render = [&](const std::filesystem::path& out, std::vector<std::string> extra) {
        std::vector<std::string> args{"render", rvol.string(), "--scene",   scene.string(),
                                      "-o",     out.string(),  "--channel", "direct"};
        args.insert(args.end(), camera.begin(), camera.end());
        args.insert(args.end(), extra.begin(), extra.end());
        return voxinspect(args);
    };
    const auto renderStats = dir / "render.json";
    ASSERT_EQ(
        render(dir / "on.png", {"--lightcuts", "on", "--stats", renderStats.string()}).exitCode, 0);
    ASSERT_EQ(render(dir / "off.png", {"--lightcuts", "off"}).exitCode, 0);
    const auto rendered = nlohmann::json::parse(vox::test::readText(renderStats));
    EXPECT_EQ(rendered["direct_light"]["method"], "lightcuts");
    EXPECT_EQ(rendered["direct_light"]["points"], rendered["hits"]);
    EXPECT_GT(rendered["direct_light"]["clusters"].get<int>(), 0);
    const vox::Texture on = vox::loadTexture(dir / "on.png", vox::ColorSpace::Linear);
    const vox::Texture off = vox::loadTexture(dir / "off.png", vox::ColorSpace::Linear);
    double diff = 0, sum = 0;
    for (int y = 0; y < on.height(); ++y)
        for (int x = 0; x < on.width(); ++x) {
            const vox::Vec4f a = on.texel(0, x, y), b = off.texel(0, x, y);
            diff += std::abs(a.x - b.x) + std::abs(a.y - b.y) + std::abs(a.z - b.z);
            sum += b.x + b.y + b.z;
        }
    EXPECT_GT(sum, 0.05 * on.width() * on.height());
    EXPECT_LT(diff, 0.01 * sum);

    expectOneLineError(voxelize({scene.string(), "--radiance", (dir / "x.rvol").string(),
                                 "--lightcuts", "always"}),
                       1, "--lightcuts");
    expectOneLineError(voxelize({scene.string(), "--radiance", (dir / "x.rvol").string(),
                                 "--lightcut-criterion", "max"}),
                       1, "--lightcut-criterion");
    expectOneLineError(render(dir / "x.png", {"--lightcut-error", "0"}), 1, "--lightcut-error",
                       "voxinspect");
    EXPECT_FALSE(std::filesystem::exists(dir / "x.rvol"));
    EXPECT_FALSE(std::filesystem::exists(dir / "x.png"));
}

TEST(Tools, RenderLightsTheMovingLightsTheBakeLeavesOut) {
    ScratchDir dir;
    const auto still = vox::scenes::writeCorridor(dir.path());
    const auto moving = vox::scenes::writeCorridorMoving(dir.path(), 0);
    const auto rvol = dir / "corridor.rvol";
    ASSERT_EQ(voxelize({moving.string(), "--radiance", rvol.string(), "--radiance-depth", "5",
                        "--bounces", "0"})
                  .exitCode,
              0);
    const std::vector<std::string> camera{"--eye",   "-29,1.6,0", "--target", "29,1.4,0",
                                          "--width", "32",        "--height", "32"};
    const auto direct = [&](const std::filesystem::path& scene, const std::string& name) {
        std::vector<std::string> args{"render", rvol.string(),         "--scene",   scene.string(),
                                      "-o",     (dir / name).string(), "--channel", "direct"};
        args.insert(args.end(), camera.begin(), camera.end());
        const ProcessResult r = voxinspect(args);
        EXPECT_EQ(r.exitCode, 0) << r.err;
        EXPECT_TRUE(r.err.empty()) << r.err;  // 30 static lights in both: the bake's count
        const vox::Texture image = vox::loadTexture(dir / name, vox::ColorSpace::Linear);
        double sum = 0;
        for (int y = 0; y < image.height(); ++y)
            for (int x = 0; x < image.width(); ++x) sum += image.texel(0, x, y).x;
        return sum;
    };
    // The two dynamic lights add direct light the still corridor lacks.
    EXPECT_GT(direct(moving, "moving.png"), 1.02 * direct(still, "still.png"));
}

// ---- Crash-safe outputs (issue 10) ------------------------------------------------------------
// voxelize is SIGKILLed while it writes an output: the previous output must be left as it was and
// nothing left behind may look like an output. Outputs go through AtomicFile: a temporary
// ".<name>.tmp-XXXXXX" beside the target, renamed into place once complete.

namespace {

/// A program started without waiting for it (stdout and stderr to @p log), so that a test can kill
/// it. Killed and reaped when destroyed, should a test stop early.
class StartedProcess {
public:
    StartedProcess(const std::filesystem::path& program, const std::vector<std::string>& args,
                   const std::filesystem::path& log) {
        posix_spawn_file_actions_t actions;
        posix_spawn_file_actions_init(&actions);
        posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log.c_str(),
                                         O_WRONLY | O_CREAT | O_TRUNC, 0644);
        posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
        std::vector<std::string> strings = {program.string()};
        strings.insert(strings.end(), args.begin(), args.end());
        std::vector<char*> argv;
        for (auto& s : strings) argv.push_back(s.data());
        argv.push_back(nullptr);
        const int spawned =
            posix_spawn(&pid_, program.c_str(), &actions, nullptr, argv.data(), environ);
        posix_spawn_file_actions_destroy(&actions);
        if (spawned != 0)
            throw std::runtime_error("cannot start " + program.string() + ": " +
                                     std::strerror(spawned));
    }
    ~StartedProcess() {
        if (running()) {
            ::kill(pid_, SIGKILL);
            wait();
        }
    }
    StartedProcess(const StartedProcess&) = delete;
    StartedProcess& operator=(const StartedProcess&) = delete;

    [[nodiscard]] pid_t pid() const { return pid_; }
    /// False once the process has ended (and been reaped).
    bool running() {
        if (ended_) return false;
        const pid_t r = ::waitpid(pid_, &status_, WNOHANG);
        if (r == pid_ || r < 0) ended_ = true;
        return !ended_;
    }
    /// Waits for the end; the raw waitpid status.
    int wait() {
        if (!ended_) {
            while (::waitpid(pid_, &status_, 0) < 0 && errno == EINTR) {}
            ended_ = true;
        }
        return status_;
    }

private:
    pid_t pid_ = -1;
    int status_ = 0;
    bool ended_ = false;
};

/// The AtomicFile temporary of @p output in its directory, or an empty path.
std::filesystem::path findTemporaryOf(const std::filesystem::path& output) {
    // Appended piecewise: GCC 12 reports a false -Wrestrict on chained string concatenation.
    std::string prefix = ".";
    prefix.append(output.filename().string()).append(".tmp-");
    std::error_code ec;
    for (const auto& entry : std::filesystem::directory_iterator(output.parent_path(), ec)) {
        const std::string name = entry.path().filename().string();
        if (name.rfind(prefix, 0) == 0 && vox::AtomicFile::isTemporaryName(name))
            return entry.path();
    }
    return {};
}

struct KilledWrite {
    std::filesystem::path
        temporary;  ///< the output's temporary, which existed when the kill was sent
    std::uintmax_t bytesAtKill = 0;  ///< its size then
    double secondsToKill = 0;
};

/// Starts voxelize with @p args and SIGKILLs it as soon as the temporary of @p output exists and
/// has data in it, i.e. while the output is being written. Fails (fatally) if voxelize ends first,
/// if the temporary does not show within @p timeoutSeconds, or if the process was not killed by the
/// signal.
void killDuringWrite(const std::vector<std::string>& args, const std::filesystem::path& output,
                     const std::filesystem::path& log, KilledWrite& killed,
                     int timeoutSeconds = 180) {
    const auto start = std::chrono::steady_clock::now();
    StartedProcess process(vox::test::voxelizePath(), args, log);
    const auto deadline = start + std::chrono::seconds(timeoutSeconds);
    for (;;) {
        const std::filesystem::path temporary = findTemporaryOf(output);
        std::error_code ec;
        const std::uintmax_t size =
            temporary.empty() ? 0 : std::filesystem::file_size(temporary, ec);
        if (!temporary.empty() && !ec && size > 0) {
            ASSERT_EQ(::kill(process.pid(), SIGKILL), 0) << std::strerror(errno);
            killed.temporary = temporary;
            killed.bytesAtKill = size;
            break;
        }
        ASSERT_TRUE(process.running())
            << "voxelize ended before the temporary of " << output << " was seen with data in it "
            << "(the write was too fast to catch: use a larger job); its output:\n"
            << vox::test::readText(log);
        ASSERT_LT(std::chrono::steady_clock::now(), deadline)
            << "no temporary of " << output << " with data in it after " << timeoutSeconds
            << " s; voxelize's output:\n"
            << vox::test::readText(log);
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    killed.secondsToKill =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const int status = process.wait();
    ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL)
        << "voxelize was not killed by SIGKILL (it finished first?); wait status " << status
        << "; its output:\n"
        << vox::test::readText(log);
    // Not vacuous: the temporary outlives the killed process, so it had not been renamed into
    // place.
    ASSERT_TRUE(std::filesystem::exists(killed.temporary))
        << killed.temporary << " is gone: the kill landed after the write, not during it";
}

bool endsWith(const std::string& text, const std::string& suffix) {
    return text.size() >= suffix.size() &&
           text.compare(text.size() - suffix.size(), suffix.size(), suffix) == 0;
}

/// Writes @p output (and --stats) with @p previousJob, kills voxelize while it writes @p output for
/// @p bigJob, and checks that the previous files are untouched, that whatever is left is a
/// temporary no one takes for an output, and that @p nextJob then replaces the outputs.
/// @p staleTemporaries: how many temporaries are left in the output directory after the next run
/// (none: it removes the killed run's).
void expectKillDuringWriteKeepsThePreviousOutput(
    const ScratchDir& dir, const std::string& outputOption, const std::string& outputName,
    const std::vector<std::string>& previousJob, const std::vector<std::string>& bigJob,
    const std::vector<std::string>& nextJob, std::size_t& staleTemporaries) {
    const auto scene = vox::scenes::writeCornellBox(dir / "scene");
    const auto outDir = dir / "out";
    std::filesystem::create_directories(outDir);
    const auto output = outDir / outputName;
    const auto stats = outDir / "stats.json";
    const auto run = [&](const std::vector<std::string>& job) {
        std::vector<std::string> args = {scene.string(), outputOption, output.string(), "--stats",
                                         stats.string()};
        args.insert(args.end(), job.begin(), job.end());
        return args;
    };

    const ProcessResult previous = voxelize(run(previousJob));
    ASSERT_EQ(previous.exitCode, 0) << previous.err;
    const auto previousOutput = readBytes(output);
    const auto previousStats = readBytes(stats);
    ASSERT_FALSE(previousOutput.empty());

    KilledWrite killed;
    ASSERT_NO_FATAL_FAILURE(killDuringWrite(run(bigJob), output, dir / "killed.log", killed));
    std::cout << "[          ] killed after " << killed.secondsToKill << " s with "
              << killed.bytesAtKill << " bytes in " << killed.temporary.filename().string() << "\n";

    EXPECT_TRUE(readBytes(output) == previousOutput) << "the previous " << outputName << " changed";
    EXPECT_TRUE(readBytes(stats) == previousStats) << "the previous stats.json changed";
    const ProcessResult stillValid = voxinspect({"validate", output.string()});
    EXPECT_EQ(stillValid.exitCode, 0) << stillValid.out << stillValid.err;
    for (const std::string& name : filesIn(outDir)) {
        if (name == outputName || name == "stats.json") continue;
        EXPECT_TRUE(vox::AtomicFile::isTemporaryName(name)) << "left behind: " << name;
        for (const char* extension : {".esvo", ".rvol", ".json", ".d"})
            EXPECT_FALSE(endsWith(name, extension)) << name << " is named like an output";
    }

    const ProcessResult next = voxelize(run(nextJob));
    ASSERT_EQ(next.exitCode, 0) << next.err;
    EXPECT_FALSE(readBytes(output) == previousOutput)
        << "the next run did not replace " << outputName;
    EXPECT_FALSE(readBytes(stats) == previousStats);
    const ProcessResult valid = voxinspect({"validate", output.string()});
    EXPECT_EQ(valid.exitCode, 0) << valid.out << valid.err;
    staleTemporaries = 0;
    for (const std::string& name : filesIn(outDir))
        if (vox::AtomicFile::isTemporaryName(name)) ++staleTemporaries;
    // The next run of the same output removes the killed run's temporary (no live writer holds
    // its lock) and leaves none of its own.
    EXPECT_EQ(staleTemporaries, 0u) << "a temporary is left after the next run";
}

}  // namespace

TEST(Tools, KilledWhileWritingAnEsvoLeavesThePreviousOutputUntouched) {
    ScratchDir dir;
    std::size_t stale = 0;
    // Depth 10 with raw attributes: about 95 MB of .esvo (a write of ~0.1 s to catch) after ~4 s of
    // voxelizing; raw rather than dxt skips a second of encoding before the write.
    expectKillDuringWriteKeepsThePreviousOutput(dir, "-o", "box.esvo", {"--depth", "5"},
                                                {"--depth", "10", "--attributes", "raw"},
                                                {"--depth", "6"}, stale);
    RecordProperty("stale_temporaries", static_cast<int>(stale));
}

TEST(Tools, KilledWhileWritingAnRvolLeavesThePreviousOutputUntouched) {
    ScratchDir dir;
    std::size_t stale = 0;
    // Radiance depth 8 without bounces: about 70 MB of .rvol after ~5 s of baking.
    expectKillDuringWriteKeepsThePreviousOutput(dir, "--radiance", "box.rvol",
                                                {"--radiance-depth", "4", "--bounces", "0"},
                                                {"--radiance-depth", "8", "--bounces", "0"},
                                                {"--radiance-depth", "5", "--bounces", "0"}, stale);
    RecordProperty("stale_temporaries", static_cast<int>(stale));
}
