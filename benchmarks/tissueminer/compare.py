"""Compare TissueMiner's shear decomposition with the exact truth of a synthetic movie and,
when it exists, hexatissue's ``deformation`` table.

TissueMiner's output (``MOVIE/shear_contrib/<roi>/avgDeformTensorsWide.tsv``, one row per frame
pair ``frame -> frame + 1``, rates per frame, ``frame`` = the pair's first frame) has, per term,
``<name>_xx`` and ``<name>_xy``:

==================  =================================================  =======================
TissueMiner         meaning                                            hexatissue
==================  =================================================  =======================
nu                  total pure shear (area-weighted mean of the        total
                    triangles' linearised displacement gradient)
ShearCE             change of the mean triangle elongation Q           cell_shape
ct                  corotational term                                  corotation
cagc                area-growth correlation                            growth_correlation
crc                 rotation correlation                               rotation_correlation
ShearT1             T1 transitions (I2 -> I3: every retriangulation    t1_cycle + t1_intercalation
                    but divisions)                                     + t1_unresolved + rearrangement
                                                                       + resampling
ShearCD             cell divisions (I3 -> t+1)                         division
ShearT2             extrusions ("T2", t -> I1)                         extrusion
deltaCheck          TissueMiner's own residual nu - (cecr + ct +       nonlinear + closure
                    cagc + crc), cecr = Q(I2) - Q(I1): the nonlinear
                    corotational term TissueMiner leaves out
==================  =================================================  =======================

The sum TissueMiner plots: ShearCE + ct + (cagc + crc) + ShearT1 + ShearT2 + ShearCD ("sumContrib");
compare.py adds the rows ``correlation`` (cagc + crc, TissueMiner's "correlationEffects"; hexatissue:
growth_correlation + rotation_correlation) and ``sum`` (compared with the exact / hexatissue total).

Names on either side live in the dicts below (TM_TERMS, HX_TERMS; hexatissue's names as of main
80a67c9, ``hexatissue.schema.DEFORMATION_TERMS``).  hexatissue's tissue triangulation uses interior
cells only: compare it with TissueMiner's ``interior`` ROI (``raw`` also has the border cells'
triangles).  hexatissue's ``border`` and ``advection`` terms have no TissueMiner counterpart.  Both codes get the same coordinates (x = column, y = row, px), so
components are compared as they are.

Usage::

    python benchmarks/tissueminer/compare.py --tm MOVIE_DIR --truth truth.json [--roi raw]
        [--hexatissue RESULTS_DIR_OR_TABLE] [--label NAME] [--csv OUT.csv] [--md OUT.md]
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import pandas as pd

#: term -> TissueMiner column stem (its avgDeformTensorsWide.tsv has <stem>_xx, <stem>_xy)
TM_TERMS = {
    "total": "nu",
    "elongation": "ShearCE",
    "corotation": "ct",
    "growth_correlation": "cagc",
    "rotation_correlation": "crc",
    "t1": "ShearT1",
    "division": "ShearCD",
    "extrusion": "ShearT2",
    "residual": "deltaCheck",
}
#: term -> alternatives, each a list of hexatissue ``deformation`` column stems summed; the first
#: alternative whose columns all exist is used (<stem>_xx, <stem>_xy)
HX_TERMS = {
    "total": [["total"]],
    "elongation": [["cell_shape"], ["elongation"]],
    "corotation": [["corotation"]],
    "growth_correlation": [["growth_correlation"]],
    "rotation_correlation": [["rotation_correlation"]],
    # TissueMiner's ShearT1 is every change of triangulation I2 -> I3 (all but divisions)
    "t1": [["t1_cycle", "t1_intercalation", "t1_unresolved", "rearrangement", "resampling"], ["rearrangement"],
           ["t1"]],
    "division": [["division"]],
    "extrusion": [["extrusion"]],
    # TissueMiner leaves out the nonlinear corotational term: its residual deltaCheck is that term
    "residual": [["nonlinear", "closure"], ["nonlinear"]],
}
#: hexatissue's deformation table: frame column, region column and the region to use
HX_FRAME, HX_REGION, HX_REGION_VALUE = "frame", "region", "tissue"
#: file names tried for hexatissue's deformation table inside a results folder
HX_FILES = ["deformation.parquet", "deformation.csv"]
COMPONENTS = ("xx", "xy")


def read_tm(movie_dir, roi="raw"):
    path = Path(movie_dir) / "shear_contrib" / roi / "avgDeformTensorsWide.tsv"
    d = pd.read_csv(path, sep="\t")
    out = pd.DataFrame({"frame": d["frame"].astype(int)})
    for term, stem in TM_TERMS.items():
        for c in COMPONENTS:
            out[f"{term}_{c}"] = d[f"{stem}_{c}"] if f"{stem}_{c}" in d else np.nan
    for c in COMPONENTS:
        # TissueMiner's "correlationEffects" = cagc + crc
        out[f"correlation_{c}"] = out[f"growth_correlation_{c}"] + out[f"rotation_correlation_{c}"]
    for c in COMPONENTS:
        out[f"sum_{c}"] = sum(d[f"{TM_TERMS[t]}_{c}"] for t in ("elongation", "corotation", "growth_correlation",
                                                                   "rotation_correlation", "t1", "division", "extrusion"))
    return out


def read_hexatissue(path):
    """hexatissue's deformation table (a file, or a results folder holding one); None when absent."""
    if path is None:
        return None
    p = Path(path)
    if p.is_dir():
        found = [p / f for f in HX_FILES if (p / f).exists()]
        if not found:
            return None
        p = found[0]
    d = pd.read_parquet(p) if p.suffix == ".parquet" else pd.read_csv(p)
    if HX_REGION in d:
        d = d[d[HX_REGION] == HX_REGION_VALUE]
    out = pd.DataFrame({"frame": d[HX_FRAME].astype(int).to_numpy()})
    for term, alternatives in HX_TERMS.items():
        for alt in alternatives:
            if all(f"{s}_{c}" in d for s in alt for c in COMPONENTS):
                for c in COMPONENTS:
                    out[f"{term}_{c}"] = sum(d[f"{s}_{c}"].to_numpy() for s in alt)
                break
    for c in COMPONENTS:
        if f"growth_correlation_{c}" in out and f"rotation_correlation_{c}" in out:
            out[f"correlation_{c}"] = out[f"growth_correlation_{c}"] + out[f"rotation_correlation_{c}"]
    return out


