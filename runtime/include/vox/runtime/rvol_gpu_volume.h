/// @file rvol_gpu_volume.h
/// @brief An .rvol radiance volume, or a tiled one, on the GPU: its bricks in 3D texture atlases
/// (GL_RGB9_E5 radiance, GL_R8 opacity) and an indirection table from brick coordinates to atlas
/// slots, so that a shader samples any level and channel with the hardware's trilinear filter (no
/// sparse textures). docs/runtime.md, "The radiance volume on the GPU".
#pragma once

#include <vox/formats/rvol_io.h>

#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <vector>

namespace vox::rvol {
class TiledRvolReader;
}

namespace vox::runtime {

class GlContext;

/// The file of a single volume, or of a tiled volume's far field (RvolBrickRef::file).
inline constexpr std::uint32_t kBaseFile = 0xFFFFFFFFu;

/// A brick of one of the volume's files: @c file is kBaseFile or, in a tiled volume, the tile's
/// position in TileIndex::tiles; @c level and @c index as that file's directory numbers them.
struct RvolBrickRef {
    std::uint32_t file = kBaseFile;
    std::uint32_t level = 0, index = 0;
    auto operator<=>(const RvolBrickRef&) const = default;
};

/// Fixed-size slots of an atlas, handed out from a free list (the lowest freed slot first is not
/// promised: last freed, first reused). Slot 0 is reserved: the all-zero slot that absent bricks
/// point at, never handed out.
class AtlasSlotAllocator {
public:
    explicit AtlasSlotAllocator(std::uint32_t capacity = 1) : capacity_(capacity) {}
    /// A free slot (≥ 1), or nothing when all capacity − 1 usable slots are taken.
    [[nodiscard]] std::optional<std::uint32_t> allocate();
    /// Gives @p slot back (it must have come from allocate() and not been released since).
    void release(std::uint32_t slot);
    [[nodiscard]] std::uint32_t capacity() const noexcept { return capacity_; }
    [[nodiscard]] std::uint32_t used() const noexcept {
        return next_ - 1 - static_cast<std::uint32_t>(free_.size());
    }

private:
    std::uint32_t capacity_;
    std::uint32_t next_ = 1;  // slots below next_ have been handed out at least once
    std::vector<std::uint32_t> free_;
};

/// Where RvolGpuVolume::bind() puts its objects; the GLSL of final_gather_gpu.cpp declares the
/// same bindings (a shader of its own must too).
struct RvolGpuBindings {
    std::uint32_t rgbAtlasUnit = 0;  ///< sampler3D: the GL_RGB9_E5 radiance atlas, GL_LINEAR
    std::uint32_t wordAtlasUnit =
        1;  ///< usampler3D: the same storage as GL_R32UI (texture view), GL_NEAREST
    std::uint32_t alphaAtlasUnit = 2;    ///< sampler3D: the GL_R8 opacity atlas, GL_LINEAR
    std::uint32_t tileTableBinding = 3;  ///< SSBO: per tile its slot, missing or absent
    std::uint32_t infoBinding = 4;       ///< SSBO: volume geometry and the level table
    std::uint32_t indirectionBinding =
        5;  ///< SSBO: per level, brick and plane, the packed atlas slot
};

struct RvolGpuVolumeOptions {
    /// Slots to reserve in each atlas beyond what the file's bricks need (room for streaming).
    std::uint32_t extraRgbSlots = 0, extraAlphaSlots = 0;
    /// Upload every brick of every level in the constructor. false: a volume with every brick
    /// *missing* (indirection kMissingBrick: samples fall back to coarser levels) to be filled
    /// with uploadBrick(), as RvolResidency does.
    bool uploadAll = true;
    /// With uploadAll false and > 0: size the atlases for about this many bytes of bricks
    /// instead of the whole file (six RGB9E5 slots to three A8 slots, as a directional brick
    /// needs), so that a streaming budget bounds GPU memory too.
    std::uint64_t atlasBytes = 0;
    /// The opacity atlas as GL_R16 instead of GL_R8: each A8 value k expanded to k·257 on upload
    /// (k/255 exactly), twice the opacity bytes. Worth it where the texture unit returns a
    /// filtered GL_R8 at 8 bits (llvmpipe does: up to 1/255 off), since the directional
    /// opacity's log(1 − a) is steep near 1; irrelevant with FinalGatherGpuOptions::hardwareFilter
    /// false (texelFetch reads the exact value either way).
    bool alpha16 = false;
    /// Tiled volumes: how many tiles can have bricks on the GPU at once (each takes a block of
    /// the indirection for all its bricks). 0: every tile with uploadAll; else as many blocks as
    /// a quarter of atlasBytes holds, at least one. Cut to GL_MAX_SHADER_STORAGE_BLOCK_SIZE.
    std::uint32_t tileSlots = 0;
};

/// The indirection entry of a brick the file has but the GPU does not hold (not yet streamed in,
/// or evicted): the shader samples the next coarser level there instead (whose brick a residency
/// keeps whenever it keeps a finer one). Slot words use the low 30 bits, so bit 31 is free.
inline constexpr std::uint32_t kMissingBrick = 0x80000000u;
/// Tile table entries of a tile the GPU does not hold (its samples fall back to the far field)
/// and of a tile the index does not list (all zero, as the format says); else the tile's slot.
inline constexpr std::uint32_t kMissingTile = 0x80000000u;
inline constexpr std::uint32_t kAbsentTile = 0x40000000u;

/// The radiance of an .rvol file in GL (OpenGL 4.5). Layout (docs/runtime.md):
/// - **RGB atlas**: one GL_RGB9_E5 3D texture of slots of N×N×N texels (N = brickTexels); a
///   level-0 brick takes one slot (its RGB plane), a brick of levels ≥ 1 up to six (one per
///   directional channel the file stores; a plane it leaves out is all zero and points at the
///   zero slot). The planes are uploaded expanded (RvolReader::readBrickBytes,
///   GL_UNSIGNED_INT_5_9_9_9_REV).
/// - **Opacity atlas**: one GL_R8 3D texture of N³ slots: one per level-0 brick (none with
///   binary level-0 opacity, kFlagBinaryLevel0Opacity: the shader reads the RGB words through a
///   GL_R32UI view of the RGB atlas and counts non-zero corners), up to three per brick above
///   (x, y, z; likewise only the stored ones).
/// - **Indirection**: an SSBO of u32, per level K³ bricks × P planes (P = 2 at level 0: RGB,
///   opacity; 9 above: six RGB channels then the x, y, z opacities), each the slot's grid
///   coordinates packed 10 bits each (x | y << 10 | z << 20). 0 is slot (0, 0, 0), the all-zero
///   slot: an absent brick, or an absent plane, samples (0, 0, 0, 0) without a branch.
/// - **Info**: an SSBO with the volume's origin and size, depth, N, atlas sizes and per level
///   the table offset, bricks per axis, resolution, planes per brick and where to fall back.
/// - **Tiled volumes** (docs/rvol-format.md, "Tiled volumes"): the far field's levels as a single
///   volume's; each resident tile a block of the indirection (its levels 0 … T) in a tile slot;
///   a **tile table** SSBO, per tile of the volume its slot, kMissingTile or kAbsentTile. Levels
///   ≤ T sample the tile owning each cell (fetching across tile borders); where a tile or brick
///   is missing, the far field at that level (or its finest) serves.
/// The reader must outlive the object (uploadBrick reads from it). Of a tiled volume's tiles, the
/// object keeps what eviction and the residency's byte counts need while a tile has a tile slot,
/// and holds a tile's file open only while it reads it (TiledRvolReader::tile): the reader's bound
/// on open tiles holds.
class RvolGpuVolume {
public:
    /// Allocates the atlases for every brick of @p reader (plus the options' extra slots) and, by
    /// default, uploads them all. @throws RuntimeError when an atlas needs more slots than
    /// GL_MAX_3D_TEXTURE_SIZE allows, or on a GL error; InvalidDataError for a corrupt brick.
    RvolGpuVolume(GlContext& context, const rvol::RvolReader& reader,
                  const RvolGpuVolumeOptions& options = {});
    /// A tiled volume: its far field and tiles. With uploadAll it opens every tile (one at a
    /// time) and uploads every brick; without, it needs atlasBytes > 0 and opens a tile only when
    /// uploadBrick asks for one of its bricks. Tiles must have the far field's level-0 layout
    /// (binary opacity or not, as one bake writes them): InvalidDataError names a tile that has
    /// not.
    /// @throws RuntimeError as above, or when the tile table or one tile block does not fit
    /// GL_MAX_SHADER_STORAGE_BLOCK_SIZE; IoError, InvalidDataError from the files.
    RvolGpuVolume(GlContext& context, const rvol::TiledRvolReader& reader,
                  const RvolGpuVolumeOptions& options = {});
    ~RvolGpuVolume();
    RvolGpuVolume(const RvolGpuVolume&) = delete;
    RvolGpuVolume& operator=(const RvolGpuVolume&) = delete;

