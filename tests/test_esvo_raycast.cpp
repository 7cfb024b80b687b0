// The reference ray caster (libvox/src/render/esvo_raycast.cpp) against geometric truth: a real
// mesh (Wuson.ply, 3732 triangles) is voxelized, written as .esvo, streamed into an EsvoPool and
// ray cast; an independent triangle ray caster (BVH + Möller–Trumbore in double) renders the mesh
// from the same cameras. Hits and distances must agree to within a leaf voxel; slicing and
// streaming must not change what the octree shows except by coarsening it.
#include <vox/base/error.h>
#include <vox/formats/esvo_reader.h>
#include <vox/import.h>
#include <vox/octree.h>
#include <vox/raycast.h>
#include <vox/triangle_raycast.h>

#include "test_support.h"

#include <unistd.h>

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <numeric>
#include <vector>

namespace fs = std::filesystem;
using vox::Vec3d;

namespace {

// Depth 10 voxelizes Wuson in well under a second in a RelWithDebInfo build, so the full depth
// the brief asks for is used.
constexpr std::uint32_t kDepth = 10;
constexpr int kImage = 128;

// ---- the reference: the mesh through vox::TriangleRayCaster (BVH, Möller–Trumbore) ----------

/// Closest point of triangle abc to p (Ericson, Real-Time Collision Detection 5.1.5).
Vec3d closestOnTriangle(Vec3d p, Vec3d a, Vec3d b, Vec3d c) {
    const Vec3d ab = b - a, ac = c - a, ap = p - a;
    const double d1 = vox::dot(ab, ap), d2 = vox::dot(ac, ap);
    if (d1 <= 0 && d2 <= 0) return a;
    const Vec3d bp = p - b;
    const double d3 = vox::dot(ab, bp), d4 = vox::dot(ac, bp);
    if (d3 >= 0 && d4 <= d3) return b;
    const double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + ab * (d1 / (d1 - d3));
    const Vec3d cp = p - c;
    const double d5 = vox::dot(ab, cp), d6 = vox::dot(ac, cp);
    if (d6 >= 0 && d5 <= d6) return c;
    const double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + ac * (d2 / (d2 - d6));
    const double va = d3 * d6 - d5 * d4;
    if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0)
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    const double denom = 1.0 / (va + vb + vc);
    return a + ab * (vb * denom) + ac * (vc * denom);
}

/// Distance from @p p to the nearest triangle of @p scene (brute force, double).
double meshDistance(const vox::Scene& scene, Vec3d p) {
    double best = std::numeric_limits<double>::infinity();
    for (const vox::Mesh& m : scene.meshes)
        for (std::size_t t = 0; t < m.triangleCount(); ++t) {
            const auto v = [&](int k) {
                const vox::Vec3f q = m.positions[m.indices[3 * t + k]];
                return Vec3d{q.x, q.y, q.z};
            };
            best = std::min(best, vox::length(p - closestOnTriangle(p, v(0), v(1), v(2))));
        }
    return best;
}

struct MeshHit {
    double t = std::numeric_limits<double>::infinity();  ///< +inf on a miss
    Vec3d normal{0, 0, 0};  ///< unit normal of the triangle hit, facing the ray
};

// ---- shared data: the mesh, its octree and the files, built once ------------------------------

struct Shared {
    fs::path dir;
    vox::Scene scene;
    vox::SparseOctree octree;
    std::unique_ptr<vox::TriangleRayCaster> mesh;
    fs::path bigSlices, smallSlices;
    double voxelizeSeconds = 0;
    std::vector<vox::PinholeCamera> cameras;
};

Shared* shared = nullptr;

