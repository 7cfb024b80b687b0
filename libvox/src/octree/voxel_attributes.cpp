#include "voxel_attributes.h"

#include <vox/formats/esvo_attributes.h>
#include <vox/texture.h>

#include <algorithm>
#include <cmath>

namespace vox::detail {

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
    : scene_(scene), triangles_(triangles), sources_(std::move(sources)), textured_(scene.meshes.size(), 0) {
    for (std::size_t m = 0; m < scene.meshes.size(); ++m) {
        const Material& material = scene.materials[scene.meshes[m].material];
        textured_[m] = material.baseColorTexture.valid() || material.normalTexture.valid() ||
                      (material.isEmissive() && material.emissiveTexture.valid());
    }
}

AttributeSums AttributeSampler::filter(std::span<const std::uint32_t> list, Vec3d c, double h, AttributeScratch& scratch,
                                       TriangleView view) const {
    view = resolve(view);
    scratch.fragments.clip(list, view.triangles, c, filterScale(h));
    return filter(scratch.fragments, list, c, h, scratch, view);
}

AttributeSums AttributeSampler::filter(const CubeFragments& fragments, std::span<const std::uint32_t> list, Vec3d c, double h,
                                       AttributeScratch& scratch, TriangleView view) const {
    view = resolve(view);
    AttributeSums sums;
    const double edge = 2 * h;
    const double toLocal = 1.0 / edge;
    const double tiny = 1e-9 * edge * edge;
    for (std::size_t entry = 0; entry < list.size(); ++entry) {
        const BoxTestTriangle& tri = view.triangles[list[entry]];
        const std::uint32_t t = view.global ? view.global[list[entry]] : list[entry];  // the sampler's index
        const std::span<const Vec3d> poly = fragments.polygon(entry);
        const double* fan = fragments.fanArea(entry);
        Vec3d centroid{0, 0, 0};
        const double area = fragments.area(entry);
        for (std::size_t i = 1; i + 1 < poly.size(); ++i) centroid += (poly[0] + poly[i] + poly[i + 1]) * (fan[i + 1] / 3.0);
        if (area > 0) {
            centroid = centroid / area;
        } else if (!poly.empty()) {
            for (const Vec3d& v : poly) centroid += v;
            centroid = centroid / static_cast<double>(poly.size());
        } else {
            // Overlapping within the box test's margin only: take the triangle's vertex nearest
            // the cube, at the tiny weight.
            double best = 1e300;
            for (const Vec3d& v : {tri.v0, tri.v1, tri.v2})
                if (const double d = length(v - c); d < best) {
                    best = d;
                    centroid = (v - c) * toLocal;
                }
        }
        const double weight = area * edge * edge + tiny;
        // Without textures the attributes are linear over the fragment: its centroid's value is
        // its mean. Textures are box-filtered over the fragment itself; a lookup at its centroid
        // with a voxel-wide footprint would reach half a voxel past it.
        const std::array<Vec3d, 3> corners{tri.v0, tri.v1, tri.v2};
        const BarycentricFrame barycentric(corners);
        scratch.barycentrics.clear();
        if (area > 0 && textured_[sources_[t].mesh]) {
            const BarycentricFrame::Linear linear = barycentric.linear();
            for (const Vec3d& v : poly) scratch.barycentrics.push_back(linear(c + v * edge));
        }
        const SurfaceSample sample = shadeTriangle(scene_, sources_[t], corners, barycentric(c + centroid * edge), edge, scratch.barycentrics);
        const Vec4f& color = sample.color;
        const Vec3d& normal = sample.normal;
        sums.weight += weight;
        sums.color += Vec3d{color.x, color.y, color.z} * weight;
        sums.alpha += color.w * weight;
        sums.normal += normal * weight;
        sums.emission += Vec3d{sample.emission.x, sample.emission.y, sample.emission.z} * weight;
        for (int axis = 0; axis < 3; ++axis)
            sums.normalMoments[2 * axis + (normal[axis] < 0 ? 1 : 0)] += std::abs(normal[axis]) * weight;
        if (weight > sums.dominantWeight) {
            sums.dominantWeight = weight;
            sums.dominantNormal = normal;
        }
    }
    return sums;
}

AttributeSampler::Variation AttributeSampler::variation(std::span<const std::uint32_t> list, Vec3d c, double h, std::uint64_t packed,
                                                      AttributeScratch& scratch, TriangleView view) const {
    view = resolve(view);
    const auto colorWord = static_cast<std::uint32_t>(packed);
    const esvo::Vec3 n = esvo::decodeUnitNormal(static_cast<std::uint32_t>(packed >> 32));
    Variation out;
    const double q = 0.5 * h;
    for (std::uint32_t slot = 0; slot < 8; ++slot) {
        const Vec3d childCentre{c.x + (slot & 1u ? q : -q), c.y + (slot & 2u ? q : -q), c.z + (slot & 4u ? q : -q)};
        scratch.childList.clear();
        for (std::uint32_t t : list)
            if (triangleOverlapsCube(view.triangles[t], childCentre, q)) scratch.childList.push_back(t);
        if (scratch.childList.empty()) continue;
        const AttributeSums sums = filter(scratch.childList, childCentre, q, scratch, view);
        if (!(sums.weight > 1e-6 * q * q)) continue;  // a touching contact, not surface
        const std::uint64_t child = sums.pack();
        for (unsigned ch = 0; ch < 3; ++ch)
            out.color = std::max(out.color, std::abs(double(esvo::colorChannel(static_cast<std::uint32_t>(child), ch)) -
                                                     double(esvo::colorChannel(colorWord, ch))));
        const esvo::Vec3 m = esvo::decodeUnitNormal(static_cast<std::uint32_t>(child >> 32));
        const double cosine = std::clamp(double(n[0]) * m[0] + double(n[1]) * m[1] + double(n[2]) * m[2], -1.0, 1.0);
        out.normalDegrees = std::max(out.normalDegrees, std::acos(cosine) * 57.29577951308232);
    }
    return out;
}

}  // namespace vox::detail
