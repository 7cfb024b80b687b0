// Lays a SparseOctree out as ESVO blocks (child descriptors with near/far pointers, page headers,
// info sections) grouped into slices, and writes the .esvo file (docs/esvo-format.md).
#include <vox/formats/atomic_file.h>
#include <vox/formats/error.h>
#include <vox/formats/esvo.h>
#include <vox/octree.h>
#include <vox/util/log.h>
#include <vox/util/progress.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <deque>
#include <memory>
#include <optional>

namespace vox {
namespace {

constexpr std::uint64_t kPageUnits = esvo::kPageBytes / 8;  // 64-bit units per page

/// Child-index prefix sums over a SparseOctree, for navigating it by (level, index).
class OctreeIndex {
public:
    explicit OctreeIndex(const SparseOctree& octree) : octree_(octree), firstChild_(octree.leafDepth) {
        tbb::parallel_for(std::uint32_t{0}, octree.leafDepth, [&](std::uint32_t level) {
            const auto& masks = octree.masks[level];
            auto& prefix = firstChild_[level];
            prefix.resize(masks.size() + 1);
            std::uint64_t sum = 0;
            for (std::size_t i = 0; i < masks.size(); ++i) {
                prefix[i] = sum;
                sum += esvo::popc8(masks[i]);
            }
            prefix[masks.size()] = sum;
        });
    }

    [[nodiscard]] std::uint32_t depth() const { return octree_.leafDepth; }
    [[nodiscard]] std::uint64_t levelSize(std::uint32_t level) const { return octree_.masks[level].size(); }
    [[nodiscard]] std::uint32_t validMask(std::uint32_t level, std::uint64_t i) const {
        return level < depth() ? octree_.masks[level][i] : 0u;
    }
    [[nodiscard]] bool hasDescriptor(std::uint32_t level, std::uint64_t i) const { return validMask(level, i) != 0; }
    [[nodiscard]] std::uint64_t firstChild(std::uint32_t level, std::uint64_t i) const { return firstChild_[level][i]; }
    /// Slots whose children have descriptors of their own.
    [[nodiscard]] std::uint32_t nonLeafMask(std::uint32_t level, std::uint64_t i) const {
        const std::uint32_t valid = validMask(level, i);
        if (valid == 0 || level + 1 >= depth()) return 0;
        std::uint64_t child = firstChild(level, i);
        std::uint32_t mask = 0;
        for (std::uint32_t slot = 0; slot < 8; ++slot)
            if (valid & (1u << slot)) {
                if (octree_.masks[level + 1][child]) mask |= 1u << slot;
                ++child;
            }
        return mask;
    }
    /// The descendants at level+1 of the voxels [lo, hi) of level.
    [[nodiscard]] std::pair<std::uint64_t, std::uint64_t> childRange(std::uint32_t level, std::uint64_t lo, std::uint64_t hi) const {
        return {firstChild_[level][lo], firstChild_[level][hi]};
    }
    [[nodiscard]] std::uint64_t descriptorsIn(std::uint32_t level, std::uint64_t lo, std::uint64_t hi) const {
        if (level >= depth()) return 0;
        const auto& masks = octree_.masks[level];
        return static_cast<std::uint64_t>(std::count_if(masks.begin() + std::ptrdiff_t(lo), masks.begin() + std::ptrdiff_t(hi),
                                                        [](std::uint8_t m) { return m != 0; }));
    }

private:
    const SparseOctree& octree_;
    std::vector<std::vector<std::uint64_t>> firstChild_;
};

/// A region: the subtree of voxel `index` at `level`.
struct Region {
    std::uint32_t level = 0;
    std::uint64_t index = 0;
};

/// One slice's block, laid out.
struct SliceBlock {
    std::vector<std::uint64_t> units;     // the block, 64-bit units
    std::uint32_t descriptors = 0, farSlots = 0;
    std::uint64_t voxels = 0;
    std::uint32_t rootGroups = 0;
    std::vector<std::uint64_t> frontierVoxels;  // level endLevel−1 indices, in frontier-table order
    std::uint32_t infoWord = 0;
    [[nodiscard]] std::uint64_t byteSize() const { return 8 * units.size(); }
};

/// Depth-first layout of the descriptors of one region over levels [first, end).
class BlockLayout {
public:
    BlockLayout(const OctreeIndex& tree, Region region, std::uint32_t first, std::uint32_t end, std::uint32_t nearLimit)
        : tree_(tree), first_(first), end_(end), nearLimit_(nearLimit) {
        // Voxel ranges of the region per level, and descendant descriptor counts for the
        // conservative near/far decision.
        lo_.assign(end + 1, 0);
        hi_.assign(end + 1, 0);
        lo_[region.level] = region.index;
        hi_[region.level] = region.index + 1;
        for (std::uint32_t l = region.level; l < end; ++l) std::tie(lo_[l + 1], hi_[l + 1]) = tree.childRange(l, lo_[l], hi_[l]);
        below_.resize(end + 1);
        for (std::uint32_t l = end; l-- > first;) {
            // below_[l][i]: descriptors strictly below voxel (l, lo_[l]+i) inside this slice.
            auto& counts = below_[l];
            counts.assign(hi_[l] - lo_[l], 0);
            if (l + 1 >= end) continue;
            for (std::uint64_t i = lo_[l]; i < hi_[l]; ++i) {
                const std::uint32_t valid = tree.validMask(l, i);
                if (!valid) continue;
                std::uint64_t child = tree.firstChild(l, i), sum = 0;
                for (std::uint32_t slot = 0; slot < 8; ++slot)
                    if (valid & (1u << slot)) {
                        if (tree.hasDescriptor(l + 1, child)) sum += 1 + below_[l + 1][child - lo_[l + 1]];
                        ++child;
                    }
                counts[i - lo_[l]] = sum;
            }
        }
    }

