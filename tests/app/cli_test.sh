#!/usr/bin/env bash
# End-to-end: `matfit synth` writes every layout, `matfit info` reads each back (auto-detect),
# bad input exits non-zero with a message naming the problem.
# Usage: cli_test.sh MATFIT_BINARY SOURCE_DIR SHARED_DATA_DIR
set -u
bin=$1; src=$2; shared=$3
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
pass=0; fail=0
ok()   { pass=$((pass+1)); }
bad()  { fail=$((fail+1)); echo "FAIL: $*"; }
expect_contains() { # name, haystack, needle
  if grep -qF -- "$3" <<<"$2"; then ok; else bad "$1: output lacks '$3'"; echo "$2" | head -20; fi
}

for layout in bonn utia lp diligent lights-txt; do
  out="$tmp/obj-$layout"
  if "$bin" synth --material plastic --lights ring12 --size 16 --layout "$layout" --out "$out" >/dev/null; then ok; else bad "synth $layout"; continue; fi
  info=$("$bin" info "$out" --quiet 2>&1) || bad "info $layout exited non-zero"
  expect_contains "info $layout" "$info" "layout       $layout"
  expect_contains "info $layout" "$info" "images       12 x 16x16"
  # ring12 is one elevation: exactly one warning, the elevation span (issue #21).
  expect_contains "info $layout" "$info" "warning      elevation-span: every light lies at θl 45.0°...45.0°"
  [ "$(grep -c '^warning' <<<"$info")" -eq 1 ] && ok || bad "info $layout: other warnings than elevation-span"
done

# Every named material renders; bonn81 reports its groups.
for m in plaster plastic plastic-ct wool corduroy granite leaf micro-stone; do
  "$bin" synth --material $m --lights bonn81 --size 8 --noise 0.01 --shadows --clip 0.9 --seed 3 \
    --layout bonn --bits 8 --out "$tmp/m-$m" >/dev/null && ok || bad "synth material $m"
done
info=$("$bin" info "$tmp/m-wool" --quiet)
expect_contains "bonn groups" "$info" "0°:1 15°:6 30°:12 45°:18 60°:20 75°:24"
expect_contains "bonn colour" "$info" "sRGB"
json=$("$bin" info "$tmp/m-wool" --quiet --json)
expect_contains "info json" "$json" '"images": 81'

# Coplanar lights are reported.
"$bin" synth --material plaster --lights ring:8:89 --size 8 --layout lp --out "$tmp/flat" >/dev/null
expect_contains "ill-conditioned" "$("$bin" info "$tmp/flat" --quiet)" "ill-conditioned"

# Errors: clear message, non-zero exit, nothing left behind.
mkdir -p "$tmp/empty"
msg=$("$bin" info "$tmp/empty" 2>&1); rc=$?
[ $rc -ne 0 ] && ok || bad "info on empty folder should fail"
expect_contains "empty folder" "$msg" "is empty"
msg=$("$bin" synth --material velvet --out "$tmp/v" 2>&1); rc=$?
[ $rc -ne 0 ] && ok || bad "unknown material should fail"
expect_contains "unknown material" "$msg" "choose one of: plaster"
[ ! -e "$tmp/v" ] && ok || bad "failed synth left output"
# micro-stone: its truth is micro-geometry (params.json says so), and its size is capped.
grep -q '"appearance": "micro-geometry"' "$tmp/m-micro-stone/truth/params.json" && ok || bad "micro-stone params"
msg=$("$bin" synth --material micro-stone --size 600 --out "$tmp/big" 2>&1); rc=$?
[ $rc -ne 0 ] && ok || bad "micro-stone 600² should fail"
expect_contains "micro-stone size" "$msg" "at most 512 texels per side"
[ ! -e "$tmp/big" ] && ok || bad "failed micro-stone synth left output"
msg=$("$bin" synth --material plaster --out "$tmp/obj-lp" 2>&1); rc=$?
[ $rc -ne 0 ] && ok || bad "existing output should fail without --force"
expect_contains "existing output" "$msg" "--force"
msg=$("$bin" info "$tmp/obj-bonn" --view 45,10 2>&1); rc=$?
[ $rc -ne 0 ] && ok || bad "missing view should fail"
expect_contains "missing view" "$msg" "available views"
"$bin" synth --help | grep -q -- "--material" && ok || bad "synth --help"
"$bin" info --help | grep -q -- "--layout" && ok || bad "info --help"
"$bin" --help | grep -q "synth" && ok || bad "--help"

# matfit fit: every model on a fixture, summary table, pack on disk; errors are clear.
for model in mean lambert heinrich ptm; do
  out=$("$bin" fit "$src/fixtures/plaster-bonn81" --model $model --holdout 3 --out "$tmp/pack-$model" --quiet 2>&1) \
    && ok || bad "fit $model: $out"
  expect_contains "fit $model table" "$out" "held-out    rmse"
  [ -f "$tmp/pack-$model/material.json" ] && ok || bad "fit $model wrote no material.json"
done
expect_contains "fit truth" "$("$bin" fit "$src/fixtures/plaster-bonn81" --model lambert --out "$tmp/p2" --quiet)" "vs truth    normal MAE"
# Leave-one-out: one fold per image (plastic-ring12: 12), scored in linear and sRGB 8-bit, with
# the bound's tightness against those lights and against truth/.
out=$("$bin" fit "$src/fixtures/plastic-ring12" --model lambert --holdout loo --out "$tmp/ploo" --quiet 2>&1) \
  && ok || bad "fit --holdout loo: $out"
