#!/usr/bin/env bash
# Cost growth of the octree build with depth (issue 9): for the 1,048,576-triangle bumpy sphere,
# the default full build (contours, dxt colours and normals, .esvo written) at every depth from
# MIN to MAX, each in its own process (REPEAT times, medians): voxels, build seconds, whole-process
# CPU seconds, peak RSS and file size. Then the least-squares slope of log2 of each against the
# depth: the per-level growth factor 2^slope. A surface has 4× the voxels per level (slope 2);
# time and memory should follow. The fit over the last three depths is printed too: fixed costs
# (the import, the mesh in memory) flatten the slope at shallow depths.
# Usage: bench/cost_growth.sh [BUILD_DIR] [MIN_DEPTH] [MAX_DEPTH]     (default: build 8 14)
# Environment: REPEAT (default 1); THREADS (default: all cores); MESH (default: the bumpy
# sphere); VOXELIZE_ARGS: extra voxelize options, passed as given (depths 13 and 14 need the
# out-of-core build, e.g. VOXELIZE_ARGS="--memory-limit 8G").
# Outputs: build/bench/growth/cost_growth.{json,csv} and every run's stats beside them.
set -euo pipefail
build=${1:-build}
min=${2:-8}
max=${3:-14}
repeat=${REPEAT:-1}
here=$(cd "$(dirname "$0")" && pwd)
out=$build/bench/growth
mkdir -p "$out/runs"
rm -f "$out"/runs/*.json
threads=()
[ -z "${THREADS:-}" ] || threads=(--threads "$THREADS")
mesh=${MESH:-}
if [ -z "$mesh" ]; then
    "$build/examples/make_example_scene" bumpy-sphere -o "$out" >/dev/null
    mesh=$out/bumpy_sphere.glb
fi
echo "cost_growth: $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg); $mesh depths $min..$max; threads ${THREADS:-all}; REPEAT=$repeat; voxelize options: ${VOXELIZE_ARGS:-(defaults)}" >&2
for ((d = min; d <= max; ++d)); do
    for ((r = 1; r <= repeat; ++r)); do
        # shellcheck disable=SC2086
        python3 "$here/measure.py" "$out/runs/$d-$r.time.json" -- \
            "$build/tools/voxelize" "$mesh" -o "$out/growth.esvo" --depth "$d" --stats "$out/runs/$d-$r.json" -q "${threads[@]}" ${VOXELIZE_ARGS:-}
    done
    rm -f "$out/growth.esvo"
done
python3 - "$out" "$min" "$max" "$repeat" <<'PY'
import csv, json, math, statistics, sys
out, lo, hi, repeat = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
MB = 2**20
rows = []
for d in range(lo, hi + 1):
    runs = [(json.load(open(f"{out}/runs/{d}-{r}.json")), json.load(open(f"{out}/runs/{d}-{r}.time.json"))) for r in range(1, repeat + 1)]
    s = runs[0][0]
    rows.append({"depth": d, "voxels": s["octree"]["voxels"], "leaves": s["octree"]["voxels_per_level"][-1],
                 "build_seconds": statistics.median(x[0]["octree"]["build_seconds"] for x in runs),
                 "voxelize_seconds": statistics.median(x[0]["octree"]["voxelize_seconds"] for x in runs),
                 "cpu_seconds": statistics.median(x[1]["cpu_seconds"] for x in runs),
                 "wall_seconds": statistics.median(x[1]["wall_seconds"] for x in runs),
                 "peak_rss_bytes": statistics.median(x[0]["peak_rss_bytes"] for x in runs),
                 "file_bytes": s["octree"]["file_bytes"], "threads": s["threads"]})
def slope(key, subset):
    xs = [r["depth"] for r in subset]
    ys = [math.log2(r[key]) for r in subset]
    if len(xs) < 2:
        return float("nan")
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    return sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sum((x - mx) ** 2 for x in xs)
print(f'{"depth":>5} {"voxels":>11} {"leaves":>11} {"build_s":>8} {"cpu_s":>8} {"RSS_MB":>8} {"file_MB":>8} {"x_voxels":>8} {"x_build":>8} {"x_RSS":>8}')
for i, r in enumerate(rows):
    prev = rows[i - 1] if i else None
    f = lambda k: f'{r[k] / prev[k]:>8.2f}' if prev else f'{"":>8}'
    print(f'{r["depth"]:>5} {r["voxels"]:>11} {r["leaves"]:>11} {r["build_seconds"]:>8.3f} {r["cpu_seconds"]:>8.2f} {r["peak_rss_bytes"]/MB:>8.0f} '
          f'{r["file_bytes"]/MB:>8.1f} {f("voxels")} {f("build_seconds")} {f("peak_rss_bytes")}')
fits = {}
for label, subset in (("all", rows), ("last3", rows[-3:])) if len(rows) > 3 else (("all", rows),):
    fits[label] = {k: slope(k, subset) for k in ("voxels", "build_seconds", "cpu_seconds", "peak_rss_bytes", "file_bytes")}
    span = f'{subset[0]["depth"]}..{subset[-1]["depth"]}'
    print(f'fit {span:>6} (log2 slope per level, factor 2^slope): ' +
          ", ".join(f'{k} {v:.2f} (x{2**v:.2f})' for k, v in fits[label].items()))
print(f'threads {rows[0]["threads"]}; medians of {repeat}; build_s: octree.build_seconds (no import); cpu_s, RSS: the whole process; '
      'a surface: slope 2 (x4 per level)')
json.dump({"rows": rows, "fits": fits}, open(f"{out}/cost_growth.json", "w"), indent=2)
with open(f"{out}/cost_growth.csv", "w", newline="") as f:
    w = csv.DictWriter(f, fieldnames=list(rows[0]))
    w.writeheader()
    w.writerows(rows)
print(f"JSON and CSV: {out}/cost_growth.json, {out}/cost_growth.csv")
PY
