// Which slices a view needs and keeping a pool of them under a budget (the streaming policy).
#include <vox/runtime/slice_schedule.h>

#include <vox/base/error.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <queue>
#include <stdexcept>
#include <string>
#include <tuple>

namespace vox::runtime {

namespace {

constexpr double kPi = 3.14159265358979323846;

using V3 = Vec3d;

/// Unit vector by the reciprocal of the length (not vox::normalize's division: the schedule's
/// planes keep the bits they always had).
V3 unit(V3 a) {
    const double l = std::sqrt(dot(a, a));
    return l > 0 ? a * (1 / l) : V3{0, 0, 0};
}

/// The view in root-cube coordinates: the eye, and inward normals of the frustum's near and four
/// side planes through it.
struct RootView {
    V3 eye;
    std::array<V3, 5> planes;
    double pixelAngle;
    double lodScale;

    RootView(const esvo::Header& header, const StreamingView& view) {
        const auto& m = header.worldToRoot;
        const auto point = [&](V3 p) {
            return V3{m[0] * p[0] + m[1] * p[1] + m[2] * p[2] + m[3],
                      m[4] * p[0] + m[5] * p[1] + m[6] * p[2] + m[7],
                      m[8] * p[0] + m[9] * p[1] + m[10] * p[2] + m[11]};
        };
        const auto direction = [&](V3 d) {
            return V3{m[0] * d[0] + m[1] * d[1] + m[2] * d[2],
                      m[4] * d[0] + m[5] * d[1] + m[6] * d[2],
                      m[8] * d[0] + m[9] * d[1] + m[10] * d[2]};
        };
        const PinholeCamera& camera = view.camera;
        camera.validate();
        if (!(view.lodScale > 0))
            throw UsageError("streaming view: the LOD scale must be positive");
        eye = point(camera.eye);
        const V3 forward = unit(direction(camera.target - camera.eye));
        const V3 right = unit(cross(forward, unit(direction(camera.up))));
        const V3 up = cross(right, forward);
        const double ty = std::tan(0.5 * camera.fovYDegrees * kPi / 180);
        const double tx = ty * double(camera.width) / double(camera.height);
        planes = {forward, forward * tx - right, forward * tx + right, forward * ty - up,
                  forward * ty + up};
        pixelAngle = camera.pixelAngle();
        lodScale = view.lodScale;
    }

