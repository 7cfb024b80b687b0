// A tiled radiance volume on the GPU (RvolGpuVolume over a TiledRvolReader, FinalGatherGpu,
// RvolResidency) on real GL (Mesa llvmpipe in CI): the Cornell box baked tiled at depth 6 (tiles
// of 16³ cells, far field of depth 5), sampled against the CPU's TiledRvolReader (tile borders
// included), gathered against the same cells as one single .rvol, served by the far field alone,
// and streamed along a camera path within a budget.
#include <vox/final_gather.h>
#include <vox/formats/rvol_io.h>
#include <vox/formats/rvol_tiles.h>
#include <vox/import.h>
#include <vox/radiance_tiles.h>
#include <vox/triangle_raycast.h>
#include <vox/runtime/final_gather_gpu.h>
#include <vox/runtime/gl_context.h>
#include <vox/runtime/rvol_gpu_volume.h>
#include <vox/runtime/rvol_residency.h>

#include "cornell_box.h"
#include "gl_test_context.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <random>

namespace fs = std::filesystem;
namespace rt = vox::runtime;

namespace {

/// The Cornell box baked tiled once (depth 6, tile depth 4, halo 8: far field of depth 5).
struct Baked {
    vox::test::ScratchDir dir;
    vox::Scene scene;
    fs::path index;
    std::unique_ptr<vox::rvol::TiledRvolReader> reader;
};

const Baked& baked() {
    static const std::unique_ptr<Baked> b = [] {
        auto out = std::make_unique<Baked>();
        out->scene = vox::importScene(vox::scenes::writeCornellBox(out->dir.path()));
        vox::RadianceBakeOptions options;
        options.bounces = 1;
        out->index = out->dir.path() / "tiled.rvol";
        vox::bakeTiledRadiance(out->scene, options, vox::RadianceTiling::plan(6, 4, 8), {},
                               out->index, {});
        out->reader = std::make_unique<vox::rvol::TiledRvolReader>(out->index);
        return out;
    }();
    return *b;
}

vox::Vec3f f3(vox::Vec3d v) { return vox::vec3Cast<float>(v); }

/// Whether the trilinear filter at @p p on @p level reads cells of more than one tile.
bool crossesTileBorder(const vox::rvol::TileIndex& index, std::uint32_t level,
                       const vox::Vec3f& p) {
    if (level > index.tileDepth) return false;
    const std::uint32_t resolution = 1u << (index.depth - level);
    const std::uint32_t tileCells = 1u << (index.tileDepth - level);
    const double cell = index.cellSize() * double(1u << level);
    for (std::size_t a = 0; a < 3; ++a) {
        const double u =
            std::clamp((double(p[a]) - index.origin[a]) / cell - 0.5, 0.0, double(resolution - 1));
        const auto c0 = static_cast<std::uint32_t>(std::floor(u));
        const std::uint32_t c1 = std::min(c0 + 1, resolution - 1);
        if (c0 / tileCells != c1 / tileCells) return true;
    }
    return false;
}

/// Whether every cell the trilinear filter at @p p on @p level reads lies in a tile the index does
/// not list (all zero, so never missing); false above the tiles.
bool onlyAbsentTiles(const vox::rvol::TiledRvolReader& reader, std::uint32_t level,
                     const vox::Vec3f& p) {
    const vox::rvol::TileIndex& index = reader.index();
    if (level > index.tileDepth) return false;
    const std::uint32_t resolution = 1u << (index.depth - level);
    const std::uint32_t shift = index.tileDepth - level;
    const double cell = index.cellSize() * double(1u << level);
    std::uint32_t c[2][3];
    for (std::size_t a = 0; a < 3; ++a) {
        const double u =
            std::clamp((double(p[a]) - index.origin[a]) / cell - 0.5, 0.0, double(resolution - 1));
        c[0][a] = static_cast<std::uint32_t>(std::floor(u));
        c[1][a] = std::min(c[0][a] + 1, resolution - 1);
    }
    for (int corner = 0; corner < 8; ++corner)
        if (reader.findTile(c[corner & 1][0] >> shift, c[(corner >> 1) & 1][1] >> shift,
                            c[(corner >> 2) & 1][2] >> shift) >= 0)
            return false;
    return true;
}

/// Queries at every level: random points, and points within half a cell of a tile border.
std::vector<rt::FinalGatherGpu::SampleQuery> borderAndRandomQueries(
    const vox::rvol::TileIndex& index, int count) {
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> pos(0.0, 1.0), unit(-1, 1), half(-0.5, 0.5);
    std::uniform_int_distribution<std::uint32_t> tileBorder(
        1, (1u << (index.depth - index.tileDepth)) - 1);
    std::vector<rt::FinalGatherGpu::SampleQuery> queries;
    for (int i = 0; i < count; ++i) {
        const auto level = static_cast<std::uint32_t>(i % int(index.depth + 1));
        const double cell = index.cellSize() * double(1u << level);
        vox::Vec3d p{};
        for (std::size_t a = 0; a < 3; ++a) {
            p[a] = index.origin[a] + pos(rng) * index.size;
            // Two of three queries on a tile border along this axis (at most half a cell off).
            if (i % 3 != 0 && (i / 3 + int(a)) % 2 == 0)
                p[a] = index.origin[a] + tileBorder(rng) * index.tileSize() + half(rng) * cell;
        }
        vox::Vec3d d{unit(rng), unit(rng), unit(rng)};
        if (i % 5 == 0) d.x = 0;
        if (vox::length(d) < 1e-3) d = {0, 0, 1};
        queries.push_back({level, f3(p), f3(vox::normalize(d))});
    }
    return queries;
}

/// The volume the tiled one describes, as one single-volume Volume: every cell of every level
/// read from the CPU's TiledRvolReader (tiles at levels ≤ T, the far field above).
vox::rvol::Volume assembled(const vox::rvol::TiledRvolReader& reader) {
    const vox::rvol::TileIndex& index = reader.index();
    vox::rvol::Volume v;
    v.origin = index.origin;
    v.size = index.size;
    v.depth = index.depth;
    v.bake = index.bake;
    constexpr std::uint32_t kB = vox::rvol::kBlockCells;
    for (std::uint32_t l = 0; l <= index.depth; ++l) {
        vox::rvol::Level level;
        level.resolution = 1u << (index.depth - l);
        level.channels = vox::rvol::levelChannels(l);
        const std::uint32_t blocks = (level.resolution + kB - 1) / kB;
        std::vector<vox::rvol::Texel> texels(std::size_t{level.channels} * vox::rvol::kBlockTexels);
        for (std::uint64_t code = 0; code < std::uint64_t{blocks} * blocks * blocks; ++code) {
            const auto b = vox::rvol::demorton3(code);
            if (b[0] >= blocks || b[1] >= blocks || b[2] >= blocks) continue;
            bool any = false;
            std::fill(texels.begin(), texels.end(), vox::rvol::Texel{});
            for (std::uint32_t c = 0; c < level.channels; ++c)
                for (std::uint32_t z = b[2] * kB; z < std::min((b[2] + 1) * kB, level.resolution);
                     ++z)
                    for (std::uint32_t y = b[1] * kB;
                         y < std::min((b[1] + 1) * kB, level.resolution); ++y)
                        for (std::uint32_t x = b[0] * kB;
                             x < std::min((b[0] + 1) * kB, level.resolution); ++x) {
                            const vox::rvol::Texel t = reader.cell(l, c, x, y, z);
                            texels[vox::rvol::Level::texelIndex(0, level.channels, c, x, y, z)] = t;
                            any = any || t.r != 0 || t.g != 0 || t.b != 0 || t.a != 0;
                        }
            if (!any) continue;
            level.blocks.push_back(code);
            level.texels.insert(level.texels.end(), texels.begin(), texels.end());
        }
        v.levels.push_back(std::move(level));
    }
    return v;
}

/// The shading points of the Cornell box seen by a 64×48 camera (float-rounded).
std::vector<rt::GpuShadingPoint> shadingPoints(const vox::Scene& scene,
                                               const vox::PinholeCamera& camera) {
    const vox::TriangleRayCaster caster(scene);
    std::vector<rt::GpuShadingPoint> points;
    for (int y = 0; y < camera.height; ++y)
        for (int x = 0; x < camera.width; ++x) {
            vox::ShadingPoint p;
            if (vox::sceneShadingPoint(scene, caster, camera.rayThrough(x, y), camera.pixelAngle(),
                                       p))
                points.push_back(
                    {f3(p.position), f3(p.normal), f3(p.albedo), f3(p.emission), f3(p.view)});
        }
    return points;
}

vox::PinholeCamera frontCamera() {
    vox::PinholeCamera camera;
    camera.eye = {0, 1, 3.2};
    camera.target = {0, 1, 0};
    camera.fovYDegrees = 50;
    camera.width = 64;
    camera.height = 48;
    return camera;
}

std::vector<vox::PunctualLight> lightsOf(const vox::Scene& scene) {
    std::vector<vox::PunctualLight> lights;
    for (const vox::Light& l : scene.lights) lights.push_back(l);
    return lights;
}

/// The largest |gpu − cpu| over the queries, relative to the largest CPU value (radiance and
/// opacity alike), and how many queries had a non-zero CPU sample.
struct SampleError {
    double worst = 0;
    std::size_t nonZero = 0;
};
SampleError compare(const std::vector<std::array<float, 4>>& gpu,
                    const std::vector<vox::rvol::Texel>& cpu) {
    double maxValue = 0, maxError = 0;
    SampleError out;
    for (std::size_t i = 0; i < cpu.size(); ++i) {
        const float c[4] = {cpu[i].r, cpu[i].g, cpu[i].b, cpu[i].a};
        out.nonZero += c[3] > 0;
        for (int k = 0; k < 4; ++k) {
            maxValue = std::max(maxValue, double(std::abs(c[k])));
            maxError = std::max(maxError, std::abs(double(c[k]) - double(gpu[i][std::size_t(k)])));
        }
    }
    out.worst = maxValue > 0 ? maxError / maxValue : maxError;
    return out;
}

/// The CPU's samples (TiledRvolReader's or RvolReader's) at the queries' levels less @p
/// levelOffset.
template <class Sampler>
std::vector<vox::rvol::Texel> cpuSamples(
    const Sampler& sampler, const std::vector<rt::FinalGatherGpu::SampleQuery>& queries,
    std::uint32_t levelOffset = 0) {
    std::vector<vox::rvol::Texel> out;
    for (const auto& q : queries) {
        const std::uint32_t level = std::max(q.level, levelOffset) - levelOffset;
        out.push_back(sampler.sampleDirectional(level,
                                                {q.position[0], q.position[1], q.position[2]},
                                                {q.direction[0], q.direction[1], q.direction[2]}));
    }
    return out;
}

}  // namespace

