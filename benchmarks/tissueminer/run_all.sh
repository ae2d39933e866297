#!/usr/bin/env bash
# The whole side-by-side check: synthetic movies -> hexatissue.analyze -> TissueMiner DB ->
# TissueMiner's shear code -> comparison.   OUT defaults to /tmp/tmbench.
#   PYTHONPATH=$PWD benchmarks/tissueminer/run_all.sh [OUT]
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
OUT="${1:-/tmp/tmbench}"
KINDS="${KINDS:-shear t1 division extrusion}"
mkdir -p "$OUT"
MD="$OUT/results.md"; : > "$MD"
for k in $KINDS; do
    [ -f "$OUT/$k/tables/cells.parquet" ] || python "$HERE/movies.py" --kind "$k" --out "$OUT/$k"
    # 1) TissueMiner on hexatissue's tables as they are (pixel centroids)
    rm -rf "$OUT/tm_$k"; python "$HERE/write_db.py" "$OUT/$k/tables" "$OUT/tm_$k/movie_$k"
    # 2) the same with the exact centroids of the continuous cells (no rasterisation error)
    rm -rf "$OUT/tm_${k}_exact"; python "$HERE/write_db.py" "$OUT/$k/tables" "$OUT/tm_${k}_exact/movie_${k}_exact" --centres "$OUT/$k/exact_centres.csv"
    # hexatissue's own budget on the same tables (pixel centroids / exact centres)
    python "$HERE/hexatissue_budget.py" "$OUT/$k/tables" --out "$OUT/$k/deformation.parquet" > "$OUT/$k/deformation.txt"
    python "$HERE/hexatissue_budget.py" "$OUT/$k/tables" --out "$OUT/$k/deformation_exact.parquet" --centres "$OUT/$k/exact_centres.csv" > "$OUT/$k/deformation_exact.txt"
    bash "$HERE/run_tissueminer.sh" "$OUT/tm_$k/movie_$k" "$OUT/tm_${k}_exact/movie_${k}_exact"
    for run in "movie_$k:tm_$k:deformation" "movie_${k}_exact:tm_${k}_exact:deformation_exact"; do
        m="${run%%:*}"; rest="${run#*:}"; d="${rest%%:*}"; hx="${rest#*:}"
        for roi in raw interior; do
            python "$HERE/compare.py" --tm "$OUT/$d/$m" --roi $roi --truth "$OUT/$k/truth.json" \
                --hexatissue "$OUT/$k/$hx.parquet" --csv "$OUT/$d/compare_$roi.csv" --md "$MD" > "$OUT/$d/compare_$roi.txt"
        done
    done
done
# diagnostics (exact centres): TissueMiner's shear code with other triangulations than
# CreateTriangles.R's (which makes n overlapping triangles at an n-fold vertex):
#   fan   = a tiling from hexatissue's vertices (fans from the smallest id at n-fold vertices)
#   stage = exactly the triangles of hexatissue's deformation stage (interior cells; a four-fold
#           vertex keeps the previous frame's diagonal): the like-for-like check of the two codes
for k in ${DIAG_KINDS:-t1 division extrusion}; do
    for variant in fan:hexatissue stage:stage; do
        name="${variant%%:*}"; opt="${variant##*:}"
        d="$OUT/tm_${k}_exact_$name"; m="movie_${k}_exact_$name"
        rm -rf "$d"
        python "$HERE/write_db.py" "$OUT/$k/tables" "$d/$m" --centres "$OUT/$k/exact_centres.csv" --triangles $opt
        bash "$HERE/run_tissueminer.sh" "$d/$m"
        for roi in raw interior; do
            python "$HERE/compare.py" --tm "$d/$m" --roi $roi --truth "$OUT/$k/truth.json" \
                --hexatissue "$OUT/$k/deformation_exact.parquet" --label "$m / $roi (triangles: $name)" \
                --csv "$d/compare_$roi.csv" --md "$MD" > "$d/compare_$roi.txt"
        done
    done
done
echo "summary: $MD"
