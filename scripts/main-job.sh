#!/usr/bin/env bash
# The README's main job: install dependencies, build, then on the bundled data
# generate a synthetic dataset with ground truth and print the summary of every dataset.
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
