#!/usr/bin/env bash
# The inputs labs have, end to end (issue 20, item 3): --crop on info, fit and leaf (the region's
# maps equal the same region of a whole fit; report.json and leaves.json say which region; a
# region outside the images is refused naming it); an RTIBuilder .lp with Windows paths; a
# lights.txt folder with its own image names.
# Usage: inputs_cli_test.sh MATFIT_BINARY SOURCE_DIR
set -u
bin=$1; src=$2
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
. "$src/tests/app/lib.sh"
cd "$tmp"
command -v oiiotool >/dev/null || { echo "oiiotool missing (openimageio-tools)"; exit 1; }

"$bin" synth --material granite --lights dome:24 --layout lights-txt --size 32 --noise 0.01 \
  --out ds --quiet || bad "synth ds"

# info: the region and its size.
out=$("$bin" info ds --crop 4,6,20,16 --quiet 2>&1) || bad "info --crop: $out"
expect_contains "info crop size" "$out" "images       24 x 20x16"
expect_contains "info crop region" "$out" "region       20x16 at 4,6 of the 32x32 images (--crop)"
expect_contains "info crop json" "$("$bin" info ds --crop 4,6,20,16 --quiet --json)" '"source_width": 32'

# fit: a per-texel model's maps of the region are the whole fit's, cut.
"$bin" fit ds --model lambert --out whole --quiet >/dev/null || bad "whole fit"
out=$("$bin" fit ds --model lambert --crop 4,6,20,16 --out part --quiet 2>&1) || bad "fit --crop: $out"
expect_contains "fit crop texels" "$out" "texels      20 x 16"
expect_contains "fit crop truth" "$out" "vs truth    normal MAE"  # the truth is cut to the region
for map in normal albedo; do
  oiiotool whole/maps/$map.exr --cut 20x16+4+6 --origin +0+0 --fullsize 20x16+0+0 -o cut-$map.exr
  d=$(oiiotool --diff --fail 1e-6 cut-$map.exr part/maps/$map.exr 2>&1) && ok ||
    bad "crop $map differs from the whole fit's region: $d"
done
expect_contains "report crop" "$(cat part/report.json)" '"crop": {'
expect_contains "report crop x" "$(tr -d ' \n' <part/report.json)" '"crop":{"height":16,"source_height":32,"source_width":32,"width":20,"x":4,"y":6}'
expect_contains "report no crop" "$(tr -d ' \n' <whole/report.json)" '"crop":null'

# Refusals name the flag and the value.
out=$("$bin" fit ds --model lambert --crop 4,6,20 --out bad1 --quiet 2>&1) && bad "--crop with 3 numbers accepted"
expect_contains "crop malformed" "$out" "--crop '4,6,20' must be X,Y,WIDTH,HEIGHT"
out=$("$bin" info ds --crop 20,20,20,20 --quiet 2>&1) && bad "a region outside the images accepted"
expect_contains "crop outside" "$out" "--crop 20,20,20,20 (x,y,width,height) reaches outside the 32x32 images"
[ ! -e bad1 ] || bad "a refused fit left its output folder"

# leaf: the sheet's region (the 112x88 sheet less a 2-pixel rim: the leaf and the four markers
# inside it, their bounding boxes moved by the offset).
out=$("$bin" leaf "$src/fixtures/leaf-scan" --crop 2,1,108,86 --out leaf --quiet 2>&1) || bad "leaf --crop: $out"
expect_contains "leaf crop found" "$out" "found       1 leaves, 0 twigs, 4 markers"
expect_contains "leaf crop scale" "$out" "scale       0.2 mm/pixel (markers)"
j=$(tr -d ' \n' <leaf/leaves.json)
expect_contains "leaf crop size" "$j" '"size":{"height":86,"width":108}'
expect_contains "leaf crop field" "$j" '"crop":{"height":86,"width":108,"x":2,"y":1}'
expect_contains "leaf crop bbox" "$j" '"bbox":[31,16,46,54]'
expect_contains "leaf crop marker" "$j" '"bbox":[87,64,20,20]'
out=$("$bin" leaf "$src/fixtures/leaf-scan" --crop 100,0,20,20 --out leaf2 --quiet 2>&1) && bad "leaf crop outside accepted"
expect_contains "leaf crop outside" "$out" "reaches outside the 112x88 images"

