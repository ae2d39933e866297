"""Benchmark: T1 events against an active vertex model's own T1 log, clean and rendered at several SNR.

The truth is :func:`hexatissue.benchmark.truth_from_vertex_model` (an active vertex
model on a periodic box, default 196 cells x 60 frames; its T1s are the model's log,
not a detection).  The prediction is ``analyze`` of

- the model's clean labels (ids kept), and
- the movie rendered at each SNR (1-px membranes, Gaussian PSF sigma 1 px, the
  default noise model: ``benchmark make``), segmented by the baseline
  (``segment_movie``) and tracked by overlap,

for each merge distance asked (``MeshOptions.merge_distance``, px), and scored by
:func:`hexatissue.benchmark.score`: T1 precision, recall and kind accuracy with a
frame tolerance of 1 and 2 frames, a T1 on time by its ``frame_start`` or by its held
four-fold interval (``t1_timing``); neighbour pairs beside them.  The per-cell
definition (``neighbour_events``: a cell's neighbour list changes and returns)
is counted beside it, on the prediction and on the truth's clean labels.  The true T1s
missed on the clean labels at the default merge distance are listed with what the model's
exact junctions say about them (:func:`misses`).
Writes ``benchmarks/results_events.md``.  Usage::

    PYTHONPATH=$PWD python benchmarks/bench_events.py [--cells 196] [--frames 80]
        [--snr 4 8 16 32] [--merge 0.5 1 2] [--out /tmp/bench_events]
"""
from __future__ import annotations

import argparse
import os
import platform
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import hexatissue as ht  # noqa: E402
from hexatissue.benchmark import RenderOptions, make_benchmark, score, segment_movie  # noqa: E402
from hexatissue.benchmark.truth import truth_from_vertex_model  # noqa: E402
from hexatissue.benchmark.vertex_model import vertex_model_movie  # noqa: E402
from hexatissue.events import default_censor, neighbour_events  # noqa: E402
from hexatissue.errors import HexatissueWarning  # noqa: E402

warnings.simplefilter("ignore", HexatissueWarning)
SHOWN = ("t1_precision", "t1_recall", "t1_kind_accuracy", "neighbour_pairs_precision", "neighbour_pairs_recall")


def truth_cell_events(truth):
    """The per-cell events (``neighbour_events``) of the model's exact junctions: the truth of that definition."""
    params = {k: v for k, v in truth.source.items() if k not in ("kind", "n_t1_flips")}
    model = vertex_model_movie(**params)
    edges = model.contacts.assign(edge=0)
    return neighbour_events(edges, truth.movie.cells, censor=default_censor(len(truth)))


def cell_scores(pred, truth, tolerance=1):
    """Per-cell events of the clean labels (ids kept) against the truth's: precision, recall, kind accuracy.

    A predicted event of a track matches a true event of the same track whose frame_start is within
    ``tolerance`` frames (one-to-one, nearest first)."""
    cand = []
    by_track = {}
    for m, t in enumerate(truth.itertuples()):
        by_track.setdefault(int(t.track), []).append((m, int(t.frame_start), t.kind))
    for k, p in enumerate(pred.itertuples()):
        for m, frame, _ in by_track.get(int(p.track), ()):
            if abs(int(p.frame_start) - frame) <= tolerance:
                cand.append((abs(int(p.frame_start) - frame), k, m))
    used_p, used_t, right = set(), set(), 0
    for _, k, m in sorted(cand):
        if k not in used_p and m not in used_t:
            used_p.add(k)
            used_t.add(m)
            right += pred["kind"].iloc[k] == truth["kind"].iloc[m]
    n = len(used_p)
    return {"cell_precision@1": n / max(len(pred), 1), "cell_recall@1": n / max(len(truth), 1),
            "cell_kind@1": right / max(n, 1), "n_cell_truth": len(truth)}


