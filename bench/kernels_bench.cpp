// The build's and the runtime's inner kernels under Google Benchmark (issue 9), each on real data
// and, where there is one, against a peer in the same run:
// - the triangle/box test (libvox/src/octree/triangle_box.h) on the triangles of a 65,536-triangle
//   bumpy sphere in leaf units at depths 6, 8 and 10 (mean triangle edges of 0.8, 3.2 and 13 leaf
//   voxels, counter edge_voxels: what the 1,048,576-triangle sphere has at depths 8, 10 and 12):
//   prepareBoxTest per triangle; triangleOverlapsCube against every leaf cell of the triangle's
//   bounding box (the binning pattern); childOverlapMask on the (triangle, cell) pairs the
//   voxelizer visits at the level above the leaves, against its peer, eight triangleOverlapsCube
//   calls;
// - descriptor layout: vox::writeEsvo of the sphere's octree (depth 9, about 1.9 M voxels;
//   without colours, so the layout, far pointers, slices, contours and the write alone), cubes only
//   and with contours, to a file in the temporary directory;
// - DXT encode: vox::detail::encodeCompressedBlock on the real blocks writeEsvo forms (Cornell box
//   at depth 8: textured and flat walls; the sphere at depth 8: smooth normals; at most 16,384 of
//   each, sampled over all levels), and its colour
//   half, encodeColorBlock, against stb_dxt on the same blocks;
// - ray casting: the CPU EsvoRayCaster, one thread, one primary ray per pixel of a 256×192 view of
//   the sphere at depth 10 (leaves, level-of-detail cut, attributes), against the BVH triangle
//   caster on the mesh itself: the Mrays counter (per second).
// items_per_second is the throughput of every benchmark: triangles, tests, pairs, voxels,
// blocks or rays per second. Scenes are generated at start-up into a temporary directory.
// Usage: kernels_bench [Google Benchmark options, e.g. --benchmark_filter=Box
// --benchmark_format=json]
#include "attribute_corpus.h"
#include "octree/attribute_encode.h"
#include "octree/triangle_box.h"

#include "bumpy_sphere.h"
#include "cornell_box.h"

#include <vox/formats/esvo_reader.h>
#include <vox/import.h>
#include <vox/octree.h>
#include <vox/raycast.h>
#include <vox/triangle_raycast.h>
#include <vox/util/log.h>
#include <vox/util/parallel.h>

#include <benchmark/benchmark.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace {

using vox::Vec3d;
using vox::detail::BoxTestTriangle;

/// The scenes, generated once into a directory removed at exit.
class Data {
public:
    static Data& get() {
        static Data data;
        return data;
    }
    ~Data() {
        std::error_code ignored;
        std::filesystem::remove_all(dir_, ignored);
    }
    Data(const Data&) = delete;
    Data& operator=(const Data&) = delete;

    const std::filesystem::path& dir() const { return dir_; }
    const vox::Scene& sphere() {
        if (sphere_.meshes.empty())
            sphere_ = vox::importScene(
                vox::scenes::writeBumpySphere(dir_, 129, 256));  // 65,536 triangles
        return sphere_;
    }
    const vox::Scene& cornell() {
        if (cornell_.meshes.empty())
            cornell_ = vox::importScene(vox::scenes::writeCornellBox(dir_));
        return cornell_;
    }

private:
    Data()
        : dir_(std::filesystem::temp_directory_path() /
               ("libvox_kernels_bench_" + std::to_string(::getpid()))) {
        vox::log::setVerbosity(vox::log::Verbosity::Quiet);
        std::filesystem::create_directories(dir_);
    }
    std::filesystem::path dir_;
    vox::Scene sphere_, cornell_;
};

// ---- triangle/box test ----------------------------------------------------------------------

/// The sphere's triangles in leaf units at @p depth (the cube [0, 2^depth]³), as voxelizeSurface
/// prepares them.
struct LeafTriangles {
    std::vector<std::array<Vec3d, 3>> vertices;
    std::vector<BoxTestTriangle> prepared;
    double meanEdge = 0;  ///< in leaf voxels
};

