#!/usr/bin/env bash
# scripts/voxelize-slurm against a real Slurm (issue 35): starts munged, slurmctld and slurmd as a
# one-node cluster in a temporary directory (tests/slurm/slurm_cluster.sh), then
#   1. an array of 4 partition runs + merge of the Cornell box at depth 10, partition level 2
#      (57 partitions), and the radiance bake as its own job: the merged .esvo and the .rvol
#      equal a local voxelize build's byte for byte;
#   2. the same with run 3 killed by scancel while it runs: the merge is cancelled, no output;
#      a part with a corrupt header and one with a corrupt block; --resubmit builds only the
#      runs whose part is missing or corrupt (the block's as named by the failed merge), and
#      the merge then gives the same bytes again;
#   3. a tiled radiance bake (depth 6, tiles of 16³) as an array of 3 `--radiance-tile K/3` runs
#      and the index job after them: valid, and a one-process tiled bake's files byte for byte;
#      a tile removed, --resubmit bakes its run and the index again, and the bytes are the same.
# Usage: tests/slurm/run_slurm_test.sh [BUILD_DIR]    (default: build; LIBVOX_VOXELIZE,
# LIBVOX_VOXINSPECT and LIBVOX_MAKE_EXAMPLE_SCENE override BUILD_DIR/tools/voxelize,
# BUILD_DIR/tools/voxinspect, BUILD_DIR/examples/make_example_scene)
# Exit 0 passed, 1 failed, 77 skipped (not root, or no slurm-wlm/munge). Stops its daemons on
# exit. LIBVOX_SLURM_KEEP=1 keeps the temporary directory (logs, parts).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
# shellcheck source-path=SCRIPTDIR source=slurm_cluster.sh
source "$here/slurm_cluster.sh"
slurm_cluster_check
build=$(cd "${1:-$root/build}" && pwd)
voxelize=${LIBVOX_VOXELIZE:-$build/tools/voxelize}
voxinspect=${LIBVOX_VOXINSPECT:-$build/tools/voxinspect}
make_scene=${LIBVOX_MAKE_EXAMPLE_SCENE:-$build/examples/make_example_scene}
front=$root/scripts/voxelize-slurm
for f in "$voxelize" "$voxinspect" "$make_scene"; do
    [ -x "$f" ] || { echo "FAIL: $f not built" >&2; exit 1; }
done

