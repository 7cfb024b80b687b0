// Structural validation of .esvo blocks and files (docs/esvo-format.md, "Invariants").
#include <vox/base/error.h>
#include <vox/formats/esvo_attributes.h>
#include <vox/formats/esvo_reader.h>

#include <vox/formats/read_only_file.h>

#include <algorithm>
#include <string>

namespace vox::esvo {
namespace {

std::int32_t signedWord(const std::uint8_t* block, std::uint64_t word) {
    return load<std::int32_t>(block + 4 * word);
}
std::uint32_t word(const std::uint8_t* block, std::uint64_t word) {
    return load<std::uint32_t>(block + 4 * word);
}

class BlockChecker {
public:
    BlockChecker(const std::filesystem::path& file, std::uint32_t sliceIndex,
                 const SliceEntry& entry)
        : file_(file), sliceIndex_(sliceIndex), entry_(entry) {}

    [[noreturn]] void fail(std::uint64_t byteInSlice, const std::string& what) const {
        throw InvalidDataError(file_, "slice " + std::to_string(sliceIndex_) + ", byte " +
                                          std::to_string(byteInSlice) + " (file offset " +
                                          std::to_string(entry_.fileOffset + byteInSlice) +
                                          "): " + what);
    }

private:
    const std::filesystem::path& file_;
    std::uint32_t sliceIndex_;
    const SliceEntry& entry_;
};

/// The colour/normal attachment. Uncompressed: a lookup word per unit of the descriptor area
/// (zero where the unit is no descriptor; mask within the valid mask), padded to a whole unit,
/// then the values every lookup entry references, each exactly once, in order. Compressed: one
/// 6-word block per pair of units (that pairs never mix parents, validateBlock checks: every
/// group starts on an even unit), and the base normal's axis field is not 3. Compressed behind a
/// lookup: the same lookup array with pointers counting values, then one block per 16 values.
void validateAttributes(const BlockChecker& check, const BlockTables& t, const std::uint8_t* b,
                        std::uint64_t units, std::vector<std::uint64_t>& descriptorUnits,
                        BlockSummary& summary) {
    std::sort(descriptorUnits.begin(), descriptorUnits.end());
    const std::uint64_t begin = t.attributeWord, size = t.attributeEndWord - t.attributeWord;
    const auto checkBlocks = [&](std::uint64_t first, std::uint64_t blocks) {
        for (std::uint64_t p = 0; p < blocks; ++p)
            if ((word(b, first + kCompressedBlockWords * p + 2) >> 29 & 3u) == 3u)
                check.fail(4 * (first + kCompressedBlockWords * p + 2),
                           "base normal with an invalid cube face");
    };
    if (t.attributeKind == AttachmentKind::Palette ||
        t.attributeKind == AttachmentKind::DxtLookup) {
        const bool palette = t.attributeKind == AttachmentKind::Palette;
        const std::uint64_t lookupWords = units + units % 2;
        if (size < lookupWords)
            check.fail(4 * begin, "colour/normal lookup array shorter than the descriptor area");
        // Palette pointers count words (values follow the lookup array, two words each);
        // DxtLookup pointers count values. Either way in descriptor order.
        std::uint64_t expected = palette ? lookupWords : 0;
        std::size_t next = 0;
        for (std::uint64_t u = 0; u < lookupWords; ++u) {
            const PaletteLookup entry{word(b, begin + u)};
            const bool isDescriptor = next < descriptorUnits.size() && descriptorUnits[next] == u;
            if (!isDescriptor) {
                if (entry.word != 0)
                    check.fail(4 * (begin + u),
                               "colour/normal lookup entry for a unit that is no descriptor");
                continue;
            }
            ++next;
            const std::uint32_t valid = ChildDescriptor{word(b, 2 * u), 0}.validMask();
            if ((entry.mask() & ~valid) != 0)
                check.fail(4 * (begin + u), "colour/normal mask has bits outside the valid mask");
            if (entry.mask() == 0) {
                if (entry.word != 0)
                    check.fail(4 * (begin + u), "colour/normal value pointer without a mask");
                continue;
            }
            // DxtLookup may skip slots (padding) between descriptors' values; Palette may not.
            if (palette ? entry.valuePointer() != expected : entry.valuePointer() < expected)
                check.fail(4 * (begin + u), "colour/normal values not stored in descriptor order");
            if (!palette) expected = entry.valuePointer();
            expected += (palette ? 2ull : 1ull) * popc8(entry.mask());
            if (palette && expected > size)
                check.fail(4 * (begin + u), "colour/normal values run past the attachment");
        }
        if (!palette) {
            const std::uint64_t blocks = (expected + 15) / 16;
            if (size != lookupWords + kCompressedBlockWords * blocks)
                check.fail(4 * begin,
                           "compressed colour/normal array is not one block per 16 stored values");
            checkBlocks(begin + lookupWords, blocks);
            summary.attributeLookupBytes += 4 * lookupWords;
            summary.attributeBlockBytes += 4 * (size - lookupWords);
            return;
        }
        for (std::uint64_t w = lookupWords; w < size; w += 2)
            if ((word(b, begin + w + 1) >> 29 & 3u) == 3u)
                check.fail(4 * (begin + w + 1), "normal with an invalid cube face");
        if (expected != size)
            check.fail(4 * (begin + expected), "colour/normal values no lookup entry refers to");
        summary.attributeLookupBytes += 4 * lookupWords;
        summary.attributeValueBytes += 4 * (size - lookupWords);
        return;
    }
    const std::uint64_t blocks = (units + 1) / 2;
    if (size != kCompressedBlockWords * blocks)
        check.fail(4 * begin, "compressed colour/normal array is not one block per pair of units");
    checkBlocks(begin, blocks);
    summary.attributeBlockBytes += 4 * size;
}

}  // namespace

BlockTables readBlockTables(std::span<const std::uint8_t> block, const std::filesystem::path& file,
                            std::uint32_t sliceIndex, std::optional<std::uint64_t> fileOffset) {
    const auto fail = [&](std::uint64_t byte, const std::string& what) {
        throw InvalidDataError(
            file, "slice " + std::to_string(sliceIndex) + ", byte " + std::to_string(byte) +
                      (fileOffset ? " (file offset " + std::to_string(*fileOffset + byte) + ")"
                                  : std::string()) +
                      ": " + what);
    };
    const std::uint64_t words = block.size() / 4;
    if (block.size() < kPageHeaderBytes || block.size() % 8 != 0)
        fail(0, "block size is not a multiple of 8 bytes");
    BlockTables t;
    const std::int64_t infoWord = signedWord(block.data(), 0);
    if (infoWord < 2 || infoWord % 2 != 0 ||
        static_cast<std::uint64_t>(infoWord) + info::kAttachments > words)
        fail(0, "page header does not point at an info section inside the block");
    t.infoWord = static_cast<std::uint32_t>(infoWord);
    const std::uint64_t attachments = word(block.data(), t.infoWord + info::kAttachmentCount);
    if (attachments > 64 || t.infoWord + info::tablesWord(static_cast<std::uint32_t>(attachments)) +
                                    info::kTablesWords >
                                words)
        fail(4ull * (t.infoWord + info::kAttachmentCount), "attachment count runs past the block");
    const std::uint64_t tables =
        t.infoWord + info::tablesWord(static_cast<std::uint32_t>(attachments));
    const auto table = [&](std::uint64_t at, std::uint32_t& count, std::uint32_t& tableWord) {
        count = word(block.data(), at);
        const std::int64_t start =
            static_cast<std::int64_t>(t.infoWord) + signedWord(block.data(), at + 1);
        if (start < static_cast<std::int64_t>(tables + info::kTablesWords) ||
            static_cast<std::uint64_t>(start) + count > words)
            fail(4 * at, "table lies outside the block's info section");
        tableWord = static_cast<std::uint32_t>(start);
    };
    table(tables, t.rootGroupCount, t.rootGroupTableWord);
    table(tables + 2, t.frontierCount, t.frontierTableWord);
    // Attachments lie between the descriptor area and the info section, in directory order, each
    // reaching to the next: at most a contour array, then at most one colour/normal attachment.
    std::int64_t previous = 2;
    bool contours = false;
    std::vector<std::uint32_t> starts;
    for (std::uint64_t a = 0; a < attachments; ++a) {
        const std::uint64_t at = t.infoWord + info::kAttachments + 2 * a;
        const std::uint32_t kind = word(block.data(), at);
        const bool contour = kind == static_cast<std::uint32_t>(AttachmentKind::Contour);
        const bool attribute = kind < 32 && ((kAttributeKindBits >> kind) & 1u);
        if (!(contour && a == 0) && !(attribute && !t.hasAttributes()))
            fail(4 * at, "unexpected attachment kind " + std::to_string(kind));
        const std::int64_t start =
            static_cast<std::int64_t>(t.infoWord) + signedWord(block.data(), at + 1);
        if (start < previous || start % 2 != 0 || start > static_cast<std::int64_t>(t.infoWord))
            fail(4 * at + 4, "attachment pointer outside the block or out of order");
        previous = start;
        starts.push_back(static_cast<std::uint32_t>(start));
        if (contour) contours = true;
        if (attribute) t.attributeKind = static_cast<AttachmentKind>(kind);
    }
    t.descriptorEndWord = starts.empty() ? t.infoWord : starts.front();
    t.contourWord = t.contourEndWord = t.descriptorEndWord;
    if (contours) t.contourEndWord = starts.size() > 1 ? starts[1] : t.infoWord;
    if (t.hasAttributes()) {
        t.attributeWord = starts.back();
        t.attributeEndWord = t.infoWord;
    }
    return t;
}

BlockSummary validateBlock(const std::filesystem::path& file, const Header& header,
                           std::uint32_t sliceIndex, const SliceEntry& entry,
                           std::span<const std::uint8_t> block,
                           std::span<const FrontierDescriptor> parents) {
    const BlockChecker check(file, sliceIndex, entry);
    if (block.size() != entry.byteSize) check.fail(0, "block size differs from the directory's");
    const BlockTables t = readBlockTables(block, file, sliceIndex, entry.fileOffset);
    const std::uint8_t* b = block.data();
    const std::uint64_t infoByte = 4ull * t.infoWord;
    if (word(b, t.infoWord + info::kSliceId) != sliceIndex)
        check.fail(infoByte, "info section names another slice");
    if (word(b, t.infoWord + info::kBlockIndex) != 0)
        check.fail(infoByte + 4, "block index in slice is not 0");
    if (static_cast<std::int64_t>(t.infoWord) +
            signedWord(b, t.infoWord + info::kFirstDescriptor) !=
        2)
        check.fail(infoByte + 8, "first-descriptor pointer does not point at byte 8");
    const auto declared = [&](AttachmentKind kind) {
        return (header.attachmentKinds >> static_cast<unsigned>(kind)) & 1u;
    };
    if (t.contourEndWord != t.contourWord && !declared(AttachmentKind::Contour))
        check.fail(infoByte + 12, "contour attachment, but the header declares no contours");
    if (t.hasAttributes() && !declared(t.attributeKind))
        check.fail(infoByte + 12, "colour/normal attachment of a kind the header does not declare");
    if (!t.hasAttributes() && header.hasAttributes())
        check.fail(infoByte + 12,
                   "the header declares colours and normals, but the block has none");
    const std::uint64_t contourStart = t.contourWord;  // words
    std::vector<std::uint8_t> contourUsed(t.contourEndWord - contourStart, 0);
    if (t.rootGroupCount != entry.rootGroupCount || t.rootGroupCount != parents.size())
        check.fail(infoByte, "root group count differs from the directory's");

    // Every 8-byte unit of the descriptor area is a page header, a descriptor, a far slot or zero
    // padding.
    const std::uint64_t units = t.descriptorEndWord / 2;
    enum : std::uint8_t { kFree, kPageHeader, kDescriptor, kFarSlot };
    std::vector<std::uint8_t> use(units, kFree);
    BlockSummary summary;
    for (std::uint64_t page = 0; page * kPageBytes < 8 * units; ++page) {
        const std::uint64_t byte = page * kPageBytes;
        if (static_cast<std::int64_t>(byte / 4) + signedWord(b, byte / 4) != t.infoWord ||
            word(b, byte / 4 + 1) != 0)
            check.fail(byte, "page header does not point at the info section");
        use[byte / 8] = kPageHeader;
        summary.pageHeaderBytes += kPageHeaderBytes;
    }
    const auto claimGroup = [&](std::uint64_t first, std::uint64_t count, std::uint64_t from,
                                const char* what) {
        if (first < 1 || first + count > units)
            check.fail(8 * from, std::string(what) + " points outside the descriptor area");
        if ((8 * first) / kPageBytes != (8 * (first + count) - 1) / kPageBytes)
            check.fail(8 * first, "sibling group straddles a page header");
        // Compressed attributes pair units 2p and 2p + 1: groups start even so pairs never mix
        // parents.
        if (t.attributeKind == AttachmentKind::Dxt && first % 2 != 0)
            check.fail(
                8 * first,
                "sibling group starts on an odd unit, so a compressed block would mix parents");
        for (std::uint64_t u = first; u < first + count; ++u) {
            if (use[u] != kFree) check.fail(8 * u, std::string(what) + " overlaps other data");
            use[u] = kDescriptor;
        }
    };
    const auto claimSlot = [&](std::uint64_t slot, std::uint64_t from) {
        if (slot < 1 || slot >= units)
            check.fail(8 * from, "far pointer slot outside the descriptor area");
        if (use[slot] != kFree) check.fail(8 * slot, "far pointer slot overlaps other data");
        use[slot] = kFarSlot;
        if (word(b, 2 * slot + 1) != 0)
            check.fail(8 * slot + 4, "far pointer slot padding is not zero");
    };

    struct Pending {
        std::uint64_t unit;
        VoxelPosition position;
    };
    std::vector<Pending> stack;
    std::vector<std::uint64_t> descriptorUnits;  // with attributes: every descriptor found
    std::uint64_t descriptors = 0, farSlots = 0, voxels = 0, frontierIndex = 0;
    std::uint32_t deepest = 0, shallowestRoot = 0xFFFFFFFFu;
    summary.voxelsPerLevel.assign(header.leafDepth + 1, 0);
    summary.leavesPerLevel.assign(header.leafDepth + 1, 0);
    summary.contoursPerLevel.assign(header.leafDepth + 1, 0);
    const auto pushGroup = [&](std::uint64_t first, std::uint32_t nonLeafMask,
                               const VoxelPosition& parent) {
        std::uint64_t n = popc8(nonLeafMask);
        for (int slot = 7; slot >= 0; --slot)
            if (nonLeafMask & (1u << slot))
                stack.push_back({first + --n, parent.child(static_cast<std::uint32_t>(slot))});
    };
    for (std::uint32_t g = 0; g < t.rootGroupCount; ++g) {
        const std::uint64_t first = word(b, t.rootGroupTableWord + g);
        const std::uint32_t mask = parents[g].nonLeafMask;
        if (mask == 0 || (g > 0 && sliceIndex == 0))
            check.fail(4ull * (t.rootGroupTableWord + g), "root group without descriptors");
        claimGroup(first, popc8(mask), t.rootGroupTableWord / 2, "root group table entry");
        shallowestRoot =
            std::min(shallowestRoot, sliceIndex == 0 ? 0u : parents[g].position.level + 1);
        if (sliceIndex == 0)
            stack.push_back({first, VoxelPosition{}});
        else
            pushGroup(first, mask, parents[g].position);
        while (!stack.empty()) {
            const Pending d = stack.back();
            stack.pop_back();
            const ChildDescriptor desc{word(b, 2 * d.unit), word(b, 2 * d.unit + 1)};
            const std::uint64_t at = 8 * d.unit;
            if (d.position.level < entry.firstLevel || d.position.level >= entry.endLevel)
                check.fail(at, "descriptor outside the slice's level range");
            deepest = std::max(deepest, d.position.level);
            if (desc.contourMask() == 0) {
                if (desc.contour != 0) check.fail(at + 4, "contour pointer without a contour mask");
            } else {
                if ((desc.contourMask() & ~desc.validMask()) != 0)
                    check.fail(at + 4, "contour mask has bits outside the valid mask");
                const std::uint64_t firstContour = 2 * d.unit + desc.contourPointer();
                const std::uint64_t count = popc8(desc.contourMask());
                if (firstContour < contourStart || firstContour + count > t.contourEndWord)
                    check.fail(at + 4, "contour pointer outside the contour array");
                for (std::uint64_t w = firstContour; w < firstContour + count; ++w) {
                    if (contourUsed[w - contourStart])
                        check.fail(4 * w, "contour shared by two descriptors");
                    contourUsed[w - contourStart] = 1;
                    const Contour c = Contour::decode(word(b, w));
                    if (std::max({std::abs(c.nx), std::abs(c.ny), std::abs(c.nz)}) != 31)
                        check.fail(4 * w, "contour normal's largest component is not ±31");
                }
                summary.contourBytes += 4 * count;
                summary.contoursPerLevel[d.position.level + 1] += count;
            }
            if (desc.validMask() == 0) check.fail(at, "descriptor with an empty valid mask");
            if (t.hasAttributes()) descriptorUnits.push_back(d.unit);
            if ((desc.nonLeafMask() & ~desc.validMask()) != 0)
                check.fail(at, "non-leaf mask has bits outside the valid mask");
            ++descriptors;
            voxels += popc8(desc.validMask());
            summary.voxelsPerLevel[d.position.level + 1] += popc8(desc.validMask());
            summary.leavesPerLevel[d.position.level + 1] +=
                popc8(desc.validMask() & ~desc.nonLeafMask());
            if (d.position.level + 1 == header.leafDepth && desc.nonLeafMask() != 0)
                check.fail(at, "children below the leaf depth");
            if (desc.nonLeafMask() == 0) {
                if (desc.childPointer() != 0 || desc.far())
                    check.fail(at, "child pointer set on a descriptor without non-leaf children");
                continue;
            }
            if (desc.childPointer() == 0) check.fail(at, "zero child pointer");
            // A far slot holding 0 marks a frontier descriptor: its children are in a child slice.
            if (desc.far() && d.unit + desc.childPointer() >= units)
                check.fail(at, "far pointer slot outside the descriptor area");
            const bool frontier = desc.far() && word(b, 2 * (d.unit + desc.childPointer())) == 0;
            if (frontier) {
                const std::uint64_t slot = d.unit + desc.childPointer();
                claimSlot(slot, d.unit);
                ++farSlots;
                if (frontierIndex >= t.frontierCount ||
                    word(b, t.frontierTableWord + frontierIndex) != d.unit)
                    check.fail(4ull * (t.frontierTableWord + frontierIndex),
                               "frontier table does not list the frontier descriptors in order");
                ++frontierIndex;
                summary.frontier.push_back({desc.nonLeafMask(), d.position});
                continue;
            }
            std::int64_t target;
            if (desc.far()) {
                const std::uint64_t slot = d.unit + desc.childPointer();
                claimSlot(slot, d.unit);
                ++farSlots;
                target = static_cast<std::int64_t>(d.unit) + signedWord(b, 2 * slot);
            } else {
                if (desc.childPointer() > header.nearPointerLimit)
                    check.fail(at, "child pointer above the file's near pointer limit");
                target = static_cast<std::int64_t>(d.unit + desc.childPointer());
            }
            if (target < 1) check.fail(at, "child pointer before the descriptor area");
            claimGroup(static_cast<std::uint64_t>(target), popc8(desc.nonLeafMask()), d.unit,
                       "child pointer");
            pushGroup(static_cast<std::uint64_t>(target), desc.nonLeafMask(), d.position);
        }
    }
    if (deepest + 1 != entry.endLevel || shallowestRoot != entry.firstLevel)
        check.fail(8, "level range differs from the directory's");
    if (frontierIndex != t.frontierCount)
        check.fail(4ull * t.frontierTableWord,
                   "frontier table lists descriptors that are not frontier");
    if (descriptors != entry.descriptorCount)
        check.fail(8, "descriptor count differs from the directory's");
    if (farSlots != entry.farPointerCount)
        check.fail(8, "far pointer count differs from the directory's");
    if (voxels != entry.voxelCount) check.fail(8, "voxel count differs from the directory's");
    for (std::uint64_t u = 1; u < units; ++u)
        if (use[u] == kFree) {
            if (load<std::uint64_t>(b + 8 * u) != 0)
                check.fail(8 * u, "padding is not zero (unreferenced data)");
            summary.paddingBytes += 8;
        }
    for (std::size_t w = 0; w < contourUsed.size(); ++w)
        if (!contourUsed[w] &&
            !(w + 1 == contourUsed.size() && w % 2 == 1 && word(b, contourStart + w) == 0))
            check.fail(4 * (contourStart + w), "contour array word no descriptor refers to");
    if (t.hasAttributes()) validateAttributes(check, t, b, units, descriptorUnits, summary);
    // The block ends with the tables, padded to 8 bytes with zero.
    const std::uint64_t tablesEnd = std::max<std::uint64_t>(t.rootGroupTableWord + t.rootGroupCount,
                                                            t.frontierTableWord + t.frontierCount);
    if ((4 * tablesEnd + 7) / 8 * 8 != block.size())
        check.fail(4 * tablesEnd, "data after the info section's tables");
    for (std::uint64_t w = tablesEnd; w < block.size() / 4; ++w)
        if (word(b, w) != 0) check.fail(4 * w, "padding after the tables is not zero");
    summary.descriptorBytes = 8 * descriptors;
    summary.farPointerBytes = 8 * farSlots;
    summary.infoBytes = block.size() - infoByte;
    summary.paddingBytes += 4 * (contourUsed.size()) - summary.contourBytes;
    return summary;
}

FileBreakdown validateFile(const EsvoReader& reader) {
    const Header& h = reader.header();
    const Directory& d = reader.directory();
    FileBreakdown total;
    total.headerAndDirectoryBytes = h.directoryOffset + h.directoryBytes;
    std::vector<std::vector<FrontierDescriptor>> frontiers(d.slices.size());
    struct Region {
        std::uint32_t level, x, y, z;
    };
    std::vector<Region> regions(d.slices.size(), Region{0, 0, 0, 0});
    std::vector<std::uint64_t> voxelsPerLevel(h.leafDepth + 1, 0);
    voxelsPerLevel[0] = 1;
    total.leavesPerLevel.assign(h.leafDepth + 1, 0);
    total.contoursPerLevel.assign(h.leafDepth + 1, 0);
    std::uint64_t used = total.headerAndDirectoryBytes;
    // The alignment gaps before each slice must be zero, as the writer leaves them: a flipped
    // byte there is corruption too, even if no reader reads it.
    const ReadOnlyFile file(reader.path());
    std::uint64_t previousEnd = total.headerAndDirectoryBytes;
    const auto checkGap = [&](std::uint64_t from, std::uint64_t to) {
        if (to <= from) return;
        std::vector<std::uint8_t> gap(to - from);
        file.read(from, gap.data(), gap.size());
        for (std::size_t k = 0; k < gap.size(); ++k)
            if (gap[k] != 0)
                throw InvalidDataError(reader.path(),
                                       "byte " + std::to_string(from + k) +
                                           ": the alignment gap before a slice is not zero");
    };
    const FrontierDescriptor rootParent{1, {}};
    for (std::uint32_t i = 0; i < d.slices.size(); ++i) {
        const SliceEntry& s = d.slices[i];
        std::span<const FrontierDescriptor> parents(&rootParent, 1);
        if (i > 0) {
            const Region& pr = regions[s.parent];
            Region r = pr;
            for (std::uint32_t step = 0; step < s.pathLevels; ++step) {
                const auto octant =
                    static_cast<std::uint32_t>(s.regionPath >> (3 * (s.pathLevels - 1 - step))) &
                    7u;
                r = {r.level + 1, 2 * r.x + (octant & 1u), 2 * r.y + ((octant >> 1) & 1u),
                     2 * r.z + (octant >> 2)};
            }
            regions[i] = r;
            const auto& pf = frontiers[s.parent];
            if (std::uint64_t{s.firstFrontier} + s.rootGroupCount > pf.size())
                throw InvalidDataError(reader.path(),
                                       "slice directory entry " + std::to_string(i) +
                                           ": frontier range exceeds its parent's frontier table");
            parents =
                std::span<const FrontierDescriptor>(pf.data() + s.firstFrontier, s.rootGroupCount);
            for (const FrontierDescriptor& p : parents) {
                // A frontier descriptor above the region (a directory entry whose region and
                // first level were moved below its root groups passes the directory checks,
                // which tie the region to the entry's first level, not to the parent's
                // frontier) would make the shift below negative, wrapped, and undefined.
                if (p.position.level < r.level)
                    throw InvalidDataError(reader.path(),
                                           "slice directory entry " + std::to_string(i) +
                                               ": a root group lies above the slice's region");
                const std::uint32_t shift = p.position.level - r.level;
                if ((p.position.x >> shift) != r.x || (p.position.y >> shift) != r.y ||
                    (p.position.z >> shift) != r.z)
                    throw InvalidDataError(reader.path(),
                                           "slice directory entry " + std::to_string(i) +
                                               ": a root group lies outside the slice's region");
            }
        }
        checkGap(previousEnd, s.fileOffset);
        previousEnd = std::max(previousEnd, s.fileOffset + s.byteSize);
        const std::vector<std::uint8_t> bytes = reader.readSlice(i);
        BlockSummary summary = validateBlock(reader.path(), h, i, s, bytes, parents);
        std::uint64_t consumed = 0;
        for (std::uint32_t c = 0; c < s.childCount; ++c)
            consumed += d.slices[s.firstChild + c].rootGroupCount;
        if (consumed != summary.frontier.size())
            throw InvalidDataError(reader.path(),
                                   "slice " + std::to_string(i) + ": " +
                                       std::to_string(summary.frontier.size()) +
                                       " frontier descriptors but its child slices resolve " +
                                       std::to_string(consumed));
        for (std::size_t l = 0; l < voxelsPerLevel.size(); ++l) {
            voxelsPerLevel[l] += summary.voxelsPerLevel[l];
            total.leavesPerLevel[l] += summary.leavesPerLevel[l];
            total.contoursPerLevel[l] += summary.contoursPerLevel[l];
        }
        total.descriptorBytes += summary.descriptorBytes;
        total.farPointerBytes += summary.farPointerBytes;
        total.pageHeaderBytes += summary.pageHeaderBytes;
        total.infoBytes += summary.infoBytes;
        total.paddingBytes += summary.paddingBytes;
        total.contourBytes += summary.contourBytes;
        total.attributeLookupBytes += summary.attributeLookupBytes;
        total.attributeValueBytes += summary.attributeValueBytes;
        total.attributeBlockBytes += summary.attributeBlockBytes;
        used += s.byteSize;
        frontiers[i] = std::move(summary.frontier);
    }
    for (std::size_t l = 0; l < voxelsPerLevel.size(); ++l)
        if (voxelsPerLevel[l] != d.voxelsPerLevel[l])
            throw InvalidDataError(reader.path(), "slice directory: level " + std::to_string(l) +
                                                      " lists " +
                                                      std::to_string(d.voxelsPerLevel[l]) +
                                                      " voxels but the slices hold " +
                                                      std::to_string(voxelsPerLevel[l]));
    total.slicePaddingBytes = h.fileBytes - used;
    return total;
}

}  // namespace vox::esvo
