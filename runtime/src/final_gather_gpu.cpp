#include <vox/runtime/final_gather_gpu.h>
#include <vox/runtime/gl_context.h>

#include "final_gather_glsl.h"
#include "light_grid.h"

#include <GL/glcorearb.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>

namespace vox::runtime {
namespace {

constexpr double kPi = 3.14159265358979323846;

std::string shaderSource(const FinalGatherGpuOptions& options, const char* mode) {
    std::string source = "#version 450 core\n#define ";
    source += mode;
    source += "\n";
    if (options.hardwareFilter) source += "#define VOX_HARDWARE_FILTER\n";
    if (options.tiledVolumes) source += "#define VOX_TILED\n";
    return source + detail::kFinalGatherShader;
}

const FinalGatherGpuOptions& checked(const FinalGatherGpuOptions& o) {
    const auto aperture = [](double degrees, const char* what) {
        if (!(degrees > 0 && degrees < 90))
            throw RuntimeError(std::string("final gather: ") + what +
                               " must be between 0 and 90 degrees (exclusive)");
    };
    aperture(o.specularApertureDegrees, "the specular aperture");
    aperture(o.shadowApertureDegrees, "the shadow aperture");
    if (!(o.offsetCells >= 0) || !std::isfinite(o.offsetCells))
        throw RuntimeError("final gather: the cone offset must be ≥ 0");
    if (!(o.aoLambda >= 0) || !std::isfinite(o.aoLambda))
        throw RuntimeError("final gather: λ must be a finite number ≥ 0");
    if (!(o.specularF0 >= 0 && o.specularF0 <= 1))
        throw RuntimeError("final gather: F0 must be between 0 and 1");
    return o;
}

/// A GL buffer for one dispatch, deleted with the scope.
struct ScopedBuffer {
    GLuint id = 0;
    ScopedBuffer(std::size_t bytes, const void* data, GLbitfield flags) {
        glCreateBuffers(1, &id);
        // At least 16 bytes (an empty SSBO binding is invalid); a shorter source is copied into
        // 16 zeroed bytes rather than read past its end.
        std::uint8_t padded[16] = {};
        if (data && bytes < sizeof padded) {
            std::copy_n(static_cast<const std::uint8_t*>(data), bytes, padded);
            data = padded;
        }
        glNamedBufferStorage(id, static_cast<GLsizeiptr>(std::max<std::size_t>(bytes, 16)), data,
                             flags);
    }
    ~ScopedBuffer() { glDeleteBuffers(1, &id); }
    ScopedBuffer(const ScopedBuffer&) = delete;
    ScopedBuffer& operator=(const ScopedBuffer&) = delete;
};

/// The shader's RvolCounters: points (queries) that fell back to a coarser cover, that met a hole.
constexpr GLuint kCountersBinding = 9;
constexpr std::uint32_t kZeroCounters[4] = {0, 0, 0, 0};  // ScopedBuffer takes 16 bytes at least

void put3(float* out, Vec3f v, float w = 0) {
    out[0] = v[0];
    out[1] = v[1];
    out[2] = v[2];
    out[3] = w;
}

}  // namespace

FinalGatherGpu::FinalGatherGpu(GlContext& context, const FinalGatherGpuOptions& options)
    : context_(context),
      options_(checked(options)),
      shadeProgram_("final gather", shaderSource(options, "VOX_MODE_SHADE")),
      sampleProgram_("rvol sample", shaderSource(options, "VOX_MODE_SAMPLE")) {
    // The constants of FinalGather and RadianceField::gatherDiffuse, in double, rounded once.
    const GLuint p = shadeProgram_.id();
    glProgramUniform1f(p, shadeProgram_.uniform("uAoLambda"),
                       static_cast<float>(options_.aoLambda));
    glProgramUniform1f(p, shadeProgram_.uniform("uSpecularF0"),
                       static_cast<float>(options_.specularF0));
    glProgramUniform1f(
        p, shadeProgram_.uniform("uTanHalfSpecular"),
        static_cast<float>(std::tan(0.5 * options_.specularApertureDegrees * kPi / 180)));
    glProgramUniform1f(
        p, shadeProgram_.uniform("uTanHalfShadow"),
        static_cast<float>(std::tan(0.5 * options_.shadowApertureDegrees * kPi / 180)));
    glProgramUniform1i(p, shadeProgram_.uniform("uShadowCones"), options_.shadowCones ? 1 : 0);
    // The diffuse cones (RadianceField::diffuseCones): one along the normal and six tilted 55°,
    // half-angle 28°, weighted by their exact cosine-weighted solid angles scaled to sum to π.
    constexpr double kHalf = 28 * kPi / 180, kTilt = 55 * kPi / 180;
    constexpr int kRing = 6;
    const double cap = kPi * std::sin(kHalf) * std::sin(kHalf), ring = std::cos(kTilt) * cap;
    const double norm = kPi / (cap + kRing * ring);
    const float weights[2] = {static_cast<float>(cap * norm), static_cast<float>(ring * norm)};
    glProgramUniform1fv(p, shadeProgram_.uniform("uDiffuseWeights"), 2, weights);
    glProgramUniform1f(p, shadeProgram_.uniform("uDiffuseTanHalf"),
                       static_cast<float>(std::tan(kHalf)));
    glProgramUniform2f(p, shadeProgram_.uniform("uDiffuseTilt"),
                       static_cast<float>(std::cos(kTilt)), static_cast<float>(std::sin(kTilt)));
    float cosines[kRing], sines[kRing];
    for (int i = 0; i < kRing; ++i) {
        const double phi = 2 * kPi * i / kRing;
        cosines[i] = static_cast<float>(std::cos(phi));
        sines[i] = static_cast<float>(std::sin(phi));
    }
    glProgramUniform1fv(p, shadeProgram_.uniform("uDiffuseCos"), kRing, cosines);
    glProgramUniform1fv(p, shadeProgram_.uniform("uDiffuseSin"), kRing, sines);
    glCreateQueries(GL_TIME_ELAPSED, 1, &query_);
    context_.throwOnErrors("final gather: setting up the shader");
}

FinalGatherGpu::~FinalGatherGpu() {
    if (query_ != 0) glDeleteQueries(1, &query_);
}

void FinalGatherGpu::requireTiledSupport(const RvolGpuVolume& volume) const {
    if (volume.tiled() && !options_.tiledVolumes)
        throw RuntimeError(
            "final gather: a tiled volume needs a shader compiled for it "
            "(FinalGatherGpuOptions::tiledVolumes)");
}

std::vector<GpuGatherParts> FinalGatherGpu::shade(const RvolGpuVolume& volume,
                                                  std::span<const GpuShadingPoint> points,
                                                  std::span<const PunctualLight> lights) {
    requireTiledSupport(volume);
    const auto start = std::chrono::steady_clock::now();
    std::vector<GpuGatherParts> out(points.size());
    if (points.empty()) {
        lastSeconds_ = lastGpuSeconds_ = lastLightsPerPoint_ = 0;
        lastFallbacks_ = lastHoles_ = 0;
        return out;
    }
    std::vector<float> pointData(points.size() * 20);
    for (std::size_t i = 0; i < points.size(); ++i) {
        float* d = &pointData[i * 20];
        put3(d, points[i].position, 1);
        put3(d + 4, points[i].normal);
        put3(d + 8, points[i].albedo);
        put3(d + 12, points[i].emission);
        put3(d + 16, points[i].view);
    }
    std::vector<float> lightData(lights.size() * 16);
    for (std::size_t i = 0; i < lights.size(); ++i) {
        const PunctualLight& l = lights[i];
        float* d = &lightData[i * 16];
        put3(d, l.position, static_cast<float>(static_cast<std::uint32_t>(l.type)));
        put3(d + 4, l.direction, l.range);
        // vox::lightArrival's colour × intensity and spot constants, in double as there.
        put3(d + 8, {static_cast<float>(l.color[0] * double(l.intensity)),
                     static_cast<float>(l.color[1] * double(l.intensity)),
                     static_cast<float>(l.color[2] * double(l.intensity))});
        const double cosOuter = std::cos(double(l.outerConeAngle)),
                     cosInner = std::cos(double(l.innerConeAngle));
        d[12] = static_cast<float>(cosOuter);
        d[13] = static_cast<float>(1.0 / std::max(1e-3, cosInner - cosOuter));
        d[14] = d[15] = 0;
    }
    std::vector<Vec3f> positions(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) positions[i] = points[i].position;
    const detail::LightGrid grid = detail::buildLightGrid(positions, lights);
    std::uint64_t lightsTested = 0;
    for (const Vec3f& p : positions) lightsTested += grid.cellRanges[grid.cellOf(p)][1];
    lastLightsPerPoint_ = double(lightsTested) / double(points.size());

    const ScopedBuffer pointBuffer(pointData.size() * 4, pointData.data(), 0);
    const ScopedBuffer lightBuffer(lightData.size() * 4,
                                   lightData.empty() ? nullptr : lightData.data(), 0);
    const ScopedBuffer cellBuffer(grid.cellRanges.size() * 8, grid.cellRanges.data(), 0);
    const ScopedBuffer lightListBuffer(grid.lightList.size() * 4,
                                       grid.lightList.empty() ? nullptr : grid.lightList.data(), 0);
    const ScopedBuffer partsBuffer(points.size() * 64, nullptr, GL_CLIENT_STORAGE_BIT);

    const GLuint p = shadeProgram_.id();
    glProgramUniform1f(p, shadeProgram_.uniform("uOffset"),
                       static_cast<float>(options_.offsetCells * volume.finestCellSize()));
    glProgramUniform1ui(p, shadeProgram_.uniform("uCount"), static_cast<GLuint>(points.size()));
    glProgramUniform3f(p, shadeProgram_.uniform("uLightGridOrigin"), grid.origin[0],
                       grid.origin[1], grid.origin[2]);
    glProgramUniform3f(p, shadeProgram_.uniform("uLightGridInverseCell"), grid.inverseCell[0],
                       grid.inverseCell[1], grid.inverseCell[2]);
    glProgramUniform3ui(p, shadeProgram_.uniform("uLightGridCells"), grid.cells[0], grid.cells[1],
                        grid.cells[2]);
    volume.bind();
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 6, pointBuffer.id);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 7, partsBuffer.id);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 8, lightBuffer.id);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 10, cellBuffer.id);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 11, lightListBuffer.id);
    const ScopedBuffer counters(sizeof kZeroCounters, kZeroCounters, GL_CLIENT_STORAGE_BIT);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, kCountersBinding, counters.id);
    glUseProgram(p);
    glBeginQuery(GL_TIME_ELAPSED, query_);
    glDispatchCompute(static_cast<GLuint>((points.size() + 63) / 64), 1, 1);
    glEndQuery(GL_TIME_ELAPSED);
    glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
    glUseProgram(0);
    std::vector<float> raw(points.size() * 16);
    glGetNamedBufferSubData(partsBuffer.id, 0, static_cast<GLsizeiptr>(raw.size() * 4), raw.data());
    GLuint64 nanoseconds = 0;
    glGetQueryObjectui64v(query_, GL_QUERY_RESULT, &nanoseconds);
    lastGpuSeconds_ = double(nanoseconds) * 1e-9;
    readCounters(counters.id);
    context_.throwOnErrors("final gather: shading " + std::to_string(points.size()) + " points");
    for (std::size_t i = 0; i < points.size(); ++i) {
        const float* d = &raw[i * 16];
        GpuGatherParts& o = out[i];
        o.final = {d[0], d[1], d[2]};
        o.direct = {d[4], d[5], d[6]};
        o.indirect = {d[8], d[9], d[10]};
        o.specular = {d[12], d[13], d[14]};
        o.ao = d[15];
    }
    lastSeconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return out;
}