TEST(TiledRvolGpu, SamplesEqualTheCpuTiledReaderAtEveryLevelAndAcrossTileBorders) {
    REQUIRE_GL();
    const Baked& b = baked();
    const vox::rvol::TileIndex& index = b.reader->index();
    ASSERT_EQ(index.farDepth, 5u);
    const rt::RvolGpuVolume volume(*gl, *b.reader);
    EXPECT_EQ(volume.residentTiles(), index.tiles.size());
    EXPECT_LT(index.tiles.size(), 64u) << "some tiles of the box are empty: absent from the index";
    const auto queries = borderAndRandomQueries(index, 4200);
    std::size_t crossing = 0;
    for (const auto& q : queries) crossing += crossesTileBorder(index, q.level, q.position);
    EXPECT_GT(crossing, queries.size() / 4);
    const auto cpu = cpuSamples(*b.reader, queries);
    // texelFetch: float rounding only. The texture unit inside a tile (GL_R8 opacity comes back at
    // 8 bits on llvmpipe, as for a single volume), fetches across tile borders.
    for (const bool hardware : {false, true}) {
        rt::FinalGatherGpu gather(*gl, {.hardwareFilter = hardware, .tiledVolumes = true});
        const auto gpu = gather.sample(volume, queries);
        const SampleError e = compare(gpu, cpu);
        std::vector<std::array<float, 4>> gpuCrossing;
        std::vector<vox::rvol::Texel> cpuCrossing;
        for (std::size_t i = 0; i < queries.size(); ++i)
            if (crossesTileBorder(index, queries[i].level, queries[i].position)) {
                gpuCrossing.push_back(gpu[i]);
                cpuCrossing.push_back(cpu[i]);
            }
        const SampleError border = compare(gpuCrossing, cpuCrossing);
        std::printf(
            "[ tiled gpu ] %s: %zu queries (%zu across tile borders, %zu of them solid): max "
            "|error| / max %.3g, across borders %.3g\n",
            hardware ? "hardware" : "texelFetch", queries.size(), crossing, border.nonZero, e.worst,
            border.worst);
        EXPECT_GT(border.nonZero, crossing / 10);
        EXPECT_LT(border.worst, 1e-5);
        EXPECT_LT(e.worst, hardware ? 0.2 : 1e-5);
        EXPECT_EQ(gather.lastHoles(), 0u);
        EXPECT_EQ(gather.lastFallbacks(), 0u);
    }
    EXPECT_EQ(gl->errorCount(), 0u) << gl->errorSummary();
}

