// The OpenGL runtime against the CPU reference, on real GL (Mesa llvmpipe in CI): the headless
// context, KHR_debug error collection, and the compute-shader ray caster's images against
// EsvoRayCaster's on the same cameras (hit mask, depth, normals, colours, shaded PSNR).
#include <vox/base/error.h>
#include <vox/formats/esvo_reader.h>
#include <vox/formats/rvol_io.h>
#include <vox/import.h>
#include <vox/octree.h>
#include <vox/radiance.h>
#include <vox/radiance_tiles.h>
#include <vox/raycast.h>
#include <vox/texture.h>
#include <vox/runtime/channels.h>
#include <vox/runtime/esvo_gpu_pool.h>
#include <vox/runtime/esvo_gpu_raycaster.h>
#include <vox/runtime/esvo_stream.h>
#include <vox/runtime/gl_context.h>
#include <vox/runtime/shader.h>

#include "cornell_box.h"
#include "gl_test_context.h"
#include "test_support.h"

#include <GL/glcorearb.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>

namespace fs = std::filesystem;
namespace rt = vox::runtime;

namespace {

/// The Cornell box voxelized once per depth (contours and attributes on).
const vox::SparseOctree& cornellOctree(std::uint32_t depth) {
    static std::map<std::uint32_t, vox::SparseOctree> cache;
    static vox::test::ScratchDir dir;
    auto it = cache.find(depth);
    if (it != cache.end()) return it->second;
    static const vox::Scene scene = vox::importScene(vox::scenes::writeCornellBox(dir.path()));
    vox::SurfaceVoxelizeOptions options;
    options.depth = depth;
    options.contours = true;
    options.attributes = true;
    return cache.emplace(depth, vox::voxelizeSurface(scene, options)).first->second;
}

fs::path writeOctree(const fs::path& file, std::uint32_t depth, vox::AttributeEncoding encoding,
                     std::uint32_t sliceBytes = 1u << 20, std::uint32_t nearLimit = 0x7FFF) {
    vox::EsvoWriteOptions options;
    options.attributes = encoding;
    options.sliceBytes = sliceBytes;
    options.nearPointerLimit = nearLimit;
    vox::writeEsvo(file, cornellOctree(depth), options);
    return file;
}

struct View {
    vox::Vec3d eye, target;
    int width = 128, height = 96;
};
// Front (the box's opening), and oblique from above: grazing rays, contours seen edge-on.
const View kViews[] = {{{0, 1, 3.2}, {0, 1, 0}}, {{1.3, 1.7, 2.4}, {-0.2, 0.8, -0.3}}};

vox::PinholeCamera cpuCamera(const View& v) {
    vox::PinholeCamera c;
    c.eye = v.eye, c.target = v.target, c.width = v.width, c.height = v.height;
    return c;
}
vox::PinholeCamera gpuCamera(const View& v) {
    vox::PinholeCamera c;
    c.eye = {v.eye.x, v.eye.y, v.eye.z}, c.target = {v.target.x, v.target.y, v.target.z},
    c.width = v.width, c.height = v.height;
    return c;
}

/// What differs between the CPU and GPU images of one view.
struct Comparison {
    std::size_t pixels = 0, cpuHits = 0, maskAgree = 0, bothHit = 0, depthExact = 0, levelAgree = 0,
                normalAgree = 0, colorExact = 0, iterationsExact = 0;
    double maxRelDepth = 0, maxNormalDiff = 0, shadedPsnr = 0, colorPsnr = 0;
};

double psnr(double sumSquared, std::size_t count) {
    if (count == 0) return 0;
    if (sumSquared == 0) return std::numeric_limits<double>::infinity();
    return 10.0 * std::log10(255.0 * 255.0 / (sumSquared / double(count)));
}

/// Two PNGs of one view, voxinspect's and voxview's: the hit masks (non-black pixels) and the
/// PSNR, in 8-bit steps, over the pixels either image shows.
struct PngComparison {
    std::size_t pixels = 0, firstHits = 0, maskAgree = 0, exact = 0, shown = 0;
    double psnr = 0;
};

PngComparison comparePngs(const fs::path& first, const fs::path& second) {
    const vox::Texture a = vox::loadTexture(first, vox::ColorSpace::Linear),
                       b = vox::loadTexture(second, vox::ColorSpace::Linear);
    EXPECT_EQ(a.width(), b.width());
    EXPECT_EQ(a.height(), b.height());
    PngComparison c;
    double sumSq = 0;
    for (int y = 0; y < std::min(a.height(), b.height()); ++y)
        for (int x = 0; x < std::min(a.width(), b.width()); ++x) {
            const vox::Vec4f p = a.texel(0, x, y), q = b.texel(0, x, y);
            const bool ph = p.x > 0 || p.y > 0 || p.z > 0, qh = q.x > 0 || q.y > 0 || q.z > 0;
            ++c.pixels;
            c.firstHits += ph;
            c.maskAgree += ph == qh;
            c.exact += p.x == q.x && p.y == q.y && p.z == q.z;
            if (!(ph || qh)) continue;
            ++c.shown;
            for (int k = 0; k < 3; ++k) {
                const double d = 255.0 * (double(p[k]) - double(q[k]));
                sumSq += d * d;
            }
        }
    c.psnr = psnr(sumSq, 3 * c.shown);
    return c;
}

/// 8-bit sRGB of libvox's linear image, as voxinspect render writes it.
std::vector<std::uint8_t> toBytes(const std::vector<vox::Vec3f>& linear) {
    std::vector<std::uint8_t> out(3 * linear.size());
    for (std::size_t i = 0; i < linear.size(); ++i)
        for (int k = 0; k < 3; ++k)
            out[3 * i + std::size_t(k)] = static_cast<std::uint8_t>(
                std::lround(255.0f * vox::linearToSrgb(std::clamp(linear[i][k], 0.0f, 1.0f))));
    return out;
}

Comparison compare(const vox::RenderBuffers& cpu, const rt::GpuFrame& gpu,
                   const vox::PinholeCamera& cpuCam, const vox::PinholeCamera& gpuCam) {
    Comparison c;
    c.pixels = cpu.depth.size();
    const std::vector<std::uint8_t> cpuShaded = toBytes(vox::shadeHeadlight(cpu, cpuCam));
    const std::vector<std::uint8_t> gpuShaded =
        rt::composeChannel(gpu, gpuCam, vox::parseChannel("shaded"));
    const std::vector<std::uint8_t> cpuColor = toBytes(vox::albedoImage(cpu));
    const std::vector<std::uint8_t> gpuColor =
        rt::composeChannel(gpu, gpuCam, vox::parseChannel("color"));
    double shadedSq = 0, colorSq = 0;
    for (std::size_t i = 0; i < c.pixels; ++i) {
        const bool ch = std::isfinite(cpu.depth[i]), gh = gpu.hit(i);
        c.cpuHits += ch;
        c.maskAgree += ch == gh;
        c.iterationsExact += cpu.iterations[i] == gpu.iterations[i];
        if (!(ch && gh)) continue;
        ++c.bothHit;
        c.depthExact += cpu.depth[i] == gpu.depth[i];
        c.maxRelDepth =
            std::max(c.maxRelDepth, double(std::abs(cpu.depth[i] - gpu.depth[i]) / cpu.depth[i]));
        c.levelAgree += cpu.level[i] == gpu.level[i];
        const float dn = std::abs(cpu.normal[i].x - gpu.normal[3 * i]) +
                         std::abs(cpu.normal[i].y - gpu.normal[3 * i + 1]) +
                         std::abs(cpu.normal[i].z - gpu.normal[3 * i + 2]);
        c.normalAgree += dn < 1e-6f;
        c.maxNormalDiff = std::max(c.maxNormalDiff, double(dn));
        c.colorExact +=
            cpu.color[i] == gpu.color[i] && vox::hasAttributes(cpu, i) == gpu.hasAttributes(i);
        for (std::size_t k = 0; k < 3; ++k) {
            const double ds = double(cpuShaded[3 * i + k]) - double(gpuShaded[3 * i + k]);
            const double dc = double(cpuColor[3 * i + k]) - double(gpuColor[3 * i + k]);
            shadedSq += ds * ds, colorSq += dc * dc;
        }
    }
    c.shadedPsnr = psnr(shadedSq, 3 * c.bothHit);
    c.colorPsnr = psnr(colorSq, 3 * c.bothHit);
    return c;
}

void report(const std::string& what, const Comparison& c, double gpuMs) {
    std::printf(
        "[ runtime  ] %s: %zu px, %zu hits; mask %zu/%zu; of %zu common hits: depth exact %zu (max "
        "rel %.2g), level %zu, "
        "normal %zu (max %.2g), colour word %zu; iterations exact %zu; shaded PSNR %.1f dB, colour "
        "PSNR %.1f dB; %.2f ms wall\n",
        what.c_str(), c.pixels, c.cpuHits, c.maskAgree, c.pixels, c.bothHit, c.depthExact,
        c.maxRelDepth, c.levelAgree, c.normalAgree, c.maxNormalDiff, c.colorExact,
        c.iterationsExact, c.shadedPsnr, c.colorPsnr, gpuMs);
}

/// The acceptance bar, and tighter checks on what must agree where both hit.
void expectEquivalent(const Comparison& c) {
    EXPECT_GT(c.cpuHits, c.pixels / 4) << "the view must show the scene";
    EXPECT_GE(double(c.maskAgree), 0.999 * double(c.pixels)) << "hit masks differ";
    EXPECT_GE(c.shadedPsnr, 40.0);
    EXPECT_GE(c.colorPsnr, 40.0);
    EXPECT_LE(c.maxRelDepth, 1e-3);
    EXPECT_GE(double(c.levelAgree), 0.999 * double(c.bothHit));
    EXPECT_GE(double(c.normalAgree), 0.999 * double(c.bothHit));
    EXPECT_GE(double(c.colorExact), 0.999 * double(c.bothHit));
}

/// Casts @p view with both casters, with attributes, at @p lodScale times the pixel angle (0:
/// to the leaves); checks GL raised no error and compares the images. @p reference receives the
/// CPU's.
Comparison castBoth(vox::runtime::HeadlessGlContext& gl, const vox::EsvoRayCaster& cpu,
                    rt::EsvoGpuRaycaster& gpu, const View& view, double lodScale,
                    const std::string& what, vox::RenderBuffers* reference = nullptr) {
    const vox::PinholeCamera cc = cpuCamera(view);
    const vox::PinholeCamera gc = gpuCamera(view);
    vox::CastOptions options;
    options.lodAngle = cc.pixelAngle() * lodScale;
    options.attributes = true;
    rt::GpuCastOptions gpuOptions;
    gpuOptions.lodAngle = gc.pixelAngle() * lodScale;
    EXPECT_EQ(options.lodAngle, gpuOptions.lodAngle);
    vox::RenderBuffers image = vox::renderEsvo(cpu, cc, options);
    const rt::GpuFrame frame = gpu.render(gc, gpuOptions);
    EXPECT_EQ(gl.errorCount(), 0u) << gl.errorSummary();
    const Comparison c = compare(image, frame, cc, gc);
    report(what + " lod " + std::to_string(lodScale), c, frame.wallMilliseconds);
    if (reference) *reference = std::move(image);
    return c;
}

}  // namespace

