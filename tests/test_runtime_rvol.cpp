// The radiance volume on the GPU (RvolGpuVolume) and the final gather shader (FinalGatherGpu)
// against the CPU reference on real GL (Mesa llvmpipe in CI): a Cornell box baked at depth 5,
// written and read back as .rvol, sampled at random points and final-gathered at the surface
// points of a 64×48 camera by RadianceField / FinalGather and by the shader.
#include <vox/final_gather.h>
#include <vox/formats/rvol_io.h>
#include <vox/import.h>
#include <vox/radiance.h>
#include <vox/radiance_field.h>
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
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <random>

namespace fs = std::filesystem;
namespace rt = vox::runtime;
using vox::Vec3d;

namespace {

/// The Cornell box baked once (depth 5, one bounce), through an .rvol file: the reader, the volume
/// it reads (the CPU reference samples the same decoded texels the GPU holds) and its field.
struct Baked {
    vox::test::ScratchDir dir;
    vox::Scene scene;
    fs::path file;
    std::unique_ptr<vox::rvol::RvolReader> reader;
    vox::rvol::Volume volume;
    std::unique_ptr<vox::RadianceField> field;
};

const Baked& baked() {
    static const std::unique_ptr<Baked> b = [] {
        auto out = std::make_unique<Baked>();
        out->scene = vox::importScene(vox::scenes::writeCornellBox(out->dir.path()));
        vox::RadianceBakeOptions options;
        options.depth = 5;
        options.bounces = 1;
        const vox::RadianceBake bake = vox::bakeRadiance(out->scene, options);
        out->file = out->dir.path() / "cornell.rvol";
        vox::rvol::writeRvol(out->file, bake.volume);
        out->reader = std::make_unique<vox::rvol::RvolReader>(out->file);
        out->volume = out->reader->readVolume();
        out->field = std::make_unique<vox::RadianceField>(out->volume);
        return out;
    }();
    return *b;
}

vox::Vec3f f3(Vec3d v) { return vox::vec3Cast<float>(v); }

/// The surface points a 64×48 (@p width × @p height) camera sees in the box, as the CPU and the
/// GPU shade them (the float-rounded point on both sides).
struct CameraPoints {
    std::vector<vox::ShadingPoint> points;
    std::vector<rt::GpuShadingPoint> gpuPoints;
};

CameraPoints cameraPoints(const vox::Scene& scene, int width, int height) {
    vox::PinholeCamera camera;
    camera.eye = {0, 1, 3.2};
    camera.target = {0, 1, 0};
    camera.fovYDegrees = 50;
    camera.width = width;
    camera.height = height;
    const vox::TriangleRayCaster caster(scene);
    CameraPoints out;
    for (int y = 0; y < camera.height; ++y)
        for (int x = 0; x < camera.width; ++x) {
            vox::ShadingPoint p;
            if (!vox::sceneShadingPoint(scene, caster, camera.rayThrough(x, y),
                                        camera.pixelAngle(), p))
                continue;
            const rt::GpuShadingPoint g{f3(p.position), f3(p.normal), f3(p.albedo), f3(p.emission),
                                        f3(p.view)};
            p = {{g.position[0], g.position[1], g.position[2]},
                 {g.normal[0], g.normal[1], g.normal[2]},
                 {g.albedo[0], g.albedo[1], g.albedo[2]},
                 {g.emission[0], g.emission[1], g.emission[2]},
                 {g.view[0], g.view[1], g.view[2]}};
            out.points.push_back(p);
            out.gpuPoints.push_back(g);
        }
    return out;
}

/// PSNR over points of one term: peak the reference's largest component.
struct Psnr {
    double sumSq = 0, peak = 0;
    std::size_t count = 0;
    void add(const double* ref, const float* gpu, int n) {
        for (int c = 0; c < n; ++c) {
            const double d = ref[c] - double(gpu[c]);
            sumSq += d * d;
            peak = std::max(peak, std::abs(ref[c]));
            ++count;
        }
    }
    [[nodiscard]] double db() const {
        const double mse = sumSq / double(std::max<std::size_t>(count, 1));
        return mse > 0 ? 10 * std::log10(peak * peak / mse) : 999.0;
    }
};

}  // namespace

