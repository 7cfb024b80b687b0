// The post-process filter of Laine & Karras (section 6.3, figure 19): an adaptive disc blur whose
// radius comes from the size of the voxel each pixel shows and shrinks to its neighbours'.
#include <vox/raycast.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>

namespace vox {
namespace {

struct KernelSample {
    int dx, dy;
    float distance;
    float weight;  ///< the disc area the sample stands for
};

constexpr int kKernelSamples = 96;
constexpr float kKernelRadius = 24.0f;

/// 96 samples in a disc of radius 24, in increasing distance; their density falls with the square
/// root of the distance (so the count within r grows as r^1.5), spread by the golden angle, in
/// point-symmetric pairs so that the blur has no direction (a colour edge blends the same
/// amount on both sides). Each weighs the area of the ring it stands for.
const std::array<KernelSample, kKernelSamples>& kernel() {
    static const std::array<KernelSample, kKernelSamples> samples = [] {
        constexpr int pairs = kKernelSamples / 2;
        std::array<KernelSample, kKernelSamples> k{};
        const double golden = 3.14159265358979323846 * (3.0 - std::sqrt(5.0));
        double previousArea = 0;
        for (int i = 0; i < pairs; ++i) {
            const double outer = kKernelRadius * std::pow((i + 1.0) / pairs, 2.0 / 3.0);
            const double r = i == 0 ? 0.0 : kKernelRadius * std::pow((i + 0.5) / pairs, 2.0 / 3.0);
            const double area = 3.14159265358979323846 * outer * outer;
            const int dx = static_cast<int>(std::lround(r * std::cos(i * golden)));
            const int dy = static_cast<int>(std::lround(r * std::sin(i * golden)));
            const auto distance = static_cast<float>(std::sqrt(double(dx * dx + dy * dy)));
            const auto weight = static_cast<float>(0.5 * (area - previousArea));
            k[static_cast<std::size_t>(2 * i)] = {dx, dy, distance, weight};
            k[static_cast<std::size_t>(2 * i + 1)] = {
                -dx, -dy, distance, weight};  // the centre twice: same weight in total
            previousArea = area;
        }
        // Rounding to pixels can reorder distances slightly; the walk needs them increasing.
        std::stable_sort(k.begin(), k.end(), [](const KernelSample& a, const KernelSample& b) {
            return a.distance < b.distance;
        });
        return k;
    }();
    return samples;
}

}  // namespace

std::vector<float> filterRadii(const RenderBuffers& buffers, const EsvoRayCaster& caster,
                               const PinholeCamera& camera) {
    std::vector<float> out(buffers.depth.size(), 0.0f);
    const int leafDepth = static_cast<int>(caster.leafDepth());
    for (std::size_t i = 0; i < out.size(); ++i) {
        if (!std::isfinite(buffers.depth[i]) || !(buffers.depth[i] > 0)) continue;
        const double edge = std::ldexp(caster.leafVoxelSize(), leafDepth - int(buffers.level[i]));
        out[i] = static_cast<float>(0.5 * edge / (double(buffers.depth[i]) * camera.pixelAngle()));
    }
    return out;
}

std::vector<Vec3f> postProcessFilter(const std::vector<Vec3f>& image,
                                     const std::vector<float>& radius, int width, int height) {
    std::vector<Vec3f> out(image.size());
    const auto& samples = kernel();
    tbb::parallel_for(
        tbb::blocked_range<int>(0, height, 8), [&](const tbb::blocked_range<int>& rows) {
            for (int y = rows.begin(); y != rows.end(); ++y)
                for (int x = 0; x < width; ++x) {
                    const std::size_t i = std::size_t(y) * std::size_t(width) + std::size_t(x);
                    float r = std::min(radius[i], kKernelRadius);
                    if (r <= 1.0f) {
                        out[i] = image[i];
                        continue;
                    }
                    Vec3f sum{0, 0, 0};
                    float total = 0;
                    for (const KernelSample& s : samples) {
                        const int sx = x + s.dx, sy = y + s.dy;
                        // Outside the image counts as a miss: it ends the walk like a silhouette
                        // does.
                        const float r2 =
                            sx < 0 || sy < 0 || sx >= width || sy >= height
                                ? 0.0f
                                : radius[std::size_t(sy) * std::size_t(width) + std::size_t(sx)];
                        r = std::min(r, r2);
                        if (s.distance > r) break;
                        const float w = s.weight * std::min(r - s.distance, 1.0f);
                        if (w <= 0) continue;
                        sum += image[std::size_t(sy) * std::size_t(width) + std::size_t(sx)] * w;
                        total += w;
                    }
                    out[i] = total > 0 ? sum * (1.0f / total) : image[i];
                }
        });
    return out;
}

}  // namespace vox
