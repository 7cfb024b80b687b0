// Streaming uploads (runtime/src/upload_ring.cpp) on the real GL implementation (Mesa llvmpipe
// in CI): bytes arrive intact through the persistent ring, across wraps, and through the plain
// buffer-update fallback, with no GL error.
#include <vox/runtime/gl_context.h>
#include <vox/runtime/upload_ring.h>

#include <GL/glcorearb.h>
#include <gtest/gtest.h>

#include <cstring>
#include <memory>
#include <optional>
#include <random>
#include <vector>

namespace {

/// The context, or a skip with the reason where this machine has no OpenGL 4.5 at all.
std::unique_ptr<vox::runtime::HeadlessGlContext> makeContext(std::string& why) {
    try {
        return std::make_unique<vox::runtime::HeadlessGlContext>();
    } catch (const std::exception& e) {
        why = e.what();
        return nullptr;
    }
}

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
    std::string why;
    auto context = makeContext(why);
    if (!context) GTEST_SKIP() << "no OpenGL 4.5 context: " << why;
    // A 256 KB ring under 1.6 MB of uploads: it wraps several times, and uploads bigger than a
    // quarter of it go in parts.
    vox::runtime::UploadRing ring(*context, 256 << 10, vox::runtime::UploadPath::PersistentRing);
    EXPECT_EQ(ring.path(), vox::runtime::UploadPath::PersistentRing);
    roundTrip(*context, ring);
    EXPECT_GT(ring.bytesUploaded(), 2 * ring.ringBytes());
}

TEST(UploadRing, BufferSubDataFallbackDeliversTheSameBytes) {
    std::string why;
    auto context = makeContext(why);
    if (!context) GTEST_SKIP() << "no OpenGL 4.5 context: " << why;
    vox::runtime::UploadRing ring(*context, 0, vox::runtime::UploadPath::BufferSubData);
    roundTrip(*context, ring);
    EXPECT_EQ(ring.fenceWaits(), 0u);
}
