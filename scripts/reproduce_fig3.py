"""Reproduce the paper's Fig. 3e–g: an MPF sweep over the rotational diffusion D_r, analysed end to end.

Usage::

    python scripts/reproduce_fig3.py --out fig3              # reduced settings (~25 min, 2 idle cores)
    python scripts/reproduce_fig3.py --out fig3 --param v0=0.0015   # any simulation parameter changed
    python scripts/reproduce_fig3.py --out fig3 --paper      # the paper's settings (days; use a cluster)
    python scripts/reproduce_fig3.py --out fig3 --tiny       # smoke test (a few minutes)
    python scripts/reproduce_fig3.py --out fig3 --scheduler tcp://host:8786   # runs on a dask cluster

Every stage resumes: run the same command again after an interruption.
Outputs in OUT: one folder per D_r value (run.zarr, results/, done.json),
sweep.csv, and from :func:`hexatissue.analysis.figure3` the Fig. 3e/3f/3g
PNGs, their tables (CSV) and summary.json.

Settings (``--paper`` / default reduced / ``--tiny``):

=================  ==========================  ==========================  ===================
setting            paper                       reduced (default)           tiny (smoke test)
=================  ==========================  ==========================  ===================
cells, box (px)    440, 384 x 403              100, 183 x 192              16, 74 x 77
D_r                1e-6 2e-6 5e-6 1e-5 2e-5    1e-5 2e-5 4e-5 8e-5         2e-5 8e-5
                   4e-5 8e-5
relax, steps       10,000, 2,000,000           10,000, 300,000             1,000, 6,000
save_every         1,000 (window = 25 frames)  500 (window = 50 frames)    100 (window = 10 frames)
=================  ==========================  ==========================  ===================

The reduced box keeps the paper's area per cell (384 * 403 / 440 = 352 px^2)
and aspect ratio.  The migration window is the paper's 25,000 iterations in
every preset except ``--tiny`` (1,000 iterations).  Time estimate of the
reduced preset on the idle 2-core development machine: 100 cells ran at about
670 steps/s per process with central advection; the default upwind3 advection
costs about 1.6x per step, so each 310,000-step run takes about 12 minutes and
the four runs about 25 minutes, analysis included.
"""
from __future__ import annotations

import argparse
import sys
import time

PRESETS = {
    "paper": dict(n_cells=440, Lx=384, Ly=403, values=[1e-6, 2e-6, 5e-6, 1e-5, 2e-5, 4e-5, 8e-5], relax=10_000,
                  steps=2_000_000, save_every=1_000, window_iterations=25_000, patch=55),
    "reduced": dict(n_cells=100, Lx=183, Ly=192, values=[1e-5, 2e-5, 4e-5, 8e-5], relax=10_000, steps=300_000,
                    save_every=500, window_iterations=25_000, patch=55),
    "tiny": dict(n_cells=16, Lx=74, Ly=77, values=[2e-5, 8e-5], relax=1_000, steps=6_000, save_every=100,
                 window_iterations=1_000, patch=41),
}


