#!/usr/bin/env bash
# The whole side-by-side check: synthetic movies -> hexatissue.analyze -> TissueMiner DB ->
# TissueMiner's shear code -> comparison.   OUT defaults to /tmp/tmbench.
#   PYTHONPATH=/work/wt-tm benchmarks/tissueminer/run_all.sh [OUT]
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
OUT="${1:-/tmp/tmbench}"
KINDS="${KINDS:-shear t1 division}"
mkdir -p "$OUT"
MD="$OUT/results.md"; : > "$MD"
for k in $KINDS; do
    [ -f "$OUT/$k/tables/cells.parquet" ] || python "$HERE/movies.py" --kind "$k" --out "$OUT/$k"
    # 1) TissueMiner on hexatissue's tables as they are (pixel centroids)
    rm -rf "$OUT/tm_$k"; python "$HERE/write_db.py" "$OUT/$k/tables" "$OUT/tm_$k/movie_$k"
    # 2) the same with the exact centroids of the continuous cells (no rasterisation error)
    rm -rf "$OUT/tm_${k}_exact"; python "$HERE/write_db.py" "$OUT/$k/tables" "$OUT/tm_${k}_exact/movie_${k}_exact" --centres "$OUT/$k/exact_centres.csv"
    bash "$HERE/run_tissueminer.sh" "$OUT/tm_$k/movie_$k" "$OUT/tm_${k}_exact/movie_${k}_exact"
    for run in "movie_$k:tm_$k" "movie_${k}_exact:tm_${k}_exact"; do
        m="${run%%:*}"; d="${run##*:}"
        for roi in raw interior; do
            python "$HERE/compare.py" --tm "$OUT/$d/$m" --roi $roi --truth "$OUT/$k/truth.json" \
                --hexatissue "$OUT/$k/tables" --csv "$OUT/$d/compare_$roi.csv" --md "$MD" > "$OUT/$d/compare_$roi.txt"
        done
    done
done
echo "summary: $MD"
