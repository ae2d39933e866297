"""Audit of the T1s found at default settings on real movies: each T1's geometry, and crops to look at.

For each movie (ITASC pos00, the EpiTools wing disc, the bundled EpiCure notum) the script runs ``analyze``
with the default options (ids kept) and, when ``--old`` names a checkout of an earlier commit, the same
analysis with that code (a subprocess with the checkout first on ``PYTHONPATH``); the T1s found now and not
before are the ones audited (every T1 when none is new or without ``--old``), and so is every cycle of
one frame (``duration`` 1: a-b lost and c-d gained in one frame, undone in the next).  With each
``--min-length`` it also counts which audited T1s a junction-length threshold keeps.  For each audited
T1 it measures, from the ``edges`` and ``cells`` tables:

- ``ab_before``: the a-b contact's length (px) in the frame before ``frame_start``;
- ``cd_after``: the c-d contact's length in the frame of ``frame_gain``, and ``cd_frames``: the
  frames c-d stays in contact from ``frame_gain`` on (to the movie's end);
- ``ab_4fold``/``cd_4fold``: whether the a-b junction (before the loss) / the c-d junction (at the gain)
  ends at a vertex of four or more cells (a four-fold vertex next to the exchange);
- ``area_jump``: the largest frame-to-frame area ratio of the four cells between the frame before the loss
  and the frame after the gain (segmentation jitter).

and draws a crop of the labels around the quartet (frames before/at the loss, at/after the gain; a, b red,
c, d blue) into ``--crops``.  The classes read by eye from the crops (real exchange, four-fold vertex
flicker, segmentation error, tracking error) are kept in ``benchmarks/data/t1_audit_labels.csv`` and
counted here with the measured geometry of each class.  Writes ``benchmarks/results_t1_audit.md``.  Usage::

    git worktree add /tmp/old 29a5bbb
    PYTHONPATH=$PWD python benchmarks/t1_audit_real.py --old /tmp/old [--crops /tmp/t1_crops]
"""
from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import hexatissue as ht  # noqa: E402
from hexatissue.errors import HexatissueWarning  # noqa: E402
from hexatissue.samples import sample_path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _timing import REAL_DATA  # noqa: E402

LABELS = Path(__file__).resolve().parent / "data" / "t1_audit_labels.csv"
MOVIES = {
    "itasc_pos00": (REAL_DATA / "itasc_micropattern" / "pos00" / "cell_labels.tif", None),
    "epitools_wingdisc": (REAL_DATA / "epitools_wingdisc" / "SegResults_CLabels_RegIm_TYX.npz", "CLabels"),
    "epicure_notum": (sample_path("epicure_notum"), None),
}
RUN = """
import sys, warnings
import hexatissue as ht
warnings.simplefilter("ignore")
src = ht.open_source(sys.argv[1], key=sys.argv[2] or None)
ht.analyze(src, workers=1, progress=False, events=ht.EventOptions(min_length=float(sys.argv[4]))).write(sys.argv[3])
"""


def analyse(path, key, out, tree=None, min_length=0.0):
    """The default analysis of ``path`` by the code in ``tree`` (None: this tree), written to ``out``
    (``min_length``: ``EventOptions.min_length``, px)."""
    env = dict(os.environ, PYTHONPATH=str(tree or ROOT), HEXATISSUE_PROGRESS="0")
    subprocess.run([sys.executable, "-c", RUN, str(path), key or "", str(out), str(min_length)], env=env, check=True,
                   cwd=tree or ROOT)  # "-c" puts the working directory first on the path
    return ht.read_results(out)


def event_key(r):
    """A T1 as (frame_start, frame_gain, a-b, c-d), each pair sorted: the same event in two analyses."""
    return (int(r.frame_start), int(r.frame_gain), tuple(sorted((int(r.cell_a), int(r.cell_b)))),
            tuple(sorted((int(r.cell_c), int(r.cell_d)))))


