// Streams the .esvo given on the command line to the GPU (a headless EGL context), casts one
// 64×64 frame at the root cube from +z and prints how many pixels hit.
#include <vox/base/camera.h>
#include <vox/base/error.h>
#include <vox/runtime/esvo_stream.h>
#include <vox/runtime/gl_context.h>

#include <cstdio>

int main(int argc, char** argv) {
    if (argc != 2) return 1;
    try {
        vox::runtime::HeadlessGlContext context;
        vox::runtime::EsvoStream stream(context, argv[1]);
        // The writer's world-to-root transform is a uniform scale and a translation.
        const auto& m = stream.reader().header().worldToRoot;
        const double scale = m[0];
        const vox::Vec3d centre{(0.5 - m[3]) / scale, (0.5 - m[7]) / scale,
                                (0.5 - m[11]) / scale};
        vox::PinholeCamera camera;
        camera.target = centre;
        camera.eye = centre + vox::Vec3d{0, 0, 2 / scale};
        camera.width = camera.height = 64;
        stream.setCamera(camera);
        stream.update();
        const vox::runtime::GpuFrame frame = stream.render(stream.castOptions());
        std::size_t hits = 0;
        for (std::size_t i = 0; i < frame.depth.size(); ++i) hits += frame.hit(i) ? 1 : 0;
        std::printf("%zu of %zu pixels hit on %s\n", hits, frame.depth.size(),
                    context.renderer().c_str());
        return 0;
    } catch (const vox::Error& e) {
        std::fprintf(stderr, "%s\n", e.what());
        return static_cast<int>(e.exitCode());
    }
}
