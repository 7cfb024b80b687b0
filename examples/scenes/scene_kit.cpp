#include "scene_kit.h"

#include "shapes.h"

#include <stdexcept>

namespace vox::scenes {

void appendBox(GltfBuilder::Primitive& primitive, std::array<float, 3> min,
               std::array<float, 3> max) {
    const GltfBuilder::Primitive box = boxPrimitive(min, max, primitive.material);
    const auto base = static_cast<std::uint32_t>(primitive.positions.size() / 3);
    primitive.positions.insert(primitive.positions.end(), box.positions.begin(),
                               box.positions.end());
    primitive.normals.insert(primitive.normals.end(), box.normals.begin(), box.normals.end());
    primitive.uvs.insert(primitive.uvs.end(), box.uvs.begin(), box.uvs.end());
    for (std::uint32_t index : box.indices) primitive.indices.push_back(base + index);
}

int LightPalette::operator()(const GltfBuilder::LightDesc& light) {
    if (auto it = indices_.find(light.name); it != indices_.end()) return it->second;
    if (light.name.empty())
        throw std::logic_error("LightPalette: a shared light definition needs a name");
    const int index = gltf_.addLight(light);
    indices_.emplace(light.name, index);
    return index;
}

}  // namespace vox::scenes
