#!/usr/bin/env bash
# Ray casting against the triangle peer users compare with, Embree 3 (issue 33): for each bench
# mesh (bench/peer_table.sh's: the generated bumpy sphere and four assimp-testmodels meshes), the
# default voxelize build at DEPTH, then at each field of view the same camera cast two ways, in the
# same run, REPEAT times interleaved (alternately the peer first and ours first), medians taken:
#   ours:   `voxinspect render FILE.esvo` as users run it (default options: depth channel, LOD cut
#           at one pixel), its --stats mrays_per_second (the cast alone, no PNG writing);
#   Embree: bench/raycast_peer --embree-only: single rays (rtcIntersect1) on the mesh's triangles,
#           BVH built at RTC_BUILD_QUALITY_HIGH and not timed, TBB tiles.
# The camera frames the mesh's bounds from VIEW at DISTANCE times the distance where the bounding
# sphere just fits the image height (raycast_peer --view, --distance: 0.5 puts most of the image on
# the mesh, as users look at a model; at 1 most rays miss); raycast_peer prints its eye, target and
# up to the last bit and voxinspect render gets exactly those, with the same fov, size and threads. Prints one table: mesh, fov, hit % (ours / Embree), Mrays/s of both and
# the ratio ours / Embree (> 1: ours is faster). Needs raycast_peer built with Embree
# (libembree-dev installed when CMake configured).
# Usage: bench/raycast_table.sh [BUILD_DIR]     (default: build)
# Environment: DEPTH (11), FOVS ("20 30"), SIZE (1024x768), THREADS (2), REPEAT (3),
# VIEW (1,0.6,0.8: the direction the camera looks from), DISTANCE (0.5), MESHES (space-separated NAME:PATH,
# replacing the default list).
# Outputs: BUILD_DIR/bench/raycast/raycast_table.{json,csv}, every run's JSON beside them.
set -euo pipefail
build=${1:-build}
depth=${DEPTH:-11}
read -r -a fovs <<< "${FOVS:-20 30}"
size=${SIZE:-1024x768}
width=${size%x*}
height=${size#*x}
threads=${THREADS:-2}
repeat=${REPEAT:-3}
view=${VIEW:-1,0.6,0.8}
distance=${DISTANCE:-0.5}
here=$(cd "$(dirname "$0")" && pwd)
out=$build/bench/raycast
mkdir -p "$out/runs"
rm -f "$out"/runs/*.json
# shellcheck source=bench/bench_meshes.sh
. "$here/bench_meshes.sh"
bench_meshes "$build" "$out"
# Fails early (and clearly) where raycast_peer was built without Embree.
"$build/bench/raycast_peer" x x --embree-only >/dev/null 2>"$out/runs/probe.err" ||
    ! grep -q "built without Embree" "$out/runs/probe.err" || { cat "$out/runs/probe.err" >&2; exit 1; }
echo "raycast_table: $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg); threads $threads; REPEAT=$repeat; depth $depth; ${width}x$height; view $view at distance $distance" >&2

peer() {  # NAME FOV RUN
    "$build/bench/raycast_peer" "$mesh" - --embree-only --view "$view" --distance "$distance" --fov "$2" --width "$width" --height "$height" \
        --threads "$threads" --repeat 1 > "$out/runs/$1-$2-peer-$3.json"
}
camera_vector() {  # PEER_JSON KEY: x,y,z with every bit (repr of the doubles raycast_peer printed)
    python3 -c 'import json, sys; print(",".join(repr(float(x)) for x in json.load(open(sys.argv[1]))["views"][0][sys.argv[2]]))' "$1" "$2"
}
ours() {  # NAME FOV RUN: the camera raycast_peer framed in run 1
    local camera=$out/runs/$1-$2-peer-1.json
    "$build/tools/voxinspect" render "$out/$1.esvo" -o "$out/$1.png" --eye "$(camera_vector "$camera" eye)" \
        --target "$(camera_vector "$camera" target)" --up "$(camera_vector "$camera" up)" \
        --fov "$2" --width "$width" --height "$height" --threads "$threads" -q --stats "$out/runs/$1-$2-ours-$3.json"
}
for entry in "${meshes[@]}"; do
    name=${entry%%:*}
    mesh=${entry#*:}
    "$build/tools/voxelize" "$mesh" -o "$out/$name.esvo" --depth "$depth" -q
    for fov in "${fovs[@]}"; do
        for ((r = 1; r <= repeat; ++r)); do
            # Run 1 is the peer's first: it frames the camera both then use.
            if ((r % 2)); then peer "$name" "$fov" "$r"; ours "$name" "$fov" "$r"; else ours "$name" "$fov" "$r"; peer "$name" "$fov" "$r"; fi
        done
    done
    rm -f "$out/$name.esvo" "$out/$name.png"
    echo "raycast_table: $name done" >&2
done
PYTHONPATH="$here" python3 - "$out" "$repeat" "$depth" "${meshes[@]%%:*}" -- "${fovs[@]}" <<'PY'
import json, statistics, sys
from tables import write_json_and_csv
out, repeat, depth = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
rest = sys.argv[4:]
names, fovs = rest[:rest.index("--")], rest[rest.index("--") + 1:]
def load(name, fov, who, r):
    return json.load(open(f"{out}/runs/{name}-{fov}-{who}-{r}.json"))
rows = []
for name in names:
    for fov in fovs:
        ours = [load(name, fov, "ours", r) for r in range(1, repeat + 1)]
        peer = [load(name, fov, "peer", r) for r in range(1, repeat + 1)]
        cameras = {json.dumps({k: p["views"][0][k] for k in ("eye", "target", "up")}) for p in peer}
        assert len(cameras) == 1, f"{name} fov {fov}: raycast_peer framed different cameras"
        row = {"mesh": name, "fov": float(fov), "depth": depth, "width": ours[0]["width"], "height": ours[0]["height"],
               "threads": ours[0]["threads"], "peer_threads": peer[0]["threads"], "repeat": repeat,
               "camera": json.loads(cameras.pop()),
               "ours_hit_fraction": ours[0]["hits"] / ours[0]["rays"],
               "embree_hit_fraction": peer[0]["embree"]["hit_fraction"],
               "ours_mrays_per_second": statistics.median(o["mrays_per_second"] for o in ours),
               "embree_mrays_per_second": statistics.median(p["embree"]["mrays_per_second"] for p in peer),
               "ours_mrays_all": [o["mrays_per_second"] for o in ours],
               "embree_mrays_all": [p["embree"]["mrays_per_second"] for p in peer],
               "embree_build_seconds": statistics.median(p["embree_build"]["build_seconds"] for p in peer),
               "embree_version": peer[0]["embree_build"]["version"],
               "embree_build_quality": peer[0]["embree_build"]["build_quality"],
               "triangles": peer[0]["embree_build"]["triangles"]}
        row["ratio"] = row["ours_mrays_per_second"] / row["embree_mrays_per_second"]
        rows.append(row)
print(f'{"mesh":<16} {"fov":>4} {"triangles":>9} | {"hit % ours/Embree":>17} | {"ours Mrays/s":>12} {"Embree Mrays/s":>14} | {"ours/Embree":>11}')
for r in rows:
    hits = f'{100 * r["ours_hit_fraction"]:.1f} / {100 * r["embree_hit_fraction"]:.1f}'
    print(f'{r["mesh"]:<16} {r["fov"]:>4g} {r["triangles"]:>9} | {hits:>17} | {r["ours_mrays_per_second"]:>12.2f} '
          f'{r["embree_mrays_per_second"]:>14.2f} | {r["ratio"]:>11.2f}')
print(f'depth {depth}, {rows[0]["width"]}x{rows[0]["height"]}, threads {rows[0]["threads"]} (Embree {rows[0]["peer_threads"]}); medians of {repeat}, '
      f'interleaved; ours: voxinspect render (defaults, --stats mrays_per_second); Embree {rows[0]["embree_version"]} rtcIntersect1, '
      f'build quality {rows[0]["embree_build_quality"]} (not timed); ratio = ours / Embree')
write_json_and_csv(out, "raycast_table", rows)
PY
