// Writes libvox's example scenes. Usage: make_example_scene [cornell-box] [-o DIR] [--glb]
#include "cornell_box.h"

#include <cstdio>
#include <cstring>
#include <string>

int main(int argc, char** argv) {
    std::filesystem::path directory = ".";
    vox::scenes::BufferStorage storage = vox::scenes::BufferStorage::External;
    for (int i = 1; i < argc; ++i) {
        const std::string arg = argv[i];
        if ((arg == "-o" || arg == "--output") && i + 1 < argc) {
            directory = argv[++i];
        } else if (arg == "--glb") {
            storage = vox::scenes::BufferStorage::Glb;
        } else if (arg == "cornell-box") {
        } else {
            std::fprintf(stderr, "make_example_scene: error: unknown argument '%s'\nusage: make_example_scene [cornell-box] [-o DIR] [--glb]\n", argv[i]);
            return 1;
        }
    }
    try {
        const auto file = vox::scenes::writeCornellBox(directory, storage);
        std::printf("%s\n", file.string().c_str());
    } catch (const std::exception& e) {
        std::fprintf(stderr, "make_example_scene: error: %s\n", e.what());
        return 2;
    }
    return 0;
}
