#!/usr/bin/env bash
# The README's test command: install dependencies, build, run the whole test suite.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
"$root/scripts/install-deps.sh"
"$root/scripts/install-node-tools.sh" || echo "test.sh: node tools unavailable; glTF validation tests will be skipped"
"$root/scripts/build.sh"
cd "${MATFIT_BUILD_DIR:-"$root/build"}"
ctest --output-on-failure -j "$(nproc)"
