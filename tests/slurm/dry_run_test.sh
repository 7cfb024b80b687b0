#!/usr/bin/env bash
# scripts/voxelize-slurm without Slurm (in the default suite; run_slurm_test.sh submits for real):
#   1. --dry-run of an octree build and a tiled radiance bake prints the parts array, the merge,
#      the array of M `--radiance-tile K/M` runs and the `--radiance-tile index` job after them,
#      and writes their batch scripts; a single bake, and a tiled one of one run, is one job;
#   2. the tiled bake's batch scripts, run outside Slurm as docs/distributed.md says they can be,
#      write the files of a one-process tiled bake byte for byte, and they validate;
#   3. --resubmit --dry-run picks the runs whose tiles are missing or whose header is corrupt
#      (from each run's --stats tile_files), then the index job; nothing when all is there.
# Usage: tests/slurm/dry_run_test.sh VOXELIZE VOXINSPECT MAKE_EXAMPLE_SCENE. Exit 0 passed, 1 failed.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
front=$here/../../scripts/voxelize-slurm
voxelize=$1 voxinspect=$2 make_scene=$3
tmp=$(mktemp -d /tmp/libvox-slurm-dry.XXXXXX)
trap 'rm -rf "$tmp"' EXIT
passed=0
fail() {
    echo "FAIL: $*" >&2
    echo "slurm dry run: $passed passed, 1 failed"
    exit 1
}
ok() { passed=$((passed + 1)); echo "ok: $*"; }
expect_lines() {  # OUTPUT LINE...: OUTPUT is exactly these lines
    local out=$1
    shift
    [ "$out" = "$(printf '%s\n' "$@")" ] || fail "expected:
$(printf '%s\n' "$@")
got:
$out"
}
expect_usage_error() {  # TEXT ARGS...: exit 1 and one line naming TEXT
    local text=$1 err rc=0
    shift
    err=$("$front" "$@" 2>&1 >/dev/null) || rc=$?
    [ $rc -eq 1 ] && [ "$(wc -l <<< "$err")" -eq 1 ] && [[ $err == "voxelize-slurm: error: "*"$text"* ]] ||
        fail "voxelize-slurm $*: exit $rc, expected 1 and one line with '$text': $err"
}

scene=$("$make_scene" cornell-box -o "$tmp/scene")
mkdir -p "$tmp/out"
w=$tmp/w
tiled=(--radiance "$tmp/out/tiled.rvol" --radiance-depth 5 --radiance-tile-depth 3 --bounces 1)
out=$("$front" "$scene" -o "$tmp/out/scene.esvo" --runs 4 --workdir "$w" --depth 10 --partition-level 2 \
    "${tiled[@]}" --radiance-runs 3 --voxelize "$voxelize" --dry-run)
expect_lines "$out" \
    "sbatch --parsable --array=1-4 $w/parts.sbatch" \
    "sbatch --parsable --dependency=afterok:ARRAY_ID --kill-on-invalid-dep=yes $w/merge.sbatch" \
    "sbatch --parsable --array=1-3 $w/radiance-tiles.sbatch" \
    "sbatch --parsable --dependency=afterok:RADIANCE_TILES_ID --kill-on-invalid-dep=yes $w/radiance-index.sbatch"
for s in parts merge radiance-tiles radiance-index; do [ -x "$w/$s.sbatch" ] || fail "no $s.sbatch"; done
[ ! -e "$w/radiance.sbatch" ] || fail "a tiled bake of 3 runs wrote radiance.sbatch"
grep -q -- "^#SBATCH --output=$w/radiance-tile-%a.log$" "$w/radiance-tiles.sbatch" || fail "radiance-tiles.sbatch: no log per run"
grep -q -- "--radiance-tile-depth 3 --bounces 1 --threads 1 --radiance-tile \"\$K/3\" --stats \"\$DIR/radiance-tile-\$K.stats.json\")$" \
    "$w/radiance-tiles.sbatch" || fail "radiance-tiles.sbatch: $(grep '^cmd=' "$w/radiance-tiles.sbatch")"
grep -q -- "--radiance-tile index --stats \"\$DIR/radiance-index.stats.json\")$" "$w/radiance-index.sbatch" ||
    fail "radiance-index.sbatch: $(grep '^cmd=' "$w/radiance-index.sbatch")"
ok "--dry-run: the parts array and merge, the array of 3 tile runs and the index job after it"

out=$("$front" "$scene" --workdir "$tmp/w4" --radiance "$tmp/out/deep.rvol" --radiance-depth 11 --voxelize "$voxelize" --dry-run)
expect_lines "$out" "sbatch --parsable --array=1-4 $tmp/w4/radiance-tiles.sbatch" \
    "sbatch --parsable --dependency=afterok:RADIANCE_TILES_ID --kill-on-invalid-dep=yes $tmp/w4/radiance-index.sbatch"