    /// Uploads @p brick into free slots and points the indirection at them; nothing if it is
    /// resident. A tile's first brick takes a tile slot; every tile brick opens its tile's file
    /// if the tiled reader has closed it since. @throws IoError, InvalidDataError from the file.
    /// Returns false when an atlas or the tile slots are full (nothing changed): evict first.
    bool uploadBrick(const RvolBrickRef& brick);
    /// Frees the brick's slots and marks its indirection entries kMissingBrick (samples there fall
    /// back to the coarser level, or over a tile to the far field); a tile's last brick frees its
    /// tile slot. Nothing if it is not resident. Reads no file.
    void evictBrick(const RvolBrickRef& brick);
    [[nodiscard]] bool resident(const RvolBrickRef& brick) const;

    /// Binds the atlases, the view and the SSBOs at @p bindings.
    void bind(const RvolGpuBindings& bindings = {}) const;

    /// The single volume, or a tiled volume's far field.
    [[nodiscard]] const rvol::RvolReader& reader() const noexcept { return reader_; }
    /// The tiled volume, or null.
    [[nodiscard]] const rvol::TiledRvolReader* tiled() const noexcept { return tiled_; }
    /// The file of @p file: kBaseFile's, or a tile's, opened if the tiled reader has it closed and
    /// kept open while the pointer lives (TiledRvolReader::tile). @throws as tile().
    [[nodiscard]] std::shared_ptr<const rvol::RvolReader> fileReader(std::uint32_t file) const;
    /// The name of @p file, without opening it.
    [[nodiscard]] std::filesystem::path fileName(std::uint32_t file) const;
    /// The volume level that level @p level of @p file is: a tiled volume's far field starts at
    /// depth − farDepth; tiles and single volumes at 0.
    [[nodiscard]] std::uint32_t volumeLevel(std::uint32_t file,
                                            std::uint32_t level) const noexcept {
        return file == kBaseFile ? level + baseLevelOffset_ : level;
    }
    /// Levels 0 … depth() of the volume (the tiled volume's depth D).
    [[nodiscard]] std::uint32_t depth() const noexcept { return depth_; }
    /// The finest cells' edge, world units.
    [[nodiscard]] double finestCellSize() const noexcept;
    /// Tiles that can be resident at once, and those that are (that have a resident brick).
    [[nodiscard]] std::uint32_t tileSlotCount() const noexcept { return tileSlotCount_; }
    [[nodiscard]] std::uint32_t residentTiles() const noexcept {
        return tileSlotCount_ - static_cast<std::uint32_t>(freeTileSlots_.size());
    }
    [[nodiscard]] bool tileResident(std::uint32_t tile) const;
    [[nodiscard]] std::uint32_t brickTexels() const noexcept { return n_; }
    /// Bytes per opacity texel: 1 (GL_R8) or 2 (GL_R16, RvolGpuVolumeOptions::alpha16).
    [[nodiscard]] std::uint32_t alphaTexelBytes() const noexcept { return alpha16_ ? 2u : 1u; }
    [[nodiscard]] std::array<std::uint32_t, 3> rgbSlotGrid() const noexcept { return rgbGrid_; }
    [[nodiscard]] std::array<std::uint32_t, 3> alphaSlotGrid() const noexcept { return alphaGrid_; }
    [[nodiscard]] const AtlasSlotAllocator& rgbSlots() const noexcept { return rgbSlots_; }
    [[nodiscard]] const AtlasSlotAllocator& alphaSlots() const noexcept { return alphaSlots_; }
    [[nodiscard]] std::uint64_t residentBricks() const noexcept { return residentBricks_; }
    /// GPU memory held: both atlases (all slots, used or not), the indirection and the info SSBOs.
    [[nodiscard]] std::uint64_t residentBytes() const noexcept;
    /// Of the atlases, the bytes of slots holding a brick's plane.
    [[nodiscard]] std::uint64_t usedAtlasBytes() const noexcept;
    [[nodiscard]] std::uint64_t indirectionBytes() const noexcept {
        return indirection_.size() * 4;
    }
    [[nodiscard]] std::uint64_t uploadedBytesTotal() const noexcept { return uploadedTotal_; }

