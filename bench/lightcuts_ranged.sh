#!/usr/bin/env bash
# Lightcuts against brute force in the radiance bake with over a thousand ranged lights: the light
# grid with 32 × 32 lights 1 m apart (make_example_scene light-grid --lights-per-side 32: 1024
# point lights with 5 m ranges over a floor with 64 boxes) and the corridor lit by LED strips
# (corridor-strips: 1184 point lights with 4 m ranges, partitions, doors, pillars and crates).
# Each scene is baked REPEAT times with --lightcuts on --lightcuts-compare, which lights the same
# voxels with our Lightcuts (forest, cluster–light lists, cut reuse, shadow rays shared by voxel
# blocks), classic Lightcuts and brute force (one ray per light in range and voxel) in one run.
# One row per scene:
#   lights, points                  static lights and voxels
#   cut                             our mean cut size per voxel
#   rays/voxel ours/brute           shadow rays traced per voxel (ours: queries − shared answers)
#   shared                          share of our visibility queries a block test answered
#   brute s, ours s                 medians over the runs of the direct light's wall time (cuts and
#                                   visibility; building the forest and the clusters apart, in
#                                   tree_s and cluster_s of the JSON)
#   speedup                         median brute / median ours; min–max over the runs
#   within 2 %, max err             our voxels within the threshold of brute force, our worst
#                                   relative error (the same in every run: the bake is
#                                   deterministic)
# Usage: bench/lightcuts_ranged.sh [BUILD_DIR]    (default: build)
# Environment: DEPTH radiance depth (8), REPEAT runs per scene (3), THREADS (all cores), OUT output
# directory (BUILD_DIR/bench/lightcuts_ranged), SCENES a subset of "light_grid_1024
# corridor_strips".
set -euo pipefail
build=${1:-build}
depth=${DEPTH:-8}
repeat=${REPEAT:-3}
out=${OUT:-$build/bench/lightcuts_ranged}
threads=${THREADS:-}
for tool in examples/make_example_scene tools/voxelize; do
    if [ ! -x "$build/$tool" ]; then
        echo "lightcuts_ranged.sh: $build/$tool is not built; build it first, e.g." >&2
        echo "    cmake --build $build --target make_example_scene voxelize" >&2
        exit 1
    fi
done
command -v python3 >/dev/null || { echo "lightcuts_ranged.sh: needs python3 for the table" >&2; exit 1; }
mkdir -p "$out"

# name | make_example_scene arguments
all_scenes=(
    "light_grid_1024|light-grid --lights-per-side 32"
    "corridor_strips|corridor-strips"
)
wanted=${SCENES:-light_grid_1024 corridor_strips}
thread_args=()
[ -n "$threads" ] && thread_args=(--threads "$threads")
ran=()
for entry in "${all_scenes[@]}"; do
    IFS='|' read -r name generate <<<"$entry"
    case " $wanted " in *" $name "*) ;; *) continue ;; esac
    # shellcheck disable=SC2086
    "$build/examples/make_example_scene" $generate -o "$out" >/dev/null
    for run in $(seq 1 "$repeat"); do
        echo "$name: bake $run of $repeat (depth $depth) ..." >&2
        "$build/tools/voxelize" "$out/$name.gltf" --radiance "$out/$name.rvol" --radiance-depth "$depth" \
            --bounces 0 --lightcuts on --lightcuts-compare "${thread_args[@]}" \
            --stats "$out/${name}_$run.json" -q
    done
    ran+=("$name")
done
[ ${#ran[@]} -gt 0 ] || { echo "lightcuts_ranged.sh: no scene ran (check SCENES)" >&2; exit 1; }

python3 - "$out" "$depth" "$repeat" "${ran[@]}" <<'PY'
import json, statistics, sys
out, depth, repeat, names = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4:]
header = ['scene', 'lights', 'points', 'cut', 'rays/voxel ours/brute', 'shared', 'brute s', 'ours s',
          'speedup (min-max)', 'within 2 %', 'max err']
widths = [16, 6, 7, 5, 21, 7, 8, 7, 18, 10, 8]
print(f'Bake, radiance depth {depth}, 0 bounces; medians of {repeat} runs')
print(' '.join(h.rjust(w) if i else h.ljust(w) for i, (h, w) in enumerate(zip(header, widths))))
for name in names:
    runs = [json.load(open(f'{out}/{name}_{k}.json'))['radiance']['direct_light']['compare']
            for k in range(1, repeat + 1)]
    ours = [r['lightcuts'] for r in runs]
    brute = [r['brute_force'] for r in runs]
    o, b = ours[0], brute[0]
    ours_s = statistics.median(x['seconds'] for x in ours)
    brute_s = statistics.median(x['seconds'] for x in brute)
    ratios = [y['seconds'] / x['seconds'] for x, y in zip(ours, brute)]
    rays = (o['visibility_evaluations'] - o.get('visibility_shared', 0)) / o['points']
    shared = o.get('visibility_shared', 0) / max(1, o['visibility_evaluations'])
    cells = [name, str(o['lights']), str(o['points']), f"{o['mean_cut_size']:.1f}",
             f"{rays:.1f} / {b['visibility_evaluations'] / b['points']:.1f}", f'{100 * shared:.0f} %',
             f'{brute_s:.3f}', f'{ours_s:.3f}',
             f'{brute_s / ours_s:.2f}x ({min(ratios):.2f}-{max(ratios):.2f})',
             f"{100 * o['error']['fraction_within']:.2f} %", f"{100 * o['error']['max_relative']:.1f} %"]
    print(' '.join(c.rjust(w) if i else c.ljust(w) for i, (c, w) in enumerate(zip(cells, widths))))
PY
echo "threads: ${threads:-$(nproc)}; load before the last run: $(cut -d' ' -f1-3 /proc/loadavg); JSON in $out"
