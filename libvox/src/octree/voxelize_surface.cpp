// Surface voxelization: triangles are binned into the cells of a coarse level, then every cell's
// subtree is built top-down in parallel, each node filtering its parent's triangle list with the
// exact triangle/box test. Per-level mask arrays come out in Morton order (see SparseOctree).
#include "surface_voxelizer.h"

#include "contours.h"
#include "triangle_box.h"
#include "voxel_attributes.h"
#include "../util/huge_pages.h"

#include <vox/base/error.h>
#include <vox/formats/esvo.h>
#include <vox/octree.h>
#include <vox/util/progress.h>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <span>

namespace vox {

RootCube RootCube::enclosing(const Bounds3f& bounds) {
    RootCube cube;
    cube.origin = {bounds.min.x, bounds.min.y, bounds.min.z};
    const double extent =
        std::max({double(bounds.max.x) - bounds.min.x, double(bounds.max.y) - bounds.min.y,
                  double(bounds.max.z) - bounds.min.z});
    cube.size = extent > 0 ? extent : 1.0;
    return cube;
}

std::array<double, 16> RootCube::worldToUnit() const {
    const double s = 1.0 / size;
    return {s, 0, 0, -origin.x * s, 0, s, 0, -origin.y * s, 0, 0, s, -origin.z * s, 0, 0, 0, 1};
}

std::uint64_t SparseOctree::voxelCount() const noexcept {
    std::uint64_t total = 0;
    for (std::uint64_t n : voxelsPerLevel) total += n;
    return total;
}

namespace {

using detail::BoxTestTriangle;

std::uint32_t mortonCell(std::uint32_t x, std::uint32_t y, std::uint32_t z, std::uint32_t levels) {
    std::uint32_t code = 0;
    for (std::uint32_t bit = 0; bit < levels; ++bit)
        code |= (((x >> bit) & 1u) << (3 * bit)) | (((y >> bit) & 1u) << (3 * bit + 1)) |
                (((z >> bit) & 1u) << (3 * bit + 2));
    return code;
}

/// A voxel whose carried slab does not spare it a fit (below) stores a contour of its own only
/// where its fitted slab is at most this fraction of the carried one. With full refinement every
/// voxel refines anyway and an own contour buys only accuracy, so it must be much thinner.
constexpr double kOwnContourGainFull = 0.25;
/// Error-bounded, an own contour above the leaf depth also lets the voxel stop early, saving its
/// subtree, so a smaller gain pays; at the leaf depth nothing stops below it and the carried slab
/// keeps the depth error well within a diagonal, so a leaf-depth voxel fits its own only where
/// none is carried.
constexpr double kOwnContourGainBounded = 0.7;
/// Error-bounded, a carried slab spares a voxel a fit of its own where it is within this fraction
/// of the contour error; and where the voxel's colour deviates by more than kVaryingColor × the
/// colour bound (a texture, a material border), the voxel stops only where its slab is within it
/// too: a ray that enters a voxel away from the surface sees the colour of another part of it.
/// All three fractions measured with bench/fidelity_table.sh (docs/internals/esvo-writer.md).
constexpr double kVaryingColorContourError = 0.5;
constexpr double kVaryingColor = 0.5;
/// Thinnest slab the encoding can state, in edge units: one 0.75 step along a normal of length
/// at most 31·√3.
constexpr double kThinnestSlab = 0.75 / (31 * 1.7320508075688772);

LeafMaterial leafMaterial(const detail::AttributeSums& sums, std::uint32_t x, std::uint32_t y,
                          std::uint32_t z) {
    LeafMaterial out;
    out.x = x;
    out.y = y;
    out.z = z;
    if (!(sums.weight > 0)) return out;
    const double w = 1.0 / sums.weight;
    out.albedo = {static_cast<float>(sums.color.x * w), static_cast<float>(sums.color.y * w),
                  static_cast<float>(sums.color.z * w)};
    out.coverage = static_cast<float>(sums.alpha * w);
    out.emission = {static_cast<float>(sums.emission.x * w),
                    static_cast<float>(sums.emission.y * w),
                    static_cast<float>(sums.emission.z * w)};
    // Where opposite sides of a thin sheet cancel, the heaviest fragment's side stands in (as for
    // the packed normal).
    const Vec3d n =
        length(sums.normal) > 0.05 * sums.weight ? normalize(sums.normal) : sums.dominantNormal;
    out.normals.mean = {static_cast<float>(n.x), static_cast<float>(n.y), static_cast<float>(n.z)};
    for (std::size_t i = 0; i < 6; ++i)
        out.normals.moments[i] = static_cast<float>(sums.normalMoments[i] * w);
    return out;
}

/// Builds one cell's subtree depth-first, appending each node's mask to its level's array after
/// its children: per level, nodes still come out in Morton order.
class SubtreeBuilder {
public:
    /// @p contourError: leaf units; a voxel whose cube ∩ slab lies within it of the surface
    /// stops refining (0: always refine to the leaf depth).
    /// @p attributes: null, or the sampler that filters every voxel's colour and normal.
    /// @p normals: the triangles' (all three arrays), or empty without contours.
    SubtreeBuilder(const std::vector<BoxTestTriangle>& triangles, detail::TriangleNormals normals,
                   std::uint32_t depth, std::uint32_t rootLevel,
                   const SurfaceVoxelizeOptions& options,
                   const detail::AttributeSampler* attributes)
        : triangles_(triangles),
          normals_(normals),
          depth_(depth),
          rootLevel_(rootLevel),
          contours_(options.contours),
          contourError_(options.contourError),
          colorError_(options.colorError),
          normalError_(options.normalErrorDegrees),
          attributes_(attributes),
          childLists_(depth + 1),
          childFragments_(depth + 1),
          childSums_(depth + 1),
          packAttributes_(options.attributes),
          keepLeafMaterials_(options.leafMaterials) {}

