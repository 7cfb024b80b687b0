// Lays an octree view out as ESVO blocks (child descriptors with near/far pointers, page headers,
// info sections, contour and attribute attachments) grouped into slices (docs/esvo-format.md).
#include "esvo_layout.h"

#include "attribute_encode.h"

#include <vox/formats/esvo.h>
#include <vox/formats/esvo_attributes.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <memory>
#include <optional>
#include <span>
#include <stdexcept>

namespace vox::detail {
namespace {

constexpr std::uint64_t kPageUnits = esvo::kPageBytes / 8;  // 64-bit units per page

/// Child-index prefix sums over an OctreeView, for navigating it by (level, index).
class OctreeIndex {
public:
    explicit OctreeIndex(const OctreeView& view) : view_(view), firstChild_(view.leafDepth) {
        tbb::parallel_for(std::uint32_t{0}, view.leafDepth, [&](std::uint32_t level) {
            const auto& masks = view.masks[level];
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

    [[nodiscard]] std::uint32_t depth() const { return view_.leafDepth; }
    [[nodiscard]] std::uint64_t levelSize(std::uint32_t level) const {
        return view_.levelSize(level);
    }
    [[nodiscard]] std::uint32_t validMask(std::uint32_t level, std::uint64_t i) const {
        return level < depth() ? view_.masks[level][i] : 0u;
    }
    [[nodiscard]] bool hasDescriptor(std::uint32_t level, std::uint64_t i) const {
        return validMask(level, i) != 0;
    }
    [[nodiscard]] bool hasContours() const { return !view_.contours.empty(); }
    /// Encoded contour of voxel i of level (0: none).
    [[nodiscard]] std::uint32_t contour(std::uint32_t level, std::uint64_t i) const {
        return view_.contours.empty() ? 0u : view_.contours[level][i];
    }
    [[nodiscard]] bool hasAttributes() const { return !view_.attributes.empty(); }
    /// Attribute word pair of voxel i of level (SparseOctree::attributes).
    [[nodiscard]] std::uint64_t attribute(std::uint32_t level, std::uint64_t i) const {
        return view_.attributes[level][i];
    }
    /// The level whose non-leaf descriptors are all frontier (the partition level of a top
    /// view), or none.
    [[nodiscard]] std::uint32_t partitionLevel() const {
        return view_.partitionNonLeaf.empty() ? 0xFFFFFFFFu : depth() - 1;
    }
    [[nodiscard]] std::uint64_t firstChild(std::uint32_t level, std::uint64_t i) const {
        return firstChild_[level][i];
    }
    /// Slots whose children have descriptors of their own.
    [[nodiscard]] std::uint32_t nonLeafMask(std::uint32_t level, std::uint64_t i) const {
        const std::uint32_t valid = validMask(level, i);
        if (valid == 0) return 0;
        if (level == partitionLevel()) return view_.partitionNonLeaf[i];
        if (level + 1 >= depth()) return 0;
        std::uint64_t child = firstChild(level, i);
        std::uint32_t mask = 0;
        for (std::uint32_t slot = 0; slot < 8; ++slot)
            if (valid & (1u << slot)) {
                if (view_.masks[level + 1][child]) mask |= 1u << slot;
                ++child;
            }
        return mask;
    }

private:
    const OctreeView& view_;
    std::vector<std::vector<std::uint64_t>> firstChild_;
};

/// A DxtLookup slot no lookup entry references (never a value: its normal's axis field is 3).
constexpr std::uint64_t kPaddingValue = ~std::uint64_t{0};

using Node = LayoutNode;

/// One slice's block, laid out.
struct SliceBlock {
    std::vector<std::uint64_t> units;  // the block, 64-bit units
    std::uint32_t descriptors = 0, farSlots = 0;
    std::uint64_t voxels = 0;
    std::uint32_t rootGroups = 0;
    std::uint32_t firstLevel = 0, endLevel = 0;
    std::vector<Node> frontier;  // in frontier-table order
    std::uint32_t infoWord = 0;
    std::uint64_t contourWords = 0;
    /// Compressed attributes are encoded once the plan is final: the descriptors by unit, and
    /// where their blocks go.
    struct DescriptorRef {
        std::uint64_t unit;
        std::uint32_t level;
        std::uint64_t index;
    };
    std::vector<DescriptorRef> pendingCompressed;  // Compressed: by unit
    std::vector<std::uint64_t> pendingValues;      // CompressedLookup: the stored values in order
    std::uint64_t compressedUnit = 0;
    bool overflow = false;  // a near pointer estimate failed: the block is over a slice anyway
    /// A 24-bit contour or colour/normal pointer cannot reach: the block must not be used even
    /// if it fits the slice (a dxt-lookup slice past about 48 MiB); the planner cuts deeper.
    bool pointerOutOfReach = false;
    [[nodiscard]] std::uint64_t byteSize() const {
        return overflow || pointerOutOfReach ? ~std::uint64_t{0} : 8 * units.size();
    }
};

/// Bytes of the descriptors strictly below each voxel (saturating), bottom-up: what a child
/// slice holding that voxel's child group and everything under it needs, before overheads.
class SubtreeSizes {
public:
    /// Attribute bytes are estimated per descriptor: raw, a lookup word and 8 bytes per child;
    /// compressed, half a 24-byte block plus a padding unit and its half block per group; behind
    /// a lookup, a lookup word and 2 bytes (1.5 of block, and padding) per child.
    SubtreeSizes(const OctreeIndex& tree, AttributeEncoding attributes) : bytes_(tree.depth()) {
        const std::uint32_t depth = tree.depth();
        const auto descriptorBytes = [&](std::uint32_t valid) -> std::uint64_t {
            switch (attributes) {
                case AttributeEncoding::Raw:
                    return 8 + 4 + 8 * esvo::popc8(valid);
                case AttributeEncoding::Compressed:
                    return 8 + 12;
                case AttributeEncoding::CompressedLookup:
                    return 8 + 4 + 2 * esvo::popc8(valid);
                case AttributeEncoding::None:
                    break;
            }
            return 8;
        };
        const std::uint64_t groupBytes = attributes == AttributeEncoding::Compressed ? 20 : 0;
        for (std::uint32_t l = depth; l-- > 0;) {
            auto& out = bytes_[l];
            out.assign(tree.levelSize(l), 0);
            if (l + 1 >= depth) {
                // Children are leaves: only their contours. (In a top view these are partition
                // roots, whose children are the partitions': what stays is the contours and,
                // where it has non-leaf children, the frontier descriptor's far slot.)
                const bool top = l == tree.partitionLevel();
                for (std::uint64_t i = 0; i < out.size(); ++i) {
                    const std::uint32_t valid = tree.validMask(l, i);
                    std::uint64_t child = tree.firstChild(l, i),
                                  sum = top && tree.nonLeafMask(l, i) ? 8 : 0;
                    for (std::uint32_t slot = 0; slot < 8; ++slot)
                        if (valid & (1u << slot)) sum += tree.contour(l + 1, child++) ? 4 : 0;
                    out[i] = static_cast<std::uint32_t>(sum);
                }
                continue;
            }
            const auto& next = bytes_[l + 1];
            tbb::parallel_for(
                tbb::blocked_range<std::uint64_t>(0, out.size(), 1 << 14),
                [&](const tbb::blocked_range<std::uint64_t>& r) {
                    for (std::uint64_t i = r.begin(); i != r.end(); ++i) {
                        const std::uint32_t valid = tree.validMask(l, i);
                        std::uint64_t child = tree.firstChild(l, i), sum = 0;
                        bool group = false;
                        for (std::uint32_t slot = 0; slot < 8; ++slot)
                            if (valid & (1u << slot)) {
                                if (tree.hasDescriptor(l + 1, child)) {
                                    sum +=
                                        descriptorBytes(tree.validMask(l + 1, child)) + next[child];
                                    group = true;
                                }
                                if (tree.contour(l + 1, child)) sum += 4;
                                ++child;
                            }
                        if (group) sum += groupBytes;
                        out[i] =
                            static_cast<std::uint32_t>(std::min<std::uint64_t>(sum, 0xFFFFFFFFu));
                    }
                });
        }
    }
    [[nodiscard]] std::uint64_t operator()(std::uint32_t level, std::uint64_t index) const {
        return bytes_[level][index];
    }

private:
    std::vector<std::vector<std::uint32_t>> bytes_;
};

/// Which descriptors of a slice hand their children to child slices (become frontier).
struct CutRule {
    bool whole = true;            // nothing is cut: the slice holds complete subtrees
    std::uint64_t leafBytes = 0;  // cut a voxel whose subtree (SubtreeSizes) is at most this
    std::uint32_t endLevel = 0xFFFFFFFFu;  // cut every voxel at level endLevel − 1 or deeper
};

/// Depth-first layout of one slice: the child groups of its root parents (or the root
/// descriptor), and everything below them that the cut rule keeps.
class BlockLayout {
public:
    /// Blocks larger than @p sliceBytes are only measured, never written: their near/far
    /// estimates may assume every subtree fits the slice.
    BlockLayout(const OctreeIndex& tree, const SubtreeSizes& sizes, std::uint32_t nearLimit,
                CutRule cut, std::uint64_t sliceBytes, AttributeEncoding attributes)
        : tree_(tree),
          sizes_(sizes),
          nearLimit_(nearLimit),
          cut_(cut),
          maxUnits_(sliceBytes / 8),
          attributes_(tree.hasAttributes() ? attributes : AttributeEncoding::None) {}

    /// @p parents empty: the root slice.
    SliceBlock run(const std::vector<Node>& parents) {
        block_.units.assign(1, 0);  // page header of page 0
        pageHeaders_.push_back(0);
        block_.firstLevel = parents.empty() ? 0 : 0xFFFFFFFFu;
        std::vector<std::uint64_t> rootGroupUnits;
        if (parents.empty()) {
            const Node root{0, 0, 0};
            const bool far = isFrontier(root);
            const std::uint64_t unit = placeGroup(far ? 2 : 1);
            rootGroupUnits.push_back(unit);
            writeMembers(&root, 1, unit, &far);  // also queues the root's children's contours
            descend(&root, 1, unit);
        } else {
            for (const Node& p : parents) {
                block_.firstLevel = std::min(block_.firstLevel, p.level + 1);
                rootGroupUnits.push_back(layoutGroup(p));
            }
        }
        // Contour array: each descriptor's children's contours, in descriptor order.
        const std::uint64_t contourWord = 2 * block_.units.size();
        std::uint64_t nextWord = contourWord;
        std::vector<std::uint32_t> contourWords;
        for (const PendingContours& p : contours_) {
            block_.units[p.unit] |= std::uint64_t{((nextWord - 2 * p.unit) << 8) | p.mask} << 32;
            contourWords.insert(contourWords.end(), p.values.begin(),
                                p.values.begin() + esvo::popc8(p.mask));
            nextWord += esvo::popc8(p.mask);
        }
        if (contourWords.size() % 2) contourWords.push_back(0);
        for (std::size_t i = 0; i < contourWords.size(); i += 2)
            block_.units.push_back(contourWords[i] | (std::uint64_t{contourWords[i + 1]} << 32));
        block_.contourWords = nextWord - contourWord;
        if (contourWord >= (std::uint64_t{1} << 24) && !contours_.empty())
            block_.pointerOutOfReach = true;  // 24-bit contour pointers
        const std::uint64_t attributeWord = 2 * block_.units.size();
        if (attributes_ == AttributeEncoding::Raw) appendPalette(contourWord / 2);
        if (attributes_ == AttributeEncoding::Compressed) reserveCompressed(contourWord / 2);
        if (attributes_ == AttributeEncoding::CompressedLookup)
            appendLookupAndReserveBlocks(contourWord / 2);
        const std::uint32_t attachments =
            (contours_.empty() ? 0 : 1) + (attributes_ == AttributeEncoding::None ? 0 : 1);

        // Info section and tables.
        const std::uint64_t infoUnit = block_.units.size();
        block_.infoWord = static_cast<std::uint32_t>(2 * infoUnit);
        std::vector<std::uint32_t> words;
        const auto rel = [&](std::uint64_t wordIndex) {
            return static_cast<std::uint32_t>(static_cast<std::int32_t>(wordIndex - 2 * infoUnit));
        };
        const std::uint64_t tablesStart =
            2 * infoUnit + esvo::info::tablesWord(attachments) + esvo::info::kTablesWords;
        words.push_back(0);  // slice id, set when the slice's place in the directory is known
        words.push_back(0);  // block index in slice
        words.push_back(rel(2));
        words.push_back(attachments);
        if (!contours_.empty()) {
            words.push_back(static_cast<std::uint32_t>(esvo::AttachmentKind::Contour));
            words.push_back(rel(contourWord));
        }
        if (attributes_ != AttributeEncoding::None) {
            words.push_back(static_cast<std::uint32_t>(attachmentKind(attributes_)));
            words.push_back(rel(attributeWord));
        }
        words.push_back(static_cast<std::uint32_t>(rootGroupUnits.size()));
        words.push_back(rel(tablesStart));
        words.push_back(static_cast<std::uint32_t>(frontierUnits_.size()));
        words.push_back(rel(tablesStart + rootGroupUnits.size()));
        for (std::uint64_t u : rootGroupUnits) words.push_back(static_cast<std::uint32_t>(u));
        for (std::uint64_t u : frontierUnits_) words.push_back(static_cast<std::uint32_t>(u));
        if (words.size() % 2) words.push_back(0);
        for (std::size_t i = 0; i < words.size(); i += 2)
            block_.units.push_back(words[i] | (std::uint64_t{words[i + 1]} << 32));
        for (std::uint64_t header : pageHeaders_)
            block_.units[header] =
                static_cast<std::uint32_t>(static_cast<std::int32_t>(2 * infoUnit - 2 * header));
        block_.rootGroups = static_cast<std::uint32_t>(rootGroupUnits.size());
        if (block_.overflow && block_.units.size() <= maxUnits_)
            throw std::logic_error("esvo layout: near pointer estimate exceeded");
        return std::move(block_);
    }

private:
    [[nodiscard]] bool isFrontier(const Node& n) const {
        if (tree_.nonLeafMask(n.level, n.index) == 0) return false;
        if (n.level == tree_.partitionLevel()) return true;  // its children are the partition's
        if (cut_.whole) return false;
        return n.level + 1 >= cut_.endLevel || sizes_(n.level, n.index) <= cut_.leafBytes;
    }

    /// Reserves @p count contiguous units inside one page, inserting padding and a page header
    /// where the page is full. With compressed attributes groups start on even units, so that
    /// the descriptors sharing a compressed block are siblings.
    std::uint64_t placeGroup(std::uint64_t count) {
        auto& u = block_.units;
        const auto alignForPairs = [&] {
            if (attributes_ == AttributeEncoding::Compressed && u.size() % 2) u.push_back(0);
        };
        alignForPairs();
        if (u.size() % kPageUnits + count > kPageUnits)
            u.resize((u.size() / kPageUnits + 1) * kPageUnits, 0);
        if (u.size() % kPageUnits == 0) {
            pageHeaders_.push_back(u.size());
            u.push_back(0);
            alignForPairs();
        }
        const std::uint64_t start = u.size();
        u.resize(start + count, 0);
        return start;
    }

    /// Upper bound, in units, of what a voxel's subtree lays out in this slice: its descriptors,
    /// at most one far slot each, page headers and padding.
    [[nodiscard]] std::uint64_t subtreeBound(const Node& n) const {
        if (isFrontier(n) || tree_.nonLeafMask(n.level, n.index) == 0) return 0;
        // What stays in this slice is at most the slice, whatever the whole subtree holds.
        const std::uint64_t raw = std::min(2 * (sizes_(n.level, n.index) / 8), maxUnits_);
        return raw + 17 * ((raw + kPageUnits - 18) / (kPageUnits - 17)) + 17;
    }

    /// Writes the descriptors of a group placed at @p start (far slots follow the members).
    void writeMembers(const Node* members, std::uint64_t n, std::uint64_t start, const bool* far) {
        std::uint64_t slot = start + n;
        for (std::uint64_t j = 0; j < n; ++j) {
            const std::uint64_t unit = start + j;
            const std::uint32_t valid = tree_.validMask(members[j].level, members[j].index);
            const std::uint32_t nonLeaf = tree_.nonLeafMask(members[j].level, members[j].index);
            std::uint32_t pointer = 0;
            if (far[j]) {
                pointer = static_cast<std::uint32_t>(slot - unit);
                ++slot;
                ++block_.farSlots;
            }
            block_.units[unit] =
                esvo::ChildDescriptor::make(valid, nonLeaf, pointer, far[j]).topology;
            collectContours(members[j], unit);
            if (attributes_ != AttributeEncoding::None)
                descriptors_.push_back({unit, members[j].level, members[j].index});
            ++block_.descriptors;
            block_.voxels += esvo::popc8(valid);
            block_.endLevel = std::max(block_.endLevel, members[j].level + 1);
        }
    }

    /// Queues the contours of @p n's children for the block's contour array.
    void collectContours(const Node& n, std::uint64_t unit) {
        if (!tree_.hasContours()) return;
        const std::uint32_t valid = tree_.validMask(n.level, n.index);
        PendingContours p{unit, 0, {}};
        std::uint64_t child = tree_.firstChild(n.level, n.index);
        std::uint32_t count = 0;
        for (std::uint32_t slot = 0; slot < 8; ++slot)
            if (valid & (1u << slot)) {
                if (const std::uint32_t c = tree_.contour(n.level + 1, child)) {
                    p.mask |= 1u << slot;
                    p.values[count++] = c;
                }
                ++child;
            }
        if (p.mask) contours_.push_back(p);
    }

    /// Values of the children of descriptor @p d, in slot order: SparseOctree::attributes.
    template <typename F>
    void forEachChildValue(const SliceBlock::DescriptorRef& d, F&& f) const {
        const std::uint32_t valid = tree_.validMask(d.level, d.index);
        std::uint64_t child = tree_.firstChild(d.level, d.index);
        for (std::uint32_t slot = 0; slot < 8; ++slot)
            if (valid & (1u << slot)) f(slot, tree_.attribute(d.level + 1, child++));
    }

    /// Uncompressed attachment: the lookup array (appendLookup), then the stored values.
    void appendPalette(std::uint64_t descriptorUnits) {
        std::vector<std::uint64_t> values;
        // Pointers in words from the attachment's start: past the lookup array, two per value.
        appendLookup(descriptorUnits, values,
                     esvo::lookupArrayWords(static_cast<std::uint32_t>(descriptorUnits)), 2);
        block_.units.insert(block_.units.end(), values.begin(), values.end());
    }

    /// The lookup array both lookup-based attachments share: the entry of each descriptor's unit
    /// masks the children that differ from their parent (the others inherit) and points at the
    /// first of them, collected into @p values in descriptor order: pointer = @p base + @p scale ×
    /// index. (The root voxel's own value is stored nowhere, so the root stores all its children.)
    void appendLookup(std::uint64_t descriptorUnits, std::vector<std::uint64_t>& values,
                      std::uint64_t base, std::uint64_t scale, bool blockAligned = false) {
        std::vector<std::uint32_t> lookup(
            esvo::lookupArrayWords(static_cast<std::uint32_t>(descriptorUnits)), 0);
        for (const SliceBlock::DescriptorRef& d : descriptors_) {
            const std::uint64_t own =
                d.level == 0 ? ~std::uint64_t{0} : tree_.attribute(d.level, d.index);
            std::uint32_t mask = 0;
            std::array<std::uint64_t, 8> stored{};
            std::uint32_t count = 0;
            forEachChildValue(d, [&](std::uint32_t slot, std::uint64_t value) {
                if (value == own) return;
                mask |= 1u << slot;
                stored[count++] = value;
            });
            if (blockAligned && count > 0)
                padBeforeIncompatible(values, std::span<const std::uint64_t>(stored.data(), count));
            const std::uint64_t pointer = base + scale * values.size();
            values.insert(values.end(), stored.begin(), stored.begin() + count);
            if (pointer > esvo::PaletteLookup::kMaxPointer) block_.pointerOutOfReach = true;
            lookup[d.unit] =
                mask ? esvo::PaletteLookup::make(mask, static_cast<std::uint32_t>(pointer)).word
                     : 0u;
        }
        for (std::size_t i = 0; i < lookup.size(); i += 2)
            block_.units.push_back(lookup[i] | (std::uint64_t{lookup[i + 1]} << 32));
    }

    /// DxtLookup packing: a descriptor's values never straddle two blocks, and start a new block
    /// where they would not share one well with the values already in it (a colour channel
    /// spread past kPackColourSpread, or a normal's cosine to the block's first below
    /// kPackNormalCosine). The skipped slots are padding (kPaddingValue), never referenced.
    static void padBeforeIncompatible(std::vector<std::uint64_t>& values,
                                      std::span<const std::uint64_t> next) {
        const std::size_t inBlock = values.size() % 16;
        bool pad = inBlock + next.size() > 16;
        if (!pad && inBlock > 0) {
            const std::size_t first = values.size() - inBlock;
            std::array<std::uint32_t, 3> lo{255, 255, 255}, hi{0, 0, 0};
            const auto widen = [&](std::uint64_t v) {
                for (unsigned ch = 0; ch < 3; ++ch) {
                    const std::uint32_t c = esvo::colorChannel(static_cast<std::uint32_t>(v), ch);
                    lo[ch] = std::min(lo[ch], c);
                    hi[ch] = std::max(hi[ch], c);
                }
            };
            for (std::size_t i = first; i < values.size(); ++i) widen(values[i]);
            for (std::uint64_t v : next) widen(v);
            for (unsigned ch = 0; ch < 3; ++ch) pad = pad || hi[ch] - lo[ch] > kPackColourSpread;
            const esvo::Vec3 a =
                esvo::decodeUnitNormal(static_cast<std::uint32_t>(values[first] >> 32));
            for (std::uint64_t v : next) {
                const esvo::Vec3 b = esvo::decodeUnitNormal(static_cast<std::uint32_t>(v >> 32));
                pad = pad || a[0] * b[0] + a[1] * b[1] + a[2] * b[2] < kPackNormalCosine;
            }
        }
        if (pad && inBlock > 0) values.resize(values.size() + (16 - inBlock), kPaddingValue);
    }
    static constexpr std::uint32_t kPackColourSpread = 64;
    static constexpr float kPackNormalCosine = 0.819f;  // cos 35°

    /// Combined-lookup compressed attachment: the lookup array (pointers count values), then one
    /// block per 16 stored values, filled by encodeCompressedAttributes once the plan is final.
    void appendLookupAndReserveBlocks(std::uint64_t descriptorUnits) {
        std::vector<std::uint64_t> values;
        appendLookup(descriptorUnits, values, 0, 1, true);
        block_.compressedUnit = block_.units.size();
        block_.units.resize(block_.units.size() + 3 * ((values.size() + 15) / 16), 0);
        block_.pendingValues = std::move(values);
    }

    /// Compressed attachment: one block per pair of units of the descriptor area, filled by
    /// encodeCompressedAttributes once the slice plan is final.
    void reserveCompressed(std::uint64_t descriptorUnits) {
        const std::uint64_t blocks = (descriptorUnits + 1) / 2;
        block_.compressedUnit = block_.units.size();
        block_.units.resize(block_.units.size() + 3 * blocks, 0);  // 6 words each
        block_.pendingCompressed = std::move(descriptors_);
    }

    /// Links each member to its child group (laid out now) or records it as frontier.
    void descend(const Node* members, std::uint64_t n, std::uint64_t start) {
        for (std::uint64_t j = 0; j < n; ++j) {
            if (tree_.nonLeafMask(members[j].level, members[j].index) == 0) continue;
            if (isFrontier(members[j])) {
                frontierUnits_.push_back(start + j);
                block_.frontier.push_back(members[j]);
                continue;
            }
            link(start + j, layoutGroup(members[j]));
        }
    }

    /// Lays out the child group of @p parent — its children with descriptors — and everything
    /// below them; returns the group's first unit.
    std::uint64_t layoutGroup(const Node& parent) {
        const std::uint32_t valid = tree_.validMask(parent.level, parent.index);
        Node members[8];
        std::uint64_t n = 0;
        std::uint64_t child = tree_.firstChild(parent.level, parent.index);
        for (std::uint32_t slot = 0; slot < 8; ++slot)
            if (valid & (1u << slot)) {
                if (tree_.hasDescriptor(parent.level + 1, child))
                    members[n++] = Node{parent.level + 1, child, (parent.path << 3) | slot};
                ++child;
            }
        bool far[8];
        std::uint64_t farCount = 0, earlier = 0;
        for (std::uint64_t j = 0; j < n; ++j) {
            // Conservative: the rest of this group and its slots, the subtrees of earlier
            // members, and a page break before the child group.
            far[j] = isFrontier(members[j]) ||
                     (tree_.nonLeafMask(members[j].level, members[j].index) != 0 &&
                      (2 * n - j) + earlier + 17 > nearLimit_);
            farCount += far[j];
            earlier += subtreeBound(members[j]);
        }
        const std::uint64_t start = placeGroup(n + farCount);
        writeMembers(members, n, start, far);
        descend(members, n, start);
        return start;
    }

    /// Points the descriptor at @p unit to the group at @p group, through its far slot if it has
    /// one.
    void link(std::uint64_t unit, std::uint64_t group) {
        auto& word = block_.units[unit];
        const esvo::ChildDescriptor d{static_cast<std::uint32_t>(word), 0};
        const std::uint64_t offset = group - unit;
        if (d.far()) {
            block_.units[unit + d.childPointer()] =
                static_cast<std::uint32_t>(static_cast<std::int32_t>(offset));
            return;
        }
        if (offset > nearLimit_) {
            // Only possible in a block larger than a slice (see the constructor): mark it unusable.
            block_.overflow = true;
        }
        word = esvo::ChildDescriptor::make(d.validMask(), d.nonLeafMask(),
                                           static_cast<std::uint32_t>(offset), false)
                   .topology;
    }

    const OctreeIndex& tree_;
    const SubtreeSizes& sizes_;
    std::uint32_t nearLimit_;
    CutRule cut_;
    std::uint64_t maxUnits_;
    SliceBlock block_;
    std::vector<std::uint64_t> pageHeaders_;
    std::vector<std::uint64_t> frontierUnits_;
    struct PendingContours {
        std::uint64_t unit;
        std::uint32_t mask;
        std::array<std::uint32_t, 8> values;
    };
    std::vector<PendingContours> contours_;
    AttributeEncoding attributes_;
    std::vector<SliceBlock::DescriptorRef>
        descriptors_;  // with attributes: every descriptor placed, by unit
};

/// Encodes the compressed attribute blocks of a laid-out slice: block p holds the children of
/// the descriptors in units 2p (slots 0-7) and 2p + 1 (slots 8-15).
void encodeCompressedAttributes(SliceBlock& block, const OctreeIndex& tree,
                                AttributeEffort effort) {
    auto& refs = block.pendingCompressed;
    auto* words = reinterpret_cast<std::uint32_t*>(block.units.data() + block.compressedUnit);
    // CompressedLookup: runs of 16 stored values.
    const auto& pending = block.pendingValues;
    for (std::size_t first = 0; first < pending.size(); first += 16) {
        std::array<std::uint64_t, 16> values{};
        const std::size_t n = std::min<std::size_t>(16, pending.size() - first);
        std::copy(pending.begin() + std::ptrdiff_t(first),
                  pending.begin() + std::ptrdiff_t(first + n), values.begin());
        std::uint32_t used = 0;
        for (std::size_t i = 0; i < n; ++i)
            if (values[i] != kPaddingValue) used |= 1u << i;
        const esvo::CompressedBlock encoded = detail::encodeCompressedBlock(values, used, effort);
        std::copy(encoded.begin(), encoded.end(), words + 6 * (first / 16));
    }
    block.pendingValues = {};
    for (std::size_t i = 0; i < refs.size();) {
        const std::uint64_t pair = refs[i].unit / 2;
        std::array<std::uint64_t, 16> values{};
        std::uint32_t used = 0;
        for (; i < refs.size() && refs[i].unit / 2 == pair; ++i) {
            const SliceBlock::DescriptorRef& d = refs[i];
            const std::uint32_t base = (d.unit & 1u) ? 8u : 0u;
            const std::uint32_t valid = tree.validMask(d.level, d.index);
            std::uint64_t child = tree.firstChild(d.level, d.index);
            for (std::uint32_t slot = 0; slot < 8; ++slot)
                if (valid & (1u << slot)) {
                    values[base + slot] = tree.attribute(d.level + 1, child++);
                    used |= 1u << (base + slot);
                }
        }
        const esvo::CompressedBlock encoded = detail::encodeCompressedBlock(values, used, effort);
        std::copy(encoded.begin(), encoded.end(), words + 6 * pair);
    }
    refs = {};
}

/// Splits the octree into slices of at most sliceBytes. A slice whose subtrees fit holds them
/// whole; otherwise every voxel whose subtree fits a slice hands it to a child slice (so the far
/// slots this costs are few, one per such voxel), and if the part left still does not fit, it
/// ends at the deepest level that does. Child slices take runs of the frontier by region; in
/// the top of a partitioned file, each partition root's child group goes to its partition.
class SlicePlanner {
public:
    SlicePlanner(const OctreeIndex& tree, const SubtreeSizes& sizes,
                 const SliceLayoutOptions& options)
        : tree_(tree), sizes_(sizes), options_(options) {}

    /// Slices in depth-first order (each slice, then its children's subtrees in order), with
    /// their blocks. Child slices are planned in parallel; the result does not depend on the
    /// thread count.
    std::vector<std::pair<LaidOutSlice, SliceBlock>> plan() {
        const Node root{0, 0, 0};
        std::unique_ptr<PlanNode> top =
            options_.fileRoot ? makeSlice(root, {}) : makeSlice(root, {root});
        std::vector<std::pair<LaidOutSlice, SliceBlock>> slices;
        flatten(*top, 0xFFFFFFFFu, slices);
        return slices;
    }

    Progress* progress = nullptr;

private:
    struct PlanNode {
        Node region;
        SliceBlock block;
        bool partition = false;  // the place of a partition's slices (no block)
        std::vector<std::unique_ptr<PlanNode>> children;
    };
    struct ChildJob {
        Node region;
        std::vector<Node> parents;
    };

    [[nodiscard]] std::uint64_t budget() const {
        return options_.sliceBytes - options_.sliceBytes / 16;
    }

    SliceBlock layout(const std::vector<Node>& parents, CutRule cut) const {
        return BlockLayout(tree_, sizes_, options_.nearPointerLimit, cut, options_.sliceBytes,
                           options_.attributes)
            .run(parents);
    }

    std::unique_ptr<PlanNode> makeSlice(const Node& region,
                                        const std::vector<Node>& parents) const {
        if (region.level == tree_.partitionLevel()) {
            auto node = std::make_unique<PlanNode>();
            node->region = region;
            node->partition = true;
            return node;
        }
        std::uint64_t content = parents.empty() ? 8 + sizes_(0, 0) : 0;
        std::uint32_t shallowest = parents.empty() ? 0 : 0xFFFFFFFFu;
        for (const Node& p : parents) {
            content += sizes_(p.level, p.index);
            shallowest = std::min(shallowest, p.level + 1);
        }
        std::optional<SliceBlock> block;
        if (content <= budget()) {
            SliceBlock whole = layout(parents, CutRule{});
            if (whole.byteSize() <= options_.sliceBytes) block = std::move(whole);
        }
        if (!block) {
            // Deepest trunk level that fits, from the bottom up.
            for (std::uint32_t end = tree_.depth(); end > shallowest; --end) {
                SliceBlock trial = layout(parents, CutRule{false, budget(), end});
                if (trial.byteSize() <= options_.sliceBytes) {
                    block = std::move(trial);
                    break;
                }
            }
            if (!block) {
                if (parents.size() < 2)
                    throw std::logic_error("esvo layout: the root groups of a slice do not fit it");
                return nullptr;  // the caller splits the run
            }
        }
        auto node = std::make_unique<PlanNode>();
        node->region = region;
        node->block = std::move(*block);
        if (progress) progress->advance();
        std::vector<ChildJob> jobs;
        const auto& frontier = node->block.frontier;
        if (!frontier.empty()) partition(region, frontier, 0, frontier.size(), jobs);
        std::vector<std::vector<std::unique_ptr<PlanNode>>> children(jobs.size());
        tbb::parallel_for(std::size_t{0}, jobs.size(), [&](std::size_t i) {
            children[i] = makeSlices(jobs[i].region, jobs[i].parents);
        });
        for (auto& run : children)
            for (auto& child : run) node->children.push_back(std::move(child));
        return node;
    }

    /// One slice for the run @p parents, or, where its root groups together do not fit a slice
    /// (the estimate let too many of them into one run), slices for its halves.
    std::vector<std::unique_ptr<PlanNode>> makeSlices(const Node& region,
                                                      const std::vector<Node>& parents) const {
        std::vector<std::unique_ptr<PlanNode>> out;
        if (std::unique_ptr<PlanNode> node = makeSlice(region, parents)) {
            out.push_back(std::move(node));
            return out;
        }
        const auto middle = parents.begin() + std::ptrdiff_t(parents.size() / 2);
        for (auto half :
             {std::vector<Node>(parents.begin(), middle), std::vector<Node>(middle, parents.end())})
            for (auto& node : makeSlices(region, half)) out.push_back(std::move(node));
        return out;
    }

    static void flatten(PlanNode& node, std::uint32_t parent,
                        std::vector<std::pair<LaidOutSlice, SliceBlock>>& out) {
        const auto index = static_cast<std::uint32_t>(out.size());
        LaidOutSlice slice;
        slice.region = node.region;
        slice.parent = parent;
        slice.partition = node.partition;
        if (parent != 0xFFFFFFFFu) out[parent].first.children.push_back(index);
        out.emplace_back(std::move(slice), std::move(node.block));
        for (auto& child : node.children) flatten(*child, index, out);
        node.children.clear();
    }

    [[nodiscard]] static bool inside(const Node& n, const Node& region) {
        return n.level >= region.level && (n.path >> (3 * (n.level - region.level))) == region.path;
    }

    /// Child slices for frontier[first, last), all inside @p region. A run holding a partition
    /// root is split down to the partition level: no slice of the top spans two partitions.
    void partition(const Node& region, const std::vector<Node>& frontier, std::size_t first,
                   std::size_t last, std::vector<ChildJob>& jobs) const {
        if (first == last) return;
        std::uint64_t content = 0;
        bool holdsPartition = false;
        for (std::size_t i = first; i < last; ++i) {
            content += sizes_(frontier[i].level, frontier[i].index);
            holdsPartition = holdsPartition || frontier[i].level == tree_.partitionLevel();
        }
        if (region.level == tree_.partitionLevel() ||
            (!holdsPartition &&
             (last - first == 1 || content <= budget() || frontier[first].level == region.level))) {
            jobs.push_back({region, std::vector<Node>(frontier.begin() + std::ptrdiff_t(first),
                                                      frontier.begin() + std::ptrdiff_t(last))});
            return;
        }
        const std::uint32_t valid = tree_.validMask(region.level, region.index);
        std::uint64_t child = tree_.firstChild(region.level, region.index);
        std::size_t i = first;
        for (std::uint32_t slot = 0; slot < 8; ++slot)
            if (valid & (1u << slot)) {
                const Node octant{region.level + 1, child++, (region.path << 3) | slot};
                std::size_t j = i;
                while (j < last && inside(frontier[j], octant)) ++j;
                partition(octant, frontier, i, j, jobs);
                i = j;
            }
        if (i != last) throw std::logic_error("esvo layout: frontier not in Morton order");
    }

    const OctreeIndex& tree_;
    const SubtreeSizes& sizes_;
    const SliceLayoutOptions& options_;
};

}  // namespace

esvo::AttachmentKind attachmentKind(AttributeEncoding encoding) {
    switch (encoding) {
        case AttributeEncoding::Raw:
            return esvo::AttachmentKind::Palette;
        case AttributeEncoding::Compressed:
            return esvo::AttachmentKind::Dxt;
        case AttributeEncoding::CompressedLookup:
            return esvo::AttachmentKind::DxtLookup;
        case AttributeEncoding::None:
            break;
    }
    throw std::logic_error("attachmentKind: no attributes");
}

AttributeEncoding attributeEncoding(std::uint32_t attachmentKinds) {
    for (const auto encoding : {AttributeEncoding::Raw, AttributeEncoding::Compressed,
                                AttributeEncoding::CompressedLookup})
        if (attachmentKinds & (1u << static_cast<unsigned>(attachmentKind(encoding))))
            return encoding;
    return AttributeEncoding::None;
}

OctreeView viewOf(const SparseOctree& octree) {
    OctreeView view;
    view.leafDepth = octree.leafDepth;
    for (const auto& level : octree.masks) view.masks.emplace_back(level);
    for (const auto& level : octree.contours) view.contours.emplace_back(level);
    for (const auto& level : octree.attributes) view.attributes.emplace_back(level);
    return view;
}

std::vector<LaidOutSlice> layoutSlices(const OctreeView& view, const SliceLayoutOptions& options,
                                       Progress* progress) {
    const OctreeIndex index(view);
    std::vector<std::pair<LaidOutSlice, SliceBlock>> planned;
    {
        Timings::Scope timer(options.timings, "esvo_layout");
        const SubtreeSizes sizes(
            index, view.attributes.empty() ? AttributeEncoding::None : options.attributes);
        SlicePlanner planner(index, sizes, options);
        planner.progress = progress;
        planned = planner.plan();
    }
    if (!view.attributes.empty() && (options.attributes == AttributeEncoding::Compressed ||
                                     options.attributes == AttributeEncoding::CompressedLookup)) {
        Timings::Scope timer(options.timings, "esvo_compress_attributes");
        tbb::parallel_for(std::size_t{0}, planned.size(), [&](std::size_t i) {
            encodeCompressedAttributes(planned[i].second, index, options.attributeEffort);
        });
    }

    std::vector<LaidOutSlice> slices;
    slices.reserve(planned.size());
    for (auto& [slice, block] : planned) {
        if (!slice.partition) {
            slice.infoWord = block.infoWord;
            slice.firstLevel = block.firstLevel;
            slice.endLevel = block.endLevel;
            slice.rootGroups = block.rootGroups;
            slice.descriptors = block.descriptors;
            slice.farSlots = block.farSlots;
            slice.voxels = block.voxels;
            slice.frontier = static_cast<std::uint32_t>(block.frontier.size());
            slice.units = std::move(block.units);
        }
        slices.push_back(std::move(slice));
    }
    return slices;
}

}  // namespace vox::detail