TEST(RvolGpuVolume, UploadsEveryBrickIntoAtlasSlotsAndEvictedBricksFallBackToTheLevelAbove) {
    REQUIRE_GL();
    const Baked& b = baked();
    rt::RvolGpuVolume volume(*gl, *b.reader);
    EXPECT_EQ(volume.residentBricks(), b.reader->header().brickCount);
    // A slot per plane the file stores; the planes it leaves out (all zero) take the zero slot.
    std::uint64_t rgbPlanes = 0, alphaPlanes = 0, densePlanes = 0;
    for (std::uint32_t l = 0; l < b.reader->levels().size(); ++l) {
        const std::uint32_t channels = l == 0 ? 1 : 6;
        for (const vox::rvol::BrickEntry& e : b.reader->bricks(l)) {
            rgbPlanes +=
                static_cast<std::uint64_t>(std::popcount(e.planes & ((1u << channels) - 1)));
            alphaPlanes +=
                static_cast<std::uint64_t>(std::popcount(unsigned{e.planes} >> channels));
        }
        densePlanes += b.reader->level(l).brickCount * (l == 0 ? 1 : 6);
    }
    EXPECT_TRUE(b.reader->header().binaryLevel0Opacity());
    EXPECT_LT(rgbPlanes, densePlanes) << "some directional planes are all zero";
    EXPECT_EQ(volume.rgbSlots().used(), rgbPlanes);
    EXPECT_EQ(volume.alphaSlots().used(), alphaPlanes);
    EXPECT_GT(volume.residentBytes(), volume.usedAtlasBytes());
    std::printf(
        "[ rvol gpu ] %llu bricks, RGB atlas %u×%u×%u slots (%u used), A8 atlas %u×%u×%u slots (%u "
        "used), resident %llu bytes "
        "(atlas slots in use %llu, indirection %llu), uploaded %llu bytes\n",
        static_cast<unsigned long long>(volume.residentBricks()), volume.rgbSlotGrid()[0],
        volume.rgbSlotGrid()[1], volume.rgbSlotGrid()[2], volume.rgbSlots().used(),
        volume.alphaSlotGrid()[0], volume.alphaSlotGrid()[1], volume.alphaSlotGrid()[2],
        volume.alphaSlots().used(), static_cast<unsigned long long>(volume.residentBytes()),
        static_cast<unsigned long long>(volume.usedAtlasBytes()),
        static_cast<unsigned long long>(volume.indirectionBytes()),
        static_cast<unsigned long long>(volume.uploadedBytesTotal()));

    // Evicting a level-1 brick frees its slots (one per stored plane) and makes it sample as the
    // level above; uploading it again reuses them and restores the samples.
    rt::FinalGatherGpu gather(*gl, {.hardwareFilter = false});
    const vox::rvol::BrickEntry e = b.reader->bricks(1)[0];
    const double cell = b.reader->header().cellSize(1);
    const auto& o = b.reader->header().origin;
    std::vector<rt::FinalGatherGpu::SampleQuery> queries;
    for (int i = 0; i < 27; ++i) {
        // Points strictly inside the brick's cells (cell centres 1 … N − 2 of the brick and
        // between).
        const double u[3] = {e.x * 4.0 + 1 + 0.5 * (i % 3), e.y * 4.0 + 1 + 0.5 * (i / 3 % 3),
                             e.z * 4.0 + 1 + 0.5 * (i / 9)};
        queries.push_back({1,
                           {float(o[0] + (u[0] + 0.5) * cell), float(o[1] + (u[1] + 0.5) * cell),
                            float(o[2] + (u[2] + 0.5) * cell)},
                           {0.3f, -0.5f, 0.8f}});
    }
    const auto before = gather.sample(volume, queries);
    double total = 0;
    for (const auto& s : before) total += s[0] + s[1] + s[2] + s[3];
    EXPECT_GT(total, 0);
    const std::uint32_t rgbUsed = volume.rgbSlots().used(), alphaUsed = volume.alphaSlots().used();
    volume.evictBrick({rt::kBaseFile, 1, 0});
    EXPECT_FALSE(volume.resident({rt::kBaseFile, 1, 0}));
    EXPECT_EQ(volume.rgbSlots().used(), rgbUsed - std::popcount(e.planes & 0x3Fu));
    EXPECT_EQ(volume.alphaSlots().used(), alphaUsed - std::popcount(unsigned{e.planes} >> 6));
    // A missing brick is not empty: samples there fall back to the level above, which holds.
    std::vector<rt::FinalGatherGpu::SampleQuery> coarser = queries;
    for (auto& q : coarser) q.level = 2;
    EXPECT_EQ(gather.sample(volume, queries), gather.sample(volume, coarser));
    double fallback = 0;
    for (const auto& s : gather.sample(volume, queries)) fallback += s[0] + s[1] + s[2] + s[3];
    EXPECT_GT(fallback, 0);
    ASSERT_TRUE(volume.uploadBrick({rt::kBaseFile, 1, 0}));
    EXPECT_EQ(volume.rgbSlots().used(), rgbUsed);
    EXPECT_EQ(gather.sample(volume, queries), before);
    EXPECT_EQ(gl->errorCount(), 0u) << gl->errorSummary();
}

