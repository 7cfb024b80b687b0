// voxview: renders an .esvo octree with the OpenGL runtime (vox::runtime), headless through EGL,
// to a PNG. Its camera options and channels are voxinspect render's, so the two images of the
// same view compare pixel for pixel. Exit codes as the tools: 0 ok, 1 usage, 2 cannot read or
// write a file, 3 invalid input data, 4 no usable OpenGL 4.5 or an internal error.
#include "png_writer.h"

#include <vox/formats/atomic_file.h>
#include <vox/formats/error.h>
#include <vox/formats/esvo_reader.h>
#include <vox/runtime/channels.h>
#include <vox/runtime/esvo_gpu_pool.h>
#include <vox/runtime/esvo_gpu_raycaster.h>
#include <vox/runtime/esvo_stream.h>
#include <vox/runtime/gl_context.h>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <new>

namespace {

vox::runtime::Vec3d parseVector(const std::string& text, const char* option) {
    vox::runtime::Vec3d v{};
    char tail = 0;
    if (std::sscanf(text.c_str(), "%lf,%lf,%lf%c", &v[0], &v[1], &v[2], &tail) != 3 || !std::isfinite(v[0]) ||
        !std::isfinite(v[1]) || !std::isfinite(v[2]))
        throw vox::UsageError(std::string(option) + " expects x,y,z (got '" + text + "')");
    return v;
}

struct Options {
    std::string file, output, stats, channel = "depth";
    std::string eye, target, up = "0,1,0";
    double fov = 60, lodScale = 1.0;
    int width = 512, height = 512, frames = 1;
    unsigned maxLevel = 0xFFFFFFFFu;
    bool headless = false, quiet = false;
    double budgetMb = 256, frameLoadMb = 0;
    std::string cameraPath, upload = "ring";
};

constexpr double kPi = 3.14159265358979323846;

/// The camera of each frame: the given one, an orbit around the target at the eye's distance and
/// height ("orbit"), or a file of lines "ex,ey,ez tx,ty,tz" (one per frame, repeated if short).
std::vector<vox::runtime::Camera> cameraPath(const Options& o, const vox::runtime::Camera& camera) {
    std::vector<vox::runtime::Camera> path;
    if (o.cameraPath.empty()) return std::vector<vox::runtime::Camera>(std::size_t(o.frames), camera);
    if (o.cameraPath == "orbit") {
        const double dx = camera.eye[0] - camera.target[0], dz = camera.eye[2] - camera.target[2];
        const double radius = std::hypot(dx, dz), start = std::atan2(dx, dz);
        for (int f = 0; f < o.frames; ++f) {
            vox::runtime::Camera c = camera;
            const double a = start + 2 * kPi * f / o.frames;
            c.eye = {camera.target[0] + radius * std::sin(a), camera.eye[1], camera.target[2] + radius * std::cos(a)};
            path.push_back(c);
        }
        return path;
    }
    std::ifstream in(o.cameraPath);
    if (!in) throw vox::IoError(o.cameraPath, "cannot open the camera path");
    std::string eye, target;
    std::vector<vox::runtime::Camera> keys;
    while (in >> eye >> target) {
        vox::runtime::Camera c = camera;
        c.eye = parseVector(eye, "--camera-path");
        c.target = parseVector(target, "--camera-path");
        c.validate();
        keys.push_back(c);
    }
    if (keys.empty()) throw vox::InvalidDataError(o.cameraPath, "no camera in the path (lines: ex,ey,ez tx,ty,tz)");
    for (int f = 0; f < o.frames; ++f) path.push_back(keys[std::size_t(f) % keys.size()]);
    return path;
}

void run(const Options& o) {
    if (!o.headless) throw vox::UsageError("--headless is required: this voxview has no window (it renders to -o FILE.png)");
    if (!vox::runtime::isChannel(o.channel))
        throw vox::UsageError("--channel must be depth, normal, face-normal, color, shaded, iterations or level");
    if (!(o.lodScale >= 0)) throw vox::UsageError("--lod-scale must be 0 or more");
    vox::runtime::Camera camera;
    camera.eye = parseVector(o.eye, "--eye");
    camera.target = parseVector(o.target, "--target");
    camera.up = parseVector(o.up, "--up");
    camera.fovYDegrees = o.fov;
    camera.width = o.width;
    camera.height = o.height;
    camera.validate();

    if (!(o.budgetMb > 0) || !(o.frameLoadMb >= 0)) throw vox::UsageError("--budget must be positive and --frame-load 0 or more");
    if (o.upload != "ring" && o.upload != "subdata") throw vox::UsageError("--upload must be ring or subdata");
    const std::vector<vox::runtime::Camera> path = cameraPath(o, camera);

    const auto start = std::chrono::steady_clock::now();
    vox::runtime::HeadlessGlContext context;
    vox::runtime::EsvoStreamOptions streamOptions;
    streamOptions.budgetBytes = std::uint64_t(o.budgetMb * 1048576.0);
    streamOptions.frameLoadBytes = std::uint64_t(o.frameLoadMb * 1048576.0);
    streamOptions.lodScale = o.lodScale > 0 ? o.lodScale : 1.0;
    streamOptions.uploadPath = o.upload == "ring" ? vox::runtime::UploadPath::PersistentRing : vox::runtime::UploadPath::BufferSubData;
    vox::runtime::EsvoStream stream(context, o.file, streamOptions);
    const vox::esvo::EsvoReader& reader = stream.reader();
    if ((o.channel == "color") && !reader.header().hasAttributes())
        throw vox::UsageError(o.file + ": no colours in this file (voxelize --attributes none)");
    const auto loaded = std::chrono::steady_clock::now();

    vox::runtime::GpuCastOptions options;
    options.maxLevel = o.maxLevel;
    options.attributes = vox::runtime::channelNeedsAttributes(o.channel);
    vox::runtime::GpuFrame frame;
    std::vector<double> gpuMs, wallMs, updateMs;
    nlohmann::json perFrame = nlohmann::json::array();
    std::uint64_t maxResident = 0, slicesLoaded = 0, slicesEvicted = 0;
    int fullDetailFrame = -1;
    for (int f = 0; f < o.frames; ++f) {
        stream.setCamera(path[std::size_t(f)]);
        const vox::runtime::EsvoStreamUpdate update = stream.update();
        options.lodAngle = path[std::size_t(f)].pixelAngle() * o.lodScale;
        frame = stream.render(options);
        gpuMs.push_back(frame.gpuMilliseconds);
        wallMs.push_back(frame.wallMilliseconds);
        updateMs.push_back(update.seconds * 1e3);
        maxResident = std::max(maxResident, update.residentBytes);
        slicesLoaded += update.loaded;
        slicesEvicted += update.evicted;
        if (fullDetailFrame < 0 && update.pending == 0) fullDetailFrame = f;
        perFrame.push_back({{"resident_bytes", update.residentBytes},
                            {"uploaded_bytes", update.uploadedBytes},
                            {"slices_loaded", update.loaded},
                            {"slices_evicted", update.evicted},
                            {"slices_pending", update.pending},
                            {"slices_over_budget", update.neededNotFitting},
                            {"update_ms", update.seconds * 1e3},
                            {"cast_wall_ms", frame.wallMilliseconds},
                            {"cast_gpu_ms", frame.gpuMilliseconds},
                            {"hits", frame.hits}});
        context.throwOnErrors("frame " + std::to_string(f));
    }
    const vox::esvo::EsvoPool& pool = stream.pool();
    const vox::runtime::EsvoGpuPool& gpuPool = stream.gpuPool();
    const auto rendered = std::chrono::steady_clock::now();
    voxview::writePngRgb8(o.output, frame.width, frame.height, vox::runtime::composeChannel(frame, camera, o.channel));
    if (!o.quiet)
        std::fprintf(stderr, "voxview: %s: %dx%d, %llu hits, %.3f ms GPU timer, %.3f ms wall (%s, EGL %s)\n", o.output.c_str(),
                     frame.width, frame.height, static_cast<unsigned long long>(frame.hits), frame.gpuMilliseconds,
                     frame.wallMilliseconds, context.renderer().c_str(), context.platformName());
    if (!o.stats.empty()) {
        const auto median = [](std::vector<double> v) {
            std::sort(v.begin(), v.end());
            return v[v.size() / 2];
        };
        std::uint64_t iterations = 0;
        for (std::uint32_t it : frame.iterations) iterations += it;
        const double pixels = double(frame.width) * double(frame.height);
        const nlohmann::json report{
            {"tool", "voxview"},
            {"file", o.file},
            {"renderer", context.renderer()},
            {"gl_version", context.version()},
            {"gl_vendor", context.vendor()},
            {"egl_platform", context.platformName()},
            {"channel", o.channel},
            {"width", frame.width},
            {"height", frame.height},
            {"rays", frame.width * frame.height},
            {"hits", frame.hits},
            {"mean_iterations", double(iterations) / pixels},
            {"frames", o.frames},
            {"gpu_ms_per_frame", gpuMs},
            {"gpu_ms_median", median(gpuMs)},
            // Dispatch to glFinish on the host: what llvmpipe can be timed by (its GL_TIME_ELAPSED
            // does not cover compute work and reads ~0).
            {"wall_ms_per_frame", wallMs},
            {"wall_ms_median", median(wallMs)},
            {"mrays_per_second", pixels / (median(wallMs) * 1e-3) / 1e6},
            {"loaded_slices", pool.loadedSliceCount()},
            {"resident_bytes", pool.residentBytes()},
            {"max_resident_bytes", maxResident},
            {"budget_bytes", streamOptions.budgetBytes},
            {"slices_loaded", slicesLoaded},
            {"slices_evicted", slicesEvicted},
            // The first frame whose view had every slice it needs (within the budget); -1: none.
            {"full_detail_frame", fullDetailFrame},
            {"upload_path", o.upload},
            {"update_ms_per_frame", updateMs},
            {"per_frame", perFrame},
            {"gpu_pool_bytes", gpuPool.capacityBytes()},
            {"uploaded_bytes", gpuPool.uploadedBytesTotal()},
            {"gl_errors", context.errorCount()},
            {"timings_ms",
             {{"load", std::chrono::duration<double, std::milli>(loaded - start).count()},
              {"gl_and_render", std::chrono::duration<double, std::milli>(rendered - loaded).count()}}}};
        vox::writeFileAtomically(o.stats, report.dump(2) + "\n");
    }
}

}  // namespace

