"""Benchmark: tracking a flowing tissue against exact truth; writes ``benchmarks/results_tracking.md``.

Movies with known identities:

- synthetic (:func:`hexatissue.synthetic.flowing_movie`): a Voronoi tissue
  (spacing 16 px, 240 x 320 px, 8 frames) translating 0.1-1.0 cell diameters
  per frame, shearing 1 %/frame and turning 0.02 rad/frame, with divisions and
  extrusions (and one movie with 1 px of seed noise per frame), ids shuffled
  every frame;
- real: the curated EpiCure notum movie (``epicure_notum/013_crop_labels.tif``)
  and ITASC ``pos00`` (``itasc_micropattern/pos00/cell_labels.tif``), whose
  ids are the same cell across frames: the ids are shuffled frame by frame and
  only every 1st, 2nd or 3rd frame is kept, so the motion between frames grows.

Trackers: :class:`hexatissue.track.Tracker` with ``follow="flow"`` (the
default) and ``follow="none"`` (the overlap of the frames as they are: the
tracker before), and, when laptrack is importable, laptrack's ``LapTrack``
on centroids (cutoff one cell spacing, splitting allowed) and its
``OverLapTrack`` (overlap costs).  Scores: the share of true frame-to-frame
links kept, the false links, tracks ending / starting inside the tissue that
truly do not, divisions found (:func:`hexatissue.benchmark.tracking.score_tracking`),
and, when traccuracy is importable, its CTC TRA on the same segmentation.
Times are CPU seconds per frame of the tracker alone.

laptrack and traccuracy are not dependencies: run the script in a side venv
that has them (``python -m venv --system-site-packages /tmp/v && /tmp/v/bin/pip install
laptrack traccuracy``, then ``PYTHONPATH=. /tmp/v/bin/python benchmarks/bench_tracking.py``).
"""
from __future__ import annotations

import argparse
import datetime as dt
import os
import platform
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from _timing import REAL_DATA  # benchmarks/_timing.py
from hexatissue.benchmark.tracking import clone_growth, score_tracking
from hexatissue.synthetic import flowing_movie, relabel_movie
from hexatissue.track import Tracker

HERE = Path(__file__).resolve().parent
REAL = REAL_DATA


def run_ours(labels, follow):
    tr = Tracker(follow=follow)
    t0 = time.process_time()
    for t, lab in enumerate(labels):
        tr.add(lab, t)
    tracks = tr.tracks()
    return tracks, tr.parents, (time.process_time() - t0) / len(labels)


def _cells(labels):
    from scipy import ndimage

    rows = []
    for t, lab in enumerate(labels):
        ids = np.unique(lab)
        ids = ids[ids > 0]
        com = np.asarray(ndimage.center_of_mass(np.ones_like(lab), lab, ids))
        rows.append(pd.DataFrame({"frame": t, "cell": ids, "y": com[:, 0], "x": com[:, 1]}))
    return pd.concat(rows, ignore_index=True)


def _parents(split_df):
    """laptrack's splits as ``{daughter track: mother track}`` (track ids + 1: ours start at 1)."""
    if not len(split_df):
        return {}
    return {int(c) + 1: int(p) + 1 for p, c in zip(split_df["parent_track_id"], split_df["child_track_id"])}


def speed(n_frames, pairs):
    """CPU ms per frame of the tracker (checking, compacting and linking) on the 440-cell periodic movie of
    ``bench_t1.py`` (384 x 403 px, slow Lissajous motion), follow flow / none alternated ``pairs`` times."""
    from hexatissue.synthetic import voronoi_movie

    mv = voronoi_movie(440, (384, 403), n_frames, periodic=True, amplitude=0.3, seed=0)
    frames = [mv[t].astype(np.uint16) for t in range(n_frames)]
    out = {"flow": [], "none": []}
    for _ in range(pairs):
        for follow in ("none", "flow"):
            tr = Tracker(follow=follow, periodic=True)
            t0 = time.process_time()
            for t, lab in enumerate(frames):
                tr.add(lab, t)
            tr.tracks()
            out[follow].append(1000 * (time.process_time() - t0) / n_frames)
    return out


