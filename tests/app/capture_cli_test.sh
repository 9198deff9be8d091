#!/usr/bin/env bash
# End-to-end `matfit capture` with the simulated devices → `matfit fit` on the result (no
# options), resume after an interruption, `matfit devices`, `matfit calibrate-lights` on a real
# chrome sphere (when the shared data is present), and error exits that name the problem.
# Usage: capture_cli_test.sh MATFIT_BINARY SHARED_DATA_DIR
set -u
bin=$1; shared=$2
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
pass=0; fail=0
ok()  { pass=$((pass+1)); }
bad() { fail=$((fail+1)); echo "FAIL: $*"; }
expect_contains() { if grep -qF -- "$3" <<<"$2"; then ok; else bad "$1: lacks '$3'"; echo "$2" | head -20; fi; }

cat > "$tmp/plan.json" <<'P'
{"schema": "matfit.captureplan/1", "exposures_s": [0.004, 0.016], "repeats": 1, "dark_frames": 1}
P
cam='sim:camera?material=plaster&size=48&seed=3'
rig='sim:rig?lights=ring:24:40'
out=$("$bin" capture --camera "$cam" --rig "$rig" --plan "$tmp/plan.json" --out "$tmp/set" --quiet 2>&1)
expect_contains capture "$out" "captured    24 images (0 kept"
[ -f "$tmp/set/lights.lp" ] && [ -f "$tmp/set/capture.json" ] && ok || bad "dataset files"
out=$("$bin" fit "$tmp/set" --model lambert --out "$tmp/pack" --quiet 2>&1)
expect_contains fit "$out" "vs truth    normal MAE"
mae=$(sed -n 's/.*normal MAE \([0-9.]*\)°.*/\1/p' <<<"$out")
awk "BEGIN{exit !($mae < 1.0)}" && ok || bad "normal MAE $mae° ≥ 1°"

# Interrupted (simulated disconnect after 10 frames), then resumed with the same command.
out=$("$bin" capture --camera "$cam&fail_after=10" --rig "$rig" --plan "$tmp/plan.json" --out "$tmp/part" --quiet 2>&1)
[ $? -ne 0 ] && ok || bad "an interrupted capture must fail"
expect_contains interrupted "$out" "run the same command again to resume"
out=$("$bin" capture --camera "$cam" --rig "$rig" --plan "$tmp/plan.json" --out "$tmp/part" --quiet 2>&1)
expect_contains resumed "$out" "kept from an earlier run"
cmp -s "$tmp/set/lights.lp" "$tmp/part/lights.lp" && ok || bad "resumed light file differs"

out=$("$bin" devices 2>&1)
expect_contains devices "$out" "sim:camera"

out=$("$bin" capture --camera v4l2:/dev/video-absent --rig "$rig" --plan "$tmp/plan.json" --out "$tmp/x" 2>&1)
[ $? -ne 0 ] && ok || bad "absent camera must fail"
expect_contains absent "$out" "no such device"
out=$("$bin" capture --camera "$cam" --rig usb:1209:4d46 --plan "$tmp/plan.json" --out "$tmp/x" 2>&1)
expect_contains usb-no-lights "$out" "--rig-lights"
echo '{"exposures_s": [0.01], "gian": 2}' > "$tmp/bad.json"
out=$("$bin" capture --camera "$cam" --rig "$rig" --plan "$tmp/bad.json" --out "$tmp/x" 2>&1)
expect_contains bad-plan "$out" "field 'gian'"

if [ -d "$shared/psm/chrome" ]; then
  out=$("$bin" calibrate-lights "$shared/psm/chrome" --out "$tmp/lights.txt" 2>&1)
  expect_contains calibrate "$out" "lights      $tmp/lights.txt (12 directions, lights-txt)"
  [ "$(head -1 "$tmp/lights.txt")" = 12 ] && ok || bad "light file header"
else
  echo "skip: $shared/psm/chrome absent"
fi
echo "capture_cli_test: $pass passed, $fail failed"
[ "$fail" -eq 0 ]
