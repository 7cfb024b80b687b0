#!/usr/bin/env bash
# The Slurm job test (issue 35): scripts/voxelize-slurm on a real one-node Slurm cluster that
# tests/slurm/run_slurm_test.sh starts and stops itself (munged, slurmctld, slurmd in a temporary
# directory), against the tools built in BUILD_DIR: 4 partition runs + merge of the Cornell box
# compared byte for byte with a local build, then a run cancelled with scancel and resubmitted,
# then a tiled radiance bake as an array of tile runs and the index job, and its resubmission.
# Needs root and slurm-wlm + munge (scripts/install-deps.sh); without them it skips, exit 77.
# Usage: scripts/test-slurm.sh [BUILD_DIR]    (default: build, as scripts/test.sh builds it)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
for f in "$build/tools/voxelize" "$build/tools/voxinspect" "$build/examples/make_example_scene"; do
    [ -x "$f" ] || { echo "test-slurm: $f is not built (run scripts/test.sh, or cmake --build $build)" >&2; exit 1; }
done
exec tests/slurm/run_slurm_test.sh "$build"
