/// @file octree.h
/// @brief Surface voxelization into a sparse octree, and writing it as an .esvo file
/// (docs/esvo-format.md).
#pragma once

#include <vox/lighting.h>
#include <vox/base/math.h>
#include <vox/scene.h>
#include <vox/util/timings.h>

#include <cstdint>
#include <filesystem>
#include <vector>

namespace vox {

/// The axis-aligned cube the octree covers, in world units.
struct RootCube {
    Vec3d origin{0, 0, 0};  ///< minimum corner
    double size = 1;        ///< edge length

    /// The cube for @p bounds: its minimum corner at the bounds' minimum, its edge the longest
    /// side (1 if the bounds are a point). Geometry on the far faces belongs to the last voxels.
    [[nodiscard]] static RootCube enclosing(const Bounds3f& bounds);
    /// Row-major affine matrix from world coordinates to the unit cube [0,1]³.
    [[nodiscard]] std::array<double, 16> worldToUnit() const;
};

/// A leaf voxel's material, area-weighted over the triangle fragments inside it, unquantised.
struct LeafMaterial {
    std::uint32_t x = 0, y = 0, z = 0;  ///< leaf cell
    Vec3f albedo{0, 0, 0};              ///< linear base colour (factor × texture × vertex colour)
    float coverage = 0;                 ///< mean base-colour alpha
    Vec3f emission{0, 0, 0};            ///< linear emitted radiance
    VoxelNormals normals;               ///< mean normal and per-axis moments (lighting.h)
};

/// A sparse octree as per-level child masks in Morton order: the structure every builder
/// produces and the .esvo writer lays out. Level 0 is the root cube; a voxel at level l has
/// mask bit s set when its child in slot s (bit 0: +x, bit 1: +y, bit 2: +z) exists; a mask of 0
/// is a leaf. The children of the voxels of level l are the voxels of level l+1, in order.
struct SparseOctree {
    RootCube cube;
    std::uint32_t leafDepth = 0;                   ///< finest level
    std::vector<std::vector<std::uint8_t>> masks;  ///< masks[l][i] for levels 0 … leafDepth−1
    std::vector<std::uint64_t> voxelsPerLevel;     ///< leafDepth + 1 entries
    /// contours[l][i]: the encoded esvo::Contour of voxel i of level l (0: none), for levels
    /// 0 … leafDepth (level 0's single entry is unused). Empty: the octree has no contours.
    std::vector<std::vector<std::uint32_t>> contours;
    /// attributes[l][i]: the shading attributes of voxel i of level l, for levels 0 … leafDepth,
    /// filtered from the triangle fragments inside the voxel: the colour word
    /// (esvo::packColor, sRGB-encoded RGB, linear coverage in alpha) in the low 32 bits and the
    /// cube-face normal (esvo::encodeNormal) in the high 32 bits. Empty: no attributes.
    std::vector<std::vector<std::uint64_t>> attributes;

    /// With SurfaceVoxelizeOptions::leafMaterials: the unquantised material of every voxel of the
    /// leaf level, in the order of that level (Morton order). What the radiance bake lights.
    std::vector<LeafMaterial> leafMaterials;

