#!/usr/bin/env bash
# README command 1: installs what is needed, builds, and runs the main job on the example scene.
set -euo pipefail
cd "$(dirname "$0")/.."

./scripts/install-deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build

out=build/example
rm -rf "$out"
mkdir -p "$out"
scene=$(build/examples/make_example_scene cornell-box -o "$out/scene")
build/tools/voxelize "$scene" -o "$out/cornell_box.esvo" --depth 10 --radiance "$out/cornell_box.rvol" -v \
    --stats "$out/cornell_box.stats.json" --depfile "$out/cornell_box.d"
build/tools/voxinspect validate "$out/cornell_box.esvo" -v
build/tools/voxinspect validate "$out/cornell_box.rvol" -v
build/tools/voxinspect render "$out/cornell_box.rvol" --scene "$scene" -o "$out/cornell_box.gi.png" \
    --eye 0,1,3.4 --target 0,1,0 --fov 45 --width 480 --height 480 -v
build/tools/voxinspect render "$out/cornell_box.esvo" -o "$out/cornell_box.png" --channel shaded \
    --eye 0,1,3.4 --target 0,1,0 --fov 45 --width 640 --height 640 --depth-out "$out/cornell_box.depth.pfm" -v
# The same on the GPU through the OpenGL runtime, headless (Mesa llvmpipe where there is no GPU):
# the octree streamed and ray cast in a compute shader, the final gather over the .rvol atlas.
build/examples/voxview "$out/cornell_box.esvo" --rvol "$out/cornell_box.rvol" --scene "$scene" --headless \
    -o "$out/cornell_box.gpu.png" --eye 0,1,3.4 --target 0,1,0 --fov 45 --width 480 --height 480 \
    --stats "$out/cornell_box.gpu.json"

echo
echo "Example scene:  $scene"
echo "Octree:         $out/cornell_box.esvo   (voxinspect info $out/cornell_box.esvo)"
echo "Radiance:       $out/cornell_box.rvol   (voxinspect info $out/cornell_box.rvol; 256³, 2 bounces)"
echo "Render:         $out/cornell_box.png (colours and normals under a headlight), depth $out/cornell_box.depth.pfm"
echo "GI render:      $out/cornell_box.gi.png (the triangles lit by a cone-traced final gather over the .rvol)"
echo "GPU render:     $out/cornell_box.gpu.png (voxview: the octree and the final gather on OpenGL; $out/cornell_box.gpu.json)"
echo "Stats (JSON):   $out/cornell_box.stats.json"
echo "Depfile:        $out/cornell_box.d"
echo "Inspect it:     build/tools/voxinspect scene $scene"