    /// Builds the subtree of a node into the builder's outputs (emptied first; copyOutputs hands
    /// them over) and returns the node's mask; a node none of whose children a triangle touches
    /// (possible only where rounding made the parent's test pass) is left out: nothing is
    /// appended. A builder builds one subtree after another (one per thread), its outputs and
    /// scratch buffers grown once, not for every subtree.
    /// @p slab: the node's effective contour (its own, or its parent's carried down; 0: none).
    /// @p sums: with attributes, receives the node's attribute sums.
    std::uint32_t build(std::uint32_t level, std::uint32_t x, std::uint32_t y, std::uint32_t z,
                        std::span<const std::uint32_t> list, std::uint32_t slab = 0,
                        detail::AttributeSums* sums = nullptr) {
        const auto empty = [](auto& levels, std::size_t count) {
            levels.resize(count);
            for (auto& perLevel : levels) perLevel.clear();
        };
        empty(masks_, depth_ - rootLevel_);
        empty(contourOut_, contours_ ? depth_ + 1 - rootLevel_ : 0);
        empty(attributeOut_, packAttributes_ ? depth_ + 1 - rootLevel_ : 0);
        leafMaterials_.clear();
        // The subtree works on a copy of its triangles in list order (entry i: triangle list[i]),
        // with the per-triangle values of the contour fit; list order is kept, so every sum runs
        // in the same order as over list itself.
        local_.clear();
        global_.assign(list.begin(), list.end());
        normalLength_.clear();
        unitNormal_.clear();
        quantisedNormal_.clear();
        rootList_.clear();
        for (const std::uint32_t t : list) {
            rootList_.push_back(static_cast<std::uint32_t>(local_.size()));
            local_.push_back(triangles_[t]);
        }
        if (normals_.length)
            for (const std::uint32_t t : list) {
                normalLength_.push_back(normals_.length[t]);
                unitNormal_.push_back(normals_.unit[t]);
                quantisedNormal_.push_back(normals_.quantised[t]);
            }
        // The contour fit and the attribute filter read fragments: the root's are clipped, every
        // voxel's below split from its parent's.
        detail::CubeFragments* fragments = nullptr;
        if (contours_ || attributes_) {
            const double half = std::ldexp(1.0, static_cast<int>(depth_ - level - 1));
            rootFragments_.clip(
                rootList_, local_, {(2 * x + 1) * half, (2 * y + 1) * half, (2 * z + 1) * half},
                detail::fitContourScale(half), normals_.length ? normalLength_.data() : nullptr);
            fragments = &rootFragments_;
        }
        return buildNode(level, x, y, z, rootList_, fragments, slab, sums);
    }

