#!/usr/bin/env bash
# Partitioned builds through Slurm (issue 35): the 1,048,576-triangle bumpy sphere at depth 13
# built by scripts/voxelize-slurm as arrays of N = 1, 2, 4, 8 runs (+ merge) on a real one-node
# Slurm cluster started here (tests/slurm/slurm_cluster.sh: CPUs = the machine's cores, one CPU
# and one thread per run), against one local build with every core. For each N: the array's wall
# time (submission to the last run's end), the runs' CPU time summed (user + sys, from each run's
# log), their peak RSS (--stats peak_rss_bytes, smallest and largest), the merge's wall time, the
# total (submission to the merge's end), and whether the .esvo's SHA-256 equals the local build's.
# Usage: bench/slurm_table.sh [BUILD_DIR] [N...]     (default: build 1 2 4 8); needs root and
# slurm-wlm + munge (scripts/install-deps.sh). Environment: DEPTH (default 13); MESH (default:
# the bumpy sphere); VOXELIZE_ARGS: extra voxelize options for every build.
# Outputs: BUILD_DIR/bench/slurm/slurm_table.{json,csv}, each N's work directory beside them.
set -euo pipefail
build=$(cd "${1:-build}" && pwd)
shift || true
runs=("$@")
[ ${#runs[@]} -gt 0 ] || runs=(1 2 4 8)
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/.." && pwd)
depth=${DEPTH:-13}
# shellcheck source-path=SCRIPTDIR source=../tests/slurm/slurm_cluster.sh
source "$root/tests/slurm/slurm_cluster.sh"
slurm_cluster_check
out=$build/bench/slurm
rm -rf "$out"
mkdir -p "$out"
chmod 755 "$out"  # munged wants the folders above its socket open to all
mesh=${MESH:-}
if [ -z "$mesh" ]; then
    "$build/examples/make_example_scene" bumpy-sphere -o "$out" >/dev/null
    mesh=$out/bumpy_sphere.glb
fi
read -r -a extra <<< "${VOXELIZE_ARGS:-}"
# A copy of voxelize, so that a rebuild of BUILD_DIR during the runs changes nothing.
cp "$build/tools/voxelize" "$out/voxelize"
echo "slurm_table: $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg); $mesh depth $depth; runs ${runs[*]}; voxelize options: ${VOXELIZE_ARGS:-(defaults)}" >&2

python3 "$here/measure.py" "$out/local.time.json" -- \
    "$out/voxelize" "$mesh" -o "$out/local.esvo" --depth "$depth" --stats "$out/local.json" -q "${extra[@]}"

trap slurm_cluster_stop EXIT
slurm_cluster_start "$out/cluster"
for n in "${runs[@]}"; do
    dir=$out/runs-$n
    ids=$("$root/scripts/voxelize-slurm" "$mesh" -o "$dir/sphere.esvo" --runs "$n" --workdir "$dir" --depth "$depth" \
        --cpus-per-task 1 --voxelize "$out/voxelize" -q "${extra[@]}")
    # shellcheck disable=SC2046
    slurm_wait_gone 7200 $(awk '{ print $2 }' <<< "$ids")
    [ -f "$dir/sphere.esvo" ] || { echo "slurm_table: N=$n left no output; logs in $dir" >&2; exit 1; }
done
slurm_cluster_stop
echo "slurm_table: load at the end $(cut -d' ' -f1-3 /proc/loadavg)" >&2

PYTHONPATH=$here python3 - "$out" "$mesh" "$depth" "${runs[@]}" <<'PY'
import hashlib, json, os, re, sys
from tables import write_json_and_csv
out, mesh, depth, runs = sys.argv[1], sys.argv[2], int(sys.argv[3]), [int(n) for n in sys.argv[4:]]

def sha(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()

def exit_line(log):
    for line in open(log):
        m = re.match(r"voxelize-slurm: .* exit (\d+); start ([\d.]+) end ([\d.]+); wall ([\d.]+) user ([\d.]+) sys ([\d.]+)", line)
        if m:
            rc, start, end, wall, user, sys_ = m.groups()
            return {"exit": int(rc), "start": float(start), "end": float(end), "wall": float(wall),
                    "cpu": float(user) + float(sys_)}
    raise SystemExit(f"{log}: no exit line")

local = json.load(open(f"{out}/local.json"))
local_time = json.load(open(f"{out}/local.time.json"))
reference = sha(f"{out}/local.esvo")
rows = []
for n in runs:
    d = f"{out}/runs-{n}"
    submitted = json.load(open(f"{d}/voxelize-slurm.json"))["submissions"][0]["time"]
    tasks = [exit_line(f"{d}/part-{k}.log") for k in range(1, n + 1)]
    rss = [json.load(open(f"{d}/part-{k}.stats.json"))["peak_rss_bytes"] for k in range(1, n + 1)]
    merge = exit_line(f"{d}/merge.log") if n > 1 else None
    last = max(t["end"] for t in tasks)
    digest = sha(f"{d}/sphere.esvo")
    rows.append({"runs": n, "array_seconds": last - submitted, "cpu_seconds": sum(t["cpu"] for t in tasks),
                 "run_seconds_max": max(t["wall"] for t in tasks),
                 "peak_rss_mb_min": min(rss) / 2**20, "peak_rss_mb_max": max(rss) / 2**20,
                 "merge_seconds": merge["wall"] if merge else 0.0,
                 "merge_peak_rss_mb": json.load(open(f"{d}/merge.stats.json"))["peak_rss_bytes"] / 2**20 if merge else 0.0,
                 "total_seconds": (merge["end"] if merge else last) - submitted,
                 "sha256": digest, "same_bytes": digest == reference})
o = local["octree"]
print(f"{os.path.basename(mesh)}, {local['triangles']} triangles, depth {depth}: {o['partitions']} partitions at level "
      f"{o['partition_level']}, {o['file_bytes']} bytes, sha256 {reference[:16]}")
print(f"local build, {local['threads']} threads: {local_time['wall_seconds']:.1f} s wall, "
      f"{local_time['cpu_seconds']:.1f} s CPU, peak RSS {local['peak_rss_bytes'] / 2**20:.0f} MB")
print(f"{'runs':>4} {'array_s':>8} {'cpu_s':>7} {'run_s_max':>9} {'rss_MB_min':>10} {'rss_MB_max':>10} "
      f"{'merge_s':>7} {'merge_MB':>8} {'total_s':>7}  same bytes")
for r in rows:
    merge_s = f"{r['merge_seconds']:7.1f}" if r["runs"] > 1 else f"{'-':>7}"
    merge_mb = f"{r['merge_peak_rss_mb']:8.0f}" if r["runs"] > 1 else f"{'-':>8}"
    print(f"{r['runs']:4d} {r['array_seconds']:8.1f} {r['cpu_seconds']:7.1f} {r['run_seconds_max']:9.1f} "
          f"{r['peak_rss_mb_min']:10.0f} {r['peak_rss_mb_max']:10.0f} {merge_s} {merge_mb} {r['total_seconds']:7.1f}  "
          f"{'yes' if r['same_bytes'] else 'NO'}")
write_json_and_csv(out, "slurm_table", rows)
PY
