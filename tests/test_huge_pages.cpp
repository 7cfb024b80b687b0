// libvox/src/util/huge_pages.h: the advice covers exactly the whole huge pages of a range, and
// HugePageArena's copies stay where they are, intact and aligned, while it grows.
#include "util/huge_pages.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <sstream>
#include <string>
#include <vector>

namespace {

using vox::detail::adviseHugePages;
using vox::detail::HugePageArena;
using vox::detail::kHugePageBytes;

/// The VmFlags of the mapping of this process holding @p address ("" if none): "hg" marks a
/// range advised with MADV_HUGEPAGE.
std::string mappingFlags(std::uintptr_t address) {
    std::ifstream smaps("/proc/self/smaps");
    std::string line;
    bool inside = false;
    while (std::getline(smaps, line)) {
        std::uintptr_t start = 0, end = 0;
        char dash = 0;
        std::istringstream header(line);
        if (header >> std::hex >> start >> dash >> end && dash == '-') {
            inside = address >= start && address < end;
            continue;
        }
        if (inside && line.rfind("VmFlags:", 0) == 0) return line.substr(8);
    }
    return "";
}

bool advised(std::uintptr_t address) {
    return mappingFlags(address).find(" hg") != std::string::npos;
}

TEST(AdviseHugePages, AdvisesTheWholeHugePagesInsideTheRangeOnly) {
    if (!std::filesystem::exists("/sys/kernel/mm/transparent_hugepage/enabled"))
        GTEST_SKIP() << "no transparent huge pages here";
    // Eight huge pages of address space, from a huge-page boundary; advise from half a page into
    // the second to half a page into the seventh: pages 2 to 5 (0-based) are whole inside.
    std::vector<std::byte> memory(9 * kHugePageBytes);
    const auto base = (reinterpret_cast<std::uintptr_t>(memory.data()) + kHugePageBytes - 1) &
                      ~std::uintptr_t{kHugePageBytes - 1};
    const std::uintptr_t from = base + kHugePageBytes + kHugePageBytes / 2,
                         to = base + 6 * kHugePageBytes + kHugePageBytes / 2;
    adviseHugePages(reinterpret_cast<void*>(from), to - from);
    EXPECT_FALSE(advised(base + kHugePageBytes + kHugePageBytes - 1));  // the partial page before
    EXPECT_TRUE(advised(base + 2 * kHugePageBytes));
    EXPECT_TRUE(advised(base + 6 * kHugePageBytes - 1));
    EXPECT_FALSE(advised(base + 6 * kHugePageBytes));  // the partial page after
    // Ranges without a whole huge page, and none at all, are left alone.
    adviseHugePages(reinterpret_cast<void*>(base + 7 * kHugePageBytes + 1), kHugePageBytes);
    EXPECT_FALSE(advised(base + 7 * kHugePageBytes + kHugePageBytes / 2));
    adviseHugePages(nullptr, 0);
}

TEST(AdviseHugePages, VectorOverloadCoversItsCapacity) {
    if (!std::filesystem::exists("/sys/kernel/mm/transparent_hugepage/enabled"))
        GTEST_SKIP() << "no transparent huge pages here";
    std::vector<std::uint64_t> values;
    values.reserve(3 * kHugePageBytes / sizeof(std::uint64_t));
    adviseHugePages(values);
    const auto data = reinterpret_cast<std::uintptr_t>(values.data());
    const std::uintptr_t firstWhole =
        (data + kHugePageBytes - 1) & ~std::uintptr_t{kHugePageBytes - 1};
    EXPECT_TRUE(advised(firstWhole));
    EXPECT_TRUE(advised(firstWhole + kHugePageBytes));
}

TEST(HugePageArena, CopiesStayIntactAlignedAndInPlaceAsItGrows) {
    HugePageArena arena;
    EXPECT_TRUE(arena.copy(std::span<const std::uint32_t>()).empty());
    EXPECT_EQ(arena.reservedBytes(), 0u);
    // Odd-sized copies of mixed alignment, far more than the first blocks hold, and one larger
    // than the largest block.
    struct Copy {
        std::span<const std::uint8_t> bytes;
        std::span<const std::uint64_t> words;
        std::uint64_t seed;
    };
    std::vector<Copy> copies;
    std::uint64_t seed = 1;
    for (int i = 0; i < 3000; ++i) {
        std::vector<std::uint8_t> bytes(1 + (i * 7919) % 5000);
        std::vector<std::uint64_t> words(1 + (i * 104729) % 2000);
        if (i == 1500) words.resize((std::size_t{20} << 20) / sizeof(std::uint64_t));
        std::iota(bytes.begin(), bytes.end(), static_cast<std::uint8_t>(seed));
        std::iota(words.begin(), words.end(), seed * 1000003);
        copies.push_back({arena.copy(std::span<const std::uint8_t>(bytes)),
                          arena.copy(std::span<const std::uint64_t>(words)), seed});
        ASSERT_EQ(copies.back().bytes.size(), bytes.size());
        ASSERT_EQ(copies.back().words.size(), words.size());
        ASSERT_NE(static_cast<const void*>(copies.back().words.data()),
                  static_cast<const void*>(words.data()));
        ++seed;
    }
    EXPECT_GE(arena.reservedBytes(), std::size_t{20} << 20);
    for (const Copy& c : copies) {
        EXPECT_EQ(reinterpret_cast<std::uintptr_t>(c.words.data()) % alignof(std::uint64_t), 0u);
        for (std::size_t i = 0; i < c.bytes.size(); ++i)
            ASSERT_EQ(c.bytes[i], static_cast<std::uint8_t>(c.seed + i))
                << "copy " << c.seed << " byte " << i;
        for (std::size_t i = 0; i < c.words.size(); ++i)
            ASSERT_EQ(c.words[i], c.seed * 1000003 + i) << "copy " << c.seed << " word " << i;
    }
}

}  // namespace
