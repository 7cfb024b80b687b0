/// @file upload_ring.h
/// @brief Streaming uploads through a persistently mapped staging ring (GL 4.4 buffer storage
/// with fences), with plain buffer updates as the fallback.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace vox::runtime {

class GlContext;

/// How UploadRing moves bytes to the GPU.
enum class UploadPath : std::uint8_t {
    /// A staging buffer mapped once (GL_MAP_PERSISTENT_BIT | GL_MAP_COHERENT_BIT): the CPU writes
    /// into the ring while the GPU copies earlier parts out (glCopyNamedBufferSubData), each
    /// quarter of the ring guarded by a fence that is waited on only when the ring wraps onto it.
    PersistentRing,
    /// glNamedBufferSubData straight into the target: the driver copies (and may stall).
    BufferSubData,
};

/// Copies host bytes into GPU buffers. Needs the context current on the calling thread.
class UploadRing {
public:
    /// @p ringBytes: the staging ring's size (rounded up to 256 bytes; uploads larger than a
    /// quarter of it go in several parts). @throws RuntimeError on a GL error.
    UploadRing(GlContext& context, std::uint64_t ringBytes = 8u << 20,
               UploadPath path = UploadPath::PersistentRing);
    ~UploadRing();
    UploadRing(const UploadRing&) = delete;
    UploadRing& operator=(const UploadRing&) = delete;

    /// Queues a copy of @p data into buffer @p target at byte @p offset. The data is consumed
    /// before this returns (the caller may reuse it); the copy is ordered before later GL
    /// commands that read @p target.
    void upload(unsigned target, std::uint64_t offset, std::span<const std::byte> data);

    [[nodiscard]] UploadPath path() const noexcept { return path_; }
    [[nodiscard]] std::uint64_t ringBytes() const noexcept { return size_; }
    [[nodiscard]] std::uint64_t bytesUploaded() const noexcept { return uploaded_; }
    /// Times upload() waited on a fence because the ring wrapped onto data still being copied.
    [[nodiscard]] std::uint64_t fenceWaits() const noexcept { return waits_; }

private:
    struct Fenced {
        std::uint64_t begin, end;  // ring bytes the copy reads
        void* sync;                // GLsync
    };
    void waitFor(std::uint64_t begin, std::uint64_t end);
    void closeSegment();  // fences the ring bytes written since the last fence

    GlContext& context_;
    UploadPath path_;
    unsigned ring_ = 0;
    std::byte* mapped_ = nullptr;
    std::uint64_t size_ = 0, head_ = 0, segmentStart_ = 0;
    std::vector<Fenced> fences_;
    std::uint64_t uploaded_ = 0, waits_ = 0;
};

}  // namespace vox::runtime
