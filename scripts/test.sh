#!/usr/bin/env bash
# README command 2 (and CI's): installs what is needed, builds with warnings as errors, and runs
# the whole test suite; then the sanitizer job (scripts/test-sanitizers.sh: the tests again on an
# ASan + UBSan build, and each fuzzer for a minute; docs/fuzzing.md). LIBVOX_SKIP_SANITIZERS=1
# skips that second part.
set -euo pipefail
cd "$(dirname "$0")/.."

./scripts/install-deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DLIBVOX_WERROR=ON >/dev/null
cmake --build build
ctest --test-dir build --output-on-failure -j"$(nproc)"
if [ "${LIBVOX_SKIP_SANITIZERS:-0}" != 1 ]; then
  ./scripts/test-sanitizers.sh
fi