    /// Copies the last subtree's outputs to @p subtree, into @p storage (which the subtree
    /// must keep: CellSubtree::storage).
    void copyOutputs(detail::CellSubtree& subtree, detail::HugePageArena& storage) const {
        const auto copy = [&](const auto& from, auto& to) {
            to.resize(from.size());
            for (std::size_t level = 0; level < from.size(); ++level)
                to[level] = storage.copy(std::span(from[level]));
        };
        copy(masks_, subtree.masks);
        copy(contourOut_, subtree.contours);
        copy(attributeOut_, subtree.attributes);
        if (keepLeafMaterials_)
            subtree.leafMaterials.assign(leafMaterials_.begin(), leafMaterials_.end());
    }

private:
    /// build() on the subtree's own triangles: @p list indexes local_.
    /// @p fragments: the node's (entry i: list[i]'s), or null where neither contours nor
    /// attributes are wanted.
    std::uint32_t buildNode(std::uint32_t level, std::uint32_t x, std::uint32_t y, std::uint32_t z,
                            std::span<const std::uint32_t> list, detail::CubeFragments* fragments,
                            std::uint32_t slab, detail::AttributeSums* sums) {
        const double half =
            std::ldexp(1.0, static_cast<int>(depth_ - level - 1));  // this node's half-extent
        const Vec3d centre{(2 * x + 1) * half, (2 * y + 1) * half, (2 * z + 1) * half};
        std::uint32_t mask = 0;
        if (level + 1 == depth_ && !contours_ && !attributes_) {
            for (std::uint32_t t : list) {
                mask |= detail::childOverlapMask(local_[t], centre, half);
                if (mask == 0xFF) break;
            }
        } else {
            // The children's lists, in this level's buffer: child s's at s·n, n = list.size(); with
            // fragments, then each child's from this node's, split (in the lists' entry order).
            auto& buffer = childLists_[level + 1];
            const std::size_t n = list.size();
            if (buffer.size() < 8 * n) buffer.resize(8 * n);
            if (entryMasks_.size() < n) entryMasks_.resize(n);
            std::array<std::uint32_t, 8> counts{};
            std::uint32_t touched = 0;
            for (std::size_t entry = 0; entry < n; ++entry) {
                const std::uint32_t t = list[entry];
                const std::uint32_t m = detail::childOverlapMask(local_[t], centre, half);
                entryMasks_[entry] = static_cast<std::uint8_t>(m);
                touched |= m;
                for (std::uint32_t bits = m; bits; bits &= bits - 1) {
                    const auto slot = static_cast<unsigned>(__builtin_ctz(bits));
                    buffer[slot * n + counts[slot]++] = t;
                }
            }
            auto& childFragments = childFragments_[level + 1];
            if (fragments) {
                for (std::uint32_t bits = touched; bits; bits &= bits - 1) {
                    const auto slot = static_cast<unsigned>(__builtin_ctz(bits));
                    childFragments[slot].start(counts[slot]);
                }
                for (std::size_t entry = 0; entry < n; ++entry)
                    if (entryMasks_[entry])
                        fragments->splitInto(entry, entryMasks_[entry], childFragments);
            }
            std::array<std::span<const std::uint32_t>, 8> children;
            for (unsigned slot = 0; slot < 8; ++slot)
                children[slot] = {buffer.data() + slot * n, counts[slot]};
            const detail::ContourCarrier carrier(slab);
            const double childHalf = 0.5 * half;
            for (std::uint32_t slot = 0; slot < 8; ++slot) {
                if (!(touched & (1u << slot))) continue;
                const std::uint32_t cx = 2 * x + (slot & 1u), cy = 2 * y + ((slot >> 1) & 1u),
                                    cz = 2 * z + (slot >> 2);
                const Vec3d childCentre{(2 * cx + 1) * childHalf, (2 * cy + 1) * childHalf,
                                        (2 * cz + 1) * childHalf};
                bool leaf = level + 1 == depth_;
                std::uint32_t childSlab = 0;
                bool filtered =
                    false;  // criterionSums_ are the child's, computed by the attribute criterion
                detail::CubeFragments* ownFragments = fragments ? &childFragments[slot] : nullptr;
                std::uint32_t ownContour = 0;
                detail::AttributeSums& childSums = childSums_[level + 1];
                if (attributes_) clear(childSums);
                if (contours_) {
                    double carriedThickness = 0;
                    const std::uint32_t carried = carrier(slot, carriedThickness);
                    const auto withinError = [&](std::uint32_t candidate, double thickness,
                                                 double error) {
                        // A slab thicker than twice the error cannot be (one of its planes is too
                        // far).
                        return thickness * childHalf <= error &&
                               detail::shapeWithinError(candidate, children[slot], local_,
                                                        childCentre, childHalf, error);
                    };
                    // Where the colour varies across the voxel (kVaryingColor), the slab must be
                    // within the tighter bound for the voxel to stop.
                    const double tightError = kVaryingColorContourError * contourError_;
                    const auto stops = [&](std::uint32_t effective, double thickness,
                                           bool withinTight) {
                        double colorDeviation = 0;
                        if (!attributesWithinBounds(children[slot], *ownFragments, childCentre,
                                                    childHalf, filtered, colorDeviation))
                            return false;
                        return withinTight || colorError_ <= 0 ||
                               colorDeviation <= kVaryingColor * colorError_ ||
                               withinError(effective, thickness, tightError);
                    };
                    // Error-bounded: where the slab its ancestors impose (the ray caster carries
                    // theirs) already bounds the surface within the tighter error, the child
                    // stores no contour of its own, and stops refining there if its attributes
                    // allow.
                    if (contourError_ > 0 && carried &&
                        withinError(carried, carriedThickness, tightError)) {
                        childSlab = carried;
                        if (!leaf) leaf = stops(carried, carriedThickness, true);
                    } else {
                        // Otherwise the child keeps a contour of its own only where it is
                        // enough thinner than the carried slab; below a gain's worth of the
                        // thinnest encodable slab, no fit can win.
                        const double gain = contourError_ <= 0 ? kOwnContourGainFull
                                            : leaf             ? 0.0
                                                               : kOwnContourGainBounded;
                        detail::ContourFit fit;
                        if (!(carried && gain * carriedThickness <= kThinnestSlab))
                            fit = detail::fitContour(*ownFragments, children[slot], local_,
                                                     {normalLength_.data(), unitNormal_.data(),
                                                      quantisedNormal_.data()});
                        double thickness = carriedThickness;
                        childSlab = carried;
                        if (fit.encoded &&
                            (carried == 0 || fit.thickness < gain * carriedThickness)) {
                            ownContour = fit.encoded;
                            childSlab = fit.encoded;
                            thickness = fit.thickness;
                        }
                        // Refinement stops where cube ∩ slab is within the error of the surface.
                        if (!leaf && contourError_ > 0 && childSlab &&
                            withinError(childSlab, thickness, contourError_))
                            leaf = stops(childSlab, thickness, false);
                    }
                }
                if (leaf) {
                    if (level + 1 < depth_)
                        masks_[level + 1 - rootLevel_].push_back(0);  // a leaf above the leaf depth
                    // A leaf's error moments are never read (a voxel's error comes from its own
                    // filtering, not its children's sums): where the criterion did not filter it
                    // (the leaf depth, or no bounds), it is filtered without them.
                    if (attributes_)
                        childSums = filtered ? criterionSums_
                                             : attributes_->filter(
                                                   *ownFragments, children[slot], childCentre,
                                                   childHalf, attributeScratch_, view(), false);
                } else if (buildNode(level + 1, cx, cy, cz, children[slot], ownFragments, childSlab,
                                     &childSums) == 0) {
                    continue;
                }
                // The child's entries at level + 1, in slot order: nothing below appends to them.
                mask |= 1u << slot;
                if (contours_) contourOut_[level + 1 - rootLevel_].push_back(ownContour);
                if (attributes_) {
                    // Packed words only for SparseOctree::attributes; the radiance bake wants the
                    // leaves' sums alone.
                    if (!attributeOut_.empty())
                        attributeOut_[level + 1 - rootLevel_].push_back(childSums.pack());
                    if (keepLeafMaterials_ && level + 1 == depth_)
                        leafMaterials_.push_back(leafMaterial(childSums, cx, cy, cz));
                    if (sums) *sums += childSums;
                }
            }
        }
        if (mask != 0) masks_[level - rootLevel_].push_back(static_cast<std::uint8_t>(mask));
        return mask;
    }

