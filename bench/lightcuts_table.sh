#!/usr/bin/env bash
# Lightcuts benchmark: the paper's table 1 (Yuan et al., "Lightcuts many-light clustering based on
# adaptive spatial subdivision": Lightcuts over a binary-tree forest with cluster–light lists and
# cut reuse, against classic Lightcuts and against brute force) on the many-light example scenes:
# the corridor (30 lights), the corridor with two moving lights at frames 0 and 1 (the bake leaves
# the dynamic lights out, the render lights them), the light grid (256 lights) and the city block
# (10 000 lights). Each scene is baked (render points = static voxels) and rendered at SIZE×SIZE
# from the baked volume (render points = the pixels' hit points, visibility by shadow cones), both
# with --lightcuts on --lightcuts-compare, which runs all three methods on the same points.
# Two tables, bake and render, one row per scene:
#   lights, trees, points, clusters   of our Lightcuts (classic: one tree, no clusters)
#   cut ours/classic                  mean cut size per point
#   steps ours/classic, chg           mean search steps per point, and ours/classic − 1
#   time ours/classic/brute           seconds of the direct light (cuts and visibility; building
#                                     the forest and clustering not included: tree_s, cluster_s
#                                     in the JSON), chg = ours/classic − 1, ×brute = brute/ours
#   within ours/classic               fraction of the lit points within the threshold (2 %) of
#                                     brute force
#   max_err                           our largest relative error against brute force
# Every --stats JSON goes to the output directory (bake_<scene>.json, render_<scene>.json), with
# the .rvol volumes and the PNGs.
# Usage: bench/lightcuts_table.sh [BUILD_DIR]    (default: build)
# Environment: DEPTH radiance depth (7), BOUNCES (0), SIZE image width and height (1024, the
# paper's 1K×1K), CRITERION the Lightcuts criterion (rss; per-node is the paper's), OUT output
# directory (BUILD_DIR/bench/lightcuts), SCENES a subset of
# "corridor corridor_moving_f0 corridor_moving_f1 light_grid city_block".
set -euo pipefail
build=${1:-build}
depth=${DEPTH:-7}
bounces=${BOUNCES:-0}
size=${SIZE:-1024}
criterion=${CRITERION:-rss}
out=${OUT:-$build/bench/lightcuts}
for tool in examples/make_example_scene tools/voxelize tools/voxinspect; do
    if [ ! -x "$build/$tool" ]; then
        echo "lightcuts_table.sh: $build/$tool is not built; build it first, e.g." >&2
        echo "    cmake --build $build --target make_example_scene voxelize voxinspect" >&2
        exit 1
    fi
done
command -v python3 >/dev/null || { echo "lightcuts_table.sh: needs python3 for the tables" >&2; exit 1; }
mkdir -p "$out"

# name | make_example_scene arguments | eye | target
all_scenes=(
    "corridor|corridor|-29,1.6,0|29,1.4,0"
    "corridor_moving_f0|corridor-moving --frame 0|-29,1.6,0|29,1.4,0"
    "corridor_moving_f1|corridor-moving --frame 1|-29,1.6,0|29,1.4,0"
    "light_grid|light-grid|0,20,28|0,0,0"
    "city_block|city-block|0,120,300|0,0,0"
)
wanted=${SCENES:-corridor corridor_moving_f0 corridor_moving_f1 light_grid city_block}
now() { date +%s.%N; }
: > "$out/times.tsv"
for entry in "${all_scenes[@]}"; do
    IFS='|' read -r name generate eye target <<<"$entry"
    case " $wanted " in *" $name "*) ;; *) continue ;; esac
    # shellcheck disable=SC2086
    "$build/examples/make_example_scene" $generate -o "$out" >/dev/null
    scene=$out/$name.gltf
    [ -f "$scene" ] || { echo "lightcuts_table.sh: make_example_scene $generate did not write $scene" >&2; exit 1; }
    echo "$name: bake (depth $depth, $bounces bounces) ..." >&2
    t0=$(now)
    "$build/tools/voxelize" "$scene" --radiance "$out/$name.rvol" --radiance-depth "$depth" --bounces "$bounces" \
        --lightcuts on --lightcut-criterion "$criterion" --lightcuts-compare --stats "$out/bake_$name.json" -q
    t1=$(now)
    echo "$name: render ${size}x$size ..." >&2
    "$build/tools/voxinspect" render "$out/$name.rvol" --scene "$scene" --eye "$eye" --target "$target" \
        --width "$size" --height "$size" -o "$out/$name.png" --lightcuts on --lightcut-criterion "$criterion" --lightcuts-compare \
        --stats "$out/render_$name.json" -q
    t2=$(now)
    printf '%s\t%s\t%s\n' "$name" "$(awk "BEGIN { print $t1 - $t0 }")" "$(awk "BEGIN { print $t2 - $t1 }")" >> "$out/times.tsv"
