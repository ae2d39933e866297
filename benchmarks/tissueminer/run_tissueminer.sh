#!/usr/bin/env bash
# Run TissueMiner's own triangulation and shear decomposition on movie folders written by write_db.py.
#
#   benchmarks/tissueminer/run_tissueminer.sh MOVIE_DIR [MOVIE_DIR ...]
#
# TM_HOME: a checkout of TissueMiner (default /tmp/tm, extracted here from the stored snapshot
#   /work/.mirror/mpicbg-scicomp+tissue_miner/repo with `git archive HEAD` when absent).
# Per movie:
#   1. triangles/CreateTriangles.R  (TissueMiner's): directed_bonds -> shear_contrib/triList.RData,
#      neighbors.RData  (skipped when write_db.py --triangles hexatissue already wrote them);
#   2. shear/CalculateShearContributions.R (TissueMiner's; runs CreateIntermediates.R and
#      ShearByCellEvents2.R per ROI) through tm_compat.R (the tbl_dt shim, see there);
#   3. exports shear_contrib/triList.RData to csv/triList_tm.csv for compare.py's triangle check.
# Output: MOVIE_DIR/shear_contrib/<roi>/avgDeformTensorsWide.tsv (roi: raw = every cell, interior).
# Logs: MOVIE_DIR/logs/*.log
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
SNAPSHOT="${TM_SNAPSHOT:-/work/.mirror/mpicbg-scicomp+tissue_miner/repo}"
export TM_HOME="${TM_HOME:-/tmp/tm}"
if [ ! -f "$TM_HOME/shear/CalculateShearContributions.R" ]; then
    mkdir -p "$TM_HOME"
    git -C "$SNAPSHOT" archive HEAD | tar -x -C "$TM_HOME"
fi
echo "TissueMiner: $TM_HOME (snapshot $(git -C "$SNAPSHOT" rev-parse HEAD 2>/dev/null || echo unknown))"
for movie in "$@"; do
    movie="$(cd "$movie" && pwd)"
    mkdir -p "$movie/logs" "$movie/csv"
    echo "== $movie"
    if [ ! -f "$movie/shear_contrib/triList.RData" ]; then
        Rscript "$TM_HOME/triangles/CreateTriangles.R" "$movie" > "$movie/logs/CreateTriangles.log" 2>&1
    fi
    start=$(date +%s.%N)
    Rscript "$HERE/tm_compat.R" "$TM_HOME/shear/CalculateShearContributions.R" "$movie" \
        > "$movie/logs/CalculateShearContributions.log" 2>&1
    echo "   CalculateShearContributions.R: $(echo "$(date +%s.%N) - $start" | bc) s"
    Rscript -e "x <- get(load('$movie/shear_contrib/triList.RData')); write.csv(x, '$movie/csv/triList_tm.csv', row.names=FALSE)"
    ls "$movie"/shear_contrib/*/avgDeformTensorsWide.tsv
done