    /// Conservative: false only where the cube lies wholly outside one plane.
    [[nodiscard]] bool sees(const SliceRegion& r) const {
        const double s = r.size();
        const V3 lo{double(r.x) * s, double(r.y) * s, double(r.z) * s};
        for (const V3& n : planes) {
            // The corner furthest along n.
            const V3 corner{n[0] > 0 ? lo[0] + s : lo[0], n[1] > 0 ? lo[1] + s : lo[1],
                            n[2] > 0 ? lo[2] + s : lo[2]};
            if (dot(n, corner - eye) < 0) return false;
        }
        return true;
    }
    /// Distance from the eye to the cube (0 inside).
    [[nodiscard]] double distance(const SliceRegion& r) const {
        const double s = r.size();
        double d2 = 0;
        const std::array<std::uint64_t, 3> c{r.x, r.y, r.z};
        for (int k = 0; k < 3; ++k) {
            const double lo = double(c[std::size_t(k)]) * s, hi = lo + s;
            const double g = std::max({0.0, lo - eye[std::size_t(k)], eye[std::size_t(k)] - hi});
            d2 += g * g;
        }
        return std::sqrt(d2);
    }
    /// The angular size of slice @p entry's frontier voxels (the parent's leaves without it), or
    /// a negative value where the slice is not needed.
    [[nodiscard]] double need(const esvo::SliceEntry& entry, const SliceRegion& region) const {
        if (!sees(region)) return -1;
        const double voxel =
            1.0 / double(std::uint64_t{1} << std::min<std::uint32_t>(entry.firstLevel, 62));
        const double d = distance(region);
        const double angle = d > 0 ? voxel / d : std::numeric_limits<double>::infinity();
        return angle > lodScale * pixelAngle ? angle : -1;
    }
};

}  // namespace

std::vector<SliceRegion> sliceRegions(const esvo::Directory& directory) {
    std::vector<SliceRegion> regions(directory.slices.size());
    for (std::size_t i = 1; i < directory.slices.size(); ++i) {
        const esvo::SliceEntry& e = directory.slices[i];
        // Parents come before their children in the directory (docs/esvo-format.md).
        // Parents precede their children (the readers check it); a directory built otherwise is a
        // bug.
        if (e.parent >= i)
            throw std::logic_error("sliceRegions: slice " + std::to_string(i) +
                                   " comes before its parent");
        SliceRegion r = regions[e.parent];
        for (std::uint32_t k = 0; k < e.pathLevels; ++k) {
            const auto octant = std::uint32_t((e.regionPath >> (3 * (e.pathLevels - 1 - k))) & 7u);
            r = {r.level + 1, 2 * r.x + (octant & 1u), 2 * r.y + ((octant >> 1) & 1u),
                 2 * r.z + ((octant >> 2) & 1u)};
        }
        regions[i] = r;
    }
    return regions;
}

std::uint64_t residentBytesOf(const esvo::SliceEntry& entry) noexcept {
    return (std::uint64_t{entry.byteSize} + esvo::kPageBytes - 1) / esvo::kPageBytes *
           esvo::kPageBytes;
}

SliceSelection selectSlices(const esvo::EsvoReader& reader, const std::vector<SliceRegion>& regions,
                            const StreamingView& view, std::uint64_t budgetBytes,
                            const std::vector<char>* excluded) {
    const esvo::Directory& directory = reader.directory();
    if (regions.size() != directory.slices.size())
        throw UsageError("selectSlices: one region per slice");
    if (excluded != nullptr && excluded->size() != directory.slices.size())
        throw UsageError("selectSlices: one exclusion flag per slice");
    const RootView root(reader.header(), view);
    SliceSelection out;
    if (directory.slices.empty()) return out;
    out.slices.push_back(0);
    out.bytes = residentBytesOf(directory.slices[0]);
    // Largest angular size first; ties to the lower index.
    using Candidate = std::pair<double, std::uint32_t>;
    const auto later = [](const Candidate& a, const Candidate& b) {
        return std::tie(a.first, b.second) < std::tie(b.first, a.second);
    };
    std::priority_queue<Candidate, std::vector<Candidate>, decltype(later)> queue(later);
    const auto offerChildren = [&](std::uint32_t slice) {
        const esvo::SliceEntry& e = directory.slices[slice];
        for (std::uint32_t c = e.firstChild;
             c < e.firstChild + e.childCount && c < directory.slices.size(); ++c) {
            if (excluded != nullptr && (*excluded)[c])
                continue;  // nor is anything below it offered
            const double angle = root.need(directory.slices[c], regions[c]);
            if (angle > 0) queue.push({angle, c});
        }
    };
    offerChildren(0);
    while (!queue.empty()) {
        const std::uint32_t slice = queue.top().second;
        queue.pop();
        const std::uint64_t bytes = residentBytesOf(directory.slices[slice]);
        if (out.bytes + bytes > budgetBytes) {
            ++out.neededNotFitting;
            continue;
        }
        out.bytes += bytes;
        out.slices.push_back(slice);
        offerChildren(slice);
    }
    // Parents before children: a parent was selected before any child was offered, so selection
    // order already is; keep it.
    return out;
}

SliceResidency::SliceResidency(esvo::EsvoPool& pool, std::uint64_t budgetBytes)
    : pool_(pool),
      regions_(sliceRegions(pool.reader().directory())),
      lastUsed_(regions_.size(), 0),
      bad_(regions_.size(), 0),
      budget_(budgetBytes) {}

SliceResidency::Update SliceResidency::update(const StreamingView& view) {
    ++frame_;
    Update out;
    out.selection = selectSlices(pool_.reader(), regions_, view, budget_, &bad_);
    const std::uint32_t count = pool_.reader().sliceCount();
    std::vector<char> selected(count, 0);
    std::uint64_t missing = 0;
    for (std::uint32_t s : out.selection.slices) {
        selected[s] = 1;
        lastUsed_[s] = frame_;
        if (!pool_.loaded(s)) missing += residentBytesOf(pool_.reader().slice(s));
    }
    // Evict the least recently selected slices not selected now until the missing ones fit.
    while (pool_.residentBytes() + missing > budget_) {
        std::uint32_t victim = 0;
        for (std::uint32_t s = 1; s < count; ++s)
            if (pool_.loaded(s) && !selected[s] &&
                (victim == 0 || lastUsed_[s] < lastUsed_[victim] ||
                 (lastUsed_[s] == lastUsed_[victim] && s > victim)))
                victim = s;
        if (victim == 0) break;  // only the selection is left: it fits by construction
        std::vector<std::uint32_t> before;
        for (std::uint32_t s = 1; s < count; ++s)
            if (pool_.loaded(s)) before.push_back(s);
        pool_.unload(victim);
        for (std::uint32_t s : before)
            if (!pool_.loaded(s)) out.evicted.push_back(s);
    }
    // Load in selection order (coarse and near first; parents before children), up to the
    // per-frame limit; a child whose parent had to wait waits too. A slice that fails to load is
    // marked bad and skipped with everything below it; the rest go on loading.
    for (std::uint32_t s : out.selection.slices) {
        if (pool_.loaded(s)) continue;
        const std::uint32_t parent = s == 0 ? 0 : pool_.reader().slice(s).parent;
        if (s != 0 && bad_[parent]) {
            bad_[s] =
                2;  // below a slice that failed in this update: not bad itself, just unreachable
            continue;
        }
        const std::uint64_t bytes = residentBytesOf(pool_.reader().slice(s));
        const bool parentReady = s == 0 || pool_.loaded(parent);
        if (!parentReady ||
            (frameLimit_ > 0 && !out.loaded.empty() && out.loadedBytes + bytes > frameLimit_)) {
            ++out.pending;
            continue;
        }
        try {
            pool_.load(s);
        } catch (const Error& e) {
            if (dynamic_cast<const InvalidDataError*>(&e) == nullptr &&
                dynamic_cast<const IoError*>(&e) == nullptr)
                throw;
            bad_[s] = 1;
            badList_.push_back(s);
            out.failed.push_back(s);
            const esvo::SliceEntry& entry = pool_.reader().slice(s);
            std::string problem = e.what();
            const std::string path = pool_.reader().path().string();
            if (problem.rfind(path + ": ", 0) == 0)
                problem.erase(0, path.size() + 2);  // named once, in front
            out.errors.push_back(
                path + ": slice " + std::to_string(s) + " (levels " +
                std::to_string(entry.firstLevel) + "-" + std::to_string(entry.endLevel) + ", " +
                std::to_string(entry.byteSize) + " bytes at file offset " +
                std::to_string(entry.fileOffset) +
                ") rejected, not loaded again; rays stop at its parent there: " + problem);
            continue;
        }
        out.loaded.push_back(s);
        out.loadedBytes += bytes;
    }
    // Slices only unreachable below one that failed stay selectable (their parent never is again).
    for (char& b : bad_)
        if (b == 2) b = 0;
    return out;
}

}  // namespace vox::runtime