class EsvoRaycast : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        shared = new Shared;
        shared->dir =
            fs::temp_directory_path() / ("libvox_test_esvo_raycast_" + std::to_string(::getpid()));
        fs::remove_all(shared->dir);
        fs::create_directories(shared->dir);
        shared->scene = vox::importScene(vox::test::assimpModels() / "PLY/Wuson.ply");

        shared->mesh = std::make_unique<vox::TriangleRayCaster>(shared->scene);

        vox::SurfaceVoxelizeOptions options;
        options.depth = kDepth;
        const auto start = std::chrono::steady_clock::now();
        shared->octree = vox::voxelizeSurface(shared->scene, options);
        shared->voxelizeSeconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

        vox::EsvoWriteOptions write;
        write.sceneBounds = shared->scene.bounds();
        shared->bigSlices = shared->dir / "wuson.esvo";
        (void)vox::writeEsvo(shared->bigSlices, shared->octree, write);
        write.sliceBytes = 16384;
        shared->smallSlices = shared->dir / "wuson_16k.esvo";
        (void)vox::writeEsvo(shared->smallSlices, shared->octree, write);

        // Three cameras around the model, each framing it whole.
        const vox::Bounds3f b = shared->scene.bounds();
        const Vec3d centre{(b.min.x + b.max.x) / 2.0, (b.min.y + b.max.y) / 2.0,
                           (b.min.z + b.max.z) / 2.0};
        const vox::Vec3f e = b.extent();
        const double radius =
            0.5 * std::sqrt(double(e.x) * e.x + double(e.y) * e.y + double(e.z) * e.z);
        for (const Vec3d dir :
             {Vec3d{1, 0.35, 0.3}, Vec3d{-0.9, 0.5, -0.4}, Vec3d{0.5, -0.45, -1}}) {
            vox::PinholeCamera cam;
            cam.target = centre;
            cam.eye = centre + vox::normalize(dir) * (2.0 * radius);
            cam.up = {0, 1, 0};
            cam.fovYDegrees = 50;
            cam.width = cam.height = kImage;
            shared->cameras.push_back(cam);
        }
    }
    static void TearDownTestSuite() {
        std::error_code ec;
        fs::remove_all(shared->dir, ec);
        delete shared;
        shared = nullptr;
    }
};

vox::CastOptions exact() {
    vox::CastOptions o;
    o.lodAngle = 0;
    return o;
}

/// Per-pixel mesh hits for @p cam.
std::vector<MeshHit> renderMesh(const vox::PinholeCamera& cam) {
    std::vector<MeshHit> hits(std::size_t(cam.width) * cam.height);
    for (int y = 0; y < cam.height; ++y)
        for (int x = 0; x < cam.width; ++x) {
            const vox::CastHit h = shared->mesh->cast(cam.rayThrough(x, y));
            if (h.hit)
                hits[std::size_t(y) * cam.width + x] = {h.t, {h.normal.x, h.normal.y, h.normal.z}};
        }
    return hits;
}

}  // namespace

