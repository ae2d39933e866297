"""How TissueMiner's terms converge with the per-frame strain eps (exact centres, shear movie).

The pure-shear movie's topology does not depend on eps (an affine map of a fixed Voronoi
tessellation), so hexatissue's tables of one run (``--tables``, made at eps = 0.01) give the
polygons for every eps, and the exact centroids of movies.py (``exact_centres``) give the
positions.  For each eps: write the DB with those centres, run TissueMiner's shear code, and
record per term the mean over frame pairs and the largest deviation from the exact value.

Usage::

    PYTHONPATH=$PWD python benchmarks/tissueminer/sweep_eps.py --tables /tmp/tmbench/shear/tables \
        --out /tmp/tmbench/sweep [--eps 0.0025 0.005 0.01 0.02 0.04]
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import compare  # noqa: E402
import movies  # noqa: E402
import write_db  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--tables", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--eps", type=float, nargs="+", default=[0.0025, 0.005, 0.01, 0.02, 0.04])
    args = ap.parse_args(argv)
    import hexatissue as ht
    movie = ht.read_results(args.tables)
    out = Path(args.out)
    rows = []
    for eps in args.eps:
        _, info = movies.make("shear", eps=eps)
        d = out / f"eps_{eps:g}"
        d.mkdir(parents=True, exist_ok=True)
        pd.DataFrame(info.pop("exact_centres"), columns=["frame", "cell", "x", "y", "area"]).to_csv(d / "exact_centres.csv", index=False)
        (d / "truth.json").write_text(json.dumps(info, indent=1))
        mdir = d / f"movie_eps_{eps:g}".replace(".", "p")
        write_db.write(movie, mdir, centres=d / "exact_centres.csv")
        subprocess.run(["bash", str(HERE / "run_tissueminer.sh"), str(mdir)], check=True, stdout=subprocess.DEVNULL)
        tm = compare.read_tm(mdir, "raw")
        tt = compare.truth_table(info, tm["frame"])
        nu = np.hypot(info["exact_per_frame"]["nu_xx"], info["exact_per_frame"]["nu_xy"])
        row = {"eps": eps, "|nu| exact": nu}
        for term in ("total", "elongation", "residual", "corotation", "growth_correlation", "rotation_correlation"):
            dev = np.hypot(tm[f"{term}_xx"] - tt[f"{term}_xx"], tm[f"{term}_xy"] - tt[f"{term}_xy"])
            row[f"{term}: max |TM-truth| / |nu|"] = dev.max() / nu
        rows.append(row)
        print(row, flush=True)
    res = pd.DataFrame(rows)
    res.to_csv(out / "sweep_eps.csv", index=False)
    print(res.to_string(index=False))


if __name__ == "__main__":
    main()