expect_contains "loo folds" "$out" "over 12 folds"
expect_contains "loo sRGB" "$out" "sRGB 8-bit PSNR"
expect_contains "bound vs held-out" "$out" "the held-out lights error"
expect_contains "bound vs truth" "$out" "the truth error"
msg=$("$bin" fit "$src/fixtures/plastic-ring12" --model lambert --holdout -3 --out "$tmp/pneg" 2>&1); rc=$?
[ $rc -ne 0 ] && ok || bad "--holdout -3 should fail"
expect_contains "negative holdout" "$msg" "or loo (leave-one-out)"
expect_contains "model list" "$("$bin" fit --model list)" "heinrich"
msg=$("$bin" fit "$src/fixtures/plaster-bonn81" --model velvet --out "$tmp/pv" 2>&1); rc=$?
[ $rc -ne 0 ] && ok || bad "unknown model should fail"
expect_contains "unknown model" "$msg" "choose one of: mean"
msg=$("$bin" fit "$src/fixtures/plastic-ring12" --model heinrich --out "$tmp/pr" 2>&1); rc=$?
[ $rc -ne 0 ] && ok || bad "heinrich on a ring should fail"
expect_contains "heinrich ring" "$msg" "inseparable"
msg=$("$bin" fit "$src/fixtures/plastic-ring12" --model blinn-phong --robust-scale -1 --out "$tmp/ps" 2>&1); rc=$?
[ $rc -ne 0 ] && ok || bad "negative --robust-scale should fail"
expect_contains "robust scale" "$msg" "--robust-scale must be in [0, 10]"
[ ! -e "$tmp/pv" ] && [ ! -e "$tmp/pr" ] && [ ! -e "$tmp/ps" ] && [ ! -e "$tmp/pneg" ] && ok || bad "failed fit left output"

# Preview renderer.
out=$("$bin" render "$tmp/pack-ptm" --light 40,30 --scene sphere --size 64 --out "$tmp/bp.png" 2>&1) \
  && ok || bad "render: $out"
[ -s "$tmp/bp.png" ] && ok || bad "render wrote no PNG"
out=$("$bin" render "$tmp/pack-heinrich" --light 60,0 --sweep 4 --size 32 --backend cpu --out "$tmp/sweep.exr" 2>&1) \
  && ok || bad "render sweep: $out"
expect_contains "render sweep size" "$out" "64 × 64"
out=$("$bin" render "$tmp/pack-lambert" --scene cloth --camera 40,-30 --size 48 --out "$tmp/cloth.png" 2>&1) \
  && ok || bad "render cloth with a tilted camera: $out"
msg=$("$bin" render "$tmp/pack-lambert" --camera 85,0 --out "$tmp/x.png" 2>&1); rc=$?
[ $rc -ne 0 ] && ok || bad "camera θ > 80 should fail"
expect_contains "render camera" "$msg" "θ must be in [0, 80]"
msg=$("$bin" render "$tmp/pack-lambert" --scene cube --out "$tmp/x.png" 2>&1); rc=$?
[ $rc -ne 0 ] && ok || bad "unknown scene should fail"
expect_contains "render scene" "$msg" "choose one of: plane, sphere, cloth"
msg=$("$bin" render "$tmp/pack-lambert" --out "$tmp/x.jpg" 2>&1); rc=$?
[ $rc -ne 0 ] && ok || bad "jpg output should fail"
expect_contains "render out" "$msg" ".png (8-bit sRGB) or .exr"
# No EGL display (glvnd pointed at no vendor): a clear error with --backend egl, the CPU otherwise.
msg=$(__EGL_VENDOR_LIBRARY_FILENAMES=/nonexistent.json "$bin" render "$tmp/pack-lambert" --backend egl --out "$tmp/noegl.png" 2>&1); rc=$?
[ $rc -ne 0 ] && [ ! -e "$tmp/noegl.png" ] && ok || bad "--backend egl without EGL should fail"
expect_contains "no egl" "$msg" "EGL renderer unavailable"
msg=$(__EGL_VENDOR_LIBRARY_FILENAMES=/nonexistent.json "$bin" render "$tmp/pack-lambert" --out "$tmp/noegl.png" 2>&1) \
  && ok || bad "auto backend without EGL should fall back: $msg"
expect_contains "cpu fallback" "$msg" "with the CPU reference renderer"
msg=$("$bin" render "$tmp/nonexistent-pack" --out "$tmp/x.png" 2>&1); rc=$?
[ $rc -ne 0 ] && [ ! -e "$tmp/x.png" ] && ok || bad "missing pack should fail without output"

# Bundled fixtures and real data.
for f in "$src"/fixtures/*/; do
  "$bin" info "$f" --quiet >/dev/null && ok || bad "info fixture $f"
done
if [ -d "$shared/psm/cat" ]; then
  expect_contains "psm cat" "$("$bin" info "$shared/psm/cat" --quiet)" "layout       lights-txt"
  expect_contains "leaf sheet" "$("$bin" info "$shared/leaf-sheet" --quiet)" "gamma 2.2"
else
  echo "shared data not found at $shared: skipping real-data CLI checks"
fi

echo "$pass passed, $fail failed"
[ $fail -eq 0 ]
