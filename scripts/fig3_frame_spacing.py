"""Fig. 3g at coarser frame spacings: does the spacing of the analysed frames decide the timing trends?

The paper does not state how often it sampled its MPF runs for the event
analysis.  Both event definitions see only what changes between two analysed
frames (a T1 cycle shorter than the spacing is invisible, and two events of a
cell within one spacing merge), so the per-cell intercalation interval and
cycle period can depend on it.  This script re-detects the events of every run
of a sweep on every ``stride``-th frame (frame spacing ``stride * save_every``
iterations) from the junction tables already computed, with the censoring
window held at the same number of iterations, and tabulates the per-cell
timing of both definitions
(:func:`hexatissue.workflows.figure3.timing_vs_frame_spacing`).

Usage::

    python scripts/fig3_frame_spacing.py --sweep fig3 --strides 1 2 4 --out fig3/frame_spacing

Writes ``OUT/frame_spacing.csv`` (one row per run, stride, definition and
quantity: ``D_r``, ``stride``, ``frame_interval`` (iterations), ``definition``,
``quantity``, ``n_cells``, ``mean``, ``q25``, ``median``, ``q75`` (iterations),
``t_pvalue``, ``n_cycles``, ``n_intercalations``) and ``OUT/frame_spacing.png``.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pandas as pd


def plot(table, path, param="D_r"):
    """Mean intercalation interval (solid) and cycle period (dashed) against the parameter, per spacing."""
    from matplotlib.figure import Figure
    from matplotlib.ticker import NullFormatter

    from hexatissue.plot import save_figure

    definitions = list(dict.fromkeys(table["definition"]))
    fig = Figure(figsize=(5 * len(definitions), 4), layout="constrained")
    axes = [fig.add_subplot(1, len(definitions), k + 1) for k in range(len(definitions))]
    for ax, definition in zip(axes, definitions):
        t = table[table["definition"] == definition]
        for k, (spacing, g) in enumerate(t.groupby("frame_interval")):
            for quantity, style in (("intercalation_interval", "-o"), ("cycle_period", "--s")):
                q = g[g["quantity"] == quantity].sort_values(param)
                ax.plot(q[param], q["mean"], style, color=f"C{k}",
                        label=f"{quantity.replace('_', ' ')}, frames every {spacing:g}")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ticks = np.unique(t[param].to_numpy(float))  # label the swept values only (minor labels overlap)
        ax.set_xticks(ticks, [f"{v:g}" for v in ticks])
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_xlabel(param)
        ax.set_ylabel("per-cell mean (iterations)")
        ax.set_title(definition, fontsize=10)
        ax.legend(frameon=False, fontsize=7)
    save_figure(fig, path, dpi=110)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sweep", required=True, help="sweep folder (its sweep.csv lists the runs)")
    ap.add_argument("--strides", type=int, nargs="+", default=[1, 2, 4], help="keep every k-th frame")
    ap.add_argument("--out", required=True)
    args = ap.parse_args(argv)
    from hexatissue.errors import InputError
    from hexatissue.io import write_table
    from hexatissue.workflows import timing_vs_frame_spacing

    sweep = pd.read_csv(Path(args.sweep) / "sweep.csv")
    param = str(sweep["param"].iloc[0])
    try:
        table = timing_vs_frame_spacing(dict(zip(sweep["value"], sweep["results"])), args.strides, param=param)
    except InputError as exc:  # a bad stride or run folder: a message, not a traceback
        ap.error(str(exc))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    write_table(table, out / "frame_spacing.csv")
    plot(table, out / "frame_spacing.png", param=param)
    print(table.to_string(index=False))
    return 0


if __name__ == "__main__":
    sys.exit(main())
