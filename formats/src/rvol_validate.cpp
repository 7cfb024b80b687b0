// Validation of whole .rvol files (docs/rvol-format.md, "Invariants checked by validate").
#include <vox/base/error.h>
#include <vox/formats/rvol_io.h>

#include "rvol_internal.h"

#include <algorithm>
#include <string>

namespace vox::rvol {
namespace {

std::string str(std::uint64_t v) { return std::to_string(v); }

/// Checks one level's bricks; the reader has checked the level table and directory.
class LevelChecker {
public:
    LevelChecker(const RvolReader& reader, std::uint32_t level)
        : reader_(reader),
          level_(level),
          e_(reader.level(level)),
          n_(reader.header().brickTexels),
          binary_(reader.header().binaryLevel0Opacity()),
          planes_(alphaPlanes(e_.channels, binary_)),
          entries_(reader.bricks(level)) {}

    /// Returns the level's distinct non-zero cells.
    std::uint64_t run() {
        std::uint64_t nonZero = 0;
        for (std::uint32_t i = 0; i < e_.brickCount; ++i) {
            const BrickEntry& b = entries_[i];
            const std::vector<std::uint8_t> bytes =
                reader_.readBrickBytes(level_, i);  // checks the CRC and the mask's size
            // In the binary-opacity layout a non-zero byte is a non-zero word: a solid cell.
            if (std::all_of(bytes.begin(), bytes.end(), [](std::uint8_t v) { return v == 0; }))
                fail(i, "all texels zero (an empty brick must not be stored)");
            checkPacked(i, bytes);
            const std::array<std::uint32_t, 3> coords{b.x, b.y, b.z};
            const std::uint32_t step = n_ - 1;
            for (std::uint32_t k = 0; k < n_; ++k)
                for (std::uint32_t j = 0; j < n_; ++j)
                    for (std::uint32_t ii = 0; ii < n_; ++ii) {
                        const std::array<std::uint32_t, 3> local{ii, j, k};
                        bool outside = false, owned = true;
                        for (int a = 0; a < 3; ++a) {
                            outside = outside || coords[a] * step + local[a] >= e_.resolution;
                            // A face texel belongs to the next brick along its axis when there is
                            // one.
                            owned = owned && (local[a] < step || coords[a] + 1 == e_.bricksPerAxis);
                        }
                        const bool zero = texelZero(bytes, texelIndex(local));
                        if (outside && !zero)
                            fail(i, "texel (" + str(ii) + "," + str(j) + "," + str(k) +
                                        ") lies outside the level but is not zero");
                        nonZero += !zero && owned && !outside;
                    }
            for (int a = 0; a < 3; ++a) {
                // Towards +axis: equal to the neighbour's first face, or zero if it is not stored.
                if (coords[a] + 1 < e_.bricksPerAxis) {
                    std::array<std::uint32_t, 3> next = coords;
                    ++next[a];
                    const std::int64_t neighbour =
                        reader_.findBrick(level_, next[0], next[1], next[2]);
                    if (neighbour >= 0) {
                        const std::vector<std::uint8_t> other =
                            reader_.readBrickBytes(level_, static_cast<std::uint32_t>(neighbour));
                        compareFace(i, bytes, other, a, next);
                    } else {
                        requireZeroFace(i, bytes, a, n_ - 1, next);
                    }
                }
                // Towards −axis: only the missing neighbour's case; a stored one compared its face
                // above.
                if (coords[a] > 0) {
                    std::array<std::uint32_t, 3> previous = coords;
                    --previous[a];
                    if (reader_.findBrick(level_, previous[0], previous[1], previous[2]) < 0)
                        requireZeroFace(i, bytes, a, 0, previous);
                }
            }
        }
        return nonZero;
    }

private:
    /// The stored form is the one packBrick gives (so a file is determined by its texels): no
    /// stored plane all zero, no mask texel zero in every plane, zero padding.
    void checkPacked(std::uint32_t index, const std::vector<std::uint8_t>& dense) const {
        const BrickEntry& b = entries_[index];
        const PackedBrick packed = packBrick(dense, n_, e_.channels, binary_);
        if (packed.planes != b.planes)
            fail(index, "a stored plane is all zero (plane bits " + str(b.planes) + ", planes " +
                            str(packed.planes) + " hold a non-zero texel)");
        if (packed.texels != b.texels)
            fail(index, "occupancy mask holds a texel that is zero in every plane");
        if (packed.bytes != reader_.readStoredBrick(level_, index))
            fail(index, "padding after the A8 planes is not zero");
    }
    [[noreturn]] void fail(std::uint32_t index, const std::string& what) const {
        const BrickEntry& b = entries_[index];
        throw InvalidDataError(reader_.path(),
                               "level " + str(level_) + ", brick " + str(index) + " (" + str(b.x) +
                                   "," + str(b.y) + "," + str(b.z) + "), file offset " +
                                   str(reader_.brickOffset(level_, index)) + ": " + what);
    }
    [[nodiscard]] std::size_t texelIndex(const std::array<std::uint32_t, 3>& t) const noexcept {
        return (std::size_t{t[2]} * n_ + t[1]) * n_ + t[0];
    }
    [[nodiscard]] std::uint64_t rgbOffset(std::uint32_t channel) const noexcept {
        return rgbPlaneOffset(n_, channel);
    }
    [[nodiscard]] std::uint64_t alphaOffset(std::uint32_t plane) const noexcept {
        return alphaPlaneOffset(n_, e_.channels, plane);
    }
    /// "A8 plane" at level 0, "x-axis A8 plane" (y, z) above.
    [[nodiscard]] std::string planeName(std::uint32_t plane) const {
        if (planes_ == 1) return "A8 plane";
        std::string name(1, static_cast<char>('x' + plane));
        name += "-axis A8 plane";
        return name;
    }
    [[nodiscard]] bool texelZero(const std::vector<std::uint8_t>& bytes,
                                 std::size_t t) const noexcept {
        for (std::uint32_t c = 0; c < e_.channels; ++c)
            if (detail::load<std::uint32_t>(bytes.data() + rgbOffset(c) + 4 * t) != 0) return false;
        for (std::uint32_t p = 0; p < planes_; ++p)
            if (bytes[alphaOffset(p) + t] != 0) return false;
        return true;
    }
    [[nodiscard]] static std::string coordsText(const std::array<std::uint32_t, 3>& c) {
        // Appended piecewise: GCC 12 reports a false -Wrestrict on chained string concatenation.
        std::string text = "(";
        text += str(c[0]);
        text += ',';
        text += str(c[1]);
        text += ',';
        text += str(c[2]);
        text += ')';
        return text;
    }
    /// Visits the N² texels of the face at @p layer along @p axis as (local coordinates).
    template <typename F>
    void forFace(int axis, std::uint32_t layer, F&& visit) const {
        const int u = (axis + 1) % 3, v = (axis + 2) % 3;
        for (std::uint32_t b = 0; b < n_; ++b)
            for (std::uint32_t a = 0; a < n_; ++a) {
                std::array<std::uint32_t, 3> t{};
                t[axis] = layer, t[u] = a, t[v] = b;
                visit(t);
            }
    }
    void compareFace(std::uint32_t index, const std::vector<std::uint8_t>& bytes,
                     const std::vector<std::uint8_t>& other, int axis,
                     const std::array<std::uint32_t, 3>& neighbour) const {
        forFace(axis, n_ - 1, [&](std::array<std::uint32_t, 3> t) {
            const std::size_t here = texelIndex(t);
            t[axis] = 0;
            const std::size_t there = texelIndex(t);
            for (std::uint32_t c = 0; c < e_.channels; ++c) {
                const std::uint8_t* a = bytes.data() + rgbOffset(c);
                const std::uint8_t* b = other.data() + rgbOffset(c);
                if (!std::equal(a + 4 * here, a + 4 * here + 4, b + 4 * there))
                    fail(index, "shared face with brick " + coordsText(neighbour) +
                                    " differs (channel " + str(c) + ")");
            }
            for (std::uint32_t p = 0; p < planes_; ++p)
                if (bytes[alphaOffset(p) + here] != other[alphaOffset(p) + there])
                    fail(index, "shared face with brick " + coordsText(neighbour) + " differs (" +
                                    planeName(p) + ")");
        });
    }
    void requireZeroFace(std::uint32_t index, const std::vector<std::uint8_t>& bytes, int axis,
                         std::uint32_t layer, const std::array<std::uint32_t, 3>& neighbour) const {
        forFace(axis, layer, [&](const std::array<std::uint32_t, 3>& t) {
            if (!texelZero(bytes, texelIndex(t)))
                fail(index, "face shared with brick " + coordsText(neighbour) +
                                ", which is not stored, is not zero");
        });
    }

