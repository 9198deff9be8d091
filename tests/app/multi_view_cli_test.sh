#!/usr/bin/env bash
# Multi-view BTFs end to end (issue 17): synth --views in the Bonn and UTIA layouts, info and fit
# of every view (--view all), held-out views, auto over the view-dependent models, refusals.
# Usage: multi_view_cli_test.sh MATFIT_BINARY SOURCE_DIR
set -u
bin=$1; src=$2
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
. "$src/tests/app/lib.sh"
cd "$tmp"
command -v oiiotool >/dev/null || { echo "oiiotool missing (openimageio-tools)"; exit 1; }

"$bin" synth --material lacquer --lights bonn81 --views dome:9 --layout bonn --bits 32 --size 16 \
  --out btf --quiet || bad "synth --views bonn"
[ "$(find btf -mindepth 1 -maxdepth 1 -type d -name 'tv*' | wc -l)" = 9 ] && ok ||
  bad "bonn: one folder per view expected"
expect_contains "params views" "$(tr -d ' \n' <btf/truth/params.json)" '"view_set":"dome:9"'
"$bin" synth --material lacquer --lights bonn81 --views dome:4 --layout utia --bits 16 --size 16 \
  --out utia --quiet || bad "synth --views utia"

out=$("$bin" info btf --view all --quiet 2>&1) || bad "info --view all: $out"
expect_contains "info images" "$out" "images       729 x 16x16"
expect_contains "info views" "$out" "views        9, θv"
out=$("$bin" info btf --quiet 2>&1) || bad "info one view: $out"
expect_contains "info one view" "$out" "images       81 x 16x16"
out=$("$bin" info utia --view all --quiet 2>&1) || bad "info utia --view all: $out"
expect_contains "info utia views" "$out" "views        4, θv"

out=$("$bin" fit btf --view all --model svbrdf --holdout-views 3 --components 1,8 --out pack --quiet 2>&1) ||
  bad "fit svbrdf: $out"
report=$(tr -d ' \n' <pack/report.json)
expect_contains "report method" "$report" '"method":"svbrdf"'
expect_contains "report held-out views" "$report" '"heldout_views":{"deviation_percent"'
expect_contains "report train views" "$report" '"train_views":6'
expect_contains "report by view" "$report" '"deviation_percent_by_view_theta":{"15":{'
expect_contains "pack model" "$(tr -d ' \n' <pack/material.json)" '"name":"cook-torrance"'
expect_contains "per-view PCA" "$report" '"k":8,"rmse"'
python3 - pack/report.json <<'PY' && ok || bad "svbrdf on lacquer: normals or held-out views out of bounds"
import json, sys
r = json.load(open(sys.argv[1]))
assert r["normal_mae_deg"] < 1.5, r["normal_mae_deg"]
assert len(r["heldout_views"]["views"]) == 3
assert all(v["theta_deg"] > 0 for v in r["heldout_views"]["views"])
pca = r["per_view_pca"]
assert [p["k"] for p in pca] == [1, 8] and pca[1]["rmse"] < pca[0]["rmse"], pca
PY
"$bin" render pack --camera 45,90 --light 30,270 --size 32 --backend cpu --out view.png --quiet ||
  bad "render the svbrdf pack from another camera"

# per-view:<model>: each view fitted on its own, one pack per view under views/, the camera's
# nearest view rendered, the pack re-scored with each image's own view's maps.
out=$("$bin" fit btf --view all --model per-view:heinrich --holdout-views 2 --out perview --quiet \
  2>&1) || bad "fit per-view:heinrich: $out"
[ "$(find perview/views -mindepth 1 -maxdepth 1 -type d | wc -l)" = 9 ] && ok ||
  bad "per-view pack: 9 view packs expected"
python3 - perview <<'PY' && ok || bad "per-view pack layout or report"
import json, os, sys
d = sys.argv[1]
m = json.load(open(d + "/material.json"))
assert m["model"]["method"] == "per-view:heinrich", m["model"]
assert len(m["views"]) == 9, m["views"]
for v in m["views"]:
    sub = json.load(open(os.path.join(d, v["pack"], "material.json")))
    assert sub["model"]["name"] == "heinrich" and sub["views"] is None
    assert os.path.isfile(os.path.join(d, v["pack"], "maps", "normal.exr"))
