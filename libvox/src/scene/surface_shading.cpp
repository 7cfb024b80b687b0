#include "surface_shading.h"

#include <vox/formats/esvo_attributes.h>
#include <vox/texture.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>

namespace vox::detail {
namespace {

template <typename T>
T interpolate(const std::vector<T>& values, const std::uint32_t* index, const Vec3d& b) {
    return values[index[0]] * static_cast<float>(b.x) + values[index[1]] * static_cast<float>(b.y) +
           values[index[2]] * static_cast<float>(b.z);
}

/// Square root of the ratio of a triangle's UV area to its area: UV units per length unit.
double uvPerLengthUnit(const std::array<Vec2f, 3>& uv, double area) {
    const double du1 = uv[1].x - uv[0].x, dv1 = uv[1].y - uv[0].y, du2 = uv[2].x - uv[0].x,
                 dv2 = uv[2].y - uv[0].y;
    const double uvArea = 0.5 * std::abs(du1 * dv2 - du2 * dv1);
    return area > 0 ? std::sqrt(uvArea / area) : 0.0;
}

}  // namespace

std::uint32_t packLinearColor(Vec4f color) {
    // Voxels of one untextured material mostly share their mean colour to the last bit: the last
    // colour this thread packed, and its word (a pure function of the bits, so exact).
    struct Last {
        bool valid = false;
        std::array<std::uint32_t, 4> bits{};
        std::uint32_t word = 0;
    };
    thread_local Last last;
    const std::array<std::uint32_t, 4> bits{
        std::bit_cast<std::uint32_t>(color.x), std::bit_cast<std::uint32_t>(color.y),
        std::bit_cast<std::uint32_t>(color.z), std::bit_cast<std::uint32_t>(color.w)};
    if (last.valid && bits == last.bits) return last.word;
    const auto alpha =
        static_cast<std::uint32_t>(std::lround(255.0f * std::clamp(color.w, 0.0f, 1.0f)));
    last.valid = true;
    last.bits = bits;
    last.word = esvo::packColor(srgbCode(color.x), srgbCode(color.y), srgbCode(color.z), alpha);
    return last.word;
}

SurfaceSample shadeTriangle(const Scene& scene, TriangleSource source,
                            const std::array<Vec3d, 3>& corners, Vec3d b, double footprint,
                            std::span<const Vec3d> fragment, Vec3f* colorVariance) {
    const Mesh& mesh = scene.meshes[source.mesh];
    const Material& material = scene.materials[mesh.material];
    const std::uint32_t* index = &mesh.indices[3 * std::size_t{source.triangle}];
    const Vec3d e1 = corners[1] - corners[0], e2 = corners[2] - corners[0];
    // The face normal and area, computed where needed only (an unfragmented texture lookup, or a
    // shading normal of zero length).
    const auto faceNormal = [&] { return cross(e1, e2); };
    const auto area = [&] { return 0.5 * length(faceNormal()); };

    const auto usable = [&](const TextureBinding& binding) {
        return binding.valid() &&
               static_cast<std::size_t>(binding.texture) < scene.textures.size() &&
               binding.uvSet < mesh.uvs.size() && !mesh.uvs[binding.uvSet].empty();
    };
    const auto cornerUvs = [&](const TextureBinding& binding) {
        const auto& uvs = mesh.uvs[binding.uvSet];
        return std::array<Vec2f, 3>{binding.transformUv(uvs[index[0]]),
                                    binding.transformUv(uvs[index[1]]),
                                    binding.transformUv(uvs[index[2]])};
    };
    const auto at = [](const std::array<Vec2f, 3>& uv, const Vec3d& w) {
        return uv[0] * static_cast<float>(w.x) + uv[1] * static_cast<float>(w.y) +
               uv[2] * static_cast<float>(w.z);
    };
    const auto lookup = [&](const TextureBinding& binding, const std::array<Vec2f, 3>& uv,
                            Vec4f* meanSquare = nullptr) {
        const Texture& texture = scene.textures[static_cast<std::size_t>(binding.texture)];
        if (!fragment.empty()) {
            std::array<Vec2f, 12> polygon;
            const std::size_t n = std::min(fragment.size(), polygon.size());
            for (std::size_t i = 0; i < n; ++i) polygon[i] = at(uv, fragment[i]);
            return texture.integrate(std::span<const Vec2f>(polygon.data(), n), binding.wrapS,
                                     binding.wrapT, 8, meanSquare);
        }
        const auto width = static_cast<float>(footprint * uvPerLengthUnit(uv, area()));
        return texture.sample(at(uv, b), width, binding.wrapS, binding.wrapT);
    };

    SurfaceSample out;
    out.color = material.baseColorFactor;
    if (!mesh.colors.empty()) out.color = out.color * interpolate(mesh.colors, index, b);
    if (colorVariance) *colorVariance = {0, 0, 0};
    if (usable(material.baseColorTexture)) {
        Vec4f meanSquare;
        const Vec4f texture =
            lookup(material.baseColorTexture, cornerUvs(material.baseColorTexture),
                   colorVariance ? &meanSquare : nullptr);
        if (colorVariance && !fragment.empty()) {
            const auto variance = [&](float square, float mean, float scale) {
                return std::max(0.0f, square - mean * mean) * scale * scale;
            };
            *colorVariance = {variance(meanSquare.x, texture.x, out.color.x),
                              variance(meanSquare.y, texture.y, out.color.y),
                              variance(meanSquare.z, texture.z, out.color.z)};
        }
        out.color = out.color * texture;
    }

    const Vec3f shading = interpolate(mesh.normals, index, b);
    Vec3d normal{shading.x, shading.y, shading.z};
    normal = length(normal) > 0 ? normalize(normal)
                                : (area() > 0 ? normalize(faceNormal()) : Vec3d{0, 0, 1});
    if (usable(material.normalTexture)) {
        const auto uv = cornerUvs(material.normalTexture);
        const double du1 = uv[1].x - uv[0].x, dv1 = uv[1].y - uv[0].y, du2 = uv[2].x - uv[0].x,
                     dv2 = uv[2].y - uv[0].y;
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
                const Vec4f m = lookup(material.normalTexture, uv);
                const double scale = material.normalScale;
                const Vec3d bent = tangent * ((2.0 * m.x - 1.0) * scale) +
                                   bitangent * ((2.0 * m.y - 1.0) * scale) +
                                   normal * (2.0 * m.z - 1.0);
                if (length(bent) > 0) normal = normalize(bent);
            }
        }
    }
    out.normal = normal;
    if (material.isEmissive()) {
        out.emission = material.emission();
        if (usable(material.emissiveTexture)) {
            const Vec4f e = lookup(material.emissiveTexture, cornerUvs(material.emissiveTexture));
            out.emission = {out.emission.x * e.x, out.emission.y * e.y, out.emission.z * e.z};
        }
    }
    return out;
}

}  // namespace vox::detail
