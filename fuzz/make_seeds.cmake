# Writes the generated seed corpora (fuzz/CMakeLists.txt): cmake -DSEEDS=DIR -DMAKE_FUZZ_SEEDS=EXE
# -DVOXELIZE=EXE -DASSIMP_MODELS=DIR -P make_seeds.cmake
file(REMOVE_RECURSE ${SEEDS})
file(MAKE_DIRECTORY ${SEEDS}/esvo ${SEEDS}/rvol ${SEEDS}/gltf ${SEEDS}/mesh ${SEEDS}/drc)
execute_process(COMMAND ${MAKE_FUZZ_SEEDS} ${SEEDS} COMMAND_ERROR_IS_FATAL ANY)

# Small files of every layout: each attribute encoding, with and without contours, several
# slices, far pointers; .rvol with 2-, 3- and 5-texel bricks, with and without the static layer.
set(box ${SEEDS}/gltf/cornell_box.glb)
function(voxelize)
  execute_process(COMMAND ${VOXELIZE} ${box} -q ${ARGN} COMMAND_ERROR_IS_FATAL ANY)
endfunction()
voxelize(-o ${SEEDS}/esvo/depth2.esvo --depth 2)
voxelize(-o ${SEEDS}/esvo/depth3_lookup.esvo --depth 3 --attributes dxt-lookup)
voxelize(-o ${SEEDS}/esvo/depth3_raw_cubes.esvo --depth 3 --attributes raw --no-contours)
voxelize(-o ${SEEDS}/esvo/depth4_far.esvo --depth 4 --attributes raw --debug-near-pointer-limit 32)
voxelize(-o ${SEEDS}/esvo/depth5_slices.esvo --depth 5 --attributes none --slice-bytes 16384)
voxelize(--radiance ${SEEDS}/rvol/depth2.rvol --radiance-depth 2 --bounces 0)
voxelize(--radiance ${SEEDS}/rvol/depth2_no_static.rvol --radiance-depth 2 --brick-texels 3 --no-static-attributes --bounces 1)
voxelize(--radiance ${SEEDS}/rvol/depth3_bricks2.rvol --radiance-depth 3 --brick-texels 2 --bounces 0)

# assimp-testmodels' small meshes (the tests read the same files), where installed.
if(IS_DIRECTORY ${ASSIMP_MODELS})
  file(GLOB models ${ASSIMP_MODELS}/OBJ/*.obj ${ASSIMP_MODELS}/PLY/*.ply ${ASSIMP_MODELS}/STL/*.stl
                   ${ASSIMP_MODELS}/OFF/*.off ${ASSIMP_MODELS}/invalid/*.obj ${ASSIMP_MODELS}/invalid/*.off)
  foreach(model IN LISTS models)
    file(SIZE ${model} bytes)
    if(bytes LESS 16384)
      get_filename_component(parent ${model} DIRECTORY)
      get_filename_component(parent ${parent} NAME)
      get_filename_component(name ${model} NAME)
      file(COPY_FILE ${model} ${SEEDS}/mesh/${parent}_${name})
    endif()
  endforeach()
  foreach(model glTF2/BoxBadNormals-glTF-Binary/BoxBadNormals.glb glTF2/BoxTextured-glTF-Binary/BoxTextured.glb
                glTF2/BoxWithInfinites-glTF-Binary/BoxWithInfinites.glb glTF2/BoxTextured-glTF-Embedded/BoxTextured.gltf
                glTF2/simple_skin/simple_skin.gltf)
    if(EXISTS ${ASSIMP_MODELS}/${model})
      get_filename_component(name ${model} NAME)
      file(COPY_FILE ${ASSIMP_MODELS}/${model} ${SEEDS}/gltf/assimp_${name})
    endif()
  endforeach()
endif()
file(TOUCH ${SEEDS}/stamp)
