// The radiance volume's streaming policy: a clipmap of bricks around the eye, within a budget.
#include <vox/formats/rvol_tiles.h>
#include <vox/runtime/rvol_residency.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <queue>
#include <set>
#include <tuple>

namespace vox::runtime {
namespace {

/// A needed brick, or a tiled volume's tile not yet opened (bound: no brick of it ranks higher).
struct Candidate {
    /// A tile brick at a level the far field also has: it only refines the far field's brick
    /// (which serves where it is missing), so it waits until every other needed brick fits.
    bool duplicate;
    double priority;
    bool tile;  // an unopened tile: brick.file is the tile
    RvolBrickRef brick;
    std::uint32_t volumeLevel;
    // The brick's slot bytes and {RGB, opacity} atlas slots, taken from the directory while its
    // file is open: the tiled reader may close a tile file that no tile slot keeps on the GPU.
    std::uint64_t bytes;
    std::array<std::uint32_t, 2> slots;
};

/// The heap's order: duplicates last; higher priority first; at ties the far field (base file)
/// first, then coarser levels, then file and directory order.
bool ranksBelow(const Candidate& a, const Candidate& b) {
    const bool aBase = a.brick.file == kBaseFile, bBase = b.brick.file == kBaseFile;
    return std::tie(b.duplicate, a.priority, aBase, a.tile, a.volumeLevel, b.brick.file,
                    b.brick.index) < std::tie(a.duplicate, b.priority, bBase, b.tile, b.volumeLevel,
                                              a.brick.file, a.brick.index);
}

/// Distance from @p eye to the box [lo, hi] (0 inside).
double boxDistance(const std::array<double, 3>& lo, const std::array<double, 3>& hi,
                   const Vec3d& eye) {
    double d2 = 0;
    for (std::size_t a = 0; a < 3; ++a) {
        const double g = std::max({0.0, lo[a] - eye[a], eye[a] - hi[a]});
        d2 += g * g;
    }
    return std::sqrt(d2);
}

}  // namespace

RvolResidency::RvolResidency(RvolGpuVolume& volume, std::uint64_t budgetBytes, double lodScale)
    : volume_(volume), budget_(budgetBytes), lodScale_(lodScale) {
    const auto count = [&](std::uint32_t file) {
        const std::shared_ptr<const rvol::RvolReader> r = volume.fileReader(file);
        for (std::uint32_t l = 0; l < r->levels().size(); ++l)
            for (std::uint32_t i = 0; i < r->level(l).brickCount; ++i)
                if (volume.resident({file, l, i})) {
                    residentBytes_ += volume.brickBytes({file, l, i});
                    lastUsed_[{file, l, i}] = 0;
                }
    };
    count(kBaseFile);
    if (const rvol::TiledRvolReader* tiled = volume.tiled())
        for (std::uint32_t t = 0; t < tiled->index().tiles.size(); ++t)
            if (volume.tileResident(t)) count(t);
}

RvolResidency::Update RvolResidency::update(const PinholeCamera& camera) {
    ++frame_;
    camera.validate();
    const double pixel = lodScale_ * camera.pixelAngle();
    const double span = double(volume_.brickTexels() - 1);
    const std::uint32_t top = volume_.depth();
    const double tiny = 1e-9 * volume_.finestCellSize() * double(1ull << top);
    std::priority_queue<Candidate, std::vector<Candidate>, decltype(&ranksBelow)> queue(ranksBelow);

    const rvol::TiledRvolReader* tiled = volume_.tiled();
    // The far field's finest level: tile bricks from there up duplicate its levels.
    const std::uint32_t farFinest = volume_.volumeLevel(kBaseFile, 0);
    // The needed bricks of a file, with their priority S / distance (the top level's: infinite).
    const auto pushBricks = [&](std::uint32_t file) {
        const std::shared_ptr<const rvol::RvolReader> r = volume_.fileReader(file);
        const rvol::Header& header = r->header();
        std::array<double, 3> end{};
        for (std::size_t a = 0; a < 3; ++a) end[a] = header.origin[a] + header.size;
        for (std::uint32_t l = 0; l < r->levels().size(); ++l) {
            const std::uint32_t level = volume_.volumeLevel(file, l);
            const double cell = header.cellSize(l), edge = span * cell;
            const auto bricks = r->bricks(l);
            for (std::uint32_t i = 0; i < bricks.size(); ++i) {
                const std::uint32_t b[3] = {bricks[i].x, bricks[i].y, bricks[i].z};
                // The brick's texels: cell centres b·(N − 1) … (b + 1)·(N − 1), inside the file.
                std::array<double, 3> lo{}, hi{};
                for (std::size_t a = 0; a < 3; ++a) {
                    lo[a] = header.origin[a] + (b[a] * span + 0.5) * cell;
                    hi[a] = std::min(lo[a] + edge, end[a]);
                }
                const double d = boxDistance(lo, hi, camera.eye);
                if (level < top && !(cell > pixel * d))
                    continue;  // its cells look smaller than lodScale pixels
                const double priority =
                    level == top ? std::numeric_limits<double>::max() : edge / std::max(d, tiny);
                const bool duplicate = file != kBaseFile && level >= farFinest;
                queue.push({duplicate,
                            priority,
                            false,
                            {file, l, i},
                            level,
                            volume_.planeBytes(l, bricks[i].planes),
                            RvolGpuVolume::planeSlots(l, bricks[i].planes)});
            }
        }
    };
    pushBricks(kBaseFile);
    if (tiled) {
        // Each tile by its bound, unopened: the brick edge of its coarsest level below the far
        // field's (else of its coarsest, a duplicate) over its distance.
        const rvol::TileIndex& index = tiled->index();
        const double tileSize = index.tileSize();
        const bool allDuplicates = farFinest == 0;
        const std::uint32_t boundLevel = allDuplicates ? index.tileDepth : farFinest - 1;
        const double boundCell = index.cellSize() * double(1ull << boundLevel);
        for (std::uint32_t t = 0; t < index.tiles.size(); ++t) {
            const rvol::TileEntry& e = index.tiles[t];
            const std::array<double, 3> lo = index.tileOrigin(e.x, e.y, e.z);
            const double d =
                boxDistance(lo, {lo[0] + tileSize, lo[1] + tileSize, lo[2] + tileSize}, camera.eye);
            if (!(boundCell > pixel * d)) continue;  // even that level's cells are under a pixel
            queue.push({allDuplicates,
                        span * boundCell / std::max(d, tiny),
                        true,
                        {t, 0, 0},
                        boundLevel,
                        0,
                        {0, 0}});
        }
    }

    // A prefix of that order within the budget: every kept brick's coarser cover comes before it.
    // A tile's bricks join when its bound comes up; a tile past the tile slots is left out whole
    // (its bricks' cover is the far field's, which the order keeps anyway).
    Update out;
    std::vector<Candidate> kept;
    std::set<std::uint32_t> keptTiles;
    // The atlases bound it too: they hold level-0 and directional planes in a fixed proportion,
    // so a slot kind can run out while the byte budget has room.
    std::uint64_t bytes = 0;
    const std::uint32_t rgbSlots = volume_.rgbSlots().capacity() - 1,
                        alphaSlots = volume_.alphaSlots().capacity() - 1;
    std::uint32_t rgbUsed = 0, alphaUsed = 0;
    while (!queue.empty()) {
        const Candidate c = queue.top();
        if (c.tile) {
            queue.pop();
            if (keptTiles.size() < volume_.tileSlotCount()) pushBricks(c.brick.file);
            continue;
        }
        const std::uint64_t b = c.bytes;
        if (bytes + b > budget_ || rgbUsed + c.slots[0] > rgbSlots ||
            alphaUsed + c.slots[1] > alphaSlots)
            break;
        queue.pop();
        if (c.brick.file != kBaseFile && !keptTiles.contains(c.brick.file)) {
            if (keptTiles.size() >= volume_.tileSlotCount()) {
                ++out.neededNotFitting;
                continue;
            }
            keptTiles.insert(c.brick.file);
        }
        bytes += b;
        rgbUsed += c.slots[0];
        alphaUsed += c.slots[1];
        kept.push_back(c);
        lastUsed_[c.brick] = frame_;
    }
    for (; !queue.empty(); queue.pop()) out.neededNotFitting += queue.top().tile ? 0 : 1;
    out.selected = static_cast<std::uint32_t>(kept.size());
    std::set<RvolBrickRef> selected;
    for (const Candidate& c : kept) selected.insert(c.brick);

    // Evict what is not selected, first the bricks of tiles the view does not keep (which frees
    // their tile slots), then the finest level (a brick goes before its cover), then the least
    // recently selected, until the selection's missing bricks and tiles fit; and again while an
    // atlas has no free slot of the kind a missing brick needs.
    std::uint64_t missing = 0;
    std::set<std::uint32_t> tilesToPlace;
    for (const Candidate& c : kept)
        if (!volume_.resident(c.brick)) {
            missing += c.bytes;
            if (c.brick.file != kBaseFile && !volume_.tileResident(c.brick.file))
                tilesToPlace.insert(c.brick.file);
        }
    std::vector<std::tuple<bool, std::uint32_t, std::uint64_t, RvolBrickRef>> victims;
    for (const auto& [brick, used] : lastUsed_)
        if (!selected.contains(brick))
            victims.emplace_back(brick.file == kBaseFile || keptTiles.contains(brick.file),
                                 volume_.volumeLevel(brick.file, brick.level), used, brick);
    std::sort(victims.begin(), victims.end());
    std::size_t nextVictim = 0;
    const auto evictNext = [&] {
        if (nextVictim == victims.size()) return false;
        const RvolBrickRef brick = std::get<3>(victims[nextVictim++]);
        const std::uint64_t b = volume_.brickBytes(brick);
        volume_.evictBrick(brick);
        lastUsed_.erase(brick);
        residentBytes_ -= b;
        ++out.evicted;
        if (brick.file != kBaseFile && !volume_.tileResident(brick.file)) ++out.tilesEvicted;
        return true;
    };
    while (residentBytes_ + missing > budget_ ||
           tilesToPlace.size() > volume_.tileSlotCount() - volume_.residentTiles())
        if (!evictNext()) break;
    // Upload in priority order (covers first).
    for (std::size_t k = 0; k < kept.size(); ++k) {
        const RvolBrickRef& brick = kept[k].brick;
        if (volume_.resident(brick)) continue;
        const bool newTile = brick.file != kBaseFile && !volume_.tileResident(brick.file);
        bool uploaded = volume_.uploadBrick(brick);
        while (!uploaded && evictNext()) uploaded = volume_.uploadBrick(brick);
        if (!uploaded) {  // an atlas is out of slots with nothing left to evict
            out.neededNotFitting += static_cast<std::uint32_t>(kept.size() - k);
            for (std::size_t j = k; j < kept.size(); ++j)
                if (!volume_.resident(kept[j].brick)) lastUsed_.erase(kept[j].brick);
            break;
        }
        residentBytes_ += kept[k].bytes;
        ++out.uploaded;
        out.tilesUploaded += newTile ? 1 : 0;
    }
    out.residentTiles = volume_.residentTiles();
    out.residentBytes = residentBytes_;
    return out;
}

}  // namespace vox::runtime
