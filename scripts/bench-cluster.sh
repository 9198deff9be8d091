#!/usr/bin/env bash
# Service cluster benchmark (issue 18): jobs per minute of `matfit serve` on loopback with
#   sqlite-1x1  one node, SQLite, 1 worker (the single-machine default)
#   sqlite-1x3  one node, SQLite, 3 workers
#   pg-1x1      one node on PostgreSQL, 1 worker
#   pg-3x1      three nodes on PostgreSQL and one data folder, 1 worker each
# and the time for a killed node's job to be re-run by another node (lease takeover) at two
# lease lengths. Every node uses all cores for its fits (--threads 0); on a 2-core machine
# three workers oversubscribe. Jobs: --jobs fits of a dataset folder named by path, submitted
# round robin over the nodes at once; the clock runs from the first submission to the last
# success. Two kinds of job: "light" (--jobs lambert-robust fits of the 12-image fixture, ~0.1 s
# each: the service's own overhead per job) and "heavy" (--heavy-jobs blinn-phong fits with 4
# held-out folds of a synthetic 128² × 81-light stack, seconds each: compute-bound). Figures are medians of --runs
# runs, interleaved.
#
# Usage: scripts/bench-cluster.sh [--jobs 60] [--heavy-jobs 12] [--runs 3]
#          [--leases "5 30"] [--out DIR] [--matfit BIN]
# Writes DIR/cluster.md (default DIR: out/bench-cluster) and keeps the node logs in DIR/raw/.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
jobs=60; heavy_jobs=12; runs=3; leases="5 30"
out="$root/out/bench-cluster"; bin="$root/build/app/matfit"
while [ $# -gt 0 ]; do
  case $1 in
    --jobs) jobs=$2; shift 2 ;;
    --runs) runs=$2; shift 2 ;;
    --heavy-jobs) heavy_jobs=$2; shift 2 ;;
    --leases) leases=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    --matfit) bin=$2; shift 2 ;;
    *) echo "unknown option $1" >&2; exit 2 ;;
  esac
done
mkdir -p "$out/raw"
tmp=$(mktemp -d); chmod 755 "$tmp"
pids=()
stop_nodes() { for p in "${pids[@]}"; do kill -9 "$p" 2>/dev/null || true; done; wait 2>/dev/null || true; pids=(); }
cleanup() { stop_nodes; bash "$root/scripts/pg-test-cluster.sh" stop "$tmp/pg"; rm -rf "$tmp"; }
trap cleanup EXIT
url=$(bash "$root/scripts/pg-test-cluster.sh" start "$tmp/pg")
cp -r "$root/fixtures/plastic-ring12" "$tmp/ring12"
"$bin" synth --material plastic --lights bonn81 --size 128 --layout lp --out "$tmp/slow" >/dev/null 2>&1

ports=()
start_nodes() { # engine(sqlite|pg) nodes workers lease tag
  local engine=$1 n=$2 w=$3 lease=$4 tag=$5 i p
  ports=()
  for i in $(seq 1 "$n"); do
    local log="$out/raw/$tag-node$i.log"
    local db=(); [ "$engine" = pg ] && db=(--db "$url" --node-id "node$i" --lease-seconds "$lease")
    "$bin" serve --port 0 --data "$tmp/data-$tag" "${db[@]}" --workers "$w" --allow-root "$tmp" \
      --quiet 2>"$log" &
    pids+=($!)
    p=""
    for _ in $(seq 1 200); do
      p=$(sed -n 's|.*listening on http://127.0.0.1:\([0-9]*\)/api/v1.*|\1|p' "$log")
      [ -n "$p" ] && break; sleep 0.05
    done
    [ -n "$p" ] || { echo "node $i of $tag did not start" >&2; cat "$log" >&2; exit 1; }
    ports+=("$p")
  done
}
succeeded() { curl -s "http://127.0.0.1:${ports[0]}/api/v1/jobs?state=succeeded&limit=1000" | grep -c '"state": "succeeded"' || true; }
now() { date +%s.%N; }

