#!/usr/bin/env bash
# The BVH triangle caster against Embree 3 on the rays a bounce gather casts (the radiance bake's
# --bounce-gather rays, the path-traced reference): for each bench mesh (bench_meshes.sh's, plus
# the Cornell box and the house the radiance accuracy is measured on), bench/raycast_peer
# --bounce-rays: from each pixel's primary hit of a SIZE view (from VIEW at DISTANCE), RAYS
# cosine-distributed directions about the surface, cast by TriangleRayCaster::castSurface and by
# Embree's rtcIntersect1 (BVH at RTC_BUILD_QUALITY_HIGH, not timed), both in chunks of 256 rays
# through TBB on THREADS threads, in the same process; each the best of REPEAT casts. Prints one
# table: mesh, triangles, rays, hit %, Mrays/s of both, ours / Embree (> 1: ours is faster), and
# the share of rays where both agree on hit or miss. Needs raycast_peer built with Embree.
# Usage: bench/bounce_rays_table.sh [BUILD_DIR]     (default: build)
# Environment: RAYS (64), SIZE (128x96), VIEW (1,0.6,0.8), DISTANCE (0.6), THREADS (2),
# REPEAT (3), MESHES (space-separated NAME:PATH, replacing the default list).
# Outputs: BUILD_DIR/bench/bounce_rays/NAME.json per mesh.
set -euo pipefail
build=${1:-build}
size=${SIZE:-128x96}
here=$(cd "$(dirname "$0")" && pwd)
out=$build/bench/bounce_rays
mkdir -p "$out"
# shellcheck source=bench/bench_meshes.sh
. "$here/bench_meshes.sh"
bench_meshes "$build" "$out"
if [ -z "${MESHES:-}" ]; then
    "$build/examples/make_example_scene" cornell-box -o "$out/cornell" >/dev/null
    meshes=("cornell-box:$out/cornell/cornell_box.gltf" "house:/usr/share/assimp/models/OBJ/regr01.obj" "${meshes[@]}")
fi
printf '%-16s %9s %9s %6s %12s %12s %10s %8s\n' mesh triangles rays hit% ours_Mrays embree_Mrays ours/embree agree
for entry in "${meshes[@]}"; do
    name=${entry%%:*}
    "$build/bench/raycast_peer" "${entry#*:}" - --view "${VIEW:-1,0.6,0.8}" \
        --distance "${DISTANCE:-0.6}" --width "${size%x*}" --height "${size#*x}" \
        --bounce-rays "${RAYS:-64}" --repeat "${REPEAT:-3}" --threads "${THREADS:-2}" \
        > "$out/$name.json"
    python3 - "$name" "$out/$name.json" <<'PY'
import json, sys
d = json.load(open(sys.argv[2]))
b = d["bounce_rays"]
print("%-16s %9d %9d %6.1f %12.2f %12.2f %10.2f %8.5f" % (
    sys.argv[1], d["triangles"], b["rays"], 100 * b["hit_fraction"], b["mrays_per_second"],
    b["embree_mrays_per_second"], b["ours_over_embree"], b["hit_agreement"]))
PY
done
echo "threads ${THREADS:-2}; ${RAYS:-64} rays per primary hit of a ${size} view; best of ${REPEAT:-3} casts each"