TEST(FinalGatherGpu, SamplesMatchRadianceFieldAtRandomPointsLevelsAndDirections) {
    REQUIRE_GL();
    const Baked& b = baked();
    const rt::RvolGpuVolume volume(*gl, *b.reader);
    const rt::RvolGpuVolume volume16(*gl, *b.reader, {.alpha16 = true});
    const auto& h = b.reader->header();
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> pos(-0.05, 1.05), unit(-1, 1);
    std::vector<rt::FinalGatherGpu::SampleQuery> queries;
    std::vector<Vec3d> points, dirs;
    const std::uint32_t levels = h.levelCount;
    for (int i = 0; i < 6000; ++i) {
        const Vec3d p{h.origin[0] + pos(rng) * h.size, h.origin[1] + pos(rng) * h.size,
                      h.origin[2] + pos(rng) * h.size};
        Vec3d d{unit(rng), unit(rng), unit(rng)};
        if (i % 5 == 0)
            d.x = 0;  // directions in a plane or along an axis: combineDirectional's skipped axes
        if (i % 7 == 0) d.y = 0;
        if (length(d) < 1e-3) d = {0, 0, 1};
        d = normalize(d);
        const auto level = static_cast<std::uint32_t>(i % levels);
        // Round the point and direction to float first: both sides see the same inputs.
        const auto pf = f3(p), df = f3(d);
        queries.push_back({level, pf, df});
        points.push_back({pf[0], pf[1], pf[2]});
        dirs.push_back({df[0], df[1], df[2]});
    }
    struct Variant {
        const char* name;
        bool hardware;
        const rt::RvolGpuVolume* volume;
        double bound;  // of max |error| / max, radiance and opacity, every level
    };
    // texelFetch with float weights: float rounding only. The texture unit: RGB9E5 is filtered in
    // float on llvmpipe, but a filtered GL_R8 comes back at 8 bits (up to 1/255 off, and the
    // directional opacity's log(1 − a) turns that into up to 0.1 near a = 1): GL_R16 fixes it.
    for (const Variant& v : {Variant{"texelFetch, R8", false, &volume, 1e-5},
                             Variant{"hardware, R16", true, &volume16, 1e-4},
                             Variant{"hardware, R8", true, &volume, 0.2}}) {
        const bool hardware = v.hardware;
        rt::FinalGatherGpu gather(*gl, {.hardwareFilter = hardware});
        const auto gpu = gather.sample(*v.volume, queries);
        std::vector<double> maxRgb(levels, 0), maxA(levels, 0), errRgb(levels, 0), errA(levels, 0);
        std::size_t nonZero = 0;
        for (std::size_t i = 0; i < queries.size(); ++i) {
            const std::uint32_t l = queries[i].level;
            const vox::rvol::Texel c = b.field->sample(l, points[i], dirs[i]);
            if (c.a > 0) ++nonZero;
            maxRgb[l] = std::max({maxRgb[l], double(c.r), double(c.g), double(c.b)});
            maxA[l] = std::max(maxA[l], double(c.a));
            errRgb[l] =
                std::max({errRgb[l], std::abs(double(c.r) - gpu[i][0]),
                          std::abs(double(c.g) - gpu[i][1]), std::abs(double(c.b) - gpu[i][2])});
            errA[l] = std::max(errA[l], std::abs(double(c.a) - gpu[i][3]));
        }
        EXPECT_GT(nonZero, queries.size() / 10);
        double worstRgb = 0, worstA = 0;
        for (std::uint32_t l = 0; l < levels; ++l) {
            const double rgb = maxRgb[l] > 0 ? errRgb[l] / maxRgb[l] : errRgb[l];
            const double a = maxA[l] > 0 ? errA[l] / maxA[l] : errA[l];
            std::printf(
                "[ rvol gpu ] %s, level %u: max |error| / max: radiance %.3g (max %.4g), opacity "
                "%.3g\n",
                v.name, l, rgb, maxRgb[l], a);
            worstRgb = std::max(worstRgb, rgb);
            worstA = std::max(worstA, a);
        }
        EXPECT_LT(worstRgb, v.bound) << v.name;
        EXPECT_LT(worstA, v.bound) << v.name;
    }
    EXPECT_EQ(gl->errorCount(), 0u) << gl->errorSummary();
}

