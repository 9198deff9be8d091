#!/usr/bin/env bash
# Runs the libFuzzer targets (fuzz/, docs/fuzzing.md), each for a fixed time over a scratch copy
# of its seed corpus fuzz/corpus/NAME. Fails on the first crash, leak, sanitizer report or
# timeout, naming the reproducer (build-san/fuzz-artifacts/). Prints executions and coverage.
# Usage: fuzz.sh [--time SECONDS] [--seed N] [--no-build] [NAME...]   (default 20 s, every target)
# The seed defaults to 1, so a short run (CI) replays the same inputs on every machine and a
# finding is reproducible; --seed 0 lets libFuzzer pick one (the long exploratory runs).
# Reproduce: build-san/fuzz/NAME_fuzzer ARTIFACT
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${MATFIT_SAN_BUILD_DIR:-"$root/build-san"}
seconds=20; seed=1; do_build=1; names=()
while [ $# -gt 0 ]; do
  case "$1" in
    --time) seconds=$2; shift 2 ;;
    --seed) seed=$2; shift 2 ;;
    --no-build) do_build=0; shift ;;
    -h|--help) sed -n '2,9p' "$0"; exit 0 ;;
    *) names+=("$1"); shift ;;
  esac
done
if [ ${#names[@]} -eq 0 ]; then
  for f in "$root"/fuzz/*_fuzzer.cc; do names+=("$(basename "$f" _fuzzer.cc)"); done
fi
if [ "$do_build" = 1 ]; then
  targets=(); for n in "${names[@]}"; do targets+=("${n}_fuzzer"); done
  "$root/scripts/build-san.sh" "${targets[@]}"
fi
artifacts="$build/fuzz-artifacts"; mkdir -p "$artifacts"
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:${ASAN_OPTIONS:-}"
export LSAN_OPTIONS="suppressions=$root/tools/sanitizers/lsan.supp:print_suppressions=0"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
printf '%-14s %10s %8s %8s %7s\n' target executions exec/s cov ft
failed=0
for n in "${names[@]}"; do
  bin="$build/fuzz/${n}_fuzzer"
  [ -x "$bin" ] || { echo "fuzz: $bin not built"; failed=1; continue; }
  work=$(mktemp -d); mkdir -p "$work/corpus"
  cp -r "$root/fuzz/corpus/$n/." "$work/corpus/" 2>/dev/null || true
  opts=(-max_total_time="$seconds" -seed="$seed" -timeout=20 -rss_limit_mb=2560 -print_final_stats=1
        -artifact_prefix="$artifacts/$n-")
  case "$n" in
    archive|upload) opts+=(-max_len=65536) ;;
    *) opts+=(-max_len=8192) ;;
  esac
  case "$n" in scene|job_spec|pack|capture_plan) opts+=(-dict="$root/fuzz/json.dict") ;; esac
  if (cd "$work" && TMPDIR="$work" "$bin" "${opts[@]}" "$work/corpus" >"$work/log" 2>&1); then
    execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$work/log" | tail -1)
    rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$work/log" | tail -1)
    cov=$(grep -oE 'cov: [0-9]+' "$work/log" | tail -1 | cut -d' ' -f2)
    ft=$(grep -oE 'ft: [0-9]+' "$work/log" | tail -1 | cut -d' ' -f2)
    printf '%-14s %10s %8s %8s %7s\n' "$n" "${execs:-?}" "${rate:-?}" "${cov:-?}" "${ft:-?}"
  else
    echo "FUZZ FAILURE in $n (log below; reproducer in $artifacts/$n-*)"
    grep -vE '^#[0-9]+\s+(NEW|REDUCE|pulse|INITED)' "$work/log" | tail -60
    failed=1
  fi
  rm -rf "$work"
done
exit $failed
