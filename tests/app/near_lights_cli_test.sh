#!/usr/bin/env bash
# Near lights end to end (issue 20, item 2): a synthetic set lit by lamps 600 px from a 64 px
# sample (light_positions.txt beside the .lp) fits with lower held-out error and truer normals
# with the positions than with --distant-lights; info says the lights are near; rbf refuses.
# Usage: near_lights_cli_test.sh MATFIT_BINARY SOURCE_DIR
set -u
bin=$1; src=$2
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
. "$src/tests/app/lib.sh"
cd "$tmp"

"$bin" synth --material plaster --lights dome:30 --layout lp --size 64 --near-lights 600 \
  --out near --quiet || bad "synth --near-lights"
[ -f near/light_positions.txt ] && ok || bad "synth wrote no light_positions.txt"
out=$("$bin" info near 2>&1) || bad "info: $out"
expect_contains "info near lights" "$out" "near lights  at 600...600 px"

for mode in near distant; do
  flag=""; [ $mode = distant ] && flag="--distant-lights"
  "$bin" fit near --model lambert --holdout 4 $flag --out pack-$mode --quiet >/dev/null ||
    bad "fit lambert ($mode)"
done
field() { python3 -c 'import json,sys
r=json.load(open(sys.argv[1])); v=r
for k in sys.argv[2].split("."): v=v[k]
print(v)' "$1" "$2"; }
hn=$(field pack-near/report.json heldout.rmse); hd=$(field pack-distant/report.json heldout.rmse)
nn=$(field pack-near/report.json normal_mae_deg)
nd=$(field pack-distant/report.json normal_mae_deg)
echo "lambert, lamps at 600 px: held-out rmse $hn with positions, $hd as distant lights;" \
  "normal MAE $nn° vs $nd°"
python3 -c "import sys; sys.exit(0 if $hn < 0.5 * $hd and $nn < 0.3 and $nd > 1.0 else 1)" &&
  ok || bad "positions did not beat distant lights: $hn vs $hd, $nn° vs $nd°"
tile=$(field pack-near/report.json parameters.near_tile_texels)
[ -n "$tile" ] && ok || bad "report.json has no near_tile_texels"

# --model auto ranks the candidates under the near lights too (rbf, which cannot, drops out).
"$bin" fit near --model auto --out pack-auto --quiet >/dev/null || bad "fit --model auto (near)"
m=$(field pack-auto/report.json method)
echo "--model auto on the near set picked $m"
[ -n "$m" ] && [ "${m#rbf}" = "$m" ] && ok || bad "auto picked '$m'"

out=$("$bin" fit near --model rbf --out pack-rbf --quiet 2>&1) && bad "rbf fitted near lights" || ok
expect_contains "rbf refuses" "$out" "--distant-lights"

# Two mirror spheres (r 60 and 56 px) in 400 × 300 photos and lamps 600 px away:
# calibrate-lights writes the lamps' positions beside the .lp, each within 2 % of its distance.
python3 "$src/tests/app/near_sphere_photos.py" photos || bad "rendering sphere photos"
mv photos/truth_positions.txt truth.txt
out=$("$bin" calibrate-lights photos --sphere auto --sphere auto --out photos/lights.lp 2>&1) ||
  bad "calibrate-lights with two spheres: $out"
expect_contains "positions written" "$out" "near lights"
[ -f photos/light_positions.txt ] && ok || bad "no light_positions.txt beside the .lp"
worst=$(python3 - truth.txt photos/light_positions.txt <<'PY'
import math, sys
rows = lambda f: [list(map(float, l.split())) for l in open(f) if l.strip() and not l.startswith("#")]
truth, got = rows(sys.argv[1]), rows(sys.argv[2])[1:]
print(max(math.dist(a, b) / math.hypot(*a) for a, b in zip(truth, got)) if len(got) == len(truth) else 9)
PY
)
echo "calibrate-lights, two spheres, 8 lamps at 600 px: worst position error ${worst} of the distance"
python3 -c "import sys; sys.exit(0 if $worst < 0.02 else 1)" && ok ||
  bad "positions off by $worst of the distance (2 % asked)"
out=$("$bin" info photos 2>&1) || bad "info on the calibrated photos: $out"
expect_contains "calibrated set is near" "$out" "near lights"
# Directions only (--distant-lights) must not leave the old positions to override them: without
# --force refused, with it the positions file (matfit's) is removed.
out=$("$bin" calibrate-lights photos --sphere auto --sphere auto --distant-lights \
  --out photos/lights.lp --quiet 2>&1) && bad "an existing calibration was replaced without --force" || ok
"$bin" calibrate-lights photos --sphere auto --sphere auto --distant-lights --force \
  --out photos/lights.lp --quiet >/dev/null 2>&1 || bad "calibrate --distant-lights --force"
[ ! -e photos/light_positions.txt ] && ok || bad "stale light_positions.txt left beside the new lights"
out=$("$bin" info photos 2>&1) || bad "info after --distant-lights: $out"
grep -q "near lights" <<<"$out" && bad "the distant calibration still reads as near" || ok

echo "near_lights_cli_test: $pass passed, $fail failed"
[ "$fail" -eq 0 ]
