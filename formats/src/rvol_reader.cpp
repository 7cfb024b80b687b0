// The .rvol reader (docs/rvol-format.md): header, level table and brick directory up front,
// bricks and attribute layers on demand, trilinear sampling over the node-centred bricks.
#include <vox/formats/checksum.h>
#include <vox/base/error.h>
#include <vox/formats/rvol_io.h>

#include <vox/formats/read_only_file.h>
#include "rvol_internal.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <list>
#include <mutex>
#include <stdexcept>
#include <string>
#include <unordered_map>

namespace vox::rvol {

using detail::load;

namespace {

[[noreturn]] void invalid(const std::filesystem::path& file, const std::string& problem) {
    throw InvalidDataError(file, problem);
}

std::string str(std::uint64_t v) { return std::to_string(v); }

Header decodeHeader(const std::filesystem::path& file, const std::uint8_t* p,
                    std::uint64_t fileSize) {
    namespace o = detail::hdr;
    if (!std::equal(kMagic.begin(), kMagic.end(), p))
        invalid(file, "not an .rvol file (bad magic)");
    Header h;
    h.versionMajor = load<std::uint16_t>(p + o::kVersionMajor);
    h.versionMinor = load<std::uint16_t>(p + o::kVersionMinor);
    if (h.versionMajor != kVersionMajor)
        invalid(file, "unsupported .rvol version " + str(h.versionMajor) + "." +
                          str(h.versionMinor) + " (this reader reads " + str(kVersionMajor) +
                          ".x)");
    if (load<std::uint32_t>(p + o::kHeaderBytes) != kHeaderBytes)
        invalid(file, "header: size field is not 256");
    if (load<std::uint32_t>(p + o::kChecksum) != crc32c(p, o::kChecksum))
        invalid(file, "header: checksum mismatch");
    h.depth = load<std::uint32_t>(p + o::kDepth);
    h.levelCount = load<std::uint32_t>(p + o::kLevelCount);
    h.brickTexels = load<std::uint32_t>(p + o::kBrickTexels);
    h.texelFormat = load<std::uint32_t>(p + o::kTexelFormat);
    h.flags = load<std::uint32_t>(p + o::kFlags);
    for (int i = 0; i < 3; ++i) h.origin[i] = load<double>(p + o::kOrigin + 8 * i);
    h.size = load<double>(p + o::kSize);
    for (int i = 0; i < 6; ++i) h.sceneBounds[i] = load<float>(p + o::kSceneBounds + 4 * i);
    h.bake.bounces = load<std::uint32_t>(p + o::kBounces);
    h.bake.shadowApertureDegrees = load<float>(p + o::kShadowAperture);
    h.bake.aoLambda = load<float>(p + o::kAoLambda);
    h.bake.attenuation = load<std::uint32_t>(p + o::kAttenuation);
    h.bake.lights = load<std::uint32_t>(p + o::kLights);
    h.bake.gatherRays = load<std::uint32_t>(p + o::kGatherRays);
    h.brickCount = load<std::uint64_t>(p + o::kBrickCount);
    h.staticVoxelCount = load<std::uint64_t>(p + o::kStaticVoxels);
    h.dynamicVoxelCount = load<std::uint64_t>(p + o::kDynamicVoxels);
    h.levelTableOffset = load<std::uint64_t>(p + o::kLevelTableOffset);
    h.levelTableBytes = load<std::uint64_t>(p + o::kLevelTableBytes);
    h.levelTableChecksum = load<std::uint32_t>(p + o::kLevelTableChecksum);
    h.directoryChecksum = load<std::uint32_t>(p + o::kDirectoryChecksum);
    h.directoryOffset = load<std::uint64_t>(p + o::kDirectoryOffset);
    h.directoryBytes = load<std::uint64_t>(p + o::kDirectoryBytes);
    h.brickDataOffset = load<std::uint64_t>(p + o::kBrickDataOffset);
    h.brickDataBytes = load<std::uint64_t>(p + o::kBrickDataBytes);
    h.staticAttributesOffset = load<std::uint64_t>(p + o::kStaticOffset);
    h.staticAttributesBytes = load<std::uint64_t>(p + o::kStaticBytes);
    h.dynamicAttributesOffset = load<std::uint64_t>(p + o::kDynamicOffset);
    h.dynamicAttributesBytes = load<std::uint64_t>(p + o::kDynamicBytes);
    h.staticAttributesChecksum = load<std::uint32_t>(p + o::kStaticChecksum);
    h.dynamicAttributesChecksum = load<std::uint32_t>(p + o::kDynamicChecksum);
    h.fileBytes = load<std::uint64_t>(p + o::kFileBytes);

    if (h.depth > kMaxDepth)
        invalid(file, "header: depth " + str(h.depth) + " above " + str(kMaxDepth));
    if (h.levelCount != h.depth + 1) invalid(file, "header: level count is not depth + 1");
    if (h.brickTexels < kMinBrickTexels || h.brickTexels > kMaxBrickTexels)
        invalid(file, "header: brick size " + str(h.brickTexels) + " outside " +
                          str(kMinBrickTexels) + ".." + str(kMaxBrickTexels));
    if (h.texelFormat != kTexelFormatRgb9e5AxisA8)
        invalid(file, "header: unknown texel format " + str(h.texelFormat));
    if (!std::isfinite(h.origin[0]) || !std::isfinite(h.origin[1]) || !std::isfinite(h.origin[2]) ||
        !std::isfinite(h.size) || !(h.size > 0))
        invalid(file, "header: root cube origin or size not finite, or size not positive");
    if (h.fileBytes != fileSize)
        invalid(file, "header says " + str(h.fileBytes) + " bytes but the file has " +
                          str(fileSize) + " (truncated or appended to)");
    if ((h.flags & kFlagStaticAttributes) == 0 && h.staticVoxelCount != 0)
        invalid(file, "header: static voxels counted but the static layer is marked absent");

    // Every section at the first multiple of 64 after the previous one; each count bounded by the
    // file size before it is multiplied, so nothing below overflows or allocates past the file.
    if (h.levelTableOffset != kHeaderBytes ||
        h.levelTableBytes != std::uint64_t{kLevelEntryBytes} * h.levelCount)
        invalid(file, "header: level table not right after the header or not " + str(h.levelCount) +
                          " entries");
    if (h.brickCount > fileSize / kBrickEntryBytes ||
        h.directoryBytes != h.brickCount * kBrickEntryBytes ||
        h.directoryOffset != alignSection(h.levelTableOffset + h.levelTableBytes))
        invalid(file, "header: brick directory misplaced or not " + str(h.brickCount) + " entries");
    if (h.brickDataBytes > fileSize ||
        h.brickDataOffset != alignSection(h.directoryOffset + h.directoryBytes))
        invalid(file, "header: brick data misplaced or larger than the file");
    if (h.staticVoxelCount > fileSize / kAttributeRecordBytes ||
        h.staticAttributesBytes != h.staticVoxelCount * kAttributeRecordBytes ||
        h.staticAttributesOffset != alignSection(h.brickDataOffset + h.brickDataBytes))
        invalid(file, "header: static attribute layer misplaced or not " + str(h.staticVoxelCount) +
                          " records");
    if (h.dynamicVoxelCount > fileSize / kAttributeRecordBytes ||
        h.dynamicAttributesBytes != h.dynamicVoxelCount * kAttributeRecordBytes ||
        h.dynamicAttributesOffset !=
            alignSection(h.staticAttributesOffset + h.staticAttributesBytes))
        invalid(file, "header: dynamic attribute layer misplaced or not " +
                          str(h.dynamicVoxelCount) + " records");
    if (h.dynamicAttributesOffset + h.dynamicAttributesBytes != h.fileBytes)
        invalid(file, "header: sections do not end at the end of the file");
    return h;
}

/// The level table; the levels' data offsets and sizes are checked with the directory
/// (decodeDirectory), which holds the bricks' sizes.
std::vector<LevelEntry> decodeLevelTable(const std::filesystem::path& file, const Header& h,
                                         const std::uint8_t* p) {
    if (h.levelTableChecksum != crc32c(p, h.levelTableBytes))
        invalid(file, "level table: checksum mismatch");
    std::vector<LevelEntry> levels(h.levelCount);
    std::uint64_t nextBrick = 0;
    for (std::uint32_t l = 0; l < h.levelCount; ++l, p += kLevelEntryBytes) {
        LevelEntry& e = levels[l];
        e.resolution = load<std::uint32_t>(p + 0);
        e.channels = load<std::uint32_t>(p + 4);
        e.bricksPerAxis = load<std::uint32_t>(p + 8);
        e.denseBrickBytes = load<std::uint32_t>(p + 12);
        e.brickCount = load<std::uint32_t>(p + 16);
        e.firstBrick = load<std::uint32_t>(p + 20);
        e.dataOffset = load<std::uint64_t>(p + 24);
        const std::string where = "level table, level " + str(l) + ": ";
        if (e.resolution != levelResolution(h.depth, l) || e.channels != levelChannels(l))
            invalid(file, where + "resolution or channel count wrong for depth " + str(h.depth));
        if (e.bricksPerAxis != bricksPerAxis(e.resolution, h.brickTexels) ||
            e.denseBrickBytes != brickBytes(h.brickTexels, e.channels, h.binaryLevel0Opacity()))
            invalid(file, where + "bricks per axis or brick size wrong for " + str(h.brickTexels) +
                              "-texel bricks");
        const std::uint64_t perAxis = e.bricksPerAxis;
        if (e.brickCount > perAxis * perAxis * perAxis)
            invalid(file, where + "more bricks than the level has");
        if (e.firstBrick != nextBrick)
            invalid(file, where + "first directory entry does not follow the previous level's");
        nextBrick += e.brickCount;
        if (nextBrick > h.brickCount) invalid(file, where + "more bricks than the header counts");
    }
    if (nextBrick != h.brickCount)
        invalid(file, "level table: levels hold " + str(nextBrick) + " bricks, the header counts " +
                          str(h.brickCount));
    return levels;
}

/// The directory, and per entry the file offset of its brick (@p offsets). Checks each entry, and
/// places every level's bricks (the sum of their stored sizes) and the levels' data offsets.
std::vector<BrickEntry> decodeDirectory(const std::filesystem::path& file, const Header& h,
                                        std::vector<LevelEntry>& levels, const std::uint8_t* p,
                                        std::vector<std::uint64_t>& offsets) {
    if (h.directoryChecksum != crc32c(p, h.directoryBytes))
        invalid(file, "brick directory: checksum mismatch");
    std::vector<BrickEntry> entries(h.brickCount);
    for (BrickEntry& e : entries) {
        e.x = load<std::uint16_t>(p + 0);
        e.y = load<std::uint16_t>(p + 2);
        e.z = load<std::uint16_t>(p + 4);
        e.planes = load<std::uint16_t>(p + 6);
        e.texels = load<std::uint32_t>(p + 8);
        e.checksum = load<std::uint32_t>(p + 12);
        p += kBrickEntryBytes;
    }
    offsets.resize(entries.size());
    const std::uint32_t n = h.brickTexels;
    const std::uint64_t n3 = std::uint64_t{n} * n * n,
                        dataEnd = h.brickDataOffset + h.brickDataBytes;
    std::uint64_t end = h.brickDataOffset;
    for (std::uint32_t l = 0; l < levels.size(); ++l) {
        LevelEntry& level = levels[l];
        if (level.dataOffset != alignSection(end))
            invalid(file, "level table, level " + str(l) + ": brick data misplaced");
        const std::uint32_t rgb = level.channels,
                            planes = rgb + alphaPlanes(level.channels, h.binaryLevel0Opacity());
        end = level.dataOffset;
        for (std::uint32_t i = 0; i < level.brickCount; ++i) {
            const BrickEntry& e = entries[level.firstBrick + i];
            const std::string where = "brick directory: level " + str(l) + ", entry " + str(i);
            if (e.x >= level.bricksPerAxis || e.y >= level.bricksPerAxis ||
                e.z >= level.bricksPerAxis)
                invalid(file, where + ": brick (" + str(e.x) + "," + str(e.y) + "," + str(e.z) +
                                  ") outside the level's " + str(level.bricksPerAxis) +
                                  " bricks per axis");
            // Binary search (findBrick) relies on this order.
            if (i > 0 && e.morton() <= entries[level.firstBrick + i - 1].morton())
                invalid(file, where + ": not in strictly ascending Morton order");
            if (e.planes == 0 || (e.planes >> planes) != 0)
                invalid(file, where + ": plane bits " + str(e.planes) + " not 1 … 2^" +
                                  str(planes) + " - 1");
            if (e.texels == 0 || e.texels > n3)
                invalid(file, where + ": " + str(e.texels) + " texels, not 1 … " + str(n3));
            const auto rgbStored = static_cast<std::uint32_t>(
                           std::popcount(static_cast<std::uint32_t>(e.planes & ((1u << rgb) - 1)))),
                       alphaStored = static_cast<std::uint32_t>(
                           std::popcount(static_cast<std::uint32_t>(e.planes >> rgb)));
            offsets[level.firstBrick + i] = end;
            // Each brick is at most a few hundred kB: no overflow before the bound below.
            end += storedBrickBytes(n, rgbStored, alphaStored, e.texels);
            if (end > dataEnd) invalid(file, where + ": bricks end past the brick data");
        }
        level.dataBytes = end - level.dataOffset;
    }
    if (end != dataEnd) invalid(file, "brick directory: bricks end before the brick data does");
    return entries;
}

}  // namespace

// Decoded bricks for sample(), least recently used evicted first.
struct RvolReader::Cache {
    std::mutex mutex;
    std::uint64_t limitBytes = std::uint64_t{64} << 20;
    std::uint64_t usedBytes = 0;
    std::list<std::uint64_t> order;  // most recently used first
    struct Item {
        std::shared_ptr<const std::vector<Texel>> texels;
        std::list<std::uint64_t>::iterator position;
    };
    std::unordered_map<std::uint64_t, Item> items;

