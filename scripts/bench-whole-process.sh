#!/usr/bin/env bash
# Whole-process benchmark of `matfit fit` (issue 16): wall time and peak RSS of the complete
# command — read, fit, reconstruction, confidence, held-out folds, write — on synthetic 8-bit
# JPEG .lp stacks, as a multiple of decoding the same images alone (`matfit fit --decode-only`,
# the floor any tool pays), with 1 and 2 threads, with and without held-out folds, and the
# growth from the small to the large stack. Everything is measured in this one invocation;
# figures are medians of --runs runs, interleaved (run 1 of every case, then run 2, ...).
#
# Usage: scripts/bench-whole-process.sh [--quick] [--runs N] [--sizes "512x344 1024x688"]
#          [--images 240] [--threads "1 2"] [--models "mean lambert ..."]
#          [--holdout-models "mean lambert ptm hsh2 hsh3"] [--holdout K] [--material plastic]
#          [--near-lights D] [--out DIR] [--cache DIR] [--matfit BIN]
# Writes DIR/whole-process.md and DIR/whole-process.json (default DIR: out/bench-whole) and
# keeps the raw runs in DIR/raw/. Stacks are cached in --cache (default DIR/stacks) and reused.
# --near-lights D: the stacks are lit by near lamps D pixels from the centre (light_positions.txt,
# docs/formats.md): every fit uses per-texel directions and fall-off; compare with a run without.
# --quick: tiny stacks (32x20 and 64x40, 24 lights), 1 run, held-out folds for lambert and ptm
# only: a smoke test (ctest runs it).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)

quick=0
runs=""
sizes="512x344 1024x688"
images=240
threads="1 2"
models="mean lambert lambert-robust ptm hsh2 hsh3 heinrich blinn-phong"
holdout_models="mean lambert ptm hsh2 hsh3"
holdout=4
material=plastic
near=0
out="$root/out/bench-whole"
cache=""
matfit="$root/build/app/matfit"

usage() { sed -n '2,16p' "$0" | sed 's/^# \{0,1\}//'; }
need() { [ $# -ge 2 ] || { echo "bench-whole-process: $1 needs a value" >&2; exit 2; }; }
while [ $# -gt 0 ]; do
  case "$1" in
    --quick) quick=1 ;;
    --runs) need "$@"; runs=$2; shift ;;
    --sizes) need "$@"; sizes=$2; shift ;;
    --images) need "$@"; images=$2; shift ;;
    --threads) need "$@"; threads=$2; shift ;;
    --models) need "$@"; models=$2; shift ;;
    --holdout-models) need "$@"; holdout_models=$2; shift ;;
    --holdout) need "$@"; holdout=$2; shift ;;
    --material) need "$@"; material=$2; shift ;;
    --near-lights) need "$@"; near=$2; shift ;;
    --out) need "$@"; out=$2; shift ;;
    --cache) need "$@"; cache=$2; shift ;;
    --matfit) need "$@"; matfit=$2; shift ;;
    -h|--help) usage; exit 0 ;;
    *) echo "bench-whole-process: unknown option '$1' (see --help)" >&2; exit 2 ;;
  esac
  shift
done
if [ $quick -eq 1 ]; then
  sizes="32x20 64x40"; images=24; runs=${runs:-1}; holdout_models="lambert ptm"
fi
runs=${runs:-3}
cache=${cache:-"$out/stacks"}

