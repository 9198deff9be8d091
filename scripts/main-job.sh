#!/usr/bin/env bash
# The README's main job: install dependencies, build, then on the bundled data: summarise
# every dataset, synthesise one with ground truth, fit it → material pack → summary table;
# preview renders; leaf materials from the bundled leaf scan (and the shared sheet if present);
# a simulated capture fitted back; chrome-sphere calibration; a service session on loopback;
# model selection for a scene; the quick benchmark and stability matrix with charts.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
"$root/scripts/install-deps.sh"
"$root/scripts/build.sh"
matfit="${MATFIT_BUILD_DIR:-"$root/build"}/app/matfit"
out="$root/out"
mkdir -p "$out"
echo "== matfit synth: corduroy under the Bonn 81-light set, 1 % noise =="
"$matfit" synth --material corduroy --lights bonn81 --size 128 --noise 0.01 --seed 7 \
  --layout bonn --out "$out/corduroy-bonn81" --force
for d in "$out/corduroy-bonn81" "$root"/fixtures/*/; do
  echo
  echo "== matfit info $d =="
  "$matfit" info "$d" --quiet
done
for model in lambert heinrich; do
  echo
  echo "== matfit fit corduroy-bonn81 --model $model =="
  "$matfit" fit "$out/corduroy-bonn81" --model $model --holdout 3 --out "$out/corduroy-$model-pack" --force --quiet
done
for model in lambert blinn-phong; do
  echo
  echo "== matfit fit fixtures/plastic-ring12 --model $model (glossy Blinn–Phong truth) =="
  "$matfit" fit "$root/fixtures/plastic-ring12" --model $model --holdout 4 --out "$out/plastic-$model-pack" --force --quiet
done
echo
echo "== matfit fit corduroy-bonn81 --model auto: the smallest model the close-up scene needs =="
"$matfit" fit "$out/corduroy-bonn81" --model auto --scene "$root/docs/examples/scene-closeup-cloth.json" \
  --out "$out/corduroy-auto-pack" --force --quiet
grep -m1 '"reason"' "$out/corduroy-auto-pack/report.json"
echo
echo "== matfit render: previews of the fitted packs (EGL if available, else CPU) =="
"$matfit" render "$out/plastic-blinn-phong-pack" --light 40,30 --scene sphere --size 256 \
  --out "$out/plastic-blinn-phong-sphere.png" --force
"$matfit" render "$out/corduroy-heinrich-pack" --light 60,0 --sweep 8 --size 128 \
  --out "$out/corduroy-heinrich-sweep.png" --force
echo
echo "== matfit leaf: the bundled synthetic leaf scan → one translucent leaf material per leaf =="
"$matfit" leaf "$root/fixtures/leaf-scan" --out "$out/leaf-scan-leaves" --force --quiet
sheet="$root/../shared/data/leaf-sheet"
if [ -d "$sheet" ]; then
  echo
  echo "== matfit leaf: the shared real leaf sheet (23 leaves) =="
  "$matfit" leaf "$sheet" --out "$out/leaf-sheet-leaves" --force --quiet
fi
echo
echo "== matfit capture: simulated camera + LED dome → dataset → matfit fit =="
cat > "$out/capture-plan.json" <<'PLAN'
{"schema": "matfit.captureplan/1", "exposures_s": [0.004, 0.016], "repeats": 2, "dark_frames": 2}
PLAN
"$matfit" capture --camera 'sim:camera?material=plaster&size=64&seed=2' --rig 'sim:rig?lights=bonn81' \
  --plan "$out/capture-plan.json" --out "$out/captured" --force --quiet
"$matfit" fit "$out/captured" --model lambert --holdout 3 --out "$out/captured-pack" --force --quiet
chrome="$root/../shared/data/psm/chrome"
if [ -d "$chrome" ]; then
  echo
  echo "== matfit calibrate-lights: the shared chrome sphere =="
  "$matfit" calibrate-lights "$chrome" --out "$out/chrome-lights.txt" --force --quiet
fi
echo
echo "== matfit serve: the service on loopback — upload the fixture, poll, fetch the pack =="
rm -rf "$out/serve-data"
"$matfit" serve --port 0 --data "$out/serve-data" --quiet 2>"$out/serve.log" &
serve_pid=$!
port=""
for _ in $(seq 1 100); do
  port=$(sed -n 's|.*listening on http://127.0.0.1:\([0-9]*\)/api/v1.*|\1|p' "$out/serve.log")
  [ -n "$port" ] && break
  sleep 0.1
done
api="http://127.0.0.1:$port/api/v1"
tar czf "$out/plastic-ring12.tar.gz" -C "$root/fixtures" plastic-ring12
id=$(curl -s -F file=@"$out/plastic-ring12.tar.gz" -F model=lambert-robust -F holdout=4 "$api/jobs" |
  sed -n 's/.*"id": "\([0-9a-f]*\)".*/\1/p')
echo "submitted job $id"
for _ in $(seq 1 600); do
  curl -s "$api/jobs/$id" | grep -qE '"state": "(succeeded|failed)"' && break
  sleep 0.1
done
curl -s "$api/jobs/$id" | grep -E '"(state|method|rmse|heldout_rmse|run_seconds)"'
curl -s -o "$out/served-pack.zip" "$api/packs/$id"
curl -s -o "$out/served-preview.png" "$api/packs/$id/preview.png?theta=40&phi=30&scene=sphere"
echo "pack $out/served-pack.zip, preview $out/served-preview.png, viewer http://127.0.0.1:$port/viewer/$id"
kill -TERM "$serve_pid"
wait "$serve_pid"
echo
echo "== matfit bench --quick: every method timed and scored, the stability matrix, charts =="
"$matfit" bench --quick --shared-data "$root/../shared/data" --out "$out/bench" --force
echo
echo "packs written to $out/*-pack (material.json, material.gltf, maps/, report.json, preview.png)"
echo "previews: $out/plastic-blinn-phong-sphere.png, $out/corduroy-heinrich-sweep.png"
echo "leaf materials: $out/leaf-scan-leaves/leaves.json (and leaf-sheet-leaves/ with the shared data)"
echo "benchmark: $out/bench/bench.json, stability.json, charts/*.svg|png"
