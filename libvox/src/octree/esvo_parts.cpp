#include "esvo_parts.h"

#include <vox/formats/atomic_file.h>
#include <vox/base/error.h>

#include <array>
#include <cstring>
#include <string>

namespace vox::detail {
namespace {

constexpr std::array<std::uint8_t, 8> kPartMagic{0x89, 'E', 'S', 'V', 'P', '\r', '\n', 0x1A};
constexpr std::uint16_t kPartVersionMajor = 1, kPartVersionMinor = 0;
constexpr std::uint32_t kPartHeaderBytes = 320;
constexpr std::uint32_t kSumsDoubles = 21;  // AttributeSums, field by field

/// Appends little-endian values.
class ByteWriter {
public:
    template <typename T>
    void put(T value) {
        const std::size_t at = bytes_.size();
        bytes_.resize(at + sizeof value);
        esvo::store(bytes_.data() + at, value);
    }
    void put(const Vec3d& v) {
        put(v.x);
        put(v.y);
        put(v.z);
    }
    [[nodiscard]] const std::vector<std::uint8_t>& bytes() const noexcept { return bytes_; }

private:
    std::vector<std::uint8_t> bytes_;
};

/// Reads little-endian values, failing with the file's name where the data ends.
class ByteReader {
public:
    ByteReader(const std::filesystem::path& file, const std::vector<std::uint8_t>& bytes)
        : file_(file), bytes_(bytes) {}
    template <typename T>
    T get() {
        if (bytes_.size() - at_ < sizeof(T))
            throw InvalidDataError(file_, "part file records end early");
        const T value = esvo::load<T>(bytes_.data() + at_);
        at_ += sizeof(T);
        return value;
    }
    Vec3d getVec3() {
        const double x = get<double>(), y = get<double>(), z = get<double>();
        return {x, y, z};
    }
    [[nodiscard]] bool atEnd() const noexcept { return at_ == bytes_.size(); }

private:
    const std::filesystem::path& file_;
    const std::vector<std::uint8_t>& bytes_;
    std::size_t at_ = 0;
};

constexpr bool hasContours(const esvo::Header& h) {
    return h.attachmentKinds & (1u << static_cast<unsigned>(esvo::AttachmentKind::Contour));
}

}  // namespace

std::uint64_t fnv1a64(const void* data, std::size_t size, std::uint64_t hash) noexcept {
    const auto* p = static_cast<const std::uint8_t*>(data);
    for (std::size_t i = 0; i < size; ++i) hash = (hash ^ p[i]) * 0x100000001B3ull;
    return hash;
}

std::uint64_t writeEsvoPart(const std::filesystem::path& file, const EsvoPart& part,
                            const SliceStore& store) {
    const esvo::Header& h = part.header;
    const bool contours = hasContours(h), attributes = h.hasAttributes();
    AtomicFile out(file);
    const std::vector<std::uint8_t> placeholder(kPartHeaderBytes, 0);
    out.write(placeholder.data(), placeholder.size());
    std::uint64_t written = kPartHeaderBytes;

    // Blocks first (their checksums go into the records), each on a 64-byte boundary.
    static const std::array<std::uint8_t, esvo::kSliceAlignment> zeros{};
    ByteWriter records;
    std::vector<std::uint64_t> units;
    std::uint32_t sliceCount = 0;
    for (std::size_t r = 0; r < part.roots.size(); ++r) {
        const PartitionRoot& root = part.roots[r];
        const PartitionSlices& slices = part.slices[r];
        records.put(root.code);
        records.put(root.mask);
        records.put(root.nonLeaf);
        records.put(std::uint16_t{0});
        records.put(static_cast<std::uint32_t>(slices.slices.size()));
        for (std::uint64_t v : root.voxelsPerLevel) records.put(v);
        if (contours)
            for (std::uint32_t c : root.childContours) records.put(c);
        if (attributes) {
            for (std::uint64_t a : root.childAttributes) records.put(a);
            const AttributeSums& s = root.sums;
            records.put(s.weight);
            records.put(s.color);
            records.put(s.alpha);
            records.put(s.normal);
            records.put(s.emission);
            for (double m : s.normalMoments) records.put(m);
            records.put(s.dominantNormal);
            records.put(s.dominantWeight);
        }
        for (const SliceRecord& s : slices.slices) {
            store.read(s.block, units);
            const std::uint64_t offset = (written + esvo::kSliceAlignment - 1) /
                                         esvo::kSliceAlignment * esvo::kSliceAlignment;
            out.write(zeros.data(), offset - written);
            out.write(units.data(), s.block.bytes);
            written = offset + s.block.bytes;
            records.put(s.parent);
            records.put(static_cast<std::uint32_t>(s.children.size()));
            for (std::uint32_t c : s.children) records.put(c);
            records.put(static_cast<std::uint8_t>(s.regionLevel));
            records.put(static_cast<std::uint8_t>(s.firstLevel));
            records.put(static_cast<std::uint8_t>(s.endLevel));
            records.put(std::uint8_t{0});
            records.put(s.regionPath);
            records.put(s.infoWord);
            records.put(s.rootGroups);
            records.put(s.descriptors);
            records.put(s.farSlots);
            records.put(s.frontier);
            records.put(s.voxels);
            records.put(offset);
            records.put(static_cast<std::uint32_t>(s.block.bytes));
            records.put(crc32c(units.data(), s.block.bytes));
            ++sliceCount;
        }
    }
    const std::uint64_t recordsOffset = written;
    out.write(records.bytes().data(), records.bytes().size());

    ByteWriter header;
    for (std::uint8_t b : kPartMagic) header.put(b);
    header.put(kPartVersionMajor);
    header.put(kPartVersionMinor);
    header.put(kPartHeaderBytes);
    header.put(part.runIndex);
    header.put(part.runCount);
    header.put(h.leafDepth);
    header.put(part.partitionLevel);
    header.put(part.partitionsTotal);
    header.put(part.firstPartition);
    header.put(part.partitionsInRun);
    header.put(static_cast<std::uint32_t>(part.roots.size()));
    header.put(part.fingerprint);
    header.put(h.attachmentKinds);
    header.put(h.sliceBytesLimit);
    header.put(h.nearPointerLimit);
    header.put(h.buildFlags);
    for (double v : h.worldToRoot) header.put(v);
    for (double v : h.sceneBoundsMin) header.put(v);
    for (double v : h.sceneBoundsMax) header.put(v);
    header.put(recordsOffset);
    header.put(static_cast<std::uint64_t>(records.bytes().size()));
    header.put(sliceCount);
    header.put(crc32c(records.bytes().data(), records.bytes().size()));
    header.put(static_cast<std::uint32_t>(part.attributeEffort));
    std::vector<std::uint8_t> headerBytes = header.bytes();
    headerBytes.resize(kPartHeaderBytes - 4, 0);
    const std::uint32_t headerChecksum = crc32c(headerBytes.data(), headerBytes.size());
    headerBytes.resize(kPartHeaderBytes);
    esvo::store(headerBytes.data() + kPartHeaderBytes - 4, headerChecksum);
    out.writeAt(0, headerBytes.data(), headerBytes.size());
    out.commit();
    return recordsOffset + records.bytes().size();
}

EsvoPart readEsvoPart(const std::filesystem::path& path, SliceStore& store) {
    const auto file = std::make_shared<const ReadOnlyFile>(path);
    const auto invalid = [&](const std::string& problem) {
        return InvalidDataError(path, problem);
    };
    if (file->size() < kPartHeaderBytes) throw invalid("not a part file (too short)");
    std::vector<std::uint8_t> headerBytes(kPartHeaderBytes);
    file->read(0, headerBytes.data(), kPartHeaderBytes);
    if (!std::equal(kPartMagic.begin(), kPartMagic.end(), headerBytes.begin()))
        throw invalid("not a part file (bad magic)");
    if (crc32c(headerBytes.data(), kPartHeaderBytes - 4) !=
        esvo::load<std::uint32_t>(headerBytes.data() + kPartHeaderBytes - 4))
        throw invalid("part file header: checksum mismatch");
    ByteReader in(path, headerBytes);
    for (std::size_t i = 0; i < kPartMagic.size(); ++i) (void)in.get<std::uint8_t>();
    if (in.get<std::uint16_t>() != kPartVersionMajor)
        throw invalid("part file of an unsupported major version");
    (void)in.get<std::uint16_t>();
    if (in.get<std::uint32_t>() != kPartHeaderBytes)
        throw invalid("part file header: unexpected size");
    EsvoPart part;
    part.path = path;
    part.runIndex = in.get<std::uint32_t>();
    part.runCount = in.get<std::uint32_t>();
    esvo::Header& h = part.header;
    h.leafDepth = in.get<std::uint32_t>();
    part.partitionLevel = in.get<std::uint32_t>();
    part.partitionsTotal = in.get<std::uint32_t>();
    part.firstPartition = in.get<std::uint32_t>();
    part.partitionsInRun = in.get<std::uint32_t>();
    const std::uint32_t rootCount = in.get<std::uint32_t>();
    part.fingerprint = in.get<std::uint64_t>();
    h.attachmentKinds = in.get<std::uint32_t>();
    h.sliceBytesLimit = in.get<std::uint32_t>();
    h.nearPointerLimit = in.get<std::uint32_t>();
    h.buildFlags = in.get<std::uint32_t>();
    for (double& v : h.worldToRoot) v = in.get<double>();
    for (double& v : h.sceneBoundsMin) v = in.get<double>();
    for (double& v : h.sceneBoundsMax) v = in.get<double>();
    const auto recordsOffset = in.get<std::uint64_t>();
    const auto recordsBytes = in.get<std::uint64_t>();
    const auto sliceCount = in.get<std::uint32_t>();
    const auto recordsChecksum = in.get<std::uint32_t>();
    const auto effort = in.get<std::uint32_t>();
    if (effort > static_cast<std::uint32_t>(AttributeEffort::Best))
        throw invalid("part file header: unknown attribute effort");
    part.attributeEffort = static_cast<AttributeEffort>(effort);
    if (h.leafDepth < 1 || h.leafDepth > esvo::kMaxLeafDepth || part.partitionLevel < 1 ||
        part.partitionLevel >= h.leafDepth || part.runCount < 2 || part.runIndex >= part.runCount ||
        part.firstPartition > part.partitionsTotal ||
        part.partitionsInRun > part.partitionsTotal - part.firstPartition ||
        rootCount > part.partitionsInRun || h.sliceBytesLimit < esvo::kMinSliceBytes ||
        recordsOffset < kPartHeaderBytes || recordsOffset > file->size() ||
        recordsBytes != file->size() - recordsOffset)
        throw invalid("part file header: inconsistent fields");

    std::vector<std::uint8_t> recordBytes(recordsBytes);
    file->read(recordsOffset, recordBytes.data(), recordsBytes);
    if (crc32c(recordBytes.data(), recordBytes.size()) != recordsChecksum)
        throw invalid("part file records: checksum mismatch");
    const bool contours = hasContours(h), attributes = h.hasAttributes();
    const std::uint32_t levels = h.leafDepth - part.partitionLevel;
    ByteReader records(path, recordBytes);
    std::uint32_t slicesRead = 0;
    std::uint64_t previousCode = 0;
    for (std::uint32_t r = 0; r < rootCount; ++r) {
        PartitionRoot root;
        root.code = records.get<std::uint32_t>();
        root.mask = records.get<std::uint8_t>();
        root.nonLeaf = records.get<std::uint8_t>();
        (void)records.get<std::uint16_t>();
        const auto slices = records.get<std::uint32_t>();
        if ((r > 0 && root.code <= previousCode) ||
            (std::uint64_t{root.code} >> (3 * part.partitionLevel)) != 0 || root.mask == 0 ||
            (root.nonLeaf & ~root.mask) != 0 || (root.nonLeaf == 0) != (slices == 0) ||
            slices > sliceCount - slicesRead)
            throw invalid("part file records: partition root " + std::to_string(r) +
                          " inconsistent");
        previousCode = root.code;
        root.voxelsPerLevel.resize(levels + 1);
        for (std::uint64_t& v : root.voxelsPerLevel) v = records.get<std::uint64_t>();
        const std::uint32_t children = esvo::popc8(root.mask);
        if (root.voxelsPerLevel[0] != 1 || root.voxelsPerLevel[1] != children)
            throw invalid("part file records: partition root " + std::to_string(r) +
                          " voxel counts inconsistent");
        if (contours)
            for (std::uint32_t c = 0; c < children; ++c)
                root.childContours.push_back(records.get<std::uint32_t>());
        if (attributes) {
            for (std::uint32_t c = 0; c < children; ++c)
                root.childAttributes.push_back(records.get<std::uint64_t>());
            AttributeSums& s = root.sums;
            s.weight = records.get<double>();
            s.color = records.getVec3();
            s.alpha = records.get<double>();
            s.normal = records.getVec3();
            s.emission = records.getVec3();
            for (double& m : s.normalMoments) m = records.get<double>();
            s.dominantNormal = records.getVec3();
            s.dominantWeight = records.get<double>();
            static_assert(kSumsDoubles == 1 + 3 + 1 + 3 + 3 + 6 + 3 + 1);
        }
        PartitionSlices partition;
        partition.level = part.partitionLevel;
        partition.path = root.code;
        for (std::uint32_t i = 0; i < slices; ++i) {
            SliceRecord s;
            const std::string where =
                "part file records: slice " + std::to_string(slicesRead + i) + " ";
            s.parent = records.get<std::uint32_t>();
            const auto childCount = records.get<std::uint32_t>();
            if (childCount > slices)
                throw invalid(where + "has more children than its partition has slices");
            for (std::uint32_t c = 0; c < childCount; ++c) {
                const auto child = records.get<std::uint32_t>();
                if (child <= i || child >= slices)
                    throw invalid(where + "child index out of range");
                s.children.push_back(child);
            }
            s.regionLevel = records.get<std::uint8_t>();
            s.firstLevel = records.get<std::uint8_t>();
            s.endLevel = records.get<std::uint8_t>();
            (void)records.get<std::uint8_t>();
            s.regionPath = records.get<std::uint64_t>();
            s.infoWord = records.get<std::uint32_t>();
            s.rootGroups = records.get<std::uint32_t>();
            s.descriptors = records.get<std::uint32_t>();
            s.farSlots = records.get<std::uint32_t>();
            s.frontier = records.get<std::uint32_t>();
            s.voxels = records.get<std::uint64_t>();
            const auto blockOffset = records.get<std::uint64_t>();
            const auto blockBytes = records.get<std::uint32_t>();
            const auto blockChecksum = records.get<std::uint32_t>();
            if ((i == 0) != (s.parent == esvo::kNoSlice) || (i > 0 && s.parent >= i) ||
                s.regionLevel < part.partitionLevel || s.firstLevel <= s.regionLevel ||
                s.endLevel <= s.firstLevel || s.endLevel > h.leafDepth ||
                (i == 0 && (s.regionLevel != part.partitionLevel || s.regionPath != root.code)) ||
                (s.regionPath >> (3 * s.regionLevel)) != 0 || blockBytes % 8 != 0 ||
                blockBytes == 0 || blockBytes > h.sliceBytesLimit ||
                blockOffset % esvo::kSliceAlignment != 0 || blockOffset < kPartHeaderBytes ||
                blockOffset > recordsOffset || blockBytes > recordsOffset - blockOffset ||
                s.infoWord >= blockBytes / 4)
                throw invalid(where + "inconsistent");
            s.block = store.external(file, blockOffset, blockBytes, blockChecksum);
            partition.slices.push_back(std::move(s));
        }
        slicesRead += slices;
        part.roots.push_back(std::move(root));
        part.slices.push_back(std::move(partition));
    }
    if (slicesRead != sliceCount || !records.atEnd())
        throw invalid("part file records: counts inconsistent");
    return part;
}

}  // namespace vox::detail