    void evict() {
        // Keep the most recent brick even when it alone exceeds the limit.
        while (usedBytes > limitBytes && order.size() > 1) {
            const auto it = items.find(order.back());
            usedBytes -= it->second.texels->size() * sizeof(Texel);
            items.erase(it);
            order.pop_back();
        }
    }
};

RvolReader::RvolReader(std::filesystem::path file)
    : path_(std::move(file)),
      file_(std::make_unique<vox::ReadOnlyFile>(path_)),
      cache_(std::make_unique<Cache>()) {
    const std::uint64_t fileSize = file_->size();
    if (fileSize < kHeaderBytes)
        invalid(path_, "too short for an .rvol header (" + str(fileSize) + " bytes)");
    std::array<std::uint8_t, kHeaderBytes> headerBytes{};
    readBytes(0, headerBytes.data(), headerBytes.size());
    header_ = decodeHeader(path_, headerBytes.data(), fileSize);
    std::vector<std::uint8_t> table(header_.levelTableBytes);  // ≤ 11 entries
    readBytes(header_.levelTableOffset, table.data(), table.size());
    levels_ = decodeLevelTable(path_, header_, table.data());
    std::vector<std::uint8_t> directoryBytes(
        header_.directoryBytes);  // inside the file, checked above
    readBytes(header_.directoryOffset, directoryBytes.data(), directoryBytes.size());
    directory_ = decodeDirectory(path_, header_, levels_, directoryBytes.data(), brickOffsets_);
}

RvolReader::~RvolReader() = default;

void RvolReader::readBytes(std::uint64_t offset, std::uint8_t* out, std::uint64_t size) const {
    file_->read(offset, out, size);
}

std::span<const BrickEntry> RvolReader::bricks(std::uint32_t level) const {
    const LevelEntry& e = levels_.at(level);
    return std::span<const BrickEntry>(directory_).subspan(e.firstBrick, e.brickCount);
}

std::int64_t RvolReader::findBrick(std::uint32_t level, std::uint32_t x, std::uint32_t y,
                                   std::uint32_t z) const {
    const LevelEntry& e = levels_.at(level);
    if (x >= e.bricksPerAxis || y >= e.bricksPerAxis || z >= e.bricksPerAxis) return -1;
    const std::span<const BrickEntry> entries = bricks(level);
    const std::uint64_t code = morton3(x, y, z);
    const auto it = std::lower_bound(
        entries.begin(), entries.end(), code,
        [](const BrickEntry& entry, std::uint64_t c) { return entry.morton() < c; });
    if (it == entries.end() || it->morton() != code) return -1;
    return it - entries.begin();
}

std::uint64_t RvolReader::brickOffset(std::uint32_t level, std::uint32_t index) const {
    const LevelEntry& e = levels_.at(level);
    if (index >= e.brickCount) throw std::out_of_range("RvolReader: brick index out of range");
    return brickOffsets_[e.firstBrick + index];
}

std::uint64_t RvolReader::storedBrickSize(std::uint32_t level, std::uint32_t index) const {
    const std::uint64_t offset = brickOffset(level, index);
    const LevelEntry& e = levels_[level];
    const std::uint64_t end = index + 1 < e.brickCount ? brickOffsets_[e.firstBrick + index + 1]
                                                       : e.dataOffset + e.dataBytes;
    return end - offset;
}

std::vector<std::uint8_t> RvolReader::readStoredBrick(std::uint32_t level,
                                                      std::uint32_t index) const {
    const std::uint64_t offset = brickOffset(level, index);
    std::vector<std::uint8_t> bytes(storedBrickSize(level, index));
    readBytes(offset, bytes.data(), bytes.size());
    const BrickEntry& entry = directory_[levels_[level].firstBrick + index];
    if (crc32c(bytes.data(), bytes.size()) != entry.checksum)
        invalid(path_, "level " + str(level) + ", brick " + str(index) + " (" + str(entry.x) + "," +
                           str(entry.y) + "," + str(entry.z) + "), file offset " + str(offset) +
                           ": checksum mismatch");
    return bytes;
}

std::vector<std::uint8_t> RvolReader::readBrickBytes(std::uint32_t level,
                                                     std::uint32_t index) const {
    const std::vector<std::uint8_t> stored = readStoredBrick(level, index);
    const BrickEntry& entry = directory_[levels_[level].firstBrick + index];
    try {
        return expandBrick(stored, header_.brickTexels, levels_[level].channels,
                           header_.binaryLevel0Opacity(), entry.planes, entry.texels);
    } catch (const std::invalid_argument& e) {
        // Sizes come from the entry, so this is a mask that disagrees with it.
        invalid(path_, "level " + str(level) + ", brick " + str(index) + " (" + str(entry.x) + "," +
                           str(entry.y) + "," + str(entry.z) + "), file offset " +
                           str(brickOffset(level, index)) + ": " +
                           std::string(e.what()).substr(sizeof "expandBrick: " - 1));
    }
}

std::vector<Texel> RvolReader::readBrick(std::uint32_t level, std::uint32_t index) const {
    return decodeBrick(readBrickBytes(level, index), header_.brickTexels,
                       levels_.at(level).channels, header_.binaryLevel0Opacity());
}

void RvolReader::setCacheBytes(std::uint64_t bytes) const {
    const std::lock_guard lock(cache_->mutex);
    cache_->limitBytes = bytes;
    cache_->evict();
}

std::shared_ptr<const std::vector<Texel>> RvolReader::cachedBrick(std::uint32_t level,
                                                                  std::uint32_t index) const {
    const std::uint64_t key = std::uint64_t{level} << 32 | index;
    Cache& c = *cache_;
    {
        const std::lock_guard lock(c.mutex);
        if (const auto it = c.items.find(key); it != c.items.end()) {
            c.order.splice(c.order.begin(), c.order, it->second.position);
            return it->second.texels;
        }
    }
    // Decoded outside the lock; two threads may decode the same brick, and the first one kept wins.
    auto texels = std::make_shared<const std::vector<Texel>>(readBrick(level, index));
    const std::lock_guard lock(c.mutex);
    if (const auto it = c.items.find(key); it != c.items.end()) return it->second.texels;
    c.order.push_front(key);
    c.items.emplace(key, Cache::Item{texels, c.order.begin()});
    c.usedBytes += texels->size() * sizeof(Texel);
    c.evict();
    return texels;
}

Texel RvolReader::sample(std::uint32_t level, std::uint32_t channel,
                         const std::array<double, 3>& position) const {
    const LevelEntry& e = levels_.at(level);
    if (channel >= e.channels) throw std::out_of_range("RvolReader::sample: channel out of range");
    const std::uint32_t n = header_.brickTexels, step = n - 1;
    const double cellSize = header_.cellSize(level);
    std::array<std::uint32_t, 3> brick{}, i0{};
    std::array<double, 3> f{};
    for (int a = 0; a < 3; ++a) {
        // Texel centres sit at cell centres: continuous cell coordinate u, clamp-to-edge.
        double u = (position[a] - header_.origin[a]) / cellSize - 0.5;
        if (!(u > 0)) u = 0;  // NaN too
        u = std::min(u, static_cast<double>(e.resolution - 1));
        brick[a] = std::min(static_cast<std::uint32_t>(u / step), e.bricksPerAxis - 1);
        const double t = u - static_cast<double>(brick[a] * step);  // in [0, N − 1]
        i0[a] = std::min(static_cast<std::uint32_t>(t), n - 2);
        f[a] = t - i0[a];
    }
    const std::int64_t index = findBrick(level, brick[0], brick[1], brick[2]);
    if (index < 0) return {};
    const auto texels = cachedBrick(level, static_cast<std::uint32_t>(index));
    const std::size_t n3 = std::size_t{n} * n * n;
    const Texel* base = texels->data() + channel * n3;
    double sum[4] = {0, 0, 0, 0};
    for (std::uint32_t corner = 0; corner < 8; ++corner) {
        const std::uint32_t dx = corner & 1u, dy = (corner >> 1) & 1u, dz = (corner >> 2) & 1u;
        const double w = (dx ? f[0] : 1 - f[0]) * (dy ? f[1] : 1 - f[1]) * (dz ? f[2] : 1 - f[2]);
        if (w == 0) continue;
        const Texel& t = base[(std::size_t{i0[2] + dz} * n + (i0[1] + dy)) * n + (i0[0] + dx)];
        sum[0] += w * t.r, sum[1] += w * t.g, sum[2] += w * t.b, sum[3] += w * t.a;
    }
    return {static_cast<float>(sum[0]), static_cast<float>(sum[1]), static_cast<float>(sum[2]),
            static_cast<float>(sum[3])};
}

Texel RvolReader::sampleDirectional(std::uint32_t level, const std::array<double, 3>& position,
                                    const std::array<double, 3>& direction) const {
    if (level >= levels_.size())
        throw std::out_of_range("RvolReader::sampleDirectional: level out of range");
    if (level == 0) return sample(0, 0, position);
    const double length2 =
        direction[0] * direction[0] + direction[1] * direction[1] + direction[2] * direction[2];
    if (!(length2 > 0) || !std::isfinite(length2)) return {};
    std::array<Texel, 3> facing{};
    for (std::uint32_t a = 0; a < 3; ++a)
        // Channel 2a looks along +axis (PosX, PosY, PosZ), 2a + 1 along −axis.
        if (direction[a] != 0)
            facing[a] = sample(level, 2 * a + (direction[a] < 0 ? 1u : 0u), position);
    return combineDirectional(facing, direction);
}

std::vector<AttributeRecord> RvolReader::readAttributeRecords(bool dynamic) const {
    const std::uint64_t offset =
        dynamic ? header_.dynamicAttributesOffset : header_.staticAttributesOffset;
    const std::uint64_t bytes =
        dynamic ? header_.dynamicAttributesBytes : header_.staticAttributesBytes;
    std::vector<std::uint8_t> data(bytes);  // inside the file, checked by the constructor
    readBytes(offset, data.data(), data.size());
    if (crc32c(data.data(), data.size()) !=
        (dynamic ? header_.dynamicAttributesChecksum : header_.staticAttributesChecksum))
        invalid(path_, std::string(dynamic ? "dynamic" : "static") +
                           " attribute layer: checksum mismatch");
    std::vector<AttributeRecord> records(bytes / kAttributeRecordBytes);
    const std::uint8_t* p = data.data();
    for (AttributeRecord& r : records) {
        r.morton = load<std::uint32_t>(p);
        std::copy(p + 4, p + 8, r.albedoCoverage.begin());
        r.normalOcclusion = load<std::uint32_t>(p + 8);
        r.emission = load<std::uint32_t>(p + 12);
        p += kAttributeRecordBytes;
    }
    return records;
}

std::vector<VoxelAttributes> RvolReader::readAttributes(bool dynamic) const {
    const std::vector<AttributeRecord> records = readAttributeRecords(dynamic);
    std::vector<VoxelAttributes> voxels;
    voxels.reserve(records.size());
    for (const AttributeRecord& r : records) voxels.push_back(decodeAttributes(r));
    return voxels;
}

Volume RvolReader::readVolume() const {
    Volume v;
    v.origin = header_.origin;
    v.size = header_.size;
    v.depth = header_.depth;
    v.sceneBounds = header_.sceneBounds;
    v.bake = header_.bake;
    const std::uint32_t n = header_.brickTexels, step = n - 1;
    const std::size_t n3 = std::size_t{n} * n * n;
    for (std::uint32_t l = 0; l < levels_.size(); ++l) {
        const LevelEntry& e = levels_[l];
        Level level;
        level.resolution = e.resolution;
        level.channels = e.channels;
        // Calls @p visit(x, y, z, texels of the brick, texel index) for every texel of the level's
        // bricks that is inside the level and non-zero in some channel.
        const auto forEachNonZero = [&](const auto& visit) {
            for (std::uint32_t i = 0; i < e.brickCount; ++i) {
                const BrickEntry& b = directory_[e.firstBrick + i];
                const std::vector<Texel> texels = readBrick(l, i);
                for (std::uint32_t k = 0; k < n; ++k)
                    for (std::uint32_t j = 0; j < n; ++j)
                        for (std::uint32_t ii = 0; ii < n; ++ii) {
                            const std::uint32_t x = b.x * step + ii, y = b.y * step + j,
                                                z = b.z * step + k;
                            if (x >= e.resolution || y >= e.resolution || z >= e.resolution)
                                continue;
                            const std::size_t t = (std::size_t{k} * n + j) * n + ii;
                            bool nonZero = false;
                            for (std::uint32_t c = 0; c < e.channels; ++c)
                                nonZero = nonZero || texels[c * n3 + t] != Texel{};
                            if (nonZero) visit(x, y, z, texels, t);
                        }
            }
        };
        // Two passes (the blocks first, then their texels) so that only the level's own texels
        // are held in memory, not its decoded bricks as well.
        forEachNonZero([&](std::uint32_t x, std::uint32_t y, std::uint32_t z,
                           const std::vector<Texel>&, std::size_t) {
            const std::uint64_t code = morton3(x / kBlockCells, y / kBlockCells, z / kBlockCells);
            if (level.blocks.empty() || level.blocks.back() != code) level.blocks.push_back(code);
        });
        std::sort(level.blocks.begin(), level.blocks.end());
        level.blocks.erase(std::unique(level.blocks.begin(), level.blocks.end()),
                           level.blocks.end());
        level.texels.assign(level.blocks.size() * level.channels * kBlockTexels, Texel{});
        forEachNonZero([&](std::uint32_t x, std::uint32_t y, std::uint32_t z,
                           const std::vector<Texel>& texels, std::size_t t) {
            const auto block = static_cast<std::size_t>(level.findBlock(x, y, z));
            for (std::uint32_t c = 0; c < level.channels; ++c)
                level.texels[Level::texelIndex(block, level.channels, c, x, y, z)] =
                    texels[c * n3 + t];
        });
        v.levels.push_back(std::move(level));
    }
    v.staticVoxels = readAttributes(false);
    v.dynamicVoxels = readAttributes(true);
    return v;
}

}  // namespace vox::rvol
