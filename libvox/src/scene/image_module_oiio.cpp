// libvox_image_oiio.so: the image module (image_module.h) on OpenImageIO. Built as a shared
// module and loaded by vox::core on first use; it links OpenImageIO and nothing of libvox.
#include "image_module.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <exception>

namespace {

using vox::detail::ImageReader;

class OiioReader final : public ImageReader {
public:
    OiioReader(std::unique_ptr<OIIO::ImageInput> input,
               std::unique_ptr<OIIO::Filesystem::IOMemReader> memory)
        : memory_(std::move(memory)), input_(std::move(input)) {}

    int width() const override { return input_->spec().width; }
    int height() const override { return input_->spec().height; }
    int depth() const override { return input_->spec().depth; }
    int channels() const override { return input_->spec().nchannels; }
    bool floatingPoint() const override { return input_->spec().format.is_floating_point(); }
    bool readUint8(int channels, std::uint8_t* out) override {
        return guarded(
            [&] { return input_->read_image(0, 0, 0, channels, OIIO::TypeDesc::UINT8, out); });
    }
    bool readFloatRows(int y0, int y1, int channels, float* out) override {
        return guarded([&] {
            return input_->read_scanlines(0, 0, y0, y1, 0, 0, channels, OIIO::TypeDesc::FLOAT, out);
        });
    }
    std::string error() override {
        return thrown_.empty() ? input_->geterror() : std::exchange(thrown_, {});
    }

private:
    template <typename Read>
    bool guarded(Read read) {
        try {
            return read();
        } catch (const std::exception& e) {
            thrown_ = e.what();
            return false;
        }
    }
    std::unique_ptr<OIIO::Filesystem::IOMemReader>
        memory_;  // declared first: destroyed after the input reading through it
    std::unique_ptr<OIIO::ImageInput> input_;
    std::string thrown_;
};

std::unique_ptr<ImageReader> openFile(const std::filesystem::path& file, std::string& error) {
    try {
        auto input = OIIO::ImageInput::open(file.string());
        if (!input) {
            error = OIIO::geterror();
            return nullptr;
        }
        return std::make_unique<OiioReader>(std::move(input), nullptr);
    } catch (const std::exception& e) {
        error = e.what();
        return nullptr;
    }
}

std::unique_ptr<ImageReader> openMemory(std::span<const std::uint8_t> bytes,
                                        const std::string& hintName, std::string& error) {
    try {
        auto memory = std::make_unique<OIIO::Filesystem::IOMemReader>(bytes.data(), bytes.size());
        auto input = OIIO::ImageInput::open(hintName, nullptr, memory.get());
        if (!input) {
            error = OIIO::geterror();
            return nullptr;
        }
        return std::make_unique<OiioReader>(std::move(input), std::move(memory));
    } catch (const std::exception& e) {
        error = e.what();
        return nullptr;
    }
}

bool encodePng(int width, int height, int channels, std::span<const std::uint8_t> pixels,
               std::vector<std::uint8_t>& png, std::string& error) {
    try {
        std::vector<unsigned char> bytes;
        OIIO::Filesystem::IOVecOutput writer(bytes);
        auto output = OIIO::ImageOutput::create("image.png");
        const OIIO::ImageSpec spec(width, height, channels, OIIO::TypeDesc::UINT8);
        if (!output || !output->set_ioproxy(&writer) || !output->open("image.png", spec) ||
            !output->write_image(OIIO::TypeDesc::UINT8, pixels.data()) || !output->close()) {
            error = output ? output->geterror() : OIIO::geterror();
            return false;
        }
        png.assign(bytes.begin(), bytes.end());
        return true;
    } catch (const std::exception& e) {
        error = e.what();
        return false;
    }
}

const vox::detail::ImageModule kModule{vox::detail::kImageModuleVersion, openFile, openMemory,
                                       encodePng};

}  // namespace

extern "C" __attribute__((visibility("default"))) const vox::detail::ImageModule*
vox_image_module_v1() {
    return &kModule;
}
