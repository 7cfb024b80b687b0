// The models of Debian's assimp-testmodels that libvox's formats cover, with what importing each
// must give: shared by the importer test and the tools test.
#pragma once

#include <vox/base/error.h>

#include <cstddef>

namespace vox::test {

struct ModelCase {
    const char* path;            ///< under /usr/share/assimp/models
    std::size_t triangles;       ///< kept triangles (valid files)
    std::size_t degenerate = 0;  ///< degenerate triangles dropped
    vox::ExitCode error = vox::ExitCode::Ok;
    const char* message = "";  ///< text the error must contain
};

inline const ModelCase kAssimpModels[] = {
    // glTF 2.0
    {"glTF2/BoxTextured-glTF/BoxTextured.gltf", 12},
    {"glTF2/BoxTextured-glTF-Binary/BoxTextured.glb", 12},
    {"glTF2/BoxTextured-glTF-Embedded/BoxTextured.gltf", 12},
    {"glTF2/BoxTextured-glTF-pbrSpecularGlossiness/BoxTextured.gltf", 12},
    {"glTF2/BoxTexcoords-glTF/boxTexcoords.gltf", 12},
    {"glTF2/BoxBadNormals-glTF-Binary/BoxBadNormals.glb", 12},
    {"glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb", 110336, 11160},
    {"glTF2/draco/2CylinderEngine.gltf", 110322, 14},
    {"glTF2/ClearCoat-glTF/ClearCoatTest.gltf", 37116},
    {"glTF2/textureTransform/TextureTransformTest.gltf", 24},
    {"glTF2/simple_skin/simple_skin.gltf", 8},
    {"glTF2/cameras/Cameras.gltf", 2},
    {"glTF2/glTF-Sample-Models/AnimatedMorphCube-glTF/AnimatedMorphCube.gltf", 12},
    {"glTF2/issue_3269/texcoord_crash.gltf", 10},
    {"glTF2/glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_04.gltf", 2},
    {"glTF2/glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_05.gltf", 2},
    {"glTF2/glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_06.gltf", 2},
    {"glTF2/glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_11.gltf", 2},
    {"glTF2/glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_12.gltf", 2},
    {"glTF2/glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_13.gltf", 2},
    {"glTF2/glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_14.gltf", 2},
    {"glTF2/glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_15.gltf", 2},
    {"glTF2/glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_00.gltf", 0, 0,
     vox::ExitCode::InvalidData, "no triangles"},
    {"glTF2/glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_08.gltf", 0, 0,
     vox::ExitCode::InvalidData, "no triangles"},
    // glTF 2.0, deliberately broken
    {"glTF2/wrongTypes/badArray.gltf", 0, 0, vox::ExitCode::InvalidData,
     "meshes[0].primitives: expected an array"},
    {"glTF2/wrongTypes/badExtension.gltf", 0, 0, vox::ExitCode::InvalidData,
     "KHR_texture_transform: expected an object"},
    {"glTF2/wrongTypes/badNumber.gltf", 0, 0, vox::ExitCode::InvalidData,
     "materials[0].normalTexture"},
    {"glTF2/wrongTypes/badObject.gltf", 0, 0, vox::ExitCode::InvalidData,
     "pbrMetallicRoughness: expected an object"},
    {"glTF2/wrongTypes/badString.gltf", 0, 0, vox::ExitCode::InvalidData,
     "scenes[0].name: expected a string"},
    {"glTF2/wrongTypes/badUint.gltf", 0, 0, vox::ExitCode::InvalidData, "index -1 out of range"},
    {"glTF2/IndexOutOfRange/IndexOutOfRange.gltf", 0, 0, vox::ExitCode::InvalidData,
     "vertex index 255 out of range"},
    {"glTF2/IndexOutOfRange/AllIndicesOutOfRange.gltf", 0, 0, vox::ExitCode::InvalidData,
     "out of range"},
    {"glTF2/BoxWithInfinites-glTF-Binary/BoxWithInfinites.glb", 0, 0, vox::ExitCode::InvalidData,
     "non-finite position"},
    {"glTF2/MissingBin/BoxTextured.gltf", 0, 0, vox::ExitCode::Io, "BoxTextured0.bin"},
    {"glTF2/RecursiveNodes/RecursiveNodes.gltf", 0, 0, vox::ExitCode::InvalidData, "cycle"},
    {"glTF2/TestNoRootNode/NoScene.gltf", 0, 0, vox::ExitCode::InvalidData,
     "scene: index 0 out of range"},
    {"glTF2/TestNoRootNode/SceneWithoutNodes.gltf", 0, 0, vox::ExitCode::InvalidData,
     "no triangles"},
    {"glTF2/IncorrectVertexArrays/Cube.gltf", 0, 0, vox::ExitCode::InvalidData, "exceed buffer 0"},
    {"glTF2/SchemaFailures/sceneWrongType.gltf", 0, 0, vox::ExitCode::InvalidData,
     "scene: expected an integer"},
    {"glTF2/BoxTextured-glTF-techniqueWebGL/BoxTextured.gltf", 0, 0, vox::ExitCode::InvalidData,
     "KHR_technique_webgl"},
    // OBJ
    {"OBJ/WusonOBJ.obj", 3732},
    {"OBJ/spider.obj", 1312, 56},
    {"OBJ/box.obj", 12},
    {"OBJ/box_longline.obj", 478, 466},
    {"OBJ/box_mat_with_spaces.obj", 12},
    {"OBJ/box_without_lineending.obj", 12},
    {"OBJ/concave_polygon.obj", 64},
    {"OBJ/cube_usemtl.obj", 12},
    {"OBJ/cube_with_vertexcolors.obj", 12},
    {"OBJ/cube_with_vertexcolors_uni.obj", 12},
    {"OBJ/empty_mat.obj", 256},
    {"OBJ/multiple_spaces.obj", 1},
    {"OBJ/regr01.obj", 2706, 4},
    {"OBJ/regr_3429812.obj", 4},
    {"OBJ/space_in_material_name.obj", 64},
    {"OBJ/testmixed.obj", 12},
    {"OBJ/box_UTF16BE.obj", 0, 0, vox::ExitCode::InvalidData, "UTF-16"},
    {"OBJ/number_formats.obj", 0, 0, vox::ExitCode::InvalidData,
     "line 11: malformed number '3.1+e2'"},
    {"OBJ/point_cloud.obj", 0, 0, vox::ExitCode::InvalidData, "no triangles"},
    {"OBJ/testline.obj", 0, 0, vox::ExitCode::InvalidData, "no triangles"},
    {"OBJ/testpoints.obj", 0, 0, vox::ExitCode::InvalidData, "no triangles"},
    {"OBJ/cube_mtllib_after_g.obj", 0, 0, vox::ExitCode::Io, "cube_mtllib_after_g.mat"},
    // PLY
    {"PLY/Wuson.ply", 3732},
    {"PLY/cube.ply", 12},
    {"PLY/cube_binary.ply", 12},
    {"PLY/cube_uv.ply", 12},
    {"PLY/float-color.ply", 1},
    {"PLY/issue623.ply", 0, 0, vox::ExitCode::InvalidData, "no faces"},
    {"PLY/points.ply", 0, 0, vox::ExitCode::InvalidData, "no faces"},
    {"PLY/pond.0.ply", 0, 0, vox::ExitCode::InvalidData, "70051 vertex elements"},
    // STL
    {"STL/Spider_ascii.stl", 1312, 56},
    {"STL/Spider_binary.stl", 1312, 56},
    {"STL/Wuson.stl", 3732},
    {"STL/sphereWithHole.stl", 285},
    {"STL/triangle.stl", 1},
    {"STL/triangle_with_empty_solid.stl", 1},
    {"STL/triangle_with_two_solids.stl", 2},
    {"STL/3DSMaxExport.STL", 2000},
    // OFF
    {"OFF/Cube.off", 12},
    {"OFF/Wuson.off", 3732},
    {"OFF/invalid.off", 0, 0, vox::ExitCode::InvalidData, "3 vertices and 4 faces"},
    // assimp's "invalid" regression files
    {"invalid/OutOfMemory.off", 0, 0, vox::ExitCode::InvalidData, "353535235358 vertices"},
    {"invalid/empty.obj", 0, 0, vox::ExitCode::InvalidData, "is empty"},
    {"invalid/empty.off", 0, 0, vox::ExitCode::InvalidData, "is empty"},
    {"invalid/empty.ply", 0, 0, vox::ExitCode::InvalidData, "is empty"},
    {"invalid/malformed.obj", 0, 0, vox::ExitCode::InvalidData,
     "line 23: vertex index 12 out of range"},
    {"invalid/malformed2.obj", 10},
    {"invalid/empty.3ds", 0, 0, vox::ExitCode::InvalidData, "unsupported file type '.3ds'"},
};

}  // namespace vox::test