# An RTIBuilder .lp written on Windows: absolute paths, images beside the .lp (with a note).
"$bin" synth --material plaster --lights dome:12 --layout lp --size 16 --out rti --quiet || bad "synth rti"
lp=$(ls rti/*.lp)
awk 'NR == 1 {print; next} {printf "C:\\Users\\lab\\RTI\\jpeg-exports\\%s %s %s %s\n", $1, $2, $3, $4}' \
  "$lp" >"$lp.new" && mv "$lp.new" "$lp"
out=$("$bin" info rti --quiet 2>&1) || bad "info on a Windows .lp: $out"
expect_contains "lp windows" "$out" "warning      lp-path-fallback: 12 of 12 image paths"
"$bin" fit rti --model lambert --out rti-pack --quiet >/dev/null || bad "fit on a Windows .lp"

# lights.txt with the camera's own names (IMG_0001.JPG ...) in a folder of any name.
mkdir -p "shoot 2026-12-05"
cp ds/lights.txt "shoot 2026-12-05/"
for i in $(seq 0 23); do cp "ds/ds.$i.png" "shoot 2026-12-05/IMG_$(printf %04d $((i + 1))).png"; done
out=$("$bin" info "shoot 2026-12-05" --quiet 2>&1) || bad "info on camera names: $out"
expect_contains "camera names layout" "$out" "image files (in light order by name)"
"$bin" fit "shoot 2026-12-05" --model lambert --out named --quiet >/dev/null || bad "fit on camera names"
d=$(oiiotool --diff --fail 1e-6 whole/maps/normal.exr named/maps/normal.exr 2>&1) && ok ||
  bad "camera-named set fits differently from the numbered one: $d"

# Height map in every pack with normals (issue 20, item 4): height.exr in texel units and a 16-bit
# height.png whose range material.json gives; the fitted relief of a synthetic stone is the
# truth's within 25 % (Lambert normals of a shadowed, interreflecting micro-geometry are biased;
# exact normals integrate within 0.2 %: tests/core/height_test.cc); none for a model without
# normals.
"$bin" synth --material micro-stone --lights dome:24 --size 96 --out stone --quiet || bad "synth stone"
"$bin" fit stone --model lambert --out stone-pack --quiet >/dev/null || bad "fit stone"
for f in height.exr height.png; do [ -s stone-pack/maps/$f ] && ok || bad "lambert pack lacks maps/$f"; done
expect_contains "height range" "$(tr -d ' \n' <stone-pack/material.json)" '"name":"height","range_texels":['
relief() { oiiotool --stats "$1" 2>/dev/null | awk '/Stats Min/ {lo = $3} /Stats Max/ {hi = $3} END {print hi - lo}'; }
t=$(relief stone/truth/height.exr); f=$(relief stone-pack/maps/height.exr)
awk -v t="$t" -v f="$f" 'BEGIN {exit !(t > 0.5 && f > 0.75 * t && f < 1.25 * t)}' && ok ||
  bad "height relief $f vs the truth's $t"
echo "height relief: fitted $f, truth $t (texels)"
"$bin" fit stone --model ptm --out stone-ptm --quiet >/dev/null || bad "fit stone ptm"
[ ! -e stone-ptm/maps/height.exr ] && ok || bad "a ptm pack (no normals) has a height map"

# PTM export (issue 20, item 4 part): ptm packs carry material.ptm (RGB) and material_lrgb.ptm
# (the bytes are checked against the fit by tests/core/ptm_export_test.cc); other models none.
"$bin" fit stone --model ptm-srgb --out stone-ptm-srgb --quiet >/dev/null || bad "fit stone ptm-srgb"
for d in stone-ptm stone-ptm-srgb; do
  expect_contains "$d header" "$(head -c 16 $d/material.ptm)" "PTM_1.2"
  expect_contains "$d format" "$(head -n 4 $d/material.ptm | tr '\n' ' ')" "PTM_FORMAT_RGB 96 96"
  expect_contains "$d lrgb" "$(head -n 2 $d/material_lrgb.ptm | tr '\n' ' ')" "PTM_1.2 PTM_FORMAT_LRGB"
  expect_contains "$d exports" "$(tr -d ' \n' <$d/material.json)" '"exports":[{"file":"material.ptm"'
done
[ ! -e stone-pack/material.ptm ] && ok || bad "a lambert pack has a .ptm"
# HSH .rti for hsh2/hsh3 packs (bytes checked by tests/core/rti_export_test.cc).
"$bin" fit stone --model hsh3-srgb --out stone-hsh --quiet >/dev/null || bad "fit stone hsh3-srgb"
expect_contains "rti header" "$(head -n 5 stone-hsh/material.rti | tr '\n' ' ')" "#HSH1.2 #written by matfit 3 96 96 3 9 2 1"
expect_contains "rti exports" "$(tr -d ' \n' <stone-hsh/material.json)" '"file":"material.rti"'
[ ! -e stone-ptm/material.rti ] && ok || bad "a ptm pack has an .rti"
# The relight / OpenLIME web layout for ptm and hsh packs (read back against the fit by
# tests/core/relight_export_test.cc): info.json + plane_<i>.jpg, three coefficient planes each.
expect_contains "relight ptm" "$(tr -d ' \n\t' <stone-ptm-srgb/relight/info.json)" '"nplanes":18'
expect_contains "relight hsh" "$(tr -d ' \n\t' <stone-hsh/relight/info.json)" '"type":"hsh"'
[ -s stone-ptm-srgb/relight/plane_5.jpg ] && [ ! -e stone-ptm-srgb/relight/plane_6.jpg ] && ok ||
  bad "a ptm web layout has 6 planes"
[ -s stone-hsh/relight/plane_8.jpg ] && ok || bad "an hsh3 web layout has 9 planes"
expect_contains "relight exports" "$(tr -d ' \n' <stone-hsh/material.json)" '"file":"relight/info.json"'
[ ! -e stone-pack/relight ] && ok || bad "a lambert pack has a relight layout"

echo "inputs_cli_test: $pass passed, $fail failed"
[ "$fail" -eq 0 ]
