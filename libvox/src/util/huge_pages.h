// Transparent huge pages for the build's large arrays. A fresh 4 KiB page costs a page fault on
// its first write (several microseconds in a virtual machine, and the faults of a process's
// threads contend); the arrays a build fills once and reads in no particular order (the octree's
// levels, the cells' outputs) fault tens of thousands of times at depth 10 and hundreds of
// thousands at 12 unless they sit on 2 MiB pages, which also spare the TLB. Linux gives huge
// pages to ranges advised with madvise(MADV_HUGEPAGE) where
// /sys/kernel/mm/transparent_hugepage/enabled is "madvise" (as on the development machines) or
// "always"; elsewhere the advice does nothing.
#pragma once

#include <cstddef>
#include <cstring>
#include <memory>
#include <span>
#include <type_traits>
#include <vector>

namespace vox::detail {

/// The size of a transparent huge page on x86-64 (and arm64 with 4 KiB pages).
inline constexpr std::size_t kHugePageBytes = std::size_t{2} << 20;

/// Advises the whole huge pages within [@p data, @p data + @p bytes) for transparent huge pages.
/// Call it before the range is first written (a page already touched stays small until the
/// kernel's background collapse); ranges smaller than a huge page are left alone.
void adviseHugePages(void* data, std::size_t bytes) noexcept;

/// adviseHugePages on a vector's whole capacity: call it after reserve() and before filling it.
template <class T>
void adviseHugePages(std::vector<T>& values) noexcept {
    adviseHugePages(values.data(), values.capacity() * sizeof(T));
}

/// Append-only storage for values copied once and read until the storage is dropped: large
/// blocks on huge pages instead of a vector per array. Not thread-safe; what it returned stays
/// where it is until the storage is destroyed.
class HugePageArena {
public:
    HugePageArena() = default;
    HugePageArena(const HugePageArena&) = delete;
    HugePageArena& operator=(const HugePageArena&) = delete;

    /// A copy of @p values in this storage (empty for no values).
    template <class T>
    std::span<const T> copy(std::span<const T> values) {
        static_assert(std::is_trivially_copyable_v<T>);
        if (values.empty()) return {};
        void* at = allocate(values.size_bytes(), alignof(T));
        std::memcpy(at, values.data(), values.size_bytes());
        return {static_cast<const T*>(at), values.size()};
    }
    /// Bytes of the blocks it holds (address space; only what was written is resident).
    [[nodiscard]] std::size_t reservedBytes() const noexcept { return reserved_; }

private:
    void* allocate(std::size_t bytes, std::size_t alignment);

    std::vector<std::unique_ptr<std::byte[]>> blocks_;
    std::byte* next_ = nullptr;
    std::size_t left_ = 0;
    std::size_t reserved_ = 0;
    std::size_t blockBytes_ = std::size_t{1} << 20;  ///< of the next block
};

}  // namespace vox::detail