    SliceBlock run() {
        block_.units.assign(1, 0);  // page header of page 0
        pageHeaders_.push_back(0);
        std::vector<std::uint64_t> rootGroupUnits;
        if (first_ == 0) {
            const std::uint64_t unit = placeGroup(1);
            rootGroupUnits.push_back(unit);
            ++block_.descriptors;
            block_.voxels += esvo::popc8(tree_.validMask(0, 0));
            layoutRoot(unit);
        } else {
            for (std::uint64_t p = lo_[first_ - 1]; p < hi_[first_ - 1]; ++p) {
                if (tree_.nonLeafMask(first_ - 1, p) == 0) continue;
                rootGroupUnits.push_back(layoutGroup(first_ - 1, p));
            }
        }
        // Info section and tables.
        const std::uint64_t infoUnit = block_.units.size();
        block_.infoWord = static_cast<std::uint32_t>(2 * infoUnit);
        std::vector<std::uint32_t> words;
        const auto rel = [&](std::uint64_t wordIndex) { return static_cast<std::uint32_t>(static_cast<std::int32_t>(wordIndex - 2 * infoUnit)); };
        const std::uint64_t tablesStart = 2 * infoUnit + esvo::info::kAttachments + esvo::info::kTablesWords;
        words.push_back(0);  // slice id, set when the slice's place in the directory is known
        words.push_back(0);  // block index in slice
        words.push_back(rel(2));
        words.push_back(0);  // attachment count
        words.push_back(static_cast<std::uint32_t>(rootGroupUnits.size()));
        words.push_back(rel(tablesStart));
        words.push_back(static_cast<std::uint32_t>(frontierUnits_.size()));
        words.push_back(rel(tablesStart + rootGroupUnits.size()));
        for (std::uint64_t u : rootGroupUnits) words.push_back(static_cast<std::uint32_t>(u));
        for (std::uint64_t u : frontierUnits_) words.push_back(static_cast<std::uint32_t>(u));
        if (words.size() % 2) words.push_back(0);
        for (std::size_t i = 0; i < words.size(); i += 2) block_.units.push_back(words[i] | (std::uint64_t{words[i + 1]} << 32));
        for (std::uint64_t header : pageHeaders_)
            block_.units[header] = static_cast<std::uint32_t>(static_cast<std::int32_t>(2 * infoUnit - 2 * header));
        block_.rootGroups = static_cast<std::uint32_t>(rootGroupUnits.size());
        return std::move(block_);
    }

private:
    /// Reserves @p count contiguous units inside one page, inserting padding and a page header
    /// where the page is full.
    std::uint64_t placeGroup(std::uint64_t count) {
        auto& u = block_.units;
        if (u.size() % kPageUnits + count > kPageUnits) u.resize((u.size() / kPageUnits + 1) * kPageUnits, 0);
        if (u.size() % kPageUnits == 0) {
            pageHeaders_.push_back(u.size());
            u.push_back(0);
        }
        const std::uint64_t start = u.size();
        u.resize(start + count, 0);
        return start;
    }