TEST(FinalGatherGpu, FinalGatherMatchesTheCpuAtA64x48CamerasSurfacePoints) {
    REQUIRE_GL();
    const Baked& b = baked();
    const rt::RvolGpuVolume volume(*gl, *b.reader);
    const rt::RvolGpuVolume volume16(*gl, *b.reader, {.alpha16 = true});
    const CameraPoints cam = cameraPoints(b.scene, 64, 48);
    const auto& points = cam.points;
    const auto& gpuPoints = cam.gpuPoints;
    ASSERT_GT(points.size(), 2000u);
    std::vector<vox::PunctualLight> lights;
    for (const vox::Light& l : b.scene.lights) lights.push_back(l);
    ASSERT_EQ(lights.size(), 3u);

    vox::FinalGatherOptions cpuOptions;
    cpuOptions.aoLambda = b.reader->header().bake.aoLambda;
    const vox::FinalGather cpu(*b.field, b.scene.lights, cpuOptions);
    const auto cpuStart = std::chrono::steady_clock::now();
    std::vector<vox::FinalGatherParts> reference(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) reference[i] = cpu.shade(points[i]);
    const double cpuSeconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - cpuStart).count();

    struct Variant {
        const char* name;
        bool hardware;
        const rt::RvolGpuVolume* volume;
    };
    for (const Variant& v :
         {Variant{"hardware, R8", true, &volume}, Variant{"hardware, R16", true, &volume16},
          Variant{"texelFetch, R8", false, &volume}}) {
        const bool hardware = v.hardware;
        rt::FinalGatherGpuOptions options;
        options.aoLambda = cpuOptions.aoLambda;
        options.hardwareFilter = hardware;
        rt::FinalGatherGpu gather(*gl, options);
        const auto gpu = gather.shade(*v.volume, gpuPoints, lights);
        Psnr finalP, directP, indirectP, specularP, aoP;
        for (std::size_t i = 0; i < points.size(); ++i) {
            const vox::FinalGatherParts& r = reference[i];
            const double fin[3] = {r.final.x, r.final.y, r.final.z},
                         dir[3] = {r.direct.x, r.direct.y, r.direct.z},
                         ind[3] = {r.indirect.x, r.indirect.y, r.indirect.z},
                         spe[3] = {r.specular.x, r.specular.y, r.specular.z};
            finalP.add(fin, &gpu[i].final.x, 3);
            directP.add(dir, &gpu[i].direct.x, 3);
            indirectP.add(ind, &gpu[i].indirect.x, 3);
            specularP.add(spe, &gpu[i].specular.x, 3);
            aoP.add(&r.ao, &gpu[i].ao, 1);
        }
        std::printf(
            "[ rvol gpu ] %s, %zu points (3 lights, shadow cones): PSNR final %.1f, direct %.1f, "
            "indirect %.1f, "
            "specular %.1f, ao %.1f dB; GPU %.3f s, CPU %.3f s\n",
            v.name, points.size(), finalP.db(), directP.db(), indirectP.db(), specularP.db(),
            aoP.db(), gather.lastSeconds(), cpuSeconds);
        EXPECT_GE(finalP.db(), 40.0);
        EXPECT_GE(directP.db(), 40.0);
        EXPECT_GE(indirectP.db(), 40.0);
        EXPECT_GE(specularP.db(), 40.0);
        EXPECT_GE(aoP.db(), 40.0);
    }
    EXPECT_EQ(gl->errorCount(), 0u) << gl->errorSummary();
}

