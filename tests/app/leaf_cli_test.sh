#!/usr/bin/env bash
# End-to-end `matfit leaf`: a synthetic scan → packs + leaves.json; bad arguments and input exit
# non-zero naming the problem; the glTF validator accepts a leaf pack; the shared sheet (when
# present) yields its 23 leaves and names its leaves with many flagged texels; every stage of
# leaf and synth shows progress.
# Usage: leaf_cli_test.sh MATFIT_BINARY SOURCE_DIR SHARED_DATA_DIR
set -u
bin=$1; src=$2; shared=$3
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
pass=0; fail=0
ok()   { pass=$((pass+1)); }
bad()  { fail=$((fail+1)); echo "FAIL: $*"; }
expect_contains() { # name, haystack, needle
  if grep -qF -- "$3" <<<"$2"; then ok; else bad "$1: output lacks '$3'"; echo "$2" | head -20; fi
}

out=$("$bin" leaf "$src/fixtures/leaf-scan" --out "$tmp/leaf" --quiet 2>&1) && ok || bad "leaf fixture: $out"
expect_contains "leaf count" "$out" "found       1 leaves, 0 twigs, 4 markers"
expect_contains "leaf scale" "$out" "scale       0.2 mm/pixel (markers)"
for f in leaves.json segmentation.png transmission.exr leaf_01/material.json leaf_01/material.gltf \
         leaf_01/report.json leaf_01/preview_front.png leaf_01/preview_back.png \
         leaf_01/maps/hl2.exr leaf_01/maps/thickness.exr leaf_01/maps/translucency.exr \
         leaf_01/viewer/params.bin; do
  [ -s "$tmp/leaf/$f" ] && ok || bad "leaf output lacks $f"
done
expect_contains "leaves.json" "$(cat "$tmp/leaf/leaves.json")" '"schema": "matfit.leaves/1"'
expect_contains "gltf extension" "$(cat "$tmp/leaf/leaf_01/material.gltf")" "KHR_materials_diffuse_transmission"

# Without --quiet every stage reports progress (issue #21: `leaf` was silent for most of a run);
# on a pipe these are plain lines, one at least per stage when it completes.
out=$("$bin" leaf "$src/fixtures/leaf-scan" --out "$tmp/leaf-progress" 2>&1) && ok || bad "leaf progress run: $out"
for stage in read sheet leaves write; do
  expect_contains "leaf progress $stage" "$out" "$stage [####################] 100%"
done
expect_contains "leaf sheet steps" "$out" "sheet [####################] 100% 15/15"
expect_contains "leaf per-leaf steps" "$out" "leaves [####################] 100% 5/5"
out=$("$bin" synth --size 16 --lights ring12 --out "$tmp/synth-progress" 2>&1) && ok || bad "synth: $out"
expect_contains "synth render progress" "$out" "render [####################] 100% 12/12"
expect_contains "synth write progress" "$out" "write [####################] 100% 12/12"
out=$("$bin" synth --leaf-scan --size 48 --out "$tmp/scan-progress" 2>&1) && ok || bad "synth scan: $out"
expect_contains "synth scan render progress" "$out" "render [####################] 100% 15/15"
expect_contains "synth scan write progress" "$out" "write [####################] 100% 20/20"

# The pack renders with the leaf shader, lit from behind.
out=$("$bin" render "$tmp/leaf/leaf_01" --light 150,45 --size 32 --backend cpu --out "$tmp/back.png" 2>&1) \
  && ok || bad "render leaf pack from behind: $out"

# Refusals.
msg=$("$bin" leaf "$src/fixtures/leaf-scan" --out "$tmp/leaf" --quiet 2>&1) && bad "existing --out accepted" || ok
expect_contains "existing out" "$msg" "already exists"
msg=$("$bin" leaf "$src/fixtures/leaf-scan" --out "$tmp/x" --nl 2 2>&1) && bad "--nl 2 accepted" || ok
expect_contains "nl" "$msg" "N_L"
msg=$("$bin" leaf "$src/fixtures/leaf-scan" --out "$tmp/x" --precompute slow 2>&1) && bad "--precompute slow accepted" || ok
expect_contains "precompute" "$msg" "choose fast or reference"
msg=$("$bin" leaf "$tmp/nowhere" --out "$tmp/x" 2>&1) && bad "missing folder accepted" || ok
expect_contains "missing" "$msg" "does not exist"
msg=$("$bin" leaf "$src/fixtures/leaf-scan" --out "$tmp/x" --leaf 7 2>&1) && bad "--leaf 7 accepted" || ok
expect_contains "leaf id" "$msg" "the sheet has leaves 1..1"
mkdir -p "$tmp/noback" && cp "$src/fixtures/leaf-scan/1_TL.png" "$tmp/noback/"
msg=$("$bin" leaf "$tmp/noback" --out "$tmp/x" 2>&1) && bad "no back-lit images accepted" || ok
expect_contains "no back" "$msg" "no back-lit images"
[ ! -e "$tmp/x" ] && ok || bad "a failed run left output behind"

# glTF validator (when installed).
if [ -d "$src/tools/gltf/node_modules/gltf-validator" ] && command -v node >/dev/null; then
  v=$(node "$src/tools/gltf/validate.mjs" "$tmp/leaf/leaf_01/material.gltf" 2>&1) && ok || bad "gltf validator: $v"
  # The core-glTF stand-in for light from behind.
  v=$(node "$src/tools/gltf/validate.mjs" "$tmp/leaf/leaf_01/material_backlit.gltf" 2>&1) && ok ||
    bad "gltf validator (material_backlit.gltf): $v"
  echo "leaf pack: $v" | tail -1
else
  echo "gltf-validator not installed: skipping the leaf pack validation"
fi

# The shared sheet, end to end.
if [ -d "$shared/leaf-sheet" ]; then
  start=$(date +%s.%N)
  out=$("$bin" leaf "$shared/leaf-sheet" --out "$tmp/sheet" --quiet 2>&1) && ok || bad "leaf sheet: $out"
  end=$(date +%s.%N)
  expect_contains "sheet leaves" "$out" "found       23 leaves"
  expect_contains "sheet scale" "$out" "no physical scale"
  # The summary names the leaves with many flagged texels (issue #21), e.g. the 88 % one.
  expect_contains "sheet flagged" "$out" "warning     leaf-flagged: 15 of 23 leaves have more than 20 %"
  expect_contains "sheet flagged" "$out" "leaf_16 88 %"
  [ "$(ls -d "$tmp"/sheet/leaf_* | wc -l)" -eq 23 ] && ok || bad "sheet: expected 23 leaf packs"
  echo "shared sheet end to end: $(echo "$end - $start" | bc) s wall"
else
  echo "shared data not found at $shared: skipping the real leaf sheet"
fi

echo "$pass passed, $fail failed"
[ $fail -eq 0 ]
