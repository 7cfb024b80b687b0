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
    const auto channel = [&](double linear) {
        return static_cast<std::uint32_t>(std::lround(255.0 * linearToSrgb(static_cast<float>(std::clamp(linear / weight, 0.0, 1.0)))));
    };
    const auto a = static_cast<std::uint32_t>(std::lround(255.0 * std::clamp(alpha / weight, 0.0, 1.0)));
    const std::uint32_t colorWord = esvo::packColor(channel(color.x), channel(color.y), channel(color.z), a);
    // Where opposite sides of a thin sheet share the voxel their normals cancel; the mean is then
    // noise, and the heaviest fragment's side is the better guess.
    const Vec3d n = length(normal) > 0.05 * weight ? normal : dominantNormal;
    const std::uint32_t normalWord = esvo::encodeNormal({static_cast<float>(n.x), static_cast<float>(n.y), static_cast<float>(n.z)});
    return colorWord | (std::uint64_t{normalWord} << 32);
}

AttributeSampler::AttributeSampler(const Scene& scene, const std::vector<BoxTestTriangle>& triangles, std::vector<TriangleSource> sources)
    : scene_(scene), triangles_(triangles), sources_(std::move(sources)) {}

namespace {

template <typename T>
T interpolate(const std::vector<T>& values, const std::uint32_t* index, const Vec3d& b) {
    return values[index[0]] * static_cast<float>(b.x) + values[index[1]] * static_cast<float>(b.y) + values[index[2]] * static_cast<float>(b.z);
}

/// Ratio of a triangle's UV area to its leaf-unit area, square-rooted: UV units per leaf unit.
double uvPerLeafUnit(const std::array<Vec2f, 3>& uv, double leafArea) {
    const double du1 = uv[1].x - uv[0].x, dv1 = uv[1].y - uv[0].y, du2 = uv[2].x - uv[0].x, dv2 = uv[2].y - uv[0].y;
    const double uvArea = 0.5 * std::abs(du1 * dv2 - du2 * dv1);
    return leafArea > 0 ? std::sqrt(uvArea / leafArea) : 0.0;
}

}  // namespace

void AttributeSampler::shade(std::uint32_t t, Vec3d p, double footprint, Vec4f& color, Vec3d& normal) const {
    const TriangleSource& src = sources_[t];
    const Mesh& mesh = scene_.meshes[src.mesh];
    const Material& material = scene_.materials[mesh.material];
    const std::uint32_t* index = &mesh.indices[3 * std::size_t{src.triangle}];
    const BoxTestTriangle& tri = triangles_[t];

    // Barycentric coordinates of p (inside the triangle up to rounding).
    const Vec3d e1 = tri.v1 - tri.v0, e2 = tri.v2 - tri.v0, vp = p - tri.v0;
    const double d00 = dot(e1, e1), d01 = dot(e1, e2), d11 = dot(e2, e2), d20 = dot(vp, e1), d21 = dot(vp, e2);
    const double denom = d00 * d11 - d01 * d01;
    Vec3d b{1.0 / 3, 1.0 / 3, 1.0 / 3};
    if (denom > 0) {
        const double b1 = std::clamp((d11 * d20 - d01 * d21) / denom, 0.0, 1.0);
        const double b2 = std::clamp((d00 * d21 - d01 * d20) / denom, 0.0, 1.0 - b1);
        b = {1 - b1 - b2, b1, b2};
    }
    const double leafArea = 0.5 * length(tri.normal);

    const auto corners = [&](const TextureBinding& binding) {
        const auto& uvs = mesh.uvs[binding.uvSet];
        return std::array<Vec2f, 3>{binding.transformUv(uvs[index[0]]), binding.transformUv(uvs[index[1]]), binding.transformUv(uvs[index[2]])};
    };
    const auto usable = [&](const TextureBinding& binding) {
        return binding.valid() && static_cast<std::size_t>(binding.texture) < scene_.textures.size() && binding.uvSet < mesh.uvs.size() &&
               !mesh.uvs[binding.uvSet].empty();
    };
    const auto at = [&](const std::array<Vec2f, 3>& uv) {
        return uv[0] * static_cast<float>(b.x) + uv[1] * static_cast<float>(b.y) + uv[2] * static_cast<float>(b.z);
    };

    color = material.baseColorFactor;
    if (!mesh.colors.empty()) color = color * interpolate(mesh.colors, index, b);
    if (usable(material.baseColorTexture)) {
        const TextureBinding& binding = material.baseColorTexture;
        const auto uv = corners(binding);
        const float width = static_cast<float>(footprint * uvPerLeafUnit(uv, leafArea));
        color = color * scene_.textures[static_cast<std::size_t>(binding.texture)].sample(at(uv), width, binding.wrapS, binding.wrapT);
    }

    const Vec3f shading = interpolate(mesh.normals, index, b);
    normal = Vec3d{shading.x, shading.y, shading.z};
    normal = length(normal) > 0 ? normalize(normal) : normalize(tri.normal);
    if (usable(material.normalTexture)) {
        const TextureBinding& binding = material.normalTexture;
        const auto uv = corners(binding);
        const double du1 = uv[1].x - uv[0].x, dv1 = uv[1].y - uv[0].y, du2 = uv[2].x - uv[0].x, dv2 = uv[2].y - uv[0].y;
        const double det = du1 * dv2 - du2 * dv1;
        if (std::abs(det) > 1e-20) {
            // dp/du and dp/dv of the triangle; the map's +Y is up in the image, i.e. towards −v
            // (glTF's UV origin is the image's top-left corner).
            Vec3d tangent = (e1 * dv2 - e2 * dv1) / det;
            const Vec3d dpdv = (e2 * du1 - e1 * du2) / det;
            tangent = tangent - normal * dot(normal, tangent);
            if (length(tangent) > 0) {
                tangent = normalize(tangent);
                Vec3d bitangent = cross(normal, tangent);
                if (dot(bitangent, dpdv) > 0) bitangent = -bitangent;
                const float width = static_cast<float>(footprint * uvPerLeafUnit(uv, leafArea));
                const Vec4f m = scene_.textures[static_cast<std::size_t>(binding.texture)].sample(at(uv), width, binding.wrapS, binding.wrapT);
                const double scale = material.normalScale;
                const Vec3d bent = tangent * ((2.0 * m.x - 1.0) * scale) + bitangent * ((2.0 * m.y - 1.0) * scale) + normal * (2.0 * m.z - 1.0);
                if (length(bent) > 0) normal = normalize(bent);
            }
        }
    }
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