TEST(FinalGatherGpu, HundredsOfRangedLightsEachPointTestingOnlyThoseInRangeMatchTheCpu) {
    REQUIRE_GL();
    const Baked& b = baked();
    const rt::RvolGpuVolume volume(*gl, *b.reader);
    const CameraPoints cam = cameraPoints(b.scene, 48, 36);
    ASSERT_GT(cam.points.size(), 1000u);
    // 400 point and spot lights of 0.25–0.45 m ranges a few centimetres off the walls, floor and
    // ceiling of the 2 m box (so that each lights a patch), and one light without a range.
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-0.95, 0.95), range(0.25, 0.45), pick(0, 1);
    std::vector<vox::Light> lights;
    for (int i = 0; i < 400; ++i) {
        vox::Light l;
        l.type = i % 4 == 0 ? vox::PunctualLight::Type::Spot : vox::PunctualLight::Type::Point;
        l.outerConeAngle = 1.2f;
        const int wall = i % 5;
        Vec3d p{u(rng), 1 + u(rng), u(rng)};
        const double inset = 0.05 + 0.1 * pick(rng);
        if (wall == 0) p.x = -1 + inset;
        if (wall == 1) p.x = 1 - inset;
        if (wall == 2) p.y = inset;
        if (wall == 3) p.y = 2 - inset;
        if (wall == 4) p.z = -1 + inset;
        l.position = f3(p);
        l.direction = f3(Vec3d{wall == 0 ? -1.0 : wall == 1 ? 1.0 : 0.0,
                               wall == 2 ? -1.0 : wall == 3 ? 1.0 : 0.0, wall == 4 ? -1.0 : 0.0});
        l.range = static_cast<float>(range(rng));
        l.intensity = 0.05f;
        l.color = {float(0.5 + 0.5 * pick(rng)), float(0.5 + 0.5 * pick(rng)), 1.0f};
        lights.push_back(l);
    }
    vox::Light fill;
    fill.position = {0, 1.5f, 0};
    fill.intensity = 0.5f;
    lights.push_back(fill);
    const std::vector<vox::PunctualLight> gpuLights(lights.begin(), lights.end());

    vox::FinalGatherOptions cpuOptions;
    cpuOptions.aoLambda = b.reader->header().bake.aoLambda;
    const vox::FinalGather cpu(*b.field, lights, cpuOptions);
    rt::FinalGatherGpuOptions options;
    options.aoLambda = cpuOptions.aoLambda;
    rt::FinalGatherGpu gather(*gl, options);
    const auto gpu = gather.shade(volume, cam.gpuPoints, gpuLights);
    Psnr directP;
    double directSum = 0;
    for (std::size_t i = 0; i < cam.points.size(); ++i) {
        const vox::FinalGatherParts r = cpu.shade(cam.points[i]);
        const double dir[3] = {r.direct.x, r.direct.y, r.direct.z};
        directP.add(dir, &gpu[i].direct.x, 3);
        directSum += r.direct.x + r.direct.y + r.direct.z;
    }
    std::printf("[ rvol gpu ] %zu points, %zu lights: %.1f lights tested per point, PSNR direct "
                "%.1f dB, GPU %.3f s\n",
                cam.points.size(), lights.size(), gather.lastLightsPerPoint(), directP.db(),
                gather.lastSeconds());
    EXPECT_GT(directSum, 0.0);
    EXPECT_GE(directP.db(), 40.0);
    // Each point tests the light without a range and those whose range reaches its cell.
    EXPECT_GE(gather.lastLightsPerPoint(), 1.0);
    EXPECT_LT(gather.lastLightsPerPoint(), 0.2 * double(lights.size()));
    EXPECT_EQ(gl->errorCount(), 0u) << gl->errorSummary();
}

