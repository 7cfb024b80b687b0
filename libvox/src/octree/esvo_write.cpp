// Writes an in-memory SparseOctree as an .esvo file (docs/esvo-format.md): partition by
// partition as buildEsvo does, so that both give the same bytes; and the pieces both share (the
// header, the top above the partitions).
#include "esvo_assemble.h"
#include "surface_voxelizer.h"

#include <vox/base/error.h>
#include <vox/formats/esvo.h>

#include <tbb/parallel_for.h>

#include <algorithm>
#include <stdexcept>

namespace vox {
namespace detail {

std::uint32_t resolvePartitionLevel(std::int32_t requested, std::uint32_t leafDepth) {
    if (requested < 0) return defaultPartitionLevel(leafDepth);
    if (static_cast<std::uint32_t>(requested) >= leafDepth)
        throw ParameterError("partitionLevel",
                             "must be below the leaf depth (" + std::to_string(leafDepth) + ")");
    return static_cast<std::uint32_t>(requested);
}

esvo::Header esvoHeader(const RootCube& cube, std::uint32_t leafDepth, bool contours,
                        bool attributes, const EsvoWriteOptions& options) {
    if (options.sliceBytes < esvo::kMinSliceBytes)
        throw ParameterError("sliceBytes",
                             "must be at least " + std::to_string(esvo::kMinSliceBytes));
    if (options.nearPointerLimit < 32 || options.nearPointerLimit > esvo::kNearPointerMax)
        throw ParameterError("nearPointerLimit", "must be between 32 and 32767");
    if (leafDepth < 1 || leafDepth > esvo::kMaxLeafDepth)
        throw UsageError("leaf depth out of range");
    esvo::Header header;
    header.worldToRoot = cube.worldToUnit();
    header.sceneBoundsMin = {options.sceneBounds.min.x, options.sceneBounds.min.y,
                             options.sceneBounds.min.z};
    header.sceneBoundsMax = {options.sceneBounds.max.x, options.sceneBounds.max.y,
                             options.sceneBounds.max.z};
    header.leafDepth = leafDepth;
    if (contours)
        header.attachmentKinds |= 1u << static_cast<unsigned>(esvo::AttachmentKind::Contour);
    if (attributes && options.attributes != AttributeEncoding::None)
        header.attachmentKinds |= 1u << static_cast<unsigned>(attachmentKind(options.attributes));
    header.sliceBytesLimit = options.sliceBytes;
    header.nearPointerLimit = options.nearPointerLimit;
    return header;
}

SliceLayoutOptions sliceLayoutOptions(const EsvoWriteOptions& options, bool attributes,
                                      bool fileRoot) {
    SliceLayoutOptions layout;
    layout.attributes = attributes ? options.attributes : AttributeEncoding::None;
    layout.sliceBytes = options.sliceBytes;
    layout.nearPointerLimit = options.nearPointerLimit;
    layout.fileRoot = fileRoot;
    layout.attributeEffort = options.attributeEffort;
    layout.timings = options.timings;
    return layout;
}

OctreeView TopTree::view() const {
    OctreeView view;
    view.leafDepth = partitionLevel + 1;
    for (const auto& level : masks) view.masks.emplace_back(level);
    for (const auto& level : contours) view.contours.emplace_back(level);
    for (const auto& level : attributes) view.attributes.emplace_back(level);
    view.partitionNonLeaf = nonLeaf;
    return view;
}

TopTree buildTop(const std::vector<PartitionRoot>& roots, std::uint32_t partitionLevel,
                 bool contours, bool attributes) {
    const std::uint32_t p = partitionLevel;
    TopTree top;
    top.partitionLevel = p;
    std::vector<std::uint32_t> codes;
    std::vector<AttributeSums> sums;
    for (const PartitionRoot& r : roots) {
        codes.push_back(r.code);
        if (attributes) sums.push_back(r.sums);
    }
    UpperLevels upper = buildUpperLevels(std::move(codes), std::move(sums), p, 0);
    top.masks = std::move(upper.masks);
    top.masks.emplace_back();
    top.voxelsPerLevel.assign(p + 1, 0);
    for (std::uint32_t l = 0; l <= p; ++l) top.voxelsPerLevel[l] = upper.codes[l].size();
    if (contours) {
        top.contours.resize(p + 2);
        for (std::uint32_t l = 0; l <= p; ++l)
            top.contours[l].assign(top.voxelsPerLevel[l], 0u);  // levels of the binning: none
    }
    if (attributes) {
        top.attributes.resize(p + 2);
        for (std::uint32_t l = 0; l <= p; ++l)
            for (const AttributeSums& s : upper.sums[l]) top.attributes[l].push_back(s.pack());
    }
    for (const PartitionRoot& r : roots) {
        top.masks[p].push_back(r.mask);
        top.nonLeaf.push_back(r.nonLeaf);
        if (contours)
            top.contours[p + 1].insert(top.contours[p + 1].end(), r.childContours.begin(),
                                       r.childContours.end());
        if (attributes)
            top.attributes[p + 1].insert(top.attributes[p + 1].end(), r.childAttributes.begin(),
                                         r.childAttributes.end());
    }
    return top;
}

}  // namespace detail

EsvoWriteResult writeEsvo(const std::filesystem::path& file, const SparseOctree& octree,
                          const EsvoWriteOptions& options) {
    const bool contours = !octree.contours.empty(), attributes = !octree.attributes.empty();
    detail::EsvoFileInfo info;
    info.header = detail::esvoHeader(octree.cube, octree.leafDepth, contours, attributes, options);
    info.voxelsPerLevel = octree.voxelsPerLevel;
    const std::uint32_t p = detail::resolvePartitionLevel(options.partitionLevel, octree.leafDepth);
    detail::SliceStore store(~std::uint64_t{0}, file.parent_path());
    Progress progress("laying out slices", 0);
    if (p == 0) {
        std::vector<detail::PartitionSlices> whole;
        whole.push_back(detail::storeSlices(
            detail::layoutSlices(detail::viewOf(octree),
                                 detail::sliceLayoutOptions(options, attributes, true), &progress),
            0, 0, store));
        return detail::assembleEsvo(file, info, nullptr, std::move(whole), store, options.timings);
    }

    // The voxels of the partition level and their descendants' index ranges on every level below
    // (a voxel's descendants are contiguous on each level); Morton codes down to it.
    const std::uint32_t depth = octree.leafDepth;
    std::vector<std::uint32_t> codes{0};
    for (std::uint32_t l = 0; l < p; ++l) {
        std::vector<std::uint32_t> next;
        for (std::size_t i = 0; i < codes.size(); ++i)
            for (std::uint32_t slot = 0; slot < 8; ++slot)
                if (octree.masks[l][i] & (1u << slot)) next.push_back((codes[i] << 3) | slot);
        codes = std::move(next);
    }
    const std::size_t roots = codes.size();
    std::vector<std::vector<std::uint64_t>> begin(
        depth - p + 1, std::vector<std::uint64_t>(roots + 1));  // [l − p][root]
    for (std::size_t r = 0; r <= roots; ++r) begin[0][r] = r;
    for (std::uint32_t l = p; l < depth; ++l) {
        std::uint64_t child = 0;
        for (std::size_t r = 0; r < roots; ++r) {
            begin[l + 1 - p][r] = child;
            for (std::uint64_t i = begin[l - p][r]; i < begin[l - p][r + 1]; ++i)
                child += esvo::popc8(octree.masks[l][i]);
        }
        begin[l + 1 - p][roots] = child;
    }
    const auto range = [&](const auto& levelArray, std::uint32_t l, std::size_t r) {
        return std::span(levelArray.data() + begin[l - p][r],
                         begin[l - p][r + 1] - begin[l - p][r]);
    };

    // The top: the octree's own levels down to the partition level, and its roots' children's
    // contours and attributes below.
    detail::TopTree top;
    top.partitionLevel = p;
    top.nonLeaf.resize(roots);
    for (std::size_t r = 0; r < roots; ++r) {
        std::uint64_t child = begin[1][r];
        for (std::uint32_t slot = 0; slot < 8; ++slot)
            if (octree.masks[p][r] & (1u << slot)) {
                if (p + 1 < depth && octree.masks[p + 1][child])
                    top.nonLeaf[r] |= static_cast<std::uint8_t>(1u << slot);
                ++child;
            }
    }
    detail::OctreeView topView;
    topView.leafDepth = p + 1;
    for (std::uint32_t l = 0; l <= p; ++l) topView.masks.emplace_back(octree.masks[l]);
    if (contours)
        for (std::uint32_t l = 0; l <= p + 1; ++l)
            topView.contours.emplace_back(octree.contours[l]);
    if (attributes)
        for (std::uint32_t l = 0; l <= p + 1; ++l)
            topView.attributes.emplace_back(octree.attributes[l]);
    topView.partitionNonLeaf = top.nonLeaf;

    std::vector<detail::PartitionSlices> partitions(roots);
    tbb::parallel_for(std::size_t{0}, roots, [&](std::size_t r) {
        if (top.nonLeaf[r] == 0) return;
        detail::OctreeView view;
        view.leafDepth = depth - p;
        for (std::uint32_t l = p; l < depth; ++l)
            view.masks.push_back(range(octree.masks[l], l, r));
        if (contours)
            for (std::uint32_t l = p; l <= depth; ++l)
                view.contours.push_back(range(octree.contours[l], l, r));
        if (attributes)
            for (std::uint32_t l = p; l <= depth; ++l)
                view.attributes.push_back(range(octree.attributes[l], l, r));
        partitions[r] = detail::storeSlices(
            detail::layoutSlices(view, detail::sliceLayoutOptions(options, attributes, false),
                                 &progress),
            p, codes[r], store);
    });
    const detail::PartitionSlices topSlices = detail::storeSlices(
        detail::layoutSlices(topView, detail::sliceLayoutOptions(options, attributes, true),
                             &progress),
        0, 0, store);
    return detail::assembleEsvo(file, info, &topSlices, std::move(partitions), store,
                                options.timings);
}

}  // namespace vox
