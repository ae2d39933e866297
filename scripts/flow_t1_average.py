"""The flow averaged around T1 cycles and intercalations of MPF runs, its angular harmonics with error bars.

For each run (an MPF store, or a results folder already analysed): ``hexatissue.analyze``, then
``hexatissue.flow.t1_flow`` at the given offsets and ``angular_harmonics`` of the relative velocity between
R_cell and 4 R_cell.  Error bars: bootstrap over events (resampled with replacement, 200 times): the standard
deviation of each harmonic's amplitude.  Noise floor: the same harmonics with every event's axes turned by a
random angle (the events' alignment destroyed, 200 times): a harmonic is resolved where its amplitude exceeds
the 95th percentile of that floor.  The theory is the quadrupole's Stokes flow, ``hexatissue.theory.quadrupole_flow_exact``,
sampled at 2-4 ell.  ``--replot`` redraws ``t1_harmonics.png`` from the saved ``t1_harmonics.csv`` (no run needed).
Writes ``<out>/<name>_t1_flow.png`` (maps), ``<out>/t1_harmonics.png`` and ``<out>/t1_harmonics.csv``.

    NUMBA_NUM_THREADS=1 python scripts/flow_t1_average.py hexatissue/sample_data/mpf_small/run.zarr RUN2.zarr --out docs/figures
"""
import argparse
from pathlib import Path

import numpy as np
import pandas as pd

import hexatissue
from hexatissue.flow import angular_harmonics, t1_flow
from hexatissue.results import read_results
from hexatissue.theory import quadrupole_flow_exact
from hexatissue.views.flow import plot_event_flow

N_MAX = 8


def movie_of(path, cache):
    path = Path(path)
    if (path / "metadata.json").exists():
        return read_results(path)
    folder = Path(cache) / (path.parent.name + "_" + path.stem)
    if (folder / "metadata.json").exists():
        return read_results(folder)
    from hexatissue.simulate import read_run
    movie = hexatissue.analyze(read_run(path), workers=1, progress=False)
    movie.write(folder)
    return movie


def harmonics(samples, r_min, r_max, column="radial_amplitude"):
    h = angular_harmonics(samples, r_min=r_min, r_max=r_max, max_harmonic=N_MAX)
    return h.set_index(["kind", "offset", "n"])[column]


def turned(samples, angles):
    """The samples with each event's axes turned by ``angles[event]``."""
    a = angles[samples["event"].to_numpy()]
    c, s = np.cos(a), np.sin(a)
    x, y, u, v = (samples[k].to_numpy(float) for k in ("x", "y", "vx", "vy"))
    return samples.assign(x=c * x - s * y, y=s * x + c * y, vx=c * u - s * v, vy=s * u + c * v)


def resampled(samples, rng):
    """Bootstrap: events of each kind and offset drawn with replacement (each drawn copy a new event id)."""
    parts = []
    for _, group in samples.groupby(["kind", "offset"]):
        events = group["event"].unique()
        pick = rng.choice(events, len(events))
        by_event = {e: g for e, g in group.groupby("event")}
        parts += [by_event[e] for e in pick]
    return pd.concat(parts, ignore_index=True)


