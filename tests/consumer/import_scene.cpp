// Imports the scene given on the command line and prints its triangle count.
#include <vox/base/error.h>
#include <vox/import.h>
#include <vox/version.h>

#include <cstdio>

int main(int argc, char** argv) {
    if (argc != 2) return 1;
    try {
        const vox::Scene scene = vox::importScene(argv[1]);
        std::printf("libvox %s: %zu triangles\n", LIBVOX_VERSION_STRING, scene.triangleCount());
        return 0;
    } catch (const vox::Error& e) {
        std::fprintf(stderr, "%s\n", e.what());
        return static_cast<int>(e.exitCode());
    }
}