TEST(TiledRvolGpu, GatherEqualsTheGatherOverTheSameCellsAsOneSingleVolume) {
    REQUIRE_GL();
    const Baked& b = baked();
    const fs::path single = b.dir.path() / "assembled.rvol";
    vox::rvol::writeRvol(single, assembled(*b.reader));
    const vox::rvol::RvolReader singleReader(single);
    const rt::RvolGpuVolume tiledVolume(*gl, *b.reader), singleVolume(*gl, singleReader);
    const auto points = shadingPoints(b.scene, frontCamera());
    ASSERT_GT(points.size(), 2000u);
    const auto lights = lightsOf(b.scene);
    rt::FinalGatherGpuOptions options;
    options.aoLambda = b.reader->index().bake.aoLambda;
    options.hardwareFilter = false;
    options.tiledVolumes = true;
    rt::FinalGatherGpu gather(*gl, options);
    const auto tiled = gather.shade(tiledVolume, points, lights);
    const double tiledSeconds = gather.lastSeconds();
    const auto reference = gather.shade(singleVolume, points, lights);
    double worst = 0, peak = 0;
    for (std::size_t i = 0; i < points.size(); ++i)
        for (std::size_t c = 0; c < 3; ++c) {
            peak = std::max(peak, double(reference[i].final[c]));
            worst = std::max({worst, std::abs(double(tiled[i].final[c] - reference[i].final[c])),
                              std::abs(double(tiled[i].indirect[c] - reference[i].indirect[c]))});
        }
    std::printf("[ tiled gpu ] %zu points: max |tiled − single| / max %.3g (gather %.3f s)\n",
                points.size(), worst / peak, tiledSeconds);
    EXPECT_GT(peak, 0);
    EXPECT_LT(worst / peak, 1e-4);
    EXPECT_EQ(gl->errorCount(), 0u) << gl->errorSummary();
}