TEST(RuntimeContext, CreatesOpenGl45Core) {
    REQUIRE_GL();
    EXPECT_GE(gl->majorVersion() * 10 + gl->minorVersion(), 45) << gl->version();
    EXPECT_FALSE(gl->renderer().empty());
    EXPECT_FALSE(gl->version().empty());
    GLint flags = 0, profile = 0;
    glGetIntegerv(GL_CONTEXT_FLAGS, &flags);
    glGetIntegerv(GL_CONTEXT_PROFILE_MASK, &profile);
    EXPECT_TRUE(flags & GL_CONTEXT_FLAG_DEBUG_BIT)
        << "the context must be a debug context (KHR_debug output)";
    EXPECT_TRUE(profile & GL_CONTEXT_CORE_PROFILE_BIT);
    std::printf("[ runtime  ] %s | %s | EGL %s\n", gl->renderer().c_str(), gl->version().c_str(),
                gl->platformName());
    EXPECT_EQ(gl->errorCount(), 0u) << gl->errorSummary();
}

TEST(RuntimeContext, DebugCallbackCatchesGlErrors) {
    REQUIRE_GL();
    ASSERT_EQ(gl->errorCount(), 0u);
    glEnable(0x7FFF);  // no such capability: GL_INVALID_ENUM
    EXPECT_EQ(gl->errorCount(), 1u) << "KHR_debug must report the error synchronously";
    EXPECT_NE(gl->errorSummary().find("error"), std::string::npos) << gl->errorSummary();
    EXPECT_THROW(gl->throwOnErrors("deliberate"), rt::RuntimeError);
    GLuint buffer = 0;
    glCreateBuffers(1, &buffer);
    glNamedBufferStorage(buffer, 16, nullptr, 0);
    const std::uint32_t data[4]{};
    glNamedBufferSubData(
        buffer, 0, 16,
        data);  // immutable storage without DYNAMIC_STORAGE_BIT: GL_INVALID_OPERATION
    glDeleteBuffers(1, &buffer);
    EXPECT_EQ(gl->errorCount(), 2u);
    gl->clearDebugMessages();
    EXPECT_EQ(gl->errorCount(), 0u);
    EXPECT_NO_THROW(gl->throwOnErrors("after clearing"));
}

