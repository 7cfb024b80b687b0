#include "voxel_attributes.h"

#include <vox/formats/esvo_attributes.h>
#include <vox/texture.h>

#include <algorithm>
#include <cmath>

namespace vox::detail {

AttributeSums& AttributeSums::operator+=(const AttributeSums& other) {
    weight += other.weight;
    color += other.color;
    alpha += other.alpha;
    normal += other.normal;
    if (other.dominantWeight > dominantWeight) {
        dominantWeight = other.dominantWeight;
        dominantNormal = other.dominantNormal;
    }
    return *this;
}

std::uint64_t AttributeSums::pack() const {
    if (!(weight > 0)) return esvo::packColor(128, 128, 128) | (std::uint64_t{esvo::encodeNormal({0, 0, 1})} << 32);
    const auto mean = [&](double v) { return static_cast<float>(v / weight); };
    const std::uint32_t colorWord = packLinearColor({mean(color.x), mean(color.y), mean(color.z), mean(alpha)});
    // Where opposite sides of a thin sheet share the voxel their normals cancel; the mean is then
    // noise, and the heaviest fragment's side is the better guess.
    const Vec3d n = length(normal) > 0.05 * weight ? normal : dominantNormal;
    const std::uint32_t normalWord = esvo::encodeNormal({static_cast<float>(n.x), static_cast<float>(n.y), static_cast<float>(n.z)});
    return colorWord | (std::uint64_t{normalWord} << 32);
}

AttributeSampler::AttributeSampler(const Scene& scene, const std::vector<BoxTestTriangle>& triangles, std::vector<TriangleSource> sources)
    : scene_(scene), triangles_(triangles), sources_(std::move(sources)) {}

void AttributeSampler::shade(std::uint32_t t, Vec3d p, double footprint, Vec4f& color, Vec3d& normal) const {
    const BoxTestTriangle& tri = triangles_[t];
    const std::array<Vec3d, 3> corners{tri.v0, tri.v1, tri.v2};
    const SurfaceSample sample = shadeTriangle(scene_, sources_[t], corners, barycentric(corners, p), footprint);
    color = sample.color;
    normal = sample.normal;
}

AttributeSums AttributeSampler::filter(std::span<const std::uint32_t> list, Vec3d c, double h, AttributeScratch& scratch) const {
    AttributeSums sums;
    const double edge = 2 * h;
    const double toLocal = 1.0 / edge;
    const double tiny = 1e-9 * edge * edge;
    for (std::uint32_t t : list) {
        const BoxTestTriangle& tri = triangles_[t];
        scratch.polygon.clear();
        clipToUnitCube({(tri.v0 - c) * toLocal, (tri.v1 - c) * toLocal, (tri.v2 - c) * toLocal}, scratch.polygon, scratch.clipA, scratch.clipB);
        Vec3d centroid{0, 0, 0};
        double area = 0;
        const auto& poly = scratch.polygon;
        if (poly.empty()) {
            // Overlapping within the box test's margin only: take the triangle's vertex nearest
            // the cube, at the tiny weight.
            const Vec3d vs[3] = {tri.v0, tri.v1, tri.v2};
            double best = 1e300;
            for (const Vec3d& v : vs)
                if (const double d = length(v - c); d < best) {
                    best = d;
                    centroid = (v - c) * toLocal;
                }
        } else {
            Vec3d vertexMean{0, 0, 0};
            for (const Vec3d& v : poly) vertexMean += v;
            vertexMean = vertexMean / static_cast<double>(poly.size());
            for (std::size_t i = 1; i + 1 < poly.size(); ++i) {
                const double a = 0.5 * length(cross(poly[i] - poly[0], poly[i + 1] - poly[0]));
                centroid += (poly[0] + poly[i] + poly[i + 1]) * (a / 3.0);
                area += a;
            }
            centroid = area > 0 ? centroid / area : vertexMean;
        }
        const double weight = area * edge * edge + tiny;
        Vec4f color;
        Vec3d normal;
        shade(t, c + centroid * edge, edge, color, normal);
        sums.weight += weight;
        sums.color += Vec3d{color.x, color.y, color.z} * weight;
        sums.alpha += color.w * weight;
        sums.normal += normal * weight;
        if (weight > sums.dominantWeight) {
            sums.dominantWeight = weight;
            sums.dominantNormal = normal;
        }
    }
    return sums;
}

AttributeSampler::Variation AttributeSampler::variation(std::span<const std::uint32_t> list, Vec3d c, double h, std::uint64_t packed,
                                                      AttributeScratch& scratch) const {
    const auto colorWord = static_cast<std::uint32_t>(packed);
    const esvo::Vec3 n = esvo::decodeUnitNormal(static_cast<std::uint32_t>(packed >> 32));
    const Vec3d voxelNormal{n[0], n[1], n[2]};
    Variation out;
    const double edge = 2 * h;
    const double toLocal = 1.0 / edge;
    const auto measure = [&](std::uint32_t t, Vec3d local) {
        Vec4f color;
        Vec3d normal;
        shade(t, c + local * edge, 1.0, color, normal);
        const float rgb[3] = {color.x, color.y, color.z};
        for (unsigned ch = 0; ch < 3; ++ch) {
            const double v = 255.0 * linearToSrgb(std::clamp(rgb[ch], 0.0f, 1.0f));
            out.color = std::max(out.color, std::abs(v - double(esvo::colorChannel(colorWord, ch))));
        }
        const double cosine = std::clamp(dot(normal, voxelNormal), -1.0, 1.0);
        out.normalDegrees = std::max(out.normalDegrees, std::acos(cosine) * 57.29577951308232);
    };
    for (std::uint32_t t : list) {
        const BoxTestTriangle& tri = triangles_[t];
        scratch.polygon.clear();
        clipToUnitCube({(tri.v0 - c) * toLocal, (tri.v1 - c) * toLocal, (tri.v2 - c) * toLocal}, scratch.polygon, scratch.clipA, scratch.clipB);
        const auto& poly = scratch.polygon;
        if (poly.size() < 3) continue;
        Vec3d mean{0, 0, 0};
        for (const Vec3d& v : poly) mean += v;
        mean = mean / static_cast<double>(poly.size());
        measure(t, mean);
        // Vertices pulled slightly inwards, so a shared edge's texel is not counted for both sides.
        for (const Vec3d& v : poly) measure(t, v + (mean - v) * 0.01);
    }
    return out;
}

}  // namespace vox::detail