fail() { echo "bench-whole-process: error: $*" >&2; exit 1; }
[[ "$runs" =~ ^[1-9][0-9]*$ ]] || fail "--runs must be a positive integer, got '$runs'"
[[ "$images" =~ ^[1-9][0-9]*$ ]] || fail "--images must be a positive integer, got '$images'"
[[ "$near" =~ ^[0-9]+$ ]] || fail "--near-lights takes a distance in pixels (0 = distant), got '$near'"
[[ "$holdout" =~ ^[0-9]+$ ]] && [ "$holdout" -ge 2 ] || fail "--holdout must be >= 2, got '$holdout'"
for s in $sizes; do [[ "$s" =~ ^[0-9]+x[0-9]+$ ]] || fail "--sizes takes WIDTHxHEIGHT, got '$s'"; done
for t in $threads; do [[ "$t" =~ ^[1-9][0-9]*$ ]] || fail "--threads takes counts >= 1, got '$t'"; done
[ -x "$matfit" ] || fail "matfit binary '$matfit' not found (build first: scripts/build.sh, or --matfit BIN)"
[ -x /usr/bin/time ] || fail "/usr/bin/time is missing: install the Debian package 'time' (scripts/install-deps.sh)"
command -v python3 >/dev/null || fail "python3 is missing (scripts/install-deps.sh)"
for m in $models $holdout_models; do
  "$matfit" fit --model list | awk 'NR > 1 {print $1}' | grep -qx -- "$m" || fail "--models: '$m' is not a model of 'matfit fit --model list'"
done

mkdir -p "$out" "$cache"
raw="$out/raw"
rm -rf "$raw"
mkdir -p "$raw"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# Stacks: plastic (Blinn–Phong specular) under a dome of $images lights, 8-bit sRGB JPEG, .lp.
# truth/ is removed so that the fit does what it does on a real capture.
suffix=""; [ "$near" -gt 0 ] && suffix="-near$near"
for s in $sizes; do
  stack="$cache/$material-$s-dome$images-jpg$suffix"
  if [ ! -f "$stack/lights.lp" ]; then
    echo "bench-whole-process: synthesising $stack" >&2
    "$matfit" synth --material "$material" --lights "dome:$images" --size "$s" --format jpg \
      --noise 0.005 --near-lights "$near" --layout lp --out "$stack" --force >/dev/null
    rm -rf "$stack/truth"
  fi
done