    const RvolReader& reader_;
    std::uint32_t level_;
    const LevelEntry& e_;
    std::uint32_t n_;
    bool binary_;           ///< the file has binary level-0 opacity
    std::uint32_t planes_;  ///< A8 planes per brick (none at level 0 with binary opacity)
    std::span<const BrickEntry> entries_;
};

void checkLayer(const RvolReader& reader, bool dynamic) {
    const std::string name = dynamic ? "dynamic" : "static";
    const std::vector<AttributeRecord> records =
        reader.readAttributeRecords(dynamic);  // checks the CRC
    const std::uint64_t limit = std::uint64_t{1} << (3 * reader.header().depth);
    const std::uint64_t offset =
        dynamic ? reader.header().dynamicAttributesOffset : reader.header().staticAttributesOffset;
    for (std::size_t i = 0; i < records.size(); ++i) {
        const auto fail = [&](const std::string& what) {
            throw InvalidDataError(reader.path(),
                                   name + " attribute layer, record " + str(i) + ", file offset " +
                                       str(offset + i * kAttributeRecordBytes) + ": " + what);
        };
        if (records[i].morton >= limit)
            fail("Morton code " + str(records[i].morton) + " outside level 0");
        if (i > 0 && records[i].morton <= records[i - 1].morton)
            fail("Morton codes not strictly ascending");
    }
}

/// The @p size bytes at @p offset must be zero (alignment gaps).
void checkGap(const RvolReader& reader, std::uint64_t offset, std::uint64_t size,
              RvolReport& report) {
    std::array<std::uint8_t, kSectionAlignment> bytes{};
    reader.readBytes(offset, bytes.data(), size);  // gaps are shorter than one alignment unit
    for (std::uint64_t i = 0; i < size; ++i)
        if (bytes[i] != 0)
            throw InvalidDataError(reader.path(),
                                   "padding at file offset " + str(offset + i) + " is not zero");
    report.paddingBytes += size;
}

}  // namespace

RvolReport validateRvol(const RvolReader& reader) {
    const Header& h = reader.header();
    RvolReport r;
    r.fileBytes = h.fileBytes;
    r.headerBytes = kHeaderBytes;
    r.levelTableBytes = h.levelTableBytes;
    r.directoryBytes = h.directoryBytes;
    r.staticAttributeBytes = h.staticAttributesBytes;
    r.dynamicAttributeBytes = h.dynamicAttributesBytes;
    r.bricks = h.brickCount;
    r.staticVoxels = h.staticVoxelCount;
    r.dynamicVoxels = h.dynamicVoxelCount;

    // The reader's constructor fixed every offset to the first multiple of 64 after the previous
    // part; here the gaps between them are checked.
    checkGap(reader, h.levelTableOffset + h.levelTableBytes,
             h.directoryOffset - (h.levelTableOffset + h.levelTableBytes), r);
    checkGap(reader, h.directoryOffset + h.directoryBytes,
             h.brickDataOffset - (h.directoryOffset + h.directoryBytes), r);
    std::uint64_t end = h.brickDataOffset;
    for (std::uint32_t l = 0; l < h.levelCount; ++l) {
        const LevelEntry& e = reader.level(l);
        checkGap(reader, end, e.dataOffset - end, r);
        end = e.dataOffset + e.dataBytes;
        r.radianceBytes += e.dataBytes;
        r.bricksPerLevel.push_back(e.brickCount);
        r.nonZeroTexelsPerLevel.push_back(LevelChecker(reader, l).run());
    }
    checkGap(reader, end, h.staticAttributesOffset - end, r);
    checkGap(reader, h.staticAttributesOffset + h.staticAttributesBytes,
             h.dynamicAttributesOffset - (h.staticAttributesOffset + h.staticAttributesBytes), r);
    checkLayer(reader, false);
    checkLayer(reader, true);
    return r;
}

}  // namespace vox::rvol
