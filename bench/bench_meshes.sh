# shellcheck shell=bash
# Sourced by the bench scripts: the bench meshes, the generated 1,048,576-triangle bumpy sphere
# and the assimp-testmodels meshes with the most triangles, or MESHES (space-separated NAME:PATH)
# in their place.
# Usage: bench_meshes BUILD_DIR OUT_DIR   (sets the array "meshes" to NAME:PATH entries; the
# bumpy sphere is written to OUT_DIR)
bench_meshes() {
    local models=/usr/share/assimp/models
    if [ -n "${MESHES:-}" ]; then
        read -r -a meshes <<< "$MESHES"
        return
    fi
    "$1/examples/make_example_scene" bumpy-sphere -o "$2" >/dev/null
    # shellcheck disable=SC2034  # the caller's array
    meshes=("bumpy-sphere:$2/bumpy_sphere.glb"
            "2CylinderEngine:$models/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb"
            "ClearCoatTest:$models/glTF2/ClearCoat-glTF/ClearCoatTest.gltf"
            "Wuson:$models/PLY/Wuson.ply"
            "spider:$models/OBJ/spider.obj")
}
