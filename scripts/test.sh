#!/usr/bin/env bash
# The README's test command: install dependencies, build, run the whole test suite, then the
# fuzz targets and the suite's sanitizer selection.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
"$root/scripts/install-deps.sh"
"$root/scripts/install-node-tools.sh" || echo "test.sh: node tools unavailable; glTF validation tests will be skipped"
"$root/scripts/build.sh"
(cd "${MATFIT_BUILD_DIR:-"$root/build"}" && ctest --output-on-failure -j "$(nproc)")
# The instrumented clang build (build-san/, one build for both): every libFuzzer target for a
# short fixed time (docs/fuzzing.md), then the sanitizer selection of the suite
# (docs/sanitizers.md). MATFIT_SANITIZERS=0 skips both; MATFIT_FUZZ_SECONDS sets the fuzz time.
if [ "${MATFIT_SANITIZERS:-1}" != 0 ]; then
  "$root/scripts/fuzz.sh" --time "${MATFIT_FUZZ_SECONDS:-20}"
  "$root/scripts/test-sanitizers.sh"
fi
