"""Speed of a lone, freely moving cell relative to v0, per advection scheme, phi0 and dt.

A single cell (paper parameters, float64) in a periodic box relaxes passively,
then moves with a fixed polarity (D_r = 0); after a settling stretch its
centroid displacement over ``--time`` time units gives speed / v0.  A perfect
discretisation of ``d_t phi + v . grad phi = -M dF/dphi`` moves a steady shape
at exactly v0, so the deficit is the numerical dispersion of the advection
stencil (plus the time stepping error, which should not depend much on dt).

Usage::

    NUMBA_NUM_THREADS=1 PYTHONPATH=. python scripts/free_cell_speed.py [--v0 0.006] [--time 2500]
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from hexatissue.simulate import Params, initial_state, set_threads, stability_limit  # noqa: E402


def free_cell_speed(phi0, dt, advection, v0=0.006, theta=0.7, time=2500.0, settle=500.0, L=64):
    """speed / v0 of one cell moving at polarity ``theta`` (rad) for ``time`` time units after ``settle``."""
    p = Params(n_cells=1, Lx=L, Ly=L, dtype="float64", v0=v0, D_r=0.0, phi0=phi0, dt=dt, advection=advection)
    sim = initial_state(p, positions=[[L / 3, L / 3]], radius=10.0)
    sim.advance(int(round(200 / dt)), active=False)
    sim.theta[:] = theta
    sim.advance(int(round(settle / dt)))
    start = sim.moments()[0, 1:]
    n = int(round(time / dt))
    sim.advance(n)
    d = sim.moments()[0, 1:] - start
    speed = math.hypot(*d) / (n * dt)
    return speed / v0, math.atan2(d[1], d[0]) - theta


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--v0", type=float, default=0.006)
    ap.add_argument("--time", type=float, default=2500.0, help="measured stretch, time units")
    ap.add_argument("--theta", type=float, default=0.7)
    ap.add_argument("--dt", type=float, nargs="*", default=None, help="time steps (default: 0.25 0.5 1.0 1.5 3 5 6.5; those above the limit are skipped)")
    args = ap.parse_args(argv)
    set_threads(1)
    print("| phi0 | dt | advection | speed / v0 | direction error (rad) |")
    print("|---|---|---|---|---|")
    for phi0 in (1.0, 2.0):
        for dt in args.dt or (0.25, 0.5, 1.0, 1.5, 3.0, 5.0, 6.5):
            if dt >= stability_limit(Params(n_cells=1, Lx=64, Ly=64, phi0=phi0, dt=0.1)):
                continue
            for adv in ("central", "upwind3"):
                s, e = free_cell_speed(phi0, dt, adv, v0=args.v0, theta=args.theta, time=args.time)
                print(f"| {phi0:g} | {dt:g} | {adv} | {s:.4f} | {e:+.4f} |", flush=True)


if __name__ == "__main__":
    main()