def run_laptrack(labels, spacing):
    from laptrack import LapTrack

    cells = _cells(labels)
    lt = LapTrack(cutoff=float(spacing) ** 2, splitting_cutoff=float(0.75 * spacing) ** 2, gap_closing_cutoff=False)
    t0 = time.process_time()
    track_df, split_df, _ = lt.predict_dataframe(cells, ["y", "x"], only_coordinate_cols=False)
    took = (time.process_time() - t0) / len(labels)
    tracks = pd.DataFrame({"frame": track_df["frame"].to_numpy(np.int64), "cell": track_df["cell"].to_numpy(np.int64),
                           "track": track_df["track_id"].to_numpy(np.int64) + 1})
    parents = _parents(split_df)
    return tracks, parents, took


def run_overlaptrack(labels):
    from laptrack import OverLapTrack

    lt = OverLapTrack(splitting_cutoff=0.9, gap_closing_cutoff=False)
    t0 = time.process_time()
    track_df, split_df, _ = lt.predict_overlap_dataframe(np.asarray(labels))
    track_df = track_df.reset_index()
    took = (time.process_time() - t0) / len(labels)
    tracks = pd.DataFrame({"frame": track_df["frame"].to_numpy(np.int64), "cell": track_df["label"].to_numpy(np.int64),
                           "track": track_df["track_id"].to_numpy(np.int64) + 1})
    parents = _parents(split_df)
    return tracks.sort_values(["frame", "cell"], ignore_index=True), parents, took


def tra(labels, tracks, parents, truth, true_parents):
    """traccuracy's CTC TRA of the tracking against the truth graph on the same segmentation (NaN without it)."""
    try:
        import networkx as nx
        from traccuracy import TrackingGraph, run_metrics
        from traccuracy.matchers import CTCMatcher
        from traccuracy.metrics import CTCMetrics
    except ImportError:
        return float("nan")

    seg = np.asarray(labels)
    big = int(seg.max()) + 1

    def _node(t, c):  # traccuracy wants integer node ids
        return int(t) * big + int(c)

    def graph(ident):  # ident: (frame, cell) -> track; edges within a track and mother -> daughters
        g = nx.DiGraph()
        frame_of = {}
        for (t, c), k in ident.items():
            g.add_node(_node(t, c), t=t, segmentation_id=c)
            frame_of.setdefault(k, []).append((t, c))
        for k, cells in frame_of.items():
            cells.sort()
            for (t0, c0), (t1, c1) in zip(cells[:-1], cells[1:]):
                if t1 == t0 + 1:
                    g.add_edge(_node(t0, c0), _node(t1, c1))
        return g, frame_of

    def with_divisions(g, frame_of, par):
        for d, m in par.items():
            if d in frame_of and m in frame_of:
                (tm, cm), (td, cd) = frame_of[m][-1], frame_of[d][0]
                if td == tm + 1:
                    g.add_edge(_node(tm, cm), _node(td, cd))
        return g

    gt, gf = graph(truth)
    gt = with_divisions(gt, gf, true_parents)
    pred_ident = dict(zip(zip(tracks["frame"].tolist(), tracks["cell"].tolist()), tracks["track"].tolist()))
    pg, pf = graph(pred_ident)
    pg = with_divisions(pg, pf, parents)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        results, _ = run_metrics(TrackingGraph(gt, seg), TrackingGraph(pg, seg), CTCMatcher(), [CTCMetrics()])
    return float(results[0]["results"]["TRA"])


def synthetic_cases(quick):
    speeds = (0.25, 0.75) if quick else (0.1, 0.25, 0.5, 0.75, 1.0)
    for s in speeds:
        yield f"flow {s:g} d/frame", dict(speed=s)
    if not quick:
        yield "flow 0.75 d/frame, 1 px noise", dict(speed=0.75, noise=1.0)
        yield "flow 0.75 d/frame, 20 divisions", dict(speed=0.75, divisions=20, extrusions=0)