TEST(RvolResidency, AFullAtlasEvictsBricksTheViewLeftBehindThoughTheBudgetHasRoom) {
    // The atlases hold level-0 and directional planes in a fixed proportion, so a slot kind can
    // run out while the byte budget has room: the bricks the previous view kept must then make
    // way for the current view's, not leave it missing bricks (and holding none it needs less).
    REQUIRE_GL();
    const Baked& b = baked();
    const auto& h = b.reader->header();
    std::uint64_t fullBytes = 0;
    std::uint32_t bricks = 0;
    {
        const rt::RvolGpuVolume full(*gl, *b.reader);
        for (std::uint32_t l = 0; l < h.levelCount; ++l)
            for (std::uint32_t i = 0; i < b.reader->level(l).brickCount; ++i, ++bricks)
                fullBytes += full.brickBytes({rt::kBaseFile, l, i});
    }
    rt::RvolGpuVolume streamed(*gl, *b.reader, {.uploadAll = false, .atlasBytes = fullBytes / 3});
    rt::RvolResidency residency(streamed, 2 * fullBytes, 4);
    vox::PinholeCamera camera;
    const auto at = [&](double x, double y, double z) {
        camera.eye = {h.origin[0] + x * h.size, h.origin[1] + y * h.size, h.origin[2] + z * h.size};
        camera.target = {h.origin[0] + 0.5 * h.size, h.origin[1] + 0.5 * h.size,
                         h.origin[2] + 0.5 * h.size};
        return residency.update(camera);
    };
    const auto residentBricks = [&] {
        std::uint32_t n = 0;
        for (std::uint32_t l = 0; l < h.levelCount; ++l)
            for (std::uint32_t i = 0; i < b.reader->level(l).brickCount; ++i)
                n += streamed.resident({rt::kBaseFile, l, i});
        return n;
    };
    const auto first = at(0.1, 0.1, 0.9);
    ASSERT_GT(first.neededNotFitting, 0u) << "the atlas, not the budget, must bind";
    const std::uint32_t heldAtFirst = residentBricks();
    const auto moved = at(0.9, 0.9, 0.1);
    EXPECT_GT(moved.evicted, 0u);
    EXPECT_GT(moved.uploaded, 0u);
    // Needed bricks are left out only once nothing unneeded is left to evict.
    if (moved.neededNotFitting > 0) {
        EXPECT_LE(residentBricks(), moved.selected);
    }
    std::printf(
        "[ rvol gpu ] full atlas: %u of %u bricks held at the first view, %u needed at the second: "
        "%u evicted, %u uploaded, %u left out\n",
        heldAtFirst, bricks, moved.selected + moved.neededNotFitting, moved.evicted,
        moved.uploaded, moved.neededNotFitting);
    EXPECT_EQ(gl->errorCount(), 0u) << gl->errorSummary();
}

