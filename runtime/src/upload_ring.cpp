// A persistently mapped staging ring with fences, the streaming path of the runtime.
#include <vox/runtime/gl_context.h>
#include <vox/runtime/upload_ring.h>

#include <GL/glcorearb.h>

#include <algorithm>
#include <cstring>

namespace vox::runtime {

UploadRing::UploadRing(GlContext& context, std::uint64_t ringBytes, UploadPath path)
    : context_(context), path_(path) {
    if (path_ == UploadPath::BufferSubData) return;
    size_ = std::max<std::uint64_t>((ringBytes + 255) / 256 * 256, 4096);
    constexpr GLbitfield flags = GL_MAP_WRITE_BIT | GL_MAP_PERSISTENT_BIT | GL_MAP_COHERENT_BIT;
    glCreateBuffers(1, &ring_);
    glObjectLabel(GL_BUFFER, ring_, -1, "vox upload ring");
    glNamedBufferStorage(ring_, GLsizeiptr(size_), nullptr, flags);
    mapped_ = static_cast<std::byte*>(glMapNamedBufferRange(ring_, 0, GLsizeiptr(size_), flags));
    context_.throwOnErrors("upload ring");
    if (mapped_ == nullptr)
        throw RuntimeError("upload ring: the staging buffer could not be mapped persistently");
}

UploadRing::~UploadRing() {
    for (const Fenced& f : fences_) glDeleteSync(static_cast<GLsync>(f.sync));
    if (ring_ != 0) {
        glUnmapNamedBuffer(ring_);
        glDeleteBuffers(1, &ring_);
    }
}

void UploadRing::waitFor(std::uint64_t begin, std::uint64_t end) {
    // Fences are in ring order; wait on (and drop) every one whose range meets [begin, end).
    auto keep = fences_.begin();
    for (auto it = fences_.begin(); it != fences_.end(); ++it) {
        if (it->begin < end && begin < it->end) {
            const GLsync sync = static_cast<GLsync>(it->sync);
            if (glClientWaitSync(sync, 0, 0) == GL_TIMEOUT_EXPIRED) {
                ++waits_;
                while (glClientWaitSync(sync, GL_SYNC_FLUSH_COMMANDS_BIT, 1'000'000'000) ==
                       GL_TIMEOUT_EXPIRED) {}
            }
            glDeleteSync(sync);
        } else {
            *keep++ = *it;
        }
    }
    fences_.erase(keep, fences_.end());
}

void UploadRing::closeSegment() {
    if (head_ > segmentStart_)
        fences_.push_back({segmentStart_, head_, glFenceSync(GL_SYNC_GPU_COMMANDS_COMPLETE, 0)});
    segmentStart_ = head_;
}

void UploadRing::upload(unsigned target, std::uint64_t offset, std::span<const std::byte> data) {
    if (data.empty()) return;
    if (path_ == UploadPath::BufferSubData) {
        glNamedBufferSubData(target, GLintptr(offset), GLsizeiptr(data.size()), data.data());
        uploaded_ += data.size();
        return;
    }
    const std::uint64_t part = std::max<std::uint64_t>(size_ / 4, 256);
    for (std::uint64_t done = 0; done < data.size();) {
        const std::uint64_t n = std::min<std::uint64_t>(part, data.size() - done);
        if (head_ + n > size_) {  // wrap: parts never straddle the end
            closeSegment();
            head_ = segmentStart_ = 0;
        }
        waitFor(head_, head_ + n);
        std::memcpy(mapped_ + head_, data.data() + done, n);
        glCopyNamedBufferSubData(ring_, target, GLintptr(head_), GLintptr(offset + done),
                                 GLsizeiptr(n));
        // Keep parts 256-byte aligned in the ring.
        head_ += (n + 255) / 256 * 256;
        done += n;
        // One fence per quarter of the ring, not per part: small uploads would otherwise pay a
        // fence each (8 KB parts ran at a tenth of the speed on llvmpipe).
        if (head_ - segmentStart_ >= size_ / 4) closeSegment();
    }
    uploaded_ += data.size();
}

}  // namespace vox::runtime
