#!/usr/bin/env bash
# End-to-end: `matfit synth --format jpg` and non-square sizes, the stages and timings of
# `matfit fit` on the CLI and in report.json, and `matfit fit --decode-only`.
# Usage: whole_process_cli_test.sh MATFIT_BINARY
set -u
bin=$1
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
. "$(dirname "$0")/lib.sh"

# Synthetic JPEG stack, non-square, as an .lp set: info reads it back.
out=$("$bin" synth --material plastic --lights dome:24 --size 40x24 --format jpg --layout lp \
  --out "$tmp/jpg" 2>&1) && ok || bad "synth jpg: $out"
expect_contains "synth jpg summary" "$out" "24 images of 40x24 (lp layout, 8-bit JPEG)"
[ -f "$tmp/jpg/img_000.jpg" ] && ok || bad "synth jpg wrote no img_000.jpg"
[ -z "$(ls "$tmp/jpg" | grep -E '^img_.*\.png$')" ] && ok || bad "synth jpg also wrote PNG images"
grep -q "^img_023.jpg " "$tmp/jpg/lights.lp" && ok || bad "lights.lp does not name the .jpg files"
info=$("$bin" info "$tmp/jpg" --quiet 2>&1) || bad "info on the jpg stack exited non-zero: $info"
expect_contains "info jpg layout" "$info" "layout       lp"
expect_contains "info jpg size" "$info" "images       24 x 40x24"
expect_contains "info jpg colour" "$info" "sRGB"
# Non-square PNG (default format) in a BTF layout, and the truth maps follow the size.
"$bin" synth --material plaster --lights bonn81 --size 20x12 --layout bonn --out "$tmp/rect" \
  >/dev/null && ok || bad "synth 20x12"
expect_contains "info 20x12" "$("$bin" info "$tmp/rect" --quiet)" "images       81 x 20x12"
grep -q '"height": 12' "$tmp/rect/truth/params.json" && ok || bad "params.json lacks the height"

# Bad values name the flag, exit non-zero and leave nothing behind.
for args in "--size 40x" "--size 0x10" "--size 16x9000" "--format gif" "--format jpg --bits 16" \
            "--format exr --bits 8"; do
  msg=$("$bin" synth --material plaster --lights ring12 $args --layout lp --out "$tmp/bad" 2>&1); rc=$?
  [ $rc -ne 0 ] && ok || bad "synth $args should fail"
  flag=${args%% *}
  expect_contains "synth $args names the flag" "$msg" "$flag"
  [ ! -e "$tmp/bad" ] && ok || bad "synth $args left output"
done

# matfit fit with progress on: every stage that ran is named on stderr, timings in the summary
# and in report.json (each >= 0, their sum <= total, absent stages absent).
out=$("$bin" fit "$tmp/jpg" --model ptm --holdout 3 --out "$tmp/pack" 2>&1) && ok || bad "fit: $out"
for stage in read fit reconstruction confidence heldout truth write; do
  grep -qE "^$stage \[" <<<"$out" && ok || bad "fit progress lacks stage '$stage'"
done
expect_contains "fit timings line" "$out" "timings     read "
expect_contains "fit timings total" "$out" "; total "
python3 - "$tmp/pack/report.json" <<'PY' && ok || bad "report.json timings"
import json, sys
t = json.load(open(sys.argv[1]))["timings"]
stages = ["read", "fit", "reconstruction", "confidence", "heldout", "truth", "write"]
assert sorted(t) == sorted(stages + ["total"]), t
assert all(t[s] >= 0 for s in stages), t
assert sum(t[s] for s in stages) <= t["total"], t
PY
out=$("$bin" fit "$tmp/rect" --model mean --out "$tmp/pack2" --quiet 2>&1) && ok || bad "fit quiet: $out"
grep -qE "^(read|fit|write) \[" <<<"$out" && bad "--quiet still prints progress" || ok
python3 -c 'import json,sys; t=json.load(open(sys.argv[1]))["timings"]; assert "heldout" not in t and "select" not in t, t' \
  "$tmp/pack2/report.json" && ok || bad "report.json has timings of stages that did not run"

# The decode floor: the read stage alone, with the same threads; nothing written.
out=$("$bin" fit "$tmp/jpg" --decode-only --threads 1 2>&1) && ok || bad "decode-only: $out"
expect_contains "decode-only summary" "$out" "decoded     24 images of 40x24, 3 channels, 1 thread"
expect_contains "decode-only timings" "$out" "timings     read "
msg=$("$bin" fit "$tmp/jpg" --decode-only --out "$tmp/nope" 2>&1); rc=$?
[ $rc -ne 0 ] && ok || bad "--decode-only with --out should fail"
expect_contains "decode-only --out" "$msg" "--decode-only"
[ ! -e "$tmp/nope" ] && ok || bad "--decode-only wrote output"

# OpenImageIO is not linked: a fit of a JPEG stack that writes a PNG + EXR pack never loads it
# (ld.so lists every library it loads, dlopen included); a TIFF stack loads it as a module.
loads=$(LD_DEBUG=files "$bin" fit "$tmp/jpg" --model ptm --out "$tmp/pack3" --quiet 2>&1 | grep -c "OpenImageIO")
[ "$loads" -eq 0 ] && ok || bad "a JPEG -> PNG/EXR fit loaded OpenImageIO ($loads lines of LD_DEBUG)"
[ -f "$tmp/pack3/maps/coefficients.exr" ] && ok || bad "the ptm pack has no maps/coefficients.exr"
if command -v oiiotool >/dev/null; then
  mkdir "$tmp/tif"
  for f in "$tmp"/jpg/img_*.jpg; do
    oiiotool "$f" -o "$tmp/tif/$(basename "${f%.jpg}").tif" || bad "oiiotool could not convert $f"
  done
  sed 's/\.jpg /.tif /' "$tmp/jpg/lights.lp" >"$tmp/tif/lights.lp"
  out=$(LD_DEBUG=files "$bin" fit "$tmp/tif" --decode-only --threads 1 2>&1) && ok || bad "decode-only tif: $out"
  expect_contains "decode-only tif summary" "$out" "decoded     24 images of 40x24, 3 channels"
  grep -q "libmatfit_oiio.so" <<<"$out" && ok || bad "the TIFF stack did not load the OpenImageIO module"
else
  echo "skip: oiiotool missing (scripts/install-deps.sh), the TIFF case of the OpenImageIO module"
fi

echo "$pass passed, $fail failed"
[ $fail -eq 0 ]
