#!/usr/bin/env bash
# The OpenGL runtime's speed through voxview (issue 33): primary-ray Mrays/s of the compute-shader
# ray caster and the final gather's ms per frame, on the example scene (the Cornell box of
# scripts/run-example.sh: voxelize --depth DEPTH with its .rvol radiance volume), its camera
# (eye 0,1,3.4, target 0,1,0, fov 45), at 1920x1080 by default. Two measurements, each
# `voxview --benchmark FRAMES` (FRAMES timed frames after one warm-up, medians):
#   primary_rays: the depth channel (no attributes): Mrays/s of the cast;
#   final_gather: the final channel (--rvol, lights from --scene): the cast with attributes, then
#                 the cone-traced final gather at every hit; its ms per frame.
# Times are the GPU's GL_TIME_ELAPSED, or the wall clock (dispatch to glFinish) where that timer
# reads ~0, as on llvmpipe; each line says which ("timer"). Prints one JSON line per measurement,
# with the GL_RENDERER, GL_VENDOR and EGL platform it ran on, and a summary on stderr. Fails (exit
# 1) on GL errors or a measurement without hits. Runs on Mesa's llvmpipe in CI at a tiny size
# (tests/CMakeLists.txt: gpu_bench_llvmpipe); on a machine with an NVIDIA GPU voxview takes the
# EGL device platform first (--egl-platform auto).
# Usage: bench/gpu_bench.sh [BUILD_DIR] [--size WxH] [--frames N] [--depth D] [--radiance-depth R]
#                           [--egl-platform auto|device|surfaceless|default] [--out DIR]
#   defaults: build, 1920x1080, 10 frames, depth 10, radiance depth 8 (voxelize's), auto,
#   BUILD_DIR/bench/gpu. The octree and volume are kept in DIR and rebuilt only when missing.
set -euo pipefail
build=build
if [ $# -gt 0 ] && [ "${1#--}" = "$1" ]; then build=$1; shift; fi
size=1920x1080 frames=10 depth=10 radiance_depth=8 platform=auto out=
while [ $# -gt 0 ]; do
    [ $# -ge 2 ] || { echo "gpu_bench: $1 needs a value" >&2; exit 1; }
    case $1 in
        --size) size=$2 ;;
        --frames) frames=$2 ;;
        --depth) depth=$2 ;;
        --radiance-depth) radiance_depth=$2 ;;
        --egl-platform) platform=$2 ;;
        --out) out=$2 ;;
        *) echo "gpu_bench: unknown option $1 (see the header of $0)" >&2; exit 1 ;;
    esac
    shift 2
done
[[ $size =~ ^[0-9]+x[0-9]+$ ]] || { echo "gpu_bench: --size must be WxH (got $size)" >&2; exit 1; }
width=${size%x*}
height=${size#*x}
out=${out:-$build/bench/gpu}
mkdir -p "$out"

scene=$("$build/examples/make_example_scene" cornell-box -o "$out/scene")
esvo=$out/cornell_box-d$depth.esvo
rvol=$out/cornell_box-d$depth-r$radiance_depth.rvol
if [ ! -s "$esvo" ] || [ ! -s "$rvol" ]; then
    "$build/tools/voxelize" "$scene" -o "$esvo" --depth "$depth" --radiance "$rvol" --radiance-depth "$radiance_depth" -q
fi
camera=(--eye "0,1,3.4" --target "0,1,0" --fov 45 --width "$width" --height "$height")
voxview=("$build/examples/voxview" "$esvo" --benchmark "$frames" --egl-platform "$platform" -q "${camera[@]}")

"${voxview[@]}" --channel depth > "$out/primary_rays.json"
"${voxview[@]}" --rvol "$rvol" --scene "$scene" --channel final > "$out/final_gather.json"

python3 - "$out" "$depth" "$radiance_depth" <<'PY'
import json, sys
out, depth, radiance_depth = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
failed = False
for name in ("primary_rays", "final_gather"):
    line = json.loads(open(f"{out}/{name}.json").read())
    # What and where first, then the rest as voxview printed it.
    front = {"measurement": name, "renderer": line["renderer"], "gl_vendor": line["gl_vendor"], "egl_platform": line["egl_platform"],
             "width": line["width"], "height": line["height"], "mrays_per_second": line["mrays_per_second"],
             "gather_ms_per_frame": line["gather"]["ms"] if line["gather"] else None,
             "scene": "cornell_box", "depth": depth, "radiance_depth": radiance_depth}
    line = {**front, **{k: v for k, v in line.items() if k not in front}}
    print(json.dumps(line), flush=True)
    if line["gl_errors"] != 0 or line["hits"] == 0 or not line["mrays_per_second"] > 0:
        print(f"gpu_bench: {name}: {line['gl_errors']} GL errors, {line['hits']} hits", file=sys.stderr)
        failed = True
    where = f'on {line["renderer"]} ({line["gl_vendor"]}, EGL {line["egl_platform"]}), {line["width"]}x{line["height"]}'
    cast = line["cast"]
    summary = f'gpu_bench: {name}: {line["mrays_per_second"]:.2f} Mrays/s ({cast["ms"]:.3f} ms by {cast["timer"]}) {where}'
    if line["gather"]:
        gather = line["gather"]
        summary += f'; final gather {gather["ms"]:.3f} ms per frame by {gather["timer"]} ({gather["points"]} points, {gather["lights"]} lights)'
    print(summary, file=sys.stderr)
sys.exit(1 if failed else 0)
PY