done

python3 - "$out" "$depth" "$bounces" "$size" <<'PY'
import json, sys
out, depth, bounces, size = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4]
times = [line.rstrip('\n').split('\t') for line in open(f'{out}/times.tsv') if line.strip()]

def pct(x):
    return f'{100 * x:+.1f}%'

def sec(x):
    return f'{x:.3f}' if x < 10 else f'{x:.1f}'

def row(name, d):
    c = d['compare']
    ours, classic, brute = c['lightcuts'], c['classic'], c['brute_force']
    cells = [
        name[:18], str(ours['lights']), str(ours['trees']), str(ours['points']), str(ours['clusters']),
        f"{ours['mean_cut_size']:.1f}/{classic['mean_cut_size']:.1f}",
        f"{ours['mean_search_steps']:.1f}/{classic['mean_search_steps']:.1f}", pct(c['search_steps_vs_classic']),
        f"{sec(ours['seconds'])}/{sec(classic['seconds'])}/{sec(brute['seconds'])}", pct(c['time_vs_classic']),
        f"{c['speedup_vs_brute_force']:.1f}x",
        f"{ours['error']['fraction_within']:.3f}/{classic['error']['fraction_within']:.3f}",
        f"{ours['error']['max_relative']:.3f}",
    ]
    return cells

header = ['scene', 'lights', 'trees', 'points', 'clusters', 'cut ours/cl', 'steps ours/cl', 'chg', 'time s ours/cl/brute',
          'chg', 'xbrute', 'within ours/cl', 'max_err']
widths = [18, 6, 5, 9, 8, 13, 15, 8, 23, 8, 7, 14, 8]

def table(title, rows):
    print(title)
    print(' '.join(h.rjust(w) if i else h.ljust(w) for i, (h, w) in enumerate(zip(header, widths))))
    for cells in rows:
        print(' '.join(c.rjust(w) if i else c.ljust(w) for i, (c, w) in enumerate(zip(cells, widths))))

bake, render, notes = [], [], []
threshold = None
for name, bake_s, render_s in times:
    b = json.load(open(f'{out}/bake_{name}.json'))
    r = json.load(open(f'{out}/render_{name}.json'))
    bd, rd = b['radiance']['direct_light'], r['direct_light']
    threshold = bd['compare']['lightcuts']['error']['threshold']
    bake.append(row(name, bd))
    render.append(row(name, rd))
    notes.append(f"  {name}: bake {float(bake_s):.1f} s wall (bake_seconds {b['radiance']['bake_seconds']:.2f}, "
                 f"{b['radiance']['static_voxels']} static voxels, forest {bd['compare']['lightcuts']['tree_seconds']:.3f} s, "
                 f"clusters {bd['compare']['lightcuts']['cluster_seconds']:.3f} s); render {float(render_s):.1f} s wall "
                 f"(render {r['seconds']:.2f} s, direct {r['direct_seconds']:.2f} s, {r['hits']} hits, "
                 f"forest {rd['compare']['lightcuts']['tree_seconds']:.3f} s, clusters {rd['compare']['lightcuts']['cluster_seconds']:.3f} s)")
if not times:
    sys.exit('lightcuts_table.sh: no scene ran (check SCENES)')
table(f'Bake (render points = static voxels; radiance depth {depth}, {bounces} bounces)', bake)
print()
table(f'Render (render points = pixels; {size}x{size}, shadow cones)', render)
print()
print(f'ours = Lightcuts with forest, cluster-light lists and cut reuse; cl = classic Lightcuts; brute = every light at every point.')
print(f'chg = ours/classic - 1; xbrute = brute/ours time; within = fraction of lit points within {100 * threshold:g} % of brute force;')
print('times are the direct light only (building the forest and clustering not included, see below).')
print('Wall times (each includes both other methods of the comparison):')
print('\n'.join(notes))
PY
echo "threads: $(nproc); JSON, volumes and images in $out"
