#!/usr/bin/env bash
# The test suite under AddressSanitizer + UBSan (build-san/, docs/sanitizers.md). By default the
# CI selection: the readers, fits, leaf, capture and server test binaries, without the slowest
# fit cases (listed in docs/sanitizers.md; the normal build runs them). --full: every test
# through ctest. Any sanitizer report fails the run (reports abort the process).
# Usage: test-sanitizers.sh [--full] [--no-build]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${MATFIT_SAN_BUILD_DIR:-"$root/build-san"}
full=0; do_build=1
for a in "$@"; do
  case "$a" in
    --full) full=1 ;;
    --no-build) do_build=0 ;;
    *) echo "test-sanitizers: unknown argument '$a'"; exit 2 ;;
  esac
done
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:strict_string_checks=1:detect_stack_use_after_return=1"
export LSAN_OPTIONS="suppressions=$root/tools/sanitizers/lsan.supp:print_suppressions=0"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
if [ "$full" = 1 ]; then
  [ "$do_build" = 0 ] || "$root/scripts/build-san.sh" all
  cd "$build" && exec ctest --output-on-failure -j "$(nproc)"
fi
# binary → gtest filter (docs/sanitizers.md says why each exclusion is made; the normal build
# runs every one of them). Left out: real-data ladders, held-out folds and selection sweeps over
# whole stacks (minutes each under ASan at -O1; the readers they use are fuzzed and covered by the
# synthetic cases), the real-sheet leaf runs, tests whose deadlines assume uninstrumented speed,
# the headless-browser test, and a test that caps the address space (ASan reserves terabytes).
declare -A filter=(
  [tests/core/core_tests]="*"
  [tests/fit/fit_tests]="-RealLadder*:*RealLadder*:RealHeldOut.*:RealData*:Select.*:FitJob.ReportOnly*:Stability.*:Svbrdf.RecoversNormalF0AndRoughnessPerTexelAcrossViews:Svbrdf.PredictsHeldOutViewsBetterThanAnyFrontalOnlyModel"
  [tests/leaf/leaf_tests]="-LeafScan.FindsEveryLeafOfTheSharedSheet:LeafScan.FastMatchesTheReferenceOnARealLeaf:LeafJob.NamesLeavesWithManyFlaggedTexels:Translucency.Hl2ErrorVersusDirectionCount:Translucency.Hl2ReconstructsTheMultipoleWithinThePublishedError:LeafScan.LightsAtSeveralElevationsFitTheSpecularLobe:LeafScan.DisplacementScansGiveTheThickness"
  [tests/capture/capture_tests]="*"
  [tests/server/server_tests]="-ServerTest.QueuedJobCancelsAtOnceAndRestartDuringARunCompletesIt:ServerTest.ViewerPageRendersThePackInHeadlessChromium:ServerTest.CancelARunningFitStopsPromptlyAndLeavesNoPack"
  [tests/server/server_hardening_input_tests]="-BombTest.CliNamesTheFileAndTheDeclaredSizeInsteadOfBadAlloc"
)
if [ "$do_build" = 1 ]; then
  targets=(); for b in "${!filter[@]}"; do targets+=("$(basename "$b")"); done
  "$root/scripts/build-san.sh" "${targets[@]}" matfit
fi
# LeakSanitizer's own stop-the-world tracer can segfault at exit after every test passed
# ("Tracer caught signal 11 … LeakSanitizer has encountered a fatal error": google/sanitizers
# #1353, intermittent; seen here on leaf_tests and server_tests with every test passed). That is
# not a finding: such a run — the tracer crash, gtest's PASSED line, no sanitizer ERROR, no
# runtime error, no FAILED test — is run again, up to twice. Anything else fails at once.
tracer_crash_only() {
  local log=$1
  grep -q "LeakSanitizer has encountered a fatal error" "$log" &&
    grep -q "Tracer caught signal" "$log" && grep -q "^\[  PASSED  \]" "$log" &&
    ! grep -qE "ERROR: |runtime error|FAILED" "$log"
}
run_binary() {  # binary → 0 when clean
  (cd "$build/$(dirname "$1")" && "./$(basename "$1")" --gtest_filter="${filter[$1]}" \
    --gtest_brief=1 >"$build/$(basename "$1").san.log" 2>&1)
}
# The job store's PostgreSQL code runs under the sanitizers too: server_tests' store contract
# and lease tests take a throw-away cluster's URL (they skip without one).
pg_dir=$(mktemp -d)
trap 'bash "$root/scripts/pg-test-cluster.sh" stop "$pg_dir"' EXIT
if url=$(bash "$root/scripts/pg-test-cluster.sh" start "$pg_dir" 2>/dev/null); then
  export MATFIT_TEST_PG_URL=$url
else
  echo "sanitizers: no PostgreSQL server here; the PostgreSQL store tests skip"
fi
failed=0
for b in $(printf '%s\n' "${!filter[@]}" | sort); do
  start=$(date +%s)
  ok=0
  for attempt in 1 2 3; do
    if run_binary "$b"; then ok=1; break; fi
    tracer_crash_only "$build/$(basename "$b").san.log" || break
    echo "sanitizers: $(basename "$b"): LeakSanitizer's tracer crashed at exit after every test" \
      "passed (attempt $attempt); running it again"
  done
  if [ "$ok" = 1 ]; then
    echo "sanitizers: $(basename "$b") clean ($(( $(date +%s) - start )) s)"
  else
    echo "SANITIZER/TEST FAILURE in $(basename "$b") (log: $build/$(basename "$b").san.log)"
    # No match (e.g. a sanitizer's own crash) must not end the loop: the other binaries still run.
    grep -E "ERROR: |runtime error|FAILED|SUMMARY|Sanitizer has encountered" \
      "$build/$(basename "$b").san.log" | head -30 || true
    failed=1
  fi
done
exit $failed
