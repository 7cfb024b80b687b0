// libvox's own build of tinygltf. Debian's libtinygltf is built without Draco, and libdraco
// exports a tinygltf of its own: renaming the namespace keeps the two apart. Images are not
// decoded by tinygltf (OpenImageIO does it), external images are not loaded by it (the
// importer reads them so that depfiles list them), and Draco is decoded by the importer after
// validation rather than by tinygltf while parsing.
#pragma once

#define tinygltf vox_tinygltf
#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#define TINYGLTF_NO_EXTERNAL_IMAGE
#include <tiny_gltf.h>