TEST_F(EsvoRaycast, OctreeMatchesTheMeshWithinALeafVoxel) {
    ASSERT_EQ(shared->scene.triangleCount(), 3732u);
    const vox::esvo::EsvoReader reader(shared->bigSlices);
    vox::esvo::EsvoPool pool(reader);
    pool.loadAll();
    const vox::EsvoRayCaster caster(pool);
    EXPECT_NEAR(caster.leafVoxelSize(), shared->octree.cube.size / (1 << kDepth),
                1e-12 * shared->octree.cube.size);
    const double diagonal = std::sqrt(3.0) * caster.leafVoxelSize();
    std::printf(
        "Wuson depth %u: voxelized in %.2f s, %llu leaves, %u slices (1 MiB), leaf %.5g, diagonal "
        "%.5g\n",
        kDepth, shared->voxelizeSeconds,
        static_cast<unsigned long long>(shared->octree.voxelsPerLevel.back()), reader.sliceCount(),
        caster.leafVoxelSize(), diagonal);

    std::uint64_t pixels = 0, agree = 0, both = 0, meshHits = 0, onlyOctree = 0, onlyMesh = 0;
    std::uint64_t close = 0;      // |t_octree − t_mesh| <= diagonal
    std::uint64_t notBehind = 0;  // t_octree <= t_mesh + diagonal
    std::uint64_t slopeClose =
        0;  // t_mesh − t_octree <= diagonal / |cos(incidence)|, and not behind
    std::uint64_t onSurface = 0;  // the octree hit point lies within a diagonal of the mesh
    std::uint64_t facing = 0,
                  facingClose = 0;  // pixels whose incidence is within 45° of the normal
    std::uint64_t coarse = 0;       // hits above the leaf level: none with every slice loaded
    std::uint64_t badNormals = 0;   // normals that are not the entered face's
    std::uint64_t octreeOnlyNearMesh =
        0;  // octree-only pixels whose hit point is within a diagonal of the mesh
    double worstBehind = -1e300, worstSurface = 0;
    for (std::size_t c = 0; c < shared->cameras.size(); ++c) {
        const vox::PinholeCamera& cam = shared->cameras[c];
        const std::vector<MeshHit> mesh = renderMesh(cam);
        const vox::RenderBuffers oct = vox::renderEsvo(caster, cam, exact());
        ASSERT_EQ(oct.depth.size(), mesh.size());
        std::uint64_t camMeshHits = 0, camOctHits = 0;
        for (int y = 0; y < kImage; ++y)
            for (int x = 0; x < kImage; ++x) {
                const std::size_t i = std::size_t(y) * kImage + x;
                const bool mh = std::isfinite(mesh[i].t), oh = std::isfinite(oct.depth[i]);
                ++pixels;
                camMeshHits += mh;
                camOctHits += oh;
                agree += mh == oh;
                onlyMesh += mh && !oh;
                const vox::Ray ray = cam.rayThrough(x, y);
                if (oh) {
                    const Vec3d point = ray.origin + ray.direction * double(oct.depth[i]);
                    // The normal is the axis of the voxel face the ray entered: facing the ray,
                    // and the hit point lies on a leaf grid plane across that axis.
                    const vox::Vec3f n = oct.normal[i];
                    const int axis = std::abs(n.x) == 1 ? 0 : (std::abs(n.y) == 1 ? 1 : 2);
                    const double along =
                        (point[axis] - shared->octree.cube.origin[axis]) / caster.leafVoxelSize();
                    const bool faceOk = std::abs(n.x) + std::abs(n.y) + std::abs(n.z) == 1 &&
                                        std::abs(n[axis]) == 1 &&
                                        n[axis] * ray.direction[axis] < 0 &&
                                        std::abs(along - std::round(along)) < 1e-3;
                    badNormals += !faceOk;
                    const double dist = meshDistance(shared->scene, point);
                    worstSurface = std::max(worstSurface, dist / diagonal);
                    onSurface += dist <= diagonal * (1 + 1e-4);
                    coarse += oct.level[i] != kDepth;
                    if (!mh) {
                        ++onlyOctree;
                        octreeOnlyNearMesh += dist <= diagonal * (1 + 1e-4);
                    }
                }
                if (!(mh && oh)) continue;
                ++both;
                const double d = double(oct.depth[i]) - mesh[i].t;  // > 0: octree behind the mesh
                const double cosine = std::abs(vox::dot(mesh[i].normal, ray.direction));
                close += std::abs(d) <= diagonal;
                notBehind += d <= diagonal;
                slopeClose += d <= diagonal && -d <= diagonal / std::max(cosine, 1e-9);
                if (cosine >= std::sqrt(0.5)) {
                    ++facing;
                    facingClose += std::abs(d) <= diagonal;
                }
                worstBehind = std::max(worstBehind, d);
            }
        meshHits += camMeshHits;
        EXPECT_EQ(oct.hits, camOctHits);
        EXPECT_GT(camMeshHits, std::uint64_t(kImage) * kImage / 20)
            << "camera " << c << ": the model is in view";
        // renderEsvo is caster.cast through camera.rayThrough, pixel by pixel.
        for (int y = 0; y < kImage; y += 17)
            for (int x = 0; x < kImage; x += 13) {
                const vox::CastHit h = caster.cast(cam.rayThrough(x, y), exact());
                const std::size_t i = std::size_t(y) * kImage + x;
                EXPECT_EQ(h.hit, std::isfinite(oct.depth[i]));
                if (h.hit) {
                    EXPECT_EQ(h.t, oct.depth[i]);
                }
            }
    }
    const auto pct = [](std::uint64_t n, std::uint64_t of) {
        return of ? 100.0 * double(n) / double(of) : 0.0;
    };
    const std::uint64_t octHits = both + onlyOctree;
    std::printf(
        "hit/miss agreement: %.3f%% of %llu pixels (%llu mesh hits; octree-only %llu, of them %llu "
        "within a diagonal of "
        "the mesh; mesh-only %llu)\n",
        pct(agree, pixels), static_cast<unsigned long long>(pixels),
        static_cast<unsigned long long>(meshHits), static_cast<unsigned long long>(onlyOctree),
        static_cast<unsigned long long>(octreeOnlyNearMesh),
        static_cast<unsigned long long>(onlyMesh));
    std::printf("pixels both hit: %llu\n", static_cast<unsigned long long>(both));
    std::printf("  |t_octree - t_mesh| <= leaf diagonal:           %.3f%%\n", pct(close, both));
    std::printf("  ... where the ray is within 45 deg of normal:   %.3f%% of %llu\n",
                pct(facingClose, facing), static_cast<unsigned long long>(facing));
    std::printf("  within diagonal / |cos incidence|, not behind:  %.3f%%\n",
                pct(slopeClose, both));
    std::printf(
        "  octree not more than a diagonal behind:         %.3f%% (worst: %.3g diagonals behind)\n",
        pct(notBehind, both), worstBehind / diagonal);
    std::printf(
        "octree hit points within a leaf diagonal of the mesh: %.3f%% of %llu (worst %.3g "
        "diagonals)\n",
        pct(onSurface, octHits), static_cast<unsigned long long>(octHits), worstSurface);
    RecordProperty("hit_agreement_percent", std::to_string(pct(agree, pixels)));
    RecordProperty("depth_within_diagonal_percent", std::to_string(pct(close, both)));
    RecordProperty("depth_within_diagonal_facing_percent",
                   std::to_string(pct(facingClose, facing)));
    RecordProperty("depth_within_slope_bound_percent", std::to_string(pct(slopeClose, both)));
    RecordProperty("not_behind_percent", std::to_string(pct(notBehind, both)));
    RecordProperty("hit_point_on_surface_percent", std::to_string(pct(onSurface, octHits)));

    EXPECT_EQ(coarse, 0u);
    EXPECT_EQ(badNormals, 0u);
    EXPECT_GE(pct(agree, pixels), 99.0);
    // Every octree hit enters a leaf voxel that the surface touches, so the hit point is within
    // one leaf diagonal of the mesh: an exact property, for every pixel.
    EXPECT_EQ(onSurface, octHits);
    // The octree is never behind the mesh: the leaf holding the mesh's hit point is on the ray.
    EXPECT_EQ(notBehind, both);
    // Along the ray, the voxel shell is a diagonal thick across the surface, so at incidence θ the
    // octree can be hit up to diagonal / cos θ early: within that on (almost) every pixel, and
    // within one diagonal wherever the surface faces the ray.
    // (Curvature and silhouettes, where the ray passes another part of the surface within a
    // voxel first, account for the rest.)
    EXPECT_GE(pct(slopeClose, both), 97.0);
    EXPECT_GE(pct(facingClose, facing), 98.0);
    // Raw |Δt| <= diagonal cannot reach 99% over all pixels, since grazing rays enter the shell
    // early (82% here); still most pixels must be that close.
    EXPECT_GE(pct(close, both), 75.0);
    // Surface voxels cover the surface: a ray that hits the mesh never passes through the octree.
    EXPECT_EQ(onlyMesh, 0u);
}