tmp=$(mktemp -d /tmp/libvox-slurm-test.XXXXXX)
chmod 755 "$tmp"  # munged wants the folders above its socket open to all
cleanup() {
    slurm_cluster_stop
    if [ "${LIBVOX_SLURM_KEEP:-0}" = 1 ]; then echo "kept $tmp"; else rm -rf "$tmp"; fi
}
trap cleanup EXIT
passed=0
fail() {
    echo "FAIL: $*" >&2
    tail -n 3 "$tmp"/r*/*.log 2>/dev/null >&2 || true
    echo "slurm: $passed passed, 1 failed"
    exit 1
}
ok() { passed=$((passed + 1)); echo "ok: $*"; }
json() { python3 -c 'import json, sys; v = json.load(open(sys.argv[1]))
for k in sys.argv[2].split("."): v = v[int(k)] if isinstance(v, list) else v[k]
print(v)' "$1" "$2"; }
job() { awk -v k="$1" '$1 == k { print $2 }' <<< "$2"; }
expect_state() {  # JOB STATE
    local s
    s=$(slurm_job_state "$1")
    [ "$s" = "$2" ] || fail "job $1 is ${s:-unknown}, expected $2"
}
expect_usage_error() {  # TEXT ARGS...: exit 1 and one line naming TEXT
    local text=$1 err rc=0
    shift
    err=$("$front" "$@" 2>&1 >/dev/null) || rc=$?
    [ $rc -eq 1 ] || fail "voxelize-slurm $*: exit $rc, expected 1 ($err)"
    [ "$(wc -l <<< "$err")" -eq 1 ] && [[ $err == "voxelize-slurm: error: "*"$text"* ]] ||
        fail "voxelize-slurm $*: expected one line with '$text', got: $err"
}

start=$SECONDS
slurm_cluster_start "$tmp/cluster" || fail "the cluster did not start"
ok "one-node cluster up: $(sinfo -h -N -o '%N %c CPUs %m MB %T')"

scene=$("$make_scene" cornell-box -o "$tmp/scene")
opts=(--depth 10 --partition-level 2)
"$voxelize" "$scene" -o "$tmp/local.esvo" "${opts[@]}" --stats "$tmp/local.json" -q
"$voxelize" "$scene" --radiance "$tmp/local.rvol" --radiance-depth 6 -q
partitions=$(json "$tmp/local.json" octree.partitions)
[ "$partitions" -ge 8 ] || fail "only $partitions partitions"

# Usage errors: one line, exit 1, nothing submitted.
expect_usage_error "--runs" "$scene" -o "$tmp/u/x.esvo" --runs 0 --workdir "$tmp/u"
expect_usage_error "unknown option '--depht'" "$scene" -o "$tmp/u/x.esvo" --runs 2 --workdir "$tmp/u" --depht 10
expect_usage_error "--partition" "$scene" -o "$tmp/u/x.esvo" --runs 2 --workdir "$tmp/u" --partition 1/2
expect_usage_error ".esvo" "$scene" -o "$tmp/u/x.esvopart" --runs 2 --workdir "$tmp/u"
expect_usage_error "needs partitions" "$scene" -o "$tmp/u/x.esvo" --runs 2 --workdir "$tmp/u" --depth 9
expect_usage_error "no submission to resubmit" "$scene" -o "$tmp/u/x.esvo" --runs 2 --workdir "$tmp/u" --voxelize "$voxelize" --resubmit
[ -z "$(squeue -h -o %A)" ] || fail "a usage error submitted a job"
ok "usage errors: one line, exit 1, no job"

# --dry-run: the batch scripts, no job.
dry=$("$front" "$scene" -o "$tmp/dry/scene.esvo" --runs 4 --workdir "$tmp/dry" "${opts[@]}" --voxelize "$voxelize" \
    --radiance "$tmp/dry/scene.rvol" --bounces 1 --dry-run)
for s in parts merge radiance; do [ -x "$tmp/dry/$s.sbatch" ] || fail "--dry-run wrote no $s.sbatch"; done
grep -q -- "--array=1-4 $tmp/dry/parts.sbatch" <<< "$dry" || fail "--dry-run printed: $dry"
grep -q -- "--dependency=afterok:ARRAY_ID --kill-on-invalid-dep=yes $tmp/dry/merge.sbatch" <<< "$dry" || fail "--dry-run printed: $dry"
grep -q -- "--partition \"\$K/4\"" "$tmp/dry/parts.sbatch" || fail "parts.sbatch runs no --partition K/4"
grep -q -- "--radiance $tmp/dry/scene.rvol --bounces 1 " "$tmp/dry/radiance.sbatch" || fail "radiance.sbatch: no --radiance --bounces 1"
[ -z "$(squeue -h -o %A)" ] || fail "--dry-run submitted a job"
ok "--dry-run writes parts.sbatch, merge.sbatch, radiance.sbatch and submits nothing"

# Round 1: 4 runs + merge and the bake, against the local build.
r1=$tmp/r1
bake=(--radiance "$r1/scene.rvol" --radiance-depth 6)
ids=$("$front" "$scene" -o "$r1/scene.esvo" --runs 4 --workdir "$r1" "${opts[@]}" "${bake[@]}" --voxelize "$voxelize" --cpus-per-task 1)
array=$(job array "$ids")
merge=$(job merge "$ids")
radiance=$(job radiance "$ids")
[ -n "$array" ] && [ -n "$merge" ] && [ -n "$radiance" ] || fail "voxelize-slurm printed: $ids"
slurm_wait_gone 300 "$array" "$merge" "$radiance" || fail "round 1 did not finish"
for k in 1 2 3 4; do expect_state "${array}_$k" COMPLETED; done
expect_state "$merge" COMPLETED
expect_state "$radiance" COMPLETED
cmp "$tmp/local.esvo" "$r1/scene.esvo" || fail "round 1: the merged .esvo differs from the local build"
ok "4 runs + merge ($partitions partitions): the merged .esvo is the local build's bytes ($(stat -c %s "$r1/scene.esvo") bytes)"
cmp "$tmp/local.rvol" "$r1/scene.rvol" || fail "round 1: the .rvol differs from the local bake"
[ "$(json "$r1/radiance.stats.json" radiance.depth)" = 6 ] || fail "radiance.stats.json: no radiance depth 6"
ok "the bake as a job of its own: the local bake's bytes ($(stat -c %s "$r1/scene.rvol") bytes), its stats beside"
built=0
for k in 1 2 3 4; do
    [ "$(json "$r1/part-$k.stats.json" octree.partition.run)/$(json "$r1/part-$k.stats.json" octree.partition.runs)" = "$k/4" ] ||
        fail "part-$k.stats.json is not run $k/4"
    built=$((built + $(json "$r1/part-$k.stats.json" octree.partitions_built)))
    grep -q "^voxelize-slurm: run $k/4 exit 0; start " "$r1/part-$k.log" || fail "part-$k.log has no exit line"
done
[ "$built" -eq "$partitions" ] || fail "the runs built $built partitions of $partitions"
[ "$(json "$r1/merge.stats.json" octree.file_bytes)" -eq "$(stat -c %s "$tmp/local.esvo")" ] || fail "merge.stats.json file_bytes"
ok "each run's --stats and log beside its part; the runs built the $partitions partitions once each"
again=$("$front" "$scene" -o "$r1/scene.esvo" --runs 4 --workdir "$r1" "${opts[@]}" "${bake[@]}" --voxelize "$voxelize" --resubmit)
[[ $again == *"nothing to resubmit"* ]] || fail "--resubmit of a complete build printed: $again"
expect_usage_error "already holds a submission" "$scene" -o "$r1/scene.esvo" --runs 4 --workdir "$r1" "${opts[@]}" "${bake[@]}" --voxelize "$voxelize"
expect_usage_error "differs from the submission" "$scene" -o "$r1/scene.esvo" --runs 4 --workdir "$r1" --depth 11 "${bake[@]}" --voxelize "$voxelize" --resubmit
ok "--resubmit of a complete build submits nothing; other options or a second submission are refused"

# Round 2: run 3 is held (the real voxelize, started late) and cancelled while it runs.
r2=$tmp/r2
mkdir -p "$r2"
cat >"$tmp/slow-voxelize" <<EOF
#!/bin/bash
# The real voxelize; run 3 of the array waits first, so that the test can scancel it running.
if [ "\${SLURM_ARRAY_TASK_ID:-}" = 3 ]; then touch "$r2/run3.started"; sleep 600; fi
exec "$voxelize" "\$@"
EOF
chmod +x "$tmp/slow-voxelize"
ids=$("$front" "$scene" -o "$r2/scene.esvo" --runs 4 --workdir "$r2" "${opts[@]}" --voxelize "$tmp/slow-voxelize")
array=$(job array "$ids")
merge=$(job merge "$ids")
for _ in $(seq 300); do [ -e "$r2/run3.started" ] && break; sleep 0.2; done
[ -e "$r2/run3.started" ] || fail "run 3 did not start"
expect_state "${array}_3" RUNNING
expect_usage_error "still queued" "$scene" -o "$r2/scene.esvo" --runs 4 --workdir "$r2" "${opts[@]}" --voxelize "$voxelize" --resubmit
scancel "${array}_3"
slurm_wait_gone 120 "$array" "$merge" || fail "round 2 did not finish"
expect_state "${array}_3" CANCELLED
for k in 1 2 4; do expect_state "${array}_$k" COMPLETED; done
expect_state "$merge" CANCELLED
[ ! -e "$r2/scene.esvo" ] && [ ! -e "$r2/merge.log" ] && [ ! -e "$r2/part-3.esvopart" ] ||
    fail "the merge ran, or run 3 left a part"
ok "run 3 cancelled while running: the merge is cancelled (never pending), no output"

# A part with a corrupt header (found by voxelize-slurm) and one with a corrupt block (found by
# the merge, which names it).
python3 - "$r2/part-2.esvopart" "$r2/part-4.esvopart" <<'PY'
import sys
for path, at in ((sys.argv[1], 100), (sys.argv[2], None)):
    data = bytearray(open(path, "rb").read())
    at = len(data) // 2 if at is None else at
    data[at] ^= 1
    open(path, "wb").write(data)
PY
part1=$(sha256sum < "$r2/part-1.esvopart")
ids=$("$front" "$scene" -o "$r2/scene.esvo" --runs 4 --workdir "$r2" "${opts[@]}" --voxelize "$voxelize" --resubmit)
array=$(job array "$ids")
merge=$(job merge "$ids")
[ "$(json "$r2/voxelize-slurm.json" submissions.-1.runs)" = 2-3 ] ||
    fail "--resubmit resubmitted runs other than 2-3"
slurm_wait_gone 120 "$array" "$merge" || fail "the resubmission did not finish"
for k in 2 3; do expect_state "${array}_$k" COMPLETED; done
expect_state "$merge" FAILED
grep -q "^voxelize: error: $r2/part-4.esvopart: " "$r2/merge.log" || fail "the merge did not name part-4: $(cat "$r2/merge.log")"
[ ! -e "$r2/scene.esvo" ] || fail "a failed merge left an output"
ok "--resubmit built runs 2-3 only (part-3 missing, part-2's header corrupt); the merge refused part-4 by name"

ids=$("$front" "$scene" -o "$r2/scene.esvo" --runs 4 --workdir "$r2" "${opts[@]}" --voxelize "$voxelize" --resubmit)
array=$(job array "$ids")
merge=$(job merge "$ids")
[ "$(json "$r2/voxelize-slurm.json" submissions.-1.runs)" = 4 ] ||
    fail "the second --resubmit resubmitted runs other than 4"
slurm_wait_gone 120 "$array" "$merge" || fail "the second resubmission did not finish"
expect_state "${array}_4" COMPLETED
expect_state "$merge" COMPLETED
cmp "$tmp/local.esvo" "$r2/scene.esvo" || fail "round 2: the merged .esvo differs from the local build"
[ "$(sha256sum < "$r2/part-1.esvopart")" = "$part1" ] || fail "part-1 was rebuilt"
ok "the second --resubmit built run 4 only (named by the merge); the merge gives the local build's bytes again"
again=$("$front" "$scene" -o "$r2/scene.esvo" --runs 4 --workdir "$r2" "${opts[@]}" --voxelize "$voxelize" --resubmit)
[[ $again == *"nothing to resubmit"* ]] || fail "a third --resubmit printed: $again"
ok "a third --resubmit finds nothing to do"

# Round 3: a tiled bake as an array of tile runs and the index job after them.
rt=$tmp/rt
mkdir -p "$rt"
tiling=(--radiance-depth 6 --radiance-tile-depth 4 --bounces 1)
"$voxelize" "$scene" --radiance "$tmp/local-tiled.rvol" "${tiling[@]}" -q
same_tiled_bake() {  # the index, the far field and every tile: the one-process bake's bytes
    cmp "$tmp/local-tiled.rvol" "$rt/scene.rvol" || fail "$1: the tile index differs from the local bake's"
    [ "$(ls "$tmp/local-tiled.rvol.tiles")" = "$(ls "$rt/scene.rvol.tiles")" ] || fail "$1: other tile files than the local bake's"
    for f in "$tmp/local-tiled.rvol.tiles"/*; do
        cmp "$f" "$rt/scene.rvol.tiles/$(basename "$f")" || fail "$1: $(basename "$f") differs from the local bake's"
    done
}
tiled_ids() { "$front" "$scene" --workdir "$rt" --radiance "$rt/scene.rvol" "${tiling[@]}" --radiance-runs 3 --voxelize "$voxelize" "$@"; }
ids=$(tiled_ids)
tiles=$(job radiance-tiles "$ids")
index=$(job radiance-index "$ids")
[ -n "$tiles" ] && [ -n "$index" ] || fail "voxelize-slurm printed: $ids"
slurm_wait_gone 300 "$tiles" "$index" || fail "round 3 did not finish"
for k in 1 2 3; do
    expect_state "${tiles}_$k" COMPLETED
    grep -q "^voxelize-slurm: radiance run $k/3 exit 0; start " "$rt/radiance-tile-$k.log" || fail "radiance-tile-$k.log has no exit line"
    [ "$(json "$rt/radiance-tile-$k.stats.json" radiance.run.run)" = "$k" ] || fail "radiance-tile-$k.stats.json is not run $k"
done
expect_state "$index" COMPLETED
grep -q "^voxelize-slurm: radiance index exit 0; start " "$rt/radiance-index.log" || fail "radiance-index.log has no exit line"
"$voxinspect" validate "$rt/scene.rvol" -q || fail "round 3: voxinspect validate refused the tiled bake"
same_tiled_bake "round 3"
ok "a tiled bake as 3 tile runs + the index job: valid, the one-process bake's $(ls "$rt/scene.rvol.tiles" | wc -l) files byte for byte"

# A tile of run 2 removed: --resubmit bakes run 2 and the index again.
tile=$(json "$rt/radiance-tile-2.stats.json" radiance.tile_files.0.file)
rm "$rt/scene.rvol.tiles/$tile"
ids=$(tiled_ids --resubmit)
tiles=$(job radiance-tiles "$ids")
index=$(job radiance-index "$ids")
[ "$(json "$rt/voxelize-slurm.json" submissions.-1.radiance_runs)" = 2 ] || fail "--resubmit resubmitted tile runs other than 2"
slurm_wait_gone 300 "$tiles" "$index" || fail "the tiled resubmission did not finish"
expect_state "${tiles}_2" COMPLETED
expect_state "$index" COMPLETED
same_tiled_bake "after --resubmit"
again=$(tiled_ids --resubmit)
[[ $again == *"nothing to resubmit"* ]] || fail "--resubmit of a complete tiled bake printed: $again"
ok "$tile removed: --resubmit baked run 2 and the index again, the same bytes; then nothing to resubmit"

echo "slurm test: $((SECONDS - start)) s"
echo "slurm: $passed passed, 0 failed"