TEST(RuntimeContext, ShaderCompileErrorCarriesTheLog) {
    REQUIRE_GL();
    try {
        rt::ComputeProgram bad("broken shader",
                               "#version 450 core\nlayout(local_size_x = 1) in;\nvoid main() { "
                               "undefined_thing = 1; }\n");
        FAIL() << "compiled a broken shader";
    } catch (const rt::RuntimeError& e) {
        const std::string what = e.what();
        EXPECT_NE(what.find("broken shader: compile failed:"), std::string::npos) << what;
        EXPECT_NE(what.find("undefined_thing"), std::string::npos) << what;
        EXPECT_EQ(what.find('\n'), std::string::npos) << "one line";
    }
    gl->clearDebugMessages();  // the compiler may also report through KHR_debug
}

class RuntimeRaycast : public ::testing::TestWithParam<vox::AttributeEncoding> {};

TEST_P(RuntimeRaycast, MatchesCpuReference) {
    REQUIRE_GL();
    vox::test::ScratchDir dir;
    const fs::path file = writeOctree(dir / "cornell.esvo", 6, GetParam());
    const vox::esvo::EsvoReader reader(file);
    vox::esvo::EsvoPool pool(reader);
    pool.loadAll();
    const vox::EsvoRayCaster cpu(pool);
    rt::EsvoGpuPool gpuPool(*gl, pool);
    rt::EsvoGpuRaycaster gpu(*gl, gpuPool);
    for (const View& view : kViews) {
        for (const double lodScale : {1.0, 0.0, 6.0}) {
            vox::RenderBuffers reference;
            expectEquivalent(castBoth(*gl, cpu, gpu, view, lodScale,
                                      "encoding " + std::to_string(int(GetParam())), &reference));
            if (lodScale == 6.0) {
                // Voxels of 6 pixels: the level-of-detail cut must stop above the leaves somewhere
                // (the GPU's levels agree with these).
                EXPECT_LT(*std::max_element(reference.level.begin(), reference.level.end()),
                          reader.header().leafDepth);
            }
        }
    }
}

INSTANTIATE_TEST_SUITE_P(Encodings, RuntimeRaycast,
                         ::testing::Values(vox::AttributeEncoding::Raw,
                                           vox::AttributeEncoding::Compressed,
                                           vox::AttributeEncoding::CompressedLookup),
                         [](const auto& param) {
                             switch (param.param) {
                                 case vox::AttributeEncoding::Raw:
                                     return std::string("raw");
                                 case vox::AttributeEncoding::Compressed:
                                     return std::string("dxt");
                                 default:
                                     return std::string("dxt_lookup");
                             }
                         });

// voxelize's default: error-bounded refinement, so many leaves stop above the leaf depth. The GPU
// caster treats them as the CPU's does, with the whole file loaded and with part of it (16 KB
// slices: coarser slices only), and full-resolution rays hit those coarse leaves.
TEST(RuntimeRaycast, ErrorBoundedOctreeMatchesCpuReference) {
    REQUIRE_GL();
    vox::test::ScratchDir dir;
    const vox::Scene scene = vox::importScene(vox::scenes::writeCornellBox(dir.path()));
    vox::SurfaceVoxelizeOptions voxelize;
    voxelize.depth = 7;
    voxelize.contours = true;
    voxelize.attributes = true;
    voxelize.contourError = vox::kDefaultContourError;
    voxelize.normalErrorDegrees = vox::kDefaultNormalErrorDegrees;
    voxelize.colorError = vox::kDefaultColorError;
    const vox::SparseOctree octree = vox::voxelizeSurface(scene, voxelize);
    std::uint64_t coarseLeaves = 0;
    for (std::uint32_t l = 1; l < octree.leafDepth; ++l)
        coarseLeaves += static_cast<std::uint64_t>(
            std::count(octree.masks[l].begin(), octree.masks[l].end(), 0));
    ASSERT_GT(coarseLeaves, 1000u);
    vox::EsvoWriteOptions write;
    write.sliceBytes = 16384;
    const fs::path file = dir / "bounded.esvo";
    vox::writeEsvo(file, octree, write);
    const vox::esvo::EsvoReader reader(file);
    ASSERT_GT(reader.sliceCount(), 2u);
    vox::esvo::EsvoPool pool(reader);
    pool.loadAll(4);
    ASSERT_LT(pool.loadedSliceCount(), reader.sliceCount());
    rt::EsvoGpuPool gpuPool(*gl, pool, 8u << 20);
    rt::EsvoGpuRaycaster gpu(*gl, gpuPool);
    const vox::EsvoRayCaster cpu(pool);
    for (const bool all : {false, true}) {
        if (all) {
            pool.loadAll();
            EXPECT_GT(gpuPool.sync(), 0u);
        }
        for (const View& view : kViews) {
            for (const double lodScale : {0.0, 1.0}) {
                vox::RenderBuffers reference;
                expectEquivalent(castBoth(*gl, cpu, gpu, view, lodScale,
                                          all ? "bounded, all slices" : "bounded, coarse slices",
                                          &reference));
                if (all && lodScale == 0.0) {
                    // Full-resolution rays end in leaves above the leaf depth (the walls' coarse
                    // voxels).
                    std::size_t coarseHits = 0;
                    for (std::size_t i = 0; i < reference.level.size(); ++i)
                        coarseHits += std::isfinite(reference.depth[i]) &&
                                      std::uint32_t{reference.level[i]} + 1 < octree.leafDepth;
                    EXPECT_GT(coarseHits, 100u);
                }
            }
        }
    }
}

