#include "huge_pages.h"

#include <algorithm>
#include <cstdint>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace vox::detail {

void adviseHugePages(void* data, std::size_t bytes) noexcept {
#if defined(MADV_HUGEPAGE)
    const auto start = reinterpret_cast<std::uintptr_t>(data);
    const std::uintptr_t first = (start + kHugePageBytes - 1) & ~std::uintptr_t{kHugePageBytes - 1};
    const std::uintptr_t end = (start + bytes) & ~std::uintptr_t{kHugePageBytes - 1};
    // Advice only: where the kernel has no huge pages to give (THP off, memory fragmented), the
    // range stays on small pages and nothing else changes.
    if (data != nullptr && end > first)
        (void)::madvise(reinterpret_cast<void*>(first), end - first, MADV_HUGEPAGE);
#else
    (void)data;
    (void)bytes;
#endif
}

void* HugePageArena::allocate(std::size_t bytes, std::size_t alignment) {
    const auto aligned = [&] {
        const auto at = reinterpret_cast<std::uintptr_t>(next_);
        return (alignment - at % alignment) % alignment;
    };
    if (next_ == nullptr || aligned() + bytes > left_) {
        // Blocks double from 1 MiB (a storage that holds little takes little) to 16 MiB, or what
        // one copy needs; a block starts on a huge-page boundary so that all of it can be one.
        const std::size_t size = std::max(bytes + alignment, blockBytes_);
        blockBytes_ = std::min(2 * blockBytes_, std::size_t{16} << 20);
        const std::size_t padding = size >= kHugePageBytes ? kHugePageBytes : 0;
        blocks_.push_back(std::make_unique_for_overwrite<std::byte[]>(size + padding));
        std::byte* block = blocks_.back().get();
        if (padding) {
            const auto at = reinterpret_cast<std::uintptr_t>(block);
            block += (kHugePageBytes - at % kHugePageBytes) % kHugePageBytes;
            adviseHugePages(block, size);
        }
        next_ = block;
        left_ = size;
        reserved_ += size;
    }
    const std::size_t skip = aligned();
    void* at = next_ + skip;
    next_ += skip + bytes;
    left_ -= skip + bytes;
    return at;
}

}  // namespace vox::detail
