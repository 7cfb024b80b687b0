// The partitioned octree build: voxelizes a scene a run of partitions at a time, as many as the
// memory limit holds, lays each partition's slices out as soon as it is built and keeps them (in
// memory while they fit a share of the limit, then in a scratch file), and finally lays out the
// top above the partitions and assembles the file; or, for one run of a build split across
// processes, writes a part file that mergeEsvoParts joins with the others.
#include "esvo_assemble.h"
#include "esvo_parts.h"
#include "surface_voxelizer.h"

#include <vox/base/error.h>
#include <vox/util/log.h>

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <unistd.h>

namespace vox {

std::uint64_t EsvoBuildResult::voxelCount() const noexcept {
    std::uint64_t total = 0;
    for (std::uint64_t n : voxelsPerLevel) total += n;
    return total;
}

std::uint64_t defaultMemoryLimit() {
    const auto pages = ::sysconf(_SC_PHYS_PAGES), pageSize = ::sysconf(_SC_PAGESIZE);
    std::uint64_t physical = pages > 0 && pageSize > 0
                                 ? std::uint64_t(pages) * std::uint64_t(pageSize)
                                 : std::uint64_t{8} << 30;
    // A container's limit (cgroup v2), where it is below the machine's memory.
    std::ifstream cgroup("/sys/fs/cgroup/memory.max");
    std::string limit;
    if (cgroup >> limit && limit != "max") {
        const std::uint64_t bytes = std::strtoull(limit.c_str(), nullptr, 10);
        if (bytes > 0) physical = std::min(physical, bytes);
    }
    return physical / 2;
}

namespace {

using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point start) {
    return std::chrono::duration<double>(Clock::now() - start).count();
}

/// Raises @p value to @p candidate if that is larger (from any thread).
void raiseTo(std::atomic<double>& value, double candidate) {
    for (double seen = value.load();
         candidate > seen && !value.compare_exchange_weak(seen, candidate);) {}
}

/// A voxel of the partition level with triangles binned under it: its run of cells.
struct Partition {
    std::uint32_t code = 0;
    std::size_t firstCell = 0, endCell = 0;
    double area = 0;  // leaf voxels², about its leaf count
};

std::vector<Partition> partitionsOf(const detail::SurfaceVoxelizer& voxelizer,
                                    std::uint32_t partitionLevel) {
    std::vector<Partition> partitions;
    const std::uint32_t shift = 3 * (voxelizer.cellLevel() - partitionLevel);
    for (std::size_t c = 0; c < voxelizer.cellCount(); ++c) {
        const std::uint32_t code = voxelizer.cellCode(c) >> shift;
        if (partitions.empty() || partitions.back().code != code)
            partitions.push_back({code, c, c, 0});
        partitions.back().endCell = c + 1;
        partitions.back().area += voxelizer.cellArea(c);
    }
    return partitions;
}

/// Run @p selection.index of @p partitions split into selection.count runs of about equal area.
std::pair<std::size_t, std::size_t> selectRun(const std::vector<Partition>& partitions,
                                              PartitionSelection selection) {
    if (selection.count <= 1) return {0, partitions.size()};
    double total = 0;
    for (const Partition& p : partitions) total += p.area + 1;
    // Run i holds the partitions whose cumulative area (at their middle) falls in [i,
    // i+1)·total/count.
    std::size_t first = partitions.size(), last = partitions.size();
    double before = 0;
    for (std::size_t i = 0; i < partitions.size(); ++i) {
        const double middle = before + 0.5 * (partitions[i].area + 1);
        const auto run = std::min<std::uint64_t>(
            static_cast<std::uint64_t>(middle / total * selection.count), selection.count - 1);
        if (run == selection.index && first == partitions.size()) first = i;
        if (run > selection.index) {
            last = i;
            break;
        }
        before += partitions[i].area + 1;
    }
    if (first == partitions.size()) first = last;
    return {first, last};
}

/// Everything that decides a build's bytes: options, the scene's geometry as binned, the
/// partitions. Runs of one build must agree on it.
std::uint64_t buildFingerprint(const esvo::Header& header, const EsvoBuildOptions& options,
                               std::uint32_t partitionLevel,
                               const detail::SurfaceVoxelizer& voxelizer) {
    const auto headerBytes = esvo::encodeHeader(header);
    std::uint64_t hash = detail::fnv1a64(headerBytes.data(), headerBytes.size());
    const SurfaceVoxelizeOptions& v = options.voxelize;
    const double values[] = {double(v.depth),
                             double(v.includeDynamic),
                             double(v.onlyDynamic),
                             double(v.contours),
                             v.contourError,
                             double(v.attributes),
                             v.colorError,
                             v.normalErrorDegrees,
                             double(partitionLevel),
                             double(static_cast<int>(options.write.attributes)),
                             double(static_cast<int>(options.write.attributeEffort))};
    hash = detail::fnv1a64(values, sizeof values, hash);
    for (std::size_t c = 0; c < voxelizer.cellCount(); ++c) {
        const std::uint32_t code = voxelizer.cellCode(c);
        const std::uint64_t triangles = voxelizer.cellTriangles(c);
        const double area = voxelizer.cellArea(c);
        hash = detail::fnv1a64(&code, sizeof code, hash);
        hash = detail::fnv1a64(&triangles, sizeof triangles, hash);
        hash = detail::fnv1a64(&area, sizeof area, hash);
    }
    return hash;
}

std::uint64_t octreeBytes(const SparseOctree& octree) {
    std::uint64_t bytes = 0;
    for (const auto& l : octree.masks) bytes += l.capacity();
    for (const auto& l : octree.contours) bytes += 4 * l.capacity();
    for (const auto& l : octree.attributes) bytes += 8 * l.capacity();
    return bytes;
}

/// The voxels-per-level of the whole octree: the top's, then the partitions' below it.
std::vector<std::uint64_t> voxelsPerLevel(const detail::TopTree& top,
                                          const std::vector<detail::PartitionRoot>& roots,
                                          std::uint32_t leafDepth) {
    std::vector<std::uint64_t> counts(leafDepth + 1, 0);
    std::copy(top.voxelsPerLevel.begin(), top.voxelsPerLevel.end(), counts.begin());
    for (const detail::PartitionRoot& r : roots)
        for (std::size_t l = 1; l < r.voxelsPerLevel.size(); ++l)
            counts[top.partitionLevel + l] += r.voxelsPerLevel[l];
    return counts;
}

/// Lays out the top over @p roots and assembles the file from it and @p partitions.
EsvoWriteResult assemblePartitioned(const std::filesystem::path& file, detail::EsvoFileInfo info,
                                    const std::vector<detail::PartitionRoot>& roots,
                                    std::vector<detail::PartitionSlices>&& partitions,
                                    std::uint32_t partitionLevel,
                                    const EsvoWriteOptions& writeOptions, detail::SliceStore& store,
                                    std::vector<std::uint64_t>& counts) {
    const bool contours = info.header.attachmentKinds & 1u,
               attributes = info.header.hasAttributes();
    const detail::TopTree top = detail::buildTop(roots, partitionLevel, contours, attributes);
    counts = voxelsPerLevel(top, roots, info.header.leafDepth);
    info.voxelsPerLevel = counts;
    const detail::OctreeView view = top.view();
    EsvoWriteOptions topOptions = writeOptions;
    topOptions.attributes = attributes ? writeOptions.attributes : AttributeEncoding::None;
    const detail::PartitionSlices topSlices = detail::storeSlices(
        detail::layoutSlices(view, detail::sliceLayoutOptions(topOptions, attributes, true)), 0, 0,
        store);
    return detail::assembleEsvo(file, info, &topSlices, std::move(partitions), store,
                                writeOptions.timings);
}

std::string megabytes(std::uint64_t bytes) {
    char text[32];
    std::snprintf(text, sizeof text, "%.0f MB", double(bytes) / 1e6);
    return text;
}

}  // namespace

