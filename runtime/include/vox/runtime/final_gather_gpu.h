/// @file final_gather_gpu.h
/// @brief The cone-traced final gather of vox::FinalGather (libvox/include/vox/final_gather.h) as
/// an OpenGL compute shader over an RvolGpuVolume (a single or a tiled volume): direct light from
/// punctual lights through shadow cones, seven diffuse cones (indirect light and AO) and a specular
/// cone per shading point.
#pragma once

#include <vox/base/light.h>
#include <vox/base/math.h>

#include <vox/runtime/rvol_gpu_volume.h>
#include <vox/runtime/shader.h>

#include <array>
#include <cstdint>
#include <span>
#include <vector>

namespace vox::runtime {

class GlContext;

/// A punctual light (vox::Light's fields; the runtime does not link libvox).
/// One surface point to shade (vox::ShadingPoint in float).
struct GpuShadingPoint {
    Vec3f position{0, 0, 0};
    Vec3f normal{0, 0, 1};  ///< unit, on the viewer's side
    Vec3f albedo{0, 0, 0};
    Vec3f emission{0, 0, 0};
    Vec3f view{0, 0, 1};  ///< unit, towards the viewer
};

/// The terms of one point (vox::FinalGatherParts in float).
struct GpuGatherParts {
    Vec3f final{0, 0, 0}, direct{0, 0, 0}, indirect{0, 0, 0}, specular{0, 0, 0};
    float ao = 1;
};

/// vox::FinalGatherOptions' shading constants (the same defaults), and the filter.
struct FinalGatherGpuOptions {
    double specularApertureDegrees = 10;  ///< full apex angle, (0, 90)
    double shadowApertureDegrees = 10;    ///< full apex angle, (0, 90)
    bool shadowCones = true;
    double offsetCells = 2;  ///< cone start off the surface, level-0 cells
    double aoLambda = 8;     ///< eq. 4's λ (the bake's: rvol BakeInfo::aoLambda)
    double specularF0 = 0.04;
    /// true: the texture unit's trilinear filter over the atlas slots (one fetch per plane);
    /// false: eight texelFetch per plane with float weights (exactly the CPU's interpolation).
    bool hardwareFilter = true;
    /// Compile for tiled volumes too (RvolGpuVolume over a TiledRvolReader): where a sample's
    /// cells lie in several tiles it fetches them one by one. false: single volumes only, whose
    /// samples then need no such branch (a JIT compiler such as llvmpipe's runs both sides of
    /// it); shade() and sample() throw RuntimeError for a tiled volume.
    bool tiledVolumes = false;
};

/// Compiles the shader (shade and sample variants) once; shade() runs it over a volume.
class FinalGatherGpu {
public:
    /// @throws RuntimeError for options outside their ranges (as FinalGather's UsageError) or a
    /// shader that does not compile.
    explicit FinalGatherGpu(GlContext& context, const FinalGatherGpuOptions& options = {});
    ~FinalGatherGpu();
    FinalGatherGpu(const FinalGatherGpu&) = delete;
    FinalGatherGpu& operator=(const FinalGatherGpu&) = delete;

    /// Every term of each point, the direct one summed over @p lights with shadow cones, through
    /// one dispatch (64 points per work group). Blocks until the results are read back. A point
    /// tests only the lights whose range can reach it (a grid over the points lists them), in
    /// @p lights' order, so the sums are those over every light.
    [[nodiscard]] std::vector<GpuGatherParts> shade(const RvolGpuVolume& volume,
                                                    std::span<const GpuShadingPoint> points,
                                                    std::span<const PunctualLight> lights);
    /// RadianceField::sample(level, position, direction) on the GPU for each query (tests); of a
    /// tiled volume, TiledRvolReader::sample / sampleDirectional's (the level the volume's).
    struct SampleQuery {
        std::uint32_t level = 0;
        Vec3f position{0, 0, 0};
        Vec3f direction{0, 0, 1};
    };
    [[nodiscard]] std::vector<std::array<float, 4>> sample(const RvolGpuVolume& volume,
                                                           std::span<const SampleQuery> queries);

    [[nodiscard]] const FinalGatherGpuOptions& options() const noexcept { return options_; }
    /// Seconds the last shade() took on the GPU, upload and read-back included (glFinish).
    [[nodiscard]] double lastSeconds() const noexcept { return lastSeconds_; }
    /// The mean number of lights the last shade() tested per point (out of all it was given).
    [[nodiscard]] double lastLightsPerPoint() const noexcept { return lastLightsPerPoint_; }
    /// The last shade()'s dispatch alone as the GPU timed it (GL_TIME_ELAPSED), seconds; llvmpipe
    /// reads ~0 for compute work.
    [[nodiscard]] double lastGpuSeconds() const noexcept { return lastGpuSeconds_; }
    /// Of the last shade() (sample()): the points (queries) one of whose samples met a missing
    /// brick or tile and was served by a coarser resident cover instead ...
    [[nodiscard]] std::uint32_t lastFallbacks() const noexcept { return lastFallbacks_; }
    /// ... and those one of whose samples found no resident cover at all up to the top level, so
    /// read zero where the volume may have radiance: a **hole**. A residency that keeps the top
    /// level leaves none.
    [[nodiscard]] std::uint32_t lastHoles() const noexcept { return lastHoles_; }

private:
    void requireTiledSupport(const RvolGpuVolume& volume) const;
    void readCounters(unsigned buffer);

    GlContext& context_;
    FinalGatherGpuOptions options_;
    ComputeProgram shadeProgram_, sampleProgram_;
    double lastSeconds_ = 0, lastGpuSeconds_ = 0, lastLightsPerPoint_ = 0;
    std::uint32_t lastFallbacks_ = 0, lastHoles_ = 0;
    unsigned query_ = 0;  // GL_TIME_ELAPSED around shade()'s dispatch
};

}  // namespace vox::runtime