const LeafTriangles& leafTriangles(std::uint32_t depth) {
    static std::map<std::uint32_t, LeafTriangles> cache;
    auto [it, inserted] = cache.try_emplace(depth);
    if (!inserted) return it->second;
    const vox::Scene& scene = Data::get().sphere();
    const vox::RootCube cube = vox::RootCube::enclosing(scene.bounds());
    const double scale = std::ldexp(1.0, static_cast<int>(depth)) / cube.size;
    for (const vox::Mesh& mesh : scene.meshes)
        for (std::size_t t = 0; t < mesh.triangleCount(); ++t) {
            std::array<Vec3d, 3> v;
            for (int k = 0; k < 3; ++k) {
                const vox::Vec3f p = mesh.positions[mesh.indices[3 * t + k]];
                v[k] = {(p.x - cube.origin.x) * scale, (p.y - cube.origin.y) * scale,
                        (p.z - cube.origin.z) * scale};
            }
            it->second.meanEdge +=
                vox::length(v[1] - v[0]) + vox::length(v[2] - v[1]) + vox::length(v[0] - v[2]);
            it->second.vertices.push_back(v);
            it->second.prepared.push_back(vox::detail::prepareBoxTest(v[0], v[1], v[2]));
        }
    it->second.meanEdge /= 3.0 * static_cast<double>(it->second.vertices.size());
    return it->second;
}

/// A triangle and an integer cell of some size.
struct Pair {
    std::uint32_t triangle;
    std::int32_t x, y, z;
};

/// Every (triangle, cell of edge @p cellSize) with the cell in the triangle's bounding box,
/// keeping only overlapping ones when @p overlappingOnly; triangles are taken at a stride so that
/// about @p limit pairs come out, spread over the whole mesh.
std::vector<Pair> cellPairs(const LeafTriangles& tris, double cellSize, bool overlappingOnly,
                            std::size_t limit) {
    const auto cellsOf = [&](const std::array<Vec3d, 3>& v, int axis) {
        const double lo = std::min({v[0][axis], v[1][axis], v[2][axis]}),
                     hi = std::max({v[0][axis], v[1][axis], v[2][axis]});
        return std::pair{static_cast<std::int32_t>(std::floor(lo / cellSize)),
                         static_cast<std::int32_t>(std::floor(hi / cellSize))};
    };
    std::size_t total = 0;
    for (std::size_t t = 0; t < tris.vertices.size(); t += 97) {
        std::size_t n = 1;
        for (int axis = 0; axis < 3; ++axis) {
            const auto [lo, hi] = cellsOf(tris.vertices[t], axis);
            n *= static_cast<std::size_t>(hi - lo + 1);
        }
        total += n;
    }
    const double estimate = static_cast<double>(total) * 97.0;
    const std::size_t stride =
        std::max<std::size_t>(1, static_cast<std::size_t>(estimate / static_cast<double>(limit)));
    std::vector<Pair> pairs;
    for (std::size_t t = 0; t < tris.vertices.size(); t += stride) {
        const auto [x0, x1] = cellsOf(tris.vertices[t], 0);
        const auto [y0, y1] = cellsOf(tris.vertices[t], 1);
        const auto [z0, z1] = cellsOf(tris.vertices[t], 2);
        for (std::int32_t z = z0; z <= z1; ++z)
            for (std::int32_t y = y0; y <= y1; ++y)
                for (std::int32_t x = x0; x <= x1; ++x) {
                    const Vec3d centre{(x + 0.5) * cellSize, (y + 0.5) * cellSize,
                                       (z + 0.5) * cellSize};
                    if (overlappingOnly && !vox::detail::triangleOverlapsCube(
                                               tris.prepared[t], centre, 0.5 * cellSize))
                        continue;
                    pairs.push_back({static_cast<std::uint32_t>(t), x, y, z});
                }
    }
    return pairs;
}

void BM_PrepareBoxTest(benchmark::State& state) {
    const LeafTriangles& tris = leafTriangles(static_cast<std::uint32_t>(state.range(0)));
    for (auto _ : state)
        for (const auto& v : tris.vertices)
            benchmark::DoNotOptimize(vox::detail::prepareBoxTest(v[0], v[1], v[2]));
    state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * tris.vertices.size()));
}
BENCHMARK(BM_PrepareBoxTest)->ArgName("depth")->Arg(8);

