#include <vox/runtime/gl_context.h>
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

/// The info SSBO's fixed part (std430: every member 16-byte aligned), then the level table.
struct InfoHeader {
    float originSize[4];        // origin xyz, size
    std::uint32_t geometry[4];  // depth, N, levelCount, flags (bit 0: binary level-0 opacity)
    float rgbAtlasSize[4];      // texels per axis, w unused
    float alphaAtlasSize[4];
};
struct InfoLevel {
    std::uint32_t base, bricksPerAxis, resolution, planes;
};

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
    const rvol::Header& header = reader.header();
    n_ = header.brickTexels;
    binaryLevel0_ = header.binaryLevel0Opacity();
    alpha16_ = options.alpha16;
    const auto& levels = reader.levels();

    // Slots: one per stored plane of every brick (RGB: one at level 0, up to six above; A8: one at
    // level 0 without binary opacity, up to three above). Planes the file leaves out are all zero
    // and take the zero slot.
    std::uint64_t rgbNeeded = 1, alphaNeeded = 1;  // + the zero slot
    levelBase_.resize(levels.size());
    residentFlags_.resize(levels.size());
    std::uint64_t entries = 0;
    for (std::uint32_t l = 0; l < levels.size(); ++l) {
        const std::uint64_t bricks = levels[l].brickCount;
        const std::uint32_t channels = rvol::levelChannels(l);
        for (const rvol::BrickEntry& e : reader.bricks(l)) {
            const std::uint32_t planes = e.planes;
            rgbNeeded += static_cast<std::uint32_t>(std::popcount(planes & ((1u << channels) - 1)));
            alphaNeeded += static_cast<std::uint32_t>(std::popcount(planes >> channels));
        }
        levelBase_[l] = entries;
        const std::uint64_t k = levels[l].bricksPerAxis;
        entries += k * k * k * planesPerBrick(l);
        residentFlags_[l].assign(bricks, 0);
    }
    if (!options.uploadAll && options.atlasBytes > 0) {
        // Sized for the budget: 6 RGB slots (4 bytes a texel) to 3 opacity slots a brick.
        const std::uint64_t slot = std::uint64_t{n_} * n_ * n_;
        const std::uint64_t perBrick = 6 * 4 * slot + 3 * (alpha16_ ? 2 : 1) * slot;
        const std::uint64_t bricks = options.atlasBytes / perBrick + 1;
        rgbNeeded = std::min<std::uint64_t>(rgbNeeded, 1 + 6 * bricks + 8);
        alphaNeeded = std::min<std::uint64_t>(alphaNeeded, 1 + 3 * bricks + 8);
    }
    rgbNeeded += options.extraRgbSlots;
    alphaNeeded += options.extraAlphaSlots;
    if (entries > (1ull << 30))
        throw RuntimeError(reader.path().string() + ": the indirection table would hold " +
                           std::to_string(entries) + " entries");
    indirection_.assign(entries, 0);
    if (!options.uploadAll)  // every brick the file has is missing until uploaded
        for (std::uint32_t l = 0; l < levels.size(); ++l)
            for (std::uint32_t i = 0; i < levels[l].brickCount; ++i) {
                const std::uint64_t k = levels[l].bricksPerAxis;
                const rvol::BrickEntry& e = reader.bricks(l)[i];
                const std::uint64_t entry =
                    levelBase_[l] + ((e.z * k + e.y) * k + e.x) * planesPerBrick(l);
                std::fill_n(indirection_.begin() + static_cast<std::ptrdiff_t>(entry),
                            planesPerBrick(l), kMissingBrick);
            }

    GLint max3d = 0;
    glGetIntegerv(GL_MAX_3D_TEXTURE_SIZE, &max3d);
    const std::uint32_t perAxis =
        std::min<std::uint32_t>(kSlotAxisMax, static_cast<std::uint32_t>(max3d) / n_);
    const std::uint64_t maxSlots = std::uint64_t{perAxis} * perAxis * perAxis;
    if (rgbNeeded > maxSlots || alphaNeeded > maxSlots)
        throw RuntimeError(reader.path().string() + ": the radiance atlas needs " +
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

    // Info SSBO.
    std::vector<std::uint8_t> info(sizeof(InfoHeader) + levels.size() * sizeof(InfoLevel));
    InfoHeader h{};
    h.originSize[0] = static_cast<float>(header.origin[0]);
    h.originSize[1] = static_cast<float>(header.origin[1]);
    h.originSize[2] = static_cast<float>(header.origin[2]);
    h.originSize[3] = static_cast<float>(header.size);
    h.geometry[0] = header.depth;
    h.geometry[1] = n_;
    h.geometry[2] = header.levelCount;
    h.geometry[3] = binaryLevel0_ ? 1u : 0u;
    for (int a = 0; a < 3; ++a) {
        h.rgbAtlasSize[a] = static_cast<float>(rgbGrid_[static_cast<std::size_t>(a)] * n_);
        h.alphaAtlasSize[a] = static_cast<float>(alphaGrid_[static_cast<std::size_t>(a)] * n_);
    }
    std::memcpy(info.data(), &h, sizeof h);
    for (std::uint32_t l = 0; l < levels.size(); ++l) {
        const InfoLevel entry{static_cast<std::uint32_t>(levelBase_[l]), levels[l].bricksPerAxis,
                              levels[l].resolution, planesPerBrick(l)};
        std::memcpy(info.data() + sizeof h + l * sizeof entry, &entry, sizeof entry);
    }
    glCreateBuffers(1, &infoBuffer_);
    glNamedBufferStorage(infoBuffer_, static_cast<GLsizeiptr>(info.size()), info.data(), 0);
    infoBytes_ = info.size();
    glCreateBuffers(1, &indirectionBuffer_);
    glNamedBufferStorage(indirectionBuffer_,
                         static_cast<GLsizeiptr>(std::max<std::size_t>(4, indirection_.size() * 4)),
                         nullptr, GL_DYNAMIC_STORAGE_BIT);
    if (!indirection_.empty())
        glNamedBufferSubData(indirectionBuffer_, 0,
                             static_cast<GLsizeiptr>(indirection_.size() * 4), indirection_.data());
    static constexpr char kInfoLabel[] = "rvol info";
    static constexpr char kIndirectionLabel[] = "rvol indirection";
    glObjectLabel(GL_BUFFER, infoBuffer_, sizeof kInfoLabel - 1, kInfoLabel);
    glObjectLabel(GL_BUFFER, indirectionBuffer_, sizeof kIndirectionLabel - 1, kIndirectionLabel);
    context_.throwOnErrors(reader.path().string() + ": allocating the radiance atlas");

    if (options.uploadAll)
        for (std::uint32_t l = 0; l < levels.size(); ++l)
            for (std::uint32_t i = 0; i < levels[l].brickCount; ++i)
                if (!uploadBrick(l, i))
                    throw RuntimeError(reader.path().string() +
                                       ": radiance atlas full");  // sized above: cannot happen
}

