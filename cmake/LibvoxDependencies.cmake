# Finds libvox's Debian 12 dependencies, working around each package's known pitfalls
# (see docs/building.md). Used by the build, which needs them all, and, installed, by
# libvoxConfig.cmake, which sets LIBVOX_PACKAGES to the packages of the components asked for.
include(CMakeFindDependencyMacro)

# find_dependency returns from the including file on failure (libvoxConfig.cmake then reports
# libvox as not found); at build time plain REQUIRED gives the clearer error.
macro(libvox_find name)
  if(LIBVOX_FINDING_FOR_CONSUMER)
    find_dependency(${name} ${ARGN})
  else()
    find_package(${name} ${ARGN} REQUIRED)
  endif()
endmacro()

if(NOT LIBVOX_FINDING_FOR_CONSUMER)
  # The build: every package, those only the tools, tests and the image module need included.
  set(LIBVOX_PACKAGES Threads TBB draco nlohmann_json OpenImageIO OpenVDB OpenGL)
endif()

if(Threads IN_LIST LIBVOX_PACKAGES)
  libvox_find(Threads)
endif()
if(TBB IN_LIST LIBVOX_PACKAGES)
  libvox_find(TBB CONFIG)
endif()
if(draco IN_LIST LIBVOX_PACKAGES)
  libvox_find(draco CONFIG)
endif()
if(nlohmann_json IN_LIST LIBVOX_PACKAGES)
  libvox_find(nlohmann_json CONFIG)
endif()
# OpenGL through glvnd (libOpenGL, libEGL): vox::runtime's only dependency besides vox::formats.
if(OpenGL IN_LIST LIBVOX_PACKAGES)
  libvox_find(OpenGL COMPONENTS OpenGL EGL)
endif()

# OpenImageIO's config demands its command-line tools (openimageio-tools) and adds
# /usr/include/opencv4 to the include path; we do not use OpenCV, so drop that directory. Only the
# image module (libvox_image_oiio, loaded at run time) links it: consumers never need it.
if(OpenImageIO IN_LIST LIBVOX_PACKAGES)
  libvox_find(OpenImageIO CONFIG)
endif()
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

if(OpenVDB IN_LIST LIBVOX_PACKAGES)
  # OpenVDB (vox::core's .vdb export; linked privately, its headers stay out of libvox's). Debian's
  # libopenvdb-dev ships no config file, only a find module in /usr/lib/<multiarch>/cmake/OpenVDB,
  # outside CMake's module path, and that module needs libboost-iostreams-dev, which the package
  # does not declare. The module also sets BUILD_SHARED_LIBS ON in its caller's scope (which would
  # make vox::formats and vox::core shared libraries) and its directory holds other find modules
  # (FindTBB, FindOpenEXR, ...): so it runs inside a block() that keeps its variables and module path
  # to itself; only the imported targets come out. Without the module: find the library by hand.
  block()
    if(NOT TARGET OpenVDB::openvdb)
      find_path(LIBVOX_OPENVDB_MODULE_DIR FindOpenVDB.cmake NO_DEFAULT_PATH
        PATHS /usr/lib/${CMAKE_LIBRARY_ARCHITECTURE}/cmake/OpenVDB /usr/local/lib/cmake/OpenVDB /usr/lib/cmake/OpenVDB
        DOC "Directory of OpenVDB's FindOpenVDB.cmake")
      if(LIBVOX_OPENVDB_MODULE_DIR)
        list(PREPEND CMAKE_MODULE_PATH "${LIBVOX_OPENVDB_MODULE_DIR}")
      endif()
      find_package(OpenVDB QUIET)
    endif()
    if(NOT TARGET OpenVDB::openvdb)
      find_path(LIBVOX_OPENVDB_INCLUDE_DIR openvdb/openvdb.h)
      find_library(LIBVOX_OPENVDB_LIBRARY openvdb)
      find_package(Imath CONFIG QUIET)  # OpenVDB >= 9 headers include <Imath/half.h>
      if(LIBVOX_OPENVDB_INCLUDE_DIR AND LIBVOX_OPENVDB_LIBRARY)
        add_library(OpenVDB::openvdb UNKNOWN IMPORTED)
        set_target_properties(OpenVDB::openvdb PROPERTIES
          IMPORTED_LOCATION "${LIBVOX_OPENVDB_LIBRARY}"
          INTERFACE_INCLUDE_DIRECTORIES "${LIBVOX_OPENVDB_INCLUDE_DIR}"
          INTERFACE_LINK_LIBRARIES "TBB::tbb;Threads::Threads;$<TARGET_NAME_IF_EXISTS:Imath::Imath>")
      endif()
    endif()
  endblock()
  if(NOT TARGET OpenVDB::openvdb)
    if(LIBVOX_FINDING_FOR_CONSUMER)
      set(${CMAKE_FIND_PACKAGE_NAME}_NOT_FOUND_MESSAGE "OpenVDB not found (Debian: libopenvdb-dev libboost-iostreams-dev)")
      set(${CMAKE_FIND_PACKAGE_NAME}_FOUND FALSE)
      return()
    endif()
    message(FATAL_ERROR "OpenVDB not found (Debian: libopenvdb-dev libboost-iostreams-dev)")
  endif()
endif()
