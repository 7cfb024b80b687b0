/// @file esvo_gpu_pool.h
/// @brief The GPU mirror of an esvo::EsvoPool: its arena of 32-bit words in one shader storage
/// buffer, at the same word indices, so that far pointers and page headers mean the same there.
#pragma once

#include <vox/formats/esvo_reader.h>

#include <cstdint>
#include <vector>

namespace vox::runtime {

class GlContext;
class UploadRing;

/// Mirrors an EsvoPool's arena (EsvoPool::words(), wordCount()) into an immutable-storage SSBO
/// (GL_DYNAMIC_STORAGE_BIT). The buffer is sized to a capacity fixed at construction (at least
/// the arena's size then); sync() uploads only the 8 KB pages whose words changed since the last
/// sync (loaded slices' pages, patched far-pointer words), found by comparing with a host shadow
/// copy, so that streaming can load and unload slices in the CPU pool and then call sync().
/// If the arena outgrows the capacity, sync() reallocates the buffer (a full upload).
class EsvoGpuPool {
public:
    /// @param capacityBytes GPU buffer size to reserve (rounded up to whole 8 KB pages; at least
    /// the arena's current size). @throws RuntimeError when it exceeds
    /// GL_MAX_SHADER_STORAGE_BLOCK_SIZE (128 MiB on llvmpipe).
    EsvoGpuPool(GlContext& context, const esvo::EsvoPool& pool, std::uint64_t capacityBytes = 0);
    ~EsvoGpuPool();
    EsvoGpuPool(const EsvoGpuPool&) = delete;
    EsvoGpuPool& operator=(const EsvoGpuPool&) = delete;

    /// Uploads the pages that differ from what the GPU holds, through @p ring (the streaming
    /// path) or, without one, with glNamedBufferSubData. Returns the bytes uploaded.
    std::uint64_t sync(UploadRing* ring = nullptr);

    [[nodiscard]] const esvo::EsvoPool& pool() const noexcept { return pool_; }
    [[nodiscard]] unsigned buffer() const noexcept { return buffer_; }  ///< the SSBO name
    [[nodiscard]] std::uint64_t capacityBytes() const noexcept { return capacityBytes_; }
    /// Bytes of the arena mirrored on the GPU (the CPU pool's resident blocks and free pages).
    [[nodiscard]] std::uint64_t arenaBytes() const noexcept { return shadow_.size() * 4; }
    [[nodiscard]] std::uint64_t uploadedBytesTotal() const noexcept { return uploadedTotal_; }

private:
    void allocate(std::uint64_t bytes);

    GlContext& context_;
    const esvo::EsvoPool& pool_;
    unsigned buffer_ = 0;
    std::uint64_t capacityBytes_ = 0;
    std::vector<std::uint32_t> shadow_;  // what the GPU buffer holds, word for word
    std::uint64_t uploadedTotal_ = 0;
};

}  // namespace vox::runtime