void BM_TriangleOverlapsCube(benchmark::State& state) {
    const LeafTriangles& tris = leafTriangles(static_cast<std::uint32_t>(state.range(0)));
    const std::vector<Pair> pairs = cellPairs(tris, 1.0, false, 1u << 20);
    std::uint64_t hits = 0;
    for (auto _ : state) {
        hits = 0;
        for (const Pair& p : pairs)
            hits += vox::detail::triangleOverlapsCube(tris.prepared[p.triangle],
                                                      {p.x + 0.5, p.y + 0.5, p.z + 0.5}, 0.5);
        benchmark::DoNotOptimize(hits);
    }
    state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * pairs.size()));
    state.counters["overlap_fraction"] =
        static_cast<double>(hits) / static_cast<double>(pairs.size());
    state.counters["edge_voxels"] = tris.meanEdge;
}
BENCHMARK(BM_TriangleOverlapsCube)->ArgName("depth")->Arg(6)->Arg(8)->Arg(10);

/// The (triangle, cell) pairs the voxelizer visits at the level above the leaves (cells of edge 2
/// that the triangle touches), and their eight children's test.
template <bool Shared>
void childMasks(benchmark::State& state) {
    const LeafTriangles& tris = leafTriangles(static_cast<std::uint32_t>(state.range(0)));
    const std::vector<Pair> pairs = cellPairs(tris, 2.0, true, 1u << 19);
    std::uint64_t children = 0;
    for (auto _ : state) {
        children = 0;
        for (const Pair& p : pairs) {
            const BoxTestTriangle& tri = tris.prepared[p.triangle];
            const Vec3d centre{2.0 * p.x + 1, 2.0 * p.y + 1, 2.0 * p.z + 1};
            std::uint32_t mask = 0;
            if constexpr (Shared) {
                mask = vox::detail::childOverlapMask(tri, centre, 1.0);
            } else {
                for (std::uint32_t slot = 0; slot < 8; ++slot) {
                    const Vec3d c{centre.x + (slot & 1u ? 0.5 : -0.5),
                                  centre.y + (slot & 2u ? 0.5 : -0.5),
                                  centre.z + (slot & 4u ? 0.5 : -0.5)};
                    if (vox::detail::triangleOverlapsCube(tri, c, 0.5)) mask |= 1u << slot;
                }
            }
            children += static_cast<unsigned>(__builtin_popcount(mask));
        }
        benchmark::DoNotOptimize(children);
    }
    state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * pairs.size()));
    state.counters["children_per_pair"] =
        static_cast<double>(children) / static_cast<double>(pairs.size());
    state.counters["edge_voxels"] = tris.meanEdge;
}
void BM_ChildOverlapMask(benchmark::State& state) { childMasks<true>(state); }
void BM_ChildOverlapMask_Peer8Tests(benchmark::State& state) { childMasks<false>(state); }
BENCHMARK(BM_ChildOverlapMask)->ArgName("depth")->Arg(6)->Arg(8)->Arg(10);
BENCHMARK(BM_ChildOverlapMask_Peer8Tests)->ArgName("depth")->Arg(6)->Arg(8)->Arg(10);

// ---- descriptor layout ----------------------------------------------------------------------

const vox::SparseOctree& sphereOctree(std::uint32_t depth, bool contours, bool attributes) {
    static std::map<std::tuple<std::uint32_t, bool, bool>, vox::SparseOctree> cache;
    auto [it, inserted] = cache.try_emplace({depth, contours, attributes});
    if (inserted) {
        vox::SurfaceVoxelizeOptions options;
        options.depth = depth;
        options.contours = contours;
        options.attributes = attributes;
        it->second = vox::voxelizeSurface(Data::get().sphere(), options);
    }
    return it->second;
}

void BM_WriteEsvo(benchmark::State& state) {
    const bool contours = state.range(1) != 0;
    const vox::SparseOctree& octree =
        sphereOctree(static_cast<std::uint32_t>(state.range(0)), contours, false);
    const std::filesystem::path file = Data::get().dir() / "layout.esvo";
    vox::EsvoWriteOptions options;
    options.attributes = vox::AttributeEncoding::None;
    options.sceneBounds = Data::get().sphere().bounds();
    vox::Timings timings;
    options.timings = &timings;
    std::uint64_t bytes = 0;
    for (auto _ : state) bytes = vox::writeEsvo(file, octree, options).fileBytes;
    state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * octree.voxelCount()));
    state.counters["voxels"] = static_cast<double>(octree.voxelCount());
    state.counters["bytes_per_voxel"] =
        static_cast<double>(bytes) / static_cast<double>(octree.voxelCount());
    const double total = timings.get("esvo_layout") + timings.get("esvo_write");
    if (total > 0) state.counters["layout_share"] = timings.get("esvo_layout") / total;
}
BENCHMARK(BM_WriteEsvo)
    ->ArgNames({"depth", "contours"})
    ->Args({9, 0})
    ->Args({9, 1})
    ->Unit(benchmark::kMillisecond);

