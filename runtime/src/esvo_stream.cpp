// An .esvo file streamed to the GPU for a moving camera: residency, upload, cast.
#include <vox/runtime/esvo_stream.h>
#include <vox/runtime/gl_context.h>

#include <GL/glcorearb.h>

#include <algorithm>
#include <chrono>

namespace vox::runtime {

EsvoStream::EsvoStream(GlContext& context, const std::filesystem::path& file,
                       const EsvoStreamOptions& options)
    : context_(context),
      options_(options),
      reader_(std::make_unique<esvo::EsvoReader>(file)),
      pool_(std::make_unique<esvo::EsvoPool>(*reader_)),
      residency_(std::make_unique<SliceResidency>(*pool_, options.budgetBytes)),
      ring_(context, options.ringBytes, options.uploadPath) {
    // The GPU buffer is sized for the budget up front (plus the root slice, which stays even
    // over it), so streaming within the budget never reallocates it; a budget beyond the GL's
    // largest shader storage block is cut to fit it.
    GLint64 largest = 0;
    glGetInteger64v(GL_MAX_SHADER_STORAGE_BLOCK_SIZE, &largest);
    const std::uint64_t root = residentBytesOf(reader_->slice(0));
    if (largest > 0 && options_.budgetBytes + root > std::uint64_t(largest))
        options_.budgetBytes = std::uint64_t(largest) > root ? std::uint64_t(largest) - root : 0;
    residency_->setBudget(options_.budgetBytes);
    residency_->setFrameLoadLimit(options_.frameLoadBytes);
    gpuPool_ = std::make_unique<EsvoGpuPool>(context, *pool_, options_.budgetBytes + root);
    caster_ = std::make_unique<EsvoGpuRaycaster>(context, *gpuPool_);
}

void EsvoStream::setCamera(const PinholeCamera& camera) {
    camera.validate();
    camera_ = camera;
}

void EsvoStream::setBudget(std::uint64_t bytes) {
    // Within the GPU buffer reserved at construction.
    const std::uint64_t root = residentBytesOf(reader_->slice(0));
    options_.budgetBytes = bytes = std::min(bytes, gpuPool_->capacityBytes() - root);
    residency_->setBudget(bytes);
}

EsvoStreamUpdate EsvoStream::update() {
    const auto start = std::chrono::steady_clock::now();
    const SliceResidency::Update u = residency_->update({camera_, options_.lodScale});
    EsvoStreamUpdate out;
    out.loaded = static_cast<std::uint32_t>(u.loaded.size());
    out.evicted = static_cast<std::uint32_t>(u.evicted.size());
    out.loadedBytes = u.loadedBytes;
    out.pending = u.pending;
    out.neededNotFitting = u.selection.neededNotFitting;
    out.badSlices = static_cast<std::uint32_t>(residency_->badSlices().size());
    out.errors = u.errors;
    // The pool's words change only where slices were loaded or unloaded; comparing the whole
    // arena with the GPU's copy costs a pass over it (≈ 19 ms for 120 MB), so skip it otherwise.
    if (!u.loaded.empty() || !u.evicted.empty()) out.uploadedBytes = gpuPool_->sync(&ring_);
    out.residentBytes = pool_->residentBytes();
    out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return out;
}

GpuCastOptions EsvoStream::castOptions() const {
    GpuCastOptions options;
    options.lodAngle = camera_.pixelAngle() * options_.lodScale;
    return options;
}

GpuFrame EsvoStream::render(const GpuCastOptions& options) {
    return caster_->render(camera_, options);
}

}  // namespace vox::runtime