TEST_F(EsvoRaycast, SliceSizeDoesNotChangeTheImage) {
    const vox::esvo::EsvoReader big(shared->bigSlices), small(shared->smallSlices);
    ASSERT_GT(small.sliceCount(), 10u);
    EXPECT_LT(big.sliceCount(), small.sliceCount());
    for (std::uint32_t i = 0; i < small.sliceCount(); ++i)
        ASSERT_LE(small.slice(i).byteSize, 16384u);
    vox::esvo::EsvoPool bigPool(big), smallPool(small);
    bigPool.loadAll();
    smallPool.loadAll();
    const vox::EsvoRayCaster bigCaster(bigPool), smallCaster(smallPool);
    std::uint64_t hits = 0;
    for (const vox::PinholeCamera& cam : shared->cameras) {
        const vox::RenderBuffers a = vox::renderEsvo(bigCaster, cam, exact());
        const vox::RenderBuffers b = vox::renderEsvo(smallCaster, cam, exact());
        std::uint64_t differ = 0;
        for (std::size_t i = 0; i < a.depth.size(); ++i)
            differ += a.depth[i] != b.depth[i] || a.level[i] != b.level[i] ||
                      !(a.normal[i] == b.normal[i]);
        EXPECT_EQ(differ, 0u);
        EXPECT_EQ(a.hits, b.hits);
        hits += a.hits;
    }
    EXPECT_GT(hits, 5000u);
}