    /// Upper bound, in units, of what a descriptor with @p below descendants in the slice lays out.
    static std::uint64_t subtreeBound(std::uint64_t below) {
        if (below == 0) return 0;
        const std::uint64_t raw = 2 * below;  // each descriptor and at most one far slot each
        return raw + 17 * ((raw + kPageUnits - 18) / (kPageUnits - 17)) + 17;
    }

    /// Pointer kind for member j of a group of n whose earlier members need @p earlierBound units.
    bool decideFar(std::uint32_t level, std::uint64_t voxel, std::uint64_t n, std::uint64_t j, std::uint64_t earlierBound) const {
        if (tree_.nonLeafMask(level, voxel) == 0) return false;
        if (level + 1 >= end_) return true;  // children live in a child slice
        const std::uint64_t estimate = (2 * n - j) + earlierBound + 17;
        return estimate > nearLimit_;
    }

    /// Lays out the child group of voxel (level, voxel) — its children with descriptors — and
    /// everything below them; returns the group's first unit.
    std::uint64_t layoutGroup(std::uint32_t level, std::uint64_t voxel) {
        const std::uint32_t valid = tree_.validMask(level, voxel);
        std::uint64_t members[8];
        std::uint64_t n = 0;
        std::uint64_t child = tree_.firstChild(level, voxel);
        for (std::uint32_t slot = 0; slot < 8; ++slot)
            if (valid & (1u << slot)) {
                if (tree_.hasDescriptor(level + 1, child)) members[n++] = child;
                ++child;
            }
        bool far[8];
        std::uint64_t farCount = 0, earlier = 0;
        for (std::uint64_t j = 0; j < n; ++j) {
            far[j] = decideFar(level + 1, members[j], n, j, earlier);
            farCount += far[j];
            earlier += subtreeBound(below_[level + 1][members[j] - lo_[level + 1]]);
        }
        const std::uint64_t start = placeGroup(n + farCount);
        std::uint64_t slot = start + n;
        for (std::uint64_t j = 0; j < n; ++j) {
            const std::uint64_t unit = start + j;
            const std::uint32_t valid1 = tree_.validMask(level + 1, members[j]);
            const std::uint32_t nonLeaf = tree_.nonLeafMask(level + 1, members[j]);
            std::uint32_t pointer = 0;
            if (far[j]) {
                pointer = static_cast<std::uint32_t>(slot - unit);
                ++slot;
                ++block_.farSlots;
            }
            block_.units[unit] = esvo::ChildDescriptor::make(valid1, nonLeaf, pointer, far[j]).topology;
            ++block_.descriptors;
            block_.voxels += esvo::popc8(valid1);
        }
        for (std::uint64_t j = 0; j < n; ++j) {
            const std::uint64_t unit = start + j;
            if (tree_.nonLeafMask(level + 1, members[j]) == 0) continue;
            if (level + 2 >= end_) {
                frontierUnits_.push_back(unit);
                block_.frontierVoxels.push_back(members[j]);
                continue;
            }
            const std::uint64_t group = layoutGroup(level + 1, members[j]);
            link(unit, group);
        }
        return start;
    }

    /// Points the descriptor at @p unit to the group at @p group, through its far slot if it has one.
    void link(std::uint64_t unit, std::uint64_t group) {
        auto& word = block_.units[unit];
        esvo::ChildDescriptor d{static_cast<std::uint32_t>(word), 0};
        const std::uint64_t offset = group - unit;
        if (d.far()) {
            block_.units[unit + d.childPointer()] = static_cast<std::uint32_t>(static_cast<std::int32_t>(offset));
            return;
        }
        if (offset > nearLimit_)
            throw std::logic_error("esvo layout: near pointer estimate exceeded (" + std::to_string(offset) + " units)");
        word = esvo::ChildDescriptor::make(d.validMask(), d.nonLeafMask(), static_cast<std::uint32_t>(offset), false).topology;
    }