// Depth 7 in 16 KB slices with far pointers: loads part of the tree (coarser levels stop where
// child slices are missing, in both casters), then the rest, which EsvoGpuPool::sync() uploads
// page by page.
TEST(RuntimeRaycastStreaming, PartialLoadThenSyncMatchesCpu) {
    REQUIRE_GL();
    vox::test::ScratchDir dir;
    const fs::path file =
        writeOctree(dir / "sliced.esvo", 7, vox::AttributeEncoding::Compressed, 16384, 64);
    const vox::esvo::EsvoReader reader(file);
    ASSERT_GT(reader.sliceCount(), 4u);
    vox::esvo::EsvoPool pool(reader);
    pool.loadAll(4);
    const std::uint32_t partial = pool.loadedSliceCount();
    ASSERT_LT(partial, reader.sliceCount());
    rt::EsvoGpuPool gpuPool(*gl, pool, 4u << 20);
    rt::EsvoGpuRaycaster gpu(*gl, gpuPool);
    const vox::EsvoRayCaster cpu(pool);
    const View view = kViews[1];
    vox::CastOptions options;
    options.lodAngle = 0;
    options.attributes = true;
    const auto check = [&](const std::string& what) -> vox::RenderBuffers {
        const vox::RenderBuffers reference = vox::renderEsvo(cpu, cpuCamera(view), options);
        const rt::GpuFrame frame =
            gpu.render(gpuCamera(view), rt::GpuCastOptions{0, 0xFFFFFFFFu, true, true});
        EXPECT_EQ(gl->errorCount(), 0u) << gl->errorSummary();
        const Comparison c = compare(reference, frame, cpuCamera(view), gpuCamera(view));
        report(what, c, frame.wallMilliseconds);
        expectEquivalent(c);
        return reference;
    };
    const vox::RenderBuffers coarse = check("streaming: " + std::to_string(partial) + " slices");
    pool.loadAll();
    const std::uint64_t uploaded = gpuPool.sync();
    EXPECT_GT(uploaded, 0u);
    EXPECT_LE(uploaded, pool.wordCount() * 4);
    EXPECT_EQ(gpuPool.sync(), 0u) << "nothing changed: nothing to upload";
    const vox::RenderBuffers fine =
        check("streaming: all " + std::to_string(pool.loadedSliceCount()) + " slices");
    // The loaded slices made a difference (finer levels appear), so the upload mattered.
    std::size_t finer = 0;
    for (std::size_t i = 0; i < fine.level.size(); ++i) finer += fine.level[i] > coarse.level[i];
    EXPECT_GT(finer, 0u);
}

TEST(EsvoStream, AFlightStaysUnderTheBudgetWithoutHolesAndMatchesTheCpuOnTheResidentSlices) {
    REQUIRE_GL();
    vox::test::ScratchDir dir;
    const fs::path file =
        writeOctree(dir / "flight.esvo", 7, vox::AttributeEncoding::Compressed, 16384, 64);
    const vox::esvo::EsvoReader full(file);
    vox::esvo::EsvoPool everything(full);
    everything.loadAll();
    const vox::EsvoRayCaster reference(everything);  // full detail: what a hole would be missing
    rt::EsvoStreamOptions options;
    options.budgetBytes = everything.residentBytes() * 2 / 5;
    options.frameLoadBytes = 96 << 10;
    options.ringBytes = 1 << 20;
    rt::EsvoStream stream(*gl, file, options);
    const vox::EsvoRayCaster cpu(stream.pool());
    std::uint64_t loaded = 0, evicted = 0, uploaded = 0;
    for (int frame = 0; frame < 10; ++frame) {
        // Round the box and in close, then a jump back to the front.
        const double a = frame < 9 ? 0.6 * frame : 0.0, d = frame < 9 ? 3.4 - 0.2 * frame : 3.6;
        const View view{{d * std::sin(a), 1.2, d * std::cos(a)}, {0, 1, 0}, 96, 72};
        stream.setCamera(gpuCamera(view));
        const rt::EsvoStreamUpdate update = stream.update();
        loaded += update.loaded, evicted += update.evicted, uploaded += update.uploadedBytes;
        EXPECT_LE(update.residentBytes, options.budgetBytes) << frame;
        EXPECT_LE(update.loadedBytes, std::uint64_t(options.frameLoadBytes)) << frame;
        // What is uploaded: the loaded slices, and a page per parent whose far pointers were
        // patched.
        EXPECT_GE(update.uploadedBytes, update.loadedBytes) << frame;
        EXPECT_LE(update.uploadedBytes,
                  update.loadedBytes + 8192u * (update.loaded + update.evicted))
            << frame;
        std::printf(
            "[ runtime  ] flight frame %d: %u loaded (%llu B), %u evicted, %llu B uploaded, %llu B "
            "resident, %u pending\n",
            frame, update.loaded, (unsigned long long)update.loadedBytes, update.evicted,
            (unsigned long long)update.uploadedBytes, (unsigned long long)update.residentBytes,
            update.pending);
        const rt::GpuFrame gpu = stream.render(stream.castOptions());
        ASSERT_EQ(gl->errorCount(), 0u) << gl->errorSummary();
        // The same image as the CPU reference on the same resident slices ...
        vox::CastOptions cast;
        cast.lodAngle = cpuCamera(view).pixelAngle() * options.lodScale;
        cast.attributes = true;
        const Comparison c = compare(vox::renderEsvo(cpu, cpuCamera(view), cast), gpu,
                                     cpuCamera(view), gpuCamera(view));
        expectEquivalent(c);
        // ... and no holes: every pixel that hits at full detail hits here (coarser voxels cover
        // their children).
        const vox::RenderBuffers fine = vox::renderEsvo(reference, cpuCamera(view), cast);
        std::size_t holes = 0;
        for (std::size_t i = 0; i < fine.depth.size(); ++i)
            holes += std::isfinite(fine.depth[i]) && !gpu.hit(i);
        EXPECT_EQ(holes, 0u) << frame;
    }
    EXPECT_GT(loaded, 0u);
    EXPECT_GT(evicted, 0u) << "a budget of 40 % of the file must evict along the flight";
    EXPECT_EQ(uploaded, stream.ring().bytesUploaded());
}

