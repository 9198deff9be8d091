#!/usr/bin/env bash
# Multi-view BTF benchmark (issue 17): the joint svbrdf fit of a synthetic 16-bit Bonn BTF
# (lacquer, bonn81 lights under --views cameras), whole process, in memory and out of core
# (--memory BUDGET), with wall time, fit-stage throughput (texels/s), peak RSS and the streamed
# run as a multiple of the in-memory one; runs interleaved, medians of --runs.
#
# Usage: scripts/bench-multi-view.sh [--size 48] [--views bonn81] [--memory 48M] [--runs 3]
#          [--threads 2] [--out DIR] [--matfit BIN]
# Writes DIR/multi-view.md (default DIR: out/bench-multi-view); the dataset is cached in DIR.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
size=48
views=bonn81
memory=48M
runs=3
threads=2
out="$root/out/bench-multi-view"
matfit="$root/build/app/matfit"
need() { [ $# -ge 2 ] || { echo "bench-multi-view: $1 needs a value" >&2; exit 2; }; }
while [ $# -gt 0 ]; do
  case "$1" in
    --size) need "$@"; size=$2; shift ;;
    --views) need "$@"; views=$2; shift ;;
    --memory) need "$@"; memory=$2; shift ;;
    --runs) need "$@"; runs=$2; shift ;;
    --threads) need "$@"; threads=$2; shift ;;
    --out) need "$@"; out=$2; shift ;;
    --matfit) need "$@"; matfit=$2; shift ;;
    -h|--help) sed -n '2,9p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "bench-multi-view: unknown option '$1' (see --help)" >&2; exit 2 ;;
  esac
  shift
done
[ -x /usr/bin/time ] || { echo "bench-multi-view: /usr/bin/time missing (Debian package time)" >&2; exit 1; }
mkdir -p "$out/raw"
data="$out/lacquer-$size-$views"
if [ ! -d "$data" ]; then
  echo "synth: lacquer ${size}² under bonn81, views $views" >&2
  "$matfit" synth --material lacquer --lights bonn81 --views "$views" --layout bonn --bits 16 \
    --size "$size" --out "$data" --quiet
fi
for r in $(seq 1 "$runs"); do
  for mode in memory streamed; do
    extra=()
    [ $mode = streamed ] && extra=(--memory "$memory" --cache-dir "$out")
    echo "run $r: $mode" >&2
    rm -rf "$out/raw/pack-$mode"
    /usr/bin/time -f "%e %M" -o "$out/raw/time-$mode-$r.txt" "$matfit" fit "$data" --view all \
      --model svbrdf --threads "$threads" "${extra[@]}" --out "$out/raw/pack-$mode" --quiet \
      >"$out/raw/log-$mode-$r.txt"
    cp "$out/raw/pack-$mode/report.json" "$out/raw/report-$mode-$r.json"
  done
done
python3 - "$out" "$runs" "$size" "$views" "$memory" "$threads" <<'PY'
import json, statistics, sys
out, runs, size, views, memory, threads = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4], sys.argv[5], sys.argv[6]
rows = {}
for mode in ("memory", "streamed"):
    wall, rss, fit, stages = [], [], [], []
    for r in range(1, runs + 1):
        w, m = open(f"{out}/raw/time-{mode}-{r}.txt").read().split()[-2:]
        wall.append(float(w)); rss.append(int(m) / 1024)
        rep = json.load(open(f"{out}/raw/report-{mode}-{r}.json"))
        t = rep["timings"]
        fit.append(t["fit"]); stages.append(t)
        texels, images = rep["texels"], rep["images"]
    rows[mode] = dict(wall=statistics.median(wall), rss=max(rss), fit=statistics.median(fit),
                      stages=stages[len(stages) // 2], texels=texels, images=images,
                      bands=rep["parameters"].get("streamed_bands", 0))
m, s = rows["memory"], rows["streamed"]
lines = [f"Multi-view svbrdf, lacquer {size}² under bonn81 × views {views} ({m['images']} images, "
         f"16-bit), {threads} threads, median of {runs} (peak RSS: the largest)", "",
         "| run | wall s | fit stage s | texels/s (fit stage) | peak RSS MB | bands | stages (s) |",
         "|---|---|---|---|---|---|---|"]
for name, r in (("in memory", m), (f"out of core, --memory {memory}", s)):
    st = ", ".join(f"{k} {v:.3g}" for k, v in r["stages"].items() if k != "total")
    lines.append(f"| {name} | {r['wall']:.2f} | {r['fit']:.2f} | {r['texels'] / r['fit']:.0f} | "
                 f"{r['rss']:.1f} | {r['bands']} | {st} |")
lines += ["", f"Streamed ÷ in memory (wall): {s['wall'] / m['wall']:.2f}"]
open(f"{out}/multi-view.md", "w").write("\n".join(lines) + "\n")
print("\n".join(lines))
PY