def parse(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", required=True, help="sweep and figure folder")
    group = ap.add_mutually_exclusive_group()
    group.add_argument("--paper", action="store_true", help="the paper's settings (440 cells, 384 x 403, 7 D_r values)")
    group.add_argument("--tiny", action="store_true", help="a smoke test of a few minutes")
    ap.add_argument("--values", type=float, nargs="+", help="D_r values (override the preset)")
    ap.add_argument("--steps", type=int, help="active steps per run (override the preset)")
    ap.add_argument("--relax", type=int, help="passive relaxation steps (override the preset)")
    ap.add_argument("--save-every", type=int, help="steps between saved frames (override the preset)")
    ap.add_argument("--window", type=int, help="migration window in iterations (override the preset's 25,000)")
    ap.add_argument("--workers", type=int, default=None,
                    help="local processes (default: one per run, at most the cores)")
    ap.add_argument("--scheduler", help="dask.distributed scheduler address (instead of local processes)")
    ap.add_argument("--threads", default=1, type=int, help="numba threads per simulation (default 1)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                    help="override a simulation parameter of the preset, e.g. --param v0=0.0015 (repeatable)")
    ap.add_argument("--min-length", type=float, default=0.0,
                    help="contacts shorter than this (px) count as four-fold vertices in T1 detection")
    ap.add_argument("--control", choices=["cells", "vertices"], nargs="+", default=["cells", "vertices"],
                    help="Fig. 3e control(s) of the quartet T1s: random cells (the paper's) and/or random vertices "
                         "(junction level); the first is fig3e.png (default: both, cells first)")
    ap.add_argument("--include-border", action="store_true",
                    help="keep cells next to unassigned gaps (flagged is_border) in the Fig. 3e/3f statistics")
    ap.add_argument("--censor", type=int, default=None,
                    help="right-censoring window for T1s, frames (default: one migration window)")
    return ap.parse_args(argv)


def parse_overrides(items):
    """``["v0=0.0015", "M=0.5"]`` -> ``{"v0": 0.0015, "M": 0.5}`` (numbers as int or float)."""
    out = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep or not name:
            raise SystemExit(f"--param expects NAME=VALUE, got {item!r}")
        try:
            out[name.strip()] = int(value) if value.strip().lstrip("-").isdigit() else float(value)
        except ValueError:
            out[name.strip()] = value.strip()  # e.g. dtype=float64
    return out


def main(argv=None):
    import pandas as pd

    from hexatissue import EventOptions
    from hexatissue.analysis import frames_per_window
    from hexatissue.workflows import figure3, sweep
    from hexatissue.simulate import Params

    args = parse(argv)
    name = "paper" if args.paper else "tiny" if args.tiny else "reduced"
    cfg = dict(PRESETS[name])
    if args.values:
        cfg["values"] = args.values
    for key, value in (("steps", args.steps), ("relax", args.relax), ("save_every", args.save_every),
                       ("window_iterations", args.window)):
        if value:
            cfg[key] = value
    window = frames_per_window(cfg["window_iterations"], cfg["save_every"])
    censor = window if args.censor is None else args.censor
    # long active runs stretch cells: 41 px patches leak >10 % of a field at their rim; 55 px do not
    base = Params.from_dict({"n_cells": cfg["n_cells"], "Lx": cfg["Lx"], "Ly": cfg["Ly"], "patch": cfg["patch"],
                             **parse_overrides(args.param)})
    client = None
    if args.scheduler:
        from distributed import Client

        client = Client(args.scheduler)
    print(f"parameters: {base.to_dict()}", flush=True)
    print(f"preset {name}: {cfg['n_cells']} cells in {cfg['Lx']} x {cfg['Ly']} px, D_r = {cfg['values']}, "
          f"relax {cfg['relax']}, {cfg['steps']} steps, a frame every {cfg['save_every']} steps, "
          f"window {window} frames", flush=True)
    start = time.perf_counter()
    table = sweep("dr", cfg["values"], args.out, params=base, steps=cfg["steps"], save_every=cfg["save_every"],
                  relax=cfg["relax"], seed=args.seed, client=client, workers=args.workers, threads=args.threads,
                  events=EventOptions(min_length=args.min_length, censor=censor))
    table.to_csv(f"{args.out}/sweep.csv", index=False)
    summary = figure3(table, args.out, param="D_r", dt=window, seed=args.seed, include_border=args.include_border,
                      control=args.control)
    f = summary["fig3f"]
    print(f"done in {time.perf_counter() - start:.0f} s; statuses {table['status'].value_counts().to_dict()}")
    for key, e in summary.items():
        if key.startswith("fig3e"):
            pooled = e["pooled"]
            print(f"Fig. 3e ({e['definition']} events vs random {e['control']}): {pooled['n_events']} events, "
                  f"median distance to a defect {pooled['median_dr_events']:.3g} px vs "
                  f"{pooled['median_dr_control']:.3g} px; KS p = {pooled['ks_pvalue']:.3g} "
                  f"(one-sided, events closer: {pooled['ks_pvalue_closer']:.3g})")
    print(f"Fig. 3f: {f['n_subregion_windows']} subregion-windows; delta BIC (two vs one population) "
          f"{f['delta_bic']:.3g} ({f['verdict']}); Spearman rho(displacement, defect density) = {f['spearman_rho']:.3g}")
    for definition, trends in summary["trends"].items():
        print(f"Fig. 3g ({definition}): log-log slope vs D_r of the intercalation interval "
              f"{trends['intercalation_interval_loglog_slope']:.3g}, of the T1-cycle period "
              f"{trends['cycle_period_loglog_slope']:.3g}")
    print(pd.DataFrame(summary["fig3g"]).to_string(index=False))
    return 0


if __name__ == "__main__":
    from hexatissue.errors import InputError

    try:
        sys.exit(main())
    except InputError as exc:
        sys.exit(f"error: {exc}")