    [[nodiscard]] unsigned rgbAtlas() const noexcept { return rgbAtlas_; }
    [[nodiscard]] unsigned wordView() const noexcept { return wordView_; }
    [[nodiscard]] unsigned alphaAtlas() const noexcept { return alphaAtlas_; }
    [[nodiscard]] unsigned infoBuffer() const noexcept { return infoBuffer_; }
    [[nodiscard]] unsigned indirectionBuffer() const noexcept { return indirectionBuffer_; }
    [[nodiscard]] unsigned tileTableBuffer() const noexcept { return tileTableBuffer_; }

    /// GPU bytes of the slots @p brick takes (its stored planes; the planes the file leaves out
    /// take none): what a residency budget counts. Opens the brick's tile where it has no tile
    /// slot (planeBytes of its directory entry needs no file).
    [[nodiscard]] std::uint64_t brickBytes(const RvolBrickRef& brick) const;
    /// GPU bytes of the slots of a brick of @p level that stores @p planes (BrickEntry::planes).
    [[nodiscard]] std::uint64_t planeBytes(std::uint32_t level,
                                           std::uint32_t planes) const noexcept;
    /// The slots such a brick takes: {RGB atlas slots, opacity atlas slots}.
    [[nodiscard]] static std::array<std::uint32_t, 2> planeSlots(std::uint32_t level,
                                                                 std::uint32_t planes) noexcept;
    /// Planes per brick entry of the indirection: 2 at level 0, 9 above.
    [[nodiscard]] static std::uint32_t planesPerBrick(std::uint32_t level) noexcept {
        return level == 0 ? 2u : 9u;
    }

private:
    /// Of a tile's brick, what the GPU side needs without the tile's file.
    struct TileBrick {
        std::uint32_t entry = 0;   // first indirection entry, within the tile's block
        std::uint16_t planes = 0;  // BrickEntry::planes
        bool resident = false;
    };
    /// A tile's bricks on the GPU: its slot (a block of the indirection) while one is resident.
    struct TileState {
        std::uint32_t slot = 0xFFFFFFFFu;
        std::uint64_t residentBricks = 0;
        std::vector<std::vector<TileBrick>> bricks;  // per level, per directory index
    };

