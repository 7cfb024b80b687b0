#!/usr/bin/env bash
# Configures the sanitizer + fuzzer build (docs/fuzzing.md) that scripts/test-sanitizers.sh and
# scripts/fuzz.sh share: clang, ASan + UBSan, the libFuzzer harnesses, no benchmarks.
# Usage: configure-sanitize.sh [BUILD_DIR (default build-sanitize)] [extra cmake arguments...]
set -euo pipefail
cd "$(dirname "$0")/.."
build="${1:-build-sanitize}"
shift || true
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_COMPILER=clang++ -DLIBVOX_WERROR=ON \
      -DLIBVOX_SANITIZE=ON -DLIBVOX_BUILD_FUZZERS=ON -DLIBVOX_BUILD_BENCH=OFF "$@" >/dev/null
