#!/usr/bin/env bash
# A world-scale tiled radiance bake: a generated city of BLOCKS × BLOCKS blocks (default 40:
# 2.09 km across, 32 000 ranged lights) baked at radiance depth DEPTH (default 12: 4096³ cells of
# 0.51 m) under --memory-limit MEMORY (default 4G), as RUNS jobs (`voxelize --radiance-tile K/N`,
# one process each, as the Slurm array runs them) and then the index job. Each job's wall time,
# CPU time and peak RSS come from bench/measure.py; its tiles and bytes from its --stats.
# ONLY="K ..." bakes just those runs and skips the index: a sample of the tiles, to measure the
# time per tile and the memory bound where the whole bake would take hours; the line "estimate"
# then scales the sample's tile seconds by its share of the far-field voxels (the runs' shares).
# Usage: bench/radiance_world.sh [BUILD_DIR]
# Environment: BLOCKS (40), DEPTH (12), MEMORY (4G), TILE_DEPTH (what MEMORY allows), RUNS (16),
# ONLY (all runs), PARALLEL (runs at a time, 1), BOUNCES (2), THREADS (all cores), OUT
# (BUILD_DIR/bench/radiance_world).
set -euo pipefail
build=${1:-build}
blocks=${BLOCKS:-40}
depth=${DEPTH:-12}
memory=${MEMORY:-4G}
runs=${RUNS:-16}
only=${ONLY:-$(seq -s ' ' 1 "$runs")}
bounces=${BOUNCES:-2}
out=${OUT:-$build/bench/radiance_world}
here=$(cd "$(dirname "$0")" && pwd)
for tool in examples/make_example_scene tools/voxelize tools/voxinspect; do
    if [ ! -x "$build/$tool" ]; then
        echo "radiance_world.sh: $build/$tool is not built; build it first, e.g." >&2
        echo "    cmake --build $build --target make_example_scene voxelize voxinspect" >&2
        exit 1
    fi
done
mkdir -p "$out"
scene=$("$build/examples/make_example_scene" city-block --blocks-per-side "$blocks" -o "$out")
index=$out/world.rvol
extra_args=()
[ -n "${THREADS:-}" ] && extra_args=(--threads "$THREADS")
[ -n "${TILE_DEPTH:-}" ] && extra_args+=(--radiance-tile-depth "$TILE_DEPTH")
common=("$scene" --radiance "$index" --radiance-depth "$depth" --memory-limit "$memory"
    --bounces "$bounces" "${extra_args[@]}" -q)

# PARALLEL runs at a time: a run's serial parts (the far field's and each tile's setup) leave a
# core idle, which a second run fills.
run_one() {
    echo "radiance_world: run $1 of $runs ..." >&2
    python3 "$here/measure.py" "$out/run-$1.measure.json" -- \
        "$build/tools/voxelize" "${common[@]}" --radiance-tile "$1/$runs" --stats "$out/run-$1.json"
}
start=$(date +%s)
for k in $only; do
    while [ "$(jobs -rp | wc -l)" -ge "${PARALLEL:-1}" ]; do wait -n; done
    run_one "$k" &
done
while [ -n "$(jobs -rp)" ]; do wait -n; done
echo "radiance_world: runs took $(($(date +%s) - start)) s from the first start to the last end" >&2
complete=0
if [ "$(echo "$only" | wc -w)" -eq "$runs" ]; then
    echo "radiance_world: index ..." >&2
    python3 "$here/measure.py" "$out/index.measure.json" -- \
        "$build/tools/voxelize" "${common[@]}" --radiance-tile index --stats "$out/index.json"
    "$build/tools/voxinspect" validate "$index" -q
    complete=1
fi

python3 - "$out" "$runs" "$complete" "$only" <<'PY'
import json, sys
out, runs, complete, only = sys.argv[1], int(sys.argv[2]), sys.argv[3] == "1", sys.argv[4].split()
MB = 2 ** 20
print(f'{"job":>6} {"tiles":>6} {"voxels":>10} {"wall s":>8} {"cpu s":>8} {"far s":>6} {"tile s":>8} {"peak MB":>8} {"bytes MB":>9}')
wall = cpu = tile_s = 0.0
baked = peak = 0
byts = 0
shares = []
for name in [f"run-{k}" for k in only] + (["index"] if complete else []):
    m = json.load(open(f"{out}/{name}.measure.json"))
    s = json.load(open(f"{out}/{name}.json"))["radiance"]
    n = s.get("tiles_baked", 0)
    b = s["tile_bytes"] + s["far_bytes"] + s["index_bytes"]
    print(f'{name:>6} {n:6d} {s["static_voxels"]:10d} {m["wall_seconds"]:8.1f} {m["cpu_seconds"]:8.1f} '
          f'{s["far_seconds"]:6.1f} {s["tile_seconds"]:8.1f} {m["max_rss_bytes"] / MB:8.0f} {b / MB:9.1f}')
    wall += m["wall_seconds"]; cpu += m["cpu_seconds"]; tile_s += s["tile_seconds"]
    baked += n; peak = max(peak, m["max_rss_bytes"]); byts += b
    tiles = s["tiles"]
print(f'{"total":>6} {baked:6d} {"":>10} {wall:8.1f} {cpu:8.1f} {"":>6} {tile_s:8.1f} {peak / MB:8.0f} {byts / MB:9.1f}')
print(f'tiles holding geometry: {tiles}; runs baked: {len(only)} of {runs}' + ("" if complete else " (no index)"))
if not complete and baked:
    # Runs take equal shares of the far-field voxels, so each run's tile time is about the same.
    print(f'estimate for all {runs} runs: {tile_s / len(only) * runs:.0f} s of tiles '
          f'({tile_s / baked:.1f} s a tile), peak RSS as measured')
PY
