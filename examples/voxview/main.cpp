// voxview: renders an .esvo octree with the OpenGL runtime (vox::runtime), headless through EGL,
// to a PNG. Its camera options and channels are voxinspect render's, so the two images of the
// same view compare pixel for pixel. With --rvol FILE.rvol it draws the radiance volume's final
// gather at the octree's primary hits (FinalGatherGpu over an RvolGpuVolume), as
// `voxinspect render FILE.rvol --esvo FILE.esvo --scene SCENE` does on the CPU. Exit codes as the
// tools: 0 ok, 1 usage, 2 cannot read or write a file, 3 invalid input data, 4 no usable OpenGL
// 4.5 or an internal error.
//
// The lights: the runtime library takes punctual lights (vox::PunctualLight, which vox::Light
// extends) and links no scene importer; an application brings its own. voxview reads them from
// --scene with libvox's vox::importScene, which is why this example (not vox::runtime) links
// vox::core.
#include "png_writer.h"
#include "window.h"

#include <vox/formats/atomic_file.h>
#include <vox/base/error.h>
#include <vox/formats/esvo_attributes.h>
#include <vox/formats/esvo_reader.h>
#include <vox/formats/rvol_io.h>
#include <vox/formats/rvol_tiles.h>
#include <vox/import.h>  // vox::import: the lights of --scene
#include <vox/runtime/channels.h>
#include <vox/runtime/esvo_gpu_pool.h>
#include <vox/runtime/esvo_gpu_raycaster.h>
#include <vox/runtime/esvo_stream.h>
#include <vox/runtime/final_gather_gpu.h>
#include <vox/runtime/gl_context.h>
#include <vox/runtime/rvol_residency.h>
#include <vox/runtime/rvol_gpu_volume.h>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <new>
#include <optional>

