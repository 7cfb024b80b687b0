/// @file esvo_gpu_raycaster.h
/// @brief The compute-shader ESVO ray caster: libvox's CPU reference traversal
/// (libvox/src/render/esvo_raycast.cpp, Laine & Karras section 6) ported to GLSL 4.50, one
/// invocation per pixel, walking an EsvoGpuPool.
#pragma once

#include <vox/base/camera.h>
#include <vox/runtime/shader.h>

#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

namespace vox::runtime {

class GlContext;
class EsvoGpuPool;

/// What to cast; the fields of libvox's CastOptions that the GPU caster supports.
struct GpuCastOptions {
    /// Stop where a voxel is smaller than this many radians along the ray (the pixel footprint:
    /// Camera::pixelAngle() × voxinspect's --lod-scale); 0 disables the level-of-detail cut.
    double lodAngle = 0;
    std::uint32_t maxLevel =
        std::numeric_limits<std::uint32_t>::max();  ///< treat this level as leaves
    bool contours = true;                           ///< intersect voxels' contours
    bool attributes = true;  ///< decode colour and shading normal (raw, dxt, dxt-lookup)
};

/// One frame read back to the host, one entry per pixel, row 0 at the top (libvox RenderBuffers'
/// layout, so the images compare pixel by pixel).
struct GpuFrame {
    int width = 0, height = 0;
    std::vector<float> depth;  ///< distance along the ray (world units); +inf where it missed
    std::vector<float>
        normal;  ///< 3 per pixel: world normal of the face or contour entered; 0 on a miss
    std::vector<float> shadingNormal;  ///< 3 per pixel: unit decoded shading normal; 0 where none
    std::vector<std::uint32_t> color;  ///< esvo::packColor word (sRGB RGB, alpha); 0 where none
    std::vector<std::uint32_t> iterations;  ///< traversal loop iterations
    std::vector<std::uint8_t> level;        ///< level of the voxel hit; 0 on a miss
    std::uint64_t hits = 0;
    double gpuMilliseconds =
        0;  ///< GL_TIME_ELAPSED of the dispatch (llvmpipe reports ~0 for compute)
    double wallMilliseconds = 0;  ///< host wall time from the dispatch to glFinish (no read-back)
    [[nodiscard]] bool hit(std::size_t i) const {
        return depth[i] != std::numeric_limits<float>::infinity();
    }
    [[nodiscard]] bool hasAttributes(std::size_t i) const {
        return shadingNormal[3 * i] != 0 || shadingNormal[3 * i + 1] != 0 ||
               shadingNormal[3 * i + 2] != 0;
    }
};

/// Casts one primary ray per pixel on the GPU. The pool's header (world-to-root transform) is
/// read at construction; the pool's contents may change between frames (call EsvoGpuPool::sync()).
class EsvoGpuRaycaster {
public:
    /// Compiles the shader. @throws RuntimeError (compile log) or InvalidDataError (a singular
    /// world-to-root transform, as the CPU caster).
    EsvoGpuRaycaster(GlContext& context, const EsvoGpuPool& pool);
    ~EsvoGpuRaycaster();
    EsvoGpuRaycaster(const EsvoGpuRaycaster&) = delete;
    EsvoGpuRaycaster& operator=(const EsvoGpuRaycaster&) = delete;

    /// Dispatches the cast for @p camera (validated) and reads the result back.
    /// @throws vox::UsageError for a bad camera, RuntimeError on any GL error.
    [[nodiscard]] GpuFrame render(const PinholeCamera& camera, const GpuCastOptions& options);

    /// World size of a leaf voxel's edge.
    [[nodiscard]] double leafVoxelSize() const noexcept { return leafSize_; }
    /// GPU bytes of the per-pixel output buffer (grows to the largest image rendered).
    [[nodiscard]] std::uint64_t outputBytes() const noexcept { return outputBytes_; }

private:
    GlContext& context_;
    const EsvoGpuPool& pool_;
    ComputeProgram program_;
    double a_[12];
    double unitScale_ = 1, leafSize_ = 1;
    unsigned output_ = 0, query_ = 0;
    std::uint64_t outputBytes_ = 0;
};

}  // namespace vox::runtime
