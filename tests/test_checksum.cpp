// CRC-32C (formats/src/checksum.cpp): the published check values, and the crc32-instruction path
// against the portable tables on every length and alignment a reader or writer meets.
#include <vox/formats/checksum.h>

#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <random>
#include <string_view>
#include <vector>

namespace {

using vox::crc32c;
using vox::detail::crc32cPortable;

TEST(Checksum, Crc32cMatchesTheCheckValueAndRfc3720Vectors) {
    constexpr std::string_view check = "123456789";
    std::array<std::uint8_t, 32> zeros{}, ones{}, up{}, down{};
    for (std::size_t i = 0; i < 32; ++i) {
        ones[i] = 0xFF;
        up[i] = static_cast<std::uint8_t>(i);
        down[i] = static_cast<std::uint8_t>(31 - i);
    }
    for (auto* f : {&crc32c, &crc32cPortable}) {
        EXPECT_EQ(f(check.data(), check.size(), 0), 0xE3069283u);
        EXPECT_EQ(f(zeros.data(), zeros.size(), 0), 0x8A9136AAu);  // RFC 3720 B.4
        EXPECT_EQ(f(ones.data(), ones.size(), 0), 0x62A8AB43u);
        EXPECT_EQ(f(up.data(), up.size(), 0), 0x46DD794Eu);
        EXPECT_EQ(f(down.data(), down.size(), 0), 0x113FDB5Cu);
        EXPECT_EQ(f(nullptr, 0, 0), 0u);
    }
}

TEST(Checksum, Crc32cByTheInstructionAgreesWithTheTablesOnEveryLengthAndAlignment) {
    if (!vox::detail::crc32cHardwareAvailable())
        GTEST_SKIP() << "no crc32 instruction on this CPU (crc32c is the tables)";
    std::mt19937 random(7);
    std::vector<std::uint8_t> bytes(4096 + 8);
    for (auto& b : bytes) b = static_cast<std::uint8_t>(random());
    for (std::size_t offset = 0; offset < 8; ++offset)
        for (std::size_t size = 0; size <= 300; ++size) {
            const std::uint32_t seed = static_cast<std::uint32_t>(random());
            ASSERT_EQ(crc32c(bytes.data() + offset, size, seed),
                      crc32cPortable(bytes.data() + offset, size, seed))
                << "offset " << offset << ", " << size << " bytes";
        }
    EXPECT_EQ(crc32c(bytes.data(), 4096), crc32cPortable(bytes.data(), 4096));
}

TEST(Checksum, Crc32cContinuesOverPieces) {
    std::vector<std::uint8_t> bytes(1000);
    for (std::size_t i = 0; i < bytes.size(); ++i) bytes[i] = static_cast<std::uint8_t>(i * 7 + 3);
    const std::uint32_t whole = crc32c(bytes.data(), bytes.size());
    for (std::size_t cut : {0u, 1u, 7u, 8u, 333u, 999u, 1000u})
        EXPECT_EQ(crc32c(bytes.data() + cut, bytes.size() - cut, crc32c(bytes.data(), cut)), whole)
            << "cut at " << cut;
    bytes[500] ^= 1;
    EXPECT_NE(crc32c(bytes.data(), bytes.size()), whole);
}

}  // namespace