def theory_shares():
    r, phi = np.meshgrid(np.linspace(2.0, 4.0, 9), np.linspace(-np.pi, np.pi, 97)[:-1])
    x, y = (r * np.cos(phi)).ravel(), (r * np.sin(phi)).ravel()
    vx, vy = quadrupole_flow_exact(x, y, 1.0, 1.0)
    h = angular_harmonics(pd.DataFrame({"kind": "theory", "offset": 0, "x": x, "y": y, "vx": vx, "vy": vy}),
                          max_harmonic=N_MAX)
    amp = h["radial_amplitude"].to_numpy()
    return amp / amp[1:].sum(), h


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="*")
    ap.add_argument("--replot", action="store_true", help="redraw t1_harmonics.png from <out>/t1_harmonics.csv")
    ap.add_argument("--out", default="docs/figures")
    ap.add_argument("--cache", default="/tmp/flow_t1_average")
    ap.add_argument("--offsets", type=int, nargs="+", default=[-4, 0, 4])
    ap.add_argument("--repeats", type=int, default=200)
    args = ap.parse_args()
    out = Path(args.out)
    if args.replot:
        plot(pd.read_csv(out / "t1_harmonics.csv"), theory_shares()[0], out / "t1_harmonics.png")
        return
    if not args.runs:
        ap.error("give the runs to analyse, or --replot")
    rng = np.random.default_rng(0)
    rows = []
    for path in args.runs:
        movie = movie_of(path, args.cache)
        name = Path(path).name if Path(path).suffix != ".zarr" else (Path(path).stem if Path(path).stem != "run" else Path(path).parent.name)
        cells = movie.cells
        r_cell = float(np.sqrt(np.nanmean(cells["area"].to_numpy(float)) / np.pi))
        average, samples = t1_flow(cells, movie.events, movie.box, offsets=args.offsets)
        plot_event_flow(average, path=out / f"{name}_t1_flow.png", calibration=movie.calibration,
                        title=f"{name}: mean flow around T1s, relative to the quartet")
        r_max = 4 * r_cell
        observed = harmonics(samples, r_cell, r_max)
        signed = {c: harmonics(samples, r_cell, r_max, c) for c in ("radial_cos", "radial_sin")}
        boot = pd.concat([harmonics(resampled(samples, rng), r_cell, r_max) for _ in range(args.repeats)], axis=1)
        n_ev = int(samples["event"].max()) + 1
        null = pd.concat([harmonics(turned(samples, rng.uniform(0, 2 * np.pi, n_ev)), r_cell, r_max)
                          for _ in range(args.repeats)], axis=1)
        counts = samples.groupby(["kind", "offset"])["event"].nunique()
        speed = float(np.sqrt(np.nanmean(cells["vx"] ** 2 + cells["vy"] ** 2)))
        for key, amp in observed.items():
            rows.append({"run": name, "kind": key[0], "offset": key[1], "n": key[2], "events": counts[key[:2]],
                         "amplitude": amp, "cos": signed["radial_cos"][key], "sin": signed["radial_sin"][key], "sd": boot.loc[key].std(), "floor95": np.percentile(null.loc[key], 95),
                         "rms_speed": speed, "frames": int(cells["frame"].max()) + 1,
                         "cells": int(len(cells) / (cells["frame"].max() + 1))})
        print(name, dict(counts), f"R_cell {r_cell:.1f} px, rms speed {speed:.4f} px/frame")
    table = pd.DataFrame(rows)
    table.to_csv(out / "t1_harmonics.csv", index=False, float_format="%.5g")
    share, theory = theory_shares()
    print("theory radial shares n=0..8:", np.round(share, 3))
    print(theory[["n", "radial_cos", "radial_sin"]].round(4).to_string(index=False))
    plot(table, share, out / "t1_harmonics.png")
    at0 = table[table["offset"] == 0]
    print(at0[["run", "kind", "events", "n", "amplitude", "cos", "sin", "sd", "floor95"]].to_string(index=False))


def plot(table, share, path):
    from matplotlib.figure import Figure

    runs = list(dict.fromkeys(table["run"]))
    at0 = table[table["offset"] == 0]
    fig = Figure(figsize=(4.2 * len(runs), 3.4), layout="constrained")
    axes = fig.subplots(1, len(runs), squeeze=False)[0]
    for ax, run in zip(axes, runs):
        for k, (kind, colour) in enumerate((("cycle", "C0"), ("intercalation", "C1"))):
            g = at0[(at0["run"] == run) & (at0["kind"] == kind)].sort_values("n")
            if not len(g) or g["events"].iloc[0] < 5:  # too few events to resolve any harmonic
                continue
            n = g["n"].to_numpy() + (k - 0.5) * 0.25
            ax.errorbar(n, g["amplitude"], g["sd"], fmt="o", color=colour, ms=4,
                        label=f"{kind} ({int(g['events'].iloc[0])} events)")
            ax.plot(n, g["floor95"], "_", color=colour, ms=10, mew=2)
            if kind == "intercalation":
                top = g.loc[g["n"] > 0, "amplitude"].sum()
                ax.bar(np.arange(N_MAX + 1) + 0.35, share * top, width=0.2, color="0.6",
                       label="quadrupole Stokes flow, same sum n>=1")
        ax.set_xticks(range(N_MAX + 1))
        ax.set_xlabel("angular harmonic n of v_r")
        ax.set_ylabel("amplitude (px/frame)")
        ax.set_title(f"{run}, offset 0 (bars: s.d. over events; -: 95 % noise floor)", fontsize=8)
        ax.set_ylim(top=1.4 * ax.get_ylim()[1])  # room for the legend above the points
        ax.legend(fontsize=7, loc="upper left")
    fig.savefig(path, dpi=110)


if __name__ == "__main__":
    main()
