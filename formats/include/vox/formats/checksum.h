/// @file checksum.h
/// @brief CRC-32C (Castagnoli), the checksum of every part of the .esvo and .rvol files.
#pragma once

#include <cstddef>
#include <cstdint>

namespace vox {

/// CRC-32C of @p size bytes at @p data: polynomial 0x1EDC6F41 bit-reflected (0x82F63B78), initial
/// value and final XOR 0xFFFFFFFF; crc32c("123456789") = 0xE3069283. Pass a previous result as
/// @p crc to continue a checksum over several pieces: crc32c(b, m, crc32c(a, n)) is the checksum
/// of a followed by b.
/// Uses the CPU's crc32 instruction (SSE4.2) where it has one, the portable tables otherwise:
/// the same values either way.
[[nodiscard]] std::uint32_t crc32c(const void* data, std::size_t size,
                                   std::uint32_t crc = 0) noexcept;

namespace detail {
/// crc32c by tables (slicing-by-8), on any host.
[[nodiscard]] std::uint32_t crc32cPortable(const void* data, std::size_t size,
                                           std::uint32_t crc = 0) noexcept;
/// True if this CPU has the crc32 instruction (x86-64 with SSE4.2), which crc32c then uses.
[[nodiscard]] bool crc32cHardwareAvailable() noexcept;
}  // namespace detail

}  // namespace vox
