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
build/tools/voxelize "$scene" -v --stats "$out/cornell_box.stats.json" --depfile "$out/cornell_box.d"

echo
echo "Example scene:  $scene"
echo "Stats (JSON):   $out/cornell_box.stats.json"
echo "Depfile:        $out/cornell_box.d"
echo "Inspect it:     build/tools/voxinspect scene $scene"
