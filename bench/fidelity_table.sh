#!/usr/bin/env bash
# The bytes–fidelity front the octree defaults are chosen on: for each bench mesh (an organic
# model, a CAD part with sharp edges, a textured model, a scene of flat walls, the 1 M-triangle
# bumpy sphere), each depth and each setting (cubes, full refinement, the default and other
# error-bounded settings), the file's bytes and voxels and voxelize's build seconds, and its
# fidelity against the mesh itself from four views at 1024x768 (bench/raycast_peer): hit/miss
# agreement, depth error in leaf-voxel diagonals (p95, and the share of hit pixels within one),
# shading-normal error against the mesh's interpolated normals (mean and p99, as stored and after
# the post-process filter) and colour PSNR against the mesh's own materials.
# Usage: bench/fidelity_table.sh [BUILD_DIR] [DEPTHS...]       (default: build 10 11 12)
# Environment: MESHES (space-separated NAME:PATH, replacing the default list); SETTINGS
# (semicolon-separated LABEL=voxelize options, replacing the default list); THREADS; OUT, the
# output directory (BUILD_DIR/bench/fidelity): runs side by side need their own.
# Outputs: OUT/fidelity_table.{json,csv} and every run's stats beside them.
set -euo pipefail
build=${1:-build}
shift || true
depths=("$@")
[ ${#depths[@]} -gt 0 ] || depths=(10 11 12)
out=${OUT:-$build/bench/fidelity}
mkdir -p "$out/runs"
threads=()
[ -z "${THREADS:-}" ] || threads=(--threads "$THREADS")
models=/usr/share/assimp/models
if [ -n "${MESHES:-}" ]; then
    read -r -a meshes <<< "$MESHES"
else
    "$build/examples/make_example_scene" bumpy-sphere -o "$out" >/dev/null
    cornell=$("$build/examples/make_example_scene" cornell-box -o "$out/cornell")
    meshes=("organic:$models/OBJ/WusonOBJ.obj"
            "cad:$models/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb"
            "textured:$models/OBJ/spider.obj"
            "walls:$cornell"
            "bumpy-sphere:$out/bumpy_sphere.glb")
fi
IFS=';' read -r -a settings <<< "${SETTINGS:-cubes=--full-refinement --no-contours;full=--full-refinement;geometry=--normal-error 0 --color-error 0;coarse=--contour-error 0.5 --normal-error 6 --color-error 10;default=;fine=--contour-error 0.15 --normal-error 2 --color-error 4}"
# Four views all round the mesh; the walls (a box open at +z) are seen through their opening.
views_for() {
    case "$1" in
        walls) echo "--view 0,0.15,1 --view 0.45,0.3,1 --view -0.5,-0.2,1 --view 0.2,0.7,1" ;;
        *) echo "--view 1,0.6,0.8 --view -0.8,0.5,-0.6 --view -0.5,-0.4,1 --view 0.7,-0.3,-0.9" ;;
    esac
}
echo "fidelity_table: $(nproc) cores; depths ${depths[*]}; settings: ${settings[*]}" >&2
rows=()
for entry in "${meshes[@]}"; do
    name=${entry%%:*}
    mesh=${entry#*:}
    for d in "${depths[@]}"; do
        for setting in "${settings[@]}"; do
            label=${setting%%=*}
            options=${setting#*=}
            base=$out/runs/$name-$d-$label
            # shellcheck disable=SC2086
            "$build/tools/voxelize" "$mesh" -o "$out/$name.esvo" --depth "$d" --stats "$base.stats.json" -q "${threads[@]}" $options
            "$build/tools/voxinspect" validate "$out/$name.esvo" -q
            "$build/tools/voxinspect" info "$out/$name.esvo" --json > "$base.info.json"
            # shellcheck disable=SC2046
            "$build/bench/raycast_peer" "$mesh" "$out/$name.esvo" $(views_for "$name") --fov 40 --repeat 1 > "$base.peer.json"
            rows+=("$name $d $label")
            echo "fidelity_table: $name depth $d $label done" >&2
        done
        rm -f "$out/$name.esvo"
    done
done
python3 - "$out" "${rows[@]}" <<'PY'
import csv, json, sys
out, rows = sys.argv[1], [r.split(" ", 2) for r in sys.argv[2:]]
table = []
for name, d, label in rows:
    base = f"{out}/runs/{name}-{d}-{label}"
    s, i, p = (json.load(open(f"{base}.{k}.json")) for k in ("stats", "info", "peer"))
    a = p["attributes"] or {}
    n, nf = a.get("normal_error_degrees", {}), a.get("normal_error_degrees_filtered", {})
    table.append({
        "mesh": name, "depth": int(d), "setting": label, "refinement": s["octree"].get("refinement"),
        "file_bytes": s["octree"]["file_bytes"], "voxels": s["octree"]["voxels"],
        "build_seconds": s["octree"]["build_seconds"],
        "leaves": i.get("leaves"), "contour_voxels": i.get("contour_voxels"), "contour_bytes": i["bytes"]["contours"],
        "hit_miss": p["hit_miss_agreement"], "depth_p95_diagonals": p["depth_error_diagonals"]["p95"],
        "within_diagonal": p["depth_within_leaf_diagonal"],
        "normal_mean": n.get("mean"), "normal_p99": n.get("p99"),
        "normal_filtered_mean": nf.get("mean"), "normal_filtered_p99": nf.get("p99"),
        "color_psnr_db": a.get("color_psnr_db"), "color_psnr_db_filtered": a.get("color_psnr_db_filtered"),
        "octree_mrays_per_second": p["octree_mrays_per_second"],
    })
json.dump(table, open(f"{out}/fidelity_table.json", "w"), indent=2)
with open(f"{out}/fidelity_table.csv", "w", newline="") as f:
    w = csv.DictWriter(f, fieldnames=list(table[0].keys()))
    w.writeheader()
    w.writerows(table)
full = {(r["mesh"], r["depth"]): r for r in table if r["setting"] == "full"}
def fmt(v, spec):
    return format(v, spec) if v is not None else "-"
print(f'{"mesh":<13} {"depth":>5} {"setting":<10} {"MB":>8} {"x full":>6} {"voxels":>10} {"build_s":>7} {"hit/miss":>8} '
      f'{"p95_diag":>8} {"<=1diag":>7} {"n_mean":>6} {"n_p99":>6} {"nf_mean":>7} {"nf_p99":>6} {"PSNR":>5} {"PSNR_f":>6}')
for r in table:
    ref = full.get((r["mesh"], r["depth"]))
    ratio = ref["file_bytes"] / r["file_bytes"] if ref else None
    print(f'{r["mesh"]:<13} {r["depth"]:>5} {r["setting"]:<10} {r["file_bytes"] / 1e6:8.2f} {fmt(ratio, "6.2f")} {r["voxels"]:>10} '
          f'{r["build_seconds"]:7.2f} {100 * r["hit_miss"]:7.2f}% {r["depth_p95_diagonals"]:8.3f} {100 * r["within_diagonal"]:6.2f}% '
          f'{fmt(r["normal_mean"], "6.2f")} {fmt(r["normal_p99"], "6.2f")} {fmt(r["normal_filtered_mean"], "7.2f")} '
          f'{fmt(r["normal_filtered_p99"], "6.2f")} {fmt(r["color_psnr_db"], "5.1f")} {fmt(r["color_psnr_db_filtered"], "6.1f")}')
print("x full: the full-refinement file's bytes / this file's; depth errors in leaf-voxel diagonals over the pixels both hit; "
      "normal errors in degrees against the mesh's shading normals (n: as stored, nf: after the post-process filter); PSNR: 8-bit sRGB colour")
PY