TEST(RuntimeRaycast, SameImageTwice) {
    REQUIRE_GL();
    vox::test::ScratchDir dir;
    const fs::path file = writeOctree(dir / "cornell.esvo", 6, vox::AttributeEncoding::Compressed);
    const vox::esvo::EsvoReader reader(file);
    vox::esvo::EsvoPool pool(reader);
    pool.loadAll();
    rt::EsvoGpuPool gpuPool(*gl, pool);
    rt::EsvoGpuRaycaster gpu(*gl, gpuPool);
    const vox::PinholeCamera camera = gpuCamera(kViews[0]);
    rt::GpuCastOptions options;
    options.lodAngle = camera.pixelAngle();
    const rt::GpuFrame a = gpu.render(camera, options), b = gpu.render(camera, options);
    EXPECT_EQ(rt::composeChannel(a, camera, vox::parseChannel("shaded")),
              rt::composeChannel(b, camera, vox::parseChannel("shaded")));
    EXPECT_EQ(a.iterations, b.iterations);
    EXPECT_EQ(gl->errorCount(), 0u) << gl->errorSummary();
}

// voxview as a process against voxinspect render on the same file and camera: the same PNG
// pixels for every channel; and its errors: one line, the tools' exit codes.
TEST(Voxview, MatchesVoxinspectRenderAndReportsErrors) {
    REQUIRE_GL();
    vox::test::ScratchDir dir;
    const fs::path file = writeOctree(dir / "cornell.esvo", 7, vox::AttributeEncoding::Compressed);
    const std::vector<std::string> camera{"--eye",   "1.3,1.7,2.4", "--target", "-0.2,0.8,-0.3",
                                          "--width", "96",          "--height", "72"};
    for (const std::string channel : {"shaded", "color", "normal", "depth", "iterations"}) {
        const fs::path cpuPng = dir / ("cpu_" + channel + ".png"),
                       gpuPng = dir / ("gpu_" + channel + ".png");
        std::vector<std::string> args{"render",    file.string(), "-o", cpuPng.string(),
                                      "--channel", channel,       "-q"};
        args.insert(args.end(), camera.begin(), camera.end());
        const vox::test::ProcessResult cpuRun =
            vox::test::runProcess(vox::test::voxinspectPath(), args);
        ASSERT_EQ(cpuRun.exitCode, 0) << cpuRun.err;
        std::vector<std::string> viewArgs{file.string(),
                                          "--headless",
                                          "-o",
                                          gpuPng.string(),
                                          "--channel",
                                          channel,
                                          "-q",
                                          "--stats",
                                          (dir / "stats.json").string()};
        viewArgs.insert(viewArgs.end(), camera.begin(), camera.end());
        const vox::test::ProcessResult gpuRun = vox::test::runProcess(LIBVOX_VOXVIEW, viewArgs);
        ASSERT_EQ(gpuRun.exitCode, 0) << gpuRun.err;
        EXPECT_TRUE(gpuRun.err.empty()) << gpuRun.err;
        const vox::Texture a = vox::loadTexture(cpuPng, vox::ColorSpace::Linear),
                           b = vox::loadTexture(gpuPng, vox::ColorSpace::Linear);
        ASSERT_EQ(b.width(), 96);
        ASSERT_EQ(b.height(), 72);
        std::size_t differing = 0;
        for (int y = 0; y < 72; ++y)
            for (int x = 0; x < 96; ++x) {
                const vox::Vec4f p = a.texel(0, x, y), q = b.texel(0, x, y);
                differing += p.x != q.x || p.y != q.y || p.z != q.z;
            }
        EXPECT_LE(double(differing), 0.001 * 96 * 72)
            << channel << ": " << differing << " pixels differ";
    }
    const std::string stats = vox::test::readText(dir / "stats.json");
    for (const char* key : {"\"renderer\"", "\"gl_version\"", "\"gpu_ms_per_frame\"",
                            "\"wall_ms_per_frame\"", "\"resident_bytes\"", "\"hits\""})
        EXPECT_NE(stats.find(key), std::string::npos) << key;
    EXPECT_NE(stats.find("\"gl_errors\": 0"), std::string::npos) << stats;

    const auto expectError = [&](std::vector<std::string> args, int code, const std::string& text) {
        const vox::test::ProcessResult r = vox::test::runProcess(LIBVOX_VOXVIEW, args);
        EXPECT_EQ(r.exitCode, code) << r.err;
        ASSERT_EQ(r.errLines().size(), 1u) << r.err;
        EXPECT_EQ(r.errLines()[0].rfind("voxview: error: ", 0), 0u) << r.err;
        EXPECT_NE(r.err.find(text), std::string::npos) << r.err;
    };
    const std::string out = (dir / "x.png").string();
    expectError({file.string(), "--headless", "-o", out, "--eye", "0,1,3", "--target", "0,1,0",
                 "--channel", "nope"},
                1, "--channel");
    {
        // Without --headless and without a display to open a window on (whatever this shell has).
        const vox::test::ProcessResult r = vox::test::runProcess(
            "/usr/bin/env", {"-u", "DISPLAY", "-u", "WAYLAND_DISPLAY", LIBVOX_VOXVIEW,
                             file.string(), "-o", out, "--eye", "0,1,3", "--target", "0,1,0"});
        EXPECT_EQ(r.exitCode, 1) << r.err;
        EXPECT_NE(r.err.find("no display"), std::string::npos) << r.err;
        EXPECT_NE(r.err.find("--headless"), std::string::npos) << r.err;
    }
    expectError({file.string(), "--headless", "-o", out, "--eye", "0,1", "--target", "0,1,0"}, 1,
                "--eye expects x,y,z");
    expectError({(dir / "missing.esvo").string(), "--headless", "-o", out, "--eye", "0,1,3",
                 "--target", "0,1,0"},
                2, "missing.esvo");
    vox::test::writeText(dir / "bad.esvo", "not an octree");
    expectError({(dir / "bad.esvo").string(), "--headless", "-o", out, "--eye", "0,1,3", "--target",
                 "0,1,0"},
                3, "bad.esvo");
    EXPECT_FALSE(fs::exists(dir / "x.png"));
}

