"""Scores of the baseline pipeline against exact truth, over SNR and membrane width (docs/benchmark.md).

    PYTHONPATH=$PWD python scripts/benchmark_snr.py --out /tmp/bench_snr [--frames 150]
        [--snr 2 4 8 16 32] [--width 1 2 3]

The truth is the bundled MPF run (hexatissue/sample_data/mpf_small: 60 cells in a periodic 140 x 151 px box,
one frame every 200 iterations), its first FRAMES frames.  For every (SNR, membrane width) the movie
is rendered (`benchmark make`, Gaussian PSF sigma 1 px, default noise model), segmented with the
baseline (`benchmark baseline --periodic`), analysed (`analyze`, periodic box, overlap tracking) and
scored (`benchmark score`).  Writes OUT/scores.csv (one row per setting, every score),
OUT/scores_vs_snr.png and OUT/frames.png (rendered frames beside the truth and the baseline's labels).
Each setting's folders stay in OUT/snr{S}_w{W}/; a setting whose scores.json exists is not redone.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import hexatissue as ht  # noqa: E402
from hexatissue.benchmark import (RenderOptions, make_benchmark, score, score_to_folder,  # noqa: E402
                                  segment_movie, truth_from_run)
from hexatissue.io import write_tiff  # noqa: E402
from hexatissue.plot import plot_labels, save_figure  # noqa: E402

RUN = ROOT / "hexatissue" / "sample_data" / "mpf_small" / "run.zarr"
SHOWN = ("seg_jaccard", "neighbour_pairs_recall", "vertex_recall", "link_recall", "t1_recall",
         "t1_right_kind")


def one_setting(truth, folder: Path, snr: float, width: int) -> dict:
    done = folder / "score" / "scores.json"
    if not done.exists():
        make_benchmark(truth, folder, render=RenderOptions(snr=snr, membrane_width=width), seed=0, progress=False)
        raw = ht.open_source(folder / "raw.tif")
        stack = np.stack([raw.image(t) for t in range(raw.n_frames)])
        labels = segment_movie(stack, sigma=max(1.0, width / 2), periodic=True, show_progress=False)
        write_tiff(folder / "baseline.tif", labels, raw.calibration)
        movie = ht.analyze(ht.open_source(folder / "baseline.tif"), box=truth.box, workers=1, progress=False)
        movie.write(folder / "pred")
        score_to_folder(score(folder / "pred", folder / "truth", show_progress=False), folder / "score")
    scores = json.loads(done.read_text())
    # T1 events recovered with the right kind: matched (recall) and of the truth's kind
    if "t1_recall" in scores and "t1_kind_accuracy" in scores:
        scores["t1_right_kind"] = scores["t1_recall"] * scores["t1_kind_accuracy"]
    return {"snr": snr, "membrane_width": width, **scores}


def plot_scores(table: pd.DataFrame, out: Path) -> None:
    from matplotlib.figure import Figure

    widths = sorted(table["membrane_width"].unique())
    fig = Figure(figsize=(4 * len(widths), 3.6), dpi=110, layout="constrained")
    axes = np.atleast_1d(fig.subplots(1, len(widths), sharey=True))
    for ax, w in zip(axes, widths):
        part = table[table["membrane_width"] == w].sort_values("snr")
        for name in SHOWN:
            if name in part:
                ax.plot(part["snr"], part[name], marker="o", label=name)
        ax.set_xscale("log", base=2)
        ax.set_xlabel("SNR (membrane contrast / noise std)")
        ax.set_title(f"membrane width {w} px")
        ax.set_ylim(0, 1.02)
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("score (1 = perfect)")
    axes[-1].legend(fontsize=7, loc="lower right")
    save_figure(fig, out)


def plot_frames(truth, out_dir: Path, settings, out: Path) -> None:
    from matplotlib.figure import Figure

    fig = Figure(figsize=(3.2 * (len(settings) + 1), 6.4), dpi=100, layout="constrained")
    axes = fig.subplots(2, len(settings) + 1)
    plot_labels(labels=truth.labels[0], polygons=truth.movie.polygons(0), box=truth.box, ax=axes[0, 0])
    axes[0, 0].set_title("truth (frame 0)", fontsize=9)
    axes[1, 0].axis("off")
    for k, (snr, width) in enumerate(settings, start=1):
        folder = out_dir / f"snr{snr:g}_w{width}"
        raw = ht.open_source(folder / "raw.tif")
        plot_labels(image=raw.image(0), ax=axes[0, k])
        axes[0, k].set_title(f"rendered: SNR {snr:g}, {width} px", fontsize=9)
        pred = ht.open_source(folder / "baseline.tif")
        plot_labels(labels=pred.frame(0), ax=axes[1, k])
        axes[1, k].set_title("baseline segmentation", fontsize=9)
    save_figure(fig, out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("--frames", type=int, default=150)
    ap.add_argument("--snr", type=float, nargs="+", default=[2, 4, 8, 16, 32])
    ap.add_argument("--width", type=int, nargs="+", default=[1, 2, 3])
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    truth = truth_from_run(RUN, frames=slice(0, args.frames), progress=False)
    rows = []
    for width in args.width:
        for snr in args.snr:
            rows.append(one_setting(truth, out / f"snr{snr:g}_w{width}", snr, width))
            print({k: (round(v, 4) if isinstance(v, float) else v) for k, v in rows[-1].items()}, flush=True)
    table = pd.DataFrame(rows)
    table.to_csv(out / "scores.csv", index=False)
    plot_scores(table, out / "scores_vs_snr.png")
    shown = [(min(args.snr), min(args.width)), (sorted(args.snr)[len(args.snr) // 2], args.width[len(args.width) // 2]),
             (max(args.snr), max(args.width))]
    plot_frames(truth, out, shown, out / "frames.png")
    print(out / "scores.csv")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
