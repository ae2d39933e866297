"""The continuum model's stability and the quadrupole's flow: every number of docs/hydro.md "Stability and scale".

1. Bulk onset of the uniform hexatic (continuum, spectral and fd schemes) at the paper's parameters, and the
   closed-form estimate |alpha_c| ~ 4 L6 sqrt(eta Gamma6 lambda6 / (3/2 + sqrt(eta Gamma6 / 2))) against it.
2. Stability diagram alpha6 against lambda6 (continuum and fd), figure.
3. Time-step limits of the schemes about the uniform state (alpha6 = 0 and -1, 128^2).
4. The quadrupole's flow: the numerical Stokes reference (two grids, two boxes) against the exact far field
   (quadrupole_flow_far) and the paper's posed problem (quadrupole_flow), at 3-20 ell.
5. Scale: ell6 / ell at the bulk onset for ell = 7, and |alpha6| = L6 ell^2.

Usage::

    PYTHONPATH=. python scripts/hydro_stability.py [--json docs/figures/hydro_stability.json]
        [--figure docs/figures/hydro_stability_diagram.png]
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from hexatissue import theory as th  # noqa: E402
from hexatissue.hydro import HydroParams  # noqa: E402
from hexatissue.hydro.plots import plot_stability_diagram  # noqa: E402
from hexatissue.hydro.stability import dt_limit  # noqa: E402


def closed_form(p):
    return 4 * p.L6 * np.sqrt(p.eta * p.Gamma6 * p.lambda6 / (1.5 + np.sqrt(p.eta * p.Gamma6 / 2)))


def ring(x, vx, vy, r, nphi=360):
    from scipy.ndimage import map_coordinates

    h = x[1] - x[0]
    phi = np.arange(nphi) * 2 * np.pi / nphi
    cx, cy = (r * np.cos(phi) - x[0]) / h, (r * np.sin(phi) - x[0]) / h
    return phi, map_coordinates(vx, [cy, cx], order=3) + 1j * map_coordinates(vy, [cy, cx], order=3)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--json", default="docs/figures/hydro_stability.json")
    ap.add_argument("--figure", default="docs/figures/hydro_stability_diagram.png")
    args = ap.parse_args(argv)
    out = {}
    p = HydroParams()
    out["onset"] = {s: th.bulk_onset(p, s).round(4).to_dict("records") for s in ("continuum", "spectral", "fd")}
    for s, rows in out["onset"].items():
        print(s, [(r["alpha"], r["k"], r["angle_deg"]) for r in rows])
    lambdas = np.array([0.1, 0.25, 0.5, 0.75, 1.11, 1.5, 2.0, 3.0, 4.0])
    cont = th.stability_diagram(p, "lambda6", lambdas)
    fd = th.stability_diagram(p, "lambda6", lambdas, scheme="fd")
    cont["closed_form"] = [closed_form(HydroParams(lambda6=v)) for v in lambdas]
    out["diagram_lambda6"] = {"continuum": cont.round(4).to_dict("records"), "fd": fd.round(4).to_dict("records")}
    print(cont[["value", "alpha_extensile", "alpha_contractile", "closed_form"]])
    print(fd[["value", "alpha_extensile", "alpha_contractile"]])
    fig = plot_stability_diagram({"continuum / spectral": cont, "fd (paper's scheme)": fd}, "lambda6",
                                 marked={"paper (alpha6 = +-0.1)": (1.11, -0.1)})
    ax = fig.axes[0]
    ax.plot([1.11], [0.1], "k*", ms=9)
    for sign in (-1, 1):  # activity beats elasticity at the defect spacing ell = 7 beyond |alpha6| = L6 ell^2
        ax.axhline(sign * p.L6 * 7.0**2, color="tab:green", ls=":", lw=1.2,
                   label="|alpha6| = L6 ell^2 (ell6 = ell = 7)" if sign > 0 else None)
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=2)
    ax.set_yscale("symlog", linthresh=1.0)
    ax.set_title("uniform hexatic: linear stability (paper's other constants)", fontsize=9)
    fig.tight_layout()
    fig.savefig(args.figure, dpi=130)
    out["dt_limit_128"] = {}
    for scheme, integ in (("spectral", "sbdf2"), ("fd", "sbdf2"), ("fd", "rk4"), ("spectral", "rk4")):
        for a in (0.0, -1.0):
            lim = dt_limit(HydroParams(scheme=scheme, integrator=integ, alpha6=a, dt=0.01), 128)
            out["dt_limit_128"][f"{scheme}/{integ}/alpha{a:g}"] = round(lim, 4)
    print(out["dt_limit_128"])
    ref = {key: th.quadrupole_flow_stokes(1.0, 1.0, n=key[0], points_per_ell=key[1])
           for key in ((512, 8), (1024, 16), (1024, 8))}
    rows = []
    for r in (3, 5, 7, 10, 15, 20):
        phi, a = ring(*ref[(512, 8)], r)
        _, b = ring(*ref[(1024, 16)], r)
        _, c = ring(*ref[(1024, 8)], r)
        fx, fy = th.quadrupole_flow_far(r * np.cos(phi), r * np.sin(phi), 1.0, 1.0)
        px, py = th.quadrupole_flow(r * np.cos(phi), r * np.sin(phi), 1.0, 1.0)
        m = np.abs(c).max()
        rows.append({"r_over_ell": r, "grid_change": np.abs(a - b).max() / m, "box_change": np.abs(c - a).max() / m,
                     "far_field_error": np.abs(fx + 1j * fy - c).max() / m,
                     "posed_error": np.abs(px + 1j * py - c).max() / m,
                     **{f"ref_h{k}": float((np.mean(c * np.exp(-1j * k * phi)) * r**5).real)
                        for k in (-7, -5, 5, 7, 9)},
                     **{f"posed_h{k}": float((np.mean((px + 1j * py) * np.exp(-1j * k * phi)) * r**5).real)
                        for k in (-7, -5, 5, 7, 9)}})
    out["flow"] = [{k: round(v, 4) for k, v in row.items()} for row in rows]
    out["far_field_c"] = -24 * th._quadrupole_monopole()
    for row in out["flow"]:
        print(row)
    ell = 7.0
    out["scale"] = {"alpha_at_ell7": p.L6 * ell**2,
                    "ell6_over_ell_at_onset": [th.ell6(r["alpha"], p.L6) / ell for r in out["onset"]["continuum"]]}
    print(out["scale"])
    Path(args.json).write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
