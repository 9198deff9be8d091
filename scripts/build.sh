#!/usr/bin/env bash
# Configures and builds matfit into build/ (Release with debug info, Ninja, ccache if present).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${MATFIT_BUILD_DIR:-"$root/build"}
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DMATFIT_WERROR=ON >/dev/null
cmake --build "$build" -j "$(nproc)"
