# libvox_component(NAME [INTERFACE] [SOURCES...] [PUBLIC libs...] [PRIVATE libs...]): the library
# vox::NAME (target vox_NAME, file libvoxNAME), its headers in the calling folder's include/ (and
# the generated ones in its binary include/), C++20, the project's warnings, installed with an
# export set of its own (libvox-NAME-targets.cmake) so that find_package(libvox COMPONENTS ...)
# loads only the components asked for and the packages they need. INTERFACE makes a library
# without sources that only links others (vox::core).
#
# What the package config needs is recorded per component in the global properties
# LIBVOX_COMPONENTS (all names, in order) and LIBVOX_COMPONENT_<NAME>_COMPONENTS /
# LIBVOX_COMPONENT_<NAME>_PACKAGES: the vox:: libraries it links, and the packages of the other
# imported targets it links (TBB::tbb -> TBB). Links inside $<BUILD_INTERFACE:...> are not needed
# by consumers and are not recorded.
function(libvox_component name)
  cmake_parse_arguments(ARG "INTERFACE" "" "SOURCES;PUBLIC;PRIVATE" ${ARGN})
  if(ARG_INTERFACE)
    add_library(vox_${name} INTERFACE)
    target_link_libraries(vox_${name} INTERFACE ${ARG_PUBLIC})
  else()
    add_library(vox_${name} ${ARG_SOURCES})
    target_include_directories(vox_${name} PUBLIC
      $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
      $<BUILD_INTERFACE:${CMAKE_CURRENT_BINARY_DIR}/include>
      $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
    target_compile_features(vox_${name} PUBLIC cxx_std_20)
    target_link_libraries(vox_${name} PUBLIC ${ARG_PUBLIC}
                          PRIVATE $<BUILD_INTERFACE:libvox_warnings> ${ARG_PRIVATE})
    set_target_properties(vox_${name} PROPERTIES OUTPUT_NAME vox${name})
  endif()
  add_library(vox::${name} ALIAS vox_${name})
  set_target_properties(vox_${name} PROPERTIES EXPORT_NAME ${name})
  install(TARGETS vox_${name} EXPORT libvox-${name}-targets)
  install(EXPORT libvox-${name}-targets NAMESPACE vox:: DESTINATION "${LIBVOX_CMAKE_DIR}")

  set(components "")
  set(packages "")
  foreach(item IN LISTS ARG_PUBLIC ARG_PRIVATE)
    if(item MATCHES "^vox::(.+)$")
      list(APPEND components ${CMAKE_MATCH_1})
    elseif(item MATCHES "^([A-Za-z0-9_]+)::")
      list(APPEND packages ${CMAKE_MATCH_1})
    endif()
  endforeach()
  list(REMOVE_DUPLICATES packages)
  set_property(GLOBAL APPEND PROPERTY LIBVOX_COMPONENTS ${name})
  set_property(GLOBAL PROPERTY LIBVOX_COMPONENT_${name}_COMPONENTS ${components})
  set_property(GLOBAL PROPERTY LIBVOX_COMPONENT_${name}_PACKAGES ${packages})
endfunction()

# libvox_component_table(VAR): the recorded components as CMake code for libvoxConfig.cmake.
function(libvox_component_table var)
  get_property(names GLOBAL PROPERTY LIBVOX_COMPONENTS)
  set(table "set(_libvox_known_components ${names})\n")
  foreach(name IN LISTS names)
    get_property(components GLOBAL PROPERTY LIBVOX_COMPONENT_${name}_COMPONENTS)
    get_property(packages GLOBAL PROPERTY LIBVOX_COMPONENT_${name}_PACKAGES)
    string(APPEND table "set(_libvox_${name}_components ${components})\n"
                        "set(_libvox_${name}_packages ${packages})\n")
  endforeach()
  set(${var} "${table}" PARENT_SCOPE)
endfunction()
