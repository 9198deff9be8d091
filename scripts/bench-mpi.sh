#!/usr/bin/env bash
# Scaling of a distributed fit (issue 18): the same synthetic fit at 1, 2 and 4 MPI ranks on this
# machine — wall time of the whole `mpirun … matfit fit` and peak RSS of every rank
# (/usr/bin/time -v), and a check that every distributed pack equals the 1-rank pack
# (matfit_pack_diff). Ranks × threads stay at the machine's cores where they can: 1 rank uses
# every core, N ranks one thread each (past the core count the ranks are oversubscribed: said
# in the table). Datasets: --size² texels × 81 lights (bonn81), 16-bit PNG (a band is decoded
# from the file's first row: PNG cannot seek) and 32-bit EXR (only the band's rows are read).
# Figures are medians of --runs runs.
#
# Usage: scripts/bench-mpi.sh [--size 2048] [--runs 1] [--models "ptm blinn-phong"]
#          [--formats "png exr"] [--ranks "1 2 4"] [--out DIR] [--matfit BIN]
# Writes DIR/mpi.md (default DIR: out/bench-mpi); the datasets stay in DIR/data until removed.
set -euo pipefail
shopt -s nullglob
root=$(cd "$(dirname "$0")/.." && pwd)
size=2048; runs=1; models="ptm blinn-phong"; formats="png exr"; rank_counts="1 2 4"
out="$root/out/bench-mpi"; bin="$root/build/app/matfit"
while [ $# -gt 0 ]; do
  case $1 in
    --size) size=$2; shift 2 ;;
    --runs) runs=$2; shift 2 ;;
    --models) models=$2; shift 2 ;;
    --formats) formats=$2; shift 2 ;;
    --ranks) rank_counts=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    --matfit) bin=$2; shift 2 ;;
    *) echo "bench-mpi: unknown option $1" >&2; exit 2 ;;
  esac
done
diff_bin="$(dirname "$bin")/../tests/tools/matfit_pack_diff"
command -v mpirun >/dev/null || { echo "bench-mpi: mpirun not installed (scripts/install-deps.sh)" >&2; exit 1; }
export OMPI_MCA_btl=self,vader,tcp OMPI_MCA_btl_tcp_if_include=lo OMPI_MCA_oob_tcp_if_include=lo
export OMPI_MCA_btl_vader_single_copy_mechanism=none
cores=$(nproc)
mkdir -p "$out/data" "$out/raw"
for f in $formats; do
  d="$out/data/$f-$size"
  [ -d "$d" ] && continue
  bits=16; [ "$f" = exr ] && bits=32
  echo "bench-mpi: rendering $size² × 81 ($f)" >&2
  "$bin" synth --material plastic --size "$size" --lights bonn81 --noise 0.005 --bits "$bits" \
    --layout lp --out "$d" --quiet
done
median() { sort -g | awk '{a[NR]=$1} END {print (NR%2 ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2)}'; }
table="$out/mpi.md"
{
  echo "| model | files | ranks | threads/rank | wall s | speed-up | peak RSS rank 0 MB | peak RSS other ranks MB (max) | pack = 1 rank |"
  echo "|---|---|---|---|---|---|---|---|---|"
} > "$table"
for model in $models; do
  for f in $formats; do
    d="$out/data/$f-$size"; lp=$(ls "$d"/*.lp)
    base_wall=""; base_rss=""
    for n in $rank_counts; do
      threads=1; [ "$n" -eq 1 ] && threads=$cores
      over=""; [ "$n" -gt "$cores" ] && over=" (oversubscribed)"
      walls=(); rss_root=(); rss_other=()
      for run in $(seq "$runs"); do
        pack="$out/raw/$model-$f-$n"
        rm -rf "$pack" "$out/raw/time.$model.$f.$n".*
        t0=$(date +%s.%N)
        # --bind-to none: mpirun binds a rank to one core when ranks ≤ cores, which would leave the
        # 1-rank baseline one core; --threads sets the threads each rank runs.
        mpirun --allow-run-as-root --oversubscribe --bind-to none -n "$n" bash -c \
          "exec /usr/bin/time -v -o '$out/raw/time.$model.$f.$n.'\$OMPI_COMM_WORLD_RANK '$bin' fit '$lp' --model $model --threads $threads --quiet --out '$pack'" \
          > "$out/raw/log.$model.$f.$n" 2>&1
        t1=$(date +%s.%N)
        walls+=("$(awk -v a="$t0" -v b="$t1" 'BEGIN {print b - a}')")
        # Rank 0 also assembles the maps and writes the pack; the others hold their band only.
        rss_root+=("$(awk '/Maximum resident/ {printf "%.0f", $6 / 1024}' "$out/raw/time.$model.$f.$n.0")")
        others=("$out/raw/time.$model.$f.$n".[1-9]*)
        rss_other+=("$(awk '/Maximum resident/ {if ($6 > m) m = $6} END {printf "%.0f", m / 1024}' \
          /dev/null "${others[@]}")")
      done
      wall=$(printf '%s\n' "${walls[@]}" | median)
      rss=$(printf '%s\n' "${rss_root[@]}" | median)
      other="—"; [ "$n" -gt 1 ] && other=$(printf '%s\n' "${rss_other[@]}" | median)
      same="—"
      if [ "$n" -eq 1 ]; then
        base_wall=$wall; rm -rf "$out/raw/base-$model-$f"; mv "$out/raw/$model-$f-1" "$out/raw/base-$model-$f"
      else
        if "$diff_bin" "$out/raw/base-$model-$f" "$out/raw/$model-$f-$n" > "$out/raw/diff.$model.$f.$n" 2>&1; then same="yes"; else same="NO"; fi
        rm -rf "$out/raw/$model-$f-$n"
      fi
      printf '| %s | %s | %d%s | %d | %.1f | %.2f× | %s | %s | %s |\n' "$model" "$f" "$n" "$over" "$threads" \
        "$wall" "$(awk -v a="$base_wall" -v b="$wall" 'BEGIN {print a / b}')" "$rss" "$other" "$same" >> "$table"
      echo "bench-mpi: $model $f $n ranks: ${wall} s, rank 0 ${rss} MB, others ${other} MB ($same)" >&2
    done
  done
done
cat "$table"
