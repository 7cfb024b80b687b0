#include <vox/base/error.h>
#include <vox/formats/esvo_reader.h>

#include <vox/formats/read_only_file.h>

#include <cmath>

#include <string>

namespace vox::esvo {
namespace {

[[noreturn]] void invalid(const std::filesystem::path& file, const std::string& problem) {
    throw InvalidDataError(file, problem);
}

Header decodeHeader(const std::filesystem::path& file, const std::uint8_t* p,
                    std::uint64_t fileSize) {
    if (std::memcmp(p, kMagic.data(), kMagic.size()) != 0)
        invalid(file, "not an .esvo file (bad magic)");
    Header h;
    h.versionMajor = load<std::uint16_t>(p + 8);
    h.versionMinor = load<std::uint16_t>(p + 10);
    if (h.versionMajor != kVersionMajor)
        invalid(file, "unsupported .esvo version " + std::to_string(h.versionMajor) + "." +
                          std::to_string(h.versionMinor) + " (this reader reads " +
                          std::to_string(kVersionMajor) + ".x)");
    if (load<std::uint32_t>(p + 12) != kHeaderBytes) invalid(file, "header: size field is not 256");
    if (load<std::uint32_t>(p + 252) != crc32c(p, 252)) invalid(file, "header: checksum mismatch");
    for (int i = 0; i < 16; ++i) h.worldToRoot[i] = load<double>(p + 16 + 8 * i);
    for (int i = 0; i < 3; ++i) {
        h.sceneBoundsMin[i] = load<double>(p + 144 + 8 * i);
        h.sceneBoundsMax[i] = load<double>(p + 168 + 8 * i);
    }
    h.leafDepth = load<std::uint32_t>(p + 192);
    h.attachmentKinds = load<std::uint32_t>(p + 196);
    h.sliceBytesLimit = load<std::uint32_t>(p + 200);
    h.nearPointerLimit = load<std::uint32_t>(p + 204);
    h.buildFlags = load<std::uint32_t>(p + 208);
    h.sliceCount = load<std::uint32_t>(p + 212);
    h.directoryOffset = load<std::uint64_t>(p + 216);
    h.directoryBytes = load<std::uint64_t>(p + 224);
    h.directoryChecksum = load<std::uint32_t>(p + 232);
    h.fileBytes = load<std::uint64_t>(p + 240);

    for (double v : h.worldToRoot)
        if (!std::isfinite(v)) invalid(file, "header: world-to-root transform is not finite");
    if (h.worldToRoot[12] != 0 || h.worldToRoot[13] != 0 || h.worldToRoot[14] != 0 ||
        h.worldToRoot[15] != 1)
        invalid(file, "header: world-to-root transform is not affine");
    if (h.leafDepth < 1 || h.leafDepth > kMaxLeafDepth)
        invalid(file, "header: leaf depth " + std::to_string(h.leafDepth) + " outside 1.." +
                          std::to_string(kMaxLeafDepth));
    if (h.sliceBytesLimit < kMinSliceBytes) invalid(file, "header: slice byte limit below 16384");
    if (h.nearPointerLimit < 1 || h.nearPointerLimit > kNearPointerMax)
        invalid(file, "header: near pointer limit out of range");
    if (h.fileBytes != fileSize)
        invalid(file, "header says " + std::to_string(h.fileBytes) + " bytes but the file has " +
                          std::to_string(fileSize) + " (truncated or appended to)");
    if (h.sliceCount < 1) invalid(file, "header: no slices");
    if (__builtin_popcount(h.attachmentKinds & kAttributeKindBits) > 1)
        invalid(file, "header: declares more than one kind of colour/normal attachment");
    if (h.directoryOffset != kHeaderBytes)
        invalid(file, "header: directory does not follow the header");
    if (h.directoryBytes != directoryBytes(h.leafDepth, h.sliceCount) ||
        h.directoryOffset + h.directoryBytes > fileSize)
        invalid(file, "header: directory size does not match " + std::to_string(h.sliceCount) +
                          " slices or exceeds the file");
    return h;
}

Directory decodeDirectory(const std::filesystem::path& file, const Header& h,
                          const std::uint8_t* p) {
    if (h.directoryChecksum != crc32c(p, h.directoryBytes))
        invalid(file, "slice directory: checksum mismatch");
    Directory d;
    d.voxelsPerLevel.resize(h.leafDepth + 1);
    for (auto& count : d.voxelsPerLevel) {
        count = load<std::uint64_t>(p);
        p += 8;
    }
    if (d.voxelsPerLevel[0] != 1)
        invalid(file, "slice directory: level 0 must hold exactly the root voxel");
    d.slices.resize(h.sliceCount);
    for (SliceEntry& s : d.slices) {
        s.fileOffset = load<std::uint64_t>(p + 0);
        s.byteSize = load<std::uint32_t>(p + 8);
        s.checksum = load<std::uint32_t>(p + 12);
        s.parent = load<std::uint32_t>(p + 16);
        s.firstChild = load<std::uint32_t>(p + 20);
        s.childCount = load<std::uint32_t>(p + 24);
        s.regionLevel = p[28];
        s.firstLevel = p[29];
        s.endLevel = p[30];
        s.pathLevels = p[31];
        s.regionPath = load<std::uint64_t>(p + 32);
        s.firstFrontier = load<std::uint32_t>(p + 40);
        s.rootGroupCount = load<std::uint32_t>(p + 44);
        s.descriptorCount = load<std::uint32_t>(p + 48);
        s.farPointerCount = load<std::uint32_t>(p + 52);
        s.voxelCount = load<std::uint64_t>(p + 56);
        p += kDirectoryEntryBytes;
    }

    const std::uint64_t dataStart = h.directoryOffset + h.directoryBytes;
    std::uint64_t previousEnd = dataStart;
    std::uint32_t nextChild = 1;
    for (std::uint32_t i = 0; i < h.sliceCount; ++i) {
        const SliceEntry& s = d.slices[i];
        const std::string where = "slice directory entry " + std::to_string(i) + ": ";
        if (s.fileOffset % kSliceAlignment != 0 || s.fileOffset < previousEnd)
            invalid(file, where + "offset " + std::to_string(s.fileOffset) +
                              " misaligned or overlapping the previous slice");
        if (s.byteSize < kPageHeaderBytes + 4 * (info::kAttachments + info::kTablesWords) ||
            s.byteSize % 8 != 0 || s.byteSize > h.sliceBytesLimit)
            invalid(file, where + "size " + std::to_string(s.byteSize) +
                              " invalid or above the slice byte limit");
        // Subtracted, not added: an offset near 2^64 would wrap the sum back inside the file.
        if (s.byteSize > h.fileBytes || s.fileOffset > h.fileBytes - s.byteSize)
            invalid(file, where + "extends past the end of the file");
        previousEnd = s.fileOffset + s.byteSize;
        if (s.firstLevel >= s.endLevel || s.endLevel > h.leafDepth)
            invalid(file, where + "level range [" + std::to_string(s.firstLevel) + "," +
                              std::to_string(s.endLevel) + ") invalid");
        if (s.childCount > 0) {
            if (s.firstChild != nextChild || s.childCount > h.sliceCount - nextChild)
                invalid(file, where + "children are not the next entries in breadth-first order");
            nextChild += s.childCount;
        }
        if (i == 0) {
            if (s.parent != kNoSlice || s.regionLevel != 0 || s.firstLevel != 0 ||
                s.pathLevels != 0 || s.regionPath != 0 || s.firstFrontier != 0 ||
                s.rootGroupCount != 1)
                invalid(
                    file,
                    where +
                        "the root slice must cover the root cube from level 0 with one root group");
            continue;
        }
        if (s.parent >= i) invalid(file, where + "parent index does not precede it");
        const SliceEntry& parent = d.slices[s.parent];
        if (i < parent.firstChild || i >= parent.firstChild + parent.childCount)
            invalid(file, where + "not among its parent's children");
        if (s.firstLevel <= parent.firstLevel || s.firstLevel > parent.endLevel)
            invalid(file, where + "does not start inside its parent's level range");
        if (s.pathLevels > 21 || s.regionLevel != parent.regionLevel + s.pathLevels ||
            s.regionLevel >= s.firstLevel ||
            (s.pathLevels < 21 && s.regionPath >> (3 * s.pathLevels) != 0))
            invalid(file, where + "region inconsistent with its parent's");
        const std::uint32_t expectedFirst =
            i == parent.firstChild ? 0
                                   : d.slices[i - 1].firstFrontier + d.slices[i - 1].rootGroupCount;
        if (s.rootGroupCount == 0 || s.firstFrontier != expectedFirst)
            invalid(file, where + "frontier range does not continue its previous sibling's");
    }
    if (nextChild != h.sliceCount)
        invalid(file, "slice directory: some slices are not reachable from the root slice");
    return d;
}

}  // namespace

EsvoReader::EsvoReader(std::filesystem::path file)
    : path_(std::move(file)), file_(std::make_unique<vox::ReadOnlyFile>(path_)) {
    const std::uint64_t fileSize = file_->size();
    if (fileSize < kHeaderBytes)
        invalid(path_, "too short for an .esvo header (" + std::to_string(fileSize) + " bytes)");
    std::array<std::uint8_t, kHeaderBytes> headerBytes{};
    file_->read(0, headerBytes.data(), headerBytes.size());
    header_ = decodeHeader(path_, headerBytes.data(), fileSize);
    std::vector<std::uint8_t> directoryBytes(
        header_.directoryBytes);  // bounded by the file size above
    file_->read(header_.directoryOffset, directoryBytes.data(), directoryBytes.size());
    directory_ = decodeDirectory(path_, header_, directoryBytes.data());
}

EsvoReader::~EsvoReader() = default;

void EsvoReader::readSlice(std::uint32_t index, std::span<std::uint8_t> destination) const {
    if (index >= sliceCount())
        throw InvalidDataError(path_, "slice " + std::to_string(index) + " does not exist");
    const SliceEntry& s = directory_.slices[index];
    if (destination.size() != s.byteSize)
        throw std::invalid_argument("readSlice: destination size differs from the slice's");
    file_->read(s.fileOffset, destination.data(), destination.size());
    if (crc32c(destination.data(), destination.size()) != s.checksum)
        invalid(path_, "slice " + std::to_string(index) + ", byte " + std::to_string(s.fileOffset) +
                           ": checksum mismatch");
}

std::vector<std::uint8_t> EsvoReader::readSlice(std::uint32_t index) const {
    std::vector<std::uint8_t> bytes(slice(index).byteSize);
    readSlice(index, bytes);
    return bytes;
}

}  // namespace vox::esvo
