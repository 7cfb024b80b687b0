#include "scene_occupancy.h"

#include "../util/segment_clip.h"

#include <vox/formats/rvol.h>

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace vox {

SceneOccupancy::SceneOccupancy(const Scene& scene, const RootCube& cube, std::uint32_t depth,
                               std::uint32_t binDepth)
    : depth_(depth), binDepth_(std::min(binDepth, depth)), shift_(depth - binDepth_) {
    // Leaf units exactly as voxelizeSurface computes them, so that the contact tests agree.
    const double scale = std::ldexp(1.0, static_cast<int>(depth_)) / cube.size;
    const auto toLeaf = [&](Vec3f p) {
        return Vec3d{(p.x - cube.origin.x) * scale, (p.y - cube.origin.y) * scale,
                     (p.z - cube.origin.z) * scale};
    };
    for (const Mesh& mesh : scene.meshes) {
        if (mesh.dynamic) continue;
        for (std::size_t t = 0; t < mesh.triangleCount(); ++t)
            triangles_.push_back(
                detail::prepareBoxTest(toLeaf(mesh.positions[mesh.indices[3 * t]]),
                                       toLeaf(mesh.positions[mesh.indices[3 * t + 1]]),
                                       toLeaf(mesh.positions[mesh.indices[3 * t + 2]])));
    }
    // (bin Morton code, triangle) for every bin a triangle touches (closed cubes), sorted: the
    // same pairs whatever the thread count.
    const std::uint32_t binsPerAxis = 1u << binDepth_;
    const double binSize = std::ldexp(1.0, static_cast<int>(shift_));
    tbb::enumerable_thread_specific<std::vector<std::pair<std::uint64_t, std::uint32_t>>> local;
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, triangles_.size(), 1024),
        [&](const tbb::blocked_range<std::size_t>& r) {
            auto& out = local.local();
            for (std::size_t t = r.begin(); t != r.end(); ++t) {
                const detail::BoxTestTriangle& tri = triangles_[t];
                std::uint32_t first[3], last[3];
                bool inside = true;
                for (int axis = 0; axis < 3; ++axis) {
                    const double lo =
                        std::min({tri.v0[axis], tri.v1[axis], tri.v2[axis]}) / binSize;
                    const double hi =
                        std::max({tri.v0[axis], tri.v1[axis], tri.v2[axis]}) / binSize;
                    if (!(hi >= 0 && lo <= binsPerAxis)) inside = false;
                    first[axis] = static_cast<std::uint32_t>(
                        std::clamp(std::ceil(lo) - 1.0, 0.0, double(binsPerAxis - 1)));
                    last[axis] = static_cast<std::uint32_t>(
                        std::clamp(std::floor(hi), 0.0, double(binsPerAxis - 1)));
                }
                if (!inside) continue;
                for (std::uint32_t z = first[2]; z <= last[2]; ++z)
                    for (std::uint32_t y = first[1]; y <= last[1]; ++y)
                        for (std::uint32_t x = first[0]; x <= last[0]; ++x) {
                            const Vec3d centre{(x + 0.5) * binSize, (y + 0.5) * binSize,
                                               (z + 0.5) * binSize};
                            if (detail::triangleOverlapsCube(tri, centre, 0.5 * binSize))
                                out.emplace_back(rvol::morton3(x, y, z),
                                                 static_cast<std::uint32_t>(t));
                        }
            }
        });
    std::vector<std::pair<std::uint64_t, std::uint32_t>> pairs;
    for (auto& part : local) pairs.insert(pairs.end(), part.begin(), part.end());
    tbb::parallel_sort(pairs.begin(), pairs.end());
    binTriangles_.reserve(pairs.size());
    std::vector<std::array<std::uint32_t, 3>> nonEmpty;
    for (std::size_t i = 0; i < pairs.size(); ++i) {
        if (i == 0 || pairs[i].first != pairs[i - 1].first) {
            binCodes_.push_back(pairs[i].first);
            binStart_.push_back(i);
            nonEmpty.push_back(rvol::demorton3(pairs[i].first));
        }
        binTriangles_.push_back(pairs[i].second);
    }
    binStart_.push_back(pairs.size());
    bins_.emplace(binDepth_, nonEmpty);
}