RvolGpuVolume::~RvolGpuVolume() {
    const GLuint textures[3] = {wordView_, rgbAtlas_, alphaAtlas_};
    glDeleteTextures(3, textures);
    const GLuint buffers[2] = {infoBuffer_, indirectionBuffer_};
    glDeleteBuffers(2, buffers);
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

std::uint64_t RvolGpuVolume::entryOffset(std::uint32_t level, std::uint32_t index) const {
    const rvol::BrickEntry& e = reader_.bricks(level)[index];
    const std::uint64_t k = reader_.level(level).bricksPerAxis;
    return levelBase_[level] + ((e.z * k + e.y) * k + e.x) * planesPerBrick(level);
}

bool RvolGpuVolume::resident(std::uint32_t level, std::uint32_t index) const {
    return residentFlags_.at(level).at(index) != 0;
}

bool RvolGpuVolume::uploadBrick(std::uint32_t level, std::uint32_t index) {
    if (resident(level, index)) return true;
    const std::uint32_t channels = rvol::levelChannels(level);
    const std::uint32_t alphaPlanes = rvol::alphaPlanes(channels, level == 0 && binaryLevel0_);
    const std::uint32_t stored = reader_.bricks(level)[index].planes;
    // Per plane its slot; 0 (the zero slot) for a plane the file leaves out (all zero).
    std::vector<std::uint32_t> rgb(channels, 0), alpha(alphaPlanes, 0);
    const auto giveBack = [&] {
        for (std::uint32_t s : rgb) rgbSlots_.release(s);
        for (std::uint32_t s : alpha) alphaSlots_.release(s);
    };
    for (std::uint32_t c = 0; c < channels; ++c) {
        if ((stored & 1u << c) == 0) continue;
        const auto s = rgbSlots_.allocate();
        if (!s) return giveBack(), false;
        rgb[c] = *s;
    }
    for (std::uint32_t p = 0; p < alphaPlanes; ++p) {
        if ((stored & 1u << (channels + p)) == 0) continue;
        const auto s = alphaSlots_.allocate();
        if (!s) return giveBack(), false;
        alpha[p] = *s;
    }
    const std::vector<std::uint8_t> bytes = reader_.readBrickBytes(level, index);
    const auto n = static_cast<GLsizei>(n_);
    const std::uint64_t entry = entryOffset(level, index);
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
    const std::uint32_t planes = planesPerBrick(level);
    glNamedBufferSubData(indirectionBuffer_, static_cast<GLintptr>(entry * 4),
                         static_cast<GLsizeiptr>(planes * 4), indirection_.data() + entry);
    residentFlags_[level][index] = 1;
    ++residentBricks_;
    uploadedTotal_ += bytes.size();
    context_.throwOnErrors(reader_.path().string() + ": uploading level " + std::to_string(level) +
                           " brick " + std::to_string(index));
    return true;
}

void RvolGpuVolume::evictBrick(std::uint32_t level, std::uint32_t index) {
    if (!resident(level, index)) return;
    const std::uint32_t channels = rvol::levelChannels(level);
    const std::uint32_t alphaPlanes = rvol::alphaPlanes(channels, level == 0 && binaryLevel0_);
    const std::uint64_t entry = entryOffset(level, index);
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
    glNamedBufferSubData(indirectionBuffer_, static_cast<GLintptr>(entry * 4),
                         static_cast<GLsizeiptr>(planes * 4), indirection_.data() + entry);
    residentFlags_[level][index] = 0;
    --residentBricks_;
    context_.throwOnErrors(reader_.path().string() + ": evicting level " + std::to_string(level) +
                           " brick " + std::to_string(index));
}

void RvolGpuVolume::bind(const RvolGpuBindings& bindings) const {
    glBindTextureUnit(bindings.rgbAtlasUnit, rgbAtlas_);
    glBindTextureUnit(bindings.wordAtlasUnit, wordView_);
    glBindTextureUnit(bindings.alphaAtlasUnit, alphaAtlas_);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, bindings.infoBinding, infoBuffer_);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, bindings.indirectionBinding, indirectionBuffer_);
}