TEST(RvolResidency, AClipmapAroundTheEyeWithinTheBudgetFallsBackToCoarserLevelsAndNeverToEmpty) {
    REQUIRE_GL();
    const Baked& b = baked();
    const auto& h = b.reader->header();
    const rt::RvolGpuVolume full(*gl, *b.reader);
    std::uint64_t fullBytes = 0;
    for (std::uint32_t l = 0; l < h.levelCount; ++l)
        for (std::uint32_t i = 0; i < b.reader->level(l).brickCount; ++i)
            fullBytes += full.brickBytes({rt::kBaseFile, l, i});
    const std::uint64_t budget = fullBytes / 4;
    rt::RvolGpuVolume streamed(*gl, *b.reader, {.uploadAll = false, .atlasBytes = budget});
    EXPECT_LT(streamed.residentBytes(), full.residentBytes())
        << "the atlas is sized for the budget";
    rt::RvolResidency residency(streamed, budget);
    // An eye in a lower corner of the box: fine bricks there, coarse ones elsewhere.
    vox::PinholeCamera camera;
    camera.eye = {h.origin[0] + 0.2 * h.size, h.origin[1] + 0.2 * h.size,
                  h.origin[2] + 0.7 * h.size};
    camera.target = {h.origin[0] + 0.5 * h.size, h.origin[1] + 0.4 * h.size,
                     h.origin[2] + 0.5 * h.size};
    const auto update = residency.update(camera);
    EXPECT_GT(update.uploaded, 0u);
    EXPECT_GT(update.neededNotFitting, 0u) << "the budget must leave needed bricks out";
    EXPECT_LE(update.residentBytes, budget);
    EXPECT_EQ(update.residentBytes, residency.residentBytes());
    // The top level is whole, and every resident brick's level above is resident where it samples.
    const std::uint32_t top = h.levelCount - 1;
    for (std::uint32_t i = 0; i < b.reader->level(top).brickCount; ++i)
        EXPECT_TRUE(streamed.resident({rt::kBaseFile, top, i}));
    std::uint32_t fine = 0;
    for (std::uint32_t i = 0; i < b.reader->level(0).brickCount; ++i)
        fine += streamed.resident({rt::kBaseFile, 0, i});
    EXPECT_GT(fine, 0u);
    EXPECT_LT(fine, b.reader->level(0).brickCount);

    // Samples at level 0: near the eye the same as the full volume; everywhere, never empty where
    // the full volume is not (a missing brick falls back to a coarser level, not to nothing).
    rt::FinalGatherGpu gather(*gl, {.hardwareFilter = false});
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> pos(0.02, 0.98), near(-0.04, 0.04);
    std::vector<rt::FinalGatherGpu::SampleQuery> anywhere, close;
    for (int i = 0; i < 3000; ++i) {
        anywhere.push_back({0,
                            f3({h.origin[0] + pos(rng) * h.size, h.origin[1] + pos(rng) * h.size,
                                h.origin[2] + pos(rng) * h.size}),
                            {0.3f, 0.5f, -0.8f}});
        close.push_back({0,
                         f3({camera.eye[0] + near(rng) * h.size, camera.eye[1] + near(rng) * h.size,
                             camera.eye[2] + near(rng) * h.size}),
                         {0.3f, 0.5f, -0.8f}});
    }
    EXPECT_EQ(gather.sample(streamed, close), gather.sample(full, close));
    const auto streamedSamples = gather.sample(streamed, anywhere),
               fullSamples = gather.sample(full, anywhere);
    std::size_t solid = 0, holes = 0, coarser = 0;
    for (std::size_t i = 0; i < anywhere.size(); ++i) {
        if (!(fullSamples[i][3] > 0)) continue;
        ++solid;
        holes += !(streamedSamples[i][3] > 0);
        coarser += streamedSamples[i] != fullSamples[i];
    }
    EXPECT_GT(solid, 100u);
    EXPECT_EQ(holes, 0u);
    EXPECT_GT(coarser, solid / 10) << "far from the eye the samples come from coarser levels";
    std::printf(
        "[ rvol gpu ] residency: %u of %u needed bricks within %llu of %llu bytes, %u level-0 "
        "bricks of %u; %zu of %zu solid "
        "samples from coarser levels, no holes\n",
        update.selected, update.selected + update.neededNotFitting,
        static_cast<unsigned long long>(budget), static_cast<unsigned long long>(fullBytes), fine,
        b.reader->level(0).brickCount, coarser, solid);
    // Moving the eye to the opposite corner moves the fine bricks, within the budget.
    camera.eye = {h.origin[0] + 0.8 * h.size, h.origin[1] + 0.8 * h.size,
                  h.origin[2] + 0.3 * h.size};
    const auto moved = residency.update(camera);
    EXPECT_GT(moved.evicted, 0u);
    EXPECT_GT(moved.uploaded, 0u);
    EXPECT_LE(moved.residentBytes, budget);
    EXPECT_EQ(gl->errorCount(), 0u) << gl->errorSummary();
}