TEST_F(EsvoRaycast, RootSliceAloneShowsCoarserSupersets) {
    const vox::esvo::EsvoReader reader(shared->smallSlices);
    vox::esvo::EsvoPool full(reader), rootOnly(reader);
    full.loadAll();
    ASSERT_EQ(rootOnly.loadedSliceCount(), 1u);
    ASSERT_GT(reader.sliceCount(), 1u);
    const vox::EsvoRayCaster fullCaster(full), coarseCaster(rootOnly);
    std::uint64_t fullHits = 0, coarseHits = 0, coarseLevel = 0, violations = 0, extra = 0;
    for (const vox::PinholeCamera& cam : shared->cameras) {
        const vox::RenderBuffers f = vox::renderEsvo(fullCaster, cam, exact());
        const vox::RenderBuffers c = vox::renderEsvo(coarseCaster, cam, exact());
        for (std::size_t i = 0; i < f.depth.size(); ++i) {
            const bool fh = std::isfinite(f.depth[i]), ch = std::isfinite(c.depth[i]);
            fullHits += fh;
            coarseHits += ch;
            extra += ch && !fh;
            if (ch) coarseLevel += c.level[i] < kDepth;
            if (ch) {
                EXPECT_LE(c.level[i], kDepth);
            }
            if (!fh) continue;
            // Every voxel is inside a loaded coarser voxel: hit, and no later.
            if (!ch || c.depth[i] > f.depth[i] * (1 + 1e-6f) + 1e-6f) ++violations;
        }
    }
    std::printf("root slice only: %llu hits (full octree %llu), %llu at levels < %u\n",
                static_cast<unsigned long long>(coarseHits),
                static_cast<unsigned long long>(fullHits),
                static_cast<unsigned long long>(coarseLevel), kDepth);
    EXPECT_EQ(violations, 0u);
    EXPECT_GT(coarseLevel, 0u);
    EXPECT_GT(extra, 0u);  // coarse voxels are bigger, so they also catch rays the leaves miss
}

TEST_F(EsvoRaycast, MaxLevelStopsTraversal) {
    const vox::esvo::EsvoReader reader(shared->smallSlices);
    vox::esvo::EsvoPool pool(reader);
    pool.loadAll();
    const vox::EsvoRayCaster caster(pool);
    vox::CastOptions capped = exact();
    capped.maxLevel = 5;
    std::uint64_t hits = 0, atFive = 0, violations = 0;
    for (const vox::PinholeCamera& cam : shared->cameras) {
        const vox::RenderBuffers f = vox::renderEsvo(caster, cam, exact());
        const vox::RenderBuffers c = vox::renderEsvo(caster, cam, capped);
        for (std::size_t i = 0; i < c.depth.size(); ++i) {
            if (!std::isfinite(c.depth[i])) {
                violations += std::isfinite(f.depth[i]);
                continue;
            }
            ++hits;
            EXPECT_LE(c.level[i], 5u);
            atFive += c.level[i] == 5;
            if (std::isfinite(f.depth[i]) && c.depth[i] > f.depth[i] * (1 + 1e-6f) + 1e-6f)
                ++violations;
        }
    }
    EXPECT_GT(hits, 5000u);
    EXPECT_EQ(atFive,
              hits);  // every voxel above the leaves has children, so level 5 is where it stops
    EXPECT_EQ(violations, 0u);
}