EsvoBuildResult buildEsvo(const std::filesystem::path& file, const Scene& scene,
                          const EsvoBuildOptions& options) {
    const SurfaceVoxelizeOptions& vo = options.voxelize;
    EsvoBuildResult result;
    result.memoryLimit = options.memoryLimit ? options.memoryLimit : defaultMemoryLimit();
    if (options.partitions.count == 0 || options.partitions.index >= options.partitions.count)
        throw ParameterError("partition", "K/N needs 1 ≤ K ≤ N");
    const auto voxelizerStart = Clock::now();
    const detail::SurfaceVoxelizer voxelizer(scene, vo);
    result.voxelizeSeconds = secondsSince(voxelizerStart);
    if (vo.timings) vo.timings->add("voxelize", 1000 * result.voxelizeSeconds);
    const std::uint32_t depth = voxelizer.depth();
    const std::uint32_t p = detail::resolvePartitionLevel(options.write.partitionLevel, depth);
    if (p > voxelizer.cellLevel())
        throw ParameterError("partitionLevel", "must be at most " +
                                                   std::to_string(voxelizer.cellLevel()) +
                                                   " at depth " + std::to_string(depth));
    if (options.partitions.count > 1 && p == 0)
        throw ParameterError("partition",
                             "needs partitions: a depth of 10 or more, or a partition level");
    result.leafDepth = depth;
    result.partitionLevel = p;
    const bool attributes = vo.attributes;
    detail::EsvoFileInfo info;
    info.header =
        detail::esvoHeader(voxelizer.cube(), depth, vo.contours, attributes, options.write);

    // What the build holds besides partitions (scene, triangles, bins) is already resident; the
    // rest of the limit goes to a quarter for finished slices and the remainder to partitions.
    const std::uint64_t baseline = currentRssBytes();
    if (baseline >= result.memoryLimit / 2)
        throw ParameterError("memoryLimit",
                             megabytes(result.memoryLimit) +
                                 " is too small: the scene and its triangles already take " +
                                 megabytes(baseline));
    const std::uint64_t storeBudget =
        options.memorySliceBytes ? options.memorySliceBytes : result.memoryLimit / 4;
    const std::uint64_t partitionBudget =
        options.roundBytes ? options.roundBytes
                           : result.memoryLimit - baseline - result.memoryLimit / 4;
    detail::SliceStore store(storeBudget, file.parent_path());

    // Partition level 0: the whole octree is one partition, laid out from the file's root.
    const std::vector<Partition> all = partitionsOf(voxelizer, p);
    const auto [first, last] = selectRun(all, options.partitions);
    result.partitionsTotal = all.size();
    result.partitionsBuilt = last - first;

    std::vector<detail::PartitionRoot> roots;
    std::vector<detail::PartitionSlices> partitionSlices;
    // Bytes per leaf voxel² of area a partition takes while it is built and laid out: learnt from
    // those built so far (starting high), to size the next round.
    std::atomic<double> bytesPerArea{256.0};
    Progress progress("voxelizing",
                      last > first ? all[last - 1].endCell - all[first].firstCell : 0);
    for (std::size_t i = first; i < last;) {
        // A round: the next partitions whose estimate fits the budget (at least one).
        std::size_t j = i;
        double estimate = 0;
        while (j < last && (j == i || estimate + bytesPerArea.load() * (all[j].area + 1) <=
                                          double(partitionBudget))) {
            estimate += bytesPerArea.load() * (all[j].area + 1);
            ++j;
        }
        ++result.batches;
        const auto roundStart = Clock::now();
        const std::size_t count = j - i;
        std::vector<detail::PartitionRoot> roundRoots(count);
        std::vector<detail::PartitionSlices> roundSlices(count);
        std::vector<char> occupied(count, 0);
        // When the round's last cell subtree was built, in seconds after its start.
        std::atomic<double> voxelized{0.0};
        // Each partition is voxelized, joined, laid out and encoded in one task, so that one
        // partition's serial steps (its join, its slice plan) overlap the others' cells, and its
        // cells' outputs are freed as soon as it is joined.
        tbb::parallel_for(std::size_t{0}, count, [&](std::size_t n) {
            std::vector<detail::CellSubtree> own =
                voxelizer.buildCells(all[i + n].firstCell, all[i + n].endCell, &progress);
            raiseTo(voxelized, secondsSince(roundStart));
            detail::PartitionRoot& root = roundRoots[n];
            SparseOctree octree = voxelizer.join(std::move(own), p, &root.sums);
            if (octree.leafDepth == 0) return;  // rounding left nothing
            occupied[n] = 1;
            const std::uint64_t bytes = octreeBytes(octree);
            root.code = all[i + n].code;
            root.mask = octree.masks[0][0];
            root.voxelsPerLevel = octree.voxelsPerLevel;
            std::uint64_t child = 0;
            for (std::uint32_t slot = 0; slot < 8; ++slot)
                if (root.mask & (1u << slot)) {
                    if (octree.leafDepth > 1 && octree.masks[1][child])
                        root.nonLeaf = static_cast<std::uint8_t>(root.nonLeaf | (1u << slot));
                    if (!octree.contours.empty())
                        root.childContours.push_back(octree.contours[1][child]);
                    if (!octree.attributes.empty())
                        root.childAttributes.push_back(octree.attributes[1][child]);
                    ++child;
                }
            if (p == 0 || root.nonLeaf)
                roundSlices[n] = detail::storeSlices(
                    detail::layoutSlices(
                        detail::viewOf(octree),
                        detail::sliceLayoutOptions(options.write, attributes, p == 0)),
                    p, root.code, store);
            // Built, laid out and encoded: about twice its arrays at the peak, and its blocks.
            const double used = 2.5 * double(bytes) / (all[i + n].area + 1);
            raiseTo(bytesPerArea, used);
        });
        for (std::size_t n = 0; n < count; ++n)
            if (occupied[n]) {
                roots.push_back(std::move(roundRoots[n]));
                partitionSlices.push_back(std::move(roundSlices[n]));
            }
        // The voxelization's share of the round is its wall time until its last cell was built,
        // the layout's the rest.
        const double roundSeconds = secondsSince(roundStart), voxelizeSeconds = voxelized.load();
        result.voxelizeSeconds += voxelizeSeconds;
        if (vo.timings) {
            vo.timings->add("voxelize", 1000 * voxelizeSeconds);
            vo.timings->add("voxelize_subtrees", 1000 * voxelizeSeconds);
        }
        if (options.write.timings)
            options.write.timings->add("esvo", 1000 * (roundSeconds - voxelizeSeconds));
        i = j;
    }
    result.scratchBytes = store.scratchBytes();

    const auto finishStart = Clock::now();
    if (p == 0) {
        if (roots.empty())
            throw InvalidDataError(scene.sourceFiles.empty() ? "scene" : scene.sourceFiles.front(),
                                   "no voxels");
        result.voxelsPerLevel = roots.front().voxelsPerLevel;
        info.voxelsPerLevel = result.voxelsPerLevel;
        result.written = detail::assembleEsvo(file, info, nullptr, std::move(partitionSlices),
                                              store, options.write.timings);
    } else if (options.partitions.count == 1) {
        result.written = assemblePartitioned(file, info, roots, std::move(partitionSlices), p,
                                             options.write, store, result.voxelsPerLevel);
    } else {
        detail::EsvoPart part;
        part.runIndex = options.partitions.index;
        part.runCount = options.partitions.count;
        part.partitionLevel = p;
        part.partitionsTotal = static_cast<std::uint32_t>(all.size());
        part.firstPartition = static_cast<std::uint32_t>(first);
        part.partitionsInRun = static_cast<std::uint32_t>(last - first);
        part.fingerprint = buildFingerprint(info.header, options, p, voxelizer);
        part.header = info.header;
        part.attributeEffort = options.write.attributeEffort;
        result.voxelsPerLevel.assign(depth + 1, 0);
        for (const detail::PartitionRoot& r : roots)
            for (std::size_t l = 0; l < r.voxelsPerLevel.size(); ++l)
                result.voxelsPerLevel[p + l] += r.voxelsPerLevel[l];
        part.roots = std::move(roots);
        part.slices = std::move(partitionSlices);
        result.written.fileBytes = detail::writeEsvoPart(file, part, store);
        for (const auto& s : part.slices) {
            result.written.slices += static_cast<std::uint32_t>(s.slices.size());
            for (const auto& r : s.slices) {
                result.written.descriptors += r.descriptors;
                result.written.farPointers += r.farSlots;
            }
        }
    }
    if (options.write.timings) options.write.timings->add("esvo", 1000 * secondsSince(finishStart));
    if (peakRssBytes() > result.memoryLimit)
        log::warning("peak memory " + megabytes(peakRssBytes()) + " exceeded the memory limit " +
                     megabytes(result.memoryLimit));
    return result;
}

