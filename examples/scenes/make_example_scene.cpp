// Writes libvox's example scenes.
// Usage: make_example_scene [cornell-box | bumpy-sphere | sphere [--rings R --segments S] |
//                            corridor | corridor-moving [--frame N] | corridor-strips |
//                            light-grid [--lights-per-side N] |
//                            city-block [--blocks-per-side N]] [-o DIR] [--glb]
#include "bumpy_sphere.h"
#include "city_block.h"
#include "cornell_box.h"
#include "corridor.h"
#include "light_grid.h"

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

namespace {

constexpr const char* kUsage =
    "usage: make_example_scene [cornell-box | bumpy-sphere | sphere [--rings R --segments S] |\n"
    "                           corridor | corridor-moving [--frame N] | corridor-strips |\n"
    "                           light-grid [--lights-per-side N] |\n"
    "                           city-block [--blocks-per-side N]] [-o DIR] [--glb]\n";

int usageError(const std::string& message) {
    std::fprintf(stderr, "make_example_scene: error: %s\n%s", message.c_str(), kUsage);
    return 1;
}

/// A non-negative decimal integer, or -1.
int parseCount(const char* text) {
    char* end = nullptr;
    errno = 0;
    const long value = std::strtol(text, &end, 10);
    if (end == text || *end != '\0' || errno != 0 || value < 0 || value > INT_MAX) return -1;
    return static_cast<int>(value);
}

}  // namespace

int main(int argc, char** argv) {
    std::filesystem::path directory = ".";
    vox::scenes::BufferStorage storage = vox::scenes::BufferStorage::External;
    std::string scene = "cornell-box";
    int rings = 513, segments = 1024;  // 1,048,576 triangles
    int frame = -1;
    int lightsPerSide = -1;
    int blocksPerSide = -1;
    for (int i = 1; i < argc; ++i) {
        const std::string arg = argv[i];
        if ((arg == "-o" || arg == "--output") && i + 1 < argc) {
            directory = argv[++i];
        } else if (arg == "--glb") {
            storage = vox::scenes::BufferStorage::Glb;
        } else if (arg == "cornell-box" || arg == "bumpy-sphere" || arg == "sphere" ||
                   arg == "corridor" || arg == "corridor-moving" || arg == "corridor-strips" ||
                   arg == "light-grid" || arg == "city-block") {
            scene = arg;
        } else if (arg == "--rings" && i + 1 < argc) {
            rings = std::max(3, std::atoi(argv[++i]));
        } else if (arg == "--segments" && i + 1 < argc) {
            segments = std::max(3, std::atoi(argv[++i]));
        } else if (arg == "--frame" && i + 1 < argc) {
            frame = parseCount(argv[++i]);
            if (frame < 0)
                return usageError(std::string("--frame needs a non-negative integer, not '") +
                                  argv[i] + "'");
        } else if (arg == "--lights-per-side" && i + 1 < argc) {
            lightsPerSide = parseCount(argv[++i]);
            if (lightsPerSide < 1)
                return usageError(std::string("--lights-per-side needs a positive integer, not '") +
                                  argv[i] + "'");
        } else if (arg == "--blocks-per-side" && i + 1 < argc) {
            blocksPerSide = parseCount(argv[++i]);
            if (blocksPerSide < 1 || blocksPerSide > vox::scenes::CityBlockFacts::kMaxBlocksPerSide)
                return usageError(std::string("--blocks-per-side needs an integer from 1 to ") +
                                  std::to_string(vox::scenes::CityBlockFacts::kMaxBlocksPerSide) +
                                  ", not '" + argv[i] + "'");
        } else {
            return usageError("unknown argument '" + arg + "'");
        }
    }
    if (frame >= 0 && scene != "corridor-moving")
        return usageError("--frame applies to corridor-moving only");
    if (lightsPerSide >= 0 && scene != "light-grid")
        return usageError("--lights-per-side applies to light-grid only");
    if (blocksPerSide >= 0 && scene != "city-block")
        return usageError("--blocks-per-side applies to city-block only");
    try {
        std::filesystem::path file;
        if (scene == "cornell-box")
            file = vox::scenes::writeCornellBox(directory, storage);
        else if (scene == "corridor")
            file = vox::scenes::writeCorridor(directory, storage);
        else if (scene == "corridor-moving")
            file = vox::scenes::writeCorridorMoving(directory, std::max(frame, 0), storage);
        else if (scene == "corridor-strips")
            file = vox::scenes::writeCorridorStrips(directory, storage);
        else if (scene == "light-grid")
            file = vox::scenes::writeLightGrid(
                directory, storage,
                lightsPerSide > 0 ? lightsPerSide : vox::scenes::LightGridFacts::kLightsPerSide);
        else if (scene == "city-block")
            file = vox::scenes::writeCityBlock(
                directory, storage,
                blocksPerSide > 0 ? blocksPerSide : vox::scenes::CityBlockFacts::kBlocksPerSide);
        else
            file =
                vox::scenes::writeBumpySphere(directory, rings, segments, scene == "bumpy-sphere");
        std::printf("%s\n", file.string().c_str());
    } catch (const std::exception& e) {
        std::fprintf(stderr, "make_example_scene: error: %s\n", e.what());
        return 2;
    }
    return 0;
}