def truth_table(truth, frames):
    """Exact per-frame rates of a movies.py movie (NaN where not known exactly).

    * total: TissueMiner's linearised nu = sinh(eps) (cos 2phi, sin 2phi) at every frame pair: the
      area-weighted mean displacement gradient of a triangulated patch depends only on the motion of
      its boundary cells, which move with the uniform affine map in every movie (events are interior);
    * extrusion: 0 except at the extrusion movie's extrusion pair; division: 0 except at the division pair; t1: 0
      except, in the t1 movie, from the first pair where the exact neighbours change on (the
      segmented topology can lag the exact one by a frame or two: four-fold vertices);
    * corotation, rotation_correlation, growth_correlation: 0 at the pairs where every cell moves
      with the affine map (``affine_pairs``): each triangle's map is then the area-preserving pure
      shear itself (no rotation, unit determinant);
    * elongation (and TissueMiner's residual deltaCheck): no closed form.  On affine pairs the change
      of the mean triangle Q is nu up to terms of order eps * |Q|^2 and eps^2: the reference is the
      first-order value nu (residual 0), so |TM - truth| there measures the decomposition's
      nonlinear closure error, not a bug;
    * sum (of TissueMiner's contributions): compared with the exact total.
    """
    ex = truth["exact_per_frame"]
    affine = set(truth.get("affine_pairs", []))
    changes = {c["frame"] for c in truth.get("topology_changes", [])}
    kind = truth["kind"]
    rows = []
    for f in frames:
        r = {"frame": f}
        aff = f in affine
        for c in COMPONENTS:
            nu = ex[f"nu_{c}"]
            r[f"total_{c}"] = nu
            r[f"extrusion_{c}"] = np.nan if kind == "extrusion" and f in changes else 0.0
            r[f"division_{c}"] = np.nan if kind == "division" and f in changes else 0.0
            # t1 movie: the segmented topology may lag the exact one (a four-fold vertex lasting a
            # few frames), so T1 = 0 is only known before the first exact change
            # (extrusion movie: TissueMiner counts the hole's retriangulation as T1, hexatissue as extrusion)
            r[f"t1_{c}"] = np.nan if (kind == "t1" and changes and f >= min(changes)) or \
                (kind == "extrusion" and f in changes) else 0.0
            for term in ("corotation", "rotation_correlation", "growth_correlation", "correlation"):
                r[f"{term}_{c}"] = 0.0 if aff else np.nan
            r[f"elongation_{c}"] = nu if aff else np.nan   # first order only (see above)
            r[f"residual_{c}"] = 0.0 if aff else np.nan    # first order only
            r[f"log_total_{c}"] = ex[f"log_{c}"]
        rows.append(r)
    return pd.DataFrame(rows)


def long_table(tm, truth=None, hx=None):
    terms = list(TM_TERMS) + ["correlation", "sum"]
    rows = []
    for _, r in tm.iterrows():
        f = int(r["frame"])
        tr = truth.set_index("frame").loc[f] if truth is not None and f in set(truth["frame"]) else None
        hr = hx.set_index("frame").loc[f] if hx is not None and f in set(hx["frame"]) else None
        for term in terms:
            for c in COMPONENTS:
                col = f"{term}_{c}"
                t_ref = col if term != "sum" else f"total_{c}"
                rows.append({"frame": f, "term": term, "component": c, "tissueminer": r[col],
                             "truth": tr[t_ref] if tr is not None and t_ref in tr else np.nan,
                             "hexatissue": hr[t_ref] if hr is not None and t_ref in hr else np.nan})
    return pd.DataFrame(rows)


