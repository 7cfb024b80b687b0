// splitmix64's finaliser (Steele, Lea and Flood 2014): a 64-bit mix whose every output bit
// depends on every input bit, for deterministic pseudo-random values keyed by an index.
#pragma once

#include <cstdint>

namespace vox::detail {

[[nodiscard]] constexpr std::uint64_t splitmix64(std::uint64_t x) noexcept {
    x += 0x9E3779B97F4A7C15ull;
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
    x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
    return x ^ (x >> 31);
}

}  // namespace vox::detail
