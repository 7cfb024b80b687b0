// libFuzzer harness: Draco .drc import (issue 10): libvox's checks around Draco's decoder and
// its conversion of the decoded attributes.
#include "import_fuzzer.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    static vox::fuzz::InputFile drc(".drc");
    vox::fuzz::importAndVoxelize(drc.write(data, size));
    return 0;
}
