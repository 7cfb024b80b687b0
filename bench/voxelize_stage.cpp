// The voxelization stage alone (vox::voxelizeSurface with voxelize's default options: contours and
// attributes), without the .esvo writer and its attribute compression: for profiling the
// SubtreeBuilder kernels under callgrind or perf, and for checking that a change leaves the octree
// bit for bit as it was (the printed FNV-1a digest covers masks, contours, attributes and counts).
// Usage: voxelize_stage SCENE [--depth N] [--contour-error E] [--color-error C] [--normal-error D]
//        [--no-contours] [--no-attributes] [--repeat R] [--threads T]
#include <vox/import.h>
#include <vox/octree.h>
#include <vox/scene.h>
#include <vox/util/parallel.h>
#include <vox/util/timings.h>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <stdexcept>
#include <string>

namespace {

struct Digest {
    std::uint64_t h = 1469598103934665603ull;
    void bytes(const void* data, std::size_t n) {
        const auto* p = static_cast<const unsigned char*>(data);
        for (std::size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 1099511628211ull;
    }
    template <typename T>
    void vec(const std::vector<T>& v) {
        const std::uint64_t n = v.size();
        bytes(&n, sizeof n);
        if (!v.empty()) bytes(v.data(), v.size() * sizeof(T));
    }
};

}  // namespace

int main(int argc, char** argv) {
    try {
        if (argc < 2) {
            std::fprintf(stderr,
                         "usage: voxelize_stage SCENE [--depth N] [--contour-error E] "
                         "[--color-error C] [--normal-error D] "
                         "[--no-contours] [--no-attributes] [--repeat R] [--threads T]\n");
            return 2;
        }
        vox::SurfaceVoxelizeOptions options;
        options.contours = true;
        options.attributes = true;
        int repeat = 1, threads = 0;
        for (int i = 2; i < argc; ++i) {
            const std::string arg = argv[i];
            const auto value = [&] {
                if (i + 1 >= argc) throw std::runtime_error(arg + " needs a value");
                return std::strtod(argv[++i], nullptr);
            };
            if (arg == "--depth")
                options.depth = static_cast<std::uint32_t>(value());
            else if (arg == "--contour-error")
                options.contourError = value();
            else if (arg == "--color-error")
                options.colorError = value();
            else if (arg == "--normal-error")
                options.normalErrorDegrees = value();
            else if (arg == "--no-contours")
                options.contours = false;
            else if (arg == "--no-attributes")
                options.attributes = false;
            else if (arg == "--repeat")
                repeat = static_cast<int>(value());
            else if (arg == "--threads")
                threads = static_cast<int>(value());
            else
                throw std::runtime_error("unknown option " + arg);
        }
        const vox::ThreadLimit limit(threads);
        const vox::Scene scene = vox::importScene(argv[1], vox::ImportOptions{});
        for (int r = 0; r < repeat; ++r) {
            vox::Timings timings;
            options.timings = &timings;
            const auto start = std::chrono::steady_clock::now();
            const vox::SparseOctree octree = vox::voxelizeSurface(scene, options);
            const double ms =
                std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
                    .count();
            Digest digest;
            digest.vec(octree.voxelsPerLevel);
            for (const auto& level : octree.masks) digest.vec(level);
            for (const auto& level : octree.contours) digest.vec(level);
            for (const auto& level : octree.attributes) digest.vec(level);
            std::printf("depth %u: %llu voxels, digest %016llx, voxelizeSurface %.1f ms",
                        octree.leafDepth, static_cast<unsigned long long>(octree.voxelCount()),
                        static_cast<unsigned long long>(digest.h), ms);
            for (const auto& [name, value] : timings.entries())
                std::printf(", %s %.1f ms", name.c_str(), value);
            std::printf("\n");
        }
        return 0;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "voxelize_stage: %s\n", e.what());
        return 1;
    }
}
