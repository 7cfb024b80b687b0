// The CPU-side slice pool: blocks in one word arena, linked by patching frontier far slots.
#include <vox/base/error.h>
#include <vox/formats/esvo_reader.h>

#include <algorithm>

namespace vox::esvo {
namespace {
constexpr std::uint32_t kPageWords = kPageBytes / 4;
}

EsvoPool::EsvoPool(const EsvoReader& reader) : reader_(reader), slices_(reader.sliceCount()) {
    load(0);
    rootWord_ = slices_[0].baseWord +
                2 * arena_[slices_[0].baseWord + slices_[0].tables.rootGroupTableWord];
}

std::uint32_t EsvoPool::allocatePages(std::uint32_t pages) {
    for (auto it = freeRuns_.begin(); it != freeRuns_.end(); ++it) {
        if (it->second < pages) continue;
        const std::uint32_t first = it->first;
        it->first += pages;
        it->second -= pages;
        if (it->second == 0) freeRuns_.erase(it);
        return first;
    }
    const auto first = static_cast<std::uint32_t>(arena_.size() / kPageWords);
    if (std::uint64_t{first + pages} * kPageWords > 0x7FFFFFFFull)
        throw InvalidDataError(reader_.path(),
                               "loaded slices exceed the pool's 8 GiB addressing range");
    arena_.resize(std::size_t{first + pages} * kPageWords, 0);
    return first;
}

void EsvoPool::freePages(std::uint32_t firstPage, std::uint32_t pages) {
    std::fill_n(arena_.begin() + std::ptrdiff_t{firstPage} * kPageWords,
                std::size_t{pages} * kPageWords, 0u);
    freeRuns_.emplace_back(firstPage, pages);
    std::sort(freeRuns_.begin(), freeRuns_.end());
    // Merge neighbouring runs so large slices can reuse space.
    std::vector<std::pair<std::uint32_t, std::uint32_t>> merged;
    for (const auto& run : freeRuns_) {
        if (!merged.empty() && merged.back().first + merged.back().second == run.first)
            merged.back().second += run.second;
        else
            merged.push_back(run);
    }
    freeRuns_ = std::move(merged);
}

void EsvoPool::load(std::uint32_t slice) {
    if (slice >= slices_.size())
        throw InvalidDataError(reader_.path(),
                               "slice " + std::to_string(slice) + " does not exist");
    if (loaded(slice)) return;
    const SliceEntry& entry = reader_.slice(slice);
    if (slice != 0) load(entry.parent);
    const std::uint32_t pages = (entry.byteSize + kPageBytes - 1) / kPageBytes;
    const std::uint32_t firstPage = allocatePages(pages);
    const std::uint32_t base = firstPage * kPageWords;
    auto* bytes = reinterpret_cast<std::uint8_t*>(arena_.data() + base);
    try {
        reader_.readSlice(slice, std::span<std::uint8_t>(bytes, entry.byteSize));
        const FrontierDescriptor rootParent{1, {}};
        std::span<const FrontierDescriptor> parents(&rootParent, 1);
        if (slice != 0) {
            const auto& pf = slices_[entry.parent].frontier;
            if (std::uint64_t{entry.firstFrontier} + entry.rootGroupCount > pf.size())
                throw InvalidDataError(reader_.path(), "slice " + std::to_string(slice) +
                                                           ": frontier range exceeds its parent's");
            parents = std::span<const FrontierDescriptor>(pf.data() + entry.firstFrontier,
                                                          entry.rootGroupCount);
        }
        BlockSummary summary =
            validateBlock(reader_.path(), reader_.header(), slice, entry,
                          std::span<const std::uint8_t>(bytes, entry.byteSize), parents);
        Resident& r = slices_[slice];
        r.tables = readBlockTables(std::span<const std::uint8_t>(bytes, entry.byteSize),
                                   reader_.path(), slice, entry.fileOffset);
        r.frontier = std::move(summary.frontier);
        r.baseWord = base;
        r.pages = pages;
    } catch (...) {
        freePages(firstPage, pages);
        throw;
    }
    residentBytes_ += std::uint64_t{pages} * kPageBytes;
    ++loadedCount_;
    if (slice != 0) link(slice, true);
}

void EsvoPool::link(std::uint32_t slice, bool attach) {
    const SliceEntry& entry = reader_.slice(slice);
    const Resident& parent = slices_[entry.parent];
    const Resident& child = slices_[slice];
    for (std::uint32_t k = 0; k < entry.rootGroupCount; ++k) {
        // Units are 64-bit; words are 32-bit. The validator has checked every index used here.
        const std::uint64_t descriptorUnit =
            parent.baseWord / 2 +
            arena_[parent.baseWord + parent.tables.frontierTableWord + entry.firstFrontier + k];
        const ChildDescriptor d{arena_[2 * descriptorUnit], arena_[2 * descriptorUnit + 1]};
        const std::uint64_t slotUnit = descriptorUnit + d.childPointer();
        const std::uint64_t groupUnit =
            child.baseWord / 2 + arena_[child.baseWord + child.tables.rootGroupTableWord + k];
        const auto offset =
            static_cast<std::int64_t>(groupUnit) - static_cast<std::int64_t>(descriptorUnit);
        arena_[2 * slotUnit] =
            attach ? static_cast<std::uint32_t>(static_cast<std::int32_t>(offset)) : 0u;
    }
}

void EsvoPool::unload(std::uint32_t slice) {
    if (slice == 0 || slice >= slices_.size() || !loaded(slice)) return;
    const SliceEntry& entry = reader_.slice(slice);
    for (std::uint32_t c = 0; c < entry.childCount; ++c) unload(entry.firstChild + c);
    link(slice, false);
    Resident& r = slices_[slice];
    freePages(r.baseWord / kPageWords, r.pages);
    residentBytes_ -= std::uint64_t{r.pages} * kPageBytes;
    --loadedCount_;
    r = Resident{};
}

void EsvoPool::loadAll(std::uint32_t level) {
    for (std::uint32_t i = 0; i < slices_.size(); ++i)
        if (reader_.slice(i).firstLevel < level) load(i);
}

void EsvoPool::forEachVoxel(
    const std::function<void(const VoxelPosition&, const AttributeValue*)>& visit) const {
    struct Pending {
        std::uint32_t word;
        VoxelPosition position;
        AttributeValue value;
        bool hasValue;
    };
    std::vector<Pending> stack{{rootWord_, VoxelPosition{}, AttributeValue{}, false}};
    const std::uint32_t* words = arena_.data();
    while (!stack.empty()) {
        const Pending p = stack.back();
        stack.pop_back();
        const ChildDescriptor d{words[p.word], words[p.word + 1]};
        // Children in slot order; their descriptors are pushed in reverse so they pop in order.
        std::array<Pending, 8> children;
        std::size_t count = 0;
        for (std::uint32_t slot = 0; slot < 8; ++slot) {
            if (!((d.validMask() >> slot) & 1u)) continue;
            Pending child{0, p.position.child(slot), p.value, p.hasValue};
            if (readAttribute(words, p.word, slot, child.value)) child.hasValue = true;
            visit(child.position, child.hasValue ? &child.value : nullptr);
            if (!((d.nonLeafMask() >> slot) & 1u)) continue;
            std::int64_t offset = d.childPointer();
            if (d.far()) {
                offset = static_cast<std::int32_t>(words[p.word + 2 * d.childPointer()]);
                if (offset == 0) continue;  // child slice not loaded
            }
            child.word = static_cast<std::uint32_t>(
                p.word + 2 * (offset + popc8(d.nonLeafMask() & ((1u << slot) - 1u))));
            children[count++] = child;
        }
        while (count > 0) stack.push_back(children[--count]);
    }
}

}  // namespace vox::esvo
