#!/usr/bin/env bash
# `matfit serve` as a real process, driven with curl as a user would (the README session):
# upload → poll → download; kill -9 during a fit loses no finished pack, shows no half pack, and
# the restarted server re-runs the interrupted job; SIGTERM lets a running job finish (drain).
# Usage: serve_test.sh MATFIT_BINARY SOURCE_DIR
set -u
bin=$1; src=$2
tmp=$(mktemp -d)
pid=""
cleanup() { [ -n "$pid" ] && { kill -9 "$pid"; wait "$pid"; } 2>/dev/null; rm -rf "$tmp"; }
trap cleanup EXIT
pass=0; fail=0
ok()  { pass=$((pass+1)); }
bad() { fail=$((fail+1)); echo "FAIL: $*"; }
command -v curl >/dev/null || { echo "SKIP: curl not installed (scripts/install-deps.sh adds it)"; exit 77; }

n=0
start_server() { # extra args...
  n=$((n+1))
  "$bin" serve --port 0 --data "$tmp/data" --allow-root "$tmp" "$@" 2>"$tmp/log$n" &
  pid=$!
  for _ in $(seq 1 100); do
    port=$(sed -n 's|.*listening on http://127.0.0.1:\([0-9]*\)/api/v1.*|\1|p' "$tmp/log$n")
    [ -n "$port" ] && break
    sleep 0.1
  done
  [ -n "$port" ] || { bad "server did not start"; cat "$tmp/log$n"; exit 1; }
  api="http://127.0.0.1:$port/api/v1"
}
field() { # json-text name → first value of "name": (string or number)
  grep -o "\"$2\": *\"\{0,1\}[^,\"}]*" <<<"$1" | head -1 | sed 's/.*: *"\{0,1\}//'
}
wait_state() { # id, state regex, timeout s
  local t0=$SECONDS j
  while [ $((SECONDS - t0)) -lt "$3" ]; do
    j=$(curl -s "$api/jobs/$1")
    if grep -qE "\"state\": \"($2)\"" <<<"$j"; then echo "$j"; return 0; fi
    sleep 0.1
  done
  echo "$j"; return 1
}

"$bin" synth --material plastic --lights bonn81 --size 128 --layout lp --out "$tmp/slow" >/dev/null
"$bin" synth --material plastic --lights bonn81 --size 64 --layout lp --out "$tmp/medium" >/dev/null
(cd "$src/fixtures" && tar czf "$tmp/plastic.tar.gz" plastic-ring12)

# 1. The README's curl session.
start_server
sub=$(curl -s -F file=@"$tmp/plastic.tar.gz" -F model=lambert-robust "$api/jobs")
quick=$(field "$sub" id)
[ -n "$quick" ] && ok || bad "upload: $sub"
j=$(wait_state "$quick" "succeeded|failed" 60) && ok || bad "quick job did not succeed: $j"
code=$(curl -s -o "$tmp/pack.zip" -w '%{http_code}' "$api/packs/$quick")
[ "$code" = 200 ] && [ "$(head -c 2 "$tmp/pack.zip")" = PK ] && ok || bad "pack zip: HTTP $code"
code=$(curl -s -o "$tmp/preview.png" -w '%{http_code}' "$api/packs/$quick/preview.png?theta=45&phi=30&scene=sphere&size=128")
png_size=$(od -An -j16 -N8 -tu1 "$tmp/preview.png" | tr -s ' ')  # IHDR width, height (big-endian)
[ "$code" = 200 ] && [ "$(head -c 4 "$tmp/preview.png" | tail -c 3)" = PNG ] && \
  [ "$png_size" = " 0 0 0 128 0 0 0 128" ] && ok || bad "preview: HTTP $code, size bytes '$png_size'"
curl -s "$api/packs/$quick/material.json" | grep -q '"maps"' && ok || bad "material.json"

# 2. kill -9 in the middle of a fit.
sub=$(curl -s -H 'Content-Type: application/json' \
  -d "{\"dataset\": \"$tmp/slow\", \"model\": \"cook-torrance\", \"holdout\": 8}" "$api/jobs")
slow=$(field "$sub" id)
t0=$SECONDS
while [ $((SECONDS - t0)) -lt 120 ]; do
  j=$(curl -s "$api/jobs/$slow")
  f=$(field "$j" fraction)
  grep -q '"state": "running"' <<<"$j" && awk "BEGIN{exit !($f > 0.3)}" && break
  sleep 0.1
done
grep -q '"state": "running"' <<<"$j" && ok || bad "slow job never ran: $j"
kill -9 "$pid"; wait "$pid" 2>/dev/null; pid=""
[ ! -e "$tmp/data/packs/$slow" ] && ok || bad "a half pack is visible under packs/$slow after kill -9"
[ -f "$tmp/data/packs/$quick/material.json" ] && ok || bad "the finished pack was lost by kill -9"

start_server
grep -q '"requeued":1' "$tmp/log$n" && ok || { bad "restart did not re-queue the job"; cat "$tmp/log$n"; }
[ -z "$(ls -A "$tmp/data/packs" | grep '^\.')" ] && ok || bad "temporaries not swept: $(ls -A "$tmp/data/packs")"
j=$(wait_state "$slow" "succeeded|failed|cancelled" 180)
grep -q '"state": "succeeded"' <<<"$j" && ok || bad "interrupted job did not complete: $j"
[ "$(field "$j" attempts)" = 2 ] && ok || bad "attempts: $(field "$j" attempts)"
[ -f "$tmp/data/packs/$slow/material.json" ] && ok || bad "re-run pack missing"
curl -s "$api/jobs/$quick" | grep -q '"state": "succeeded"' && ok || bad "quick job state lost"

# 3. SIGTERM with a drain window: the running job finishes, then the process exits 0.
kill -9 "$pid"; wait "$pid" 2>/dev/null; pid=""
start_server --drain-seconds 60
sub=$(curl -s -H 'Content-Type: application/json' \
  -d "{\"dataset\": \"$tmp/medium\", \"model\": \"cook-torrance\", \"holdout\": 4}" "$api/jobs")
med=$(field "$sub" id)
wait_state "$med" running 60 >/dev/null && ok || bad "medium job did not start"
kill -TERM "$pid"; wait "$pid"; rc=$?; pid=""
[ "$rc" = 0 ] && ok || bad "SIGTERM exit code $rc"
grep -q '"event":"stopped"' "$tmp/log$n" && ok || bad "no stopped log line"
grep -q '"id":"'"$med"'","level":"info","seconds":[0-9.]*,"state":"succeeded"' "$tmp/log$n" && ok || \
  { bad "the drained job did not finish before exit"; grep job_finished "$tmp/log$n"; }
start_server
j=$(curl -s "$api/jobs/$med")
grep -q '"state": "succeeded"' <<<"$j" && [ "$(field "$j" attempts)" = 1 ] && ok || bad "after drain: $j"

echo "serve_test: $pass passed, $fail failed"
[ "$fail" -eq 0 ]