    void build(const RvolGpuVolumeOptions& options);
    void writeInfo();
    [[nodiscard]] std::uint64_t entryOffset(const RvolBrickRef& brick) const;
    bool takeTileSlot(std::uint32_t tile);
    void releaseTileSlot(std::uint32_t tile);
    [[nodiscard]] std::uint64_t tileTableIndex(std::uint32_t tile) const;
    void uploadWords(unsigned buffer, const std::vector<std::uint32_t>& words, std::uint64_t first,
                     std::uint64_t count);
    void createAtlas(unsigned& texture, const std::array<std::uint32_t, 3>& grid, bool rgb);
    [[nodiscard]] std::array<std::uint32_t, 3> slotOrigin(const std::array<std::uint32_t, 3>& grid,
                                                          std::uint32_t slot) const noexcept;

    GlContext& context_;
    const rvol::RvolReader& reader_;
    const rvol::TiledRvolReader* tiled_ = nullptr;
    std::uint32_t n_ = 0;
    std::uint32_t depth_ = 0, baseLevelOffset_ = 0;
    bool binaryLevel0_ = false;  // of every file: a tiled volume's tiles have the far field's
    bool alpha16_ = false;
    unsigned rgbAtlas_ = 0, wordView_ = 0, alphaAtlas_ = 0, infoBuffer_ = 0, indirectionBuffer_ = 0,
             tileTableBuffer_ = 0;
    std::array<std::uint32_t, 3> rgbGrid_{1, 1, 1}, alphaGrid_{1, 1, 1};
    AtlasSlotAllocator rgbSlots_, alphaSlots_;
    std::vector<std::uint64_t> levelBase_;      // per base-file level: first u32 of its entries
    std::vector<std::uint64_t> tileLevelBase_;  // per tile level: first u32 in a tile's block
    std::uint64_t tileBlocksBase_ = 0, tileBlockEntries_ = 0;
    std::uint32_t tileSlotCount_ = 0;
    std::vector<std::uint32_t> freeTileSlots_;
    std::vector<TileState> tiles_;
    std::vector<std::uint32_t>
        indirection_;  // host copy of the indirection SSBO (packed slot coordinates)
    std::vector<std::uint32_t> tileTable_;                  // host copy of the tile table SSBO
    std::vector<std::vector<std::uint8_t>> residentFlags_;  // base file: per level, per index
    std::uint64_t residentBricks_ = 0;
    std::uint64_t infoBytes_ = 0;
    std::uint64_t uploadedTotal_ = 0;
};

}  // namespace vox::runtime
