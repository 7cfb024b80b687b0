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
            const Vec3f toEye = -vec3Cast<float>(camera.rayThrough(x, y).direction);
            // A file without attributes: the face normal on grey.
            out[i] = hasAttributes(buffers, i)
                         ? shadeHeadlight(buffers.shadingNormal[i], toEye, out[i])
                         : shadeHeadlight(buffers.normal[i], toEye, Vec3f{0.8f, 0.8f, 0.8f});
        }
    return out;
}

}  // namespace vox
