// Streaming uploads (runtime/src/upload_ring.cpp) on the real GL implementation (Mesa llvmpipe
// in CI): bytes arrive intact through the persistent ring, across wraps, and through the plain
// buffer-update fallback, with no GL error.
#include <vox/runtime/gl_context.h>
#include <vox/runtime/upload_ring.h>

#include "gl_test_context.h"

#include <GL/glcorearb.h>
#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <vector>

namespace {

std::vector<std::byte> randomBytes(std::size_t n, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::vector<std::byte> out(n);
    for (auto& b : out) b = std::byte(rng() & 0xFF);
    return out;
}

/// Uploads @p chunks of random data at scattered offsets of one buffer and reads it back.
void roundTrip(vox::runtime::HeadlessGlContext& context, vox::runtime::UploadRing& ring) {
    constexpr std::size_t kBytes = 3 << 20;
    GLuint buffer = 0;
    glCreateBuffers(1, &buffer);
    glNamedBufferStorage(buffer, kBytes, nullptr, GL_DYNAMIC_STORAGE_BIT);
    std::vector<std::byte> expected(kBytes, std::byte{0});
    glClearNamedBufferData(buffer, GL_R8UI, GL_RED_INTEGER, GL_UNSIGNED_BYTE, nullptr);
    std::mt19937_64 rng(7);
    for (int k = 0; k < 40; ++k) {
        const std::size_t size = 4 * (1 + rng() % 40000);
        const std::size_t offset = 4 * (rng() % ((kBytes - size) / 4));
        const auto data = randomBytes(size, 100 + std::uint64_t(k));
        ring.upload(buffer, offset, data);
        std::memcpy(expected.data() + offset, data.data(), size);
    }
    std::vector<std::byte> actual(kBytes);
    glGetNamedBufferSubData(buffer, 0, kBytes, actual.data());
    glDeleteBuffers(1, &buffer);
    EXPECT_TRUE(actual == expected);
    EXPECT_EQ(context.errorCount(), 0u) << context.errorSummary();
}

}  // namespace

TEST(UploadRing, PersistentRingDeliversEveryByteAcrossWraps) {
    REQUIRE_GL();
    // A 256 KB ring under 1.6 MB of uploads: it wraps several times, and uploads bigger than a
    // quarter of it go in parts.
    vox::runtime::UploadRing ring(*gl, 256 << 10, vox::runtime::UploadPath::PersistentRing);
    EXPECT_EQ(ring.path(), vox::runtime::UploadPath::PersistentRing);
    roundTrip(*gl, ring);
    EXPECT_GT(ring.bytesUploaded(), 2 * ring.ringBytes());
}

TEST(UploadRing, BufferSubDataFallbackDeliversTheSameBytes) {
    REQUIRE_GL();
    vox::runtime::UploadRing ring(*gl, 0, vox::runtime::UploadPath::BufferSubData);
    roundTrip(*gl, ring);
    EXPECT_EQ(ring.fenceWaits(), 0u);
}