TEST(TiledRvolGpu, TheFarFieldAloneServesWhereNoTileIsResidentAndNothingIsAHole) {
    REQUIRE_GL();
    const Baked& b = baked();
    const vox::rvol::TileIndex& index = b.reader->index();
    const vox::rvol::RvolReader& far = b.reader->farField();
    rt::RvolGpuVolume volume(*gl, *b.reader, {.uploadAll = false, .atlasBytes = 4u << 20});
    const auto queries = borderAndRandomQueries(index, 1400);
    rt::FinalGatherGpu gather(*gl, {.hardwareFilter = false, .tiledVolumes = true});
    // A shader compiled for single volumes refuses a tiled one rather than mis-sample its borders.
    EXPECT_THROW((void)rt::FinalGatherGpu(*gl).sample(volume, queries), rt::RuntimeError);
    // Nothing resident: every query where the volume has radiance is a hole; none that reads only
    // tiles the index leaves out (zero, as the format says: nothing missing there) is.
    std::size_t absent = 0, tiled = 0, radiant = 0;
    const auto whole = cpuSamples(*b.reader, queries);
    for (std::size_t i = 0; i < queries.size(); ++i) {
        absent += onlyAbsentTiles(*b.reader, queries[i].level, queries[i].position);
        tiled += queries[i].level <= index.tileDepth;
        radiant += whole[i].a > 0;
    }
    EXPECT_GT(absent, 0u);
    (void)gather.sample(volume, queries);
    EXPECT_GE(gather.lastHoles(), radiant);
    EXPECT_LE(gather.lastHoles(), queries.size() - absent);
    for (std::uint32_t l = 0; l < far.levels().size(); ++l)
        for (std::uint32_t i = 0; i < far.level(l).brickCount; ++i)
            ASSERT_TRUE(volume.uploadBrick({rt::kBaseFile, l, i}));
    EXPECT_EQ(volume.residentTiles(), 0u);
    // The far field alone: level l is its level max(l, D − F) − (D − F).
    const auto gpu = gather.sample(volume, queries);
    const SampleError e = compare(gpu, cpuSamples(far, queries, index.depth - index.farDepth));
    std::printf(
        "[ tiled gpu ] far field alone: max |error| / max %.3g, %u of %zu queries fell back\n",
        e.worst, gather.lastFallbacks(), queries.size());
    EXPECT_LT(e.worst, 1e-5);
    EXPECT_GT(e.nonZero, queries.size() / 10);
    EXPECT_EQ(gather.lastHoles(), 0u);
    EXPECT_EQ(gather.lastFallbacks(), tiled - absent);
    EXPECT_EQ(gl->errorCount(), 0u) << gl->errorSummary();
}

