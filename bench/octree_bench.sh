#!/usr/bin/env bash
# Octree build and ray casting benchmark (issue: sparse voxel octree).
# Builds the 1,048,576-triangle bumpy sphere at depths 10, 11 and 12 in separate processes
# (so peak memory is per build), then ray casts each file at 1024x768 with primary rays.
# Usage: bench/octree_bench.sh [BUILD_DIR] [DEPTHS...]    (default: build 10 11 12)
set -euo pipefail
build=${1:-build}
shift || true
depths=("$@")
[ ${#depths[@]} -gt 0 ] || depths=(10 11 12)
out=$build/bench
mkdir -p "$out"
"$build/examples/make_example_scene" bumpy-sphere -o "$out" >/dev/null
mesh=$out/bumpy_sphere.glb
# The same view for every depth: the whole sphere filling most of a 1024x768 frame.
camera=(--eye 0.3,0.4,3.2 --target 0,0,0 --fov 45 --width 1024 --height 768)
printf '%-6s %12s %10s %12s %10s %10s %8s %11s %10s %10s\n' depth voxels build_s Mvoxels/s peak_MB file_MB B/voxel hierarchy Mrays/s Mrays/s_lod0
for d in "${depths[@]}"; do
    "$build/tools/voxelize" "$mesh" -o "$out/sphere$d.esvo" --depth "$d" --stats "$out/build$d.json" -q
    "$build/tools/voxinspect" info "$out/sphere$d.esvo" --json > "$out/info$d.json"
    "$build/tools/voxinspect" render "$out/sphere$d.esvo" -o "$out/render$d.png" "${camera[@]}" --stats "$out/render$d.json" -q
    "$build/tools/voxinspect" render "$out/sphere$d.esvo" -o "$out/render${d}_full.png" "${camera[@]}" --lod-scale 0 --stats "$out/render${d}_full.json" -q
    python3 - "$out" "$d" <<'PY'
import json, sys
out, d = sys.argv[1], sys.argv[2]
b = json.load(open(f"{out}/build{d}.json")); i = json.load(open(f"{out}/info{d}.json"))
r = json.load(open(f"{out}/render{d}.json")); f = json.load(open(f"{out}/render{d}_full.json"))
o = b["octree"]
print(f'{d:<6} {o["voxels"]:12d} {o["build_seconds"]:10.2f} {o["voxels_per_second"]/1e6:12.2f} {b["peak_rss_bytes"]/2**20:10.0f} '
      f'{o["file_bytes"]/2**20:10.1f} {i["bytes_per_voxel"]["total"]:8.3f} {i["bytes_per_voxel"]["hierarchy"]:11.3f} '
      f'{r["mrays_per_second"]:10.2f} {f["mrays_per_second"]:10.2f}')
PY
done
echo "threads: $(nproc); stats JSON and renders in $out"