// voxview's window (GLFW, X11) on a virtual display (Xvfb, Mesa's GLX): the runtime works in the
// window's context, adopted (CurrentGlContext), and shows the same image it writes headless.
TEST(Voxview, AWindowOnAVirtualDisplayShowsWhatHeadlessWrites) {
    REQUIRE_GL();
    if (!fs::exists("/usr/bin/xvfb-run"))
        GTEST_SKIP() << "no xvfb-run (Debian package xvfb) to give the window a display";
    vox::test::ScratchDir dir;
    const fs::path file = writeOctree(dir / "cornell.esvo", 6, vox::AttributeEncoding::Compressed);
    const std::vector<std::string> camera{"--eye", "0,1,3.2",  "--target", "0,1,0",     "--width",
                                          "80",    "--height", "60",       "--channel", "shaded"};
    std::vector<std::string> headless{file.string(), "--headless", "-o",
                                      (dir / "headless.png").string(), "-q"};
    headless.insert(headless.end(), camera.begin(), camera.end());
    ASSERT_EQ(vox::test::runProcess(LIBVOX_VOXVIEW, headless).exitCode, 0);
    std::vector<std::string> windowed{"-a",
                                      LIBVOX_VOXVIEW,
                                      file.string(),
                                      "-o",
                                      (dir / "window.png").string(),
                                      "--frames",
                                      "3",
                                      "-q",
                                      "--stats",
                                      (dir / "window.json").string()};
    windowed.insert(windowed.end(), camera.begin(), camera.end());
    const vox::test::ProcessResult r = vox::test::runProcess("/usr/bin/xvfb-run", windowed);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_EQ(vox::test::readText(dir / "headless.png"), vox::test::readText(dir / "window.png"));
    const std::string stats = vox::test::readText(dir / "window.json");
    EXPECT_NE(stats.find("\"egl_platform\": \"current\""), std::string::npos) << stats;
    EXPECT_NE(stats.find("\"frames\": 3"), std::string::npos) << stats;
    EXPECT_NE(stats.find("\"gl_errors\": 0"), std::string::npos) << stats;
}

// voxview --rvol (the final gather on the GPU: EsvoStream's primary hits, shading points built on
// the host, FinalGatherGpu over an RvolGpuVolume) against `voxinspect render FILE.rvol --esvo
// FILE.esvo --scene SCENE` (the CPU's) on the same Cornell box and camera: the hit masks
// (non-black pixels) and the tone-mapped PNGs of the final, direct and indirect channels.
TEST(Voxview, FinalGatherMatchesVoxinspectRender) {
    REQUIRE_GL();
    vox::test::ScratchDir dir;
    const fs::path gltf = vox::scenes::writeCornellBox(dir.path());
    const fs::path esvo = writeOctree(dir / "box.esvo", 6, vox::AttributeEncoding::Compressed);
    const fs::path rvol = dir / "box.rvol";
    {
        vox::RadianceBakeOptions options;
        options.depth = 5;
        options.bounces = 1;
        vox::rvol::writeRvol(rvol, vox::bakeRadiance(vox::importScene(gltf), options).volume);
    }
    const int width = 96, height = 72;
    const std::vector<std::string> camera{
        "--eye",   "1.3,1.7,2.4",         "--target", "-0.2,0.8,-0.3",
        "--width", std::to_string(width), "--height", std::to_string(height)};
    for (const std::string channel : {"final", "direct", "indirect"}) {
        const fs::path cpuPng = dir / ("cpu_" + channel + ".png"),
                       gpuPng = dir / ("gpu_" + channel + ".png");
        std::vector<std::string> args{"render",    rvol.string(), "--esvo", esvo.string(),
                                      "--scene",   gltf.string(), "-o",     cpuPng.string(),
                                      "--channel", channel,       "-q"};
        args.insert(args.end(), camera.begin(), camera.end());
        const auto cpuStart = std::chrono::steady_clock::now();
        const vox::test::ProcessResult cpuRun =
            vox::test::runProcess(vox::test::voxinspectPath(), args);
        const double cpuMs =
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - cpuStart)
                .count();
        ASSERT_EQ(cpuRun.exitCode, 0) << cpuRun.err;
        std::vector<std::string> viewArgs{esvo.string(),
                                          "--rvol",
                                          rvol.string(),
                                          "--scene",
                                          gltf.string(),
                                          "--headless",
                                          "-o",
                                          gpuPng.string(),
                                          "--channel",
                                          channel,
                                          "-q",
                                          "--stats",
                                          (dir / "stats.json").string()};
        viewArgs.insert(viewArgs.end(), camera.begin(), camera.end());
        const auto gpuStart = std::chrono::steady_clock::now();
        const vox::test::ProcessResult gpuRun = vox::test::runProcess(LIBVOX_VOXVIEW, viewArgs);
        const double gpuMs =
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - gpuStart)
                .count();
        ASSERT_EQ(gpuRun.exitCode, 0) << gpuRun.err;
        EXPECT_TRUE(gpuRun.err.empty()) << gpuRun.err;
        const PngComparison c = comparePngs(cpuPng, gpuPng);
        const std::size_t pixels = std::size_t(width) * std::size_t(height);
        ASSERT_EQ(c.pixels, pixels);
        std::printf(
            "[ runtime  ] voxview --rvol %s: %zu px, %zu non-black (CPU); mask %zu/%zu; exact %zu; "
            "PSNR %.1f dB over %zu px; "
            "voxinspect %.0f ms, voxview %.0f ms (processes)\n",
            channel.c_str(), pixels, c.firstHits, c.maskAgree, pixels, c.exact, c.psnr, c.shown,
            cpuMs, gpuMs);
        EXPECT_GT(c.firstHits, pixels / 4) << channel << ": the view must show the lit box";
        EXPECT_GE(double(c.maskAgree), 0.999 * double(pixels)) << channel << ": hit masks differ";
        EXPECT_GE(c.psnr, 40.0) << channel;
    }
    const std::string stats = vox::test::readText(dir / "stats.json");
    for (const char* key : {"\"final_gather\"", "\"gather_ms_median\"", "\"points\"", "\"lights\""})
        EXPECT_NE(stats.find(key), std::string::npos) << key;
    EXPECT_NE(stats.find("\"gl_errors\": 0"), std::string::npos) << stats;
}

