# Installs the build into a scratch prefix, then configures, builds and runs the consumer project
# against it twice:
#   all components    import_scene imports Cube.off; render_esvo casts the installed voxelize's
#                     .esvo on the GPU runtime. The configure must look for OpenVDB and Draco (so
#                     that the check below can fail).
#   formats runtime   render_esvo alone; the configure must not look for OpenVDB, OpenImageIO,
#                     OpenMesh, Draco or TBB, and vox::core must not be loaded.
# What the configure looked for is read from its --trace-expand output. Fails on any step.
file(REMOVE_RECURSE "${WORK_DIR}")
function(run what)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(rc)
    message(FATAL_ERROR "${what} failed (${rc}):\n${out}\n${err}")
  endif()
  set(out "${out}" PARENT_SCOPE)
endfunction()

run("installing" ${CMAKE_COMMAND} --install "${BUILD_DIR}" --prefix "${WORK_DIR}/prefix")
set(cube /usr/share/assimp/models/OFF/Cube.off)
set(esvo "${WORK_DIR}/cube.esvo")
run("the installed voxelize" "${WORK_DIR}/prefix/bin/voxelize" ${cube} -o ${esvo} --depth 5)

# configure(NAME COMPONENTS): configures and builds the consumer in WORK_DIR/NAME; sets `trace`
# to the find_package/find_dependency/find_path/find_library calls its configure made.
function(configure name components)
  set(dir "${WORK_DIR}/${name}")
  run("configuring the consumer (${name})" ${CMAKE_COMMAND} -S "${CONSUMER_SOURCE}" -B "${dir}"
      -G Ninja "-DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix" -DCMAKE_BUILD_TYPE=Release
      "-DLIBVOX_COMPONENTS=${components}" --trace-expand "--trace-redirect=${dir}.trace")
  run("building the consumer (${name})" ${CMAKE_COMMAND} --build "${dir}")
  file(STRINGS "${dir}.trace" calls REGEX "\\): +find_(package|dependency|path|library)\\(")
  set(trace "${calls}" PARENT_SCOPE)
endfunction()

function(expect_render dir)
  run("render_esvo (${dir})" "${WORK_DIR}/${dir}/render_esvo" ${esvo})
  if(NOT out MATCHES "^([0-9]+) of 4096 pixels hit" OR CMAKE_MATCH_1 LESS 500)
    message(FATAL_ERROR "render_esvo (${dir}) did not see the cube: ${out}")
  endif()
  message(STATUS "render_esvo (${dir}): ${out}")
endfunction()

set(heavy "(OpenVDB|OpenImageIO|OpenMesh|draco|TBB)")
configure(all "")
foreach(expected "find_(package|dependency)\\(draco" "find_(package|dependency)\\(TBB"
                 "find_(package|path|library)\\((OpenVDB|LIBVOX_OPENVDB)")
  if(NOT trace MATCHES "${expected}")
    message(FATAL_ERROR "find_package(libvox) with every component did not call ${expected}")
  endif()
endforeach()
run("import_scene" "${WORK_DIR}/all/import_scene" ${cube})
if(NOT out MATCHES "12 triangles")
  message(FATAL_ERROR "import_scene did not import Cube.off: ${out}")
endif()
message(STATUS "import_scene: ${out}")
expect_render(all)

configure(runtime "formats runtime")
foreach(call IN LISTS trace)
  if(call MATCHES "find_(package|dependency)\\(${heavy}[ )]" OR call MATCHES "LIBVOX_OPENVDB")
    message(FATAL_ERROR "COMPONENTS formats runtime looked for a package it does not need:\n${call}")
  endif()
endforeach()
if(EXISTS "${WORK_DIR}/runtime/import_scene")
  message(FATAL_ERROR "COMPONENTS formats runtime loaded vox::core")
endif()
if(NOT EXISTS "${WORK_DIR}/runtime/render_esvo")
  message(FATAL_ERROR "COMPONENTS formats runtime did not load vox::runtime")
endif()
expect_render(runtime)
