# libvox_component(NAME SOURCES... [PUBLIC libs...] [PRIVATE libs...]): the library vox::NAME
# (target vox_NAME, file libvoxNAME), its headers in the calling folder's include/ (and the
# generated ones in its binary include/), C++20, the project's warnings, installed and exported.
function(libvox_component name)
  cmake_parse_arguments(ARG "" "" "SOURCES;PUBLIC;PRIVATE" ${ARGN})
  add_library(vox_${name} ${ARG_SOURCES})
  add_library(vox::${name} ALIAS vox_${name})
  set_target_properties(vox_${name} PROPERTIES EXPORT_NAME ${name} OUTPUT_NAME vox${name})
  target_include_directories(vox_${name} PUBLIC
    $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
    $<BUILD_INTERFACE:${CMAKE_CURRENT_BINARY_DIR}/include>
    $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  target_compile_features(vox_${name} PUBLIC cxx_std_20)
  target_link_libraries(vox_${name} PUBLIC ${ARG_PUBLIC}
                        PRIVATE $<BUILD_INTERFACE:libvox_warnings> ${ARG_PRIVATE})
  install(TARGETS vox_${name} EXPORT libvoxTargets)
endfunction()