std::uint64_t RvolGpuVolume::brickBytes(std::uint32_t level, std::uint32_t index) const {
    const std::uint64_t slot = std::uint64_t{n_} * n_ * n_;
    const std::uint32_t channels = rvol::levelChannels(level);
    const std::uint32_t stored = reader_.bricks(level)[index].planes;
    const auto rgb = static_cast<std::uint32_t>(std::popcount(stored & ((1u << channels) - 1))),
               alpha = static_cast<std::uint32_t>(std::popcount(stored >> channels));
    return rgb * 4 * slot + alpha * alphaTexelBytes() * slot;
}

std::uint64_t RvolGpuVolume::residentBytes() const noexcept {
    const std::uint64_t slot = std::uint64_t{n_} * n_ * n_;
    return 4 * slot * rgbSlots_.capacity() + alphaTexelBytes() * slot * alphaSlots_.capacity() +
           std::max<std::uint64_t>(4, indirection_.size() * 4) + infoBytes_;
}

std::uint64_t RvolGpuVolume::usedAtlasBytes() const noexcept {
    const std::uint64_t slot = std::uint64_t{n_} * n_ * n_;
    return 4 * slot * rgbSlots_.used() + alphaTexelBytes() * slot * alphaSlots_.used();
}

}  // namespace vox::runtime