def real_cases():
    import tifffile

    for name, path in (("EpiCure 013", REAL / "epicure_notum" / "013_crop_labels.tif"),
                       ("ITASC pos00", REAL / "itasc_micropattern" / "pos00" / "cell_labels.tif")):
        if not path.exists():
            continue
        stack = np.asarray(tifffile.imread(path)).astype(np.int64)
        for every in (1, 2, 3):
            yield f"{name}, every {every}", stack[::every]


def score_row(case, tracker, labels, tracks, parents, took, truth, true_parents, extruded, base_ext=0, base_app=0):
    sc = score_tracking(tracks, parents, truth, labels, true_parents, extruded)
    return {"movie": case, "tracker": tracker, "links kept": sc["kept"], "false links": sc["false_links"],
            "interior extrusions": sc["interior_extrusions"] - base_ext,
            "interior appearances": sc["interior_appearances"] - base_app,
            "divisions found": f"{sc['divisions_found']}/{sc['divisions']}", "false divisions": sc["divisions_false"],
            "TRA": tra(labels, tracks, parents, truth, true_parents), "CPU ms/frame": 1000 * took}


def trackers(labels, spacing):
    yield "hexatissue flow", lambda: run_ours(labels, "flow")
    yield "hexatissue none (before)", lambda: run_ours(labels, "none")
    try:
        import laptrack  # noqa: F401
    except ImportError:
        return
    yield "laptrack LapTrack (centroids)", lambda: run_laptrack(labels, spacing)
    yield "laptrack OverLapTrack", lambda: run_overlaptrack(labels)


def markdown(table: pd.DataFrame) -> str:
    """A DataFrame as a Markdown table, floats to 4 significant digits."""
    def cell(v):
        return f"{v:.4g}" if isinstance(v, float) else str(v)

    out = ["| " + " | ".join(table.columns) + " |", "|" + "---|" * len(table.columns)]
    out += ["| " + " | ".join(cell(v) for v in row) + " |" for row in table.itertuples(index=False)]
    return "\n".join(out)


