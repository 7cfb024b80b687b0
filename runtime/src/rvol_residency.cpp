// The radiance volume's streaming policy: a clipmap of bricks around the eye, within a budget.
#include <vox/runtime/rvol_residency.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <tuple>

namespace vox::runtime {

RvolResidency::RvolResidency(RvolGpuVolume& volume, std::uint64_t budgetBytes, double lodScale)
    : volume_(volume), budget_(budgetBytes), lodScale_(lodScale) {
    const auto& levels = volume.reader().levels();
    lastUsed_.resize(levels.size());
    for (std::uint32_t l = 0; l < levels.size(); ++l) {
        lastUsed_[l].assign(levels[l].brickCount, 0);
        for (std::uint32_t i = 0; i < levels[l].brickCount; ++i)
            if (volume.resident(l, i)) residentBytes_ += volume.brickBytes(l, i);
    }
}

RvolResidency::Update RvolResidency::update(const PinholeCamera& camera) {
    ++frame_;
    const rvol::RvolReader& reader = volume_.reader();
    const auto& header = reader.header();
    const auto& levels = reader.levels();
    const std::uint32_t top = static_cast<std::uint32_t>(levels.size()) - 1;
    const double span = double(volume_.brickTexels() - 1);
    camera.validate();
    const double pixel = lodScale_ * camera.pixelAngle();

    // Needed bricks with their priority S / distance (the top level's: infinite, coarse first).
    struct Candidate {
        double priority;
        std::uint32_t level, index;
    };
    std::vector<Candidate> candidates;
    for (std::uint32_t l = 0; l <= top; ++l) {
        const double cell = header.cellSize(l), edge = span * cell;
        const auto bricks = reader.bricks(l);
        for (std::uint32_t i = 0; i < bricks.size(); ++i) {
            const std::uint32_t b[3] = {bricks[i].x, bricks[i].y, bricks[i].z};
            double d2 = 0;
            for (int a = 0; a < 3; ++a) {
                // The brick's texels: cell centres b·(N − 1) … (b + 1)·(N − 1).
                const double lo = header.origin[std::size_t(a)] + (b[a] * span + 0.5) * cell,
                             hi = lo + edge;
                const double g = std::max(
                    {0.0, lo - camera.eye[std::size_t(a)], camera.eye[std::size_t(a)] - hi});
                d2 += g * g;
            }
            const double d = std::sqrt(d2);
            if (l < top && !(cell > pixel * d))
                continue;  // its cells look smaller than lodScale pixels
            const double priority = l == top ? std::numeric_limits<double>::max()
                                             : edge / std::max(d, 1e-9 * header.size);
            candidates.push_back({priority, l, i});
        }
    }
    std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
        return std::tie(b.priority, b.level, a.index) < std::tie(a.priority, a.level, b.index);
    });
    // A prefix of that order within the budget: every kept brick's coarser cover comes before it.
    Update out;
    std::vector<std::vector<char>> selected(levels.size());
    for (std::uint32_t l = 0; l <= top; ++l) selected[l].assign(levels[l].brickCount, 0);
    std::uint64_t bytes = 0;
    std::size_t kept = 0;
    for (; kept < candidates.size(); ++kept) {
        const Candidate& c = candidates[kept];
        const std::uint64_t b = volume_.brickBytes(c.level, c.index);
        if (bytes + b > budget_) break;
        bytes += b;
        selected[c.level][c.index] = 1;
        lastUsed_[c.level][c.index] = frame_;
    }
    out.selected = static_cast<std::uint32_t>(kept);
    out.neededNotFitting = static_cast<std::uint32_t>(candidates.size() - kept);

    // Evict what is not selected, finest level first (a brick goes before its cover), then the
    // least recently selected, until the selection's missing bricks fit.
    std::uint64_t missing = 0;
    for (std::size_t k = 0; k < kept; ++k)
        if (!volume_.resident(candidates[k].level, candidates[k].index))
            missing += volume_.brickBytes(candidates[k].level, candidates[k].index);
    std::vector<std::tuple<std::uint32_t, std::uint64_t, std::uint32_t>>
        victims;  // level, last used, index
    for (std::uint32_t l = 0; l <= top; ++l)
        for (std::uint32_t i = 0; i < levels[l].brickCount; ++i)
            if (volume_.resident(l, i) && !selected[l][i])
                victims.emplace_back(l, lastUsed_[l][i], i);
    std::sort(victims.begin(), victims.end());
    for (const auto& [level, used, index] : victims) {
        if (residentBytes_ + missing <= budget_) break;
        volume_.evictBrick(level, index);
        residentBytes_ -= volume_.brickBytes(level, index);
        ++out.evicted;
    }
    // Upload in priority order (covers first).
    for (std::size_t k = 0; k < kept; ++k) {
        const Candidate& c = candidates[k];
        if (volume_.resident(c.level, c.index)) continue;
        if (!volume_.uploadBrick(c.level, c.index)) {  // the atlas is out of slots of one kind
            out.neededNotFitting += static_cast<std::uint32_t>(kept - k);
            break;
        }
        residentBytes_ += volume_.brickBytes(c.level, c.index);
        ++out.uploaded;
    }
    out.residentBytes = residentBytes_;
    return out;
}

}  // namespace vox::runtime
