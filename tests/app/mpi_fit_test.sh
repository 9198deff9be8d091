#!/usr/bin/env bash
# Distributed fits on real MPI (issue 18): `mpirun --allow-run-as-root --oversubscribe -n 3
# matfit fit` of synthetic sets equals the single-process fit — every EXR map within 1e-6, PNG maps
# within one code (status identical), report.json and material.json with the same keys and figures
# to 6 digits (matfit_pack_diff). Models: lambert, lambert-robust, ptm, hsh2, heinrich,
# blinn-phong, cook-torrance, with held-out folds; layouts lp (16-bit PNG, clipped), bonn (8-bit
# sRGB), lights-txt (32-bit EXR, a width whose bands cannot start on a run boundary) and diligent
# (JPEG, mask); a synthetic leaf under a dome; `matfit leaf` with its leaves split over the ranks
# (the synthetic scan, and the real 23-leaf sheet when ../shared/data is present). Also: the
# model selection (--model auto with a scene at mip 1) and rbf; every view of a BTF (svbrdf,
# per-view:lambert); the refusals (--report-only, more
# ranks than rows) and a truncated image in one rank's rows.
# Usage: mpi_fit_test.sh MATFIT_BINARY PACK_DIFF_BINARY SOURCE_DIR
set -u
bin=$1; diff_bin=$2; src=$3
. "$src/tests/app/lib.sh"
command -v mpirun >/dev/null || { echo "SKIP: mpirun not installed (scripts/install-deps.sh adds openmpi-bin)"; exit 77; }
# `matfit` hands a launched fit to matfit-full beside it (app/main_lean.cc), which links MPI.
if ! ldd "$(dirname "$bin")/matfit-full" | grep -q libmpi; then
  echo "SKIP: this matfit was built without MPI (libopenmpi-dev absent at configure time)"; exit 77
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cd "$tmp"
# MCA settings: loopback TCP and shared memory only (no InfiniBand probing, no warnings).
export OMPI_MCA_btl=self,vader,tcp OMPI_MCA_btl_tcp_if_include=lo OMPI_MCA_oob_tcp_if_include=lo
export OMPI_MCA_btl_vader_single_copy_mechanism=none OMPI_MCA_rmaps_base_oversubscribe=1
ranks() { mpirun --allow-run-as-root --oversubscribe -n "$1" "${@:2}"; }

"$bin" synth --material plastic --size 96x80 --lights dome:40 --noise 0.01 --clip 0.9 --layout lp \
  --out plastic --quiet || bad "synth plastic"
"$bin" synth --material plaster --size 64x50 --lights bonn81 --noise 0.005 --bits 8 --layout bonn \
  --out plaster --quiet || bad "synth plaster"
"$bin" synth --material wool --size 45x37 --lights dome:30 --bits 32 --layout lights-txt \
  --out wool --quiet || bad "synth wool"
"$bin" synth --material plastic-ct --size 64x48 --lights dome:24 --format jpg --bits 8 \
  --layout diligent --out ct --quiet || bad "synth ct"

same() { # name, dataset, ranks, fit options...
  local name=$1 data=$2 n=$3; shift 3
  local one out
  "$bin" fit "$data" "$@" --out "$name.1" --quiet > "$name.1.txt" 2>&1 || { bad "$name: single process failed"; cat "$name.1.txt"; return; }
  out=$(ranks "$n" "$bin" fit "$data" "$@" --out "$name.$n" --quiet 2>&1) || { bad "$name: $n ranks failed"; echo "$out" | tail -5; return; }
  expect_contains "$name summary" "$out" "ranks       $n MPI ranks"
  # The summary figures (everything but timings and the pack name) are the same lines.
  one=$(grep -v "^timings\|^pack\|^fit time" "$name.1.txt")
  [ "$one" = "$(echo "$out" | grep -v "^timings\|^pack\|^fit time\|^ranks")" ] && ok || {
    bad "$name: summaries differ"; diff <(echo "$one") <(echo "$out" | grep -v "^timings\|^pack\|^fit time\|^ranks") | head; }
  if "$diff_bin" "$name.1" "$name.$n" > "$name.diff" 2>&1; then ok; else bad "$name: packs differ"; cat "$name.diff"; fi
}

# Every view of a BTF (issue 17): the joint svbrdf and a per-view model over row bands.
"$bin" synth --material lacquer --lights bonn81 --views dome:4 --layout bonn --bits 16 --size 24 \
  --out views --quiet || bad "synth views"