# One measured run: wall seconds (ns clock around /usr/bin/time) and peak RSS (kB) appended to
# the raw table; report.json kept for its stage timings. A failed run stops the benchmark.
measure() {  # size case threads run -- matfit args...
  local size=$1 case=$2 t=$3 run=$4
  shift 5
  local id="$size.$case.t$t.r$run"
  local t0 t1
  t0=$(date +%s%N)
  if ! /usr/bin/time -f '%M' -o "$raw/$id.rss" "$matfit" "$@" >"$raw/$id.log" 2>&1; then
    cat "$raw/$id.log" >&2
    fail "run failed: matfit $*"
  fi
  t1=$(date +%s%N)
  local wall
  wall=$(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.6f", (b - a) / 1e9 }')
  printf '%s\t%s\t%s\t%s\t%s\t%s\n' "$size" "$case" "$t" "$run" "$wall" \
    "$(tail -n 1 "$raw/$id.rss")" >>"$raw/runs.tsv"
  [ -f "$work/pack/report.json" ] && cp "$work/pack/report.json" "$raw/$id.report.json"
  rm -rf "$work/pack"
  echo "  $id: ${wall} s" >&2
}

printf 'size\tcase\tthreads\trun\twall_s\tpeak_rss_kb\n' >"$raw/runs.tsv"
for ((run = 1; run <= runs; run++)); do
  echo "bench-whole-process: run $run of $runs" >&2
  for s in $sizes; do
    stack="$cache/$material-$s-dome$images-jpg$suffix"
    for t in $threads; do
      measure "$s" decode-only "$t" "$run" -- fit "$stack" --decode-only --threads "$t" --quiet
      for m in $models; do
        measure "$s" "$m" "$t" "$run" -- fit "$stack" --model "$m" --threads "$t" \
          --out "$work/pack" --force --quiet
      done
      for m in $holdout_models; do
        measure "$s" "$m+holdout" "$t" "$run" -- fit "$stack" --model "$m" --threads "$t" \
          --holdout "$holdout" --out "$work/pack" --force --quiet
      done
    done
  done
done

# Medians, ratios, the table and the JSON.
git_rev=$(git -C "$root" rev-parse --short HEAD 2>/dev/null || echo unknown)
python3 - "$raw" "$out" "$runs" "$images" "$material" "$holdout" "$git_rev" "$quick" \
  "$sizes" "$threads" "$models" "$holdout_models" "$near" <<'PY'
import json, math, os, statistics, sys, time
(raw, out, runs, images, material, holdout, rev, quick, sizes, threads, models,
 holdout_models, near) = sys.argv[1:]
sizes, threads = sizes.split(), threads.split()
models, holdout_models = models.split(), holdout_models.split()
rows = [l.rstrip("\n").split("\t") for l in open(os.path.join(raw, "runs.tsv"))][1:]
walls, rss, stage = {}, {}, {}
for size, case, t, run, wall, kb in rows:
    key = (size, case, t)
    walls.setdefault(key, []).append(float(wall))
    rss.setdefault(key, []).append(int(kb) / 1024.0)
    rep = os.path.join(raw, f"{size}.{case}.t{t}.r{run}.report.json")
    if os.path.exists(rep):
        for k, v in json.load(open(rep)).get("timings", {}).items():
            stage.setdefault(key, {}).setdefault(k, []).append(v)

def med(key):
    return statistics.median(walls[key])

def ratio(a, b):
    return a / b if b > 0 else float("nan")

result = {
    "schema": "matfit.bench-whole/1",
    "time": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    "git": rev, "quick": quick == "1", "runs": int(runs), "images": int(images), "near_lights_px": int(near),
    "material": material, "format": "8-bit sRGB JPEG, .lp", "holdout": int(holdout),
    "cpus": os.cpu_count(), "threads": [int(t) for t in threads], "sizes": {},
}
for s in sizes:
    d = {"decode_only": {}, "models": {}}
    for t in threads:
        k = (s, "decode-only", t)
        d["decode_only"][t] = {"wall_s": med(k), "peak_rss_mb": max(rss[k])}
    if "1" in d["decode_only"] and "2" in d["decode_only"]:
        dd = d["decode_only"]
        dd["2"]["speedup_vs_1_thread"] = ratio(dd["1"]["wall_s"], dd["2"]["wall_s"])
    for m in models + [m for m in holdout_models if m not in models]:
        e = {}
        for case in ([m] if m in models else []) + ([m + "+holdout"] if m in holdout_models else []):
            for t in threads:
                k = (s, case, t)
                r = {"wall_s": med(k), "peak_rss_mb": max(rss[k]),
                     "wall_over_decode": ratio(med(k), med((s, "decode-only", t))),
                     "stages_s": {n: statistics.median(v) for n, v in stage.get(k, {}).items()}}
                e.setdefault("holdout" if case.endswith("+holdout") else "plain", {})[t] = r
        for part in e.values():
            if "1" in part and "2" in part:
                part["2"]["speedup_vs_1_thread"] = ratio(part["1"]["wall_s"], part["2"]["wall_s"])
        if "plain" in e and "holdout" in e:
            for t in threads:
                e["holdout"][t]["over_plain"] = ratio(e["holdout"][t]["wall_s"], e["plain"][t]["wall_s"])
        d["models"][m] = e
    result["sizes"][s] = d
if len(sizes) >= 2:
    small, large = sizes[0], sizes[-1]
    g = {}
    for case in ["decode_only"] + models:
        for t in threads:
            a = result["sizes"][small]["decode_only"][t] if case == "decode_only" else result["sizes"][small]["models"][case]["plain"][t]
            b = result["sizes"][large]["decode_only"][t] if case == "decode_only" else result["sizes"][large]["models"][case]["plain"][t]
            g.setdefault(case, {})[t] = ratio(b["wall_s"], a["wall_s"])
    (wl, hl), (ws, hs) = [map(int, large.split("x")), map(int, small.split("x"))]
    result["growth"] = {"from": small, "to": large, "texel_ratio": (wl * hl) / (ws * hs),
                        "wall_ratio": g}

# Every figure must be a finite number (the smoke test checks the same): JSON gets null and a
# warning otherwise.
def finite(x, path=""):
    if isinstance(x, dict):
        return {k: finite(v, f"{path}.{k}") for k, v in x.items()}
    if isinstance(x, float) and not math.isfinite(x):
        print(f"bench-whole-process: warning: {path} is not finite", file=sys.stderr)
        return None
    return x
with open(os.path.join(out, "whole-process.json"), "w") as f:
    json.dump(finite(result), f, indent=2, allow_nan=False)
    f.write("\n")

def fmt(v, unit=""):
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "—"
    return (f"{v:.3g}" if v < 100 else f"{v:.0f}") + unit

md = ["# Whole-process `matfit fit` benchmark", "",
      f"`scripts/bench-whole-process.sh{' --quick' if quick == '1' else ''}` at {rev}, {result['time']}: "
      f"synthetic {material} under dome:{images}"
      + (f" (near lamps {near} px from the centre)" if int(near) else "")
      + f", 8-bit sRGB JPEG `.lp`, {os.cpu_count()} CPUs; "
      f"median of {runs} run(s) per case, interleaved. Wall = the whole command (read, fit, "
      f"reconstruction, confidence, write; held-out: + `--holdout {holdout}`); ÷ decode = "
      f"÷ `matfit fit --decode-only` with the same threads; RSS = peak resident set "
      f"(`/usr/bin/time`), MB.", ""]
for s in sizes:
    d = result["sizes"][s]
    md += [f"## {s} × {images}", "",
           "| model | threads | wall s | ÷ decode | peak RSS MB | 2-thread speedup | held-out wall s | held-out ÷ plain | slowest stages (s) |",
           "|---|---|---|---|---|---|---|---|---|"]
    for t in threads:
        x = d["decode_only"][t]
        speedup = fmt(x["speedup_vs_1_thread"]) if "speedup_vs_1_thread" in x else ""
        md.append(f"| decode-only | {t} | {fmt(x['wall_s'])} | 1 | {fmt(x['peak_rss_mb'])} | "
                  f"{speedup} | | | |")
    for m, e in d["models"].items():
        for t in threads:
            p, h = e.get("plain", {}).get(t), e.get("holdout", {}).get(t)
            base = p or h
            st = sorted(base["stages_s"].items(), key=lambda kv: -kv[1]) if base else []
            st = ", ".join(f"{n} {fmt(v)}" for n, v in st if n != "total")
            st = ", ".join(st.split(", ")[:3])
            md.append(f"| {m} | {t} | {fmt(p['wall_s']) if p else '—'} | "
                      f"{fmt(p['wall_over_decode']) if p else '—'} | {fmt(p['peak_rss_mb']) if p else '—'} | "
                      f"{fmt(p.get('speedup_vs_1_thread')) if p and t == '2' else ''} | "
                      f"{fmt(h['wall_s']) if h else ''} | {fmt(h.get('over_plain')) if h else ''} | {st} |")
    md.append("")
if "growth" in result:
    g = result["growth"]
    md += [f"## Growth {g['from']} → {g['to']} (texels × {fmt(g['texel_ratio'])})", "",
           "| model | " + " | ".join(f"{t} thread{'s' if t != '1' else ''}" for t in threads) + " |",
           "|---|" + "---|" * len(threads)]
    for case, v in g["wall_ratio"].items():
        md.append(f"| {case.replace('_', '-')} | " + " | ".join(fmt(v[t]) for t in threads) + " |")
    md.append("")
with open(os.path.join(out, "whole-process.md"), "w") as f:
    f.write("\n".join(md))
print("\n".join(md))
PY
echo "bench-whole-process: wrote $out/whole-process.md and $out/whole-process.json" >&2