namespace {

vox::Vec3d parseVector(const std::string& text, const char* option) {
    if (const auto v = vox::parseVec3(text)) return *v;
    throw vox::UsageError(std::string(option) + " expects x,y,z (got '" + text + "')");
}

struct Options {
    std::string file, output, stats, channel = "depth";
    std::string eye, target, up = "0,1,0";
    double fov = 60, lodScale = 1.0;
    int width = 512, height = 512, frames = 1;
    unsigned maxLevel = 0xFFFFFFFFu;
    bool headless = false, quiet = false, framesGiven = false;
    double budgetMb = 256, frameLoadMb = 0, rvolBudgetMb = 0;
    unsigned rvolMaxOpenTiles = vox::rvol::TiledRvolReaderOptions{}.maxOpenTiles;
    std::string cameraPath, upload = "ring";
    // The final gather (--rvol).
    std::string rvol, scene, gatherFilter = "hardware";
    double exposure = 1, specAperture = 10, shadowAperture = 10;
    bool noShadowCones = false, channelGiven = false;
    std::string eglPlatform = "auto";
    int benchmarkFrames =
        0;  // --benchmark N: N timed frames after one warm-up, one JSON line on stdout
};

namespace rt = vox::runtime;

/// The final gather's channels (voxinspect render FILE.rvol's): with --rvol, "normal" is the
/// shading point's normal as there; the octree's other channels stay available.
const std::array<std::string, 7> kGatherChannels{"final", "direct", "indirect", "specular",
                                                 "ao",    "albedo", "normal"};
bool isGatherChannel(const std::string& channel) {
    return std::find(kGatherChannels.begin(), kGatherChannels.end(), channel) !=
           kGatherChannels.end();
}

/// voxinspect's 8-bit conversions (tools/voxinspect/rvol_commands.cpp), to the bit.
std::uint8_t toByte(float v) {
    return static_cast<std::uint8_t>(std::lround(255.0f * std::clamp(v, 0.0f, 1.0f)));
}
/// exposure × linear radiance, Reinhard x/(1 + x) per channel, sRGB-encoded to 8 bits.
std::uint8_t toneMap(double linear, double exposure) {
    const double x = std::max(0.0, exposure * linear);
    return toByte(vox::linearToSrgb(static_cast<float>(x / (1 + x))));
}

/// The shading points of a frame's hits, built as libvox's esvoShadingPoint builds them from a
/// CPU hit (libvox/src/radiance/final_gather.cpp), in double then rounded to float: position =
/// eye + direction·t (t the float depth), normal = the shading normal where the voxel has
/// attributes, else the face normal, turned to face the ray and normalised; albedo = the colour
/// word's sRGB → linear, or 0.8 grey without attributes; no emission; view = −direction.
struct ShadingPoints {
    std::vector<std::size_t> pixels;  ///< the hit pixels, in order
    std::vector<rt::GpuShadingPoint> points;
};

ShadingPoints shadingPoints(const rt::GpuFrame& frame, const vox::PinholeCamera& camera) {
    using V = vox::Vec3d;
    const auto dot = [](const V& a, const V& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; };
    const auto f3 = [](const V& v) { return vox::vec3Cast<float>(v); };
    const vox::CameraBasis basis(camera);
    ShadingPoints out;
    out.pixels.reserve(frame.hits);
    out.points.reserve(frame.hits);
    for (int y = 0; y < frame.height; ++y)
        for (int x = 0; x < frame.width; ++x) {
            const std::size_t i = std::size_t(y) * std::size_t(frame.width) + std::size_t(x);
            if (!frame.hit(i)) continue;
            const V d = basis.direction(x, y);
            const double t = double(frame.depth[i]);
            rt::GpuShadingPoint p;
            p.position =
                f3({basis.eye[0] + d[0] * t, basis.eye[1] + d[1] * t, basis.eye[2] + d[2] * t});
            V side{double(frame.normal[3 * i]), double(frame.normal[3 * i + 1]),
                   double(frame.normal[3 * i + 2])};
            if (dot(side, d) > 0) side = {-side[0], -side[1], -side[2]};
            const bool attributes = frame.hasAttributes(i);
            V n = attributes ? V{double(frame.shadingNormal[3 * i]),
                                 double(frame.shadingNormal[3 * i + 1]),
                                 double(frame.shadingNormal[3 * i + 2])}
                             : side;
            if (dot(n, side) < 0) n = {-n[0], -n[1], -n[2]};
            const double len = std::sqrt(dot(n, n));
            p.normal = len > 0 ? f3({n[0] / len, n[1] / len, n[2] / len}) : vox::Vec3f{0, 0, 0};
            if (attributes) {
                for (unsigned k = 0; k < 3; ++k)
                    p.albedo[k] = vox::srgbToLinear(
                        float(vox::esvo::colorChannel(frame.color[i], k)) / 255.0f);
            } else {
                p.albedo = {0.8f, 0.8f, 0.8f};
            }
            p.emission = {0, 0, 0};
            p.view = f3({-d[0], -d[1], -d[2]});
            out.pixels.push_back(i);
            out.points.push_back(p);
        }
    return out;
}

/// voxinspect render's pixels for a final-gather channel: black where nothing is hit.
std::vector<std::uint8_t> composeGather(const rt::GpuFrame& frame, const ShadingPoints& sp,
                                        const std::vector<rt::GpuGatherParts>& parts,
                                        const std::string& channel, double exposure) {
    std::vector<std::uint8_t> rgb(3 * std::size_t(frame.width) * std::size_t(frame.height), 0);
    for (std::size_t k = 0; k < sp.pixels.size(); ++k) {
        std::uint8_t* p = &rgb[3 * sp.pixels[k]];
        const rt::GpuGatherParts& g = parts[k];
        const vox::Vec3f* radiance = channel == "final"      ? &g.final
                                     : channel == "direct"   ? &g.direct
                                     : channel == "indirect" ? &g.indirect
                                     : channel == "specular" ? &g.specular
                                                             : nullptr;
        if (radiance) {
            for (std::size_t c = 0; c < 3; ++c) p[c] = toneMap(double((*radiance)[c]), exposure);
        } else if (channel == "ao") {
            p[0] = p[1] = p[2] = toByte(g.ao);
        } else if (channel == "albedo") {
            for (std::size_t c = 0; c < 3; ++c)
                p[c] = toByte(vox::linearToSrgb(std::clamp(sp.points[k].albedo[c], 0.0f, 1.0f)));
        } else {  // normal
            for (std::size_t c = 0; c < 3; ++c) p[c] = toByte(0.5f * (sp.points[k].normal[c] + 1));
        }
    }
    return rgb;
}

constexpr double kPi = 3.14159265358979323846;

/// The camera of each frame: the given one, an orbit around the target at the eye's distance and
/// height ("orbit"), or a file of lines "ex,ey,ez tx,ty,tz" (one per frame, repeated if short).
std::vector<vox::PinholeCamera> cameraPath(const Options& o, const vox::PinholeCamera& camera) {
    std::vector<vox::PinholeCamera> path;
    if (o.cameraPath.empty()) return std::vector<vox::PinholeCamera>(std::size_t(o.frames), camera);
    if (o.cameraPath == "orbit") {
        const double dx = camera.eye[0] - camera.target[0], dz = camera.eye[2] - camera.target[2];
        const double radius = std::hypot(dx, dz), start = std::atan2(dx, dz);
        for (int f = 0; f < o.frames; ++f) {
            vox::PinholeCamera c = camera;
            const double a = start + 2 * kPi * f / o.frames;
            c.eye = {camera.target[0] + radius * std::sin(a), camera.eye[1],
                     camera.target[2] + radius * std::cos(a)};
            path.push_back(c);
        }
        return path;
    }
    std::ifstream in(o.cameraPath);
    if (!in) throw vox::IoError(o.cameraPath, "cannot open the camera path");
    std::string eye, target;
    std::vector<vox::PinholeCamera> keys;
    while (in >> eye >> target) {
        vox::PinholeCamera c = camera;
        c.eye = parseVector(eye, "--camera-path");
        c.target = parseVector(target, "--camera-path");
        c.validate();
        keys.push_back(c);
    }
    if (keys.empty())
        throw vox::InvalidDataError(o.cameraPath,
                                    "no camera in the path (lines: ex,ey,ez tx,ty,tz)");
    for (int f = 0; f < o.frames; ++f) path.push_back(keys[std::size_t(f) % keys.size()]);
    return path;
}

/// The HeadlessGlContext platforms --egl-platform names; nullopt for auto.
std::optional<rt::EglPlatform> eglPlatform(const std::string& name) {
    if (name == "auto") return std::nullopt;
    if (name == "device") return rt::EglPlatform::Device;
    if (name == "surfaceless") return rt::EglPlatform::Surfaceless;
    if (name == "default") return rt::EglPlatform::Default;
    throw vox::UsageError("--egl-platform must be auto, device, surfaceless or default");
}

/// The tiled reader's open tile files (null without one).
nlohmann::json openTilesReport(const vox::rvol::TiledRvolReader* tiled) {
    if (!tiled) return nullptr;
    const vox::rvol::OpenTileStats stats = tiled->openTileStats();
    return {{"max_open_tiles", tiled->options().maxOpenTiles},
            {"most_open", stats.mostOpen},
            {"opened", stats.opened},
            {"closed", stats.closed}};
}

double median(std::vector<double> v) {
    if (v.empty()) return 0.0;
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
}

/// A pass's times over the timed frames (the warm-up left out): the GPU's GL_TIME_ELAPSED and the
/// host's wall clock, and which of them "ms" is. llvmpipe's timer reads ~0 for compute work, so
/// the wall clock stands in where the timer reads under a tenth of it.
nlohmann::json passTimes(const std::vector<double>& gpuMs, const std::vector<double>& wallMs,
                         std::size_t warmup) {
    const std::vector<double> gpu(gpuMs.begin() + std::ptrdiff_t(warmup), gpuMs.end()),
        wall(wallMs.begin() + std::ptrdiff_t(warmup), wallMs.end());
    const double gpuMedian = median(gpu), wallMedian = median(wall);
    const bool timerWorks = gpuMedian > 0.1 * wallMedian;
    return {{"ms", timerWorks ? gpuMedian : wallMedian},
            {"timer", timerWorks ? "GL_TIME_ELAPSED" : "wall (GL_TIME_ELAPSED read ~0)"},
            {"gpu_ms", gpuMedian},
            {"wall_ms", wallMedian},
            {"gpu_ms_per_frame", gpu},
            {"wall_ms_per_frame", wall}};
}

void run(Options o) {
    const std::optional<rt::EglPlatform> platform = eglPlatform(o.eglPlatform);
    if (o.benchmarkFrames > 0) {
        // A fixed camera, its first frame (which streams the slices in and compiles lazily)
        // untimed.
        if (!o.cameraPath.empty())
            throw vox::UsageError("--benchmark renders a fixed camera: no --camera-path");
        if (o.framesGiven) throw vox::UsageError("--benchmark N renders N + 1 frames: no --frames");
        o.headless = true;
        o.frames = o.benchmarkFrames + 1;
    }
    if (!o.headless && platform)
        throw vox::UsageError(
            "--egl-platform applies with --headless (a window brings its own context)");
    if (!o.headless && !voxview::displayAvailable())
        throw vox::UsageError(
            "no display to open a window on (DISPLAY and WAYLAND_DISPLAY are unset): pass "
            "--headless -o FILE.png");
    if (o.headless && o.output.empty() && o.benchmarkFrames == 0)
        throw vox::UsageError("--headless needs -o FILE.png");
    const bool gatherMode = !o.rvol.empty();
    if (gatherMode && !o.channelGiven) o.channel = "final";
    if (gatherMode) {
        if (!isGatherChannel(o.channel) && !vox::channelNamed(o.channel))
            throw vox::UsageError(
                "--channel with --rvol must be final, direct, indirect, specular, ao, albedo or "
                "normal (or an octree "
                "channel: depth, face-normal, color, shaded, iterations, level)");
    } else {
        if (isGatherChannel(o.channel) && !vox::channelNamed(o.channel))
            throw vox::UsageError("--channel " + o.channel +
                                  " needs --rvol FILE.rvol (the radiance volume's final gather)");
        if (!vox::channelNamed(o.channel))
            throw vox::UsageError(
                "--channel must be depth, normal, face-normal, color, shaded, iterations or level");
        if (!o.scene.empty())
            throw vox::UsageError("--scene (the lights) applies with --rvol FILE.rvol");
    }
    const bool gatherChannel = gatherMode && isGatherChannel(o.channel);
    if (!(o.exposure > 0) || !std::isfinite(o.exposure))
        throw vox::UsageError("--exposure must be a finite number > 0");
    for (const double aperture : {o.specAperture, o.shadowAperture})
        if (!(aperture > 0 && aperture < 90))
            throw vox::UsageError(
                "--spec-aperture and --shadow-aperture must be between 0 and 90 degrees "
                "(exclusive)");
    if (o.gatherFilter != "hardware" && o.gatherFilter != "fetch")
        throw vox::UsageError("--gather-filter must be hardware or fetch");
    if (!(o.lodScale >= 0)) throw vox::UsageError("--lod-scale must be 0 or more");
    vox::PinholeCamera camera;
    camera.eye = parseVector(o.eye, "--eye");
    camera.target = parseVector(o.target, "--target");
    camera.up = parseVector(o.up, "--up");
    camera.fovYDegrees = o.fov;
    camera.width = o.width;
    camera.height = o.height;
    camera.validate();

    if (!(o.budgetMb > 0) || !(o.frameLoadMb >= 0))
        throw vox::UsageError("--budget must be positive and --frame-load 0 or more");
    if (o.upload != "ring" && o.upload != "subdata")
        throw vox::UsageError("--upload must be ring or subdata");
    const std::vector<vox::PinholeCamera> path = cameraPath(o, camera);

    const auto start = std::chrono::steady_clock::now();
    // Headless: a context of our own through EGL. With a window: the window's context, adopted.
    std::unique_ptr<voxview::Window> window;
    std::unique_ptr<rt::GlContext> contextHolder;
    if (o.headless) {
        contextHolder = std::make_unique<rt::HeadlessGlContext>(platform);
    } else {
        window = std::make_unique<voxview::Window>(o.width, o.height, "voxview " + o.file);
        contextHolder = std::make_unique<rt::CurrentGlContext>();
    }
    rt::GlContext& context = *contextHolder;
    vox::runtime::EsvoStreamOptions streamOptions;
    streamOptions.budgetBytes = std::uint64_t(o.budgetMb * 1048576.0);
    streamOptions.frameLoadBytes = std::uint64_t(o.frameLoadMb * 1048576.0);
    streamOptions.lodScale = o.lodScale > 0 ? o.lodScale : 1.0;
    streamOptions.uploadPath = o.upload == "ring" ? vox::runtime::UploadPath::PersistentRing
                                                  : vox::runtime::UploadPath::BufferSubData;
    vox::runtime::EsvoStream stream(context, o.file, streamOptions);
    const vox::esvo::EsvoReader& reader = stream.reader();
    if ((o.channel == "color") && !reader.header().hasAttributes())
        throw vox::UsageError(o.file + ": no colours in this file (voxelize --attributes none)");

    // The radiance volume, every brick uploaded, and the lights: all of the scene's, static and
    // dynamic, as voxinspect render lights them.
    // A single .rvol, or a tiled volume's index (its far field then stands for it below).
    std::unique_ptr<vox::rvol::RvolReader> rvolReader;
    std::unique_ptr<vox::rvol::TiledRvolReader> tiledReader;
    std::unique_ptr<rt::RvolGpuVolume> volume;
    std::unique_ptr<rt::FinalGatherGpu> gather;
    std::unique_ptr<rt::RvolResidency> bricks;
    nlohmann::json brickFrames = nlohmann::json::array();
    std::vector<vox::PunctualLight> lights;
    std::size_t staticLights = 0;
    if (gatherChannel) {
        if (vox::rvol::isTileIndex(o.rvol)) {
            vox::rvol::TiledRvolReaderOptions tiledOptions;
            tiledOptions.maxOpenTiles = o.rvolMaxOpenTiles;
            tiledReader = std::make_unique<vox::rvol::TiledRvolReader>(o.rvol, tiledOptions);
        } else {
            rvolReader = std::make_unique<vox::rvol::RvolReader>(o.rvol);
        }
        if (!o.scene.empty()) {
            const vox::Scene scene = vox::importScene(o.scene);
            for (const vox::Light& light : scene.lights) {
                lights.push_back(light);
                staticLights += !light.dynamic;
            }
        }
        const vox::rvol::BakeInfo bake =
            tiledReader ? tiledReader->index().bake : rvolReader->header().bake;
        const std::uint32_t baked = bake.lights;
        if (!o.quiet && o.scene.empty() && baked > 0)
            std::fprintf(stderr,
                         "voxview: warning: no lights without --scene: the direct term is 0 (the "
                         "bake had %u)\n",
                         baked);
        else if (!o.quiet && !o.scene.empty() && staticLights != baked)
            std::fprintf(stderr,
                         "voxview: warning: %s: %zu static lights, but %s was baked with %u\n",
                         o.scene.c_str(), staticLights, o.rvol.c_str(), baked);
        // Every brick, or (--rvol-budget) a clipmap around the eye streamed frame by frame.
        rt::RvolGpuVolumeOptions volumeOptions;
        if (o.rvolBudgetMb > 0) {
            volumeOptions.uploadAll = false;
            volumeOptions.atlasBytes = std::uint64_t(o.rvolBudgetMb * 1048576.0);
        }
        volume = tiledReader
                     ? std::make_unique<rt::RvolGpuVolume>(context, *tiledReader, volumeOptions)
                     : std::make_unique<rt::RvolGpuVolume>(context, *rvolReader, volumeOptions);
        if (o.rvolBudgetMb > 0)
            bricks = std::make_unique<rt::RvolResidency>(*volume, volumeOptions.atlasBytes);
        rt::FinalGatherGpuOptions gatherOptions;
        gatherOptions.specularApertureDegrees = o.specAperture;
        gatherOptions.shadowApertureDegrees = o.shadowAperture;
        gatherOptions.shadowCones = !o.noShadowCones;
        gatherOptions.aoLambda = bake.aoLambda;
        gatherOptions.hardwareFilter = o.gatherFilter == "hardware";
        gatherOptions.tiledVolumes = tiledReader != nullptr;
        gather = std::make_unique<rt::FinalGatherGpu>(context, gatherOptions);
        context.throwOnErrors("uploading " + o.rvol);
    }
    const auto loaded = std::chrono::steady_clock::now();

    vox::runtime::GpuCastOptions options;
    options.maxLevel = o.maxLevel;
    // The final gather's shading points need the colours and shading normals (esvoShadingPoint
    // casts with attributes whatever it is given).
    const auto octreeChannel = vox::channelNamed(o.channel);
    options.attributes =
        gatherChannel || (octreeChannel && vox::channelNeedsAttributes(*octreeChannel));
    ShadingPoints points;
    std::vector<rt::GpuGatherParts> parts;
    std::vector<double> pointsMs, gatherMs, gatherGpuMs;
    std::uint64_t holesTotal = 0;
    vox::runtime::GpuFrame frame;
    std::vector<double> gpuMs, wallMs, updateMs;
    nlohmann::json perFrame = nlohmann::json::array();
    std::uint64_t maxResident = 0, slicesLoaded = 0, slicesEvicted = 0;
    int fullDetailFrame = -1;
    int lastFrame = 0;
    // With a window and no --frames, the camera (or path) repeats until the window is closed.
    const bool untilClosed = window && !o.framesGiven;
    for (int f = 0; f < o.frames || untilClosed; ++f) {
        const std::size_t at = std::size_t(f) % path.size();
        stream.setCamera(path[at]);
        const vox::runtime::EsvoStreamUpdate update = stream.update();
        options.lodAngle = path[at].pixelAngle() * o.lodScale;
        frame = stream.render(options);
        if (gatherChannel) {
            const auto pointsStart = std::chrono::steady_clock::now();
            points = shadingPoints(frame, path[at]);
            pointsMs.push_back(std::chrono::duration<double, std::milli>(
                                   std::chrono::steady_clock::now() - pointsStart)
                                   .count());
            rt::RvolResidency::Update u;
            if (bricks) u = bricks->update(path[at]);
            parts = gather->shade(*volume, points.points, lights);
            gatherMs.push_back(gather->lastSeconds() * 1e3);
            gatherGpuMs.push_back(gather->lastGpuSeconds() * 1e3);
            holesTotal += gather->lastHoles();
            if (brickFrames.size() < 10000)
                brickFrames.push_back(
                    {{"uploaded", u.uploaded},
                     {"evicted", u.evicted},
                     {"selected", u.selected},
                     {"over_budget", u.neededNotFitting},
                     {"tiles_uploaded", u.tilesUploaded},
                     {"tiles_evicted", u.tilesEvicted},
                     {"resident_tiles", volume->residentTiles()},
                     {"fallback_points", gather->lastFallbacks()},
                     {"holes", gather->lastHoles()},
                     // Lights each point tested: its light-grid cell's.
                     {"lights_per_point", gather->lastLightsPerPoint()},
                     // Bricks' bytes (all of them without a budget),
                     // and the GPU's: atlases, indirection, tables.
                     {"resident_bytes", bricks ? u.residentBytes : volume->usedAtlasBytes()},
                     {"volume_bytes", volume->residentBytes()}});
        }
        gpuMs.push_back(frame.gpuMilliseconds);
        wallMs.push_back(frame.wallMilliseconds);
        updateMs.push_back(update.seconds * 1e3);
        maxResident = std::max(maxResident, update.residentBytes);
        slicesLoaded += update.loaded;
        slicesEvicted += update.evicted;
        if (fullDetailFrame < 0 && update.pending == 0) fullDetailFrame = f;
        if (perFrame.size() < 10000)
            perFrame.push_back({{"resident_bytes", update.residentBytes},
                                {"uploaded_bytes", update.uploadedBytes},
                                {"slices_loaded", update.loaded},
                                {"slices_evicted", update.evicted},
                                {"slices_pending", update.pending},
                                {"slices_over_budget", update.neededNotFitting},
                                {"update_ms", update.seconds * 1e3},
                                {"cast_wall_ms", frame.wallMilliseconds},
                                {"cast_gpu_ms", frame.gpuMilliseconds},
                                {"hits", frame.hits},
                                {"gather_ms", gatherChannel ? gatherMs.back() : 0.0}});
        context.throwOnErrors("frame " + std::to_string(f));
        lastFrame = int(at);
        if (window) {
            const bool open = window->present(
                gatherChannel
                    ? composeGather(frame, points, parts, o.channel, o.exposure)
                    : vox::runtime::composeChannel(frame, path[at], vox::parseChannel(o.channel)),
                frame.width, frame.height);
            context.throwOnErrors("presenting frame " + std::to_string(f));
            if (!open) break;
        }
    }
    const vox::esvo::EsvoPool& pool = stream.pool();
    const vox::runtime::EsvoGpuPool& gpuPool = stream.gpuPool();
    const auto rendered = std::chrono::steady_clock::now();
    // The last frame's camera: what the image shows (the rays the points were built from).
    const vox::PinholeCamera& lastCamera = path[std::size_t(lastFrame)];
    if (!o.output.empty())
        voxview::writePngRgb8(
            o.output, frame.width, frame.height,
            gatherChannel
                ? composeGather(frame, points, parts, o.channel, o.exposure)
                : vox::runtime::composeChannel(frame, lastCamera, vox::parseChannel(o.channel)));
    if (!o.quiet)
        std::fprintf(
            stderr,
            "voxview: %s: %dx%d, %llu hits, %.3f ms GPU timer, %.3f ms wall (%s, %s context)\n",
            o.output.c_str(), frame.width, frame.height,
            static_cast<unsigned long long>(frame.hits), frame.gpuMilliseconds,
            frame.wallMilliseconds, context.renderer().c_str(), context.platformName());
    if (!o.quiet && gatherChannel)
        std::fprintf(stderr, "voxview: final gather: %zu points, %zu lights, %.3f ms (%s filter)\n",
                     points.points.size(), lights.size(), gatherMs.back(), o.gatherFilter.c_str());
    // What the benchmark line and the --stats report both say of the last frame and the GL.
    const auto frameReport = [&](const char* tool) {
        return nlohmann::json{{"tool", tool},
                              {"file", o.file},
                              {"renderer", context.renderer()},
                              {"gl_vendor", context.vendor()},
                              {"gl_version", context.version()},
                              {"egl_platform", context.platformName()},
                              {"channel", o.channel},
                              {"width", frame.width},
                              {"height", frame.height},
                              {"hits", frame.hits}};
    };
    if (o.benchmarkFrames > 0) {
        const double pixels = double(frame.width) * double(frame.height);
        nlohmann::json cast = passTimes(gpuMs, wallMs, 1);
        cast["attributes"] = options.attributes;
        nlohmann::json line = frameReport("voxview --benchmark");
        line["frames"] = o.benchmarkFrames;
        line["full_detail_frame"] = fullDetailFrame;
        line["mrays_per_second"] = pixels / (cast["ms"].get<double>() * 1e-3) / 1e6;
        line["cast"] = cast;
        line["gather"] = nullptr;
        line["gl_errors"] = context.errorCount();
        if (gatherChannel) {
            nlohmann::json g = passTimes(gatherGpuMs, gatherMs, 1);
            g["wall_ms_note"] = "shade(): upload, dispatch, glFinish, read-back";
            g["points"] = points.points.size();
            g["lights"] = lights.size();
            g["points_ms"] = median(std::vector<double>(pointsMs.begin() + 1, pointsMs.end()));
            line["gather"] = g;
        }
        std::printf("%s\n", line.dump().c_str());
    }
    if (!o.stats.empty()) {
        std::uint64_t iterations = 0;
        for (std::uint32_t it : frame.iterations) iterations += it;
        const double pixels = double(frame.width) * double(frame.height);
        nlohmann::json report = frameReport("voxview");
        report.update(nlohmann::json{
            {"rays", frame.width * frame.height},
            {"mean_iterations", double(iterations) / pixels},
            {"frames", gpuMs.size()},
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
            {"rvol", o.rvol},
            {"final_gather",
             gatherChannel
                 ? nlohmann::json{{"points", points.points.size()},
                                  {"lights", lights.size()},
                                  {"static_lights", staticLights},
                                  {"filter", o.gatherFilter},
                                  {"exposure", o.exposure},
                                  {"ao_lambda", gather->options().aoLambda},
                                  {"tiled", tiledReader != nullptr},
                                  {"tiles", tiledReader ? tiledReader->index().tiles.size() : 0},
                                  {"tile_slots", volume->tileSlotCount()},
                                  // The tiled reader's files: its bound, the most open at once,
                                  // openings (reopenings included) and closings.
                                  {"open_tiles", openTilesReport(tiledReader.get())},
                                  // Points whose samples met a missing brick with no resident
                                  // cover, over all frames (FinalGatherGpu::lastHoles).
                                  {"holes", holesTotal},
                                  {"volume_resident_bytes", volume->residentBytes()},
                                  {"volume_uploaded_bytes", volume->uploadedBytesTotal()},
                                  {"rvol_budget_bytes", bricks ? bricks->budget() : 0},
                                  // Per frame: bricks and tiles uploaded and evicted (with
                                  // --rvol-budget), resident bytes and tiles, the points that fell
                                  // back to a coarser cover and the holes.
                                  {"bricks_per_frame", brickFrames},
                                  // FinalGatherGpu::shade: upload, dispatch, glFinish, read-back.
                                  {"gather_ms_per_frame", gatherMs},
                                  {"gather_ms_median", median(gatherMs)},
                                  // The dispatch alone by GL_TIME_ELAPSED (llvmpipe: ~0).
                                  {"gather_gpu_ms_per_frame", gatherGpuMs},
                                  {"gather_gpu_ms_median", median(gatherGpuMs)},
                                  // Shading points built on the host from the read-back frame.
                                  {"points_ms_per_frame", pointsMs},
                                  {"points_ms_median", median(pointsMs)}}
                 : nlohmann::json(nullptr)},
            {"timings_ms",
             {{"load", std::chrono::duration<double, std::milli>(loaded - start).count()},
              {"gl_and_render",
               std::chrono::duration<double, std::milli>(rendered - loaded).count()}}}});
        vox::writeFileAtomically(o.stats, report.dump(2) + "\n");
    }
}

}  // namespace