def summary(long, scale):
    """Per term: max |TM - truth| (absolute, and / scale), TM mean, and TM vs hexatissue."""
    out = []
    for term, g in long.groupby("term", sort=False):
        d = (g["tissueminer"] - g["truth"]).abs()
        h = (g["tissueminer"] - g["hexatissue"]).abs()
        out.append({"term": term, "n": int(g["tissueminer"].notna().sum()),
                    "tm_mean_xx": g.loc[g.component == "xx", "tissueminer"].mean(),
                    "tm_mean_xy": g.loc[g.component == "xy", "tissueminer"].mean(),
                    "max_abs_tm_minus_truth": d.max() if d.notna().any() else np.nan,
                    "max_rel_tm_minus_truth": d.max() / scale if d.notna().any() else np.nan,
                    "max_abs_tm_minus_hexatissue": h.max() if h.notna().any() else np.nan})
    return pd.DataFrame(out)


def markdown(df, fmt="{:.2e}"):
    """A Markdown table (no tabulate dependency)."""
    cell = lambda v: fmt.format(v) if isinstance(v, (float, np.floating)) and np.isfinite(v) else ("" if isinstance(v, (float, np.floating)) else str(v))  # noqa: E731
    lines = ["|" + "|".join(df.columns) + "|", "|" + "|".join("---" for _ in df.columns) + "|"]
    lines += ["|" + "|".join(cell(v) for v in row) + "|" for row in df.itertuples(index=False)]
    return "\n".join(lines)


def check_triangles(movie_dir):
    """The triangles TissueMiner used (its triList.RData: CreateTriangles.R's from directed_bonds, or
    those write_db.py wrote) vs write_db.py's triangles of hexatissue's vertices (one per three-fold
    vertex off the background, fans at n-fold ones): same cell triples per frame?  Counts, or None."""
    a, b = Path(movie_dir) / "csv" / "triList_tm.csv", Path(movie_dir) / "csv" / "triList_hexatissue.csv"
    if not (a.exists() and b.exists()):
        return None

    def triples(p):
        d = pd.read_csv(p).sort_values(["tri_id", "tri_order"])
        out = set()
        for (f, _), g in d.groupby(["frame", "tri_id"]):
            out.add((int(f), tuple(sorted(g["cell_id"].astype(int)))))
        return out

    ta, tb = triples(a), triples(b)
    return {"triList": len(ta), "vertex_triangles": len(tb), "common": len(ta & tb), "only_triList": len(ta - tb),
            "only_vertex_triangles": len(tb - ta)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--tm", required=True, help="TissueMiner movie folder (after run_tissueminer.sh)")
    ap.add_argument("--roi", default="raw", help="TissueMiner ROI (raw = every cell; interior)")
    ap.add_argument("--truth", help="movies.py truth.json")
    ap.add_argument("--hexatissue", help="hexatissue results folder or deformation table")
    ap.add_argument("--label", default=None)
    ap.add_argument("--csv", help="write the per-frame long table here")
    ap.add_argument("--md", help="append a Markdown summary here")
    args = ap.parse_args(argv)
    tm = read_tm(args.tm, args.roi)
    truth = json.loads(Path(args.truth).read_text()) if args.truth else None
    tt = truth_table(truth, tm["frame"]) if truth else None
    hx = read_hexatissue(args.hexatissue)
    long = long_table(tm, tt, hx)
    scale = np.hypot(truth["exact_per_frame"]["nu_xx"], truth["exact_per_frame"]["nu_xy"]) if truth else 1.0
    summ = summary(long, scale)
    label = args.label or f"{Path(args.tm).name} / {args.roi}"
    pd.set_option("display.width", 200)
    with pd.option_context("display.float_format", "{:.3e}".format):
        print(f"## {label}")
        print(tm.set_index("frame")[[c for c in tm if c != "frame"]].T.to_string())
        print(summ.to_string(index=False))
    tri = check_triangles(args.tm)
    if tri:
        print("triangles:", tri)
    if hx is None:
        print("hexatissue deformation table: not found (", args.hexatissue, ")")
    if args.csv:
        long.assign(run=label).to_csv(args.csv, index=False)
    if args.md:
        with open(args.md, "a") as fh:
            fh.write(f"\n### {label}\n\n")
            if tri:
                fh.write(f"Triangles (TissueMiner's triList vs the triangles of hexatissue's vertices off the background): {tri}\n\n")
            fh.write(f"|shear rate per frame (|exact total| = {scale:.4e})|" if truth else "|")
            fh.write(" per-frame values (xx / xy), frames " + ", ".join(str(f) for f in tm["frame"]) + "|\n|---|---|\n")
            for term in list(TM_TERMS) + ["correlation", "sum"]:
                vals = "; ".join(f"{x:+.2e}/{y:+.2e}" for x, y in zip(tm[f"{term}_xx"], tm[f"{term}_xy"]))
                fh.write(f"|{term}|{vals}|\n")
            fh.write("\n" + markdown(summ) + "\n")
    return tm, long, summ


if __name__ == "__main__":
    main()