    /// The root descriptor (placed by run()) and everything below it.
    void layoutRoot(std::uint64_t unit) {
        const std::uint32_t level = 0;
        const std::uint64_t voxel = 0;
        block_.units[unit] = esvo::ChildDescriptor::make(tree_.validMask(0, 0), tree_.nonLeafMask(0, 0), 0, false).topology;
        if (tree_.nonLeafMask(level, voxel) == 0) return;
        auto& word = block_.units[unit];
        if (level + 1 >= end_) {
            // Root whose children are in child slices: a far slot right after it.
            const std::uint64_t slot = placeGroup(1);
            word = esvo::ChildDescriptor::make(tree_.validMask(level, voxel), tree_.nonLeafMask(level, voxel),
                                               static_cast<std::uint32_t>(slot - unit), true).topology;
            ++block_.farSlots;
            frontierUnits_.push_back(unit);
            block_.frontierVoxels.push_back(voxel);
            return;
        }
        word = esvo::ChildDescriptor::make(tree_.validMask(level, voxel), tree_.nonLeafMask(level, voxel), 0, false).topology;
        const std::uint64_t group = layoutGroup(level, voxel);
        link(unit, group);
    }

    const OctreeIndex& tree_;
    std::uint32_t first_, end_, nearLimit_;
    std::vector<std::uint64_t> lo_, hi_;
    std::vector<std::vector<std::uint64_t>> below_;
    SliceBlock block_;
    std::vector<std::uint64_t> pageHeaders_;
    std::vector<std::uint64_t> frontierUnits_;
};

struct PlannedSlice {
    Region region;
    std::uint32_t firstLevel = 0, endLevel = 0;
    std::uint32_t parent = esvo::kNoSlice;
    std::uint32_t pathLevels = 0;
    std::uint64_t path = 0;
    std::vector<std::uint32_t> children;
    SliceBlock block;
};

/// Splits the octree into slices of at most sliceBytes: each slice takes as many levels as fit;
/// the next levels go to child slices, split by region until each fits.
class SlicePlanner {
public:
    SlicePlanner(const OctreeIndex& tree, const EsvoWriteOptions& options) : tree_(tree), options_(options) {}

    std::vector<PlannedSlice> plan() {
        chooseBoundaries();
        makeSlice(Region{0, 0}, 0, esvo::kNoSlice, 0, 0);
        return std::move(slices_);
    }

private:
    SliceBlock layout(Region region, std::uint32_t first, std::uint32_t end) const {
        return BlockLayout(tree_, region, first, end, options_.nearPointerLimit).run();
    }

    std::pair<std::uint64_t, std::uint64_t> rangeAt(Region region, std::uint32_t level) const {
        std::uint64_t lo = region.index, hi = region.index + 1;
        for (std::uint32_t l = region.level; l < level; ++l) std::tie(lo, hi) = tree_.childRange(l, lo, hi);
        return {lo, hi};
    }

    void makeSlice(Region region, std::uint32_t first, std::uint32_t parent, std::uint32_t pathLevels, std::uint64_t path) {
        const std::uint32_t depth = tree_.depth();
        SliceBlock block = layout(region, first, first + 1);
        if (block.byteSize() > options_.sliceBytes) throw std::logic_error("esvo layout: a single level does not fit a slice");
        // Take as many levels as fit, but end on a boundary level where one fits: then the
        // frontier (one far slot per descriptor) falls on the sparse upper levels.
        std::uint32_t end = first + 1;
        std::optional<std::pair<std::uint32_t, SliceBlock>> aligned;
        if (isBoundary(end)) aligned.emplace(end, block);
        while (end < depth && !block.frontierVoxels.empty()) {
            const auto [lo, hi] = rangeAt(region, end);
            if (block.byteSize() + 8 * tree_.descriptorsIn(end, lo, hi) > options_.sliceBytes) break;
            SliceBlock trial = layout(region, first, end + 1);
            if (trial.byteSize() > options_.sliceBytes) break;
            block = std::move(trial);
            ++end;
            if (isBoundary(end) || block.frontierVoxels.empty()) aligned.emplace(end, block);
        }
        if (aligned) {
            end = aligned->first;
            block = std::move(aligned->second);
        }
        const auto index = static_cast<std::uint32_t>(slices_.size());
        PlannedSlice slice;
        slice.region = region;
        slice.firstLevel = first;
        slice.endLevel = end;
        slice.parent = parent;
        slice.pathLevels = pathLevels;
        slice.path = path;
        slice.block = std::move(block);
        const bool hasFrontier = !slice.block.frontierVoxels.empty();
        slices_.push_back(std::move(slice));
        if (parent != esvo::kNoSlice) slices_[parent].children.push_back(index);
        if (progress_) progress_->advance();
        if (hasFrontier) partition(region, end, index, 0, 0);
    }

