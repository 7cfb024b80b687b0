// Laying an octree out as .esvo slices: child descriptors with near/far pointers, page headers,
// info sections, contour and attribute attachments, grouped into slices (docs/esvo-format.md §8;
// libvox's layout in docs/internals/esvo-writer.md). Works on a view of a subtree, so that a file
// can be laid out one partition at a time: the slices below each voxel of the partition level are
// laid out from that voxel's subtree alone, and the slices above it (the top) from the levels down
// to it.
#pragma once

#include <vox/formats/esvo.h>
#include <vox/octree.h>
#include <vox/util/progress.h>

#include <cstdint>
#include <span>
#include <vector>

namespace vox::detail {

/// A subtree of a SparseOctree as per-level spans; level 0 is the subtree's root voxel, and the
/// arrays are indexed as SparseOctree's (by voxel, in Morton order, per level).
struct OctreeView {
    std::uint32_t leafDepth = 0;                           ///< levels below the root
    std::vector<std::span<const std::uint8_t>> masks;      ///< levels 0 … leafDepth − 1
    std::vector<std::span<const std::uint32_t>> contours;  ///< levels 0 … leafDepth; empty: none
    std::vector<std::span<const std::uint64_t>> attributes;  ///< levels 0 … leafDepth; empty: none
    /// The top of a partitioned file: the octree stops at the partition level (leafDepth − 1 is
    /// the partition level, leafDepth the partition roots' children, known only by their
    /// contours and attributes), and these are the non-leaf masks of the partition roots. Empty
    /// for an octree that goes down to its leaves.
    std::span<const std::uint8_t> partitionNonLeaf;

    [[nodiscard]] std::uint64_t levelSize(std::uint32_t level) const { return masks[level].size(); }
};

/// The attachment kind that stores @p encoding (not None). @throws std::logic_error for None.
[[nodiscard]] esvo::AttachmentKind attachmentKind(AttributeEncoding encoding);
/// The encoding whose attachment kind bit is set in header @p attachmentKinds (None: none).
[[nodiscard]] AttributeEncoding attributeEncoding(std::uint32_t attachmentKinds);

/// The whole of @p octree.
[[nodiscard]] OctreeView viewOf(const SparseOctree& octree);

/// A voxel of a view: its level and index there, and its Morton path from the view's root
/// (3 bits per level, slot bit 0 = +x).
struct LayoutNode {
    std::uint32_t level = 0;
    std::uint64_t index = 0;
    std::uint64_t path = 0;
};

/// One laid-out slice, as the planner leaves it: in the view's levels and paths.
struct LaidOutSlice {
    LayoutNode region;                    ///< the slice's region cube
    std::uint32_t parent = 0xFFFFFFFFu;   ///< index in the list; none for the first
    std::vector<std::uint32_t> children;  ///< indices in the list, in frontier order
    std::vector<std::uint64_t> units;  ///< the block (64-bit units); slice id 0 in its info section
    std::uint32_t infoWord =
        0;  ///< word index of the info section (its first word is the slice id)
    std::uint32_t firstLevel = 0, endLevel = 0;
    std::uint32_t rootGroups = 0;
    std::uint32_t descriptors = 0, farSlots = 0;
    std::uint64_t voxels = 0;
    std::uint32_t frontier = 0;  ///< frontier descriptors (= the children's root groups)
    /// The top of a partitioned file: this is no slice of the top but the place of the slices of
    /// the partition below the partition-level voxel `region` (it has no block).
    bool partition = false;
};

/// How a view is laid out.
struct SliceLayoutOptions {
    AttributeEncoding attributes = AttributeEncoding::None;  ///< None if the view has no attributes
    std::uint32_t sliceBytes = 1u << 20;
    std::uint32_t nearPointerLimit = 0x7FFF;
    /// True: the view's root is the file's root and the first slice holds the root descriptor
    /// (the root slice). False: the view is a partition, and its first slice holds the root
    /// voxel's child group (its root descriptor is in a slice of the top).
    bool fileRoot = true;
    AttributeEffort attributeEffort = AttributeEffort::Default;
    Timings* timings = nullptr;  ///< esvo_layout, esvo_compress_attributes (summed over partitions)
};

/// Plans the slices of @p view, lays them out and encodes their compressed attributes. Slices
/// come in the planner's depth-first order (each slice, then its children's subtrees in order).
/// With OctreeView::partitionNonLeaf, every partition root with a non-leaf child is a frontier
/// descriptor whose child slice is the partition's (a LaidOutSlice with `partition` set), and no
/// slice of the top spans two partitions. The result does not depend on the thread count.
[[nodiscard]] std::vector<LaidOutSlice> layoutSlices(const OctreeView& view,
                                                     const SliceLayoutOptions& options,
                                                     Progress* progress = nullptr);

}  // namespace vox::detail
