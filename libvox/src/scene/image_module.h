// The interface of libvox's image module (libvox_image_oiio.so): OpenImageIO's decoders and PNG
// encoder behind a few plain calls, in a shared module that vox::core loads on first use.
// OpenImageIO and the ~260 libraries it needs (GDAL, Poppler, DCMTK, … through its plugins'
// dependencies) add about 0.27 s of symbol binding to the start of every process that links
// them; loaded this way, only a process that decodes or writes an image pays it.
//
// Nothing crosses the boundary but standard-library values built by the same compiler (the
// module is built with libvox, never separately), and no exception: failures come back as
// messages, which the callers in vox::core turn into their typed errors.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace vox::detail {

/// An opened image (one subimage, level 0).
class ImageReader {
public:
    virtual ~ImageReader() = default;
    [[nodiscard]] virtual int width() const = 0;
    [[nodiscard]] virtual int height() const = 0;
    [[nodiscard]] virtual int depth() const = 0;
    [[nodiscard]] virtual int channels() const = 0;
    /// True where the file stores floating-point values (linear, by convention).
    [[nodiscard]] virtual bool floatingPoint() const = 0;
    /// The first @p channels channels of every pixel as 8-bit values, rows from the top.
    virtual bool readUint8(int channels, std::uint8_t* out) = 0;
    /// Rows [@p y0, @p y1) of the first @p channels channels as floats.
    virtual bool readFloatRows(int y0, int y1, int channels, float* out) = 0;
    /// What went wrong in the last call that returned false.
    [[nodiscard]] virtual std::string error() = 0;
};

/// The module's calls. kImageModuleVersion changes with any change to them or to ImageReader.
struct ImageModule {
    int version = 0;
    /// Opens an image file (null, with @p error set, where it cannot).
    std::unique_ptr<ImageReader> (*openFile)(const std::filesystem::path& file,
                                             std::string& error) = nullptr;
    /// Opens encoded bytes; @p hintName's extension picks the decoder. The bytes must outlive the
    /// reader.
    std::unique_ptr<ImageReader> (*openMemory)(std::span<const std::uint8_t> bytes,
                                               const std::string& hintName,
                                               std::string& error) = nullptr;
    /// PNG bytes of 8-bit pixels (row 0 at the top); false, with @p error set, where it fails.
    bool (*encodePng)(int width, int height, int channels, std::span<const std::uint8_t> pixels,
                      std::vector<std::uint8_t>& png, std::string& error) = nullptr;
};

inline constexpr int kImageModuleVersion = 1;

/// The module's entry point, `extern "C"` so that it is found by this name.
inline constexpr const char* kImageModuleEntry = "vox_image_module_v1";
using ImageModuleEntry = const ImageModule* (*)();

/// The loaded module (loaded on the first call, by any thread).
/// @throws std::runtime_error naming the files tried, where no module loads.
/// Found at $VOX_IMAGE_MODULE where that is set, else in ../LIBDIR of the executable's directory
/// (an installed tool), else at its place in this build tree, else in the configured library
/// directory.
[[nodiscard]] const ImageModule& imageModule();

}  // namespace vox::detail