r = json.load(open(d + "/report.json"))
assert r["heldout_views"]["train_views"] == 7, r["heldout_views"]
assert r["bytes_per_texel"] == 9 * 17, r["bytes_per_texel"]  # heinrich's 17 per view
assert r["parameters"]["views"] == 9
PY
out=$("$bin" render perview --camera 70,240 --size 16 --backend cpu --out pv.png 2>&1) ||
  bad "render per-view: $out"
expect_contains "render draws the nearest view" "$out" "drawing the maps of view 68,243"
"$bin" fit btf --view all --report-only perview --out rescore.json --quiet || bad "report-only per-view"
python3 - perview/report.json rescore.json <<'PY' && ok || bad "re-scored per-view pack differs"
import json, sys
a, b = (json.load(open(f)) for f in sys.argv[1:3])
assert abs(a["rmse"] - b["rmse"]) <= 1e-6 * a["rmse"], (a["rmse"], b["rmse"])
PY
out=$("$bin" fit btf --view all --model per-view:svbrdf --out nope --quiet 2>&1) &&
  bad "per-view:svbrdf accepted"
expect_contains "per-view of svbrdf refused" "$out" "is not a method"

out=$("$bin" fit btf --view all --model auto --out auto --quiet 2>&1) || bad "fit auto: $out"
expect_contains "auto picks the view-dependent model" "$(tr -d ' \n' <auto/report.json)" '"method":"svbrdf"'
# The scene's view range: a head-on scene fits the most frontal view with the single-view ladder.
echo '{"view_theta_max_deg": 0}' >frontal.json
out=$("$bin" fit btf --view all --model auto --scene frontal.json --out auto_front --quiet 2>&1) ||
  bad "fit auto, frontal scene: $out"
python3 - auto_front/report.json <<'PY' && ok || bad "auto for a head-on scene"
import json, sys
r = json.load(open(sys.argv[1]))
assert r["method"] != "svbrdf", r["method"]
assert r["selection"]["views"] == {"fitted": 1, "in_data": 9}, r["selection"]["views"]
assert any(w.startswith("views-outside-scene") for w in r["warnings"]), r["warnings"]
PY

# Out of core (--memory): a stack of 99.5 MB as float fitted under a 48 MB budget — peak RSS
# within it, every map equal to the in-memory fit's. 16-bit: the cache's first decode chunk is
# sized at float, the later ones at the native depth.
"$bin" synth --material lacquer --lights bonn81 --views dome:25 --layout bonn --bits 16 --size 64 \
  --out big --quiet || bad "synth big"
/usr/bin/time -f "%M" -o rss.txt "$bin" fit big --view all --model svbrdf --memory 48M \
  --holdout-views 4 --out streamed --quiet >streamed.log 2>&1 || bad "streamed fit: $(cat streamed.log)"
rss_kb=$(tail -1 rss.txt)
[ "$rss_kb" -le $((48 * 1024)) ] && ok || bad "streamed fit peak RSS ${rss_kb} kB over the 48 MB budget"
expect_contains "streamed bands" "$(tr -d ' \n' <streamed/report.json)" '"streamed_bands":'
"$bin" fit big --view all --model svbrdf --holdout-views 4 --out inmemory --quiet >/dev/null 2>&1 ||
  bad "in-memory fit"
# Held-out views out of core: each band refined again without them, the same figures.
python3 - streamed/report.json inmemory/report.json <<'PY' && ok || bad "streamed held-out views differ"
import json, sys
a, b = (json.load(open(f))["heldout_views"] for f in sys.argv[1:3])
assert a["train_views"] == b["train_views"] == 21, (a["train_views"], b["train_views"])
assert abs(a["rmse"] - b["rmse"]) <= 1e-9 * b["rmse"], (a["rmse"], b["rmse"])
for va, vb in zip(a["views"], b["views"]):
    assert va["theta_deg"] == vb["theta_deg"] and abs(va["rmse"] - vb["rmse"]) <= 1e-9 * vb["rmse"]
PY
expect_contains "in memory" "$(tr -d ' \n' <inmemory/report.json)" '"views":25'
for map in normal albedo specular roughness; do
  d=$(oiiotool --diff --fail 1e-6 streamed/maps/$map.exr inmemory/maps/$map.exr 2>&1) && ok ||
    bad "streamed $map differs from the in-memory fit: $d"
