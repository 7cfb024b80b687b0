// The radiance bake as OpenVDB grids (vdb_export.h). OpenVDB is private to vox::core: nothing of
// it appears in libvox's headers.
#include <vox/vdb_export.h>

#include "../util/splitmix.h"

#include <vox/formats/atomic_file.h>
#include <vox/base/error.h>

#include <openvdb/io/Archive.h>
#include <openvdb/openvdb.h>
#include <openvdb/version.h>

#include <array>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <mutex>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace vox {
namespace {

using openvdb::Coord;
using openvdb::FloatGrid;
using openvdb::Vec3s;
using openvdb::Vec3SGrid;
using rvol::kBlockCells;

constexpr std::array<const char*, rvol::kDirections> kDirectionSuffix{"px", "nx", "py",
                                                                      "ny", "pz", "nz"};

void initializeOpenVdb() {
    static std::once_flag once;
    std::call_once(once, [] { openvdb::initialize(); });
}

/// Voxel (i, j, k) of the grid (index-space integer point = voxel centre) at the centre of cell
/// (i, j, k) of @p level: world = origin + (index + ½) · cellSize.
openvdb::math::Transform::Ptr levelTransform(const rvol::Volume& volume, std::uint32_t level) {
    const double cell = volume.cellSize(level);
    openvdb::math::Transform::Ptr transform = openvdb::math::Transform::createLinearTransform(cell);
    transform->postTranslate(openvdb::Vec3d(volume.origin[0] + 0.5 * cell,
                                            volume.origin[1] + 0.5 * cell,
                                            volume.origin[2] + 0.5 * cell));
    return transform;
}

template <class GridT>
typename GridT::Ptr makeGrid(const std::string& name, const rvol::Volume& volume,
                             std::uint32_t level) {
    typename GridT::Ptr grid = GridT::create(typename GridT::ValueType(0));
    grid->setName(name);
    grid->setCreator("libvox");
    grid->setTransform(levelTransform(volume, level));
    grid->insertMeta("level", openvdb::Int32Metadata(static_cast<std::int32_t>(level)));
    return grid;
}

bool nonZero(const Vec3s& v) { return v[0] != 0 || v[1] != 0 || v[2] != 0; }
Vec3s vec(const std::array<float, 3>& v) { return {v[0], v[1], v[2]}; }

/// Calls fn(coord, texel) for every cell of @p channel of @p level that lies inside the level, in
/// the level's block order (ascending Morton), then z, y, x.
template <class Fn>
void forEachCell(const rvol::Level& level, std::uint32_t channel, Fn&& fn) {
    for (std::size_t b = 0; b < level.blocks.size(); ++b) {
        const auto block = rvol::demorton3(level.blocks[b]);
        const rvol::Texel* texel =
            level.texels.data() + rvol::Level::texelIndex(b, level.channels, channel, 0, 0, 0);
        for (std::uint32_t z = 0; z < kBlockCells; ++z)
            for (std::uint32_t y = 0; y < kBlockCells; ++y)
                for (std::uint32_t x = 0; x < kBlockCells; ++x, ++texel) {
                    const std::uint32_t cx = block[0] * kBlockCells + x,
                                        cy = block[1] * kBlockCells + y,
                                        cz = block[2] * kBlockCells + z;
                    if (cx >= level.resolution || cy >= level.resolution || cz >= level.resolution)
                        continue;
                    fn(Coord(static_cast<std::int32_t>(cx), static_cast<std::int32_t>(cy),
                             static_cast<std::int32_t>(cz)),
                       *texel);
                }
    }
}

/// Channel @p channel of level @p levelIndex as an un-premultiplied radiance grid and an opacity
/// (fog volume) grid.
std::pair<Vec3SGrid::Ptr, FloatGrid::Ptr> channelGrids(const rvol::Volume& volume,
                                                       std::uint32_t levelIndex,
                                                       std::uint32_t channel,
                                                       const std::string& radianceName,
                                                       const std::string& opacityName) {
    Vec3SGrid::Ptr radiance = makeGrid<Vec3SGrid>(radianceName, volume, levelIndex);
    radiance->setVectorType(openvdb::VEC_INVARIANT);
    FloatGrid::Ptr opacity = makeGrid<FloatGrid>(opacityName, volume, levelIndex);
    opacity->setGridClass(openvdb::GRID_FOG_VOLUME);
    auto radianceAccess = radiance->getAccessor();
    auto opacityAccess = opacity->getAccessor();
    forEachCell(volume.levels[levelIndex], channel, [&](const Coord& c, const rvol::Texel& t) {
        if (t.a != 0) opacityAccess.setValueOn(c, t.a);
        if (t.a > 0) {
            const Vec3s rgb(t.r / t.a, t.g / t.a, t.b / t.a);
            if (nonZero(rgb)) radianceAccess.setValueOn(c, rgb);
        }
    });
    return {radiance, opacity};
}

/// The static voxels' attributes at level 0.
void addAttributes(openvdb::GridCPtrVec& grids, const rvol::Volume& volume) {
    Vec3SGrid::Ptr albedo = makeGrid<Vec3SGrid>("albedo", volume, 0);
    albedo->setVectorType(openvdb::VEC_INVARIANT);
    Vec3SGrid::Ptr emission = makeGrid<Vec3SGrid>("emission", volume, 0);
    emission->setVectorType(openvdb::VEC_INVARIANT);
    Vec3SGrid::Ptr normal = makeGrid<Vec3SGrid>("normal", volume, 0);
    normal->setVectorType(openvdb::VEC_COVARIANT_NORMALIZE);
    FloatGrid::Ptr occlusion = makeGrid<FloatGrid>("occlusion", volume, 0);
    auto albedoAccess = albedo->getAccessor();
    auto emissionAccess = emission->getAccessor();
    auto normalAccess = normal->getAccessor();
    auto occlusionAccess = occlusion->getAccessor();
    for (const rvol::VoxelAttributes& v : volume.staticVoxels) {
        const Coord c(static_cast<std::int32_t>(v.x), static_cast<std::int32_t>(v.y),
                      static_cast<std::int32_t>(v.z));
        if (nonZero(vec(v.albedo))) albedoAccess.setValueOn(c, vec(v.albedo));
        if (nonZero(vec(v.emission))) emissionAccess.setValueOn(c, vec(v.emission));
        if (nonZero(vec(v.normal))) normalAccess.setValueOn(c, vec(v.normal));
        if (v.occlusion != 0) occlusionAccess.setValueOn(c, v.occlusion);
    }
    grids.push_back(albedo);
    if (!emission->empty()) grids.push_back(emission);
    grids.push_back(normal);
    grids.push_back(occlusion);
}

void checkVolume(const std::filesystem::path& file, const rvol::Volume& volume) {
    if (volume.depth > 20)
        throw InvalidDataError(
            file, "radiance volume depth " + std::to_string(volume.depth) + " is over 20");
    if (volume.levels.size() != std::size_t{volume.depth} + 1)
        throw InvalidDataError(file, "radiance volume has " + std::to_string(volume.levels.size()) +
                                         " levels for depth " + std::to_string(volume.depth));
    for (std::uint32_t l = 0; l <= volume.depth; ++l) {
        const rvol::Level& level = volume.levels[l];
        const std::uint32_t channels = l == 0 ? 1 : rvol::kDirections;
        if (level.resolution != (1u << (volume.depth - l)) || level.channels != channels ||
            level.texels.size() != level.blocks.size() * channels * rvol::kBlockTexels)
            throw InvalidDataError(
                file, "radiance volume level " + std::to_string(l) + " is inconsistent");
    }
    const std::uint32_t resolution = 1u << volume.depth;
    for (const rvol::VoxelAttributes& v : volume.staticVoxels)
        if (v.x >= resolution || v.y >= resolution || v.z >= resolution)
            throw InvalidDataError(file, "static voxel outside the radiance volume");
}

/// io::File::write's archive (seekable: grid offsets in the file, for delayed and partial loading)
/// into a stream we own, so that write errors are seen and the header can be patched afterwards.
class StreamArchive final : public openvdb::io::Archive {
public:
    openvdb::io::Archive::Ptr copy() const override {
        return std::make_shared<StreamArchive>(*this);
    }
    void writeTo(std::ostream& os, const openvdb::GridCPtrVec& grids,
                 const openvdb::MetaMap& meta) const {
        Archive::write(os, grids, /*seekable=*/true, meta);
    }
};

/// The header's UUID: after the magic (8 bytes), the file and library versions (3 × 4 bytes) and
/// the grid-offsets flag (1 byte), 36 characters "xxxxxxxx-xxxx-xxxx-xxxx-xxxxxxxxxxxx".
constexpr std::size_t kUuidOffset = 21;
constexpr std::size_t kUuidLength = 36;

bool isUuidText(std::string_view text) {
    if (text.size() != kUuidLength) return false;
    for (std::size_t i = 0; i < kUuidLength; ++i) {
        const char ch = text[i];
        const bool dash = i == 8 || i == 13 || i == 18 || i == 23;
        if (dash ? ch != '-'
                 : !((ch >= '0' && ch <= '9') || (ch >= 'a' && ch <= 'f') ||
                     (ch >= 'A' && ch <= 'F')))
            return false;
    }
    return true;
}

/// A 128-bit hash of everything the export writes, two 64-bit lanes fed a word at a time.
class Hash128 {
public:
    void add(const void* data, std::size_t size) {
        const auto* bytes = static_cast<const unsigned char*>(data);
        for (; size >= 8; size -= 8, bytes += 8) {
            std::uint64_t word;
            std::memcpy(&word, bytes, 8);
            addWord(word);
        }
        std::uint64_t tail = 0;
        std::memcpy(&tail, bytes, size);
        addWord(tail ^ (std::uint64_t{size} << 56));
    }
    template <class T>
    void add(const std::vector<T>& values) {
        addWord(values.size());
        add(values.data(), values.size() * sizeof(T));
    }
    void addWord(std::uint64_t word) {
        h1_ = detail::splitmix64(h1_ ^ word);
        h2_ = detail::splitmix64(h2_ + word * 0xc2b2ae3d27d4eb4full) ^ h1_;
    }
    /// As an RFC 9562 version-8 (custom) UUID in its 36-character text form.
    [[nodiscard]] std::string uuid() const {
        std::array<std::uint8_t, 16> id{};
        for (std::size_t i = 0; i < 8; ++i) {
            id[i] = static_cast<std::uint8_t>(h1_ >> (56 - 8 * i));
            id[8 + i] = static_cast<std::uint8_t>(h2_ >> (56 - 8 * i));
        }
        id[6] = static_cast<std::uint8_t>((id[6] & 0x0f) | 0x80);  // version 8
        id[8] = static_cast<std::uint8_t>((id[8] & 0x3f) | 0x80);  // variant 10
        static constexpr char kHex[] = "0123456789abcdef";
        std::string text;
        for (std::size_t i = 0; i < id.size(); ++i) {
            if (i == 4 || i == 6 || i == 8 || i == 10) text += '-';
            text += kHex[id[i] >> 4];
            text += kHex[id[i] & 15];
        }
        return text;
    }

private:
    std::uint64_t h1_ = 0x6c69627666786462ull, h2_ = 0x7664622d65787074ull;
};

/// OpenVDB writes a random UUID into every header (io::File uses it to tell files apart); the
/// export's is a hash of what it writes (the volume, the options and the OpenVDB format), so that
/// the same volume gives the same bytes and a different one a different UUID.
std::string volumeUuid(const rvol::Volume& volume, const VdbExportOptions& options) {
    Hash128 hash;
    hash.addWord(OPENVDB_LIBRARY_VERSION_NUMBER);
    hash.addWord(openvdb::OPENVDB_FILE_VERSION);
    hash.addWord(options.allLevels ? 1 : 0);
    hash.add(volume.origin.data(), sizeof volume.origin);
    hash.add(&volume.size, sizeof volume.size);
    hash.addWord(volume.depth);
    for (const rvol::Level& level : volume.levels) {
        hash.add(level.blocks);
        hash.add(level.texels);
    }
    for (const rvol::VoxelAttributes& v : volume.staticVoxels) {
        const std::array<float, 10> values{v.albedo[0],   v.albedo[1], v.albedo[2],   v.normal[0],
                                           v.normal[1],   v.normal[2], v.emission[0], v.emission[1],
                                           v.emission[2], v.occlusion};
        hash.addWord((std::uint64_t{v.x} << 42) | (std::uint64_t{v.y} << 21) | v.z);
        hash.add(values.data(), sizeof values);
    }
    return hash.uuid();
}

}  // namespace

