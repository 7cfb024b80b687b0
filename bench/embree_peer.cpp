// Embree 3 single rays on a scene's triangles (bench/embree_peer.h).
#include "embree_peer.h"

#include <embree3/rtcore.h>
#include <tbb/blocked_range.h>
#include <tbb/blocked_range2d.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace bench {

struct EmbreePeer::Handles {
    RTCDevice device = nullptr;
    RTCScene scene = nullptr;
    ~Handles() {
        if (scene != nullptr) rtcReleaseScene(scene);
        if (device != nullptr) rtcReleaseDevice(device);
    }
};

namespace {

void throwOnError(RTCDevice device, const char* what) {
    const RTCError error = rtcGetDeviceError(device);
    if (error != RTC_ERROR_NONE)
        throw std::runtime_error(std::string("Embree: ") + what + ": error " +
                                 std::to_string(int(error)));
}

/// The nearest hit's distance along one ray (rtcIntersect1), or +inf where it misses.
float intersect(RTCScene scene, RTCIntersectContext& context, const float* origin,
                const float* direction) {
    RTCRayHit rayHit;
    rayHit.ray.org_x = origin[0], rayHit.ray.org_y = origin[1], rayHit.ray.org_z = origin[2];
    rayHit.ray.dir_x = direction[0], rayHit.ray.dir_y = direction[1],
    rayHit.ray.dir_z = direction[2];
    rayHit.ray.tnear = 0;
    rayHit.ray.tfar = std::numeric_limits<float>::infinity();
    rayHit.ray.time = 0;
    rayHit.ray.mask = ~0u;
    rayHit.ray.id = 0;
    rayHit.ray.flags = 0;
    rayHit.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rayHit.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene, &context, &rayHit);
    return rayHit.hit.geomID != RTC_INVALID_GEOMETRY_ID ? rayHit.ray.tfar
                                                        : std::numeric_limits<float>::infinity();
}

}  // namespace

EmbreePeer::EmbreePeer(const vox::Scene& scene, int threads)
    : handles_(std::make_unique<Handles>()) {
    const std::string config = threads > 0 ? "threads=" + std::to_string(threads) : std::string();
    handles_->device = rtcNewDevice(config.c_str());
    if (handles_->device == nullptr)
        throw std::runtime_error("Embree: rtcNewDevice failed (error " +
                                 std::to_string(int(rtcGetDeviceError(nullptr))) + ")");
    RTCDevice device = handles_->device;
    handles_->scene = rtcNewScene(device);
    rtcSetSceneBuildQuality(handles_->scene, RTC_BUILD_QUALITY_HIGH);
    const auto start = std::chrono::steady_clock::now();
    for (const vox::Mesh& mesh : scene.meshes) {
        if (mesh.dynamic || mesh.triangleCount() == 0)
            continue;  // as TriangleRayCaster and voxelize: static meshes only
        RTCGeometry geometry = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
        rtcSetGeometryBuildQuality(geometry, RTC_BUILD_QUALITY_HIGH);
        // Embree's own buffers (it reads 16 bytes at the last vertex, past a shared std::vector's
        // end).
        auto* vertices = static_cast<float*>(
            rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                    3 * sizeof(float), mesh.positions.size()));
        auto* indices = static_cast<unsigned*>(
            rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                    3 * sizeof(unsigned), mesh.triangleCount()));
        throwOnError(device, "allocating geometry buffers");
        for (std::size_t v = 0; v < mesh.positions.size(); ++v)
            for (int a = 0; a < 3; ++a) vertices[3 * v + std::size_t(a)] = mesh.positions[v][a];
        std::copy(mesh.indices.begin(), mesh.indices.end(), indices);
        rtcCommitGeometry(geometry);
        rtcAttachGeometry(handles_->scene, geometry);
        rtcReleaseGeometry(geometry);
        triangles_ += mesh.triangleCount();
    }
    rtcCommitScene(handles_->scene);
    throwOnError(device, "building the scene");
    buildSeconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

EmbreePeer::~EmbreePeer() = default;

std::string EmbreePeer::version() { return RTC_VERSION_STRING; }

EmbreeImage EmbreePeer::render(const vox::PinholeCamera& camera) const {
    const int width = camera.width, height = camera.height;
    const std::size_t pixels = std::size_t(width) * std::size_t(height);
    // Every ray the octree's caster casts, from the camera's own code; one origin for all.
    std::vector<float> directions(3 * pixels);
    tbb::parallel_for(0, height, [&](int y) {
        for (int x = 0; x < width; ++x) {
            const vox::Vec3d d = camera.rayThrough(x, y).direction;
            float* out = &directions[3 * (std::size_t(y) * std::size_t(width) + std::size_t(x))];
            out[0] = float(d.x), out[1] = float(d.y), out[2] = float(d.z);
        }
    });
    const float origin[3] = {float(camera.eye.x), float(camera.eye.y), float(camera.eye.z)};

    EmbreeImage image;
    image.depth.assign(pixels, std::numeric_limits<float>::infinity());
    std::atomic<std::uint64_t> hits{0};
    RTCScene scene = handles_->scene;
    const auto start = std::chrono::steady_clock::now();
    // 16×16 pixel tiles: coherent rays per task, and neighbouring tasks write distinct cache lines.
    tbb::parallel_for(
        tbb::blocked_range2d<int>(0, height, 16, 0, width, 16),
        [&](const tbb::blocked_range2d<int>& tile) {
            RTCIntersectContext context;
            rtcInitIntersectContext(&context);
            std::uint64_t tileHits = 0;
            for (int y = tile.rows().begin(); y < tile.rows().end(); ++y)
                for (int x = tile.cols().begin(); x < tile.cols().end(); ++x) {
                    const std::size_t i = std::size_t(y) * std::size_t(width) + std::size_t(x);
                    const float t = intersect(scene, context, origin, &directions[3 * i]);
                    if (std::isfinite(t)) {
                        image.depth[i] = t;
                        ++tileHits;
                    }
                }
            hits += tileHits;
        });
    image.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    image.hits = hits;
    return image;
}

EmbreeImage EmbreePeer::cast(const std::vector<float>& origins,
                             const std::vector<float>& directions) const {
    const std::size_t rays = directions.size() / 3;
    EmbreeImage image;
    image.depth.assign(rays, std::numeric_limits<float>::infinity());
    std::atomic<std::uint64_t> hits{0};
    RTCScene scene = handles_->scene;
    const auto start = std::chrono::steady_clock::now();
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, rays, 256),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                          RTCIntersectContext context;
                          rtcInitIntersectContext(&context);
                          std::uint64_t chunkHits = 0;
                          for (std::size_t i = r.begin(); i != r.end(); ++i) {
                              const float t =
                                  intersect(scene, context, &origins[3 * i], &directions[3 * i]);
                              image.depth[i] = t;
                              chunkHits += std::isfinite(t) ? 1 : 0;
                          }
                          hits += chunkHits;
                      });
    image.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    image.hits = hits;
    return image;
}

}  // namespace bench
