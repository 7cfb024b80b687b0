#!/usr/bin/env bash
# Contours against cubes (issue: contours). For a CAD-like mesh with sharp edges (assimp's
# 2CylinderEngine) and an organic one (Wuson), at one leaf depth: cubes only, contours without
# an error bound, and contour-driven refinement at several --contour-error values. Each file is
# rendered at 1024x768 next to the BVH triangle caster (raycast_peer): voxel count, bytes per
# voxel (and the contours' share), hit/miss agreement and depth error (mean, p95, in leaf-voxel
# diagonals) against the mesh.
# Usage: bench/contour_bench.sh [BUILD_DIR] [DEPTH]     (default: build 10)
set -euo pipefail
build=${1:-build}
depth=${2:-10}
out=$build/bench/contours
mkdir -p "$out"
models=/usr/share/assimp/models
meshes=("cad:$models/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb" "organic:$models/PLY/Wuson.ply")
printf '%-8s %-14s %10s %8s %10s %9s %12s %12s %12s %9s\n' mesh build voxels B/voxel contours hit/miss within_diag mean_diag p95_diag Mrays/s
for entry in "${meshes[@]}"; do
    name=${entry%%:*}
    mesh=${entry#*:}
    for config in "cubes:--no-contours" "contours:" "error0.5:--contour-error 0.5" "error1:--contour-error 1" "error2:--contour-error 2"; do
        label=${config%%:*}
        # shellcheck disable=SC2086
        "$build/tools/voxelize" "$mesh" -o "$out/$name-$label.esvo" --depth "$depth" -q ${config#*:}
        "$build/tools/voxinspect" info "$out/$name-$label.esvo" --json > "$out/$name-$label.info.json"
        "$build/bench/raycast_peer" "$mesh" "$out/$name-$label.esvo" --view 1,0.6,0.8 --fov 40 --repeat 1 > "$out/$name-$label.peer.json"
        python3 - "$out/$name-$label" "$name" "$label" <<'PY'
import json, sys
base, name, label = sys.argv[1:]
i = json.load(open(base + ".info.json")); p = json.load(open(base + ".peer.json"))
d = p["leaf_diagonal"]
print(f'{name:<8} {label:<14} {i["voxels"]:10d} {i["bytes_per_voxel"]["total"]:8.3f} {i["bytes_per_voxel"]["contours"]:10.3f} '
      f'{100*p["hit_miss_agreement"]:8.3f}% {100*p["depth_within_leaf_diagonal"]:11.2f}% {p["depth_error_mean"]/d:12.3f} '
      f'{p["depth_error_p95"]/d:12.3f} {p["octree_mrays_per_second"]:9.2f}')
PY
    done
done
echo "depth $depth; files and JSON in $out"
