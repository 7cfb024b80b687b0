#include <vox/formats/esvo.h>

namespace vox::esvo {
std::array<std::uint8_t, kHeaderBytes> encodeHeader(const Header& h) {
    std::array<std::uint8_t, kHeaderBytes> out{};
    std::uint8_t* p = out.data();
    std::memcpy(p, kMagic.data(), kMagic.size());
    store<std::uint16_t>(p + 8, h.versionMajor);
    store<std::uint16_t>(p + 10, h.versionMinor);
    store<std::uint32_t>(p + 12, kHeaderBytes);
    for (int i = 0; i < 16; ++i) store<double>(p + 16 + 8 * i, h.worldToRoot[i]);
    for (int i = 0; i < 3; ++i) {
        store<double>(p + 144 + 8 * i, h.sceneBoundsMin[i]);
        store<double>(p + 168 + 8 * i, h.sceneBoundsMax[i]);
    }
    store<std::uint32_t>(p + 192, h.leafDepth);
    store<std::uint32_t>(p + 196, h.attachmentKinds);
    store<std::uint32_t>(p + 200, h.sliceBytesLimit);
    store<std::uint32_t>(p + 204, h.nearPointerLimit);
    store<std::uint32_t>(p + 208, h.buildFlags);
    store<std::uint32_t>(p + 212, h.sliceCount);
    store<std::uint64_t>(p + 216, h.directoryOffset);
    store<std::uint64_t>(p + 224, h.directoryBytes);
    store<std::uint32_t>(p + 232, h.directoryChecksum);
    store<std::uint64_t>(p + 240, h.fileBytes);
    store<std::uint32_t>(p + 252, crc32c(p, 252));
    return out;
}

std::vector<std::uint8_t> encodeDirectory(const Directory& d) {
    const auto leafDepth = static_cast<std::uint32_t>(d.voxelsPerLevel.size() - 1);
    std::vector<std::uint8_t> out(
        directoryBytes(leafDepth, static_cast<std::uint32_t>(d.slices.size())), 0);
    std::uint8_t* p = out.data();
    for (std::uint64_t count : d.voxelsPerLevel) {
        store<std::uint64_t>(p, count);
        p += 8;
    }
    for (const SliceEntry& s : d.slices) {
        store<std::uint64_t>(p + 0, s.fileOffset);
        store<std::uint32_t>(p + 8, s.byteSize);
        store<std::uint32_t>(p + 12, s.checksum);
        store<std::uint32_t>(p + 16, s.parent);
        store<std::uint32_t>(p + 20, s.firstChild);
        store<std::uint32_t>(p + 24, s.childCount);
        p[28] = s.regionLevel;
        p[29] = s.firstLevel;
        p[30] = s.endLevel;
        p[31] = s.pathLevels;
        store<std::uint64_t>(p + 32, s.regionPath);
        store<std::uint32_t>(p + 40, s.firstFrontier);
        store<std::uint32_t>(p + 44, s.rootGroupCount);
        store<std::uint32_t>(p + 48, s.descriptorCount);
        store<std::uint32_t>(p + 52, s.farPointerCount);
        store<std::uint64_t>(p + 56, s.voxelCount);
        p += kDirectoryEntryBytes;
    }
    return out;
}

}  // namespace vox::esvo
