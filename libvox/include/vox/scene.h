/// @file scene.h
/// @brief The in-memory scene every importer produces: triangle meshes in world units (node
/// transforms applied), materials, textures and punctual lights.
#pragma once

#include <vox/base/light.h>
#include <vox/base/math.h>
#include <vox/texture.h>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace vox {

/// A material's use of a texture: which image, which UV set, how it wraps, and the
/// KHR_texture_transform applied to the UVs before the lookup.
struct TextureBinding {
    std::int32_t texture = -1;  ///< index into Scene::textures; -1: no texture
    std::uint32_t uvSet = 0;    ///< which Mesh::uvs set the lookup uses
    WrapMode wrapS = WrapMode::Repeat;
    WrapMode wrapT = WrapMode::Repeat;
    /// Affine UV transform as two rows: uv' = (r0·(u,v,1), r1·(u,v,1)). Identity by default.
    std::array<float, 6> uvTransform{1, 0, 0, 0, 1, 0};

    [[nodiscard]] bool valid() const noexcept { return texture >= 0; }
    [[nodiscard]] Vec2f transformUv(Vec2f uv) const {
        return {uvTransform[0] * uv.x + uvTransform[1] * uv.y + uvTransform[2],
                uvTransform[3] * uv.x + uvTransform[4] * uv.y + uvTransform[5]};
    }
};

enum class AlphaMode : std::uint8_t { Opaque, Mask, Blend };

/// Surface appearance, after glTF 2.0's metallic-roughness material (other formats map onto it).
/// Colours are linear.
struct Material {
    std::string name;
    Vec4f baseColorFactor{1, 1, 1, 1};
    TextureBinding baseColorTexture;  ///< sRGB
    Vec3f emissiveFactor{0, 0, 0};
    float emissiveStrength = 1.0f;   ///< KHR_materials_emissive_strength
    TextureBinding emissiveTexture;  ///< sRGB
    TextureBinding normalTexture;    ///< linear, tangent space
    float normalScale = 1.0f;
    AlphaMode alphaMode = AlphaMode::Opaque;
    float alphaCutoff = 0.5f;
    bool doubleSided = false;

    /// Emitted radiance scale before the texture: emissiveFactor × emissiveStrength.
    [[nodiscard]] Vec3f emission() const { return emissiveFactor * emissiveStrength; }
    [[nodiscard]] bool isEmissive() const {
        const Vec3f e = emission();
        return e.x > 0 || e.y > 0 || e.z > 0;
    }
};

/// One triangle mesh in world units. Per-vertex arrays are either empty or as long as
/// `positions`; normals are always present and unit length after import.
struct Mesh {
    std::string name;            ///< node / object name it came from
    std::uint32_t material = 0;  ///< index into Scene::materials (always valid)
    bool dynamic = false;        ///< kept out of static bakes (glTF extras or --dynamic)
    std::vector<Vec3f> positions;
    std::vector<Vec3f> normals;
    std::vector<std::vector<Vec2f>> uvs;  ///< uvs[set][vertex]
    std::vector<Vec4f> colors;            ///< linear RGBA vertex colours
    std::vector<std::uint32_t> indices;   ///< three per triangle, counter-clockwise = front

    [[nodiscard]] std::size_t triangleCount() const noexcept { return indices.size() / 3; }
};

/// A punctual light after KHR_lights_punctual, in world space.
/// A light of the scene: the punctual light plus what the import knows about it.
struct Light : PunctualLight {
    std::string name;
    bool dynamic = false;
};

/// Everything an import produced, plus what it read and what it repaired.
struct Scene {
    std::vector<Mesh> meshes;
    std::vector<Material> materials;
    std::vector<Texture> textures;
    std::vector<Light> lights;
    /// Every file the import read (the input, buffers, .mtl files, images), in reading order,
    /// without repeats: what a depfile lists.
    std::vector<std::filesystem::path> sourceFiles;
    /// Triangles dropped because they had no area.
    std::size_t degenerateTrianglesDropped = 0;
    /// Warnings the import issued (importScene also logs them, once the import has succeeded).
    std::vector<std::string> warnings;

    [[nodiscard]] std::size_t triangleCount() const noexcept;
    [[nodiscard]] std::size_t dynamicTriangleCount() const noexcept;
    [[nodiscard]] Bounds3f bounds() const;
};

}  // namespace vox