// ---- DXT encode -----------------------------------------------------------------------------

const std::vector<vox::corpus::SceneBlock>& blocks(int scene) {
    static std::map<int, std::vector<vox::corpus::SceneBlock>> cache;
    auto [it, inserted] = cache.try_emplace(scene);
    if (inserted) {
        vox::SurfaceVoxelizeOptions options;
        options.depth = 8;
        options.attributes = true;
        const auto all = vox::corpus::sceneBlocks(vox::voxelizeSurface(
            scene == 0 ? Data::get().cornell() : Data::get().sphere(), options));
        // At most 16,384 blocks, taken at a stride over every level, so one pass stays short.
        const std::size_t stride = (all.size() + 16383) / 16384;
        for (std::size_t i = 0; i < all.size(); i += stride) it->second.push_back(all[i]);
    }
    return it->second;
}

void BM_EncodeCompressedBlock(benchmark::State& state) {
    const auto& corpus = blocks(static_cast<int>(state.range(0)));
    for (auto _ : state)
        for (const auto& b : corpus)
            benchmark::DoNotOptimize(vox::detail::encodeCompressedBlock(b.values, b.mask));
    state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * corpus.size()));
    state.SetLabel(state.range(0) == 0 ? "cornell box" : "bumpy sphere");
}
BENCHMARK(BM_EncodeCompressedBlock)
    ->ArgName("scene")
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMillisecond);

/// The colour halves of the same blocks, as encodeColorBlock and stb_dxt take them.
std::vector<vox::corpus::ColorBlock> colorBlocks(int scene) {
    std::vector<vox::corpus::ColorBlock> out;
    for (const auto& b : blocks(scene)) {
        vox::corpus::ColorBlock c;
        c.mask = b.mask;
        for (unsigned s = 0; s < 16; ++s)
            c.colors[s] = static_cast<std::uint32_t>(b.values[s]) | 0xFF000000u;
        out.push_back(c);
    }
    return out;
}

template <bool Stb>
void colorEncode(benchmark::State& state) {
    const auto corpus = colorBlocks(static_cast<int>(state.range(0)));
    for (auto _ : state)
        for (const auto& b : corpus) {
            if constexpr (Stb)
                benchmark::DoNotOptimize(vox::corpus::stbEncode(b, false));
            else
                benchmark::DoNotOptimize(vox::detail::encodeColorBlock(b.colors, b.mask));
        }
    state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * corpus.size()));
    state.SetLabel(state.range(0) == 0 ? "cornell box" : "bumpy sphere");
}
void BM_EncodeColorBlock(benchmark::State& state) { colorEncode<false>(state); }
void BM_EncodeColorBlock_PeerStbDxt(benchmark::State& state) { colorEncode<true>(state); }
BENCHMARK(BM_EncodeColorBlock)->ArgName("scene")->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_EncodeColorBlock_PeerStbDxt)
    ->ArgName("scene")
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMillisecond);

// ---- ray casting ----------------------------------------------------------------------------

/// The sphere at depth 10 with contours and colours, written and loaded whole.
struct CastData {
    std::unique_ptr<vox::esvo::EsvoReader> reader;
    std::unique_ptr<vox::esvo::EsvoPool> pool;
    std::unique_ptr<vox::EsvoRayCaster> caster;
    std::unique_ptr<vox::TriangleRayCaster> triangles;
    vox::PinholeCamera camera;
};

CastData& castData() {
    static CastData data = [] {
        CastData d;
        const vox::Scene& scene = Data::get().sphere();
        vox::SurfaceVoxelizeOptions options;
        options.depth = 10;
        options.contours = true;
        options.attributes = true;
        const std::filesystem::path file = Data::get().dir() / "cast.esvo";
        vox::EsvoWriteOptions write;
        write.sceneBounds = scene.bounds();
        (void)vox::writeEsvo(file, vox::voxelizeSurface(scene, options), write);
        d.reader = std::make_unique<vox::esvo::EsvoReader>(file);
        d.pool = std::make_unique<vox::esvo::EsvoPool>(*d.reader);
        d.pool->loadAll();
        d.caster = std::make_unique<vox::EsvoRayCaster>(*d.pool);
        d.triangles = std::make_unique<vox::TriangleRayCaster>(scene);
        d.camera.eye = {0.3, 0.4, 3.2};  // bench/octree_bench.sh's view
        d.camera.target = {0, 0, 0};
        d.camera.fovYDegrees = 45;
        d.camera.width = 256;
        d.camera.height = 192;
        return d;
    }();
    return data;
}

