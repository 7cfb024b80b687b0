#include <vox/runtime/gl_context.h>
#include <vox/formats/rvol_tiles.h>
#include <vox/runtime/rvol_gpu_volume.h>

#include <GL/glcorearb.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <string>

namespace vox::runtime {
namespace {

constexpr std::uint32_t kSlotBits = 10;  // per axis in a packed indirection entry
constexpr std::uint32_t kSlotAxisMax = 1u << kSlotBits;

/// The info SSBO's fixed part (std430: every member 16-byte aligned), then the level table
/// (final_gather_glsl.h's RvolInfo and LevelInfo).
struct InfoHeader {
    float originSize[4];          // origin xyz, size
    std::uint32_t geometry[4];    // depth, N, levels (depth + 1), tiles per axis
    std::uint32_t tileBlocks[4];  // first entry of tile slot 0's block, entries per block
    float rgbAtlasSize[4];        // texels per axis, w unused
    float alphaAtlasSize[4];
};
struct InfoLevel {
    std::uint32_t base, bricksPerAxis, resolution, planes, tileCells, fallback, coarser, level;
};
constexpr std::uint32_t kBinaryOpacityBit = 0x10000;  // InfoLevel::planes: binary level-0 opacity
constexpr std::uint32_t kNoLevel = 0xFFFFFFFFu;
constexpr std::uint32_t kNoTileSlot = 0xFFFFFFFFu;
/// Indirection entries 0 … 8: the zero brick, every plane at the zero slot (an absent tile's).
constexpr std::uint64_t kZeroBrickEntries = 9;

/// A brick's first entry within its level's part of the indirection (bricks x fastest, then y, z).
std::uint64_t entryInLevel(const rvol::RvolReader& file, std::uint32_t level, std::uint32_t index) {
    const rvol::BrickEntry& e = file.bricks(level)[index];
    const std::uint64_t k = file.level(level).bricksPerAxis;
    return ((e.z * k + e.y) * k + e.x) * RvolGpuVolume::planesPerBrick(level);
}

/// A grid of slots holding @p slots with each axis ≤ @p maxPerAxis, as cubic as it goes.
std::array<std::uint32_t, 3> slotGrid(std::uint32_t slots, std::uint32_t maxPerAxis) {
    const auto x = std::clamp<std::uint32_t>(
        static_cast<std::uint32_t>(std::ceil(std::cbrt(double(slots)))), 1, maxPerAxis);
    const auto y = std::clamp<std::uint32_t>(
        static_cast<std::uint32_t>(std::ceil(std::sqrt(double(slots) / x))), 1, maxPerAxis);
    const std::uint32_t z = std::max<std::uint32_t>(1, (slots + x * y - 1) / (x * y));
    return {x, y, z};
}

}  // namespace

std::optional<std::uint32_t> AtlasSlotAllocator::allocate() {
    if (!free_.empty()) {
        const std::uint32_t slot = free_.back();
        free_.pop_back();
        return slot;
    }
    if (next_ >= capacity_) return std::nullopt;
    return next_++;
}

void AtlasSlotAllocator::release(std::uint32_t slot) {
    if (slot != 0 && slot < next_) free_.push_back(slot);
}

RvolGpuVolume::RvolGpuVolume(GlContext& context, const rvol::RvolReader& reader,
                             const RvolGpuVolumeOptions& options)
    : context_(context), reader_(reader) {
    build(options);
}

RvolGpuVolume::RvolGpuVolume(GlContext& context, const rvol::TiledRvolReader& reader,
                             const RvolGpuVolumeOptions& options)
    : context_(context), reader_(reader.farField()), tiled_(&reader) {
    if (!options.uploadAll && options.atlasBytes == 0)
        throw RuntimeError(
            reader.path().string() +
            ": a tiled volume streamed needs atlasBytes (its tiles are not counted)");
    build(options);
}

void RvolGpuVolume::build(const RvolGpuVolumeOptions& options) {
    const rvol::Header& header = reader_.header();
    n_ = header.brickTexels;
    binaryLevel0_ = header.binaryLevel0Opacity();
    alpha16_ = options.alpha16;
    const auto& levels = reader_.levels();
    depth_ = header.depth;
    const std::string name = (tiled_ ? tiled_->path() : reader_.path()).string();
    if (tiled_) {
        const rvol::TileIndex& index = tiled_->index();
        depth_ = index.depth;
        baseLevelOffset_ = index.depth - index.farDepth;
        tiles_.resize(index.tiles.size());
    }

    // Slots: one per stored plane of every brick (RGB: one at level 0, up to six above; A8: one at
    // level 0 without binary opacity, up to three above). Planes the file leaves out are all zero
    // and take the zero slot.
    std::uint64_t rgbNeeded = 1, alphaNeeded = 1;  // + the zero slot
    const auto countPlanes = [&](const rvol::RvolReader& file) {
        for (std::uint32_t l = 0; l < file.levels().size(); ++l) {
            const std::uint32_t channels = rvol::levelChannels(l);
            for (const rvol::BrickEntry& e : file.bricks(l)) {
                const std::uint32_t planes = e.planes;
                rgbNeeded +=
                    static_cast<std::uint32_t>(std::popcount(planes & ((1u << channels) - 1)));
                alphaNeeded += static_cast<std::uint32_t>(std::popcount(planes >> channels));
            }
        }
    };
    countPlanes(reader_);
    if (tiled_ && options.uploadAll)
        for (std::size_t t = 0; t < tiles_.size(); ++t) countPlanes(*tiled_->tile(t));

    // The indirection: the zero brick (every absent tile's), the base file's levels, then the
    // tile slots' blocks.
    std::uint64_t entries = kZeroBrickEntries;
    levelBase_.resize(levels.size());
    residentFlags_.resize(levels.size());
    for (std::uint32_t l = 0; l < levels.size(); ++l) {
        levelBase_[l] = entries;
        const std::uint64_t k = levels[l].bricksPerAxis;
        entries += k * k * k * planesPerBrick(l);
        residentFlags_[l].assign(levels[l].brickCount, 0);
    }
    tileBlocksBase_ = entries;
    GLint maxBlock = 0;
    glGetIntegerv(GL_MAX_SHADER_STORAGE_BLOCK_SIZE, &maxBlock);
    const std::uint64_t maxEntries = static_cast<std::uint64_t>(maxBlock) / 4;
    if (tiled_) {
        const rvol::TileIndex& index = tiled_->index();
        for (std::uint32_t l = 0; l <= index.tileDepth; ++l) {
            tileLevelBase_.push_back(tileBlockEntries_);
            const std::uint64_t k = rvol::bricksPerAxis(1u << (index.tileDepth - l), n_);
            tileBlockEntries_ += k * k * k * planesPerBrick(l);
        }
        std::uint64_t slots = options.tileSlots;
        if (options.uploadAll) {
            slots = tiles_.size();
        } else if (slots == 0) {
            slots = std::max<std::uint64_t>(1, options.atlasBytes / 4 / (tileBlockEntries_ * 4));
        }
        slots = std::min<std::uint64_t>(slots, tiles_.size());
        const std::uint64_t room = maxEntries > entries ? (maxEntries - entries) : 0;
        if (slots > room / tileBlockEntries_) {
            if (options.uploadAll || room < tileBlockEntries_)
                throw RuntimeError(name + ": " + std::to_string(slots) + " tile blocks of " +
                                   std::to_string(tileBlockEntries_ * 4) +
                                   " bytes do not fit GL_MAX_SHADER_STORAGE_BLOCK_SIZE (" +
                                   std::to_string(maxBlock) + ")");
            slots = room / tileBlockEntries_;
        }
        tileSlotCount_ = static_cast<std::uint32_t>(slots);
        for (std::uint32_t s = tileSlotCount_; s-- > 0;) freeTileSlots_.push_back(s);
        entries += slots * tileBlockEntries_;
        const std::uint64_t perAxis = 1ull << (index.depth - index.tileDepth);
        if (perAxis * perAxis * perAxis > maxEntries)
            throw RuntimeError(name + ": the tile table of " + std::to_string(perAxis) +
                               "³ tiles does not fit GL_MAX_SHADER_STORAGE_BLOCK_SIZE");
        tileTable_.assign(perAxis * perAxis * perAxis, kAbsentTile);
        for (std::uint32_t t = 0; t < tiles_.size(); ++t)
            tileTable_[tileTableIndex(t)] = kMissingTile;
    } else {
        tileTable_.assign(1, kAbsentTile);  // never read: no level is tiled
    }
    if (!options.uploadAll && options.atlasBytes > 0) {
        // Sized for the budget: 6 RGB slots (4 bytes a texel) to 3 opacity slots a brick.
        const std::uint64_t slot = std::uint64_t{n_} * n_ * n_;
        const std::uint64_t perBrick = 6 * 4 * slot + 3 * (alpha16_ ? 2 : 1) * slot;
        const std::uint64_t bricks = options.atlasBytes / perBrick + 1;
        rgbNeeded =
            tiled_ ? 1 + 6 * bricks + 8 : std::min<std::uint64_t>(rgbNeeded, 1 + 6 * bricks + 8);
        alphaNeeded =
            tiled_ ? 1 + 3 * bricks + 8 : std::min<std::uint64_t>(alphaNeeded, 1 + 3 * bricks + 8);
    }
    rgbNeeded += options.extraRgbSlots;
    alphaNeeded += options.extraAlphaSlots;
    if (entries > std::min<std::uint64_t>(maxEntries, 1ull << 30))
        throw RuntimeError(name + ": the indirection table would hold " + std::to_string(entries) +
                           " entries, more than GL_MAX_SHADER_STORAGE_BLOCK_SIZE allows");
    indirection_.assign(entries, 0);
    if (!options.uploadAll)  // every brick the file has is missing until uploaded
        for (std::uint32_t l = 0; l < levels.size(); ++l)
            for (std::uint32_t i = 0; i < levels[l].brickCount; ++i)
                std::fill_n(indirection_.begin() +
                                static_cast<std::ptrdiff_t>(entryOffset({kBaseFile, l, i})),
                            planesPerBrick(l), kMissingBrick);

    GLint max3d = 0;
    glGetIntegerv(GL_MAX_3D_TEXTURE_SIZE, &max3d);
    const std::uint32_t perAxis =
        std::min<std::uint32_t>(kSlotAxisMax, static_cast<std::uint32_t>(max3d) / n_);
    const std::uint64_t maxSlots = std::uint64_t{perAxis} * perAxis * perAxis;
    if (rgbNeeded > maxSlots || alphaNeeded > maxSlots)
        throw RuntimeError(name + ": the radiance atlas needs " +
                           std::to_string(std::max(rgbNeeded, alphaNeeded)) + " slots of " +
                           std::to_string(n_) + "³ texels, more than this GL's 3D textures hold (" +
                           std::to_string(maxSlots) + ", GL_MAX_3D_TEXTURE_SIZE " +
                           std::to_string(max3d) + ")");
    rgbGrid_ = slotGrid(static_cast<std::uint32_t>(rgbNeeded), perAxis);
    alphaGrid_ = slotGrid(static_cast<std::uint32_t>(alphaNeeded), perAxis);
    rgbSlots_ = AtlasSlotAllocator(rgbGrid_[0] * rgbGrid_[1] * rgbGrid_[2]);
    alphaSlots_ = AtlasSlotAllocator(alphaGrid_[0] * alphaGrid_[1] * alphaGrid_[2]);
    createAtlas(rgbAtlas_, rgbGrid_, true);
    createAtlas(alphaAtlas_, alphaGrid_, false);

    // The R32UI view of the RGB atlas: the words themselves, for binary level-0 opacity.
    glGenTextures(1, &wordView_);
    glTextureView(wordView_, GL_TEXTURE_3D, rgbAtlas_, GL_R32UI, 0, 1, 0, 1);
    glTextureParameteri(wordView_, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTextureParameteri(wordView_, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    static constexpr char kViewLabel[] = "rvol atlas words (R32UI view)";
    glObjectLabel(GL_TEXTURE, wordView_, sizeof kViewLabel - 1, kViewLabel);

    writeInfo();
    const auto createBuffer = [](unsigned& buffer, const std::vector<std::uint32_t>& words,
                                 const char* label) {
        glCreateBuffers(1, &buffer);
        glNamedBufferStorage(buffer, static_cast<GLsizeiptr>(words.size() * 4), words.data(),
                             GL_DYNAMIC_STORAGE_BIT);
        glObjectLabel(GL_BUFFER, buffer, static_cast<GLsizei>(std::strlen(label)), label);
    };
    createBuffer(indirectionBuffer_, indirection_, "rvol indirection");
    createBuffer(tileTableBuffer_, tileTable_, "rvol tile table");
    context_.throwOnErrors(name + ": allocating the radiance atlas");

    if (options.uploadAll) {
        const auto uploadFile = [&](std::uint32_t file) {
            const std::shared_ptr<const rvol::RvolReader> r = fileReader(file);
            for (std::uint32_t l = 0; l < r->levels().size(); ++l)
                for (std::uint32_t i = 0; i < r->level(l).brickCount; ++i)
                    if (!uploadBrick({file, l, i}))
                        throw RuntimeError(name + ": radiance atlas full");  // sized above
        };
        uploadFile(kBaseFile);
        for (std::uint32_t t = 0; t < tiles_.size(); ++t) uploadFile(t);
    }
}

void RvolGpuVolume::writeInfo() {
    // The level table: the volume's levels 0 … depth, then (tiled) the far field's levels the
    // tiles also cover, which missing tiles fall back to.
    std::vector<InfoLevel> table;
    const auto& levels = reader_.levels();
    const auto baseEntry = [&](std::uint32_t level, std::uint32_t fileLevel) {
        const bool isotropic = fileLevel == 0;
        return InfoLevel{
            static_cast<std::uint32_t>(levelBase_[fileLevel]),
            levels[fileLevel].bricksPerAxis,
            1u << (depth_ - level),
            planesPerBrick(fileLevel) | (isotropic && binaryLevel0_ ? kBinaryOpacityBit : 0u),
            0,
            level < depth_ ? level + 1 : kNoLevel,
            level < depth_ ? level + 1 : kNoLevel,
            level};
    };
    if (!tiled_) {
        for (std::uint32_t l = 0; l <= depth_; ++l) table.push_back(baseEntry(l, l));
    } else {
        const std::uint32_t tileDepth = tiled_->index().tileDepth;
        // Entry of the far field's level at volume level l ≤ tileDepth (appended after depth).
        const auto farEntry = [&](std::uint32_t l) {
            return l > tileDepth ? l : depth_ + 1 + (l - baseLevelOffset_);
        };
        for (std::uint32_t l = 0; l <= depth_; ++l) {
            if (l > tileDepth) {
                table.push_back(baseEntry(l, l - baseLevelOffset_));
                continue;
            }
            const std::uint32_t cells = 1u << (tileDepth - l);
            table.push_back({static_cast<std::uint32_t>(tileLevelBase_[l]),
                             rvol::bricksPerAxis(cells, n_), 1u << (depth_ - l),
                             planesPerBrick(l) | (l == 0 && binaryLevel0_ ? kBinaryOpacityBit : 0u),
                             cells, farEntry(std::max(l, baseLevelOffset_)), l + 1, l});
        }
        for (std::uint32_t l = baseLevelOffset_; l <= tileDepth; ++l) {
            InfoLevel e = baseEntry(l, l - baseLevelOffset_);
            e.fallback = e.coarser = farEntry(l + 1);
            table.push_back(e);
        }
    }

    std::vector<std::uint8_t> info(sizeof(InfoHeader) + table.size() * sizeof(InfoLevel));
    InfoHeader h{};
    const std::array<double, 3> origin = tiled_ ? tiled_->index().origin : reader_.header().origin;
    const double size = tiled_ ? tiled_->index().size : reader_.header().size;
    for (std::size_t a = 0; a < 3; ++a) h.originSize[a] = static_cast<float>(origin[a]);
    h.originSize[3] = static_cast<float>(size);
    h.geometry[0] = depth_;
    h.geometry[1] = n_;
    h.geometry[2] = depth_ + 1;
    h.geometry[3] = tiled_ ? 1u << (depth_ - tiled_->index().tileDepth) : 1u;
    h.tileBlocks[0] = static_cast<std::uint32_t>(tileBlocksBase_);
    h.tileBlocks[1] = static_cast<std::uint32_t>(tileBlockEntries_);
    for (std::size_t a = 0; a < 3; ++a) {
        h.rgbAtlasSize[a] = static_cast<float>(rgbGrid_[a] * n_);
        h.alphaAtlasSize[a] = static_cast<float>(alphaGrid_[a] * n_);
    }
    std::memcpy(info.data(), &h, sizeof h);
    std::memcpy(info.data() + sizeof h, table.data(), table.size() * sizeof(InfoLevel));
    glCreateBuffers(1, &infoBuffer_);
    glNamedBufferStorage(infoBuffer_, static_cast<GLsizeiptr>(info.size()), info.data(), 0);
    infoBytes_ = info.size();
    static constexpr char kInfoLabel[] = "rvol info";
    glObjectLabel(GL_BUFFER, infoBuffer_, sizeof kInfoLabel - 1, kInfoLabel);
}

RvolGpuVolume::~RvolGpuVolume() {
    const GLuint textures[3] = {wordView_, rgbAtlas_, alphaAtlas_};
    glDeleteTextures(3, textures);
    const GLuint buffers[3] = {infoBuffer_, indirectionBuffer_, tileTableBuffer_};
    glDeleteBuffers(3, buffers);
}

void RvolGpuVolume::createAtlas(unsigned& texture, const std::array<std::uint32_t, 3>& grid,
                                bool rgb) {
    glCreateTextures(GL_TEXTURE_3D, 1, &texture);
    const auto w = static_cast<GLsizei>(grid[0] * n_), h = static_cast<GLsizei>(grid[1] * n_),
               d = static_cast<GLsizei>(grid[2] * n_);
    glTextureStorage3D(texture, 1, rgb ? GL_RGB9_E5 : alpha16_ ? GL_R16 : GL_R8, w, h, d);
    glTextureParameteri(texture, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTextureParameteri(texture, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTextureParameteri(texture, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTextureParameteri(texture, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    glTextureParameteri(texture, GL_TEXTURE_WRAP_R, GL_CLAMP_TO_EDGE);
    // Immutable storage starts undefined: zero it, which makes slot 0 the all-zero slot.
    if (rgb) {
        glClearTexImage(texture, 0, GL_RGB, GL_UNSIGNED_INT_5_9_9_9_REV, nullptr);
    } else {
        glClearTexImage(texture, 0, GL_RED, alpha16_ ? GL_UNSIGNED_SHORT : GL_UNSIGNED_BYTE,
                        nullptr);
    }
    const char* label = rgb        ? "rvol RGB9_E5 atlas"
                        : alpha16_ ? "rvol R16 opacity atlas"
                                   : "rvol R8 opacity atlas";
    glObjectLabel(GL_TEXTURE, texture, static_cast<GLsizei>(std::strlen(label)), label);
}

std::array<std::uint32_t, 3> RvolGpuVolume::slotOrigin(const std::array<std::uint32_t, 3>& grid,
                                                       std::uint32_t slot) const noexcept {
    return {slot % grid[0], (slot / grid[0]) % grid[1], slot / (grid[0] * grid[1])};
}

std::shared_ptr<const rvol::RvolReader> RvolGpuVolume::fileReader(std::uint32_t file) const {
    // The single file or far field lives as long as the volume: a pointer that owns nothing.
    if (file == kBaseFile) return {std::shared_ptr<const rvol::RvolReader>{}, &reader_};
    return tiled_->tile(file);
}

std::filesystem::path RvolGpuVolume::fileName(std::uint32_t file) const {
    return file == kBaseFile ? reader_.path() : tiled_->tileFile(file);
}

double RvolGpuVolume::finestCellSize() const noexcept {
    return tiled_ ? tiled_->index().cellSize() : reader_.header().cellSize(0);
}

std::uint64_t RvolGpuVolume::tileTableIndex(std::uint32_t tile) const {
    const rvol::TileEntry& t = tiled_->index().tiles.at(tile);
    const std::uint64_t n = 1ull << (depth_ - tiled_->index().tileDepth);
    return (t.z * n + t.y) * n + t.x;
}

bool RvolGpuVolume::tileResident(std::uint32_t tile) const {
    return tiles_.at(tile).slot != kNoTileSlot;
}

std::uint64_t RvolGpuVolume::entryOffset(const RvolBrickRef& brick) const {
    if (brick.file == kBaseFile)
        return levelBase_[brick.level] + entryInLevel(reader_, brick.level, brick.index);
    const TileState& t = tiles_[brick.file];
    return tileBlocksBase_ + std::uint64_t{t.slot} * tileBlockEntries_ +
           t.bricks[brick.level][brick.index].entry;
}

bool RvolGpuVolume::resident(const RvolBrickRef& brick) const {
    if (brick.file == kBaseFile) return residentFlags_.at(brick.level).at(brick.index) != 0;
    const TileState& t = tiles_.at(brick.file);
    return t.slot != kNoTileSlot && t.bricks.at(brick.level).at(brick.index).resident;
}

void RvolGpuVolume::uploadWords(unsigned buffer, const std::vector<std::uint32_t>& words,
                                std::uint64_t first, std::uint64_t count) {
    glNamedBufferSubData(buffer, static_cast<GLintptr>(first * 4),
                         static_cast<GLsizeiptr>(count * 4), words.data() + first);
}

bool RvolGpuVolume::takeTileSlot(std::uint32_t tile) {
    if (freeTileSlots_.empty()) return false;
    const std::shared_ptr<const rvol::RvolReader> file = tiled_->tile(tile);  // opened, checked
    // Every tile shares one level table, so one level-0 layout: the far field's, as one bake
    // writes them all.
    if (file->header().binaryLevel0Opacity() != binaryLevel0_)
        throw InvalidDataError(file->path(), "level-0 opacity layout differs from the far field's");
    TileState& t = tiles_[tile];
    t.slot = freeTileSlots_.back();
    freeTileSlots_.pop_back();
    // What the bricks' entries and sizes need from the directory, so that evicting them, or
    // counting their bytes, does not open the file again.
    t.bricks.assign(file->levels().size(), {});
    for (std::uint32_t l = 0; l < file->levels().size(); ++l) {
        const std::span<const rvol::BrickEntry> entries = file->bricks(l);
        t.bricks[l].resize(entries.size());
        for (std::uint32_t i = 0; i < entries.size(); ++i)
            t.bricks[l][i] = {
                static_cast<std::uint32_t>(tileLevelBase_[l] + entryInLevel(*file, l, i)),
                entries[i].planes, false};
    }
    // The block: every brick the tile has missing, the others the zero slot (empty).
    const std::uint64_t block = tileBlocksBase_ + std::uint64_t{t.slot} * tileBlockEntries_;
    std::fill_n(indirection_.begin() + static_cast<std::ptrdiff_t>(block), tileBlockEntries_, 0u);
    for (std::uint32_t l = 0; l < t.bricks.size(); ++l)
        for (std::uint32_t i = 0; i < t.bricks[l].size(); ++i)
            std::fill_n(
                indirection_.begin() + static_cast<std::ptrdiff_t>(entryOffset({tile, l, i})),
                planesPerBrick(l), kMissingBrick);
    uploadWords(indirectionBuffer_, indirection_, block, tileBlockEntries_);
    const std::uint64_t at = tileTableIndex(tile);
    tileTable_[at] = t.slot;
    uploadWords(tileTableBuffer_, tileTable_, at, 1);
    return true;
}

void RvolGpuVolume::releaseTileSlot(std::uint32_t tile) {
    TileState& t = tiles_[tile];
    freeTileSlots_.push_back(t.slot);
    t = TileState{};
    const std::uint64_t at = tileTableIndex(tile);
    tileTable_[at] = kMissingTile;
    uploadWords(tileTableBuffer_, tileTable_, at, 1);
}

bool RvolGpuVolume::uploadBrick(const RvolBrickRef& brick) {
    if (resident(brick)) return true;
    const bool tile = brick.file != kBaseFile;
    if (tile && !tileResident(brick.file) && !takeTileSlot(brick.file)) return false;
    const std::shared_ptr<const rvol::RvolReader> file = fileReader(brick.file);
    const std::uint32_t level = brick.level;
    const std::uint32_t channels = rvol::levelChannels(level);
    const std::uint32_t alphaPlanes = rvol::alphaPlanes(channels, level == 0 && binaryLevel0_);
    const std::uint32_t stored = file->bricks(level)[brick.index].planes;
    // Per plane its slot; 0 (the zero slot) for a plane the file leaves out (all zero).
    std::vector<std::uint32_t> rgb(channels, 0), alpha(alphaPlanes, 0);
    const auto giveBack = [&] {
        for (std::uint32_t s : rgb) rgbSlots_.release(s);
        for (std::uint32_t s : alpha) alphaSlots_.release(s);
        if (tile && tiles_[brick.file].residentBricks == 0) releaseTileSlot(brick.file);
        return false;
    };
    for (std::uint32_t c = 0; c < channels; ++c) {
        if ((stored & 1u << c) == 0) continue;
        const auto s = rgbSlots_.allocate();
        if (!s) return giveBack();
        rgb[c] = *s;
    }
    for (std::uint32_t p = 0; p < alphaPlanes; ++p) {
        if ((stored & 1u << (channels + p)) == 0) continue;
        const auto s = alphaSlots_.allocate();
        if (!s) return giveBack();
        alpha[p] = *s;
    }
    const std::vector<std::uint8_t> bytes = file->readBrickBytes(level, brick.index);
    const auto n = static_cast<GLsizei>(n_);
    const std::uint64_t entry = entryOffset(brick);
    const auto pack = [](const std::array<std::uint32_t, 3>& o) {
        return o[0] | (o[1] << kSlotBits) | (o[2] << (2 * kSlotBits));
    };
    GLint alignment = 4;
    glGetIntegerv(GL_UNPACK_ALIGNMENT, &alignment);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);  // A8 rows of odd N are not 4-byte multiples
    for (std::uint32_t c = 0; c < channels; ++c) {
        const auto o = slotOrigin(rgbGrid_, rgb[c]);
        indirection_[entry + c] = pack(o);
        if (rgb[c] == 0) continue;
        glTextureSubImage3D(rgbAtlas_, 0, static_cast<GLint>(o[0] * n_),
                            static_cast<GLint>(o[1] * n_), static_cast<GLint>(o[2] * n_), n, n, n,
                            GL_RGB, GL_UNSIGNED_INT_5_9_9_9_REV,
                            bytes.data() + rvol::rgbPlaneOffset(n_, c));
    }
    std::vector<std::uint16_t> wide(alpha16_ ? std::size_t{n_} * n_ * n_ : 0);
    for (std::uint32_t p = 0; p < alphaPlanes; ++p) {
        const auto o = slotOrigin(alphaGrid_, alpha[p]);
        indirection_[entry + channels + p] = pack(o);
        if (alpha[p] == 0) continue;
        const std::uint8_t* plane = bytes.data() + rvol::alphaPlaneOffset(n_, channels, p);
        for (std::size_t t = 0; t < wide.size(); ++t)
            wide[t] = static_cast<std::uint16_t>(plane[t] * 257u);  // k/255 = 257k/65535
        glTextureSubImage3D(
            alphaAtlas_, 0, static_cast<GLint>(o[0] * n_), static_cast<GLint>(o[1] * n_),
            static_cast<GLint>(o[2] * n_), n, n, n, GL_RED,
            alpha16_ ? GL_UNSIGNED_SHORT : GL_UNSIGNED_BYTE,
            alpha16_ ? static_cast<const void*>(wide.data()) : static_cast<const void*>(plane));
    }
    glPixelStorei(GL_UNPACK_ALIGNMENT, alignment);
    uploadWords(indirectionBuffer_, indirection_, entry, planesPerBrick(level));
    if (tile) {
        tiles_[brick.file].bricks[level][brick.index].resident = true;
        ++tiles_[brick.file].residentBricks;
    } else {
        residentFlags_[level][brick.index] = 1;
    }
    ++residentBricks_;
    uploadedTotal_ += bytes.size();
    context_.throwOnErrors(file->path().string() + ": uploading level " + std::to_string(level) +
                           " brick " + std::to_string(brick.index));
    return true;
}

void RvolGpuVolume::evictBrick(const RvolBrickRef& brick) {
    if (!resident(brick)) return;
    const std::uint32_t level = brick.level;
    const std::uint32_t channels = rvol::levelChannels(level);
    const std::uint32_t alphaPlanes = rvol::alphaPlanes(channels, level == 0 && binaryLevel0_);
    const std::uint64_t entry = entryOffset(brick);
    const auto unpack = [](std::uint32_t e, const std::array<std::uint32_t, 3>& grid) {
        const std::uint32_t m = kSlotAxisMax - 1;
        return (e & m) +
               grid[0] * (((e >> kSlotBits) & m) + grid[1] * ((e >> (2 * kSlotBits)) & m));
    };
    // release() ignores slot 0, the zero slot of planes the file leaves out.
    for (std::uint32_t c = 0; c < channels; ++c)
        rgbSlots_.release(unpack(indirection_[entry + c], rgbGrid_));
    for (std::uint32_t p = 0; p < alphaPlanes; ++p)
        alphaSlots_.release(unpack(indirection_[entry + channels + p], alphaGrid_));
    const std::uint32_t planes = planesPerBrick(level);
    std::fill_n(indirection_.begin() + static_cast<std::ptrdiff_t>(entry), planes, kMissingBrick);
    uploadWords(indirectionBuffer_, indirection_, entry, planes);
    --residentBricks_;
    if (brick.file == kBaseFile) {
        residentFlags_[level][brick.index] = 0;
    } else {
        TileState& t = tiles_[brick.file];
        t.bricks[level][brick.index].resident = false;
        if (--t.residentBricks == 0) releaseTileSlot(brick.file);
    }
    context_.throwOnErrors(fileName(brick.file).string() + ": evicting level " +
                           std::to_string(level) + " brick " + std::to_string(brick.index));
}

void RvolGpuVolume::bind(const RvolGpuBindings& bindings) const {
    glBindTextureUnit(bindings.rgbAtlasUnit, rgbAtlas_);
    glBindTextureUnit(bindings.wordAtlasUnit, wordView_);
    glBindTextureUnit(bindings.alphaAtlasUnit, alphaAtlas_);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, bindings.infoBinding, infoBuffer_);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, bindings.indirectionBinding, indirectionBuffer_);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, bindings.tileTableBinding, tileTableBuffer_);
}

std::uint64_t RvolGpuVolume::brickBytes(const RvolBrickRef& brick) const {
    if (brick.file == kBaseFile)
        return planeBytes(brick.level, reader_.bricks(brick.level)[brick.index].planes);
    if (tileResident(brick.file))
        return planeBytes(brick.level,
                          tiles_[brick.file].bricks.at(brick.level).at(brick.index).planes);
    return planeBytes(brick.level, fileReader(brick.file)->bricks(brick.level)[brick.index].planes);
}

std::array<std::uint32_t, 2> RvolGpuVolume::planeSlots(std::uint32_t level,
                                                       std::uint32_t planes) noexcept {
    const std::uint32_t channels = rvol::levelChannels(level);
    return {static_cast<std::uint32_t>(std::popcount(planes & ((1u << channels) - 1))),
            static_cast<std::uint32_t>(std::popcount(planes >> channels))};
}

std::uint64_t RvolGpuVolume::planeBytes(std::uint32_t level, std::uint32_t planes) const noexcept {
    const std::uint64_t slot = std::uint64_t{n_} * n_ * n_;
    const auto [rgb, alpha] = planeSlots(level, planes);
    return rgb * 4 * slot + alpha * alphaTexelBytes() * slot;
}

std::uint64_t RvolGpuVolume::residentBytes() const noexcept {
    const std::uint64_t slot = std::uint64_t{n_} * n_ * n_;
    return 4 * slot * rgbSlots_.capacity() + alphaTexelBytes() * slot * alphaSlots_.capacity() +
           indirection_.size() * 4 + tileTable_.size() * 4 + infoBytes_;
}

std::uint64_t RvolGpuVolume::usedAtlasBytes() const noexcept {
    const std::uint64_t slot = std::uint64_t{n_} * n_ * n_;
    return 4 * slot * rgbSlots_.used() + alphaTexelBytes() * slot * alphaSlots_.used();
}

}  // namespace vox::runtime
