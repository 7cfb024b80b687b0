#!/usr/bin/env bash
# Prints the SHA-256 of every file the tools write on the example scenes, one line per file, so
# that a change meant to alter no output (a refactoring, a build-system change) can be checked:
#   bench/output_digests.sh BUILD_DIR > before.txt   (on the old commit)
#   bench/output_digests.sh BUILD_DIR > after.txt    (on the new one);  diff before.txt after.txt
# Covers voxelize (default, --full-refinement, --no-contours, --attributes raw and dxt-lookup,
# partitions + merge, radiance), voxinspect render (esvo channels, rvol final gather, depth PFM),
# voxinspect dump/info/sample, and voxview's headless GPU render where EGL is available.
set -euo pipefail
build=${1:-build}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
vz="$build/tools/voxelize"
vi="$build/tools/voxinspect"

cornell=$("$build/examples/make_example_scene" cornell-box -o "$work/cornell")
bumpy=$("$build/examples/make_example_scene" bumpy-sphere -o "$work/bumpy")
lights=$("$build/examples/make_example_scene" light-grid -o "$work/lights")

run() { "$@" -q >/dev/null; }
view=(--eye 0,1,3.4 --target 0,1,0 --fov 45 --width 160 --height 160)

run "$vz" "$cornell" -o "$work/c_default.esvo" --depth 9
run "$vz" "$cornell" -o "$work/c_full.esvo" --depth 9 --full-refinement
run "$vz" "$cornell" -o "$work/c_cubes.esvo" --depth 8 --no-contours
run "$vz" "$cornell" -o "$work/c_raw.esvo" --depth 9 --attributes raw
run "$vz" "$cornell" -o "$work/c_lookup.esvo" --depth 9 --attributes dxt-lookup
run "$vz" "$bumpy" -o "$work/b_default.esvo" --depth 10
for k in 1 2 3; do
  run "$vz" "$bumpy" --depth 10 --partition "$k/3" -o "$work/b_part$k.esvopart"
done
run "$vz" merge "$work"/b_part*.esvopart -o "$work/b_merged.esvo"
run "$vz" "$cornell" -o "$work/c_rad.esvo" --depth 8 --radiance "$work/c.rvol" --radiance-depth 6
run "$vz" "$lights" -o "$work/l.esvo" --depth 8 --radiance "$work/l.rvol" --radiance-depth 6

for ch in color normal shaded depth; do
  run "$vi" render "$work/c_default.esvo" -o "$work/render_$ch.png" --channel "$ch" "${view[@]}"
done
run "$vi" render "$work/c_full.esvo" -o "$work/render_full.png" --channel shaded "${view[@]}" \
  --depth-out "$work/render_full.pfm"
run "$vi" render "$work/c.rvol" --scene "$cornell" -o "$work/render_gi.png" "${view[@]}"
"$vi" info "$work/c_default.esvo" > "$work/info_esvo.txt"
"$vi" info "$work/c.rvol" > "$work/info_rvol.txt"
"$vi" dump "$work/c_default.esvo" > "$work/dump_esvo.txt"
"$vi" sample "$work/c.rvol" --at 0,1,0 > "$work/sample.txt"
if [ -x "$build/examples/voxview" ] &&
   "$build/examples/voxview" "$work/c_default.esvo" --rvol "$work/c.rvol" --scene "$cornell" \
     --headless -o "$work/voxview.png" "${view[@]}" >/dev/null 2>&1; then :; fi

cd "$work"
sed -i "s|$work|WORK|g" ./*.txt  # the temporary directory's name is not output
find . -maxdepth 1 -type f \( -name '*.esvo' -o -name '*.esvopart' -o -name '*.rvol' \
  -o -name '*.png' -o -name '*.pfm' -o -name '*.txt' \) -print0 | sort -z | xargs -0 sha256sum
