#!/usr/bin/env bash
# Regenerates docs/images: the bundled fixtures fitted and previewed by `matfit render`
# (sphere under one light, and a 4-light sweep of the plane). Needs a built tree (scripts/build.sh).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
matfit="$root/build/app/matfit"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$root/docs/images"
while read -r fixture model; do
  "$matfit" fit "$root/fixtures/$fixture" --model "$model" --out "$tmp/$fixture-$model" --quiet >/dev/null
  "$matfit" render "$tmp/$fixture-$model" --scene sphere --light 40,30 --ambient 0.05 --size 192 \
    --out "$root/docs/images/$fixture-$model-sphere.png" --quiet
  "$matfit" render "$tmp/$fixture-$model" --light 55,0 --sweep 4 --size 96 \
    --out "$root/docs/images/$fixture-$model-sweep.png" --quiet
done <<'LIST'
plaster-bonn81 lambert
wool-bonn81-8bit heinrich
plastic-ring12 blinn-phong
leaf-dome24 cook-torrance
LIST
# The leaf pipeline on the shared real sheet (when present): segmentation and one leaf lit from
# the front and from behind.
sheet="$root/../shared/data/leaf-sheet"
if [ -d "$sheet" ]; then
  "$matfit" leaf "$sheet" --out "$tmp/leaves" --quiet >/dev/null
  cp "$tmp/leaves/segmentation.png" "$root/docs/images/leaf-sheet-segmentation.png"
  for side in front back; do
    cp "$tmp/leaves/leaf_20/preview_$side.png" "$root/docs/images/leaf-sheet-leaf20-$side.png"
  done
fi
echo "docs/images: $(ls "$root/docs/images" | wc -l) previews"
