#!/usr/bin/env bash
# Nothing silent (issue #21): each case that used to pass with "warnings none" now warns, with its
# code, in `matfit info` (text and --json), in the fit's summary and in report.json `warnings`.
# Cases: a lights.txt with fewer lights than images (now an error), RGBA images with a mask file,
# gamma-encoded 16-bit TIFFs
# without colour metadata (and the encoding assumed for them), a 262° light-azimuth gap, lights at
# one elevation.
# Usage: warnings_test.sh MATFIT_BINARY PROJECT_ROOT
set -u
bin=$1; src=$2
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
. "$src/tests/app/lib.sh"
cd "$tmp"
command -v oiiotool >/dev/null || { echo "oiiotool missing (openimageio-tools)"; exit 1; }

# warns NAME DIR CODE [OPTION...]: info (text and JSON) names the warning.
warns() {
  local info name=$1 dir=$2 code=$3
  shift 3
  info=$("$bin" info "$dir" --quiet "$@" 2>&1) || bad "$name: info failed: $info"
  expect_contains "$name info" "$info" "warning      $code: "
  info=$("$bin" info "$dir" --quiet --json "$@" 2>&1)
  expect_contains "$name info --json" "$info" "\"$code: "
}
# fit_warns NAME DIR CODE [OPTION...]: the fit's summary and its report.json carry the warning.
fit_warns() {
  local out name=$1 dir=$2 code=$3
  shift 3
  out=$("$bin" fit "$dir" --model lambert --out "$tmp/pack-$name" --quiet "$@" 2>&1) ||
    bad "$name: fit failed: $out"
  expect_contains "$name fit summary" "$out" "warning     $code: "
  expect_contains "$name report.json" "$(cat "$tmp/pack-$name/report.json")" "\"$code: "
}

# A clean set first: two dozen lights over a dome, 16-bit linear PNG.
"$bin" synth --material plaster --lights dome:24 --layout lights-txt --size 24 --out ds --quiet ||
  bad "synth ds"
expect_contains "clean set" "$("$bin" info ds --quiet)" "warnings     none"

# 1. lights.txt lists 23 lights beside 24 numbered images: an error, never a silent drop.
mkdir count && cp -r ds count/ds
{ echo 23; sed -n 2,24p ds/lights.txt; } >count/ds/lights.txt
out=$("$bin" info count/ds --quiet 2>&1) && bad "count: info accepted 23 lights for 24 images"
expect_contains "count info" "$out" "lists 23 lights but the folder has numbered images ds.0 to ds.23: 24 image(s)"
out=$("$bin" fit count/ds --model lambert --out "$tmp/pack-count" --quiet 2>&1) &&
  bad "count: fit accepted 23 lights for 24 images"
expect_contains "count fit" "$out" "lists 23 lights but"
[ ! -e "$tmp/pack-count" ] || bad "count: a failed fit left its output folder"

# 2. RGBA images: the alpha channel is the mask (opaque everywhere: every texel, and said; else
# the texels it covers); with a mask file as well, the mask file wins and the alpha is said to be
# unused.
mkdir rgba && cp -r ds rgba/ds
for f in rgba/ds/ds.*.png; do oiiotool "$f" --ch R,G,B,A=1.0 -o "$f"; done
expect_contains "rgba opaque info" "$("$bin" info rgba/ds --quiet)" \
  "mask         none: the alpha channel (24 of 24 images) is opaque everywhere (all texels)"
oiiotool --pattern constant:color=1 24x24 1 --fill:color=0 24x4+0+20 -d uint16 -o alpha.png
for f in rgba/ds/ds.*.png; do
  oiiotool "$f" --ch R,G,B alpha.png --chappend --chnames R,G,B,A -o "$f"
done
expect_contains "rgba info" "$("$bin" info rgba/ds --quiet)" \
  "mask         480 of 576 texels, from the alpha channel (24 of 24 images)"
oiiotool --pattern constant:color=1 24x24 1 --fill:color=0 12x24+0+0 -d uint8 -o rgba/ds/ds.mask.png
warns rgba rgba/ds alpha-dropped
fit_warns rgba rgba/ds alpha-dropped
expect_contains "rgba mask file" "$("$bin" info rgba/ds --quiet)" \
  "mask         288 of 576 texels, from the mask file 'rgba/ds/ds.mask.png'"

# 3. sRGB-encoded values in 16-bit TIFFs without colour metadata (read as linear).
"$bin" synth --material plaster --lights dome:24 --layout lights-txt --size 24 --bits 8 --out g8 \
  --quiet || bad "synth g8"
mkdir -p gamma/g8 && cp g8/lights.txt gamma/g8/
for f in g8/g8.*.png; do
  oiiotool "$f" --eraseattrib oiio:ColorSpace -d uint16 -o "gamma/g8/$(basename "$f" .png).tif"
done
# Read as linear (the 16-bit convention, or the user's choice) they look gamma-encoded; with
# --color-space auto (the default) the stack's own tone curve wins: re-read as sRGB, and said.
warns gamma gamma/g8 gamma-encoded --color-space linear
fit_warns gamma gamma/g8 gamma-encoded --color-space linear
warns gamma-auto gamma/g8 tone-corrected
fit_warns gamma-auto gamma/g8 tone-corrected
expect_contains "gamma auto colour" "$("$bin" info gamma/g8 --quiet)" "colour       sRGB (tone-curve estimate"
expect_contains "gamma auto report" "$(cat "$tmp/pack-gamma-auto/report.json")" '"to": "sRGB"'
# Linear values in 16-bit TIFFs without metadata: read as linear by the convention, which the
# stack confirms (no correction), and the assumption is said.
mkdir -p assumed/ds && cp ds/lights.txt assumed/ds/
for f in ds/ds.*.png; do
  oiiotool "$f" --eraseattrib oiio:ColorSpace -d uint16 -o "assumed/ds/$(basename "$f" .png).tif"
done
warns assumed assumed/ds encoding-assumed
expect_contains "assumed colour" "$("$bin" info assumed/ds --quiet)" "colour       linear (default for high bit depth"

# 4. All lights within φ 0…98°: a 262° azimuth gap (θ spread over 20…66°, so no elevation warning).
mkdir gap && cp -r ds gap/ds
awk 'NR == 1 {print; next} {
  i = NR - 2; t = (20 + 2 * i) * 3.14159265 / 180; p = (98 * i / 23) * 3.14159265 / 180
  printf "%.9f %.9f %.9f\n", sin(t) * cos(p), sin(t) * sin(p), cos(t) }' ds/lights.txt >gap/ds/lights.txt
warns gap gap/ds azimuth-gap
expect_contains "gap figure" "$("$bin" info gap/ds --quiet)" "largest azimuth gap 262°"
[ "$(grep -c '^warning' <<<"$("$bin" info gap/ds --quiet)")" -eq 1 ] && ok ||
  bad "gap: other warnings than azimuth-gap"

# 5. One elevation (a ring): elevation-span.
"$bin" synth --material plaster --lights ring:16:40 --layout lights-txt --size 24 --out ring --quiet ||
  bad "synth ring"
warns ring ring elevation-span

echo "warnings_test: $pass passed, $fail failed"
[ "$fail" -eq 0 ]
