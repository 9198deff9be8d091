#!/usr/bin/env bash
# `matfit` runs fit, info and --version itself, linked against core and fit only, and hands every
# other command to matfit-full beside it by exec (app/main_lean.cc): the lean binary loads none of
# the heavy libraries, a handed-over command behaves as matfit-full's own (output, exit code), a
# fit and its pack are the same from either binary, and a missing matfit-full is a clear error.
# Usage: two_binaries_test.sh MATFIT_BINARY
set -u
matfit=$1
full="$(dirname "$matfit")/matfit-full"
source "$(dirname "$0")/lib.sh"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

[ -x "$full" ] || { bad "no matfit-full beside $matfit"; echo "FAILED: $fail"; exit 1; }
libs=$(ldd "$matfit")
for heavy in libpqxx libpq libcpp-httplib libssl libEGL libGLESv2 libopencv_core libmpi libusb \
  libarchive libsqlite3; do
  if grep -q "$heavy" <<<"$libs"; then bad "matfit links $heavy (it belongs to matfit-full)"; else ok; fi
done
grep -q "libjpeg" <<<"$libs" && ok || bad "matfit does not link libjpeg (fit reads JPEG stacks)"

# Handed over: the same output and exit code as matfit-full's own (run with matfit's argv[0]).
for args in "--help" "render --help" "serve --help" "synth --list" "bogus" "" "render /nonexistent-pack --out $tmp/x.png"; do
  # shellcheck disable=SC2086
  a=$("$matfit" $args 2>&1); ra=$?
  # shellcheck disable=SC2086
  b=$(exec -a "$matfit" "$full" $args 2>&1); rb=$?  # argv[0] as the hand-over keeps it
  [ "$ra" = "$rb" ] && ok || bad "matfit $args: exit $ra, matfit-full's $rb"
  [ "$a" = "$b" ] && ok || { bad "matfit $args: output differs from matfit-full's"; diff <(echo "$a") <(echo "$b") | head -5; }
done
# Run here: the same help, version and exit codes as matfit-full's.
for args in "--version" "fit --help" "info --help" "fit" "fit --model list"; do
  # shellcheck disable=SC2086
  a=$("$matfit" $args 2>&1); ra=$?
  # shellcheck disable=SC2086
  b=$(exec -a "$matfit" "$full" $args 2>&1); rb=$?  # argv[0] as the hand-over keeps it
  [ "$ra" = "$rb" ] && ok || bad "matfit $args: exit $ra, matfit-full's $rb"
  [ "$a" = "$b" ] && ok || { bad "matfit $args: output differs from matfit-full's"; diff <(echo "$a") <(echo "$b") | head -5; }
done

# A fit from either binary: identical maps and report figures.
"$matfit" synth --material plastic --size 48x40 --lights dome:24 --noise 0.01 --layout lp \
  --out "$tmp/s" --quiet >/dev/null 2>&1 || bad "synth (handed over) failed"
"$matfit" fit "$tmp/s" --model lambert --out "$tmp/a" --quiet >/dev/null 2>&1 || bad "fit (lean) failed"
"$full" fit "$tmp/s" --model lambert --out "$tmp/b" --quiet >/dev/null 2>&1 || bad "fit (full) failed"
for f in maps/normal.exr maps/albedo.exr maps/normal.png maps/status.png; do
  cmp -s "$tmp/a/$f" "$tmp/b/$f" && ok || bad "$f differs between matfit and matfit-full"
done
"$matfit" info "$tmp/s" >/dev/null 2>&1 && ok || bad "info (lean) failed"

# Without matfit-full beside it, a handed-over command fails with a message naming the file.
mkdir "$tmp/alone" && cp "$matfit" "$tmp/alone/matfit"
msg=$("$tmp/alone/matfit" render --help 2>&1); rc=$?
[ "$rc" = 1 ] && ok || bad "missing matfit-full: exit $rc, want 1"
expect_contains "missing matfit-full" "$msg" "$tmp/alone/matfit-full"
"$tmp/alone/matfit" fit --help >/dev/null 2>&1 && ok || bad "fit --help needs matfit-full"

echo "passed: $pass, failed: $fail"
[ "$fail" = 0 ]
