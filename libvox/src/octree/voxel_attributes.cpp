#include "voxel_attributes.h"

#include <vox/formats/esvo_attributes.h>
#include <vox/texture.h>

#include <algorithm>
#include <cmath>

namespace vox::detail {

std::uint64_t AttributeSums::pack() const {
    if (!(weight > 0))
        return esvo::packColor(128, 128, 128) |
               (std::uint64_t{esvo::encodeNormal({0, 0, 1})} << 32);
    const auto mean = [&](double v) { return static_cast<float>(v / weight); };
    const std::uint32_t colorWord =
        packLinearColor({mean(color.x), mean(color.y), mean(color.z), mean(alpha)});
    // Where opposite sides of a thin sheet share the voxel their normals cancel; the mean is then
    // noise, and the heaviest fragment's side is the better guess.
    const Vec3d n = length(normal) > 0.05 * weight ? normal : dominantNormal;
    const std::uint32_t normalWord = esvo::encodeNormal(
        {static_cast<float>(n.x), static_cast<float>(n.y), static_cast<float>(n.z)});
    return colorWord | (std::uint64_t{normalWord} << 32);
}

namespace {

/// The variance (radians²) of the interpolated shading normal of triangle @p source (leaf units
/// @p tri) over a fragment of it: polygon @p poly in the voxel's local frame (edge @p edge), fan
/// areas @p fan, area @p area, centroid @p centroid at barycentric coordinates @p at. The
/// normalised interpolant's gradient at the centroid, (I − m̂m̂ᵀ) G / |m| for the interpolant m and
/// its gradient G, against the polygon's covariance C: trace(G C Gᵀ) for that G.
double normalVariance(const Scene& scene, TriangleSource source, const BoxTestTriangle& tri,
                      Vec3d at, std::span<const Vec3d> poly, const double* fan, Vec3d centroid,
                      double area, double edge) {
    const Mesh& mesh = scene.meshes[source.mesh];
    if (mesh.normals.empty()) return 0;
    const std::uint32_t* index = &mesh.indices[3 * std::size_t{source.triangle}];
    const auto normal = [&](int k) {
        const Vec3f n = mesh.normals[index[k]];
        return Vec3d{n.x, n.y, n.z};
    };
    const Vec3d n0 = normal(0), n1 = normal(1), n2 = normal(2);
    if (n0 == n1 && n0 == n2) return 0;  // one normal: flat shading
    const double nn = dot(tri.normal, tri.normal);
    const Vec3d m = n0 * at.x + n1 * at.y + n2 * at.z;
    const double ml = length(m);
    if (!(nn > 0) || !(ml > 1e-3)) return 0;
    // G = d1 ∇b1ᵀ + d2 ∇b2ᵀ with ∇b1 = (e2 × N) / |N|², ∇b2 = (N × e1) / |N|²; projected and scaled
    // as the normalisation does.
    const Vec3d mh = m * (1 / ml);
    const auto project = [&](Vec3d d) { return (d - mh * dot(mh, d)) * (1 / ml); };
    const Vec3d p1 = project(n1 - n0), p2 = project(n2 - n0);
    const Vec3d g1 = cross(tri.v2 - tri.v0, tri.normal) * (1 / nn),
                g2 = cross(tri.normal, tri.v1 - tri.v0) * (1 / nn);
    // The polygon's covariance in leaf units: its fan triangles' second moments about poly[0] (a
    // triangle 0, p, q has ∫xxᵀ = A/12 (ppᵀ + qqᵀ + (p + q)(p + q)ᵀ)), less the centroid's.
    double c[3][3] = {};
    for (std::size_t i = 1; i + 1 < poly.size(); ++i) {
        const Vec3d p = poly[i] - poly[0], q = poly[i + 1] - poly[0], r = p + q;
        const double f = fan[i + 1] / 12.0;
        for (int a = 0; a < 3; ++a)
            for (int b = a; b < 3; ++b) c[a][b] += f * (p[a] * p[b] + q[a] * q[b] + r[a] * r[b]);
    }
    const Vec3d o = centroid - poly[0];
    const double k = edge * edge;
    for (int a = 0; a < 3; ++a)
        for (int b = a; b < 3; ++b) c[b][a] = c[a][b] = (c[a][b] / area - o[a] * o[b]) * k;
    const auto form = [&](Vec3d u, Vec3d v) {
        double sum = 0;
        for (int a = 0; a < 3; ++a)
            for (int b = 0; b < 3; ++b) sum += u[a] * c[a][b] * v[b];
        return sum;
    };
    return std::max(0.0, dot(p1, p1) * form(g1, g1) + 2 * dot(p1, p2) * form(g1, g2) +
                             dot(p2, p2) * form(g2, g2));
}

}  // namespace

AttributeSums::Error AttributeSums::error() const {
    Error out;
    if (!(weight > 0)) return out;
    const double w = 1.0 / weight;
    // Where most of the surface is flat facets larger than the voxel, its normal changes only
    // across their edges and creases: refining narrows the voxels that straddle them, never
    // removes them, and costs as much as on a curved surface. Smooth shading and facets smaller
    // than the voxel (a fine tessellation of a curved surface) count.
    if (facetWeight <= 0.5 * weight) {
        // |n − m|² = 2 (1 − cos θ) ≈ θ² between unit normals n and the unit mean m; its mean over
        // the fragments' own values is 2 (1 − |Σ weight n| / Σ weight), to which the spread
        // inside them adds.
        const double normalVariance =
            2 * (1 - std::min(1.0, length(normal) * w)) + normalSpread * w;
        out.normalDegrees = std::sqrt(std::max(0.0, normalVariance)) * 57.29577951308232;
    }
    double squared = 0;
    for (int ch = 0; ch < 3; ++ch) {
        const double mean = color[ch] * w;
        const double variance = std::max(0.0, colorSquares[ch] * w - mean * mean);
        // The slope of the sRGB curve at the mean turns a linear deviation into an encoded one.
        const double slope = linearToSrgbSlope(mean);
        squared += variance * slope * slope;
    }
    out.color = 255.0 * std::sqrt(squared / 3.0);
    return out;
}

AttributeSampler::AttributeSampler(const Scene& scene,
                                   const std::vector<BoxTestTriangle>& triangles,
                                   std::vector<TriangleSource> sources, bool errorMoments)
    : scene_(scene),
      triangles_(triangles),
      sources_(std::move(sources)),
      textured_(scene.meshes.size(), 0),
      errorMoments_(errorMoments) {
    for (std::size_t m = 0; m < scene.meshes.size(); ++m) {
        const Material& material = scene.materials[scene.meshes[m].material];
        textured_[m] = material.baseColorTexture.valid() || material.normalTexture.valid() ||
                       (material.isEmissive() && material.emissiveTexture.valid());
    }
}

AttributeSums AttributeSampler::filter(std::span<const std::uint32_t> list, Vec3d c, double h,
                                       AttributeScratch& scratch, TriangleView view) const {
    view = resolve(view);
    scratch.fragments.clip(list, view.triangles, c, filterScale(h));
    return filter(scratch.fragments, list, c, h, scratch, view);
}

AttributeSums AttributeSampler::filter(const CubeFragments& fragments,
                                       std::span<const std::uint32_t> list, Vec3d c, double h,
                                       AttributeScratch& scratch, TriangleView view,
                                       bool errorMoments) const {
    view = resolve(view);
    errorMoments = errorMoments && errorMoments_;
    AttributeSums sums;
    const double edge = 2 * h;
    const double toLocal = 1.0 / edge;
    const double tiny = 1e-9 * edge * edge;
    for (std::size_t entry = 0; entry < list.size(); ++entry) {
        const BoxTestTriangle& tri = view.triangles[list[entry]];
        const std::uint32_t t =
            view.global ? view.global[list[entry]] : list[entry];  // the sampler's index
        const std::span<const Vec3d> poly = fragments.polygon(entry);
        const double* fan = fragments.fanArea(entry);
        Vec3d centroid{0, 0, 0};
        const double area = fragments.area(entry);
        for (std::size_t i = 1; i + 1 < poly.size(); ++i)
            centroid += (poly[0] + poly[i] + poly[i + 1]) * (fan[i + 1] / 3.0);
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
        Vec3f colorVariance{0, 0, 0};
        const Vec3d at = barycentric(c + centroid * edge);
        const SurfaceSample sample =
            shadeTriangle(scene_, sources_[t], corners, at, edge, scratch.barycentrics,
                          errorMoments ? &colorVariance : nullptr);
        const Vec4f& color = sample.color;
        const Vec3d& normal = sample.normal;
        if (errorMoments) {
            for (int ch = 0; ch < 3; ++ch)
                sums.colorSquares[ch] +=
                    (double(color[ch]) * color[ch] + colorVariance[ch]) * weight;
            if (area > 0) {
                const double spread =
                    normalVariance(scene_, sources_[t], tri, at, poly, fan, centroid, area, edge);
                sums.normalSpread += spread * weight;
                // A flat-shaded triangle (no spread) at least as large as the voxel's face: a
                // facet.
                if (spread == 0 && 0.5 * length(tri.normal) >= edge * edge)
                    sums.facetWeight += weight;
            }
        }
        sums.weight += weight;
        sums.color += Vec3d{color.x, color.y, color.z} * weight;
        sums.alpha += color.w * weight;
        sums.normal += normal * weight;
        sums.emission += Vec3d{sample.emission.x, sample.emission.y, sample.emission.z} * weight;
        for (int axis = 0; axis < 3; ++axis)
            sums.normalMoments[2 * axis + (normal[axis] < 0 ? 1 : 0)] +=
                std::abs(normal[axis]) * weight;
        if (weight > sums.dominantWeight) {
            sums.dominantWeight = weight;
            sums.dominantNormal = normal;
        }
    }
    return sums;
}

}  // namespace vox::detail