// voxview over a tiled volume (index, tiles, far field) along a camera path into the box, its
// bricks streamed within a budget and at most four tile files open: no holes, tiles uploaded and
// evicted, tile files closed and reopened within the bound. The budget renders far cells from
// coarser covers (the clipmap's level of detail), so the image is compared with voxinspect render
// of the same index without one: every brick uploaded, the same view, the tolerance of the
// single-volume test above.
TEST(Voxview, ATiledFlightStreamsTilesWithoutHolesAndMatchesVoxinspectRender) {
    REQUIRE_GL();
    vox::test::ScratchDir dir;
    const fs::path gltf = vox::scenes::writeCornellBox(dir.path());
    const fs::path esvo = writeOctree(dir / "box.esvo", 6, vox::AttributeEncoding::Compressed);
    const fs::path index = dir / "tiled.rvol";  // depth 6, tiles of 16³ cells: 57 of 64 listed
    {
        vox::RadianceBakeOptions options;
        options.bounces = 1;
        vox::bakeTiledRadiance(vox::importScene(gltf), options, vox::RadianceTiling::plan(6, 4), {},
                               index, {});
    }
    const int frames = 6;
    std::string path;
    std::vector<std::string> lastView;
    for (int f = 0; f < frames; ++f) {
        const double t = f / double(frames - 1);
        char eye[64];
        std::snprintf(eye, sizeof eye, "%.4f,%.4f,%.4f", -0.6 + 1.0 * t, 0.5 + 0.8 * t,
                      3.0 - 2.6 * t);
        path += std::string(eye) + " 0.2,0.9,-1.0\n";
        lastView = {"--eye", eye, "--target", "0.2,0.9,-1.0"};
    }
    vox::test::writeText(dir / "path.txt", path);
    const std::vector<std::string> size{"--width", "80", "--height", "60"};
    const auto voxview = [&](const std::string& png, const std::string& stats,
                             std::vector<std::string> extra) {
        std::vector<std::string> args{esvo.string(),
                                      "--rvol",
                                      index.string(),
                                      "--scene",
                                      gltf.string(),
                                      "--headless",
                                      "-o",
                                      png,
                                      "-q",
                                      "--stats",
                                      stats,
                                      "--rvol-max-open-tiles",
                                      "4"};
        args.insert(args.end(), size.begin(), size.end());
        args.insert(args.end(), extra.begin(), extra.end());
        const vox::test::ProcessResult r = vox::test::runProcess(LIBVOX_VOXVIEW, args);
        EXPECT_EQ(r.exitCode, 0) << r.err;
        EXPECT_TRUE(r.err.empty()) << r.err;
        return nlohmann::json::parse(vox::test::readText(stats));
    };

    // The flight, within half a megabyte of bricks.
    std::vector<std::string> flight{"--camera-path", (dir / "path.txt").string(),
                                    "--frames",      std::to_string(frames),
                                    "--rvol-budget", "0.5"};
    flight.insert(flight.end(), lastView.begin(), lastView.end());
    const nlohmann::json streamed =
        voxview((dir / "streamed.png").string(), (dir / "streamed.json").string(), flight);
    const nlohmann::json& gather = streamed.at("final_gather");
    EXPECT_EQ(gather.at("holes"), 0) << gather.dump();
    EXPECT_EQ(gather.at("tiles"), 57);
    std::uint64_t tilesUploaded = 0, tilesEvicted = 0;
    for (const nlohmann::json& f : gather.at("bricks_per_frame")) {
        tilesUploaded += f.at("tiles_uploaded").get<std::uint64_t>();
        tilesEvicted += f.at("tiles_evicted").get<std::uint64_t>();
        EXPECT_LE(f.at("resident_bytes"), gather.at("rvol_budget_bytes"));
        EXPECT_EQ(f.at("holes"), 0);
    }
    EXPECT_GT(tilesUploaded, 0u);
    EXPECT_GT(tilesEvicted, 0u);
    const nlohmann::json& open = gather.at("open_tiles");
    EXPECT_LE(open.at("most_open"), 4);
    EXPECT_GT(open.at("closed"), 0) << "more tiles resident than open: closed and reopened";
    EXPECT_EQ(streamed.at("gl_errors"), 0);

    // The last view with every brick uploaded (each tile file opened in turn, four at most), and
    // voxinspect's final gather of it. voxinspect keeps its default bound, above the 57 tiles:
    // its cones reach most tiles from every pixel, and at four it would reopen about two million
    // times (TiledRvolOpenTiles tests a bounded CPU reader).
    const nlohmann::json whole =
        voxview((dir / "whole.png").string(), (dir / "whole.json").string(), lastView);
    EXPECT_EQ(whole.at("final_gather").at("holes"), 0);
    EXPECT_LE(whole.at("final_gather").at("open_tiles").at("most_open"), 4);
    std::vector<std::string> args{"render",  index.string(), "--esvo", esvo.string(),
                                  "--scene", gltf.string(),  "-o",     (dir / "cpu.png").string(),
                                  "-q"};
    args.insert(args.end(), size.begin(), size.end());
    args.insert(args.end(), lastView.begin(), lastView.end());
    const vox::test::ProcessResult cpuRun =
        vox::test::runProcess(vox::test::voxinspectPath(), args);
    ASSERT_EQ(cpuRun.exitCode, 0) << cpuRun.err;
    const PngComparison c = comparePngs(dir / "cpu.png", dir / "whole.png");
    // The budget changes the gather, not the octree's hits.
    const PngComparison budgeted = comparePngs(dir / "whole.png", dir / "streamed.png");
    std::printf(
        "[ runtime  ] voxview tiled flight: %llu tiles uploaded, %llu evicted, %s tile files "
        "opened, %s closed, at most %s open; last view against voxinspect: mask %zu/%zu, PSNR "
        "%.1f dB; streamed against every brick: mask %zu/%zu, PSNR %.1f dB\n",
        static_cast<unsigned long long>(tilesUploaded),
        static_cast<unsigned long long>(tilesEvicted), open.at("opened").dump().c_str(),
        open.at("closed").dump().c_str(), open.at("most_open").dump().c_str(), c.maskAgree,
        c.pixels, c.psnr, budgeted.maskAgree, budgeted.pixels, budgeted.psnr);
    EXPECT_GT(c.firstHits, c.pixels / 4) << "the view must show the lit box";
    EXPECT_GE(double(c.maskAgree), 0.999 * double(c.pixels));
    EXPECT_GE(c.psnr, 40.0);
    EXPECT_EQ(budgeted.maskAgree, budgeted.pixels);
}

