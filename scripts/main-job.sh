#!/usr/bin/env bash
# The README's main job: install dependencies, build, then on the bundled data: summarise
# every dataset, synthesise one with ground truth, fit it → material pack → summary table;
# preview renders; leaf materials from the bundled leaf scan (and the shared sheet if present).
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
echo "== matfit render: previews of the fitted packs (EGL if available, else CPU) =="
"$matfit" render "$out/plastic-blinn-phong-pack" --light 40,30 --scene sphere --size 256 \
  --out "$out/plastic-blinn-phong-sphere.png"
"$matfit" render "$out/corduroy-heinrich-pack" --light 60,0 --sweep 8 --size 128 \
  --out "$out/corduroy-heinrich-sweep.png"
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
echo "packs written to $out/*-pack (material.json, material.gltf, maps/, report.json, preview.png)"
echo "previews: $out/plastic-blinn-phong-sphere.png, $out/corduroy-heinrich-sweep.png"
echo "leaf materials: $out/leaf-scan-leaves/leaves.json (and leaf-sheet-leaves/ with the shared data)"