# One throughput run: prints jobs/minute.
throughput() { # engine nodes workers tag kind
  local n dataset model t0 k
  local holdout=0
  if [ "$5" = light ]; then n=$jobs dataset=$tmp/ring12 model=lambert-robust
  else n=$heavy_jobs dataset=$tmp/slow model=blinn-phong holdout=4; fi
  rm -rf "$tmp/data-$4"
  [ "$1" = pg ] && psql -X -q "$url" -c "DROP TABLE IF EXISTS jobs, publications, schema_migrations, counters, tokens" >/dev/null 2>&1
  start_nodes "$1" "$2" "$3" 30 "$4"
  t0=$(now)
  for k in $(seq 0 $((n - 1))); do
    curl -s -o /dev/null -H 'Content-Type: application/json' \
      -d "{\"dataset\": \"$dataset\", \"model\": \"$model\", \"holdout\": $holdout}" \
      "http://127.0.0.1:${ports[$((k % ${#ports[@]}))]}/api/v1/jobs"
  done
  while [ "$(succeeded)" -lt "$n" ]; do sleep 0.1; done
  awk -v a="$t0" -v b="$(now)" -v n="$n" 'BEGIN{printf "%.1f", n * 60 / (b - a)}'
  stop_nodes
}

# Lease takeover: a 2-node cluster; the node running a long job is killed with -9; seconds
# until the other node starts it again.
takeover() { # lease
  psql -X -q "$url" -c "DROP TABLE IF EXISTS jobs, publications, schema_migrations, counters, tokens" >/dev/null 2>&1
  rm -rf "$tmp/data-lease"
  start_nodes pg 2 1 "$1" lease
  local id node t_kill started
  id=$(curl -s -H 'Content-Type: application/json' \
    -d "{\"dataset\": \"$tmp/slow\", \"model\": \"cook-torrance\", \"holdout\": 8}" \
    "http://127.0.0.1:${ports[0]}/api/v1/jobs" | sed -n 's/.*"id": "\([0-9a-f]*\)".*/\1/p')
  node=""
  while [ -z "$node" ]; do
    node=$(psql -X -A -t -q "$url" -c "SELECT node FROM jobs WHERE id = '$id' AND state = 'running' AND progress > 0.1")
    sleep 0.1
  done
  kill -9 "${pids[$(( ${node#node} - 1 ))]}"
  t_kill=$(now)
  started=""
  while [ -z "$started" ]; do
    started=$(psql -X -A -t -q "$url" -c "SELECT started FROM jobs WHERE id = '$id' AND attempts = 2")
    sleep 0.05
  done
  awk -v a="$t_kill" -v b="$started" 'BEGIN{printf "%.1f", b - a}'
  stop_nodes
}

median() { tr ' ' '\n' | grep . | sort -g | awk '{a[NR]=$1} END{print (NR%2 ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2)}'; }
declare -A res
cases=("sqlite 1 1 sqlite-1x1" "sqlite 1 3 sqlite-1x3" "pg 1 1 pg-1x1" "pg 3 1 pg-3x1")
for r in $(seq 1 "$runs"); do
  for kind in light heavy; do
    for c in "${cases[@]}"; do
      set -- $c
      v=$(throughput "$1" "$2" "$3" "$4" $kind)
      res[$4-$kind]="${res[$4-$kind]:-} $v"
      echo "run $r $4 $kind: $v jobs/min" >&2
    done
  done
done
declare -A lease_res
for r in $(seq 1 "$runs"); do
  for l in $leases; do
    v=$(takeover "$l")
    lease_res[$l]="${lease_res[$l]:-} $v"
    echo "run $r lease $l s: re-run after $v s" >&2
  done
done
{
  echo "# Service cluster benchmark"
  echo
  echo "\`scripts/bench-cluster.sh --jobs $jobs --heavy-jobs $heavy_jobs --runs $runs\` on $(nproc) cores, $(date -u +%Y-%m-%d)."
  echo "Light: $jobs \`lambert-robust\` fits of fixtures/plastic-ring12; heavy: $heavy_jobs \`blinn-phong\` fits"
  echo "with 4 held-out folds of a synthetic 128² × 81 stack; both named by path. Medians of $runs runs (all runs in brackets)."
  echo
  echo "| setup | light jobs/minute | heavy jobs/minute |"
  echo "|---|---|---|"
  for c in "${cases[@]}"; do
    set -- $c
    echo "| $4 | $(echo ${res[$4-light]} | median) ($(echo ${res[$4-light]})) | $(echo ${res[$4-heavy]} | median) ($(echo ${res[$4-heavy]})) |"
  done
  echo
  echo "| lease | kill -9 → re-run by another node, s |"
  echo "|---|---|"
  for l in $leases; do echo "| $l s | $(echo ${lease_res[$l]} | median) ($(echo ${lease_res[$l]})) |"; done
} >"$out/cluster.md"
cat "$out/cluster.md"
