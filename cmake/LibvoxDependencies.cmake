# Finds libvox's Debian 12 dependencies, working around each package's known pitfalls
# (see docs/building.md). Used by the build and, installed, by libvoxConfig.cmake.
include(CMakeFindDependencyMacro)

# find_dependency returns from the including file on failure, which is what the installed
# config wants; at build time plain REQUIRED gives the clearer error.
macro(libvox_find name)
  if(LIBVOX_FINDING_FOR_CONSUMER)
    find_dependency(${name} ${ARGN})
  else()
    find_package(${name} ${ARGN} REQUIRED)
  endif()
endmacro()

find_package(Threads REQUIRED)
libvox_find(TBB CONFIG)
libvox_find(draco CONFIG)
libvox_find(nlohmann_json CONFIG)
# OpenMesh ships no version file: asking for a version makes find_package fail.
libvox_find(OpenMesh)

# OpenImageIO's config demands its command-line tools (openimageio-tools) and adds
# /usr/include/opencv4 to the include path; we do not use OpenCV, so drop that directory.
libvox_find(OpenImageIO CONFIG)
if(TARGET OpenImageIO::OpenImageIO)
  get_target_property(_oiio_inc OpenImageIO::OpenImageIO INTERFACE_INCLUDE_DIRECTORIES)
  if(_oiio_inc)
    list(FILTER _oiio_inc EXCLUDE REGEX "opencv4")
    set_target_properties(OpenImageIO::OpenImageIO PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${_oiio_inc}")
  endif()
  unset(_oiio_inc)
endif()

# Debian's libtinygltf is built without Draco and its shared library clashes with the tinygltf
# copy inside libdraco; libvox compiles the header itself (libvox/src/import/tinygltf.cpp)
# and only needs its location.
if(NOT LIBVOX_FINDING_FOR_CONSUMER)
  find_path(TINYGLTF_INCLUDE_DIR tiny_gltf.h REQUIRED)
  find_package(CLI11 CONFIG REQUIRED)
endif()
