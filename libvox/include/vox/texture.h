/// @file texture.h
/// @brief Decoded textures with a mip pyramid and a filtered lookup whose footprint the caller
/// sets, so that a voxel can average the texels under its own size rather than point-sample.
#pragma once

#include <vox/base/color.h>
#include <vox/base/math.h>

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

namespace vox {

/// How stored 8-bit values map to the linear values lookups return.
enum class ColorSpace : std::uint8_t {
    Linear,  ///< value / 255 (normal maps, data)
    SRGB,    ///< sRGB transfer function on RGB, alpha linear (base colour, emission)
};

/// Texture coordinate wrapping outside [0, 1], as glTF samplers define it.
enum class WrapMode : std::uint8_t { Repeat, ClampToEdge, MirroredRepeat };

/// An RGBA8 image with a full mip chain down to 1×1, built by area-weighted box filtering in
/// linear space (so an sRGB checkerboard averages to the right grey, not a dark one).
class Texture {
public:
    /// Largest accepted width or height; larger images are rejected before decoding.
    static constexpr int kMaxDimension = 16384;

    Texture() = default;

    /// Builds a texture from tightly packed 8-bit pixels with 1–4 channels (grey, grey+alpha,
    /// RGB, RGBA). @p name is kept for messages.
    Texture(std::string name, int width, int height, int channels,
            std::span<const std::uint8_t> pixels, ColorSpace colorSpace);

    [[nodiscard]] const std::string& name() const noexcept { return name_; }
    [[nodiscard]] int width() const noexcept { return levels_.empty() ? 0 : levels_[0].width; }
    [[nodiscard]] int height() const noexcept { return levels_.empty() ? 0 : levels_[0].height; }
    [[nodiscard]] int levelCount() const noexcept { return static_cast<int>(levels_.size()); }
    [[nodiscard]] int levelWidth(int level) const { return levels_.at(level).width; }
    [[nodiscard]] int levelHeight(int level) const { return levels_.at(level).height; }
    [[nodiscard]] ColorSpace colorSpace() const noexcept { return colorSpace_; }
    /// Channels of the source image (1–4); a lookup always returns RGBA.
    [[nodiscard]] int sourceChannels() const noexcept { return sourceChannels_; }
    /// Bytes held by all mip levels.
    [[nodiscard]] std::size_t memoryBytes() const noexcept;

    /// The linear RGBA value of one texel of one mip level (no filtering, no wrapping).
    [[nodiscard]] Vec4f texel(int level, int x, int y) const;

    /// Filtered lookup: trilinear over the mip level whose texels are @p footprint wide,
    /// where @p footprint is the filter width in texture-coordinate units (1 = the whole
    /// texture; 0 = the finest level, bilinear). Returns linear RGBA.
    [[nodiscard]] Vec4f sample(Vec2f uv, float footprint, WrapMode wrapS = WrapMode::Repeat,
                               WrapMode wrapT = WrapMode::Repeat) const;

    /// Box filter over a convex polygon in texture coordinates: the mean of the texture over the
    /// polygon's area, integrating each texel of the mip level on which the polygon spans at most
    /// @p maxTexels texels (exactly, by clipping the polygon to every texel it touches). Where
    /// even the 1×1 level is spanned many times over (a heavily repeated texture) the result is
    /// that level's texel, the whole image's mean. A polygon without area, or one so far out that
    /// its texel coordinates pass 2^24 (huge UVs), gets sample(centroid, 0). Returns linear RGBA.
    /// @p meanSquare: null, or receives the mean of the texel values squared (per channel) over
    /// the same texels and weights, so that meanSquare − mean² is the texture's variance over the
    /// polygon at that level (0 for a single texel or a point sample).
    [[nodiscard]] Vec4f integrate(std::span<const Vec2f> polygon, WrapMode wrapS = WrapMode::Repeat,
                                  WrapMode wrapT = WrapMode::Repeat, int maxTexels = 8,
                                  Vec4f* meanSquare = nullptr) const;

private:
    struct Level {
        int width = 0, height = 0;
        std::vector<std::uint8_t> rgba;
    };
    [[nodiscard]] Vec4f bilinear(const Level& level, Vec2f uv, WrapMode wrapS,
                                 WrapMode wrapT) const;
    [[nodiscard]] Vec4f decode(const std::uint8_t* p) const;

    std::string name_;
    ColorSpace colorSpace_ = ColorSpace::Linear;
    int sourceChannels_ = 4;
    std::vector<Level> levels_;
};

/// Decodes an image file with OpenImageIO (PNG, JPEG, TGA, BMP, EXR, ...). HDR and 16-bit
/// sources are converted to 8 bits per channel. @throws IoError if it cannot be read,
/// InvalidDataError if it cannot be decoded or exceeds Texture::kMaxDimension.
[[nodiscard]] Texture loadTexture(const std::filesystem::path& file, ColorSpace colorSpace);

/// Decodes an encoded image held in memory. @p container is the file it came from and @p what
/// names it there (e.g. "image 2 'logo'" inside a GLB), or is empty when @p container is the
/// image file itself; both appear in messages and the texture's name. @p mimeType helps pick
/// the decoder and may be empty. @throws InvalidDataError.
[[nodiscard]] Texture decodeTexture(std::span<const std::uint8_t> encoded,
                                    const std::filesystem::path& container, const std::string& what,
                                    const std::string& mimeType, ColorSpace colorSpace);

}  // namespace vox