int main(int argc, char** argv) {
    Options o;
    CLI::App app{"voxview: render an .esvo octree with the OpenGL 4.5 runtime (headless, EGL) to a PNG"};
    app.add_option("file", o.file, ".esvo file")->required();
    app.add_flag("--headless", o.headless, "Render without a window, through EGL (required)");
    app.add_option("-o,--output", o.output, "PNG to write")->required();
    app.add_option("--eye", o.eye, "Camera position x,y,z (world units)")->required();
    app.add_option("--target", o.target, "Point looked at x,y,z")->required();
    app.add_option("--up", o.up, "Up vector x,y,z")->capture_default_str();
    app.add_option("--fov", o.fov, "Vertical field of view, degrees")->capture_default_str();
    app.add_option("--width", o.width, "Image width")->capture_default_str();
    app.add_option("--height", o.height, "Image height")->capture_default_str();
    app.add_option("--channel", o.channel, "shaded, color, normal, face-normal, depth, iterations or level (as voxinspect render)")
        ->capture_default_str();
    app.add_option("--lod-scale", o.lodScale, "Stop at voxels smaller than this many pixels; 0: always to the leaves")
        ->capture_default_str();
    app.add_option("--max-level", o.maxLevel, "Treat voxels of this level as leaves");
    app.add_option("--frames", o.frames, "Render this many frames (timing); the last is written")->check(CLI::Range(1, 10000));
    app.add_option("--budget", o.budgetMb, "GPU memory budget for the octree's slices, MB")->capture_default_str();
    app.add_option("--frame-load", o.frameLoadMb, "Most MB of slices loaded per frame (0: all the view needs)")->capture_default_str();
    app.add_option("--camera-path", o.cameraPath,
                   "Camera per frame: 'orbit' (around --target at --eye's distance and height, over --frames) or a file of "
                   "lines 'ex,ey,ez tx,ty,tz'");
    app.add_option("--upload", o.upload, "Upload path: ring (persistently mapped staging ring with fences) or subdata (glBufferSubData)")
        ->capture_default_str();
    app.add_option("--stats", o.stats, "Write a JSON report: renderer, frame times, hits, resident and uploaded bytes per frame");
    app.add_flag("-q,--quiet", o.quiet, "Print errors only");
    try {
        app.parse(argc, argv);
    } catch (const CLI::Success& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        // CLI11's own codes are 100+; every usage problem is exit code 1, as in the tools.
        std::fprintf(stderr, "voxview: error: %s (see --help)\n", e.what());
        return static_cast<int>(vox::ExitCode::Usage);
    }
    try {
        run(o);
        return 0;
    } catch (const vox::Error& e) {
        std::fprintf(stderr, "voxview: error: %s\n", e.what());
        return static_cast<int>(e.exitCode());
    } catch (const std::bad_alloc&) {
        std::fprintf(stderr, "voxview: error: out of memory\n");
        return static_cast<int>(vox::ExitCode::Internal);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "voxview: error: internal error: %s\n", e.what());
        return static_cast<int>(vox::ExitCode::Internal);
    }
}
