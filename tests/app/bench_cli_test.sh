#!/usr/bin/env bash
# End-to-end `matfit bench` and `matfit fit --model auto`: output files and charts (PNG when
# rsvg-convert is installed), atomic refusal to overwrite, errors that name the bad value.
# Usage: bench_cli_test.sh MATFIT_BINARY SOURCE_DIR SHARED_DATA_DIR
set -u
bin=$1; src=$2; shared=$3
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
source "$(dirname "$0")/lib.sh"

out=$("$bin" bench --quick --methods mean,lambert,lambert-robust --stability-size 12 \
      --shared-data "$shared" --out "$tmp/b" --quiet 2>&1) && ok || bad "bench: $out"
for f in bench.json stability.json charts/pareto_plaster-40.svg charts/theta_granite-40.svg \
         charts/hl2_directions.svg charts/stability_error.svg charts/stability_silent.svg; do
  [ -s "$tmp/b/$f" ] && ok || bad "bench output lacks $f"
done
if command -v rsvg-convert >/dev/null; then
  [ -s "$tmp/b/charts/stability_silent.png" ] && ok || bad "no PNG chart although rsvg-convert exists"
else
  echo "rsvg-convert absent: PNG charts not checked"
fi
expect_contains "bench schema" "$(cat "$tmp/b/bench.json")" '"schema": "matfit.bench/1"'
expect_contains "stability schema" "$(cat "$tmp/b/stability.json")" '"schema": "matfit.stability/1"'
out=$("$bin" bench --quick --no-stability --methods mean --out "$tmp/b" 2>&1) && bad "overwrote" || ok
expect_contains "existing out" "$out" "exists"
out=$("$bin" bench --quick --methods lambert,phong9 --out "$tmp/c" 2>&1) && bad "bad method accepted" || ok
expect_contains "bad method" "$out" "'phong9' is not a method"
[ ! -e "$tmp/c" ] && ok || bad "a failed bench left $tmp/c"

# --model auto with a scene file: the report explains the choice.
"$bin" synth --material plastic --size 32 --noise 0.005 --out "$tmp/pl" >/dev/null 2>&1 || bad "synth"
out=$("$bin" fit "$tmp/pl" --model auto --scene "$src/docs/examples/scene-closeup-cloth.json" \
      --out "$tmp/auto" --quiet 2>&1) && ok || bad "fit auto: $out"
rep=$(cat "$tmp/auto/report.json")
expect_contains "selection" "$rep" '"selection"'
expect_contains "candidates" "$rep" '"candidates"'
expect_contains "reason" "$rep" 'meets the budget'
echo '{"texel_footprint_px": "far"}' >"$tmp/bad.json"
out=$("$bin" fit "$tmp/pl" --model auto --scene "$tmp/bad.json" --out "$tmp/auto2" 2>&1) && bad "bad scene accepted" || ok
expect_contains "bad scene" "$out" "field 'texel_footprint_px' must be a number"
out=$("$bin" fit "$tmp/pl" --model lambert --budget 0.1 --out "$tmp/auto3" 2>&1) && bad "budget without auto" || ok
expect_contains "budget without auto" "$out" "--scene and --budget go with --model auto"

echo "bench_cli_test: $pass passed, $fail failed"
[ "$fail" -eq 0 ]