    /// The attribute criterion of refinement: true where the voxel's colour and normal stand for
    /// the surface inside it within the bounds (AttributeSums::error), or where there are none.
    /// criterionSums_ receive the voxel's sums where they were computed (@p computed set), from
    /// @p fragments, the voxel's, and @p colorDeviation its colour's error (0 where not computed).
    bool attributesWithinBounds(std::span<const std::uint32_t> list,
                                const detail::CubeFragments& fragments, Vec3d centre, double half,
                                bool& computed, double& colorDeviation) {
        if (!attributes_ || (colorError_ <= 0 && normalError_ <= 0)) return true;
        criterionSums_ =
            attributes_->filter(fragments, list, centre, half, attributeScratch_, view());
        computed = true;
        const detail::AttributeSums::Error e = criterionSums_.error();
        colorDeviation = e.color;
        return (colorError_ <= 0 || e.color <= colorError_) &&
               (normalError_ <= 0 || e.normalDegrees <= normalError_);
    }
    [[nodiscard]] detail::TriangleView view() const { return {local_.data(), global_.data()}; }

    const std::vector<BoxTestTriangle>& triangles_;
    detail::TriangleNormals normals_;  // of triangles_
    std::uint32_t depth_;
    std::uint32_t rootLevel_;
    bool contours_;
    double contourError_;
    double colorError_, normalError_;
    const detail::AttributeSampler* attributes_;
    std::vector<std::vector<std::uint32_t>>
        childLists_;  // per level: the lists of one node's children
    std::vector<std::array<detail::CubeFragments, 8>>
        childFragments_;                    // per level: the fragments of one node's children
    detail::CubeFragments rootFragments_;   // the subtree root's, clipped
    std::vector<std::uint8_t> entryMasks_;  // per entry of a node's list: its children's mask
    std::vector<detail::AttributeSums> childSums_;  // per level: the sums of the child being built
    detail::AttributeSums criterionSums_;  // a child's, where the attribute criterion filtered it
    std::vector<std::vector<std::uint8_t>>
        masks_;  // [l − rootLevel] for levels rootLevel … depth − 1
    std::vector<std::vector<std::uint32_t>>
        contourOut_;  // [l − rootLevel] for levels rootLevel … depth (rootLevel's empty)
    std::vector<std::vector<std::uint64_t>> attributeOut_;  // as contourOut_
    bool packAttributes_;  // attributeOut_ wanted (SparseOctree::attributes)
    detail::AttributeScratch attributeScratch_;
    bool keepLeafMaterials_;
    std::vector<LeafMaterial> leafMaterials_;
    std::vector<BoxTestTriangle> local_;  // the subtree's triangles, in its root list's order
    std::vector<std::uint32_t> global_;   // local_[i] is triangles_[global_[i]]
    std::vector<double> normalLength_;    // per local_ triangle: length(normal)
    std::vector<Vec3d> unitNormal_;  // per local_ triangle: normal / length (0 where degenerate)
    std::vector<detail::QuantisedNormal>
        quantisedNormal_;                  // per local_ triangle: its unit normal quantised
    std::vector<std::uint32_t> rootList_;  // 0 … local_.size() − 1
};

}  // namespace

std::uint32_t detail::cellLevel(std::uint32_t depth) {
    return std::max(std::min<std::uint32_t>(depth - 1, 4), defaultPartitionLevel(depth));
}

std::uint32_t defaultPartitionLevel(std::uint32_t leafDepth) {
    // Partitions of at most 9 levels (512³ leaf cells); never deeper than 10, the cell level's
    // bound.
    return leafDepth > 9 ? std::min<std::uint32_t>(leafDepth - 9, 10) : 0;
}

detail::UpperLevels detail::buildUpperLevels(std::vector<std::uint32_t> codes,
                                             std::vector<AttributeSums> sums, std::uint32_t level,
                                             std::uint32_t rootLevel) {
    UpperLevels out;
    const bool withSums = !sums.empty();
    out.masks.resize(level - rootLevel);
    out.sums.resize(withSums ? level - rootLevel + 1 : 0);
    out.codes.resize(level - rootLevel + 1);
    for (std::uint32_t l = level; l-- > rootLevel;) {
        std::vector<std::uint32_t> parents;
        std::vector<AttributeSums> parentSums;
        auto& masks = out.masks[l - rootLevel];
        for (std::size_t i = 0; i < codes.size(); ++i) {
            const std::uint32_t code = codes[i];
            if (parents.empty() || parents.back() != (code >> 3)) {
                parents.push_back(code >> 3);
                masks.push_back(0);
                if (withSums) parentSums.emplace_back();
            }
            masks.back() = static_cast<std::uint8_t>(masks.back() | (1u << (code & 7u)));
            if (withSums) parentSums.back() += sums[i];
        }
        out.codes[l + 1 - rootLevel] = std::move(codes);
        if (withSums) out.sums[l + 1 - rootLevel] = std::move(sums);
        codes = std::move(parents);
        sums = std::move(parentSums);
    }
    out.codes[0] = std::move(codes);
    if (withSums) out.sums[0] = std::move(sums);
    return out;
}

detail::SurfaceVoxelizer::SurfaceVoxelizer(const Scene& scene,
                                           const SurfaceVoxelizeOptions& options)
    : scene_(scene), options_(options) {
    if (options.depth < 1 || options.depth > esvo::kMaxLeafDepth)
        throw ParameterError("depth",
                             "must be between 1 and " + std::to_string(esvo::kMaxLeafDepth));
    depth_ = options.depth;
    const auto selected = [&](const Mesh& mesh) {
        return options.onlyDynamic ? mesh.dynamic : (!mesh.dynamic || options.includeDynamic);
    };
    const bool attributes = options.attributes || options.leafMaterials;

    Bounds3f bounds;
    std::size_t triangleCount = 0;
    for (const Mesh& mesh : scene.meshes) {
        if (!selected(mesh)) continue;
        for (std::uint32_t index : mesh.indices) bounds.add(mesh.positions[index]);
        triangleCount += mesh.triangleCount();
    }
    const std::filesystem::path source =
        scene.sourceFiles.empty() ? std::filesystem::path("scene") : scene.sourceFiles.front();
    if (triangleCount == 0)
        throw InvalidDataError(source, options.onlyDynamic ? "no dynamic triangles to voxelize"
                                                           : "no static triangles to voxelize");
    if (triangleCount >= 0xFFFFFFFFull) throw InvalidDataError(source, "more than 2^32 triangles");
    cube_ = options.cube ? *options.cube : RootCube::enclosing(bounds);

    // Triangles in leaf-voxel units: the cube is [0, 2^depth]³. Each mesh's triangles fill their
    // own range, in parallel.
    std::vector<TriangleSource> sources;
    {
        Timings::Scope timer(options.timings, "voxelize_prepare");
        // No huge pages here: where the kernel must compact memory for them, the first touch of
        // this array stalled for a second (55 ms otherwise).
        triangles_.resize(triangleCount);
        if (attributes) sources.resize(triangleCount);
        const double scale = std::ldexp(1.0, static_cast<int>(depth_)) / cube_.size;
        const auto toLeaf = [&](Vec3f p) {
            return Vec3d{(p.x - cube_.origin.x) * scale, (p.y - cube_.origin.y) * scale,
                         (p.z - cube_.origin.z) * scale};
        };
        std::size_t first = 0;
        for (std::uint32_t m = 0; m < scene.meshes.size(); ++m) {
            const Mesh& mesh = scene.meshes[m];
            if (!selected(mesh)) continue;
            tbb::parallel_for(tbb::blocked_range<std::size_t>(0, mesh.triangleCount(), 1 << 14),
                              [&](const tbb::blocked_range<std::size_t>& r) {
                                  for (std::size_t t = r.begin(); t != r.end(); ++t) {
                                      if (attributes)
                                          sources[first + t] = {m, static_cast<std::uint32_t>(t)};
                                      triangles_[first + t] = detail::prepareBoxTest(
                                          toLeaf(mesh.positions[mesh.indices[3 * t]]),
                                          toLeaf(mesh.positions[mesh.indices[3 * t + 1]]),
                                          toLeaf(mesh.positions[mesh.indices[3 * t + 2]]));
                                  }
                              });
            first += mesh.triangleCount();
        }
    }
    if (attributes)
        sampler_.emplace(scene, triangles_, std::move(sources),
                         options.contours && options.contourError > 0 &&
                             (options.colorError > 0 || options.normalErrorDegrees > 0));
    if (options.contours) {
        // What the contour fit would otherwise compute per cell (or voxel) a triangle is in.
        normalLengths_.resize(triangles_.size());
        unitNormals_.resize(triangles_.size());
        quantisedNormals_.resize(triangles_.size());
        tbb::parallel_for(
            tbb::blocked_range<std::size_t>(0, triangles_.size(), 4096),
            [&](const tbb::blocked_range<std::size_t>& r) {
                for (std::size_t t = r.begin(); t != r.end(); ++t) {
                    const double nl = length(triangles_[t].normal);
                    normalLengths_[t] = nl;
                    unitNormals_[t] = nl > 0 ? triangles_[t].normal * (1.0 / nl) : Vec3d{0, 0, 0};
                    quantisedNormals_[t] = detail::quantiseDirection(unitNormals_[t], true);
                }
            });
    }

    // Bin triangles into the cells of the cell level k: (Morton code << 32 | triangle), sorted.
    const std::uint32_t k = cellLevel_ = detail::cellLevel(depth_);
    const std::uint32_t cellsPerAxis = 1u << k;
    const double cellSize = std::ldexp(1.0, static_cast<int>(depth_ - k));
    std::vector<float> cellShare(triangles_.size());  // area per cell of each triangle
    {
        Timings::Scope timer(options.timings, "voxelize_bin");
        tbb::enumerable_thread_specific<std::vector<std::uint64_t>> local;
        tbb::parallel_for(
            tbb::blocked_range<std::size_t>(0, triangles_.size(), 4096),
            [&](const tbb::blocked_range<std::size_t>& r) {
                auto& out = local.local();
                for (std::size_t t = r.begin(); t != r.end(); ++t) {
                    const BoxTestTriangle& tri = triangles_[t];
                    std::uint32_t first[3], last[3];
                    for (int axis = 0; axis < 3; ++axis) {
                        const double lo =
                            std::min({tri.v0[axis], tri.v1[axis], tri.v2[axis]}) / cellSize;
                        const double hi =
                            std::max({tri.v0[axis], tri.v1[axis], tri.v2[axis]}) / cellSize;
                        // Closed cells: a vertex on a cell boundary touches the cells on both
                        // sides.
                        first[axis] = static_cast<std::uint32_t>(
                            std::clamp(std::ceil(lo) - 1.0, 0.0, double(cellsPerAxis - 1)));
                        last[axis] = static_cast<std::uint32_t>(
                            std::clamp(std::floor(hi), 0.0, double(cellsPerAxis - 1)));
                    }
                    std::size_t binned = 0;
                    for (std::uint32_t z = first[2]; z <= last[2]; ++z)
                        for (std::uint32_t y = first[1]; y <= last[1]; ++y)
                            for (std::uint32_t x = first[0]; x <= last[0]; ++x) {
                                const Vec3d centre{(x + 0.5) * cellSize, (y + 0.5) * cellSize,
                                                   (z + 0.5) * cellSize};
                                if (detail::triangleOverlapsCube(tri, centre, 0.5 * cellSize)) {
                                    out.push_back((std::uint64_t{mortonCell(x, y, z, k)} << 32) |
                                                  t);
                                    ++binned;
                                }
                            }
                    if (binned)
                        cellShare[t] =
                            static_cast<float>(0.5 * length(tri.normal) / double(binned));
                }
            });
        for (auto& part : local) pairs_.insert(pairs_.end(), part.begin(), part.end());
        tbb::parallel_sort(pairs_.begin(), pairs_.end());
    }
    for (std::size_t i = 0; i < pairs_.size();) {
        const auto code = static_cast<std::uint32_t>(pairs_[i] >> 32);
        std::size_t j = i;
        double area = 0;
        for (; j < pairs_.size() && static_cast<std::uint32_t>(pairs_[j] >> 32) == code; ++j)
            area += cellShare[static_cast<std::uint32_t>(pairs_[j])];
        cells_.push_back({code, i, j, area});
        i = j;
    }
}

std::vector<detail::CellSubtree> detail::SurfaceVoxelizer::buildCells(std::size_t first,
                                                                      std::size_t last,
                                                                      Progress* progress) const {
    const std::uint32_t k = cellLevel_;
    std::vector<CellSubtree> out(last - first);
    // One builder per thread, its buffers grown once instead of fresh memory for every cell, and
    // one storage for the outputs of the cells it builds (kept by those cells).
    struct Worker {
        SubtreeBuilder builder;
        std::shared_ptr<HugePageArena> storage;
    };
    tbb::enumerable_thread_specific<Worker> workers([&] {
        return Worker{
            SubtreeBuilder(triangles_,
                           {normalLengths_.data(), unitNormals_.data(), quantisedNormals_.data()},
                           depth_, k, options_, sampler_ ? &*sampler_ : nullptr),
            std::make_shared<HugePageArena>()};
    });
    tbb::parallel_for(tbb::blocked_range<std::size_t>(first, last, 1),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                          Worker& worker = workers.local();
                          std::vector<std::uint32_t> list;
                          for (std::size_t c = r.begin(); c != r.end(); ++c) {
                              const Cell& cell = cells_[c];
                              list.clear();
                              for (std::size_t i = cell.begin; i < cell.end; ++i)
                                  list.push_back(static_cast<std::uint32_t>(pairs_[i]));
                              std::uint32_t x = 0, y = 0, z = 0;
                              for (std::uint32_t bit = 0; bit < k; ++bit) {
                                  x |= ((cell.code >> (3 * bit)) & 1u) << bit;
                                  y |= ((cell.code >> (3 * bit + 1)) & 1u) << bit;
                                  z |= ((cell.code >> (3 * bit + 2)) & 1u) << bit;
                              }
                              CellSubtree& subtree = out[c - first];
                              subtree.code = cell.code;
                              subtree.occupied =
                                  worker.builder.build(k, x, y, z, list, 0, &subtree.sums) != 0;
                              worker.builder.copyOutputs(subtree, *worker.storage);
                              subtree.storage = worker.storage;
                              if (progress) progress->advance();
                          }
                      });
    return out;
}