namespace {

/// Every field of two hits, bit for bit.
bool sameHit(const vox::CastHit& a, const vox::CastHit& b) {
    const auto bits = [](float f) { return std::bit_cast<std::uint32_t>(f); };
    return a.hit == b.hit && bits(a.t) == bits(b.t) && a.level == b.level &&
           a.iterations == b.iterations && bits(a.normal.x) == bits(b.normal.x) &&
           bits(a.normal.y) == bits(b.normal.y) && bits(a.normal.z) == bits(b.normal.z) &&
           a.hasAttributes == b.hasAttributes && a.color == b.color &&
           bits(a.shadingNormal.x) == bits(b.shadingNormal.x) &&
           bits(a.shadingNormal.y) == bits(b.shadingNormal.y) &&
           bits(a.shadingNormal.z) == bits(b.shadingNormal.z);
}

}  // namespace

// castMany traverses eight rays at a time where the CPU has AVX2; whatever it runs, each ray's
// hit must be cast()'s, for every option the loop branches on: the level-of-detail cut, maxLevel,
// contours off, attributes, per-ray start distances, and far pointers into unloaded slices.
TEST_F(EsvoRaycast, CastManyMatchesCastBitForBit) {
    // voxelize's defaults: contours, attributes, refinement stopped early under the error bounds;
    // small slices, so that the root slice alone leaves far pointers to unloaded ones.
    vox::SurfaceVoxelizeOptions options;
    options.depth = kDepth;
    options.contours = true;
    options.attributes = true;
    options.contourError = vox::kDefaultContourError;
    const vox::SparseOctree octree = vox::voxelizeSurface(shared->scene, options);
    ASSERT_FALSE(octree.contours.empty());
    vox::EsvoWriteOptions write;
    write.sceneBounds = shared->scene.bounds();
    write.sliceBytes = 16384;
    const fs::path file = shared->dir / "cast_many.esvo";
    (void)vox::writeEsvo(file, octree, write);
    const vox::esvo::EsvoReader reader(file);
    ASSERT_GT(reader.sliceCount(), 1u);
    vox::esvo::EsvoPool full(reader), rootOnly(reader);
    full.loadAll();
    const vox::EsvoRayCaster fullCaster(full), coarseCaster(rootOnly);
    std::vector<vox::CastOptions> variants(5, exact());
    variants[1].lodAngle = shared->cameras[0].pixelAngle() * 4;
    variants[1].attributes = true;
    variants[2].maxLevel = 5;
    variants[3].contours = false;
    variants[4].attributes = true;
    variants[4].tStart = 0.25f * float(shared->octree.cube.size);
    std::uint64_t rays = 0, hits = 0, mismatches = 0;
    for (const vox::EsvoRayCaster* caster : {&fullCaster, &coarseCaster})
        for (const vox::PinholeCamera& cam : shared->cameras)
            for (std::size_t v = 0; v < variants.size(); ++v) {
                std::vector<vox::Ray> camRays;
                std::vector<float> starts;
                for (int y = 0; y < cam.height; ++y)
                    for (int x = 0; x < cam.width; ++x) {
                        camRays.push_back(cam.rayThrough(x, y));
                        // Variant 4 also gives every third ray a start of its own, some past the
                        // hit.
                        starts.push_back(v == 4 && (x + y) % 3 == 0
                                             ? float((x % 7) * 0.1 * shared->octree.cube.size)
                                             : 0.0f);
                    }
                std::vector<vox::CastHit> many(camRays.size());
                caster->castMany(camRays.data(), starts.data(), camRays.size(), variants[v],
                                 many.data());
                for (std::size_t i = 0; i < camRays.size(); ++i) {
                    vox::CastOptions one = variants[v];
                    one.tStart = std::max(one.tStart, starts[i]);
                    const vox::CastHit expected = caster->cast(camRays[i], one);
                    ++rays;
                    hits += expected.hit;
                    mismatches += !sameHit(expected, many[i]);
                }
            }
    EXPECT_EQ(mismatches, 0u) << "of " << rays << " rays";
    EXPECT_GT(hits, rays / 10);
}

