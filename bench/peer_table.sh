#!/usr/bin/env bash
# voxelize against the peer a user would reach for, OpenVDB's meshToVolume: for each
# mesh (the generated 1,048,576-triangle bumpy sphere and the assimp-testmodels meshes with the
# most triangles) and each depth, the default build (error-bounded voxelization, hierarchy,
# contours, dxt colours and normals, .esvo written) against meshToVolume's unsigned distance field with a
# half-width of 0.87 voxel (the surface voxels) at the same voxel size and thread count
# (bench/mesh_to_volume_peer), in the same run, each REPEAT times, interleaved (alternately ours
# first and the peer's first), medians taken. Prints one table: triangles, voxels, build seconds,
# whole-process wall and CPU seconds, peak RSS, output MB and bytes per voxel of both, and the
# ratios peer ÷ ours (time > 1: ours is faster; RSS > 1: ours needs less). docs/benchmarks.md
# says how to read it.
# Usage: bench/peer_table.sh [BUILD_DIR] [DEPTHS...]     (default: build 10 11 12)
# Environment: REPEAT (default 3); THREADS (default: none given, both use all cores);
# MESHES (space-separated NAME:PATH, replacing the default list); VOXELIZE_ARGS (extra voxelize
# options, e.g. --memory-limit); CROSS_CHECK=1 (also count, untimed, the octree leaves that are
# active voxels of the grid and the other way round).
# Outputs: build/bench/peer/peer_table.{json,csv}, every run's stats and measurements beside them.
set -euo pipefail
build=${1:-build}
shift || true
depths=("$@")
[ ${#depths[@]} -gt 0 ] || depths=(10 11 12)
repeat=${REPEAT:-3}
here=$(cd "$(dirname "$0")" && pwd)
out=$build/bench/peer
mkdir -p "$out/runs"
rm -f "$out"/runs/*.json
threads=()
[ -z "${THREADS:-}" ] || threads=(--threads "$THREADS")
# shellcheck source=bench/bench_meshes.sh
. "$here/bench_meshes.sh"
bench_meshes "$build" "$out"
echo "peer_table: $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg); threads ${THREADS:-all}; REPEAT=$repeat; depths ${depths[*]}" >&2
ours() {  # NAME DEPTH RUN
    # shellcheck disable=SC2086
    python3 "$here/measure.py" "$out/runs/$1-$2-ours-$3.time.json" -- \
        "$build/tools/voxelize" "$mesh" -o "$out/$1-$2.esvo" --depth "$2" --stats "$out/runs/$1-$2-ours-$3.json" -q "${threads[@]}" ${VOXELIZE_ARGS:-}
}
peer() {  # NAME DEPTH RUN
    python3 "$here/measure.py" "$out/runs/$1-$2-peer-$3.time.json" -- \
        "$build/bench/mesh_to_volume_peer" "$mesh" --depth "$2" --output "$out/$1-$2.vdb" --stats "$out/runs/$1-$2-peer-$3.json" "${threads[@]}"
}
for entry in "${meshes[@]}"; do
    name=${entry%%:*}
    mesh=${entry#*:}
    for d in "${depths[@]}"; do
        for ((r = 1; r <= repeat; ++r)); do
            if ((r % 2)); then ours "$name" "$d" "$r"; peer "$name" "$d" "$r"; else peer "$name" "$d" "$r"; ours "$name" "$d" "$r"; fi
        done
        if [ "${CROSS_CHECK:-0}" = 1 ]; then
            "$build/bench/mesh_to_volume_peer" "$mesh" --depth "$d" --stats "$out/runs/$name-$d-cross.json" --cross-check "${threads[@]}"
        fi
        rm -f "$out/$name-$d.esvo" "$out/$name-$d.vdb"
        echo "peer_table: $name depth $d done" >&2
    done
done
PYTHONPATH="$here" python3 - "$out" "$repeat" "${meshes[@]%%:*}" -- "${depths[@]}" <<'PY'
import json, os, statistics, sys
from tables import write_json_and_csv
out, repeat = sys.argv[1], int(sys.argv[2])
rest = sys.argv[3:]
names, depths = rest[:rest.index("--")], rest[rest.index("--") + 1:]
MB = 2**20
def load(name, d, who, r):
    base = f"{out}/runs/{name}-{d}-{who}-{r}"
    return json.load(open(base + ".json")), json.load(open(base + ".time.json"))
def med(values):
    return statistics.median(values)
rows = []
for name in names:
    for d in depths:
        ours = [load(name, d, "ours", r) for r in range(1, repeat + 1)]
        peer = [load(name, d, "peer", r) for r in range(1, repeat + 1)]
        s, p = ours[0][0], peer[0][0]
        o, g = s["octree"], p["grid"]
        row = {
            "mesh": name, "depth": int(d), "triangles": s["triangles"] - s["dynamic_triangles"], "threads": s["threads"],
            "peer_threads": p["threads"], "repeat": repeat,
            "ours_voxels": o["voxels"], "ours_leaves": o["voxels_per_level"][-1],
            "ours_build_seconds": med([x[0]["octree"]["build_seconds"] for x in ours]),
            "ours_voxelize_seconds": med([x[0]["octree"]["voxelize_seconds"] for x in ours]),
            "ours_esvo_seconds": med([x[0]["timings_ms"].get("esvo", 0) / 1000 for x in ours]),
            "ours_wall_seconds": med([x[1]["wall_seconds"] for x in ours]),
            "ours_cpu_seconds": med([x[1]["cpu_seconds"] for x in ours]),
            "ours_peak_rss_bytes": med([x[0]["peak_rss_bytes"] for x in ours]),
            "ours_output_bytes": o["file_bytes"], "ours_bytes_per_voxel": o["bytes_per_voxel"],
            "ours_attribute_kernels": o.get("attribute_kernels", "unknown"),
            "peer_voxels": g["active_voxels"],
            "peer_seconds": med([x[0]["grid"]["mesh_to_volume_seconds"] for x in peer]),
            "peer_prepare_seconds": med([x[0]["grid"]["prepare_seconds"] for x in peer]),
            "peer_write_seconds": med([x[0]["grid"]["write_seconds"] for x in peer]),
            "peer_wall_seconds": med([x[1]["wall_seconds"] for x in peer]),
            "peer_cpu_seconds": med([x[1]["cpu_seconds"] for x in peer]),
            "peer_peak_rss_bytes": med([x[0]["peak_rss_bytes"] for x in peer]),
            "peer_mem_usage_bytes": g["mem_usage_bytes"],
            "peer_output_bytes": g["file_bytes"], "peer_bytes_per_voxel": g["bytes_per_voxel"],
        }
        row["ours_seconds_all"] = [x[0]["octree"]["build_seconds"] for x in ours]
        row["peer_seconds_all"] = [x[0]["grid"]["mesh_to_volume_seconds"] for x in peer]
        row["time_ratio"] = row["peer_seconds"] / row["ours_build_seconds"]
        row["wall_ratio"] = row["peer_wall_seconds"] / row["ours_wall_seconds"]
        row["cpu_ratio"] = row["peer_cpu_seconds"] / row["ours_cpu_seconds"]
        row["rss_ratio"] = row["peer_peak_rss_bytes"] / row["ours_peak_rss_bytes"]
        cross = f"{out}/runs/{name}-{d}-cross.json"
        if os.path.exists(cross):
            row["cross_check"] = json.load(open(cross))["cross_check"]
        rows.append(row)
head = (f'{"mesh":<16} {"depth":>5} {"triangles":>9} | {"voxels":>10} {"build_s":>8} {"wall_s":>7} {"cpu_s":>7} {"RSS_MB":>7} {"out_MB":>7} {"B/vox":>6} | '
        f'{"voxels":>10} {"m2v_s":>8} {"wall_s":>7} {"cpu_s":>7} {"RSS_MB":>7} {"out_MB":>7} {"B/vox":>6} | {"time":>6} {"wall":>6} {"cpu":>6} {"RSS":>6}')
print(f'{"":<33}| {"voxelize (default build: error-bounded, contours + dxt)":<67}| {"OpenVDB meshToVolume (unsigned, 0.87 voxel)":<67}| {"peer / ours":<27}')
print(head)
for r in rows:
    print(f'{r["mesh"]:<16} {r["depth"]:>5} {r["triangles"]:>9} | {r["ours_voxels"]:>10} {r["ours_build_seconds"]:>8.3f} {r["ours_wall_seconds"]:>7.2f} '
          f'{r["ours_cpu_seconds"]:>7.2f} {r["ours_peak_rss_bytes"]/MB:>7.0f} {r["ours_output_bytes"]/MB:>7.1f} {r["ours_bytes_per_voxel"]:>6.2f} | '
          f'{r["peer_voxels"]:>10} {r["peer_seconds"]:>8.3f} {r["peer_wall_seconds"]:>7.2f} {r["peer_cpu_seconds"]:>7.2f} '
          f'{r["peer_peak_rss_bytes"]/MB:>7.0f} {r["peer_output_bytes"]/MB:>7.1f} {r["peer_bytes_per_voxel"]:>6.2f} | '
          f'{r["time_ratio"]:>6.2f} {r["wall_ratio"]:>6.2f} {r["cpu_ratio"]:>6.2f} {r["rss_ratio"]:>6.2f}')
threads = sorted({r["threads"] for r in rows} | {r["peer_threads"] for r in rows})
kernels = sorted({r["ours_attribute_kernels"] for r in rows})
print(f'threads {",".join(map(str, threads))}; medians of {repeat}; build_s: voxelize\'s octree.build_seconds (voxelization + .esvo layout, '
      f'encode, write; no import); m2v_s: meshToVolume alone; wall_s, cpu_s, RSS: the whole process; time = m2v_s / build_s; '
      f'attribute kernels {",".join(kernels)}')
if any("cross_check" in r for r in rows):
    print(f'{"mesh":<16} {"depth":>5} {"leaves":>10} {"active":>10} {"leaves_in_grid":>14} {"active_in_leaves":>16} {"active/leaves":>13}')
    for r in rows:
        c = r.get("cross_check")
        if c:
            print(f'{r["mesh"]:<16} {r["depth"]:>5} {c["octree_leaves"]:>10} {c["grid_active_voxels"]:>10} {c["octree_leaves_in_grid"]:>14.4f} '
                  f'{c["grid_voxels_in_octree"]:>16.4f} {c["grid_over_octree"]:>13.3f}')
write_json_and_csv(out, "peer_table", rows)
PY