def misses(movie, truth, model, merge):
    """The truth's T1s missed on the clean labels (held@1), each with what the model's exact junctions say.

    ``ab_first``: the a-b junction's true length (px) in the first frame; ``ab_seen``: whether the
    prediction ever had a-b as a contact before the loss; ``cd_max``: the longest the true c-d junction
    gets (up to the undo for a cycle, else to the movie's end).  A T1 whose a-b is shorter than the
    merge distance from the first frame on has its loss before the movie from the network's view (only
    the gain of a four-fold vertex is seen); one whose c-d never passes the merge distance is a held
    four-fold vertex that resolves back (no event by definition)."""
    s = score(movie, truth.movie, pred_labels=truth.labels, truth_labels=truth.labels, frame_tolerance=1,
              t1_timing="held", show_progress=False)
    t1 = s.tables["t1"]
    def by_pair(table):  # length by (frame, lower id, higher id)
        a, b = table["cell_a"].to_numpy(), table["cell_b"].to_numpy()
        return table.assign(lo=np.minimum(a, b), hi=np.maximum(a, b)).groupby(["frame", "lo", "hi"])["length"].sum()

    exact, pred = by_pair(model.contacts), by_pair(movie.edges)
    events = truth.movie.events.set_index("event")
    rows = []
    for m in t1.loc[t1["status"] == "missed", "event"]:
        e = events.loc[m]
        ab, cd = tuple(sorted((int(e.cell_a), int(e.cell_b)))), tuple(sorted((int(e.cell_c), int(e.cell_d))))
        last = int(e.frame_undo) if e.kind == "cycle" else len(truth) - 1
        cd_max = max(float(exact.get((f, *cd), 0.0)) for f in range(int(e.frame_gain), last + 1))
        ab_seen = any(pred.get((f, *ab), 0.0) > 0 for f in range(int(e.frame_start)))
        ab_first = float(exact.get((0, *ab), 0.0))
        cause = ("c-d never passes the merge distance" if cd_max < merge else
                 "a-b below the merge distance from the first frame" if not ab_seen and ab_first < merge else "other")
        rows.append({"event": int(m), "kind": e.kind, "frame_start": int(e.frame_start), "a-b": f"{ab[0]}-{ab[1]}",
                     "c-d": f"{cd[0]}-{cd[1]}", "ab_first": ab_first, "ab_seen": ab_seen, "cd_max": cd_max,
                     "cause": cause})
    return pd.DataFrame(rows)


def analyse(labels, box, merge, overlap):
    track = ht.TrackOptions() if overlap else ht.TrackOptions(mode="never")
    return ht.analyze(labels, box=box, mesh=ht.MeshOptions(merge_distance=merge), track=track,
                      order=ht.OrderOptions(fields=False), flow=ht.FlowOptions(enabled=False), workers=1,
                      progress=False)


def scores(movie, truth, labels):
    row = {}
    for timing, tol in (("start", 1), ("start", 2), ("held", 1)):
        s = score(movie, truth.movie, pred_labels=labels, truth_labels=truth.labels, frame_tolerance=tol,
                  t1_timing=timing, show_progress=False)
        for name in SHOWN[:3]:
            row[f"{name} {timing}@{tol}"] = s.summary.get(name, np.nan)
        if timing == "held":
            row.update({name: s.summary.get(name, np.nan) for name in SHOWN[3:]})
            row.update(n_truth=s.counts["n_truth_t1"], n_pred=s.counts["n_pred_t1"])
            ev = movie.events
            one = ev.loc[(ev["kind"] == "cycle") & (ev["duration"] == 1), "event"]  # the doubtful class of docs/t1.md
            t1 = s.tables["t1"]
            matched = set(t1.loc[t1["status"] == "matched", "pred_event"].tolist())
            row.update(n_one_frame_cycles=len(one), one_frame_true=int(one.isin(matched).sum()))
    row["n_cell_events"] = len(movie.tables["neighbour_events"]) if "neighbour_events" in movie.tables else np.nan
    held = movie.summary.get("events", {})
    row["n_held_contacts"] = held.get("n_held_contacts", np.nan)
    return row


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--cells", type=int, default=196)
    p.add_argument("--frames", type=int, default=60)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--snr", type=float, nargs="*", default=[4.0, 8.0, 16.0, 32.0])
    p.add_argument("--merge", type=float, nargs="+", default=[0.5, 1.0, 2.0])
    p.add_argument("--out", type=Path, default=Path("/tmp/bench_events"))
    p.add_argument("--result", type=Path, default=ROOT / "benchmarks" / "results_events.md")
    args = p.parse_args(argv)
    t0 = time.time()
    truth = truth_from_vertex_model(n_cells=args.cells, n_frames=args.frames, seed=args.seed, progress=False)
    ev = truth.movie.events
    kinds = ev["kind"].value_counts().to_dict()
    print(f"truth: {len(ev)} T1 events {kinds}, {truth.source['n_t1_flips']} flips, {time.time() - t0:.0f} s",
          flush=True)
    rows = []
    cell_truth = truth_cell_events(truth)
    model = vertex_model_movie(**{k: v for k, v in truth.source.items() if k not in ("kind", "n_t1_flips")})
    missed = None
    for merge in args.merge:
        movie = analyse(truth.labels, truth.box, merge, overlap=False)
        rows.append({"input": "clean labels", "merge_distance": merge, **scores(movie, truth, truth.labels),
                     **cell_scores(movie.tables["neighbour_events"], cell_truth)})
        print(rows[-1], flush=True)
        if merge == ht.MeshOptions().merge_distance:
            missed = misses(movie, truth, model, merge)
            print(missed.to_string(), flush=True)
    for snr in args.snr:
        folder = args.out / f"snr{snr:g}"
        make_benchmark(truth, folder, render=RenderOptions(snr=snr, membrane_width=1), seed=args.seed,
                       progress=False)
        raw = ht.open_source(folder / "raw.tif")
        stack = np.stack([raw.image(t) for t in range(raw.n_frames)])
        labels = segment_movie(stack, sigma=1.0, periodic=True, show_progress=False)
        for merge in args.merge:
            movie = analyse(labels, truth.box, merge, overlap=True)
            rows.append({"input": f"SNR {snr:g}", "merge_distance": merge, **scores(movie, truth, labels)})
            print(rows[-1], flush=True)
    table = pd.DataFrame(rows)
    write(args, truth, kinds, table, time.time() - t0, missed)


