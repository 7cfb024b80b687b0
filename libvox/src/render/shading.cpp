// Shading of rendered attribute buffers: the decoded albedo, and Phong under a headlight.
#include <vox/formats/esvo_attributes.h>
#include <vox/raycast.h>
#include <vox/texture.h>

#include <algorithm>
#include <cmath>

namespace vox {

std::vector<Vec3f> albedoImage(const RenderBuffers& buffers) {
    std::vector<Vec3f> out(buffers.color.size(), Vec3f{0, 0, 0});
    for (std::size_t i = 0; i < out.size(); ++i) {
        if (!hasAttributes(buffers, i)) continue;
        const std::uint32_t c = buffers.color[i];
        out[i] = {srgbToLinear(float(esvo::colorChannel(c, 0)) / 255.0f),
                  srgbToLinear(float(esvo::colorChannel(c, 1)) / 255.0f),
                  srgbToLinear(float(esvo::colorChannel(c, 2)) / 255.0f)};
    }
    return out;
}

std::vector<Vec3f> shadeHeadlight(const RenderBuffers& buffers, const PinholeCamera& camera) {
    std::vector<Vec3f> out = albedoImage(buffers);
    for (int y = 0; y < buffers.height; ++y)
        for (int x = 0; x < buffers.width; ++x) {
            const std::size_t i = std::size_t(y) * std::size_t(buffers.width) + std::size_t(x);
            if (!std::isfinite(buffers.depth[i])) continue;
            const Vec3d d = camera.rayThrough(x, y).direction;
            const Vec3f toEye{static_cast<float>(-d.x), static_cast<float>(-d.y),
                              static_cast<float>(-d.z)};
            // A file without attributes: the face normal.
            Vec3f n = hasAttributes(buffers, i) ? buffers.shadingNormal[i] : buffers.normal[i];
            // Facing the viewer: a sheet seen from behind shades like its front.
            if (dot(n, toEye) < 0) n = -n;
            const float diffuse = std::max(0.0f, dot(n, toEye));
            // With the light at the eye, the mirror direction of the light is 2(n·l)n − l.
            const Vec3f reflected = n * (2 * dot(n, toEye)) - toEye;
            const float specular = 0.25f * std::pow(std::max(0.0f, dot(reflected, toEye)), 32.0f);
            const Vec3f albedo = hasAttributes(buffers, i) ? out[i] : Vec3f{0.8f, 0.8f, 0.8f};
            out[i] = albedo * (0.1f + 0.9f * diffuse) + Vec3f{specular, specular, specular};
        }
    return out;
}

}  // namespace vox
