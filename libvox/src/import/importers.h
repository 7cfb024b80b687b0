// One entry point per input format; importScene picks one after checking the file's contents.
#pragma once

#include "import_context.h"

#include <cstdint>
#include <vector>

namespace vox::detail {

void importGltf(ImportContext& context, const std::vector<std::uint8_t>& bytes, bool binary);
void importObj(ImportContext& context, const std::vector<std::uint8_t>& bytes);
void importDrc(ImportContext& context, const std::vector<std::uint8_t>& bytes);
void importStl(ImportContext& context, const std::vector<std::uint8_t>& bytes);
void importOff(ImportContext& context, const std::vector<std::uint8_t>& bytes);
/// ASCII and binary PLY (ply_import.cpp).
void importPly(ImportContext& context, const std::vector<std::uint8_t>& bytes);

}  // namespace vox::detail
