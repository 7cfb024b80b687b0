// The radiance volume's OpenVDB export (libvox/src/radiance/vdb_export.cpp): a small synthetic
// rvol::Volume written and read back with OpenVDB's io::File — grid names, types, classes and
// metadata; voxel sizes and the cell-centred placement (a cell's world centre maps to that cell's
// voxel and value); un-premultiplied radiance; active voxels exactly at the non-zero cells;
// byte-identical repeated exports; IoError and no file left behind for unwritable targets.
#include <vox/formats/atomic_file.h>
#include <vox/base/error.h>
#include <vox/formats/rvol.h>
#include <vox/vdb_export.h>

#include "test_support.h"

#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/Interpolation.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <fstream>
#include <map>
#include <string>
#include <vector>

namespace fs = std::filesystem;
namespace rvol = vox::rvol;
using vox::test::ScratchDir;

namespace {

constexpr std::uint32_t kDepth = 4;  // 16³ cells at level 0
constexpr std::array<double, 3> kOrigin{-1.5, 2.0, 0.25};
constexpr double kSize = 4.0;  // cell size 0.25 at level 0, 0.5 at level 1
const std::array<std::string, 6> kDirs{"px", "nx", "py", "ny", "pz", "nz"};

std::vector<char> readBytes(const fs::path& file) {
    std::ifstream in(file, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

rvol::Texel& texel(rvol::Level& level, std::uint32_t channel, std::uint32_t x, std::uint32_t y,
                   std::uint32_t z) {
    const std::int64_t block = level.findBlock(x, y, z);
    EXPECT_GE(block, 0);
    return level.texels[rvol::Level::texelIndex(static_cast<std::size_t>(block), level.channels,
                                                channel, x, y, z)];
}

/// A patterned level: cells of its blocks non-zero where (x + 2y + 3z + channel) % 5 != 0, some of
/// them with zero opacity (premultiplied zero too) and some opaque but black.
void fill(rvol::Level& level, std::uint32_t levelIndex) {
    for (std::size_t b = 0; b < level.blocks.size(); ++b) {
        const auto block = rvol::demorton3(level.blocks[b]);
        for (std::uint32_t c = 0; c < level.channels; ++c)
            for (std::uint32_t z = 0; z < rvol::kBlockCells; ++z)
                for (std::uint32_t y = 0; y < rvol::kBlockCells; ++y)
                    for (std::uint32_t x = 0; x < rvol::kBlockCells; ++x) {
                        const std::uint32_t cx = block[0] * 8 + x, cy = block[1] * 8 + y,
                                            cz = block[2] * 8 + z;
                        if (cx >= level.resolution || cy >= level.resolution ||
                            cz >= level.resolution)
                            continue;
                        rvol::Texel& t =
                            level.texels[rvol::Level::texelIndex(b, level.channels, c, cx, cy, cz)];
                        const std::uint32_t k = cx + 2 * cy + 3 * cz + c;
                        if (k % 5 == 0) continue;
                        t.a = static_cast<float>(k % 4) / 4.0f;  // 0, ¼, ½, ¾
                        if (k % 7 == 0) continue;                // opaque black
                        t.r = t.a * (0.1f + static_cast<float>(cx) / 16.0f);
                        t.g = t.a * (0.2f + static_cast<float>(levelIndex));
                        t.b = t.a * (0.3f + static_cast<float>(c));
                    }
    }
}

rvol::Volume makeVolume() {
    rvol::Volume v;
    v.origin = kOrigin;
    v.size = kSize;
    v.depth = kDepth;
    v.levels.resize(kDepth + 1);
    for (std::uint32_t l = 0; l <= kDepth; ++l) {
        rvol::Level& level = v.levels[l];
        level.resolution = 1u << (kDepth - l);
        level.channels = l == 0 ? 1 : rvol::kDirections;
        if (l == 0)
            level.blocks = {rvol::morton3(0, 0, 0), rvol::morton3(1, 1, 0), rvol::morton3(0, 1, 1)};
        else
            level.blocks = {0};
        std::sort(level.blocks.begin(), level.blocks.end());
        level.texels.assign(level.blocks.size() * level.channels * rvol::kBlockTexels, {});
        fill(level, l);
    }
    // Known cells, overriding the pattern.
    texel(v.levels[0], 0, 3, 5, 7) = {0.4f, 0.2f, 0.1f,
                                      0.5f};  // radiance (0.8, 0.4, 0.2), density 0.5
    texel(v.levels[0], 0, 9, 10, 2) = {0.3f, 0.6f, 0.9f, 1.0f};   // block (1, 1, 0)
    texel(v.levels[0], 0, 4, 4, 4) = {};                          // empty
    texel(v.levels[1], 2, 1, 6, 3) = {0.25f, 0.5f, 0.0f, 0.25f};  // PosY: radiance (1, 2, 0)
    texel(v.levels[1], 5, 1, 6, 3) = {0.0f, 0.0f, 0.0f, 0.75f};   // NegZ: opaque black

    rvol::VoxelAttributes a;
    a.x = 3, a.y = 5, a.z = 7;
    a.albedo = {0.5f, 0.25f, 0.125f};
    a.normal = {0, 1, 0};
    a.occlusion = 0.3f;
    rvol::VoxelAttributes b;
    b.x = 9, b.y = 10, b.z = 2;
    b.albedo = {0, 0, 0};  // black: no active albedo voxel
    b.normal = {0, 0, -1};
    b.emission = {2, 1, 0};
    rvol::VoxelAttributes c;
    c.x = 1, c.y = 1, c.z = 1;
    c.albedo = {0.9f, 0.9f, 0.9f};
    c.normal = {1, 0, 0};
    v.staticVoxels = {a, b, c};
    std::sort(v.staticVoxels.begin(), v.staticVoxels.end(), [](const auto& p, const auto& q) {
        return rvol::morton3(p.x, p.y, p.z) < rvol::morton3(q.x, q.y, q.z);
    });
    return v;
}

/// Cells of @p channel of @p level with non-zero opacity, and with non-zero un-premultiplied
/// radiance.
std::pair<openvdb::Index64, openvdb::Index64> nonZeroCells(const rvol::Level& level,
                                                           std::uint32_t channel) {
    openvdb::Index64 opacity = 0, radiance = 0;
    for (std::uint32_t z = 0; z < level.resolution; ++z)
        for (std::uint32_t y = 0; y < level.resolution; ++y)
            for (std::uint32_t x = 0; x < level.resolution; ++x) {
                const rvol::Texel t = level.at(x, y, z, channel);
                if (t.a != 0) ++opacity;
                if (t.a > 0 && (t.r != 0 || t.g != 0 || t.b != 0)) ++radiance;
            }
    return {opacity, radiance};
}

/// Every grid of @p file by name, and the file's metadata.
struct VdbFile {
    std::vector<std::string> names;  ///< sorted (io::File lists them by name)
    std::map<std::string, openvdb::GridBase::Ptr> grids;
    openvdb::MetaMap::Ptr meta;
};

VdbFile readVdb(const fs::path& path) {
    openvdb::initialize();
    openvdb::io::File file(path.string());
    file.open();
    VdbFile out;
    out.meta = file.getMetadata();
    for (auto it = file.beginName(); it != file.endName(); ++it) out.names.push_back(it.gridName());
    std::sort(out.names.begin(), out.names.end());
    for (const std::string& name : out.names) out.grids[name] = file.readGrid(name);
    file.close();
    return out;
}

template <class GridT>
typename GridT::Ptr grid(const VdbFile& f, const std::string& name) {
    const auto it = f.grids.find(name);
    if (it == f.grids.end()) return nullptr;
    return openvdb::gridPtrCast<GridT>(it->second);
}

/// World position of the centre of cell (i, j, k) of @p level.
openvdb::Vec3d cellCentre(std::uint32_t level, std::uint32_t i, std::uint32_t j, std::uint32_t k) {
    const double cell = kSize / double(1u << (kDepth - level));
    return {kOrigin[0] + (i + 0.5) * cell, kOrigin[1] + (j + 0.5) * cell,
            kOrigin[2] + (k + 0.5) * cell};
}

/// The value a world position reads from @p g: nearest voxel through the transform, and the
/// point sampler in world space, which must agree.
template <class GridT>
typename GridT::ValueType sampleWorld(const GridT& g, const openvdb::Vec3d& world) {
    const openvdb::Coord ijk = g.transform().worldToIndexCellCentered(world);
    const auto byAccessor = g.getConstAccessor().getValue(ijk);
    openvdb::tools::GridSampler<GridT, openvdb::tools::PointSampler> sampler(g);
    EXPECT_EQ(sampler.wsSample(world), byAccessor);
    return byAccessor;
}

void expectVec(const openvdb::Vec3s& got, const openvdb::Vec3s& want) {
    EXPECT_NEAR(got[0], want[0], 1e-6f);
    EXPECT_NEAR(got[1], want[1], 1e-6f);
    EXPECT_NEAR(got[2], want[2], 1e-6f);
}

TEST(VdbExport, GridNamesTypesAndMetadata) {
    ScratchDir dir;
    const rvol::Volume volume = makeVolume();
    vox::exportVdb(dir / "bake.vdb", volume);
    EXPECT_EQ(dir.files(), std::vector<std::string>{"bake.vdb"});
    const VdbFile f = readVdb(dir / "bake.vdb");

    std::vector<std::string> want{"albedo",    "emission", "normal",
                                  "occlusion", "radiance", "density"};
    for (const auto& d : kDirs) want.push_back("radiance_" + d);
    for (const auto& d : kDirs) want.push_back("opacity_" + d);
    std::sort(want.begin(), want.end());
    EXPECT_EQ(f.names, want);

    for (const std::string name : {"albedo", "emission", "normal", "radiance"}) {
        ASSERT_TRUE(grid<openvdb::Vec3SGrid>(f, name)) << name;
        EXPECT_EQ(f.grids.at(name)->getName(), name);
    }
    EXPECT_EQ(f.grids.at("albedo")->getVectorType(), openvdb::VEC_INVARIANT);
    EXPECT_EQ(f.grids.at("radiance")->getVectorType(), openvdb::VEC_INVARIANT);
    EXPECT_EQ(f.grids.at("normal")->getVectorType(), openvdb::VEC_COVARIANT_NORMALIZE);
    ASSERT_TRUE(grid<openvdb::FloatGrid>(f, "occlusion"));
    ASSERT_TRUE(grid<openvdb::FloatGrid>(f, "density"));
    EXPECT_EQ(f.grids.at("density")->getGridClass(), openvdb::GRID_FOG_VOLUME);
    for (const auto& d : kDirs) {
        ASSERT_TRUE(grid<openvdb::Vec3SGrid>(f, "radiance_" + d)) << d;
        ASSERT_TRUE(grid<openvdb::FloatGrid>(f, "opacity_" + d)) << d;
        EXPECT_EQ(f.grids.at("opacity_" + d)->getGridClass(), openvdb::GRID_FOG_VOLUME);
    }

    ASSERT_TRUE(f.meta);
    EXPECT_EQ(f.meta->metaValue<std::string>("source"), "libvox .rvol bake");
    EXPECT_EQ(f.meta->metaValue<openvdb::Int32>("depth"), static_cast<openvdb::Int32>(kDepth));
    EXPECT_EQ(f.meta->metaValue<openvdb::Vec3d>("origin"),
              openvdb::Vec3d(kOrigin[0], kOrigin[1], kOrigin[2]));
    EXPECT_EQ(f.meta->metaValue<double>("size"), kSize);
}

TEST(VdbExport, AllLevelsAddSuffixedCoarserLevels) {
    ScratchDir dir;
    vox::exportVdb(dir / "all.vdb", makeVolume(), {.allLevels = true});
    const VdbFile f = readVdb(dir / "all.vdb");
    EXPECT_EQ(f.names.size(), 6u + 12u * kDepth);
    for (std::uint32_t l = 2; l <= kDepth; ++l)
        for (const auto& d : kDirs) {
            const std::string suffix = "_L" + std::to_string(l);
            const auto rgb = grid<openvdb::Vec3SGrid>(f, "radiance_" + d + suffix);
            const auto a = grid<openvdb::FloatGrid>(f, "opacity_" + d + suffix);
            ASSERT_TRUE(rgb && a) << d << suffix;
            EXPECT_DOUBLE_EQ(rgb->voxelSize()[0], kSize / double(1u << (kDepth - l)));
        }
    EXPECT_FALSE(f.grids.count("radiance_px_L1"));
    // The coarsest level is one cell: its centre is the cube's centre.
    const auto top = grid<openvdb::FloatGrid>(f, "opacity_py_L4");
    const openvdb::Vec3d centre(kOrigin[0] + kSize / 2, kOrigin[1] + kSize / 2,
                                kOrigin[2] + kSize / 2);
    EXPECT_EQ(top->transform().worldToIndexCellCentered(centre), openvdb::Coord(0, 0, 0));
    EXPECT_NEAR(top->transform().worldToIndex(centre).length(), 0.0, 1e-12);
}

TEST(VdbExport, CellCentresMapToTheirCells) {
    ScratchDir dir;
    const rvol::Volume volume = makeVolume();
    vox::exportVdb(dir / "bake.vdb", volume);
    const VdbFile f = readVdb(dir / "bake.vdb");

    const auto radiance = grid<openvdb::Vec3SGrid>(f, "radiance");
    const auto density = grid<openvdb::FloatGrid>(f, "density");
    const auto py = grid<openvdb::Vec3SGrid>(f, "radiance_py");
    EXPECT_EQ(radiance->voxelSize(), openvdb::Vec3d(0.25));
    EXPECT_EQ(density->voxelSize(), openvdb::Vec3d(0.25));
    EXPECT_EQ(py->voxelSize(), openvdb::Vec3d(0.5));
    EXPECT_TRUE(radiance->transform().isLinear());

    // OpenVDB voxel i spans index [i − ½, i + ½]: the root cube's corners are at −½ and res − ½.
    const openvdb::math::Transform& xf = radiance->transform();
    const openvdb::Vec3d lo = xf.indexToWorld(openvdb::Vec3d(-0.5)),
                         hi = xf.indexToWorld(openvdb::Vec3d(15.5));
    for (int i = 0; i < 3; ++i) {
        EXPECT_NEAR(lo[i], kOrigin[static_cast<std::size_t>(i)], 1e-12);
        EXPECT_NEAR(hi[i], kOrigin[static_cast<std::size_t>(i)] + kSize, 1e-12);
    }
    EXPECT_NEAR((xf.worldToIndex(cellCentre(0, 3, 5, 7)) - openvdb::Vec3d(3, 5, 7)).length(), 0.0,
                1e-12);
    EXPECT_EQ(xf.worldToIndexCellCentered(cellCentre(0, 3, 5, 7)), openvdb::Coord(3, 5, 7));

    // Known cells at their world centres; un-premultiplied radiance.
    expectVec(sampleWorld(*radiance, cellCentre(0, 3, 5, 7)), {0.8f, 0.4f, 0.2f});
    EXPECT_FLOAT_EQ(sampleWorld(*density, cellCentre(0, 3, 5, 7)), 0.5f);
    expectVec(sampleWorld(*radiance, cellCentre(0, 9, 10, 2)), {0.3f, 0.6f, 0.9f});
    EXPECT_FLOAT_EQ(sampleWorld(*density, cellCentre(0, 9, 10, 2)), 1.0f);
    EXPECT_FALSE(density->tree().isValueOn(openvdb::Coord(4, 4, 4)));
    expectVec(sampleWorld(*py, cellCentre(1, 1, 6, 3)), {1.0f, 2.0f, 0.0f});
    EXPECT_FLOAT_EQ(sampleWorld(*grid<openvdb::FloatGrid>(f, "opacity_py"), cellCentre(1, 1, 6, 3)),
                    0.25f);
    // Opaque black: opacity active, radiance not.
    EXPECT_FLOAT_EQ(sampleWorld(*grid<openvdb::FloatGrid>(f, "opacity_nz"), cellCentre(1, 1, 6, 3)),
                    0.75f);
    EXPECT_FALSE(
        grid<openvdb::Vec3SGrid>(f, "radiance_nz")->tree().isValueOn(openvdb::Coord(1, 6, 3)));

    // Near a cell's corner (still inside it) reads the same cell; just across, the neighbour.
    const openvdb::Vec3d corner(kOrigin[0] + 3 * 0.25, kOrigin[1] + 5 * 0.25,
                                kOrigin[2] + 7 * 0.25);
    EXPECT_EQ(xf.worldToIndexCellCentered(corner + openvdb::Vec3d(0.01)), openvdb::Coord(3, 5, 7));
    EXPECT_EQ(xf.worldToIndexCellCentered(corner - openvdb::Vec3d(0.01)), openvdb::Coord(2, 4, 6));

    // Every cell of the pattern, level 0 and the level-1 directions.
    for (std::uint32_t z = 0; z < 16; ++z)
        for (std::uint32_t y = 0; y < 16; ++y)
            for (std::uint32_t x = 0; x < 16; ++x) {
                const rvol::Texel t = volume.levels[0].at(x, y, z, 0);
                const openvdb::Vec3d w = cellCentre(0, x, y, z);
                ASSERT_EQ(sampleWorld(*density, w), t.a) << x << "," << y << "," << z;
                if (t.a > 0)
                    expectVec(sampleWorld(*radiance, w), {t.r / t.a, t.g / t.a, t.b / t.a});
                else
                    ASSERT_EQ(sampleWorld(*radiance, w), openvdb::Vec3s(0.0f));
            }
    for (std::uint32_t d = 0; d < rvol::kDirections; ++d) {
        const auto rgb = grid<openvdb::Vec3SGrid>(f, "radiance_" + kDirs[d]);
        const auto a = grid<openvdb::FloatGrid>(f, "opacity_" + kDirs[d]);
        for (std::uint32_t z = 0; z < 8; ++z)
            for (std::uint32_t y = 0; y < 8; ++y)
                for (std::uint32_t x = 0; x < 8; ++x) {
                    const rvol::Texel t = volume.levels[1].at(x, y, z, d);
                    ASSERT_EQ(sampleWorld(*a, cellCentre(1, x, y, z)), t.a);
                    if (t.a > 0)
                        expectVec(sampleWorld(*rgb, cellCentre(1, x, y, z)),
                                  {t.r / t.a, t.g / t.a, t.b / t.a});
                }
    }

    // Static voxel attributes.
    const auto albedo = grid<openvdb::Vec3SGrid>(f, "albedo");
    const auto normal = grid<openvdb::Vec3SGrid>(f, "normal");
    const auto emission = grid<openvdb::Vec3SGrid>(f, "emission");
    const auto occlusion = grid<openvdb::FloatGrid>(f, "occlusion");
    expectVec(sampleWorld(*albedo, cellCentre(0, 3, 5, 7)), {0.5f, 0.25f, 0.125f});
    expectVec(sampleWorld(*normal, cellCentre(0, 3, 5, 7)), {0, 1, 0});
    EXPECT_FLOAT_EQ(sampleWorld(*occlusion, cellCentre(0, 3, 5, 7)), 0.3f);
    expectVec(sampleWorld(*emission, cellCentre(0, 9, 10, 2)), {2, 1, 0});
    expectVec(sampleWorld(*normal, cellCentre(0, 9, 10, 2)), {0, 0, -1});
    expectVec(sampleWorld(*albedo, cellCentre(0, 1, 1, 1)), {0.9f, 0.9f, 0.9f});
}

TEST(VdbExport, ActiveVoxelsAreTheNonZeroCells) {
    ScratchDir dir;
    const rvol::Volume volume = makeVolume();
    vox::exportVdb(dir / "bake.vdb", volume, {.allLevels = true});
    const VdbFile f = readVdb(dir / "bake.vdb");

    const auto [density, radiance] = nonZeroCells(volume.levels[0], 0);
    EXPECT_GT(density, radiance);  // the pattern has opaque black cells
    EXPECT_EQ(f.grids.at("density")->activeVoxelCount(), density);
    EXPECT_EQ(f.grids.at("radiance")->activeVoxelCount(), radiance);
    for (std::uint32_t l = 1; l <= kDepth; ++l)
        for (std::uint32_t d = 0; d < rvol::kDirections; ++d) {
            const std::string suffix = l == 1 ? "" : "_L" + std::to_string(l);
            const auto [a, rgb] = nonZeroCells(volume.levels[l], d);
            EXPECT_EQ(f.grids.at("opacity_" + kDirs[d] + suffix)->activeVoxelCount(), a)
                << l << kDirs[d];
            EXPECT_EQ(f.grids.at("radiance_" + kDirs[d] + suffix)->activeVoxelCount(), rgb)
                << l << kDirs[d];
        }
    EXPECT_EQ(f.grids.at("albedo")->activeVoxelCount(), 2u);  // one static voxel is black
    EXPECT_EQ(f.grids.at("normal")->activeVoxelCount(), 3u);
    EXPECT_EQ(f.grids.at("emission")->activeVoxelCount(), 1u);
    EXPECT_EQ(f.grids.at("occlusion")->activeVoxelCount(), 1u);
}

TEST(VdbExport, NoEmissionGridWithoutEmission) {
    ScratchDir dir;
    rvol::Volume volume = makeVolume();
    for (auto& v : volume.staticVoxels) v.emission = {0, 0, 0};
    vox::exportVdb(dir / "bake.vdb", volume);
    const VdbFile f = readVdb(dir / "bake.vdb");
    EXPECT_FALSE(f.grids.count("emission"));
    EXPECT_TRUE(f.grids.count("albedo"));
}

TEST(VdbExport, RepeatedExportsAreByteIdentical) {
    ScratchDir dir;
    const rvol::Volume volume = makeVolume();
    vox::exportVdb(dir / "a.vdb", volume, {.allLevels = true});
    vox::exportVdb(dir / "b.vdb", volume, {.allLevels = true});
    const std::vector<char> a = readBytes(dir / "a.vdb");
    EXPECT_GT(a.size(), 1000u);
    EXPECT_EQ(a, readBytes(dir / "b.vdb"));
    vox::exportVdb(dir / "a.vdb", volume, {.allLevels = true});  // replaces it in place
    EXPECT_EQ(a, readBytes(dir / "a.vdb"));
    EXPECT_EQ(dir.files(), (std::vector<std::string>{"a.vdb", "b.vdb"}));

    // The header's UUID is derived from the contents: another volume gets another one.
    rvol::Volume other = volume;
    other.levels[0].texels[0].a += 0.125f;
    vox::exportVdb(dir / "c.vdb", other, {.allLevels = true});
    const std::vector<char> c = readBytes(dir / "c.vdb");
    ASSERT_GT(c.size(), 57u);
    EXPECT_NE(std::string(a.begin() + 21, a.begin() + 57),
              std::string(c.begin() + 21, c.begin() + 57));
    EXPECT_EQ(a[21 + 8], '-');
    EXPECT_EQ(a[21 + 14], '8');  // version-8 (custom) UUID
    // io::File reports the UUID it read back.
    openvdb::io::File file((dir / "a.vdb").string());
    file.open();
    EXPECT_EQ(file.getUniqueTag(), std::string(a.begin() + 21, a.begin() + 57));
    file.close();
}

TEST(VdbExport, UnwritableTargetsThrowIoErrorAndLeaveNothing) {
    ScratchDir dir;
    const rvol::Volume volume = makeVolume();
    const auto expectIoError = [&](const fs::path& target) {
        try {
            vox::exportVdb(target, volume);
            ADD_FAILURE() << "no error for " << target;
        } catch (const vox::IoError& e) {
            EXPECT_NE(std::string(e.what()).find(target.string()), std::string::npos) << e.what();
        }
    };
    expectIoError(dir / "missing" / "bake.vdb");  // no such directory
    vox::test::writeText(dir / "plain", "a file, not a directory");
    expectIoError(dir / "plain" / "bake.vdb");
    fs::create_directory(dir / "taken.vdb");  // the rename onto a directory fails after writing
    expectIoError(dir / "taken.vdb");
    EXPECT_EQ(dir.files(), (std::vector<std::string>{"plain", "taken.vdb"}));
    EXPECT_TRUE(fs::is_empty(dir / "taken.vdb"));
    for (const auto& entry : fs::directory_iterator(dir.path()))
        EXPECT_FALSE(vox::AtomicFile::isTemporaryName(entry.path().filename().string()));
}

TEST(VdbExport, InconsistentVolumeIsInvalidData) {
    ScratchDir dir;
    rvol::Volume volume = makeVolume();
    volume.levels.pop_back();
    EXPECT_THROW(vox::exportVdb(dir / "bad.vdb", volume), vox::InvalidDataError);
    volume = makeVolume();
    volume.staticVoxels.push_back({});
    volume.staticVoxels.back().x = 16;
    EXPECT_THROW(vox::exportVdb(dir / "bad.vdb", volume), vox::InvalidDataError);
    EXPECT_TRUE(dir.files().empty());
}

TEST(VdbExport, DepthZeroHasNoDirectionalGrids) {
    ScratchDir dir;
    rvol::Volume volume;
    volume.depth = 0;
    volume.levels.resize(1);
    volume.levels[0].resolution = 1;
    volume.levels[0].blocks = {0};
    volume.levels[0].texels.assign(rvol::kBlockTexels, {});
    volume.levels[0].texels[0] = {0.5f, 0.5f, 0.5f, 0.5f};
    vox::exportVdb(dir / "one.vdb", volume, {.allLevels = true});
    const VdbFile f = readVdb(dir / "one.vdb");
    EXPECT_EQ(f.names,
              (std::vector<std::string>{"albedo", "density", "normal", "occlusion", "radiance"}));
    EXPECT_EQ(f.grids.at("density")->activeVoxelCount(), 1u);
    expectVec(grid<openvdb::Vec3SGrid>(f, "radiance")->tree().getValue(openvdb::Coord(0)),
              {1, 1, 1});
}

}  // namespace
