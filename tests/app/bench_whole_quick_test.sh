#!/usr/bin/env bash
# Smoke test of scripts/bench-whole-process.sh --quick (tiny stacks, one run): it finishes, and
# whole-process.json is well-formed JSON with every case and every figure a finite number.
# Usage: bench_whole_quick_test.sh MATFIT_BINARY SOURCE_DIR
set -u
bin=$1; src=$2
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
[ -x /usr/bin/time ] || { echo "skip: /usr/bin/time missing (Debian package 'time')"; exit 77; }
if ! log=$(bash "$src/scripts/bench-whole-process.sh" --quick --matfit "$bin" --out "$tmp/b" 2>&1); then
  echo "$log" | tail -30
  echo "FAIL: bench-whole-process.sh --quick"
  exit 1
fi
[ -s "$tmp/b/whole-process.md" ] || { echo "FAIL: no whole-process.md"; exit 1; }
python3 - "$tmp/b/whole-process.json" <<'PY'
import json, math, sys
def bad_constant(c):
    raise ValueError(f"non-finite constant {c} in the JSON")
j = json.load(open(sys.argv[1]), parse_constant=bad_constant)
assert j["schema"] == "matfit.bench-whole/1", j.get("schema")
models = ["mean", "lambert", "lambert-robust", "ptm", "hsh2", "hsh3", "heinrich", "blinn-phong"]
assert len(j["sizes"]) == 2, j["sizes"].keys()
for size, d in j["sizes"].items():
    for t in ("1", "2"):
        assert d["decode_only"][t]["wall_s"] > 0, (size, t)
    for m in models:
        for t in ("1", "2"):
            p = d["models"][m]["plain"][t]
            assert p["wall_over_decode"] > 0 and p["peak_rss_mb"] > 0, (size, m, t)
            assert "total" in p["stages_s"], (size, m, t)
        assert d["models"][m]["plain"]["2"]["speedup_vs_1_thread"] > 0, (size, m)
    held = [m for m, e in d["models"].items() if "holdout" in e]
    assert held, size
    for m in held:
        for t in ("1", "2"):
            assert d["models"][m]["holdout"][t]["over_plain"] > 0, (size, m, t)
for m in ["decode_only"] + models:
    for t in ("1", "2"):
        assert j["growth"]["wall_ratio"][m][t] > 0, (m, t)
def check(x, path=""):
    if isinstance(x, dict):
        for k, v in x.items():
            check(v, f"{path}.{k}")
    elif isinstance(x, list):
        for i, v in enumerate(x):
            check(v, f"{path}[{i}]")
    elif isinstance(x, float):
        assert math.isfinite(x), path
    elif x is None:
        raise AssertionError(f"{path} is null (a figure that was not finite)")
check(j)
print("whole-process.json: well-formed, every figure finite")
PY
