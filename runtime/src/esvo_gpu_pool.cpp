#include <vox/runtime/esvo_gpu_pool.h>
#include <vox/runtime/gl_context.h>
#include <vox/runtime/upload_ring.h>

#include <GL/glcorearb.h>

#include <algorithm>
#include <cstring>
#include <span>

namespace vox::runtime {
namespace {
constexpr std::uint64_t kPageWords = esvo::kPageBytes / 4;
std::uint64_t roundToPages(std::uint64_t bytes) {
    return (bytes + esvo::kPageBytes - 1) / esvo::kPageBytes * esvo::kPageBytes;
}
}  // namespace

EsvoGpuPool::EsvoGpuPool(GlContext& context, const esvo::EsvoPool& pool,
                         std::uint64_t capacityBytes)
    : context_(context), pool_(pool) {
    allocate(std::max<std::uint64_t>(
        {roundToPages(capacityBytes), roundToPages(pool.wordCount() * 4), esvo::kPageBytes}));
    sync();
}

EsvoGpuPool::~EsvoGpuPool() {
    if (buffer_ != 0) glDeleteBuffers(1, &buffer_);
}

void EsvoGpuPool::allocate(std::uint64_t bytes) {
    GLint64 limit = 0;
    glGetInteger64v(GL_MAX_SHADER_STORAGE_BLOCK_SIZE, &limit);
    if (bytes > static_cast<std::uint64_t>(limit))
        throw RuntimeError(pool_.reader().path().string() + ": the octree pool needs " +
                           std::to_string(bytes) +
                           " bytes, more than this GL's largest shader storage block (" +
                           std::to_string(limit) + ")");
    if (buffer_ != 0) glDeleteBuffers(1, &buffer_);
    glCreateBuffers(1, &buffer_);
    // Immutable storage, updated with glNamedBufferSubData: the pool changes a few pages at a
    // time when slices stream in, never wholesale.
    glNamedBufferStorage(buffer_, static_cast<GLsizeiptr>(bytes), nullptr, GL_DYNAMIC_STORAGE_BIT);
    static constexpr char kLabel[] = "esvo pool";
    glObjectLabel(GL_BUFFER, buffer_, sizeof kLabel - 1, kLabel);
    capacityBytes_ = bytes;
    shadow_.clear();  // the new buffer holds nothing yet: everything is dirty
    context_.throwOnErrors("esvo pool: allocating " + std::to_string(bytes) + " bytes");
}

std::uint64_t EsvoGpuPool::sync(UploadRing* ring) {
    const std::size_t words = pool_.wordCount();
    if (words * 4 > capacityBytes_)
        allocate(roundToPages(words * 4 + words * 2));  // grow by half again
    const std::uint32_t* source = pool_.words();
    const std::size_t known = std::min(shadow_.size(), words);
    std::uint64_t uploaded = 0;
    // Runs of changed pages, each uploaded with one call.
    std::size_t runStart = 0, runEnd = 0;
    const auto flush = [&] {
        if (runEnd > runStart) {
            if (ring != nullptr)
                ring->upload(buffer_, runStart * 4,
                             std::as_bytes(std::span(source + runStart, runEnd - runStart)));
            else
                glNamedBufferSubData(buffer_, static_cast<GLintptr>(runStart * 4),
                                     static_cast<GLsizeiptr>((runEnd - runStart) * 4),
                                     source + runStart);
            uploaded += (runEnd - runStart) * 4;
        }
        runStart = runEnd = 0;
    };
    for (std::size_t page = 0; page < words; page += kPageWords) {
        const std::size_t end = std::min<std::size_t>(page + kPageWords, words);
        const bool same = end <= known &&
                          std::memcmp(source + page, shadow_.data() + page, (end - page) * 4) == 0;
        if (same) {
            flush();
            continue;
        }
        if (runEnd != page) flush(), runStart = page;
        runEnd = end;
    }
    flush();
    shadow_.assign(source, source + words);
    uploadedTotal_ += uploaded;
    context_.throwOnErrors("esvo pool: upload");
    return uploaded;
}

}  // namespace vox::runtime