same mv_svbrdf views 2 --view all --model svbrdf
same mv_per_view views 3 --view all --model per-view:lambert --holdout 3

lp=$(ls plastic/*.lp)
same bp "$lp" 3 --model blinn-phong --holdout 4
same lambert "$lp" 3 --model lambert --holdout 4
same robust "$lp" 3 --model lambert-robust
same ptm plaster 3 --model ptm --holdout 3
same hsh2 plaster 3 --model hsh2
same heinrich plaster 3 --model heinrich --holdout 3
same wool_ptm wool 3 --model ptm --holdout loo
same wool_lambert wool 2 --model lambert
same ct ct 3 --model cook-torrance
same ct_lambert ct 4 --model lambert --holdout 3

# One leaf: the synthetic leaf material under a 24-light dome (fitted as a stack), and `matfit
# leaf` with its leaves split over the ranks — the synthetic scan (one leaf) and, when the shared
# data are present, the real 23-leaf sheet.
same leaf_dome "$(ls "$src"/fixtures/leaf-dome24/*.lp)" 3 --model lambert --holdout 3
same_leaf() { # name, scan folder, ranks
  local name=$1 scan=$2 n=$3 out
  "$bin" leaf "$scan" --out "$name.1" --quiet > "$name.1.txt" 2>&1 || { bad "$name: single process failed"; cat "$name.1.txt"; return; }
  out=$(ranks "$n" "$bin" leaf "$scan" --out "$name.$n" --quiet 2>&1) || { bad "$name: $n ranks failed"; echo "$out" | tail -5; return; }
  expect_contains "$name summary" "$out" "ranks       $n MPI ranks, leaf k fitted by rank k mod $n"
  local keep="^found\|^scale\|^hl2\|^warning"
  [ "$(grep "$keep" "$name.1.txt")" = "$(echo "$out" | grep "$keep")" ] && ok || {
    bad "$name: summaries differ"; diff <(grep "$keep" "$name.1.txt") <(echo "$out" | grep "$keep") | head; }
  if "$diff_bin" "$name.1" "$name.$n" > "$name.diff" 2>&1; then ok; else bad "$name: leaf folders differ"; cat "$name.diff"; fi
}
same_leaf leaf_scan "$src/fixtures/leaf-scan" 2
sheet="${MATFIT_SHARED_DATA:-$src/../shared/data}/leaf-sheet"
if [ -d "$sheet" ]; then
  same_leaf leaf_sheet "$sheet" 3
else
  echo "note: $sheet absent (shared data): the 23-leaf sheet is not run across ranks"
fi

# Model selection over ranks: the scene shows mip 1, candidates down to mip 3, so the bands are
# whole 8-row blocks; and rbf, whose PCA gathers every band's sampled texels.
echo '{"texel_footprint_px": 0.5, "error_budget": 0.02}' > scene.json
same auto "$lp" 3 --model auto --scene scene.json
same rbf plaster 3 --model rbf --holdout 3

# Refused with a clear message on every rank, printed once.
out=$(ranks 2 "$bin" fit "$lp" --model lambert --report-only bp.1 --out r.json 2>&1); rc=$?
[ $rc -ne 0 ] && ok || bad "--report-only under mpirun accepted"
expect_contains "report-only refused" "$out" "--report-only is not run across MPI ranks"
[ "$(grep -c "is not run across MPI ranks" <<<"$out")" = 1 ] && ok || bad "report-only: error printed more than once"
"$bin" synth --material plaster --size 8x4 --lights dome:12 --layout lp --out tiny --quiet
out=$(ranks 5 "$bin" fit "$(ls tiny/*.lp)" --model lambert --out tiny.pack 2>&1)
expect_contains "more ranks than rows" "$out" "the images have 4 rows but 5 ranks were started"
[ ! -e tiny.pack ] && ok || bad "a refused fit left a pack"
# A corrupt image in one rank's rows only: the job fails on every rank, naming the file.
cp -r plastic broken
f=$(ls broken/*.png | sed -n 5p)
head -c 3000 "$f" > "$f.cut" && mv "$f.cut" "$f"
out=$(ranks 3 "$bin" fit "$(ls broken/*.lp)" --model lambert --out broken.pack 2>&1); rc=$?
[ $rc -ne 0 ] && ok || bad "a truncated image was accepted"
expect_contains "truncated image named" "$out" "$(basename "$f")"
[ ! -e broken.pack ] && ok || bad "a failed distributed fit left a pack"

echo "mpi_fit_test: $pass passed, $fail failed"
[ $fail -eq 0 ]
