#!/usr/bin/env bash
# Import speed and memory on a big mesh (issue 33): the bumpy sphere at 4,194,304 triangles as
# GLB and as binary PLY (bench/mesh_convert.py), each voxelized at depth 11 with --stats, REPEAT
# times, medians taken. Prints one table per format: triangles, import ms, import.finalize ms,
# prepare+bin ms (voxelize_prepare + voxelize_bin), M triangles/s of import + prepare + bin,
# peak RSS bytes per triangle right after the import (--stats import.peak_rss_bytes_per_triangle),
# whole build seconds, and meshToVolume's seconds on the same mesh in the same run
# (bench/mesh_to_volume_peer, the same depth and threads) with the ratio peer ÷ ours.
# Usage: bench/import_bench.sh [BUILD_DIR]
# Environment: REPEAT (default 3); THREADS (default 2); RINGS/SEGMENTS (default 1025/2048);
# FORMATS (default "glb ply"; also stl obj off, written from the GLB); PEER=0 skips meshToVolume.
# Outputs: BUILD_DIR/bench/import/{import_bench.json, runs/*.json}.
set -euo pipefail
build=${1:-build}
repeat=${REPEAT:-3}
threads=${THREADS:-2}
here=$(cd "$(dirname "$0")" && pwd)
out=$build/bench/import
mkdir -p "$out/runs"
rm -f "$out"/runs/*.json
mesh=$out/bumpy_sphere
if [ ! -f "$mesh.glb" ]; then
    "$build/examples/make_example_scene" bumpy-sphere --rings "${RINGS:-1025}" --segments "${SEGMENTS:-2048}" -o "$out" >/dev/null
fi
formats=(${FORMATS:-glb ply})
for f in "${formats[@]}"; do
    [ "$f" = glb ] || [ -f "$mesh.$f" ] || python3 "$here/mesh_convert.py" "$mesh.glb" "$mesh.$f"
done
echo "import_bench: $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg); threads $threads; REPEAT=$repeat" >&2
for ((r = 1; r <= repeat; ++r)); do
    for f in "${formats[@]}"; do
        python3 "$here/measure.py" "$out/runs/$f-ours-$r.time.json" -- \
            "$build/tools/voxelize" "$mesh.$f" -o "$out/out.esvo" --depth 11 --threads "$threads" --stats "$out/runs/$f-ours-$r.json" -q
    done
    if [ "${PEER:-1}" = 1 ]; then
        python3 "$here/measure.py" "$out/runs/peer-$r.time.json" -- \
            "$build/bench/mesh_to_volume_peer" "$mesh.glb" --depth 11 --output "$out/out.vdb" --threads "$threads" --stats "$out/runs/peer-$r.json"
    fi
done
rm -f "$out/out.esvo" "$out/out.vdb"
python3 - "$out" "$repeat" "${PEER:-1}" "${formats[@]}" <<'PY'
import json, os, statistics, sys
out, repeat, peer, formats = sys.argv[1], int(sys.argv[2]), sys.argv[3] == "1", sys.argv[4:]
load = lambda name: json.load(open(os.path.join(out, "runs", name)))
median = statistics.median
peer_seconds = median(load(f"peer-{r}.time.json")["wall_seconds"] for r in range(1, repeat + 1)) if peer else None
rows = []
for f in formats:
    runs = [load(f"{f}-ours-{r}.json") for r in range(1, repeat + 1)]
    walls = [load(f"{f}-ours-{r}.time.json")["wall_seconds"] for r in range(1, repeat + 1)]
    ms = lambda key: median(run["timings_ms"].get(key, 0.0) for run in runs)
    triangles = runs[0]["triangles"]
    front = median(run["timings_ms"]["import"] + run["timings_ms"]["voxelize_prepare"] + run["timings_ms"]["voxelize_bin"] for run in runs)
    rows.append({
        "format": f, "triangles": triangles, "import_ms": ms("import"), "parse_ms": ms("import.parse"),
        "finalize_ms": ms("import.finalize"), "prepare_bin_ms": ms("voxelize_prepare") + ms("voxelize_bin"),
        "mtris_per_second": triangles / front / 1000.0,
        "peak_rss_bytes_per_triangle": median(run["import"]["peak_rss_bytes_per_triangle"] for run in runs),
        "build_seconds": median(walls), "peer_seconds": peer_seconds,
        "peer_over_ours": peer_seconds / median(walls) if peer else None,
    })
json.dump(rows, open(os.path.join(out, "import_bench.json"), "w"), indent=2)
print(f"{'format':<6} {'triangles':>10} {'import ms':>9} {'parse ms':>8} {'final. ms':>9} {'prep+bin ms':>11} {'Mtri/s':>7} {'RSS B/tri':>9} "
      f"{'build s':>7} {'peer s':>7} {'peer/ours':>9}")
for r in rows:
    peer_cols = f"{r['peer_seconds']:>7.2f} {r['peer_over_ours']:>9.2f}" if peer else f"{'-':>7} {'-':>9}"
    print(f"{r['format']:<6} {r['triangles']:>10} {r['import_ms']:>9.0f} {r['parse_ms']:>8.0f} {r['finalize_ms']:>9.0f} {r['prepare_bin_ms']:>11.0f} "
          f"{r['mtris_per_second']:>7.2f} {r['peak_rss_bytes_per_triangle']:>9.1f} {r['build_seconds']:>7.2f} {peer_cols}")
PY