class Geometry:
    """Contacts (length by track pair) and the track sets around held vertices, per frame."""

    def __init__(self, movie):
        cells, edges, vertices = movie.cells, movie.edges, movie.vertices
        track = {(int(f), int(c)): int(t) for f, c, t in zip(cells["frame"], cells["cell"], cells["track"])}
        self.area = {(int(f), int(t)): float(a) for f, t, a in zip(cells["frame"], cells["track"], cells["area"])}
        self.n_frames = int(cells["frame"].max()) + 1
        self.length, self.around = {}, {}
        for f, a, b, va, vb, ln in zip(edges["frame"], edges["cell_a"], edges["cell_b"], edges["vertex_a"],
                                       edges["vertex_b"], edges["length"]):
            f = int(f)
            ta, tb = track.get((f, int(a)), -int(a)), track.get((f, int(b)), -int(b))
            pair = (f, min(ta, tb), max(ta, tb))
            self.length[pair] = self.length.get(pair, 0.0) + float(ln)
            for v in (int(va), int(vb)):
                self.around.setdefault((f, v), set()).update((ta, tb))
        self.held = {}
        for (f, v), ts in self.around.items():
            if len(ts) >= 4:
                self.held.setdefault(f, []).append(ts)

    def contact(self, f, a, b):
        return self.length.get((f, min(a, b), max(a, b)), 0.0)

    def held_pair(self, f, a, b):
        return any(a in ts and b in ts for ts in self.held.get(f, ()))

    def features(self, r):
        a, b, c, d = (int(r.cell_a), int(r.cell_b), int(r.cell_c), int(r.cell_d))
        s, g = int(r.frame_start), int(r.frame_gain)
        cd_frames = 0
        for f in range(g, self.n_frames):
            if self.contact(f, c, d) <= 0:
                break
            cd_frames += 1
        jumps = []
        for f in range(max(s - 1, 0), min(g + 1, self.n_frames - 1)):
            for t in (a, b, c, d):
                x, y = self.area.get((f, t)), self.area.get((f + 1, t))
                if x and y:
                    jumps.append(max(x, y) / min(x, y))
        return {"ab_before": self.contact(s - 1, a, b), "cd_after": self.contact(g, c, d), "cd_frames": cd_frames,
                "ab_4fold": self.held_pair(s - 1, a, b), "cd_4fold": self.held_pair(g, c, d),
                "area_jump": max(jumps) if jumps else np.nan}