EsvoBuildResult mergeEsvoParts(const std::filesystem::path& file,
                               const std::vector<std::filesystem::path>& parts,
                               std::uint64_t memoryLimit, Timings* timings) {
    if (parts.empty()) throw UsageError("merge: no part files");
    EsvoBuildResult result;
    result.memoryLimit = memoryLimit ? memoryLimit : defaultMemoryLimit();
    detail::SliceStore store(result.memoryLimit / 4, file.parent_path());
    std::vector<detail::EsvoPart> read;
    {
        Timings::Scope timer(timings, "merge_read");
        for (const auto& path : parts) read.push_back(detail::readEsvoPart(path, store));
    }
    std::sort(read.begin(), read.end(),
              [](const auto& a, const auto& b) { return a.runIndex < b.runIndex; });
    const detail::EsvoPart& head = read.front();
    const auto sameBuild = [&](const detail::EsvoPart& part) {
        return part.fingerprint == head.fingerprint &&
               part.attributeEffort == head.attributeEffort && part.runCount == head.runCount &&
               part.partitionLevel == head.partitionLevel &&
               part.partitionsTotal == head.partitionsTotal &&
               part.header.leafDepth == head.header.leafDepth;
    };
    std::uint32_t nextPartition = 0;
    for (std::size_t i = 0; i < read.size(); ++i) {
        if (!sameBuild(read[i]))
            throw InvalidDataError(read[i].path,
                                   "part of a different build than " + head.path.string());
        if (read[i].runIndex < i)
            throw InvalidDataError(read[i].path,
                                   "merge: run " + std::to_string(read[i].runIndex + 1) + " of " +
                                       std::to_string(head.runCount) + " is given twice");
        if (read[i].runIndex > i)
            throw InvalidDataError(file, "merge: run " + std::to_string(i + 1) + " of " +
                                             std::to_string(head.runCount) + " is missing");
        if (read[i].firstPartition != nextPartition)
            throw InvalidDataError(file, "merge: runs do not tile the partitions");
        nextPartition += read[i].partitionsInRun;
    }
    if (read.size() != head.runCount)
        throw InvalidDataError(file, "merge: run " + std::to_string(read.size() + 1) + " of " +
                                         std::to_string(head.runCount) + " is missing");
    if (nextPartition != head.partitionsTotal)
        throw InvalidDataError(file, "merge: runs do not tile the partitions");

    std::vector<detail::PartitionRoot> roots;
    std::vector<detail::PartitionSlices> partitionSlices;
    for (detail::EsvoPart& part : read) {
        for (auto& r : part.roots) roots.push_back(std::move(r));
        for (auto& s : part.slices) partitionSlices.push_back(std::move(s));
    }
    for (std::size_t i = 1; i < roots.size(); ++i)
        if (roots[i].code <= roots[i - 1].code)
            throw InvalidDataError(file, "merge: partitions out of Morton order");
    detail::EsvoFileInfo info;
    info.header = head.header;
    EsvoWriteOptions writeOptions;
    writeOptions.sliceBytes = head.header.sliceBytesLimit;
    writeOptions.nearPointerLimit = head.header.nearPointerLimit;
    writeOptions.attributes = detail::attributeEncoding(head.header.attachmentKinds);
    writeOptions.attributeEffort = head.attributeEffort;
    writeOptions.timings = timings;
    result.leafDepth = head.header.leafDepth;
    result.partitionLevel = head.partitionLevel;
    result.partitionsTotal = head.partitionsTotal;
    result.partitionsBuilt = head.partitionsTotal;
    result.written =
        assemblePartitioned(file, info, roots, std::move(partitionSlices), head.partitionLevel,
                            writeOptions, store, result.voxelsPerLevel);
    result.scratchBytes = store.scratchBytes();
    return result;
}

}  // namespace vox