void exportVdb(const std::filesystem::path& file, const rvol::Volume& volume,
               const VdbExportOptions& options) {
    checkVolume(file, volume);
    AtomicFile out(file);  // fails early on an unwritable directory
    initializeOpenVdb();

    openvdb::GridCPtrVec grids;
    addAttributes(grids, volume);
    const auto [radiance, density] = channelGrids(volume, 0, 0, "radiance", "density");
    grids.push_back(radiance);
    grids.push_back(density);
    // Per directional level: radiance_px … radiance_nz, then opacity_px … opacity_nz.
    for (std::uint32_t l = 1; l <= volume.depth && (l == 1 || options.allLevels); ++l) {
        const std::string suffix = l == 1 ? std::string() : "_L" + std::to_string(l);
        openvdb::GridCPtrVec opacities;
        for (std::uint32_t d = 0; d < rvol::kDirections; ++d) {
            const auto [rgb, a] =
                channelGrids(volume, l, d, std::string("radiance_") + kDirectionSuffix[d] + suffix,
                             std::string("opacity_") + kDirectionSuffix[d] + suffix);
            grids.push_back(rgb);
            opacities.push_back(a);
        }
        grids.insert(grids.end(), opacities.begin(), opacities.end());
    }

    openvdb::MetaMap meta;
    meta.insertMeta("source", openvdb::StringMetadata("libvox .rvol bake"));
    meta.insertMeta("depth", openvdb::Int32Metadata(static_cast<std::int32_t>(volume.depth)));
    meta.insertMeta("origin", openvdb::Vec3DMetadata(openvdb::Vec3d(
                                  volume.origin[0], volume.origin[1], volume.origin[2])));
    meta.insertMeta("size", openvdb::DoubleMetadata(volume.size));

    // Into AtomicFile's temporary (renamed into place by commit, removed on an exception).
    std::fstream stream(out.temporaryPath(),
                        std::ios::in | std::ios::out | std::ios::binary | std::ios::trunc);
    if (!stream)
        throw IoError(file, "cannot open the temporary file " + out.temporaryPath().string());
    try {
        StreamArchive().writeTo(stream, grids, meta);
    } catch (const openvdb::Exception& e) {
        throw IoError(file, std::string("cannot write the OpenVDB grids: ") + e.what());
    }
    std::string header(kUuidOffset + kUuidLength, '\0');
    stream.seekg(0);
    stream.read(header.data(), static_cast<std::streamsize>(header.size()));
    const std::string uuid = volumeUuid(volume, options);
    // An unexpected header (another OpenVDB) keeps its random UUID: correct, but not reproducible.
    if (stream && isUuidText(std::string_view(header).substr(kUuidOffset))) {
        stream.seekp(static_cast<std::streamoff>(kUuidOffset));
        stream.write(uuid.data(), static_cast<std::streamsize>(uuid.size()));
    }
    stream.close();
    if (stream.fail()) throw IoError(file, "cannot write the OpenVDB grids (disk full?)");
    out.commit();
}

}  // namespace vox