std::pair<std::size_t, std::size_t> SceneOccupancy::binOf(const std::int64_t c[3]) const {
    const std::uint64_t code = rvol::morton3(static_cast<std::uint32_t>(c[0] >> shift_),
                                             static_cast<std::uint32_t>(c[1] >> shift_),
                                             static_cast<std::uint32_t>(c[2] >> shift_));
    const auto it = std::lower_bound(binCodes_.begin(), binCodes_.end(), code);
    if (it == binCodes_.end() || *it != code) return {0, 0};
    const auto b = static_cast<std::size_t>(it - binCodes_.begin());
    return {binStart_[b], binStart_[b + 1]};
}

bool SceneOccupancy::cellSolid(const std::int64_t c[3],
                               std::pair<std::size_t, std::size_t> range) const {
    const Vec3d centre{double(c[0]) + 0.5, double(c[1]) + 0.5, double(c[2]) + 0.5};
    for (std::size_t i = range.first; i < range.second; ++i)
        if (detail::triangleOverlapsCube(triangles_[binTriangles_[i]], centre, 0.5)) return true;
    return false;
}

bool SceneOccupancy::solid(std::int64_t x, std::int64_t y, std::int64_t z) const {
    const std::int64_t r = std::int64_t{1} << depth_;
    if (x < 0 || y < 0 || z < 0 || x >= r || y >= r || z >= r) return false;
    const std::int64_t c[3] = {x, y, z};
    return cellSolid(c, binOf(c));
}

bool SceneOccupancy::occluded(Vec3d origin, Vec3d dir, double t0, double t1,
                              std::array<std::int64_t, 3> skip) const {
    // SolidGrid::occluded's walk (the same sample points, 1e-9 past each boundary), the grid of
    // bins skipping empty space.
    const std::int64_t resolution = std::int64_t{1} << depth_;
    const double r = double(resolution);
    if (!detail::clipSegmentToCube(origin, dir, r, t0, t1)) return false;
    const std::int64_t binCells = std::int64_t{1} << shift_;
    std::int64_t lastBin[3] = {-1, -1, -1};
    std::pair<std::size_t, std::size_t> range{0, 0};
    double t = t0;
    while (t < t1) {
        const Vec3d p = origin + dir * (t + 1e-9);
        std::int64_t c[3] = {static_cast<std::int64_t>(std::floor(p.x)),
                             static_cast<std::int64_t>(std::floor(p.y)),
                             static_cast<std::int64_t>(std::floor(p.z))};
        for (auto& v : c) v = std::clamp<std::int64_t>(v, 0, resolution - 1);
        const std::int64_t bin[3] = {c[0] >> shift_, c[1] >> shift_, c[2] >> shift_};
        const bool empty = !bins_->solid(bin[0], bin[1], bin[2]);
        if (!empty && (bin[0] != lastBin[0] || bin[1] != lastBin[1] || bin[2] != lastBin[2])) {
            range = binOf(c);
            std::copy(bin, bin + 3, lastBin);
        }
        const std::int64_t size = empty ? binCells : 1;
        const std::int64_t lo[3] = {empty ? bin[0] * binCells : c[0],
                                    empty ? bin[1] * binCells : c[1],
                                    empty ? bin[2] * binCells : c[2]};
        if (!empty && !(c[0] == skip[0] && c[1] == skip[1] && c[2] == skip[2]) &&
            cellSolid(c, range))
            return true;
        t = std::max(detail::exitOfCube(origin, dir, lo, size), t + 1e-7);
    }
    return false;
}

}  // namespace vox