def growth_budget():
    """The deformation budget's cumulative total (log area) of a growing flowing tissue against the growth of its
    clones (the same cells and their daughters) and the seeds' own growth, tracked by each ``follow``."""
    from hexatissue import HexatissueWarning, analyze
    from hexatissue.options import DeformationOptions, TrackOptions

    m = flowing_movie(shape=(320, 400), n_frames=6, speed=0.5, shear=0.01, rotation=0.02, growth=0.03, divisions=12,
                      seed=5)
    rows = []
    for follow in ("flow", "none"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", HexatissueWarning)
            movie = analyze(m.labels, workers=1, progress=False, track=TrackOptions(follow=follow),
                            deformation=DeformationOptions(enabled=True))
        tissue = movie.deformation[movie.deformation["region"] == "tissue"]
        growth, clones = clone_growth(movie.cells, movie.lineage, 0, 5)
        rows.append({"follow": follow, "budget total (log area)": tissue["total_iso"].sum(),
                     "division term": tissue["division_iso"].sum(), "extrusion term": tissue["extrusion_iso"].sum(),
                     "border term": tissue["border_iso"].sum(), "clone growth": growth, "clones": clones,
                     "truth": 10 * np.log(1.03), "intervals doubtful": int(tissue["tracking_doubtful"].sum())})
    return pd.DataFrame(rows)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="two synthetic speeds, no real data")
    ap.add_argument("--out", default=str(HERE / "results_tracking.md"))
    args = ap.parse_args(argv)
    rows = []
    warm = flowing_movie(n_frames=3, speed=0.75)  # numba compiles (or loads its cache) before anything is timed
    run_ours(warm.labels, "flow"), run_ours(warm.labels, "none")
    start = dt.datetime.now(dt.timezone.utc)
    load = os.getloadavg()
    for case, kw in synthetic_cases(args.quick):
        kw = {"n_frames": 8, "divisions": 6, "extrusions": 4, "shear": 0.01, "rotation": 0.02, "seed": 7, **kw}
        m = flowing_movie(**kw)
        for name, fn in trackers(m.labels, m.spacing):
            tracks, parents, took = fn()
            rows.append(score_row(case, name, m.labels, tracks, parents, took, m.truth, m.parents, m.extruded))
            print(rows[-1], flush=True)
    if not args.quick:
        for case, stack in real_cases():
            labels, maps = relabel_movie(stack, seed=3)
            truth = {(t, new): old for t, mp in enumerate(maps) for new, old in mp.items()}
            areas = np.bincount(stack[0].ravel())[1:]
            spacing = float(np.sqrt(np.median(areas[areas > 0])))
            # the curated ids' own tracks: their interior ends and starts are the truth's events
            cells = pd.DataFrame([(t, c) for (t, c) in truth], columns=["frame", "cell"]).sort_values(["frame", "cell"])
            true_tracks = cells.assign(track=[truth[k] for k in zip(cells["frame"], cells["cell"])])
            base = score_tracking(true_tracks, {}, truth, labels)
            for name, fn in trackers(labels, spacing):
                tracks, parents, took = fn()
                rows.append(score_row(case, name, labels, tracks, parents, took, truth, {}, {},
                                      base["interior_extrusions"], base["interior_appearances"]))
                print(rows[-1], flush=True)
    table = pd.DataFrame(rows)
    times = speed(100 if args.quick else 300, 1 if args.quick else 5)
    growing = None if args.quick else growth_budget()
    ratio = np.median(times["flow"]) / np.median(times["none"])
    end = dt.datetime.now(dt.timezone.utc)
    lines = ["# Tracking a flowing tissue against truth", "",
             f"Generated by `benchmarks/bench_tracking.py{' --quick' if args.quick else ''}` on {platform.node()} "
             f"({platform.machine()}, {os.cpu_count()} cores), {start:%Y-%m-%d %H:%M}-{end:%H:%M} UTC, load "
             f"{load[0]:.1f} at the start, {os.getloadavg()[0]:.1f} at the end.", "",
             "Synthetic: Voronoi, spacing 16 px (one cell diameter = d), 240 x 320 px, 8 frames, shear 1 %/frame, "
             "rotation 0.02 rad/frame, 6 divisions and 4 extrusions unless said, ids shuffled per frame. Real: curated "
             "ids shuffled per frame, every n-th frame kept; interior extrusions / appearances are counted beyond "
             "those of the curated tracks themselves (negative: fewer); their truth holds ids only, so a real division "
             "(EpiCure 013's 73 -> 477 + 490) counts as a false division. `divisions found` needs mother and both "
             "daughters right. TRA: traccuracy's CTC TRA on the same segmentation (NaN when traccuracy is absent). "
             "CPU ms/frame: the tracker alone (ours includes checking and compacting the labels; laptrack's "
             "LapTrack excludes the centroids).", "",
             markdown(table), "",
             f"Speed (the `bench_t1.py` movie: 440 cells, 384 x 403 px, periodic, {100 if args.quick else 300} "
             f"frames; CPU ms per frame of `Tracker.add`, checking and compacting included; alternated runs): "
             f"follow flow {', '.join(f'{v:.2f}' for v in times['flow'])}; none (before) "
             f"{', '.join(f'{v:.2f}' for v in times['none'])}; ratio of the medians {ratio:.2f}.", ""]
    if growing is not None:
        lines += ["Growing tissue (320 x 400 px, 6 frames, lengths +3 %/frame, 0.5 d/frame, shear 1 %/frame, 0.02 "
                  "rad/frame, 12 divisions): the deformation budget's cumulative total against the growth of the cells "
                  "of frame 0 and their daughters that stay inside (`clone_growth`) and the seeds' own 10 log 1.03:",
                  "",
                  markdown(growing), ""]
    Path(args.out).write_text("\n".join(lines))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
