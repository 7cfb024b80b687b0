/// @file esvo_stream.h
/// @brief An .esvo file streamed to the GPU for a moving camera under a memory budget: what an
/// application embeds. Open the file, set the camera, call update() each frame, then render().
#pragma once

#include <vox/formats/esvo_reader.h>
#include <vox/base/camera.h>
#include <vox/runtime/esvo_gpu_pool.h>
#include <vox/runtime/esvo_gpu_raycaster.h>
#include <vox/runtime/slice_schedule.h>
#include <vox/runtime/upload_ring.h>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace vox::runtime {

/// How an EsvoStream streams.
struct EsvoStreamOptions {
    /// Most bytes of slices resident (CPU pool and GPU buffer alike); cut to the GL's largest
    /// shader storage block (GL_MAX_SHADER_STORAGE_BLOCK_SIZE, 128 MiB on llvmpipe) less the
    /// root slice. options() tells the budget in force.
    std::uint64_t budgetBytes = 256u << 20;
    std::uint64_t frameLoadBytes =
        0;                ///< most bytes of slices loaded per update (0: all that is needed)
    double lodScale = 1;  ///< detail: voxels of about lodScale pixels
    UploadPath uploadPath = UploadPath::PersistentRing;
    std::uint64_t ringBytes = 8u << 20;  ///< the staging ring (PersistentRing)
};

/// What one update() did.
struct EsvoStreamUpdate {
    std::uint32_t loaded = 0, evicted = 0;  ///< slices
    std::uint64_t loadedBytes = 0;          ///< resident bytes of the slices loaded
    std::uint32_t pending = 0;           ///< needed slices left for later frames by frameLoadBytes
    std::uint32_t neededNotFitting = 0;  ///< needed slices the budget leaves out
    std::uint64_t uploadedBytes = 0;     ///< bytes sent to the GPU
    std::uint64_t residentBytes = 0;     ///< slice bytes resident after the update
    double seconds = 0;                  ///< reading, validating and uploading
    /// Slices found corrupt or unreadable so far (this update and earlier ones): each is left out
    /// with everything below it, never retried, and rays stop at its parent's level there.
    std::uint32_t badSlices = 0;
    /// One line per slice that failed in this update, naming the file, the slice and the problem.
    std::vector<std::string> errors;
};

/// An .esvo file on the GPU, streamed slice by slice: each update() selects the slices the
/// camera needs (coarse and near first, within the budget), evicts the least recently needed
/// ones to make room, reads and validates the new ones into the CPU pool and uploads the changed
/// pages through the upload ring. Missing children are unlinked in the pool, so rays stop at the
/// finest resident level instead of reading missing data: a frame never shows a hole, only
/// coarser voxels where detail has not arrived. Needs the context current on the calling thread.
class EsvoStream {
public:
    /// Opens @p file (header, directory, root slice). @throws IoError, InvalidDataError,
    /// RuntimeError.
    EsvoStream(GlContext& context, const std::filesystem::path& file,
               const EsvoStreamOptions& options = {});

    void setCamera(const PinholeCamera& camera);
    /// A new budget, at most the one the stream was opened with (its GPU buffer is that big).
    void setBudget(std::uint64_t bytes);
    /// Brings the resident slices to what the camera needs. A slice that fails to load (checksum,
    /// structure or read error) does not stop the update: it is reported in errors, counted in
    /// badSlices and never loaded again; the rest stream on. @throws RuntimeError on a GL error.
    EsvoStreamUpdate update();
    /// Cast options matching the streamed detail: the LOD cut at lodScale pixels.
    [[nodiscard]] GpuCastOptions castOptions() const;
    /// Casts the current camera's primary rays over the resident slices.
    [[nodiscard]] GpuFrame render(const GpuCastOptions& options);

    [[nodiscard]] const esvo::EsvoReader& reader() const noexcept { return *reader_; }
    [[nodiscard]] const esvo::EsvoPool& pool() const noexcept { return *pool_; }
    [[nodiscard]] const EsvoGpuPool& gpuPool() const noexcept { return *gpuPool_; }
    [[nodiscard]] const UploadRing& ring() const noexcept { return ring_; }
    [[nodiscard]] const PinholeCamera& camera() const noexcept { return camera_; }
    [[nodiscard]] const EsvoStreamOptions& options() const noexcept { return options_; }

private:
    GlContext& context_;
    EsvoStreamOptions options_;
    std::unique_ptr<esvo::EsvoReader> reader_;
    std::unique_ptr<esvo::EsvoPool> pool_;
    std::unique_ptr<SliceResidency> residency_;
    UploadRing ring_;
    std::unique_ptr<EsvoGpuPool> gpuPool_;
    std::unique_ptr<EsvoGpuRaycaster> caster_;
    PinholeCamera camera_;
};

}  // namespace vox::runtime