out=$("$front" "$scene" --workdir "$tmp/w1" "${tiled[@]}" --radiance-runs 1 --voxelize "$voxelize" --dry-run)
expect_lines "$out" "sbatch --parsable $tmp/w1/radiance.sbatch"
! grep -q -- "--radiance-tile " "$tmp/w1/radiance.sbatch" || fail "one run of a tiled bake got --radiance-tile"
out=$("$front" "$scene" --workdir "$tmp/ws" --radiance "$tmp/out/single.rvol" --radiance-depth 6 --voxelize "$voxelize" --dry-run)
expect_lines "$out" "sbatch --parsable $tmp/ws/radiance.sbatch"
expect_usage_error "--radiance-runs needs a tiled bake" "$scene" --workdir "$tmp/u" --radiance "$tmp/out/u.rvol" --radiance-runs 2
expect_usage_error "--radiance-runs: '0'" "$scene" --workdir "$tmp/u" "${tiled[@]}" --radiance-runs 0
expect_usage_error "--radiance-tile: " "$scene" --workdir "$tmp/u" "${tiled[@]}" --radiance-tile 1/2
expect_usage_error "--radiance-runs needs --radiance" "$scene" -o "$tmp/out/u.esvo" --runs 1 --workdir "$tmp/u" --radiance-runs 2
ok "4 runs by default from --radiance-depth 11; one job for one run or a single volume; usage errors"

# The batch scripts outside Slurm: each run, then the index.
rw=$tmp/rw
"$front" "$scene" --workdir "$rw" "${tiled[@]}" --radiance-runs 3 --voxelize "$voxelize" --dry-run >/dev/null
for k in 1 2 3; do
    SLURM_ARRAY_TASK_ID=$k bash "$rw/radiance-tiles.sbatch" >"$rw/radiance-tile-$k.log" 2>&1 || fail "run $k: $(tail -n 3 "$rw/radiance-tile-$k.log")"
    grep -q "^voxelize-slurm: radiance run $k/3 exit 0; start " "$rw/radiance-tile-$k.log" || fail "radiance-tile-$k.log has no exit line"
done
bash "$rw/radiance-index.sbatch" >"$rw/radiance-index.log" 2>&1 || fail "index: $(tail -n 3 "$rw/radiance-index.log")"
"$voxelize" "$scene" --radiance "$tmp/local.rvol" --radiance-depth 5 --radiance-tile-depth 3 --bounces 1 -q
cmp "$tmp/local.rvol" "$tmp/out/tiled.rvol" || fail "the index differs from a one-process bake's"
tiles=0
for f in "$tmp/local.rvol.tiles"/*.rvol; do
    cmp "$f" "$tmp/out/tiled.rvol.tiles/$(basename "$f")" || fail "$(basename "$f") differs from a one-process bake's"
    tiles=$((tiles + 1))
done
[ "$(ls "$tmp/out/tiled.rvol.tiles" | wc -l)" -eq "$tiles" ] || fail "the runs wrote other files than the one-process bake"
"$voxinspect" validate "$tmp/out/tiled.rvol" -q || fail "voxinspect validate"
ok "3 runs and the index outside Slurm: a one-process bake's $tiles files byte for byte, valid"

resubmit() { "$front" "$scene" --workdir "$rw" "${tiled[@]}" --radiance-runs 3 --voxelize "$voxelize" --resubmit --dry-run; }
out=$(resubmit)
[[ $out == *"nothing to resubmit"* ]] || fail "--resubmit of a complete bake printed: $out"
tile_of() { python3 -c 'import json, sys
print(json.load(open(sys.argv[1]))["radiance"]["tile_files"][0]["file"])' "$rw/radiance-tile-$1.stats.json"; }
rm "$tmp/out/tiled.rvol.tiles/$(tile_of 2)"
python3 - "$tmp/out/tiled.rvol.tiles/$(tile_of 3)" <<'PY'
import sys
data = bytearray(open(sys.argv[1], "rb").read())
data[20] ^= 1  # inside the header: its checksum no longer matches
open(sys.argv[1], "wb").write(data)
PY
expect_lines "$(resubmit)" "sbatch --parsable --array=2-3 $rw/radiance-tiles.sbatch" \
    "sbatch --parsable --dependency=afterok:RADIANCE_TILES_ID --kill-on-invalid-dep=yes $rw/radiance-index.sbatch"
ok "--resubmit: nothing when complete; runs 2-3 (a tile missing, a tile's header corrupt), then the index"
echo "slurm dry run: $passed passed, 0 failed"