    [[nodiscard]] std::uint64_t voxelCount() const noexcept;
};

/// The error bounds voxelize refines to unless told otherwise (docs/cli.md): see
/// SurfaceVoxelizeOptions::contourError, colorError and normalErrorDegrees.
inline constexpr double kDefaultContourError = 0.25;
inline constexpr double kDefaultNormalErrorDegrees = 4;
inline constexpr double kDefaultColorError = 6;

/// Options for voxelizeSurface.
struct SurfaceVoxelizeOptions {
    std::uint32_t depth = 10;     ///< leaf level: 2^depth voxels along the cube's edge (1 … 20)
    bool includeDynamic = false;  ///< voxelize meshes flagged dynamic too
    bool onlyDynamic = false;     ///< voxelize only the meshes flagged dynamic
    /// The cube to voxelize in; null: RootCube::enclosing the selected meshes' bounds. Triangles
    /// outside it are clipped away.
    const RootCube* cube = nullptr;
    /// Keep SparseOctree::leafMaterials (implies attributes; without contours every leaf is at
    /// the leaf depth).
    bool leafMaterials = false;
    bool contours = false;  ///< fit a contour (slab) to every voxel where it helps
    /// With contours: a voxel stops refining where cube ∩ slab lies within this many leaf
    /// voxels of the surface; 0 refines everything to the leaf depth. With a bound, a voxel
    /// stores a contour of its own only where the slab its ancestors impose is not within it.
    double contourError = 0;
    /// Filter a colour and a normal for every voxel (SparseOctree::attributes).
    bool attributes = false;
    /// With attributes and a contour error: a voxel whose geometry is within the contour error
    /// still refines while the root-mean-square deviation over its surface from its colour
    /// (8-bit sRGB steps, linearised at the mean) or from its normal (degrees; the interpolated
    /// shading normal, without normal maps) exceeds these bounds. 0 disables that criterion.
    double colorError = 0;
    double normalErrorDegrees = 0;
    Timings* timings = nullptr;
};

/// Voxelizes the triangles of @p scene: a leaf voxel exists exactly where a triangle intersects
/// its closed cube (separating-axis test in double precision), and so does every ancestor.
/// Top-down and subtree by subtree in parallel; memory grows with the output, not with the
/// resolution. The result does not depend on the thread count.
/// @throws InvalidDataError if the scene has no (static) triangles; UsageError for a bad depth.
[[nodiscard]] SparseOctree voxelizeSurface(const Scene& scene,
                                           const SurfaceVoxelizeOptions& options);

/// How writeEsvo stores SparseOctree::attributes (docs/esvo-format.md, "Attributes").
enum class AttributeEncoding : std::uint8_t {
    None,  ///< no colour or normal
    Raw,   ///< uncompressed ("palette"): a lookup entry per descriptor, 64 bits per stored voxel
    Compressed,  ///< DXT-style: 6 words per pair of sibling descriptors (16 child slots)
    /// DXT-style behind a lookup entry per descriptor (Laine & Karras 5.7): 6 words per 16 stored
    /// values; a child equal to its parent is not stored (it inherits), and no pairing padding.
    CompressedLookup,
};

/// The default partition level for leaf depth @p leafDepth: leafDepth − 9 (at most 10), or 0
/// (no partitions) up to depth 9. See EsvoWriteOptions::partitionLevel.
[[nodiscard]] std::uint32_t defaultPartitionLevel(std::uint32_t leafDepth);

/// How hard the compressed (Dxt, DxtLookup) attribute encoders search for each block: Fast,
/// Default and Best take increasingly long for an increasingly small error. Every effort is
/// deterministic, and the effort is part of the output: files written with different efforts
/// may differ. Measurements: docs/internals/esvo-writer.md.
enum class AttributeEffort : std::uint8_t { Fast, Default, Best };

/// Options for writeEsvo.
struct EsvoWriteOptions {
    /// Ignored (None) when the octree has no attributes.
    AttributeEncoding attributes = AttributeEncoding::Compressed;
    AttributeEffort attributeEffort = AttributeEffort::Default;
    std::uint32_t sliceBytes = 1u << 20;  ///< largest slice, ≥ 16384
    /// Largest near child pointer (64-bit units). 32767 is the format's; tests lower it to force
    /// far pointers.
    std::uint32_t nearPointerLimit = 0x7FFF;
    /// Slices never span two voxels of this level (the partitions): the slices below each of
    /// them are laid out from its subtree alone, those above from the levels down to it (the
    /// top). That is what lets buildEsvo lay a file out one partition at a time, and in
    /// separate processes, with the same bytes. 0: no partitions; −1: defaultPartitionLevel.
    /// For buildEsvo at most the voxelizer's cell level (4, or deeper from depth 14).
    std::int32_t partitionLevel = -1;
    Bounds3f sceneBounds;
    Timings* timings = nullptr;
};

/// What writeEsvo produced.
struct EsvoWriteResult {
    std::uint64_t fileBytes = 0;
    std::uint32_t slices = 0;
    std::uint64_t descriptors = 0;
    std::uint64_t farPointers = 0;
};

/// Lays @p octree out as ESVO blocks in slices and writes the .esvo file atomically. The same
/// octree and options always give the same bytes, and the same as buildEsvo from the scene the
/// octree was voxelized from.
EsvoWriteResult writeEsvo(const std::filesystem::path& file, const SparseOctree& octree,
                          const EsvoWriteOptions& options);

/// Which partitions a build makes: the partitions (voxels of the partition level holding
/// triangles, in Morton order) are split into `count` runs of about equal work, and a build
/// makes run `index` (0-based) only.
struct PartitionSelection {
    std::uint32_t index = 0;
    std::uint32_t count = 1;  ///< 1: the whole octree, written as an .esvo file
};

/// Options for buildEsvo.
struct EsvoBuildOptions {
    SurfaceVoxelizeOptions voxelize;  ///< `cube` and `leafMaterials` are not used
    EsvoWriteOptions write;
    /// Bytes the build may use: it builds as many partitions at a time as fit, and keeps at
    /// most a quarter of it of finished slices in memory (the rest waits in a scratch file
    /// beside the output). 0: defaultMemoryLimit().
    std::uint64_t memoryLimit = 0;
    PartitionSelection partitions;
    /// For tests: bytes of partitions to build at a time, and of finished slices to keep in
    /// memory, instead of the shares of the memory limit (0: those shares).
    std::uint64_t roundBytes = 0, memorySliceBytes = 0;
};

/// What buildEsvo did.
struct EsvoBuildResult {
    std::uint32_t leafDepth = 0;
    std::uint32_t partitionLevel = 0;
    std::vector<std::uint64_t> voxelsPerLevel;  ///< of the whole octree (a part file: of its
                                                ///< partitions and the levels above)
    std::uint64_t partitionsBuilt = 0;  ///< partitions of this build (all of them unless selected)
    std::uint64_t partitionsTotal = 0;  ///< partitions of the octree
    std::uint32_t batches = 0;          ///< rounds of partitions built together
    std::uint64_t scratchBytes = 0;     ///< finished slices that waited on disk
    std::uint64_t memoryLimit = 0;
    EsvoWriteResult written;     ///< the .esvo or the part file
    double voxelizeSeconds = 0;  ///< wall time of binning and building the cells
    [[nodiscard]] std::uint64_t voxelCount() const noexcept;
};

/// The kernels the compressed attribute encoders run on this machine: "avx512" (AVX-512F),
/// "sse2", or "scalar" (a build without SSE2). They give the same bytes; only the time differs
/// (docs/internals/esvo-writer.md), which is why reports name them.
[[nodiscard]] const char* attributeEncoderKernels() noexcept;

/// Half the physical memory (capped by the cgroup's limit where there is one).
[[nodiscard]] std::uint64_t defaultMemoryLimit();

/// Voxelizes @p scene and writes its octree as an .esvo file, partition by partition within the
/// memory limit: the same bytes as voxelizeSurface then writeEsvo with the same options, for any
/// memory limit and thread count. With a partition selection of more than one run, writes a
/// part file of the selected partitions instead (docs/esvo-part-format.md), for mergeEsvoParts.
/// @throws InvalidDataError (no triangles), UsageError (bad options, memory limit below what
/// the scene itself takes), IoError.
EsvoBuildResult buildEsvo(const std::filesystem::path& file, const Scene& scene,
                          const EsvoBuildOptions& options);

/// Joins the part files of every run of one partitioned build into the .esvo file the
/// unpartitioned build writes, byte for byte.
/// @throws InvalidDataError if a part is corrupt, from another build, or runs are missing or
/// repeated; IoError.
EsvoBuildResult mergeEsvoParts(const std::filesystem::path& file,
                               const std::vector<std::filesystem::path>& parts,
                               std::uint64_t memoryLimit = 0, Timings* timings = nullptr);

}  // namespace vox
