#!/usr/bin/env bash
# Walks every subcommand's --help and checks the shared flags (issue #21): the same name and
# meaning everywhere (--out, --force, --threads, --quiet), every option described, required
# options marked, and a command run without a required option failing with an error naming it.
# A subcommand added without an entry in the table below fails the test.
set -u
matfit=$1
source "$(dirname "$0")/lib.sh"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# Subcommand → shared flags it must have. "out" implies --force (replaces only matfit output).
declare -A flags=(
  [synth]="out force threads quiet"
  [info]="threads quiet"
  [fit]="out force threads quiet"
  [render]="out force threads quiet"
  [leaf]="out force threads quiet"
  [serve]="threads quiet"
  [tokens]=""
  [capture]="out force quiet"
  [calibrate-lights]="out force quiet"
  [devices]=""
  [bench]="out force threads quiet"
)
force_help="replace --out if matfit wrote it (anything else is refused, never deleted)"

subs=$("$matfit" --help | awk '/^Subcommands:/ {on = 1; next} on && NF {print $1}')
[ -n "$subs" ] || bad "matfit --help lists no subcommands"
for s in $subs; do
  if [ -z "${flags[$s]+set}" ]; then
    bad "subcommand '$s' has no entry in help_test.sh: add its shared flags"
    continue
  fi
  h=$("$matfit" "$s" --help 2>&1) || bad "$s --help exits non-zero"
  for f in ${flags[$s]}; do
    grep -qE "^  --$f( |$)" <<<"$h" || bad "$s --help lacks --$f"
  done
  # Flags outside the table must not appear under another name for the same meaning.
  for alias in --overwrite --replace --jobs --silent --output -o; do
    grep -qE "^  (-[a-z],)?$alias( |,|$)" <<<"$h" && bad "$s uses $alias (the shared name differs)"
  done
  if [[ " ${flags[$s]} " == *" force "* ]]; then
    line=$(grep -E "^  --force" <<<"$h")
    # capture's --force also restarts a resumable capture; the rule about foreign folders holds.
    if [ "$s" = capture ]; then
      expect_contains "$s --force" "$line" "replaces only a capture matfit wrote"
    else
      expect_contains "$s --force" "$line" "$force_help"
    fi
  fi
  if [[ " ${flags[$s]} " == *" threads "* ]]; then
    line=$(grep -E "^  --threads" <<<"$h")
    expect_contains "$s --threads" "$line" "INT=0"
    expect_contains "$s --threads" "$line" "(0 = all cores)"
  fi
  # Every option and positional has a description (on its line or, when the name is long, the
  # next, more indented one).
  # After the name, its value type ("TEXT", "INT=0", "..."), REQUIRED marks: the rest is the
  # description, on the same line or (long names) on the next, more indented one.
  undocumented=$(awk '
    /^Options:/ {on = 1; next}
    on && /^  [-A-Z]/ {
      if (pending != "") print pending
      i = 2
      while (i <= NF && $i ~ /^([A-Z]+(=.*)?|\.\.\.)$/) i++
      pending = i > NF ? $1 : ""
      next
    }
    on && /^      / { pending = ""; next }
    END { if (pending != "") print pending }' <<<"$h")
  [ -z "$undocumented" ] || bad "$s: options without a description: $undocumented"
done

# Required options are marked, and the command fails naming them when they are missing.
h=$("$matfit" fit --help)
expect_contains "fit --out marked" "$(grep -E '^  --out' <<<"$h")" "[REQUIRED unless"
expect_contains "fit DIR marked" "$(grep -E '^  DIR' <<<"$h")" "[REQUIRED unless"
expect_contains "synth --out marked" "$("$matfit" synth --help | grep -E '^  --out')" \
  "[REQUIRED unless --list]"
"$matfit" synth --quiet --size 16 --lights ring12 --out "$tmp/ds" >/dev/null 2>&1 ||
  bad "synth for the required-option checks failed"
out=$("$matfit" fit "$tmp/ds" 2>&1) && bad "fit without --out succeeded"
expect_contains "fit without --out" "$out" "--out PACK is required"
out=$("$matfit" synth --size 16 2>&1) && bad "synth without --out succeeded"
expect_contains "synth without --out" "$out" "--out DIR is required"
for s in leaf render info calibrate-lights; do
  h=$("$matfit" "$s" --help)
  req=$(grep -E '^  [-A-Z].* REQUIRED' <<<"$h" | awk '{print $1}' | head -1)
  [ -n "$req" ] || { bad "$s marks no required option"; continue; }
  out=$("$matfit" "$s" 2>&1) && bad "$s without $req succeeded"
  expect_contains "$s without arguments" "$out" "$req"
done

echo "help_test: $pass passed, $fail failed"
[ "$fail" -eq 0 ]
