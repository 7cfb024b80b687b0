// libFuzzer harness: the mesh formats OBJ, PLY, STL and OFF, all read by libvox itself
// (issue 10). The extension follows the contents the way a user's
// file would be named: "ply" → .ply, an OFF keyword in the first line → .off, "solid" or a binary
// STL's consistent size → .stl, anything else → .obj.
#include "import_fuzzer.h"

#include <cstring>
#include <string_view>

namespace {

bool isBinaryStlSize(const std::uint8_t* data, std::size_t size) {
    if (size < 84) return false;
    std::uint32_t triangles = 0;
    std::memcpy(&triangles, data + 80, 4);
    return size == 84 + 50ull * triangles;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    static vox::fuzz::InputFile obj(".obj"), ply(".ply"), stl(".stl"), off(".off");
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    const std::string_view firstLine = text.substr(0, std::min(text.find('\n'), std::size_t{16}));
    vox::fuzz::InputFile* file = &obj;
    if (text.starts_with("ply"))
        file = &ply;
    else if (firstLine.find("OFF") != std::string_view::npos)
        file = &off;
    else if (text.starts_with("solid") || isBinaryStlSize(data, size))
        file = &stl;
    vox::fuzz::importAndVoxelize(file->write(data, size));
    return 0;
}
