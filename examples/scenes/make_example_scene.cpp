// Writes libvox's example scenes.
// Usage: make_example_scene [cornell-box | bumpy-sphere | sphere [--rings R --segments S]] [-o DIR] [--glb]
#include "bumpy_sphere.h"
#include "cornell_box.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

int main(int argc, char** argv) {
    std::filesystem::path directory = ".";
    vox::scenes::BufferStorage storage = vox::scenes::BufferStorage::External;
    std::string scene = "cornell-box";
    int rings = 513, segments = 1024;  // 1,048,576 triangles
    for (int i = 1; i < argc; ++i) {
        const std::string arg = argv[i];
        if ((arg == "-o" || arg == "--output") && i + 1 < argc) {
            directory = argv[++i];
        } else if (arg == "--glb") {
            storage = vox::scenes::BufferStorage::Glb;
        } else if (arg == "cornell-box" || arg == "bumpy-sphere" || arg == "sphere") {
            scene = arg;
        } else if (arg == "--rings" && i + 1 < argc) {
            rings = std::max(3, std::atoi(argv[++i]));
        } else if (arg == "--segments" && i + 1 < argc) {
            segments = std::max(3, std::atoi(argv[++i]));
        } else {
            std::fprintf(stderr, "make_example_scene: error: unknown argument '%s'\nusage: make_example_scene [cornell-box | bumpy-sphere | sphere [--rings R --segments S]] [-o DIR] [--glb]\n", argv[i]);
            return 1;
        }
    }
    try {
        const auto file = scene == "cornell-box" ? vox::scenes::writeCornellBox(directory, storage)
                                                 : vox::scenes::writeBumpySphere(directory, rings, segments, scene == "bumpy-sphere");
        std::printf("%s\n", file.string().c_str());
    } catch (const std::exception& e) {
        std::fprintf(stderr, "make_example_scene: error: %s\n", e.what());
        return 2;
    }
    return 0;
}
