#include <vox/base/error.h>
#include <vox/runtime/esvo_gpu_pool.h>
#include <vox/runtime/esvo_gpu_raycaster.h>
#include <vox/runtime/gl_context.h>

#include "esvo_raycast_glsl.h"

#include <GL/glcorearb.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>

namespace vox::runtime {
namespace {
// std430 PixelOut: t, iterations, flags, color, vec4 faceNormal, vec4 shadingNormal.
constexpr std::size_t kPixelWords = 12;
constexpr std::uint32_t kHitBit = 0x80000000u;
// The shader spells out these layout constants; they must stay formats' values.
static_assert(static_cast<std::uint32_t>(esvo::AttachmentKind::Palette) == 1 &&
              static_cast<std::uint32_t>(esvo::AttachmentKind::Dxt) == 2 &&
              static_cast<std::uint32_t>(esvo::AttachmentKind::DxtLookup) == 6);
static_assert(esvo::kPageBytes / 4 == 2048 && esvo::kCompressedBlockWords == 6);
static_assert(esvo::info::kFirstDescriptor == 2 && esvo::info::kAttachmentCount == 3 &&
              esvo::info::kAttachments == 4);
}  // namespace

EsvoGpuRaycaster::EsvoGpuRaycaster(GlContext& context, const EsvoGpuPool& pool)
    : context_(context), pool_(pool), program_("esvo ray caster", detail::kEsvoRaycastShader) {
    const esvo::EsvoReader& reader = pool.pool().reader();
    // The CPU caster's constructor (EsvoRayCaster), in the same arithmetic.
    const auto& m = reader.header().worldToRoot;
    for (int i = 0; i < 12; ++i) a_[i] = m[i];
    const double det = a_[0] * (a_[5] * a_[10] - a_[6] * a_[9]) -
                       a_[1] * (a_[4] * a_[10] - a_[6] * a_[8]) +
                       a_[2] * (a_[4] * a_[9] - a_[5] * a_[8]);
    if (!(std::abs(det) > 0))
        throw InvalidDataError(reader.path(), "header: world-to-root transform is singular");
    unitScale_ = std::cbrt(std::abs(det));
    leafSize_ = std::ldexp(1.0, -static_cast<int>(reader.header().leafDepth)) / unitScale_;
    glCreateQueries(GL_TIME_ELAPSED, 1, &query_);
    context_.throwOnErrors("esvo ray caster: set-up");
}

EsvoGpuRaycaster::~EsvoGpuRaycaster() {
    if (output_ != 0) glDeleteBuffers(1, &output_);
    if (query_ != 0) glDeleteQueries(1, &query_);
}

GpuFrame EsvoGpuRaycaster::render(const PinholeCamera& camera, const GpuCastOptions& options) {
    camera.validate();
    const CameraBasis basis(camera);
    const std::size_t pixels = std::size_t(camera.width) * std::size_t(camera.height);
    const std::uint64_t bytes = pixels * kPixelWords * 4;
    if (bytes > outputBytes_) {
        if (output_ != 0) glDeleteBuffers(1, &output_);
        glCreateBuffers(1, &output_);
        // Read back with glGetNamedBufferSubData; written only by the shader.
        glNamedBufferStorage(output_, static_cast<GLsizeiptr>(bytes), nullptr, 0);
        outputBytes_ = bytes;
    }
    const GLuint p = program_.id();
    glProgramUniform1dv(p, program_.uniform("uA"), 12, a_);
    glProgramUniform3d(p, program_.uniform("uForward"), basis.forward[0], basis.forward[1],
                       basis.forward[2]);
    glProgramUniform3d(p, program_.uniform("uRight"), basis.right[0], basis.right[1],
                       basis.right[2]);
    glProgramUniform3d(p, program_.uniform("uUp"), basis.up[0], basis.up[1], basis.up[2]);
    glProgramUniform1d(p, program_.uniform("uTanHalf"), basis.tanHalf);
    glProgramUniform1d(p, program_.uniform("uAspect"), basis.aspect);
    glProgramUniform2i(p, program_.uniform("uSize"), camera.width, camera.height);
    // The origin in octree coordinates, rounded to float as EsvoRayCaster::cast() rounds it.
    const Vec3d& o = camera.eye;
    const auto px = static_cast<float>(a_[0] * o[0] + a_[1] * o[1] + a_[2] * o[2] + a_[3] + 1.0);
    const auto py = static_cast<float>(a_[4] * o[0] + a_[5] * o[1] + a_[6] * o[2] + a_[7] + 1.0);
    const auto pz = static_cast<float>(a_[8] * o[0] + a_[9] * o[1] + a_[10] * o[2] + a_[11] + 1.0);
    glProgramUniform3f(p, program_.uniform("uOrigin"), px, py, pz);
    glProgramUniform1f(p, program_.uniform("uLodCoef"),
                       static_cast<float>(options.lodAngle * unitScale_));
    glProgramUniform1ui(p, program_.uniform("uMaxLevel"), options.maxLevel);
    glProgramUniform1ui(p, program_.uniform("uRootWord"), pool_.pool().rootDescriptorWord());
    glProgramUniform1ui(p, program_.uniform("uFlags"),
                        (options.contours ? 1u : 0u) | (options.attributes ? 2u : 0u));

    glUseProgram(p);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, pool_.buffer());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, output_);
    const auto start = std::chrono::steady_clock::now();
    glBeginQuery(GL_TIME_ELAPSED, query_);
    glDispatchCompute(static_cast<GLuint>((camera.width + 7) / 8),
                      static_cast<GLuint>((camera.height + 7) / 8), 1);
    glEndQuery(GL_TIME_ELAPSED);
    glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
    glFinish();
    const auto finished = std::chrono::steady_clock::now();
    std::vector<std::uint32_t> raw(pixels * kPixelWords);
    glGetNamedBufferSubData(output_, 0, static_cast<GLsizeiptr>(bytes), raw.data());
    GLuint64 nanoseconds = 0;
    glGetQueryObjectui64v(query_, GL_QUERY_RESULT, &nanoseconds);
    glUseProgram(0);
    context_.throwOnErrors("esvo ray caster: render");

    GpuFrame frame;
    frame.width = camera.width;
    frame.height = camera.height;
    frame.gpuMilliseconds = double(nanoseconds) * 1e-6;
    frame.wallMilliseconds = std::chrono::duration<double, std::milli>(finished - start).count();
    frame.depth.resize(pixels);
    frame.normal.assign(3 * pixels, 0.0f);
    frame.shadingNormal.assign(3 * pixels, 0.0f);
    frame.color.assign(pixels, 0);
    frame.iterations.resize(pixels);
    frame.level.assign(pixels, 0);
    for (std::size_t i = 0; i < pixels; ++i) {
        const std::uint32_t* r = &raw[i * kPixelWords];
        std::memcpy(&frame.depth[i], &r[0], 4);
        frame.iterations[i] = r[1];
        if (!(r[2] & kHitBit)) {
            frame.depth[i] = std::numeric_limits<float>::infinity();
            continue;
        }
        ++frame.hits;
        frame.level[i] = static_cast<std::uint8_t>(r[2] & 0xFFu);
        std::memcpy(&frame.normal[3 * i], &r[4], 12);
        if (r[2] & 0x40000000u) {
            frame.color[i] = r[3];
            std::memcpy(&frame.shadingNormal[3 * i], &r[8], 12);
        }
    }
    return frame;
}

}  // namespace vox::runtime