TEST_F(EsvoRaycast, RaysOutsideAndInsideTheCube) {
    const vox::esvo::EsvoReader reader(shared->bigSlices);
    vox::esvo::EsvoPool pool(reader);
    pool.loadAll();
    const vox::EsvoRayCaster caster(pool);
    const vox::RootCube& cube = shared->octree.cube;
    const Vec3d centre = cube.origin + Vec3d{1, 1, 1} * (0.5 * cube.size);
    const double diagonal = std::sqrt(3.0) * caster.leafVoxelSize();

    // Misses the root cube: pointing away from it, and passing beside it.
    const Vec3d outside = centre + Vec3d{3 * cube.size, 0, 0};
    EXPECT_FALSE(caster.cast({outside, {1, 0, 0}}, exact()).hit);
    EXPECT_FALSE(caster.cast({outside, vox::normalize(Vec3d{-1, 0.9, 0})}, exact()).hit);
    EXPECT_FALSE(caster.cast({outside + Vec3d{0, 2 * cube.size, 0}, {-1, 0, 0}}, exact()).hit);
    // From outside the cube towards mesh vertices, along their normals: the octree is hit no
    // later than the mesh, at a point within a leaf diagonal of the surface.
    const vox::Mesh& m = shared->scene.meshes[0];
    int aimed = 0;
    for (std::size_t k = 0; k < m.positions.size(); k += 401) {
        const Vec3d v{m.positions[k].x, m.positions[k].y, m.positions[k].z};
        const Vec3d n = vox::normalize(Vec3d{m.normals[k].x, m.normals[k].y, m.normals[k].z});
        const vox::Ray ray{v + n * (2 * cube.size), -n};
        const vox::CastHit meshHit = shared->mesh->cast(ray);
        const double t = meshHit.hit ? double(meshHit.t) : std::numeric_limits<double>::infinity();
        ASSERT_TRUE(std::isfinite(t));  // at the latest, the vertex itself
        const vox::CastHit h = caster.cast(ray, exact());
        ASSERT_TRUE(h.hit) << "vertex " << k;
        EXPECT_LE(h.t, t + 1e-5) << "vertex " << k;
        EXPECT_LE(meshDistance(shared->scene, ray.origin + ray.direction * double(h.t)), diagonal)
            << "vertex " << k;
        EXPECT_EQ(h.level, kDepth);
        // tMax short of the octree hit: no hit.
        vox::CastOptions shortRay = exact();
        shortRay.tMax = 0.99 * h.t;
        EXPECT_FALSE(caster.cast(ray, shortRay).hit) << "vertex " << k;
        ++aimed;
    }
    EXPECT_GT(aimed, 20);

    // Starting inside the cube, in empty space (the centre of the model's bounds, inside its
    // body): finds the same surface the mesh does.
    const vox::Bounds3f b = shared->scene.bounds();
    const Vec3d middle{(b.min.x + b.max.x) / 2.0, (b.min.y + b.max.y) / 2.0,
                       (b.min.z + b.max.z) / 2.0};
    EXPECT_GT(meshDistance(shared->scene, middle), 10 * diagonal);
    int inside = 0;
    for (const Vec3d dir : {Vec3d{1, 0, 0}, Vec3d{0, -1, 0}, Vec3d{0, 0.3, 1}, Vec3d{-1, -0.2, 0.1},
                            Vec3d{0.3, 1, -0.5}}) {
        const vox::Ray ray{middle, vox::normalize(dir)};
        const vox::CastHit meshHit = shared->mesh->cast(ray);
        const double t = meshHit.hit ? double(meshHit.t) : std::numeric_limits<double>::infinity();
        const vox::CastHit h = caster.cast(ray, exact());
        if (!std::isfinite(t)) continue;
        ++inside;
        ASSERT_TRUE(h.hit);
        EXPECT_GE(h.t, 0.0f);
        EXPECT_LE(h.t, t + 1e-5);
        EXPECT_LE(meshDistance(shared->scene, ray.origin + ray.direction * double(h.t)), diagonal);
    }
    EXPECT_GE(inside, 3);
    // Starting on the surface (a mesh vertex): inside a leaf voxel, so t = 0 at the leaf level.
    const vox::Vec3f v = shared->scene.meshes[0].positions[shared->scene.meshes[0].indices[0]];
    const vox::CastHit onSurface =
        caster.cast({{v.x, v.y, v.z}, vox::normalize(Vec3d{0.3, 0.4, 0.5})}, exact());
    ASSERT_TRUE(onSurface.hit);
    EXPECT_EQ(onSurface.t, 0.0f);
    EXPECT_EQ(onSurface.level, kDepth);
}

