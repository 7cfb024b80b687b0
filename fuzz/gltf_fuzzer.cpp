// libFuzzer harness: glTF 2.0 import (JSON .gltf, or binary .glb when the input starts with the
// GLB magic), Draco-compressed primitives included (issue 10).
#include "import_fuzzer.h"

#include <cstring>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    static vox::fuzz::InputFile gltf(".gltf"), glb(".glb");
    const bool binary = size >= 4 && std::memcmp(data, "glTF", 4) == 0;
    vox::fuzz::importAndVoxelize((binary ? glb : gltf).write(data, size));
    return 0;
}
