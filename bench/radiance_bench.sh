#!/usr/bin/env bash
# Radiance bake benchmark (issue: radiance volumes): bake time, peak memory and stored bytes of
# the .rvol at radiance depths 8 (256³) and 9 (512³), on the Cornell-like example (816 triangles,
# 3 lights, emissive panel) and on a real scene of ≥ 100 k triangles from assimp-testmodels
# (2CylinderEngine, 110 k triangles, no lights of its own: the bake then does all of its cone work
# on an unlit volume, which costs the same). Each bake runs in its own process, so peak memory is
# per bake. Peers from the same run: the .esvo octree build of the same scene at the same depth
# (time), and a dense volume of the same resolution with every mip and direction in RGBA16F
# (memory; the paper stores dense 3D textures: 598 MB for its 256³ scene).
# Usage: bench/radiance_bench.sh [BUILD_DIR] [DEPTHS...]    (default: build 8 9)
set -euo pipefail
build=${1:-build}
shift || true
depths=("$@")
[ ${#depths[@]} -gt 0 ] || depths=(8 9)
out=$build/bench
mkdir -p "$out"
"$build/examples/make_example_scene" cornell-box -o "$out" >/dev/null
scenes=("$out/cornell_box.gltf")
engine=/usr/share/assimp/models/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb
[ -f "$engine" ] && scenes+=("$engine")
printf '%-18s %5s %9s %9s %8s %8s %9s %9s %9s %8s %9s %9s\n' scene depth triangles voxels bake_s peak_MB file_MB radiance attrib bricks dense_MB octree_s
for scene in "${scenes[@]}"; do
    name=$(basename "${scene%.*}")
    for d in "${depths[@]}"; do
        "$build/tools/voxelize" "$scene" --radiance "$out/$name$d.rvol" --radiance-depth "$d" --stats "$out/rvol_$name$d.json" -q
        "$build/tools/voxelize" "$scene" -o "$out/$name$d.esvo" --depth "$d" --stats "$out/esvo_$name$d.json" -q
        "$build/tools/voxinspect" validate "$out/$name$d.rvol" -q
        python3 - "$out" "$name" "$d" <<'PY'
import json, sys
out, name, d = sys.argv[1], sys.argv[2], int(sys.argv[3])
s = json.load(open(f"{out}/rvol_{name}{d}.json")); e = json.load(open(f"{out}/esvo_{name}{d}.json"))
r = s["radiance"]; MB = 2**20
# Dense peer: every level of a 2^d cube, level 0 one RGBA16F texel per cell, coarser levels six.
dense = sum((2 ** (d - l)) ** 3 * 8 * (1 if l == 0 else 6) for l in range(d + 1))
print(f'{name[:18]:<18} {d:5d} {s["triangles"]:9d} {r["static_voxels"]:9d} {r["bake_seconds"]:8.2f} {s["peak_rss_bytes"]/MB:8.0f} '
      f'{r["file_bytes"]/MB:9.1f} {r["radiance_bytes"]/MB:9.1f} {r["attribute_bytes"]/MB:9.1f} {r["bricks"]:8d} {dense/MB:9.0f} '
      f'{e["octree"]["build_seconds"]:9.2f}')
t = s["timings_ms"]
print('      stages (s): ' + ', '.join(f'{k.replace("radiance_", "")} {v/1000:.2f}' for k, v in t.items()
                                    if k.startswith('radiance_') or k.startswith('voxelize_subtrees') or k == 'rvol_write'))
PY
    done
done
echo "threads: $(nproc); MB = 2^20 bytes; radiance = brick data (all levels and directions), attrib = voxel attribute layers"
