#include "esvo_assemble.h"

#include <vox/formats/atomic_file.h>
#include <vox/base/error.h>

#include <algorithm>
#include <array>
#include <map>
#include <stdexcept>
#include <utility>

namespace vox::detail {

SliceStore::SliceStore(std::uint64_t memoryBudget, std::filesystem::path scratchDirectory)
    : memoryBudget_(memoryBudget), scratchDirectory_(std::move(scratchDirectory)) {}

SliceStore::Location SliceStore::add(std::vector<std::uint64_t>&& units) {
    const std::uint64_t bytes = 8 * units.size();
    std::lock_guard lock(mutex_);
    if (memoryBytes_ + bytes <= memoryBudget_) {
        memoryBytes_ += bytes;
        memory_.push_back(std::move(units));
        return {kMemory, memory_.size() - 1, bytes};
    }
    if (!scratch_) scratch_ = std::make_unique<ScratchFile>(scratchDirectory_);
    const std::uint64_t offset = scratch_->append(units.data(), bytes);
    units = {};
    return {kScratch, offset, bytes};
}

SliceStore::Location SliceStore::external(const std::shared_ptr<const ReadOnlyFile>& file,
                                          std::uint64_t offset, std::uint64_t bytes,
                                          std::uint32_t checksum) {
    std::lock_guard lock(mutex_);
    if (files_.empty() || files_.back() != file) files_.push_back(file);
    return {static_cast<std::int32_t>(files_.size() - 1), offset, bytes, checksum};
}

void SliceStore::read(const Location& where, std::vector<std::uint64_t>& out) const {
    out.resize(where.bytes / 8);
    if (where.file == kScratch) {
        scratch_->read(where.offset, out.data(), where.bytes);
    } else if (where.file < 0) {
        std::lock_guard lock(mutex_);
        out = memory_[where.offset];
    } else {
        const ReadOnlyFile& file = *files_[static_cast<std::size_t>(where.file)];
        file.read(where.offset, reinterpret_cast<std::uint8_t*>(out.data()), where.bytes);
        if (crc32c(out.data(), where.bytes) != where.checksum)
            throw InvalidDataError(file.path(), "the slice at byte " +
                                                    std::to_string(where.offset) +
                                                    " does not match its checksum");
    }
}

PartitionSlices storeSlices(std::vector<LaidOutSlice>&& slices, std::uint32_t level,
                            std::uint64_t path, SliceStore& store) {
    PartitionSlices out;
    out.level = level;
    out.path = path;
    out.slices.reserve(slices.size());
    for (LaidOutSlice& s : slices) {
        SliceRecord r;
        r.regionLevel = s.region.level + level;
        r.regionPath = (path << (3 * s.region.level)) | s.region.path;
        r.parent = s.parent;
        r.children = std::move(s.children);
        r.partition = s.partition;
        if (!s.partition) {
            r.infoWord = s.infoWord;
            r.firstLevel = s.firstLevel + level;
            r.endLevel = s.endLevel + level;
            r.rootGroups = s.rootGroups;
            r.descriptors = s.descriptors;
            r.farSlots = s.farSlots;
            r.frontier = s.frontier;
            r.voxels = s.voxels;
            r.block = store.add(std::move(s.units));
        }
        out.slices.push_back(std::move(r));
    }
    slices.clear();
    return out;
}

EsvoWriteResult assembleEsvo(const std::filesystem::path& file, const EsvoFileInfo& info,
                             const PartitionSlices* top, std::vector<PartitionSlices>&& partitions,
                             const SliceStore& store, Timings* timings) {
    // One record list: the top's (or the single partition's) first, then each partition's, the
    // top's places for partitions replaced by the partitions' root slices.
    std::vector<SliceRecord> records;
    const auto append = [&](PartitionSlices& part) {
        const auto base = static_cast<std::uint32_t>(records.size());
        for (SliceRecord& r : part.slices) {
            if (r.parent != esvo::kNoSlice) r.parent += base;
            for (std::uint32_t& c : r.children) c += base;
            records.push_back(std::move(r));
        }
        return base;
    };
    if (top) {
        PartitionSlices topCopy = *top;
        append(topCopy);
        std::map<std::pair<std::uint32_t, std::uint64_t>, std::size_t> byVoxel;
        for (std::size_t p = 0; p < partitions.size(); ++p)
            if (!partitions[p].slices.empty())
                byVoxel[{partitions[p].level, partitions[p].path}] = p;
        std::vector<char> linked(partitions.size(), 0);
        const std::size_t topCount = records.size();
        for (std::size_t i = 0; i < topCount; ++i) {
            if (!records[i].partition) continue;
            const auto it = byVoxel.find({records[i].regionLevel, records[i].regionPath});
            if (it == byVoxel.end() || partitions[it->second].slices.empty())
                throw std::logic_error("esvo assembly: a partition the top refers to is missing");
            const std::uint32_t parent = records[i].parent;
            const std::uint32_t root = append(partitions[it->second]);
            linked[it->second] = 1;
            records[root].parent = parent;
            for (std::uint32_t& c : records[parent].children)
                if (c == i) c = root;
        }
        for (std::size_t p = 0; p < partitions.size(); ++p)
            if (!linked[p] && !partitions[p].slices.empty())
                throw std::logic_error("esvo assembly: a partition has no place in the top");
    } else {
        if (partitions.size() != 1)
            throw std::logic_error("esvo assembly: a file without a top is one partition");
        append(partitions.front());
    }
    partitions.clear();

    // Directory order: breadth-first, so every slice's children are contiguous.
    std::vector<std::uint32_t> order{0};  // directory position → record
    for (std::size_t i = 0; i < order.size(); ++i)
        for (std::uint32_t c : records[order[i]].children) order.push_back(c);
    if (order.size() !=
        static_cast<std::size_t>(std::count_if(records.begin(), records.end(),
                                               [](const SliceRecord& r) { return !r.partition; })))
        throw std::logic_error("esvo assembly: slice tree does not reach every slice");
    std::vector<std::uint32_t> position(records.size(), esvo::kNoSlice);
    for (std::uint32_t i = 0; i < order.size(); ++i) position[order[i]] = i;

    esvo::Directory directory;
    directory.voxelsPerLevel = info.voxelsPerLevel;
    directory.slices.resize(order.size());
    EsvoWriteResult result;
    const auto align = [](std::uint64_t v) {
        return (v + esvo::kSliceAlignment - 1) / esvo::kSliceAlignment * esvo::kSliceAlignment;
    };
    std::uint64_t offset =
        esvo::kHeaderBytes +
        esvo::directoryBytes(info.header.leafDepth, static_cast<std::uint32_t>(order.size()));
    for (std::uint32_t i = 0; i < order.size(); ++i) {
        const SliceRecord& s = records[order[i]];
        esvo::SliceEntry& e = directory.slices[i];
        offset = align(offset);
        e.fileOffset = offset;
        e.byteSize = static_cast<std::uint32_t>(s.block.bytes);
        offset += e.byteSize;
        e.parent = s.parent == esvo::kNoSlice ? esvo::kNoSlice : position[s.parent];
        e.childCount = static_cast<std::uint32_t>(s.children.size());
        e.firstChild = s.children.empty() ? 0 : position[s.children.front()];
        e.regionLevel = static_cast<std::uint8_t>(s.regionLevel);
        e.firstLevel = static_cast<std::uint8_t>(s.firstLevel);
        e.endLevel = static_cast<std::uint8_t>(s.endLevel);
        if (s.parent != esvo::kNoSlice) {
            const std::uint32_t pathLevels = s.regionLevel - records[s.parent].regionLevel;
            e.pathLevels = static_cast<std::uint8_t>(pathLevels);
            e.regionPath =
                pathLevels ? s.regionPath & ((std::uint64_t{1} << (3 * pathLevels)) - 1) : 0;
        }
        e.rootGroupCount = s.rootGroups;
        e.descriptorCount = s.descriptors;
        e.farPointerCount = s.farSlots;
        e.voxelCount = s.voxels;
        result.descriptors += s.descriptors;
        result.farPointers += s.farSlots;
        // Frontier ranges: a child's root groups are its parent's frontier descriptors, in order.
        std::uint32_t next = 0;
        for (std::uint32_t c : s.children) {
            directory.slices[position[c]].firstFrontier = next;
            next += records[c].rootGroups;
        }
        if (next != s.frontier)
            throw std::logic_error("esvo assembly: child slices do not cover the frontier");
    }

    esvo::Header header = info.header;
    header.sliceCount = static_cast<std::uint32_t>(order.size());
    header.directoryOffset = esvo::kHeaderBytes;
    header.fileBytes = offset;
    {
        Timings::Scope timer(timings, "esvo_write");
        AtomicFile out(file);
        // Header and directory last: the slices' checksums are known once they are written.
        const std::uint64_t directoryBytesCount =
            esvo::directoryBytes(header.leafDepth, header.sliceCount);
        const std::vector<std::uint8_t> placeholder(esvo::kHeaderBytes + directoryBytesCount, 0);
        out.write(placeholder.data(), placeholder.size());
        std::uint64_t written = placeholder.size();
        static const std::array<std::uint8_t, esvo::kSliceAlignment> zeros{};
        std::vector<std::uint64_t> units;
        for (std::uint32_t i = 0; i < order.size(); ++i) {
            const SliceRecord& s = records[order[i]];
            esvo::SliceEntry& e = directory.slices[i];
            store.read(s.block, units);
            auto& idUnit = units[s.infoWord / 2];
            idUnit = (idUnit & 0xFFFFFFFF00000000ull) |
                     i;  // the slice id, in the info section's first word
            e.checksum = esvo::crc32c(units.data(), e.byteSize);
            out.write(zeros.data(), e.fileOffset - written);
            out.write(units.data(), e.byteSize);
            written = e.fileOffset + e.byteSize;
        }
        const std::vector<std::uint8_t> directoryBytes = esvo::encodeDirectory(directory);
        header.directoryBytes = directoryBytes.size();
        header.directoryChecksum = esvo::crc32c(directoryBytes.data(), directoryBytes.size());
        const auto headerBytes = esvo::encodeHeader(header);
        out.writeAt(0, headerBytes.data(), headerBytes.size());
        out.writeAt(esvo::kHeaderBytes, directoryBytes.data(), directoryBytes.size());
        out.commit();
    }
    result.fileBytes = header.fileBytes;
    result.slices = header.sliceCount;
    return result;
}

}  // namespace vox::detail