// Issue 10: a slice corrupted on disk is rejected by the stream, which reports it (file and
// slice) and renders the rest, rays stopping at its parent's level there; it is never retried.
TEST(EsvoStream, ACorruptSliceIsReportedAndSkippedAndTheRestRenders) {
    REQUIRE_GL();
    vox::test::ScratchDir dir;
    const fs::path file =
        writeOctree(dir / "corrupt.esvo", 7, vox::AttributeEncoding::Compressed, 16384, 64);
    const View view = kViews[0];
    const double lodScale = 1e-3;  // finer than any voxel: the view needs every slice it sees
    std::vector<std::uint32_t> needed;
    std::uint32_t victim = 0;
    std::vector<char> below;  // per slice: the victim or under it
    {
        const vox::esvo::EsvoReader reader(file);
        const auto regions = rt::sliceRegions(reader.directory());
        needed = rt::selectSlices(reader, regions, {gpuCamera(view), lodScale}, ~std::uint64_t{0})
                     .slices;
        ASSERT_GT(needed.size(), 4u);
        // A needed non-root slice with needed children, so that its subtree is left out too.
        for (std::uint32_t s : needed)
            if (s != 0 && victim == 0 && reader.slice(s).childCount > 0 &&
                std::any_of(needed.begin(), needed.end(),
                            [&](std::uint32_t c) { return c != 0 && reader.slice(c).parent == s; }))
                victim = s;
        ASSERT_NE(victim, 0u);
        below.assign(reader.sliceCount(), 0);
        below[victim] = 1;
        for (std::uint32_t s = 1; s < reader.sliceCount(); ++s)
            below[s] = below[s] || below[reader.slice(s).parent];
        // Flip one byte in the middle of the victim's block on disk.
        const vox::esvo::SliceEntry& e = reader.slice(victim);
        std::FILE* f = std::fopen(file.c_str(), "r+b");
        ASSERT_NE(f, nullptr);
        const long at = long(e.fileOffset + e.byteSize / 2);
        ASSERT_EQ(std::fseek(f, at, SEEK_SET), 0);
        const int byte = std::fgetc(f);
        ASSERT_NE(byte, EOF);
        ASSERT_EQ(std::fseek(f, at, SEEK_SET), 0);
        std::fputc(byte ^ 0xFF, f);
        std::fclose(f);
    }
    rt::EsvoStreamOptions options;
    options.lodScale = lodScale;
    rt::EsvoStream stream(*gl, file, options);
    stream.setCamera(gpuCamera(view));
    rt::EsvoStreamUpdate update;
    ASSERT_NO_THROW(update = stream.update());
    std::printf("[ runtime  ] corrupt slice %u: %u loaded, %u bad, %zu error(s): %s\n", victim,
                update.loaded, update.badSlices, update.errors.size(),
                update.errors.empty() ? "" : update.errors[0].c_str());
    EXPECT_EQ(update.badSlices, 1u);
    ASSERT_EQ(update.errors.size(), 1u);
    EXPECT_NE(update.errors[0].find(file.string()), std::string::npos) << update.errors[0];
    EXPECT_NE(update.errors[0].find("slice " + std::to_string(victim) + " "), std::string::npos)
        << update.errors[0];
    EXPECT_EQ(update.errors[0].find('\n'), std::string::npos) << "one line";
    EXPECT_EQ(update.pending, 0u);
    std::size_t resident = 0;
    for (std::uint32_t s : needed) {
        EXPECT_EQ(stream.pool().loaded(s), !below[s]) << "slice " << s;
        resident += !below[s];
    }
    EXPECT_EQ(stream.pool().loadedSliceCount(), resident);
    EXPECT_LT(resident, needed.size());
    // Never retried: a second update loads nothing and reports nothing new.
    const rt::EsvoStreamUpdate again = stream.update();
    EXPECT_EQ(again.loaded, 0u);
    EXPECT_TRUE(again.errors.empty());
    EXPECT_EQ(again.badSlices, 1u);
    EXPECT_EQ(again.pending, 0u);
    // The GPU image on what is resident matches the CPU reference on the same pool.
    const rt::GpuFrame gpu = stream.render(stream.castOptions());
    ASSERT_EQ(gl->errorCount(), 0u) << gl->errorSummary();
    const vox::EsvoRayCaster cpu(stream.pool());
    vox::CastOptions cast;
    cast.lodAngle = cpuCamera(view).pixelAngle() * lodScale;
    cast.attributes = true;
    const vox::RenderBuffers reference = vox::renderEsvo(cpu, cpuCamera(view), cast);
    const Comparison c = compare(reference, gpu, cpuCamera(view), gpuCamera(view));
    report("corrupt slice " + std::to_string(victim) + " skipped", c, gpu.wallMilliseconds);
    expectEquivalent(c);
    EXPECT_GT(c.cpuHits, 0u);
}
