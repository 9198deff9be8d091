#!/usr/bin/env bash
# Configures and builds the instrumented clang build (build-san/: AddressSanitizer + UBSan,
# libFuzzer coverage) — one build for scripts/fuzz.sh and scripts/test-sanitizers.sh.
# Usage: build-san.sh TARGET...   (never `all`: only what the caller runs)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${MATFIT_SAN_BUILD_DIR:-"$root/build-san"}
command -v clang++ >/dev/null || { echo "build-san: clang++ missing (scripts/install-deps.sh)"; exit 1; }
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_CXX_COMPILER=clang++ \
  -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g" \
  -DMATFIT_SANITIZE=address,undefined -DMATFIT_FUZZ=ON -DMATFIT_BUILD_BENCH=OFF >/dev/null
cmake --build "$build" -j "$(nproc)" --target "$@"
