#!/usr/bin/env bash
# The sanitizer job (docs/fuzzing.md), a command of its own that .ci/run runs after scripts/test.sh:
# one clang build with AddressSanitizer + UndefinedBehaviorSanitizer (undefined behaviour aborts)
# and the libFuzzer harnesses, into its own build directory; then the unit and tool tests on it,
# then each fuzzer for LIBVOX_FUZZ_SECONDS (default 60) from its seed corpus (CTest label fuzz).
#
# Left out: label package, which builds a consumer project with the plain toolchain against this
# build (it would need the sanitizer runtime in that project too); it checks packaging, which the
# normal suite does. The OpenGL tests (label gl, on llvmpipe) run without leak checking: Mesa's
# driver leaks on every context from a module it unloads before exit, which no suppression can
# name (cmake/LibvoxSanitizers.cmake); ASan and UBSan still check them.
#
# Environment: LIBVOX_SANITIZE_BUILD (build directory, default build-sanitize),
# LIBVOX_FUZZ_SECONDS, CMAKE_CXX_COMPILER_LAUNCHER (e.g. ccache; not needed).
set -euo pipefail
cd "$(dirname "$0")/.."

build="${LIBVOX_SANITIZE_BUILD:-build-sanitize}"
fuzz_seconds="${LIBVOX_FUZZ_SECONDS:-60}"

./scripts/install-deps.sh
./scripts/configure-sanitize.sh "$build" -DLIBVOX_FUZZ_SECONDS="$fuzz_seconds"
cmake --build "$build"
ctest --test-dir "$build" --output-on-failure -j"$(nproc)" -LE '^(package|fuzz)$'
ctest --test-dir "$build" --output-on-failure -j"$(nproc)" -L '^fuzz$'