    /// Covers the descriptors of levels ≥ level inside @p region with child slices of @p parent.
    void partition(Region region, std::uint32_t level, std::uint32_t parent, std::uint32_t pathLevels, std::uint64_t path) {
        const auto [lo, hi] = rangeAt(region, level - 1);
        bool any = false;
        for (std::uint64_t i = lo; i < hi && !any; ++i) any = tree_.nonLeafMask(level - 1, i) != 0;
        if (!any) return;
        bool fits = region.level + 1 == level;
        if (!fits) {
            const auto [clo, chi] = rangeAt(region, level);
            fits = 8 * tree_.descriptorsIn(level, clo, chi) < options_.sliceBytes &&
                   layout(region, level, level + 1).byteSize() <= options_.sliceBytes;
        }
        if (fits) {
            makeSlice(region, level, parent, pathLevels, path);
            return;
        }
        const std::uint32_t valid = tree_.validMask(region.level, region.index);
        std::uint64_t child = tree_.firstChild(region.level, region.index);
        for (std::uint32_t slot = 0; slot < 8; ++slot)
            if (valid & (1u << slot)) {
                partition(Region{region.level + 1, child}, level, parent, pathLevels + 1, (path << 3) | slot);
                ++child;
            }
    }

    /// Slices end on levels leafDepth − j·h: h is the tallest stack of bottom levels whose
    /// descriptors, per parent voxel above them, average a quarter slice or less.
    void chooseBoundaries() {
        const std::uint32_t depth = tree_.depth();
        std::vector<std::uint64_t> descriptors(depth + 1, 0);
        for (std::uint32_t l = 0; l < depth; ++l) descriptors[l] = tree_.descriptorsIn(l, 0, tree_.levelSize(l));
        std::uint32_t height = 1;
        std::uint64_t below = descriptors[depth - 1];
        for (std::uint32_t h = 2; h < depth; ++h) {
            below += descriptors[depth - h];
            const std::uint64_t parents = std::max<std::uint64_t>(1, descriptors[depth - h - 1]);
            if (8 * below / parents > options_.sliceBytes / 4) break;
            height = h;
        }
        boundaries_.assign(depth + 1, false);
        for (std::int64_t b = depth; b > 0; b -= height) boundaries_[static_cast<std::size_t>(b)] = true;
    }
    [[nodiscard]] bool isBoundary(std::uint32_t level) const { return boundaries_[level]; }

