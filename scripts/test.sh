#!/usr/bin/env bash
# README command 2: installs what is needed, builds with warnings as errors, and runs the Release
# test suite. The sanitizer job is its own command, scripts/test-sanitizers.sh (the tests again on
# an ASan + UBSan build, and each fuzzer for a minute; docs/fuzzing.md); .ci/run runs both, and
# the real-Slurm test (scripts/test-slurm.sh).
set -euo pipefail
cd "$(dirname "$0")/.."

./scripts/install-deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DLIBVOX_WERROR=ON >/dev/null
cmake --build build
ctest --test-dir build --output-on-failure -j"$(nproc)"