namespace {

struct DepthAgreement {
    double hitMiss = 0, withinDiagonal = 0, meanError = 0, p95Error = 0, worstBehind = 0;
    std::uint64_t voxels = 0;
};

/// Octree (with @p options for the voxelizer) against the mesh over the three cameras.
DepthAgreement compareWithMesh(const vox::SurfaceVoxelizeOptions& options,
                               const std::string& name) {
    const vox::SparseOctree octree = vox::voxelizeSurface(shared->scene, options);
    vox::EsvoWriteOptions write;
    write.sceneBounds = shared->scene.bounds();
    const fs::path file = shared->dir / (name + ".esvo");
    (void)vox::writeEsvo(file, octree, write);
    const vox::esvo::EsvoReader reader(file);
    EXPECT_NO_THROW((void)vox::esvo::validateFile(reader));
    vox::esvo::EsvoPool pool(reader);
    pool.loadAll();
    const vox::EsvoRayCaster caster(pool);
    const double diagonal = std::sqrt(3.0) * caster.leafVoxelSize();
    std::uint64_t pixels = 0, agree = 0, both = 0, within = 0;
    std::vector<double> errors;
    DepthAgreement r;
    for (const auto& cam : shared->cameras) {
        const auto mesh = renderMesh(cam);
        const vox::RenderBuffers oct = vox::renderEsvo(caster, cam, exact());
        for (std::size_t i = 0; i < mesh.size(); ++i) {
            ++pixels;
            const bool mh = std::isfinite(mesh[i].t), oh = std::isfinite(oct.depth[i]);
            agree += mh == oh;
            if (!(mh && oh)) continue;
            ++both;
            const double e = double(oct.depth[i]) - mesh[i].t;
            errors.push_back(std::abs(e) / diagonal);
            within += std::abs(e) <= diagonal;
            r.worstBehind = std::max(r.worstBehind, e / diagonal);
        }
    }
    std::sort(errors.begin(), errors.end());
    r.hitMiss = double(agree) / double(pixels);
    r.withinDiagonal = double(within) / double(both);
    for (double e : errors) r.meanError += e / double(errors.size());
    r.p95Error = errors[errors.size() * 95 / 100];
    r.voxels = octree.voxelCount();
    std::printf(
        "%-22s voxels %9llu  hit/miss %.3f%%  within a diagonal %.2f%%  mean %.3f  p95 %.3f "
        "diagonals  worst behind %.4f\n",
        name.c_str(), static_cast<unsigned long long>(r.voxels), 100 * r.hitMiss,
        100 * r.withinDiagonal, r.meanError, r.p95Error, r.worstBehind);
    return r;
}

}  // namespace

TEST_F(EsvoRaycast, ContoursTightenDepthAndRefinementStopsEarlyAtEqualError) {
    vox::SurfaceVoxelizeOptions cubes;
    cubes.depth = kDepth;
    vox::SurfaceVoxelizeOptions withContours = cubes;
    withContours.contours = true;
    vox::SurfaceVoxelizeOptions refined = withContours;
    refined.contourError = 0.5;
    const DepthAgreement c = compareWithMesh(cubes, "cubes");
    const DepthAgreement k = compareWithMesh(withContours, "contours");
    const DepthAgreement e = compareWithMesh(refined, "contours_error_0.5");
    // Same voxels, but the slabs cut the layer down to the surface.
    EXPECT_EQ(k.voxels, c.voxels);
    EXPECT_GE(k.hitMiss, c.hitMiss);
    EXPECT_LT(k.meanError, 0.25 * c.meanError);
    EXPECT_LT(k.p95Error, 0.5 * c.p95Error);
    EXPECT_GE(k.withinDiagonal, 0.99) << "with contours the octree issue's depth bound holds";
    // Conservative slabs: never noticeably behind the surface.
    EXPECT_LT(k.worstBehind, 0.01);
    EXPECT_LT(e.worstBehind, 0.01);
    // Error-driven refinement: far fewer voxels at no worse error than cubes at full depth.
    EXPECT_LT(e.voxels, c.voxels / 4);
    EXPECT_LE(e.p95Error, c.p95Error);
    EXPECT_LE(e.meanError, c.meanError);
    EXPECT_GE(e.hitMiss, 0.995);
}