void FinalGatherGpu::readCounters(unsigned buffer) {
    std::uint32_t counts[2] = {0, 0};
    glGetNamedBufferSubData(buffer, 0, sizeof counts, counts);
    lastFallbacks_ = counts[0];
    lastHoles_ = counts[1];
}

std::vector<std::array<float, 4>> FinalGatherGpu::sample(const RvolGpuVolume& volume,
                                                         std::span<const SampleQuery> queries) {
    requireTiledSupport(volume);
    std::vector<std::array<float, 4>> out(queries.size());
    lastFallbacks_ = lastHoles_ = 0;
    if (queries.empty()) return out;
    std::vector<float> data(queries.size() * 8);
    for (std::size_t i = 0; i < queries.size(); ++i) {
        put3(&data[i * 8], queries[i].position, static_cast<float>(queries[i].level));
        put3(&data[i * 8 + 4], queries[i].direction);
    }
    const ScopedBuffer queryBuffer(data.size() * 4, data.data(), 0);
    const ScopedBuffer sampleBuffer(queries.size() * 16, nullptr, GL_CLIENT_STORAGE_BIT);
    const GLuint p = sampleProgram_.id();
    glProgramUniform1ui(p, sampleProgram_.uniform("uCount"), static_cast<GLuint>(queries.size()));
    volume.bind();
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 6, queryBuffer.id);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 7, sampleBuffer.id);
    const ScopedBuffer counters(sizeof kZeroCounters, kZeroCounters, GL_CLIENT_STORAGE_BIT);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, kCountersBinding, counters.id);
    glUseProgram(p);
    glDispatchCompute(static_cast<GLuint>((queries.size() + 63) / 64), 1, 1);
    glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
    glUseProgram(0);
    glGetNamedBufferSubData(sampleBuffer.id, 0, static_cast<GLsizeiptr>(out.size() * 16),
                            out.data());
    readCounters(counters.id);
    context_.throwOnErrors("rvol sample: " + std::to_string(queries.size()) + " queries");
    return out;
}

}  // namespace vox::runtime