def crops(labels, movie, events, folder, name, half=28):
    """One PNG per T1: the labels around its quartet at frame_start-1, frame_start, frame_gain, frame_gain+1."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from skimage.segmentation import find_boundaries

    cells = movie.cells
    label_of = {(int(f), int(t)): int(c) for f, c, t in zip(cells["frame"], cells["cell"], cells["track"])}
    folder.mkdir(parents=True, exist_ok=True)
    n = labels.shape[0]
    for r in events.itertuples():
        s, g = int(r.frame_start), int(r.frame_gain)
        frames = [max(s - 1, 0), s, g, min(g + 1, n - 1)]
        x0, y0 = int(round(r.x)) - half, int(round(r.y)) - half
        fig, axes = plt.subplots(1, 4, figsize=(8, 2.3))
        for ax, f in zip(axes, frames):
            lab = labels[f]
            sl = (slice(max(y0, 0), y0 + 2 * half), slice(max(x0, 0), x0 + 2 * half))
            crop = lab[sl]
            rgb = np.full(crop.shape + (3,), 0.85)
            for t, col in ((r.cell_a, (1, .3, .3)), (r.cell_b, (.8, .1, .1)), (r.cell_c, (.4, .6, 1)),
                           (r.cell_d, (.1, .2, .8))):
                lbl = label_of.get((f, int(t)))
                if lbl is not None:
                    rgb[crop == lbl] = col
            rgb[crop == 0] = 1.0
            rgb[find_boundaries(crop, mode="inner")] = 0.0
            ax.imshow(rgb, interpolation="nearest")
            ax.set_title(f"t={f}", fontsize=8)
            ax.axis("off")
        fig.suptitle(f"{name} event {int(r.event)}: a-b {int(r.cell_a)}-{int(r.cell_b)} (red) -> c-d "
                     f"{int(r.cell_c)}-{int(r.cell_d)} (blue), start {s}, gain {g}", fontsize=8)
        fig.savefig(folder / f"{name}_{int(r.event):03d}.png", dpi=90, bbox_inches="tight")
        plt.close(fig)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--old", type=Path, help="a checkout of the earlier code; without it every T1 is audited")
    p.add_argument("--crops", type=Path, help="folder for the crops (PNG), none when absent")
    p.add_argument("--min-length", type=float, nargs="*", default=[4.0],
                   help="EventOptions.min_length values (px) whose T1s are compared with the audited ones")
    p.add_argument("--result", type=Path, default=ROOT / "benchmarks" / "results_t1_audit.md")
    args = p.parse_args(argv)
    warnings.simplefilter("ignore", HexatissueWarning)
    t0 = time.time()
    by_eye = pd.read_csv(LABELS) if LABELS.exists() else pd.DataFrame(columns=["movie", "key", "class"])
    by_eye = {(m, k): c for m, k, c in zip(by_eye["movie"], by_eye["key"], by_eye["class"])}
    rows, counts, threshold = [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        for name, (path, key) in MOVIES.items():
            if not Path(path).exists():
                print(f"{name}: {path} absent, skipped")
                continue
            movie = analyse(path, key, Path(tmp) / f"new_{name}")
            ev = movie.events
            old = analyse(path, key, Path(tmp) / f"old_{name}", args.old).events if args.old else ev.iloc[:0]
            old_keys = {event_key(r) for r in old.itertuples()}
            new = ev[np.array([event_key(r) not in old_keys for r in ev.itertuples()], bool)]
            counts.append({"movie": name, "T1s": len(ev), "before": len(old) if args.old else np.nan,
                           "new": len(new) if args.old else np.nan,
                           "gone": len(old_keys - {event_key(r) for r in ev.itertuples()}) if args.old else np.nan})
            audited = new if args.old and len(new) else ev
            one_frame = (ev["kind"] == "cycle") & (ev["duration"] == 1)
            audited = ev[ev["event"].isin(audited["event"]) | one_frame]
            counts[-1].update(one_frame=int(one_frame.sum()), one_frame_new=int(one_frame[new.index].sum()))
            geo = Geometry(movie)
            new_events = set(new["event"].tolist()) if args.old and len(new) else set()
            for r in audited.itertuples():
                k = "{}:{}:{}-{}:{}-{}".format(int(r.frame_start), int(r.frame_gain), *event_key(r)[2], *event_key(r)[3])
                rows.append({"movie": name, "event": int(r.event), "key": k, "new": int(r.event) in new_events,
                             "kind": r.kind,
                             "is_border": bool(r.is_border), "consecutive": int(r.frame_gain) == int(r.frame_start),
                             "one_frame": r.kind == "cycle" and r.duration == 1,
                             **geo.features(r), "class": by_eye.get((name, k), "not examined")})
            for min_length in args.min_length:  # what a junction-length threshold keeps of each class
                other = analyse(path, key, Path(tmp) / f"min_{name}_{min_length:g}", min_length=min_length).events
                keys = {event_key(r) for r in other.itertuples()}
                kept = [event_key(r) in keys for r in audited.itertuples()]
                classes = [by_eye.get((name, row["key"]), "not examined") for row in rows[len(rows) - len(audited):]]
                threshold.append({"movie": name, "min_length": min_length, "T1s": len(other),
                                  "one_frame": int(((other["kind"] == "cycle") & (other["duration"] == 1)).sum()) if len(other) else 0,
                                  **{c: f"{sum(k for k, x in zip(kept, classes) if x == c)} / {classes.count(c)}"
                                     for c in sorted(set(classes))}})
            if args.crops is not None and len(audited):
                src = ht.open_source(path, key=key)
                labels = np.stack([src.frame(t) for t in range(src.n_frames)])
                crops(labels, movie, audited, args.crops, name)
    table = pd.DataFrame(rows)
    write(args, pd.DataFrame(counts), table, time.time() - t0, pd.DataFrame(threshold))
    return table


def write(args, counts, table, seconds, threshold):
    lines = ["# T1s at default settings on real movies, audited (`benchmarks/t1_audit_real.py`)", "",
             f"Generated {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())} on {platform.node() or 'this machine'} "
             f"({os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}), {seconds:.0f} s. Command: "
             f"`PYTHONPATH=$PWD python benchmarks/t1_audit_real.py"
             f"{' --old CHECKOUT' if args.old else ''}`"
             f"{' (CHECKOUT: the code before the held flanks, 29a5bbb)' if args.old else ''}.", "",
             "T1s found at default settings (ids kept); `new`: not found by the earlier code, `gone`: found by it "
             "and no longer; audited: the new T1s (every T1 when none is new) and every cycle of 1 frame:", "", "| movie | T1s | before | new | gone | cycles of 1 frame (new) |", "|---|---|---|---|---|---|"]
    for r in counts.itertuples():
        lines.append(f"| {r.movie} | {r.T1s} | " + " | ".join("" if pd.isna(v) else str(int(v))
                                                              for v in (r.before, r.new, r.gone))
                     + f" | {r.one_frame} ({r.one_frame_new}) |")
    if len(table):
        lines += ["", "Audited T1s by class (new: not found by the earlier code; read by eye from the crops; `benchmarks/data/t1_audit_labels.csv`), with "
                  "the median a-b length before the loss and c-d length at the gain (px), the frames c-d lasts, "
                  "and how many have their a-b / c-d junction ending at a vertex of four or more cells, are exchanges "
                  "between two consecutive frames, touch a border cell, and are cycles of 1 frame:", "",
                  "| movie | new | class | n | ab_before | cd_after | cd_frames | ab_4fold | cd_4fold | consecutive | border "
                  "| cycle of 1 frame |", "|---|---|---|---|---|---|---|---|---|---|---|---|"]
        for (movie, is_new, cls), g in table.groupby(["movie", "new", "class"], sort=False):
            lines.append(f"| {movie} | {'new' if is_new else 'before too'} | {cls} | {len(g)} | {g['ab_before'].median():.1f} | "
                         f"{g['cd_after'].median():.1f} | {g['cd_frames'].median():.0f} | {int(g['ab_4fold'].sum())} | "
                         f"{int(g['cd_4fold'].sum())} | {int(g['consecutive'].sum())} | {int(g['is_border'].sum())} | "
                         f"{int(g['one_frame'].sum())} |")
        if len(threshold):
            cols = [c for c in threshold.columns if c not in ("movie", "min_length", "T1s", "one_frame")]
            lines += ["", "With `min_length` (px, `EventOptions`): the T1s, the cycles of 1 frame, and of the audited "
                      "T1s of each class how many are found again (same quartet, loss and gain frames):", "",
                      "| movie | min_length | T1s | cycles of 1 frame | " + " | ".join(cols) + " |",
                      "|" + "---|" * (4 + len(cols))]
            for r in threshold.to_dict("records"):
                lines.append(f"| {r['movie']} | {r['min_length']:g} | {r['T1s']} | {r['one_frame']} | "
                             + " | ".join("" if pd.isna(r[c]) else str(r[c]) for c in cols) + " |")
        lines += ["", "Every audited T1:", "", "| movie | event | key (start:gain:a-b:c-d) | kind | ab_before | "
                  "cd_after | cd_frames | ab_4fold | cd_4fold | area_jump | border | class |", "|" + "---|" * 12]
        for r in table.itertuples():
            lines.append(f"| {r.movie} | {r.event} | {r.key} | {r.kind} | {r.ab_before:.1f} | {r.cd_after:.1f} | "
                         f"{r.cd_frames} | {r.ab_4fold} | {r.cd_4fold} | {r.area_jump:.2f} | {r.is_border} | "
                         f"{r[-1]} |")
    args.result.write_text("\n".join(lines) + "\n")
    print(args.result.read_text())


if __name__ == "__main__":
    main()
