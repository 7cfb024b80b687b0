#!/usr/bin/env bash
# Octree build and ray casting benchmark (issue: sparse voxel octree).
# Builds the 1,048,576-triangle bumpy sphere at depths 10, 11 and 12 in separate processes
# (so peak memory is per build), then ray casts each file at 1024x768 with primary rays, and
# against its peer: the same view of the mesh through the BVH triangle caster (raycast_peer).
# Usage: bench/octree_bench.sh [BUILD_DIR] [DEPTHS...]    (default: build 10 11 12)
# VOXELIZE_ARGS adds voxelize options, e.g. VOXELIZE_ARGS=--no-contours for cubes only.
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
# The geometric-truth view of a real mesh (assimp-testmodels), depth 10, against the triangle caster.
wuson=/usr/share/assimp/models/PLY/Wuson.ply
if [ -f "$wuson" ]; then
    # shellcheck disable=SC2086
    "$build/tools/voxelize" "$wuson" -o "$out/wuson10.esvo" --depth 10 -q ${VOXELIZE_ARGS:-}
    "$build/bench/raycast_peer" "$wuson" "$out/wuson10.esvo" --eye 2.5,1.2,3 --target 0,0.75,0 --fov 50 > "$out/wuson_peer.json"
    python3 -c "import json,sys; p=json.load(open(sys.argv[1])); print('Wuson depth 10, 1024x768: hit/miss agree %.2f%%, depth within a leaf diagonal %.1f%% (along the normal %.1f%%), p50/p99 error %.3f/%.3f leaf diagonals; triangles %.2f Mrays/s, octree %.2f (x%.2f)' % (100*p['hit_miss_agreement'], 100*p['depth_within_leaf_diagonal'], 100*p['surface_distance_within_leaf_diagonal'], p['depth_error_diagonals']['p50'], p['depth_error_diagonals']['p99'], p['triangle_mrays_per_second'], p['octree_mrays_per_second'], p['octree_over_triangle']))" "$out/wuson_peer.json"
fi
printf '%-6s %12s %10s %12s %10s %10s %8s %11s %10s %10s\n' depth voxels build_s Mvoxels/s peak_MB file_MB B/voxel hierarchy Mrays/s Mrays/s_lod0
for d in "${depths[@]}"; do
    # shellcheck disable=SC2086
    "$build/tools/voxelize" "$mesh" -o "$out/sphere$d.esvo" --depth "$d" --stats "$out/build$d.json" -q ${VOXELIZE_ARGS:-}
    "$build/tools/voxinspect" info "$out/sphere$d.esvo" --json > "$out/info$d.json"
    "$build/tools/voxinspect" render "$out/sphere$d.esvo" -o "$out/render$d.png" "${camera[@]}" --stats "$out/render$d.json" -q
    "$build/tools/voxinspect" render "$out/sphere$d.esvo" -o "$out/render${d}_full.png" "${camera[@]}" --lod-scale 0 --stats "$out/render${d}_full.json" -q
    "$build/bench/raycast_peer" "$mesh" "$out/sphere$d.esvo" "${camera[@]}" > "$out/peer$d.json"
    python3 - "$out" "$d" <<'PY'
import json, sys
out, d = sys.argv[1], sys.argv[2]
b = json.load(open(f"{out}/build{d}.json")); i = json.load(open(f"{out}/info{d}.json"))
r = json.load(open(f"{out}/render{d}.json")); f = json.load(open(f"{out}/render{d}_full.json"))
o = b["octree"]
print(f'{d:<6} {o["voxels"]:12d} {o["build_seconds"]:10.2f} {o["voxels_per_second"]/1e6:12.2f} {b["peak_rss_bytes"]/2**20:10.0f} '
      f'{o["file_bytes"]/2**20:10.1f} {i["bytes_per_voxel"]["total"]:8.3f} {i["bytes_per_voxel"]["hierarchy"]:11.3f} '
      f'{r["mrays_per_second"]:10.2f} {f["mrays_per_second"]:10.2f}')
p = json.load(open(f"{out}/peer{d}.json"))
print(f'       peer (same process, best of 3): triangles {p["triangle_mrays_per_second"]:.2f} Mrays/s, octree {p["octree_mrays_per_second"]:.2f} '
      f'(x{p["octree_over_triangle"]:.2f}), octree+LOD {p["octree_lod_mrays_per_second"]:.2f} (x{p["octree_lod_over_triangle"]:.2f}); '
      f'hit/miss agree {100*p["hit_miss_agreement"]:.2f}%, depth within a leaf diagonal {100*p["depth_within_leaf_diagonal"]:.1f}% '
      f'(along the normal {100*p["surface_distance_within_leaf_diagonal"]:.1f}%)')
PY
done
echo "threads: $(nproc); voxelize options: ${VOXELIZE_ARGS:-(defaults)}; stats JSON and renders in $out"