SparseOctree detail::SurfaceVoxelizer::join(std::vector<CellSubtree>&& cells,
                                            std::uint32_t rootLevel,
                                            AttributeSums* rootSums) const {
    const std::uint32_t depth = depth_, k = cellLevel_;
    std::erase_if(cells, [](const CellSubtree& c) { return !c.occupied; });
    SparseOctree octree;
    if (cells.empty()) return octree;
    if (rootLevel == 0) octree.cube = cube_;
    const std::uint32_t levels = depth - rootLevel;  // the joined octree's leaf depth
    octree.leafDepth = levels;

    // Levels from the root level down to k from the occupied cells' codes.
    std::vector<std::uint32_t> codes;
    std::vector<AttributeSums> sums;  // with attributes: per entry of codes
    codes.reserve(cells.size());
    for (const CellSubtree& c : cells) {
        codes.push_back(c.code);
        if (options_.attributes) sums.push_back(c.sums);
    }
    UpperLevels upper = buildUpperLevels(std::move(codes), std::move(sums), k, rootLevel);
    if (upper.codes[0].size() != 1)
        throw std::logic_error("SurfaceVoxelizer::join: cells under more than one root");
    octree.masks.resize(levels);
    for (std::uint32_t level = rootLevel; level < k; ++level)
        octree.masks[level - rootLevel] = std::move(upper.masks[level - rootLevel]);
    if (options_.attributes) {
        octree.attributes.resize(levels + 1);
        for (std::uint32_t level = rootLevel; level <= k; ++level)
            for (const auto& s : upper.sums[level - rootLevel])
                octree.attributes[level - rootLevel].push_back(s.pack());
        if (rootSums) *rootSums = upper.sums[0].front();
    }
    for (std::uint32_t level = k; level < depth; ++level) {
        std::size_t total = 0;
        for (const auto& c : cells) total += c.masks[level - k].size();
        auto& masks = octree.masks[level - rootLevel];
        masks.reserve(total);
        adviseHugePages(masks);
        for (const auto& c : cells)
            masks.insert(masks.end(), c.masks[level - k].begin(), c.masks[level - k].end());
    }
    octree.voxelsPerLevel.assign(levels + 1, 0);
    octree.voxelsPerLevel[0] = 1;
    for (std::uint32_t level = 0; level < levels; ++level) {
        std::uint64_t children = 0;
        for (std::uint8_t m : octree.masks[level]) children += esvo::popc8(m);
        octree.voxelsPerLevel[level + 1] = children;
        if (level + 1 < levels && octree.masks[level + 1].size() != children)
            throw std::logic_error("voxelizeSurface: level sizes inconsistent");
    }
    if (options_.contours) {
        // Levels down to k come from the binning and carry no contours; below, the subtrees'.
        octree.contours.resize(levels + 1);
        for (std::uint32_t level = rootLevel; level <= k; ++level)
            octree.contours[level - rootLevel].assign(octree.voxelsPerLevel[level - rootLevel], 0u);
        for (std::uint32_t level = k + 1; level <= depth; ++level) {
            auto& out = octree.contours[level - rootLevel];
            out.reserve(octree.voxelsPerLevel[level - rootLevel]);
            adviseHugePages(out);
            for (const auto& c : cells)
                out.insert(out.end(), c.contours[level - k].begin(), c.contours[level - k].end());
            if (out.size() != octree.voxelsPerLevel[level - rootLevel])
                throw std::logic_error("voxelizeSurface: contour count inconsistent");
        }
    }
    if (options_.leafMaterials) {
        octree.leafMaterials.reserve(octree.voxelsPerLevel[levels]);
        adviseHugePages(octree.leafMaterials);
        for (auto& c : cells) {
            octree.leafMaterials.insert(octree.leafMaterials.end(), c.leafMaterials.begin(),
                                        c.leafMaterials.end());
            c.leafMaterials = {};
        }
        if (!options_.contours && octree.leafMaterials.size() != octree.voxelsPerLevel[levels])
            throw std::logic_error("voxelizeSurface: leaf material count inconsistent");
    }
    if (options_.attributes) {
        for (std::uint32_t level = k + 1; level <= depth; ++level) {
            auto& out = octree.attributes[level - rootLevel];
            out.reserve(octree.voxelsPerLevel[level - rootLevel]);
            adviseHugePages(out);
            for (const auto& c : cells)
                out.insert(out.end(), c.attributes[level - k].begin(),
                           c.attributes[level - k].end());
        }
        for (std::uint32_t level = 0; level <= levels; ++level)
            if (octree.attributes[level].size() != octree.voxelsPerLevel[level])
                throw std::logic_error("voxelizeSurface: attribute count inconsistent");
    }
    cells.clear();
    return octree;
}

SparseOctree voxelizeSurface(const Scene& scene, const SurfaceVoxelizeOptions& options) {
    const detail::SurfaceVoxelizer voxelizer(scene, options);
    std::vector<detail::CellSubtree> cells;
    {
        Timings::Scope timer(options.timings, "voxelize_subtrees");
        Progress progress("voxelizing", voxelizer.cellCount());
        cells = voxelizer.buildCells(0, voxelizer.cellCount(), &progress);
    }
    return voxelizer.join(std::move(cells), 0);
}

}  // namespace vox