/// Casts every pixel's primary ray on this thread with @p cast; counts hits.
template <typename Cast>
void castImage(benchmark::State& state, Cast cast) {
    const vox::PinholeCamera& camera = castData().camera;
    std::vector<vox::Ray> rays;
    for (int y = 0; y < camera.height; ++y)
        for (int x = 0; x < camera.width; ++x) rays.push_back(camera.rayThrough(x, y));
    std::uint64_t hits = 0;
    for (auto _ : state) {
        hits = 0;
        for (const vox::Ray& ray : rays) hits += cast(ray);
        benchmark::DoNotOptimize(hits);
    }
    state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * rays.size()));
    state.counters["Mrays"] = benchmark::Counter(
        static_cast<double>(state.iterations() * rays.size()) / 1e6, benchmark::Counter::kIsRate);
    state.counters["hit_fraction"] = static_cast<double>(hits) / static_cast<double>(rays.size());
}

/// The options of mode state.range(0): 0 to the leaves, 1 with the level-of-detail cut, 2 with
/// the attribute lookup; labels the benchmark.
vox::CastOptions castMode(benchmark::State& state) {
    vox::CastOptions options;
    if (state.range(0) == 1) options.lodAngle = castData().camera.pixelAngle();
    if (state.range(0) == 2) options.attributes = true;
    state.SetLabel(state.range(0) == 0   ? "leaves"
                   : state.range(0) == 1 ? "lod"
                                         : "leaves+attributes");
    return options;
}

void BM_EsvoCast(benchmark::State& state) {
    const CastData& d = castData();
    const vox::CastOptions options = castMode(state);
    castImage(state, [&](const vox::Ray& ray) { return d.caster->cast(ray, options).hit; });
}
BENCHMARK(BM_EsvoCast)->ArgName("mode")->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

/// The same rays and modes through EsvoRayCaster::castMany, 256 at a time (eight per AVX2 lane
/// group where the CPU has it; the same hits).
void BM_EsvoCastMany(benchmark::State& state) {
    const CastData& d = castData();
    const vox::CastOptions options = castMode(state);
    std::vector<vox::Ray> rays;
    for (int y = 0; y < d.camera.height; ++y)
        for (int x = 0; x < d.camera.width; ++x) rays.push_back(d.camera.rayThrough(x, y));
    std::vector<vox::CastHit> hits(rays.size());
    constexpr std::size_t kBatch = 256;
    std::uint64_t hitCount = 0;
    for (auto _ : state) {
        for (std::size_t i = 0; i < rays.size(); i += kBatch)
            d.caster->castMany(&rays[i], nullptr, std::min(kBatch, rays.size() - i), options,
                               &hits[i]);
        hitCount = 0;
        for (const vox::CastHit& h : hits) hitCount += h.hit;
        benchmark::DoNotOptimize(hitCount);
    }
    state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * rays.size()));
    state.counters["Mrays"] = benchmark::Counter(
        static_cast<double>(state.iterations() * rays.size()) / 1e6, benchmark::Counter::kIsRate);
    state.counters["hit_fraction"] =
        static_cast<double>(hitCount) / static_cast<double>(rays.size());
}
BENCHMARK(BM_EsvoCastMany)->ArgName("mode")->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

void BM_EsvoCast_PeerTriangles(benchmark::State& state) {
    const CastData& d = castData();
    state.SetLabel("BVH, 65,536 triangles");
    castImage(state,
              [&](const vox::Ray& ray) { return std::isfinite(d.triangles->castSurface(ray).t); });
}
BENCHMARK(BM_EsvoCast_PeerTriangles)->Unit(benchmark::kMillisecond);

}  // namespace

int main(int argc, char** argv) {
    const vox::ThreadLimit oneThread(1);  // kernels, not parallel loops: one thread, less noise
    benchmark::Initialize(&argc, argv);
    if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    return 0;
}