int main(int argc, char** argv) {
    Options o;
    CLI::App app{
        "voxview: render an .esvo octree with the OpenGL 4.5 runtime (headless, EGL) to a PNG"};
    app.add_option("file", o.file, ".esvo file")->required();
    app.add_flag(
        "--headless", o.headless,
        "Render without a window, through EGL (else a window through GLFW, which needs a display)");
    app.add_option("-o,--output", o.output,
                   "PNG to write (the last frame; required with --headless)");
    app.add_option("--eye", o.eye, "Camera position x,y,z (world units)")->required();
    app.add_option("--target", o.target, "Point looked at x,y,z")->required();
    app.add_option("--up", o.up, "Up vector x,y,z")->capture_default_str();
    app.add_option("--fov", o.fov, "Vertical field of view, degrees")->capture_default_str();
    app.add_option("--width", o.width, "Image width")->capture_default_str();
    app.add_option("--height", o.height, "Image height")->capture_default_str();
    app.add_option("--channel", o.channel,
                   "shaded, color, normal, face-normal, depth, iterations or level (as voxinspect "
                   "render); with --rvol final (the "
                   "default), direct, indirect, specular, ao, albedo or normal (as voxinspect "
                   "render FILE.rvol)")
        ->capture_default_str();
    app.add_option("--lod-scale", o.lodScale,
                   "Stop at voxels smaller than this many pixels; 0: always to the leaves")
        ->capture_default_str();
    app.add_option("--max-level", o.maxLevel, "Treat voxels of this level as leaves");
    app.add_option("--frames", o.frames, "Render this many frames (timing); the last is written")
        ->check(CLI::Range(1, 10000));
    app.add_option("--budget", o.budgetMb, "GPU memory budget for the octree's slices, MB")
        ->capture_default_str();
    app.add_option("--rvol-budget", o.rvolBudgetMb,
                   "With --rvol: stream the radiance bricks around the eye within this many MB (0: "
                   "upload every brick)")
        ->capture_default_str();
    app.add_option(
           "--rvol-max-open-tiles", o.rvolMaxOpenTiles,
           "With --rvol INDEX (a tiled volume): tile files open at once (the least recently "
           "used is closed, and opened again when needed)")
        ->check(CLI::Range(1u, 1u << 20))
        ->capture_default_str();
    app.add_option("--frame-load", o.frameLoadMb,
                   "Most MB of slices loaded per frame (0: all the view needs)")
        ->capture_default_str();
    app.add_option("--camera-path", o.cameraPath,
                   "Camera per frame: 'orbit' (around --target at --eye's distance and height, "
                   "over --frames) or a file of "
                   "lines 'ex,ey,ez tx,ty,tz'");
    app.add_option("--upload", o.upload,
                   "Upload path: ring (persistently mapped staging ring with fences) or subdata "
                   "(glBufferSubData)")
        ->capture_default_str();
    app.add_option(
        "--stats", o.stats,
        "Write a JSON report: renderer, frame times, hits, resident and uploaded bytes per frame");
    app.add_option(
        "--rvol", o.rvol,
        "Draw this radiance volume's final gather at the octree's hits (GPU cone tracing); a .rvol "
        "or a tiled volume's index");
    app.add_option("--scene", o.scene,
                   "--rvol: the lights of this scene (glTF, OBJ; all of them, static and dynamic)");
    app.add_option("--exposure", o.exposure, "--rvol: radiance scale before tone mapping")
        ->capture_default_str();
    app.add_option("--spec-aperture", o.specAperture, "--rvol: specular cone aperture, degrees")
        ->capture_default_str();
    app.add_option("--shadow-aperture", o.shadowAperture, "--rvol: shadow cone aperture, degrees")
        ->capture_default_str();
    app.add_flag("--no-shadow-cones", o.noShadowCones, "--rvol: lights unshadowed");
    app.add_option("--gather-filter", o.gatherFilter,
                   "--rvol: hardware (one trilinear texture() per plane) or fetch (eight "
                   "texelFetch, the CPU's interpolation)")
        ->capture_default_str();
    app.add_option("--egl-platform", o.eglPlatform,
                   "Headless: auto (a GPU through EGL_EXT_platform_device first, then Mesa's "
                   "surfaceless platform, Mesa's "
                   "software device, the default display), device, surfaceless or default")
        ->capture_default_str();
    app.add_option("--benchmark", o.benchmarkFrames,
                   "Time N frames of the fixed camera after one warm-up frame (headless) and print "
                   "one JSON line: GL renderer, "
                   "ms per pass by GL_TIME_ELAPSED (the wall clock where the timer reads ~0, as on "
                   "llvmpipe), Mrays/s")
        ->check(CLI::Range(1, 10000));
    app.add_flag("-q,--quiet", o.quiet, "Print errors only");
    try {
        app.parse(argc, argv);
        o.channelGiven = app.get_option("--channel")->count() > 0;
    } catch (const CLI::Success& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        // CLI11's own codes are 100+; every usage problem is exit code 1, as in the tools.
        std::fprintf(stderr, "voxview: error: %s (see --help)\n", e.what());
        return static_cast<int>(vox::ExitCode::Usage);
    }
    try {
        o.framesGiven = app.get_option("--frames")->count() > 0;
        run(o);
        return 0;
    } catch (const vox::ParameterError& e) {
        std::fprintf(stderr, "voxview: error: %s\n", e.commandLineMessage().c_str());
        return static_cast<int>(e.exitCode());
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
