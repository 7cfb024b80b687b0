// libFuzzer harness: an .esvo file through the reader, the validator (voxinspect validate) and the
// CPU pool that streams slices the way the runtime does (issue 10). Every input is tried as it
// is and, where that changes it, again with its checksums repaired, so that mutations reach the
// structural checks behind the checksums. Any vox::Error is a correct rejection; anything else
// (a crash, a sanitizer report, another exception, a leak, a hang) is a bug.
#include "fuzz_support.h"

#include <vox/base/error.h>
#include <vox/formats/esvo_reader.h>

#include <cstddef>
#include <cstdint>
#include <vector>

namespace {

void readAndValidate(const std::filesystem::path& file) {
    std::unique_ptr<vox::esvo::EsvoReader> reader;
    try {
        reader = std::make_unique<vox::esvo::EsvoReader>(file);
    } catch (const vox::Error&) {
        return;
    }
    try {
        (void)vox::esvo::validateFile(*reader);
    } catch (const vox::Error&) {}
    // The runtime never runs validateFile: it loads slices as it needs them, each validated on
    // its own (EsvoPool::load), so a file that fails validation must still only fail there.
    try {
        vox::esvo::EsvoPool pool(*reader);
        pool.loadAll();
        std::uint64_t voxels = 0;
        pool.forEachVoxel(
            [&](const vox::esvo::VoxelPosition&, const vox::esvo::AttributeValue*) { ++voxels; });
        // Streaming evicts subtrees and loads them again into the freed pages.
        if (reader->sliceCount() > 1) {
            pool.unload(1);
            pool.loadAll();
        }
    } catch (const vox::Error&) {}
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    static vox::fuzz::InputFile input(".esvo");
    vox::fuzz::asIsAndWithChecksumsRepaired(input, data, size, vox::fuzz::repairEsvoChecksums,
                                            readAndValidate);
    return 0;
}