def write(args, truth, kinds, table, seconds, missed=None):
    src = truth.source
    lines = [
        "# T1 events against a vertex model's own T1 log (`benchmarks/bench_events.py`)", "",
        f"Generated {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())} on {platform.node() or 'this machine'} "
        f"({os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}), {seconds:.0f} s. Command: "
        f"`PYTHONPATH=$PWD python benchmarks/bench_events.py --cells {args.cells} --frames {args.frames} "
        f"--seed {args.seed} --snr {' '.join(f'{s:g}' for s in args.snr)} "
        f"--merge {' '.join(f'{m:g}' for m in args.merge)}`.", "",
        f"Truth: active vertex model (`hexatissue.benchmark.vertex_model`), {src['n_cells']} cells, periodic "
        f"{truth.box.Lx:g} x {truth.box.Ly:g} px (A0 = {src['cell_area']:.0f} px^2), {src['n_frames']} frames, "
        f"p0 = {src['p0']}, v0 = {src['v0']}, Dr = {src['Dr']}, T1 below {src['t1_length']} px -> new junction "
        f"{src['new_length']} px; {src['n_t1_flips']} flips logged, {sum(kinds.values())} T1 events at frame "
        f"resolution ({', '.join(f'{v} {k}' for k, v in sorted(kinds.items()))}).", "",
        "Prediction: `analyze` with the given `merge_distance` (px), all else default; clean labels keep the ids, "
        "rendered movies (1-px membranes, Gaussian PSF sigma 1 px, Poisson + read noise) are segmented by the "
        "baseline and tracked by overlap. Scores: `hexatissue.benchmark.score`, T1 P / R / kind with frame "
        "tolerance 1 (@1) and 2 (@2), on time by `frame_start` (start) or by the held four-fold interval "
        "`frame_start`..`frame_gain` (held, `t1_timing='held'`); `n_cell_events`: rows of the per-cell "
        "`neighbour_events` table; "
        "`n_held_contacts`: contacts held as four-fold vertices (contact-frames); `n_one_frame_cycles`: predicted "
        "cycles of one frame (`duration` 1), `one_frame_true`: how many of them match a true T1 (held@1).", "",
    ]
    cols = ["input", "merge_distance"] + [f"{n} {t}" for t in ("start@1", "start@2", "held@1") for n in SHOWN[:3]] + [
        "neighbour_pairs_precision", "neighbour_pairs_recall", "n_truth", "n_pred", "n_cell_events", "n_held_contacts",
        "n_one_frame_cycles", "one_frame_true"]
    lines.append("| " + " | ".join(cols) + " |")
    lines.append("|" + "---|" * len(cols))
    for r in table[cols].itertuples(index=False):
        lines.append("| " + " | ".join(f"{v:.3f}" if isinstance(v, float) and not float(v).is_integer()
                                       else str(v) for v in r) + " |")
    cell = table[table["input"] == "clean labels"]
    if "cell_precision@1" in cell:
        lines += ["", f"The paper's per-cell definition (`neighbour_events`: a cell's neighbour list changes), clean "
                      f"labels, against the same definition on the model's exact junctions "
                      f"({int(cell['n_cell_truth'].iloc[0])} true per-cell events); a predicted event matches a true "
                      f"one of the same cell within 1 frame:", "",
                  "| merge_distance | precision | recall | kind |", "|---|---|---|---|"]
        for r in cell.to_dict("records"):
            lines.append(f"| {r['merge_distance']:g} | {r['cell_precision@1']:.3f} | {r['cell_recall@1']:.3f} "
                         f"| {r['cell_kind@1']:.3f} |")
    if missed is not None:
        merge = ht.MeshOptions().merge_distance
        lines += ["", f"The true T1s missed on the clean labels at the default merge distance ({merge:g} px, held@1), "
                      "against the model's exact junctions (`ab_first`: true a-b length in the first frame, px; "
                      "`ab_seen`: a-b ever a contact of the prediction before the loss; `cd_max`: longest true c-d, "
                      "px, up to the undo of a cycle):", "",
                  "| event | kind | frame_start | a-b | c-d | ab_first | ab_seen | cd_max | cause |",
                  "|---|---|---|---|---|---|---|---|---|"]
        for r in missed.itertuples(index=False):
            lines.append(f"| {r[0]} | {r[1]} | {r[2]} | {r[3]} | {r[4]} | {r[5]:.2f} | {r[6]} | {r[7]:.2f} | {r[8]} |")
        if missed.empty:
            lines.append("| none | | | | | | | | |")
    args.result.write_text("\n".join(lines) + "\n")
    print(args.result.read_text())


if __name__ == "__main__":
    main()
