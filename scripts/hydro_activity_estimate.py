"""How strong is the paper's activity? Active vs elastic forcing near a +-1/6 defect, on paper and on a pair.

1. Closed forms for an isolated defect with |Psi6| = 1 (Psi6 = e^{+- i phi}):
   active force (alpha6/8) Dbar^5 Psi6 and elastic force div sigma^e, sigma^e = -(L6/2) Re(d_i Psi d_j Psi^*),
   and their ratio as a function of r.  The active force is checked by finite differences.
2. A relaxed +1/6 / -1/6 pair (n = 128, distance 32, far-field angle 30 deg, as the runs of docs/hydro.md):
   the Stokes flow driven by the active term alone and by all passive stresses, at the two cores, compared
   with the defects' passive approach speed.  The ratio estimates the relative change of the annihilation
   time the activity can make.

3. ``--scan A1 A2 ...``: the pair (same state) run to annihilation at those alpha6 (a rescaled activity),
   with the production scheme and/or the paper's finite differences (``--schemes``); prints t_a, the
   largest number of defects and kinetic energy (proliferation or blow-up show there).

Usage::

    PYTHONPATH=. python scripts/hydro_activity_estimate.py [--alpha 0.1] [--json docs/figures/hydro_activity_estimate.json]
    PYTHONPATH=. python scripts/hydro_activity_estimate.py --scan 3.2 -3.2 --schemes fd [--json FILE]
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from hexatissue.hydro import default_params  # noqa: E402
from hexatissue.hydro.initial import dipole_initial  # noqa: E402
from hexatissue.hydro.solver import Solver, fft2, ifft2  # noqa: E402


def dbar_power_coefficient(m: int, sign: int) -> float:
    """|Dbar^m e^{i sign phi}| r^m for |Psi| = 1: e^{i s phi} = z^{s/2} zbar^{-s/2}, Dbar = 2 d_z."""
    c, a = 1.0, sign / 2
    for k in range(m):
        c *= 2 * (a - k)
    return abs(c)


def analytic(alpha, L6):
    rows = []
    for charge, sign in (("+1/6", 1), ("-1/6", -1)):
        fa = abs(alpha) / 8 * dbar_power_coefficient(5, sign)  # |f_a| = fa / r^5
        curl_a = abs(alpha) / 8 * dbar_power_coefficient(6, sign)  # |curl f_a| <= curl_a / r^6
        fe = L6 / 2  # |div sigma^e| = (L6/2) / r^3 for |grad Psi| = 1/r (a pure gradient: no curl)
        rows.append(dict(charge=charge, active_coef=fa, active_curl_coef=curl_a, elastic_coef=fe,
                         ratio_coef=fa / fe, active_harmonic=-4 if sign > 0 else -6))
    return rows


def finite_difference_check(alpha, h=0.05):
    """|f_a| r^5 of (alpha/8) Dbar^5 e^{+-i phi} at r = 12, by five centred differences (spacing h)."""
    x = np.arange(-60, 61) * h + 12.0
    y = np.arange(-60, 61) * h
    X, Y = np.meshgrid(x, y)
    out = {}
    for sign in (1, -1):
        f = np.exp(1j * sign * np.arctan2(Y, X))
        for _ in range(5):
            f = ((f[1:-1, 2:] - f[1:-1, :-2]) - 1j * (f[2:, 1:-1] - f[:-2, 1:-1])) / (2 * h)
        c = f.shape[0] // 2
        out["+1/6" if sign > 0 else "-1/6"] = float(alpha / 8 * np.abs(f[c, c]) * 12.0**5)
    return out


def stokes_velocity(solver, psi, off):
    """Stokes-limit flow V = vx + i vy driven by the stresses left on (off = the terms switched off)."""
    s = Solver(solver.n, solver.params, off=off)
    st = s.state_from_fields(psi)
    _, domg = s.rhs(st.psi_hat, st.omega_hat)
    o = s.ops
    p = s.params
    omega_hat = p.rho * domg * np.where(o.k2 > 0, 1.0 / np.where(o.k2 > 0, o.k2, 1.0), 0.0) / p.eta
    return ifft2(-1j * o.D * omega_hat * o.inv_k2)


def core_average(field, x0, y0, radius=2.0):
    n = field.shape[0]
    X, Y = np.meshgrid(np.arange(n), np.arange(n))
    m = np.hypot(X - x0, Y - y0) <= radius
    return complex(field[m].mean())


def pair(alpha, n=128, distance=32.0, orientation_deg=30.0, t_passive=254.5):
    params = default_params(alpha)
    psi, info = dipole_initial(n, distance, 5.0, params, seed=0, orientation=np.deg2rad(orientation_deg))
    solver = Solver(n, params)
    terms = Solver.TERMS
    stress_terms = ("active", "reactive", "antisymmetric", "elastic")
    not_stress = tuple(t for t in terms if t not in stress_terms)
    v_active = stokes_velocity(solver, psi, off=tuple(t for t in terms if t != "active"))
    v_passive = stokes_velocity(solver, psi, off=("active",) + not_stress)
    (xp, yp, _), (xm, ym, _) = info["positions"]
    res = {}
    for name, v in (("active", v_active), ("passive stresses", v_passive)):
        vp, vm = core_average(v, xp, yp), core_average(v, xm, ym)
        res[name] = dict(v_plus=[vp.real, vp.imag], v_minus=[vm.real, vm.imag],
                         approach=vp.real - vm.real, max_speed=float(np.abs(v).max()))
    # passive approach rate at the start, from the measured t_a and d^2 = d0^2 (1 - t / t_a)
    approach = distance / (2 * t_passive)
    res["passive approach rate (from t_a)"] = approach
    res["active approach / passive approach"] = res["active"]["approach"] / approach
    return res


def scan(alphas, schemes, n=128, distance=32.0, orientation_deg=30.0):
    import time

    from hexatissue.hydro import run_dipole

    rows = []
    for scheme in schemes:
        for alpha in alphas:
            if scheme == "spectral":
                params, every = default_params(alpha), 2  # diagnostics every 0.1 time units
            else:
                params, every = default_params(alpha, scheme="fd", integrator="rk4", dt=0.1), 1
            t0 = time.perf_counter()
            r = run_dipole(alpha, n=n, distance=distance, seed=0, progress=False, save_every=every, params=params,
                           orientation=np.deg2rad(orientation_deg))
            d = r.diagnostics
            row = dict(scheme=scheme, alpha=alpha, t_a=r.annihilation_time, final_time=float(d["time"].iloc[-1]),
                       max_defects=int(d["n_defects"].max()), max_kinetic=float(d["kinetic_energy"].max()),
                       wall=time.perf_counter() - t0)
            print(json.dumps(row), flush=True)
            rows.append(row)
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--alpha", type=float, default=0.1)
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--scan", type=float, nargs="+", default=None, help="alpha6 values of a dipole scan")
    ap.add_argument("--schemes", nargs="+", default=["spectral"], choices=["spectral", "fd"])
    args = ap.parse_args(argv)
    if args.scan:
        rows = scan(args.scan, args.schemes)
        if args.json:
            args.json.write_text(json.dumps(rows, indent=1))
        return
    L6 = default_params(0.0).L6
    xi = math.sqrt(L6 / (2 * abs(default_params(0.0).A6)))
    rows = analytic(args.alpha, L6)
    check = finite_difference_check(args.alpha)
    print(f"alpha6 = {args.alpha:g}, L6 = {L6:g}, core size xi = {xi:.2f}")
    print("| charge | |f_a| r^5 (closed form; finite differences) | |f_e| r^3 | |f_a| / |f_e| | at r = xi, 2, 5, 16 |")
    print("|---|---|---|---|---|")
    for row in rows:
        rr = [xi, 2.0, 5.0, 16.0]
        ratios = ", ".join(f"{row['ratio_coef'] / r**2:.3g}" for r in rr)
        print(f"| {row['charge']} | {row['active_coef']:.4g}; {check[row['charge']]:.4g} | {row['elastic_coef']:.3g} "
              f"| {row['ratio_coef']:.3g} / r^2 | {ratios} |")
    res = pair(args.alpha)
    print(json.dumps(res, indent=1))
    if args.json:
        args.json.write_text(json.dumps({"alpha": args.alpha, "analytic": rows, "finite_difference_check": check,
                                         "pair": res}, indent=1))


if __name__ == "__main__":
    main()
