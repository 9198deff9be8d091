#!/usr/bin/env bash
# --force replaces only what matfit wrote (issue #21): every subcommand that writes --out refuses
# a folder or file that holds something of the user's, names it, and leaves it untouched; a
# folder or file matfit wrote is replaced whole (no temporary left behind, no old file kept).
# Usage: force_test.sh MATFIT_BINARY PROJECT_ROOT
set -u
bin=$1; src=$2
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
. "$src/tests/app/lib.sh"
cd "$tmp"

# refuses NAME OUTPUT -- COMMAND…: the command must fail naming OUTPUT and keep the user's file.
refuses() {
  local name=$1 target=$2; shift 3
  local out rc
  out=$("$@" 2>&1); rc=$?
  [ $rc -ne 0 ] && ok || bad "$name: --force on a foreign '$target' must fail"
  expect_contains "$name names it" "$out" "'$target'"
  expect_contains "$name says why" "$out" "--force only replaces what matfit wrote"
}
user_folder() { rm -rf "$1"; mkdir -p "$1"; echo "my notes" > "$1/notes.txt"; }
kept() { [ "$(cat "$1/notes.txt" 2>/dev/null)" = "my notes" ] && ok || bad "$2: the user's file was touched"; }
no_temporaries() { [ -z "$(ls -A | grep -E '\.tmp-|\.old$')" ] && ok || bad "$1: temporaries left: $(ls -A)"; }

"$bin" synth --size 16 --lights ring12 --layout lp --out ds --quiet || bad "synth ds"
"$bin" fit ds --model lambert --out pack --quiet >/dev/null || bad "fit pack"

# 1. A user's folder is refused by every writer, with --force.
user_folder u
refuses synth u -- "$bin" synth --size 16 --lights ring12 --out u --force --quiet; kept u synth
refuses synth-leaf u -- "$bin" synth --leaf-scan --minimal --size 40 --out u --force --quiet; kept u synth-leaf
refuses fit u -- "$bin" fit ds --model lambert --out u --force --quiet; kept u fit
refuses leaf u -- "$bin" leaf "$src/fixtures/leaf-scan" --out u --force --quiet; kept u leaf
refuses bench u -- "$bin" bench --quick --methods mean --out u --force --quiet; kept u bench
cat > plan.json <<'P'
{"schema": "matfit.captureplan/1", "exposures_s": [0.004], "repeats": 1, "dark_frames": 0}
P
out=$("$bin" capture --camera 'sim:camera?material=plaster&size=16' --rig 'sim:rig?lights=ring:6:40' \
      --plan plan.json --out u --force --quiet 2>&1); rc=$?
[ $rc -ne 0 ] && ok || bad "capture: --force on a foreign folder must fail"
expect_contains "capture names it" "$out" "'u' exists and is not a capture"
kept u capture

# 2. A matfit folder that a user added a file to is refused too (the file is named).
echo "mine" > pack/notes.txt
refuses fit-extra pack -- "$bin" fit ds --model lambert --out pack --force --quiet
out=$("$bin" fit ds --model lambert --out pack --force --quiet 2>&1)
expect_contains "fit-extra names the file" "$out" "holds 'notes.txt'"
[ -f pack/notes.txt ] && ok || bad "fit-extra: the user's file was deleted"
rm pack/notes.txt

# 3. Foreign single files: zip, image, light file, report.
echo "not a zip" > user.zip
refuses fit-zip user.zip -- "$bin" fit ds --model lambert --out user.zip --zip --force --quiet
[ "$(cat user.zip)" = "not a zip" ] && ok || bad "fit-zip: user's zip replaced"
echo "user picture" > photo.png
refuses render photo.png -- "$bin" render pack --out photo.png --force --quiet
[ "$(cat photo.png)" = "user picture" ] && ok || bad "render: user's image replaced"
printf '2\na.png 0 0 1\nb.png 0 1 1\n' > user.lp
mkdir sphere  # refused before any image is read
refuses calibrate user.lp -- "$bin" calibrate-lights sphere --out user.lp --force --quiet
echo '{"mine": 1}' > report.json
refuses report-only report.json -- "$bin" fit ds --report-only pack --out report.json --force --quiet

# 4. Without --force an existing output is refused and the message says how to go on.
out=$("$bin" fit ds --model lambert --out pack --quiet 2>&1); rc=$?
[ $rc -ne 0 ] && ok || bad "fit without --force over a pack must fail"
expect_contains "no --force" "$out" "pass --force to replace it"
out=$("$bin" render pack --out r.png --quiet 2>&1) || bad "render r.png: $out"
out=$("$bin" render pack --out r.png --quiet 2>&1); rc=$?
[ $rc -ne 0 ] && ok || bad "render over an existing image without --force must fail"

# 5. What matfit wrote is replaced whole.
echo stale > stale.txt
"$bin" synth --size 16 --lights ring:8 --layout lp --out ds --force --quiet && ok || bad "synth --force over its dataset"
[ "$(ls ds | grep -c '^img_')" = 8 ] && ok || bad "ds not replaced (12 → 8 images): $(ls ds)"
"$bin" fit ds --model mean --out pack --force --quiet >/dev/null && ok || bad "fit --force over its pack"
python3 -c "import json,sys; sys.exit(json.load(open('pack/material.json'))['model']['name'] != 'mean')" &&
  ok || bad "pack not replaced by the mean fit"
"$bin" fit ds --model lambert --out p.zip --zip --quiet >/dev/null && \
  "$bin" fit ds --model lambert --out p.zip --zip --force --quiet >/dev/null && ok || bad "zip --force over its zip"
"$bin" render pack --out r.png --force --quiet && ok || bad "render --force over its image"
"$bin" fit ds --report-only pack --out rep.json --quiet >/dev/null &&
  "$bin" fit ds --report-only pack --out rep.json --force --quiet >/dev/null && ok || bad "report --force over its report"
"$bin" leaf "$src/fixtures/leaf-scan" --out leafpack --quiet --no-preview >/dev/null &&
  "$bin" leaf "$src/fixtures/leaf-scan" --out leafpack --force --quiet --no-preview >/dev/null && ok || bad "leaf --force over its pack"
no_temporaries "after the replacements"

echo "force_test: $pass passed, $fail failed"
[ $fail -eq 0 ]