TEST(TiledRvolResidency, ABudgetedFlightIntoTheBoxLeavesNoHolesAndNeverOpensFarTiles) {
    REQUIRE_GL();
    const Baked& b = baked();
    // A copy of the volume without the tiles the flight never needs: those whose finest cells
    // (the level below the far field's) look smaller than lodScale pixels from every eye. A
    // residency that opened them would fail.
    // (In baked()'s directory: a ScratchDir of this test's name is that one when it runs alone.)
    const fs::path flightDir = b.dir.path() / "flight";
    fs::create_directories(flightDir);
    const fs::path index = flightDir / "tiled.rvol";
    fs::copy_file(b.index, index);
    fs::copy(vox::rvol::tileDirectory(b.index), vox::rvol::tileDirectory(index));
    const vox::rvol::TiledRvolReader reader(index);
    const vox::rvol::TileIndex& tiles = reader.index();
    std::vector<vox::PinholeCamera> flight;
    for (int f = 0; f < 8; ++f) {
        vox::PinholeCamera c = frontCamera();
        const double t = f / 7.0;
        c.eye = {-0.6 + 1.0 * t, 0.5 + 0.8 * t, 3.0 - 2.6 * t};  // from outside to the back
        c.target = {0.2, 0.9, -1.0};
        flight.push_back(c);
    }
    const double lodScale = 2;
    const double farthestNeeded = tiles.cellSize() / (lodScale * flight[0].pixelAngle());
    std::size_t deleted = 0;
    for (std::uint32_t t = 0; t < tiles.tiles.size(); ++t) {
        const auto& e = tiles.tiles[t];
        const auto o = tiles.tileOrigin(e.x, e.y, e.z);
        double nearest = 1e30;
        for (const auto& c : flight) {
            double d2 = 0;
            for (std::size_t a = 0; a < 3; ++a) {
                const double g =
                    std::max({0.0, o[a] - c.eye[a], c.eye[a] - (o[a] + tiles.tileSize())});
                d2 += g * g;
            }
            nearest = std::min(nearest, std::sqrt(d2));
        }
        if (nearest > farthestNeeded)
            deleted += fs::remove(vox::rvol::tilePath(index, e.x, e.y, e.z));
    }
    EXPECT_GT(deleted, tiles.tiles.size() / 4);

    // The budget: a quarter of every brick's bytes (the far field's and the tiles').
    const rt::RvolGpuVolume full(*gl, *b.reader);
    std::uint64_t total = 0;
    const auto addFile = [&](std::uint32_t file) {
        const std::shared_ptr<const vox::rvol::RvolReader> r = full.fileReader(file);
        for (std::uint32_t l = 0; l < r->levels().size(); ++l)
            for (std::uint32_t i = 0; i < r->level(l).brickCount; ++i)
                total += full.brickBytes({file, l, i});
    };
    addFile(rt::kBaseFile);
    for (std::uint32_t t = 0; t < tiles.tiles.size(); ++t) addFile(t);
    const std::uint64_t budget = total / 4;
    rt::RvolGpuVolume volume(*gl, reader, {.uploadAll = false, .atlasBytes = budget});
    rt::RvolResidency residency(volume, budget, lodScale);

    const auto lights = lightsOf(b.scene);
    rt::FinalGatherGpuOptions options;
    options.aoLambda = tiles.bake.aoLambda;
    options.hardwareFilter = false;
    options.tiledVolumes = true;
    rt::FinalGatherGpu gather(*gl, options);
    std::uint32_t uploaded = 0, evicted = 0, tilesUploaded = 0, tilesEvicted = 0, maxTiles = 0;
    std::uint64_t fallbacks = 0;
    double worstPsnr = 1e9;
    for (std::size_t f = 0; f < flight.size(); ++f) {
        const rt::RvolResidency::Update u = residency.update(flight[f]);
        EXPECT_LE(u.residentBytes, budget) << "frame " << f;
        EXPECT_EQ(u.residentTiles, volume.residentTiles());
        const auto points = shadingPoints(b.scene, flight[f]);
        ASSERT_GT(points.size(), 500u);
        const auto streamed = gather.shade(volume, points, lights);
        const std::uint32_t holes = gather.lastHoles(), fellBack = gather.lastFallbacks();
        EXPECT_EQ(holes, 0u) << "frame " << f;
        const auto reference = gather.shade(full, points, lights);
        double sumSq = 0, peak = 0;
        for (std::size_t i = 0; i < points.size(); ++i)
            for (std::size_t c = 0; c < 3; ++c) {
                const double d = double(streamed[i].final[c]) - reference[i].final[c];
                sumSq += d * d;
                peak = std::max(peak, double(reference[i].final[c]));
            }
        const double psnr = 10 * std::log10(peak * peak * double(3 * points.size()) / sumSq);
        worstPsnr = std::min(worstPsnr, psnr);
        std::printf(
            "[ tiled gpu ] frame %zu: %u bricks up, %u evicted, %u tiles up, %u evicted, %u "
            "resident (%llu of %llu bytes), %u left out; %zu points, %u fell back, %u holes, final "
            "%.1f dB against every brick, gather %.2f s\n",
            f, u.uploaded, u.evicted, u.tilesUploaded, u.tilesEvicted, u.residentTiles,
            static_cast<unsigned long long>(u.residentBytes),
            static_cast<unsigned long long>(budget), u.neededNotFitting, points.size(), fellBack,
            holes, psnr, gather.lastSeconds());
        uploaded += u.uploaded;
        evicted += u.evicted;
        tilesUploaded += u.tilesUploaded;
        tilesEvicted += u.tilesEvicted;
        maxTiles = std::max(maxTiles, u.residentTiles);
        fallbacks += fellBack;
    }
    EXPECT_GT(uploaded, 0u);
    EXPECT_GT(evicted, 0u) << "the flight moves the fine bricks";
    EXPECT_GT(tilesUploaded, 0u);
    EXPECT_GT(fallbacks, 0u) << "the budget must leave needed bricks out";
    EXPECT_LT(maxTiles, tiles.tiles.size() - deleted);
    // The PSNR against every brick measures the clipmap's level of detail (lodScale 2), not a
    // fault: printed, not asserted.
    std::printf(
        "[ tiled gpu ] %zu of %zu tile files deleted, never opened; tiles uploaded %u, evicted %u; "
        "worst final %.1f dB\n",
        deleted, tiles.tiles.size(), tilesUploaded, tilesEvicted, worstPsnr);
    EXPECT_EQ(gl->errorCount(), 0u) << gl->errorSummary();
}
