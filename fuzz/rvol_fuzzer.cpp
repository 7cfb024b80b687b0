// libFuzzer harness: an .rvol file through the reader, the validator (voxinspect validate) and
// what a runtime reads without validating the whole file first: every brick, both attribute
// layers and trilinear samples (issue 10). Every input is tried as it is and, where that changes
// it, again with its checksums repaired. Any vox::Error is a correct rejection; anything else is
// a bug.
#include "fuzz_support.h"

#include <vox/base/error.h>
#include <vox/formats/rvol_io.h>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

namespace {

void readAndValidate(const std::filesystem::path& file) {
    std::unique_ptr<vox::rvol::RvolReader> reader;
    try {
        reader = std::make_unique<vox::rvol::RvolReader>(file);
    } catch (const vox::Error&) {
        return;
    }
    bool valid = false;
    try {
        (void)vox::rvol::validateRvol(*reader);
        valid = true;
    } catch (const vox::Error&) {}
    try {
        for (std::uint32_t level = 0; level < reader->levels().size(); ++level)
            for (std::uint32_t i = 0; i < reader->level(level).brickCount; ++i)
                (void)reader->readBrick(level, i);
    } catch (const vox::Error&) {}
    for (bool dynamic : {false, true}) {
        try {
            (void)reader->readAttributes(dynamic);
        } catch (const vox::Error&) {}
    }
    try {
        const auto& h = reader->header();
        const std::array<double, 3> centre{h.origin[0] + h.size / 2, h.origin[1] + h.size / 2,
                                           h.origin[2] + h.size / 2};
        for (std::uint32_t level = 0; level < reader->levels().size(); ++level)
            (void)reader->sampleDirectional(level, centre, {1, -2, 0.5});
        if (valid) (void)reader->readVolume();
    } catch (const vox::Error&) {}
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    static vox::fuzz::InputFile input(".rvol");
    vox::fuzz::asIsAndWithChecksumsRepaired(input, data, size, vox::fuzz::repairRvolChecksums,
                                            readAndValidate);
    return 0;
}