    const OctreeIndex& tree_;
    const EsvoWriteOptions& options_;
    std::vector<PlannedSlice> slices_;
    std::vector<bool> boundaries_;

public:
    Progress* progress_ = nullptr;
};

}  // namespace

EsvoWriteResult writeEsvo(const std::filesystem::path& file, const SparseOctree& octree, const EsvoWriteOptions& options) {
    if (options.sliceBytes < esvo::kMinSliceBytes)
        throw UsageError("--slice-bytes must be at least " + std::to_string(esvo::kMinSliceBytes));
    if (options.nearPointerLimit < 32 || options.nearPointerLimit > esvo::kNearPointerMax)
        throw UsageError("near pointer limit must be between 32 and 32767");
    if (octree.leafDepth < 1 || octree.leafDepth > esvo::kMaxLeafDepth) throw UsageError("leaf depth out of range");

    std::vector<PlannedSlice> planned;
    {
        Timings::Scope timer(options.timings, "esvo_layout");
        const OctreeIndex index(octree);
        Progress progress("laying out slices", 0);
        SlicePlanner planner(index, options);
        planner.progress_ = &progress;
        planned = planner.plan();
    }

    // Directory order: breadth-first, so every slice's children are contiguous.
    std::vector<std::uint32_t> order;  // directory position → planned index
    std::vector<std::uint32_t> position(planned.size());
    order.push_back(0);
    for (std::size_t i = 0; i < order.size(); ++i)
        for (std::uint32_t c : planned[order[i]].children) order.push_back(c);

    esvo::Directory directory;
    directory.voxelsPerLevel = octree.voxelsPerLevel;
    directory.slices.resize(planned.size());
    for (std::uint32_t i = 0; i < order.size(); ++i) position[order[i]] = i;

    EsvoWriteResult result;
    std::uint64_t offset = esvo::kHeaderBytes + esvo::directoryBytes(octree.leafDepth, static_cast<std::uint32_t>(planned.size()));
    const auto align = [](std::uint64_t v) { return (v + esvo::kSliceAlignment - 1) / esvo::kSliceAlignment * esvo::kSliceAlignment; };
    for (std::uint32_t i = 0; i < order.size(); ++i) {
        PlannedSlice& s = planned[order[i]];
        esvo::SliceEntry& e = directory.slices[i];
        // Slice id into the info section, then the checksum.
        auto& infoUnit = s.block.units[s.block.infoWord / 2];
        infoUnit = (infoUnit & 0xFFFFFFFF00000000ull) | i;
        offset = align(offset);
        e.fileOffset = offset;
        e.byteSize = static_cast<std::uint32_t>(s.block.byteSize());
        e.checksum = esvo::crc32c(s.block.units.data(), s.block.byteSize());
        offset += e.byteSize;
        e.parent = s.parent == esvo::kNoSlice ? esvo::kNoSlice : position[s.parent];
        e.childCount = static_cast<std::uint32_t>(s.children.size());
        e.firstChild = s.children.empty() ? 0 : position[s.children.front()];
        e.regionLevel = static_cast<std::uint8_t>(s.region.level);
        e.firstLevel = static_cast<std::uint8_t>(s.firstLevel);
        e.endLevel = static_cast<std::uint8_t>(s.endLevel);
        e.pathLevels = static_cast<std::uint8_t>(s.pathLevels);
        e.regionPath = s.path;
        e.rootGroupCount = s.block.rootGroups;
        e.descriptorCount = s.block.descriptors;
        e.farPointerCount = s.block.farSlots;
        e.voxelCount = s.block.voxels;
        result.descriptors += s.block.descriptors;
        result.farPointers += s.block.farSlots;
    }
    // Frontier ranges: a child's root groups are its parent's frontier descriptors, in order.
    for (const PlannedSlice& s : planned) {
        std::uint32_t next = 0;
        for (std::uint32_t c : s.children) {
            directory.slices[position[c]].firstFrontier = next;
            next += planned[c].block.rootGroups;
        }
        if (next != s.block.frontierVoxels.size()) throw std::logic_error("esvo layout: child slices do not cover the frontier");
    }

    esvo::Header header;
    header.worldToRoot = octree.cube.worldToUnit();
    header.sceneBoundsMin = {options.sceneBounds.min.x, options.sceneBounds.min.y, options.sceneBounds.min.z};
    header.sceneBoundsMax = {options.sceneBounds.max.x, options.sceneBounds.max.y, options.sceneBounds.max.z};
    header.leafDepth = octree.leafDepth;
    header.sliceBytesLimit = options.sliceBytes;
    header.nearPointerLimit = options.nearPointerLimit;
    header.sliceCount = static_cast<std::uint32_t>(planned.size());
    header.directoryOffset = esvo::kHeaderBytes;
    const std::vector<std::uint8_t> directoryBytes = esvo::encodeDirectory(directory);
    header.directoryBytes = directoryBytes.size();
    header.directoryChecksum = esvo::crc32c(directoryBytes.data(), directoryBytes.size());
    header.fileBytes = offset;

    {
        Timings::Scope timer(options.timings, "esvo_write");
        AtomicFile out(file);
        const auto headerBytes = esvo::encodeHeader(header);
        out.write(headerBytes.data(), headerBytes.size());
        out.write(directoryBytes.data(), directoryBytes.size());
        std::uint64_t written = esvo::kHeaderBytes + directoryBytes.size();
        static const std::array<std::uint8_t, esvo::kSliceAlignment> zeros{};
        for (std::uint32_t i = 0; i < order.size(); ++i) {
            const esvo::SliceEntry& e = directory.slices[i];
            out.write(zeros.data(), e.fileOffset - written);
            out.write(planned[order[i]].block.units.data(), e.byteSize);
            written = e.fileOffset + e.byteSize;
        }
        out.commit();
    }
    result.fileBytes = header.fileBytes;
    result.slices = header.sliceCount;
    return result;
}

}  // namespace vox