done
out=$("$bin" fit big --view all --model lambert --memory 48M --out bad0 --quiet 2>&1) && bad "lambert out of core accepted"
expect_contains "out of core needs svbrdf" "$out" "--model svbrdf and per-view:MODEL"
# per-view:MODEL out of core: one view read at a time, under the budget, the in-memory maps and
# figures (held-out views from the nearest other view).
/usr/bin/time -f "%M" -o rss_pv.txt "$bin" fit big --view all --model per-view:lambert --memory 48M \
  --holdout-views 4 --out pv_streamed --quiet >pv.log 2>&1 || bad "per-view out of core: $(cat pv.log)"
rss_kb=$(tail -1 rss_pv.txt)
[ "$rss_kb" -le $((48 * 1024)) ] && ok || bad "per-view out of core peak RSS ${rss_kb} kB over 48 MB"
"$bin" fit big --view all --model per-view:lambert --holdout-views 4 --out pv_memory --quiet \
  >/dev/null 2>&1 || bad "per-view in memory"
python3 - pv_streamed pv_memory <<'PY' && ok || bad "per-view out of core differs from in memory"
import json, sys
a, b = (json.load(open(d + "/report.json")) for d in sys.argv[1:3])
assert a["parameters"]["streamed_views"] == 25 and "streamed_views" not in b["parameters"]
for key in ("rmse", "rmse_common", "deviation_percent"):
    assert abs(a[key] - b[key]) <= 1e-9 * b[key], (key, a[key], b[key])
assert abs(a["heldout_views"]["rmse"] - b["heldout_views"]["rmse"]) <= 1e-9 * b["heldout_views"]["rmse"]
assert a["deviation_percent_by_view_theta"].keys() == b["deviation_percent_by_view_theta"].keys()
ma, mb = (json.load(open(d + "/material.json")) for d in sys.argv[1:3])
assert [v["pack"] for v in ma["views"]] == [v["pack"] for v in mb["views"]]
PY
for v in v000 v013 v024; do
  d=$(oiiotool --diff --fail 1e-6 pv_streamed/views/$v/maps/normal.exr pv_memory/views/$v/maps/normal.exr 2>&1) &&
    ok || bad "per-view out of core: view $v's normals differ: $d"
done

# Refusals name what to do.
out=$("$bin" fit btf --view all --model lambert --out bad1 --quiet 2>&1) && bad "lambert over views accepted"
expect_contains "single-view model" "$out" "--model svbrdf"
out=$("$bin" fit btf --model lambert --memory 48M --out bad5 --quiet 2>&1) && bad "--memory on one view accepted"
expect_contains "memory needs all views" "$out" "--memory and --cache-dir apply to every view"
out=$("$bin" fit btf --model svbrdf --holdout-views 2 --out bad2 --quiet 2>&1) && bad "held-out views of one view accepted"
expect_contains "holdout-views needs all" "$out" "--view all"
out=$("$bin" fit btf --view all --model svbrdf --holdout-views 9 --out bad3 --quiet 2>&1) && bad "every view held out accepted"
expect_contains "holdout-views range" "$out" "--holdout-views must be in [1, 8]"
out=$("$bin" synth --material lacquer --views dome:4 --layout diligent --size 8 --out bad4 --quiet 2>&1) &&
  bad "views in diligent accepted"
expect_contains "views layout" "$out" "--views needs --layout bonn, utia or lp"
# An .lp with a view per image ("N views"): every view with --view all, else the most frontal.
"$bin" synth --material lacquer --lights bonn81 --views dome:4 --layout lp --bits 16 --size 16 \
  --out lpviews --quiet || bad "synth --views lp"
expect_contains "lp header" "$(head -1 lpviews/lights.lp)" "324 views"
out=$("$bin" info lpviews --view all --quiet 2>&1) || bad "info lp --view all: $out"
expect_contains "lp views" "$out" "views        4, θv"
out=$("$bin" info lpviews --quiet 2>&1) || bad "info lp one view: $out"
expect_contains "lp one view" "$out" "images       81 x 16x16"
out=$("$bin" fit lpviews --view all --model svbrdf --out lppack --quiet 2>&1) || bad "fit lp views: $out"
expect_contains "lp svbrdf" "$(tr -d ' \n' <lppack/report.json)" '"deviation_percent_by_view_theta"'


echo "multi-view CLI: $pass passed, $fail failed"
[ "$fail" = 0 ]
