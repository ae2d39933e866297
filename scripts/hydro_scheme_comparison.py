"""Measured stability and accuracy of the hydro schemes (results in docs/hydro.md).

A +-1/6 pair (distance 16, alpha6 = -0.1, so active and reactive stresses all
act) on a 64 x 64 grid, dx = 1, relaxed once; every scheme / integrator / dt
starts from the same field and runs until the pair annihilates (or blows up).
Accuracy reference: the same physical system on a grid twice as fine
(dx = 0.5, spectral), small dt.
Run: python scripts/hydro_scheme_comparison.py [--quick]
"""
import json
import sys
import time

import numpy as np

from hexatissue.defects import plaquette_charges
from hexatissue.hydro.initial import dipole_initial
from hexatissue.hydro.params import HydroParams
from hexatissue.hydro.solver import Solver

N, DIST, ALPHA, T_MAX = 64, 16, -0.1, 600.0


def refine(psi, factor):
    """Spectral (zero-padding) interpolation of a periodic field onto a finer grid."""
    n = psi.shape[0]
    m = n * factor
    hat = np.fft.fftshift(np.fft.fft2(psi))
    pad = np.zeros((m, m), complex)
    o = (m - n) // 2
    pad[o:o + n, o:o + n] = hat
    return np.fft.ifft2(np.fft.ifftshift(pad)) * factor**2


T_SNAP = 30.0


def annihilation(psi0, scheme, integrator, dt, dx=1.0, t_max=T_MAX):
    n = psi0.shape[0]
    solver = Solver(n, HydroParams(scheme=scheme, integrator=integrator, dt=dt, dx=dx, alpha6=ALPHA))
    state = solver.state_from_fields(psi0)
    every = max(1, int(round(0.5 / dt)))
    t0 = time.perf_counter()
    snap = None
    while state.time < t_max:
        for _ in range(every):
            solver.step(state)
        psi = solver.psi(state)
        if snap is None and state.time >= T_SNAP - 1e-9:
            step = int(round(1 / dx))
            snap = psi[::step, ::step].copy()
            SNAPS[(scheme, integrator, dt, dx)] = snap
        if not np.all(np.isfinite(psi)) or np.abs(psi).max() > 10:
            return {"status": "unstable", "t": state.time, "wall": time.perf_counter() - t0}
        if not np.any(plaquette_charges(psi, 6, periodic=True)):
            return {"status": "annihilated", "t": state.time, "wall": time.perf_counter() - t0}
    return {"status": "running", "t": state.time, "wall": time.perf_counter() - t0}


SNAPS = {}


def main(quick=False):
    psi0, _ = dipole_initial(N, DIST, 3.0, seed=1)
    runs = [("fd", "rk4", dt) for dt in (0.05, 0.1, 0.2, 0.3)]
    runs += [("fd", "sbdf2", dt) for dt in (0.02, 0.05, 0.1)]
    runs += [("spectral", "sbdf2", dt) for dt in (0.02, 0.05, 0.1, 0.2)]
    runs += [("spectral", "rk4", dt) for dt in (0.02, 0.01)]
    out = []
    for scheme, integ, dt in runs:
        t_max = 31.0 if (scheme, integ) == ("spectral", "rk4") else T_MAX
        r = annihilation(psi0, scheme, integ, dt, t_max=t_max)
        r.update(scheme=scheme, integrator=integ, dt=dt, dx=1.0)
        print(r, flush=True)
        out.append(r)
    if not quick:
        fine = refine(psi0, 2)
        for scheme, integ, dt in [("spectral", "sbdf2", 0.01), ("fd", "rk4", 0.025)]:
            r = annihilation(fine, scheme, integ, dt, dx=0.5)
            r.update(scheme=scheme, integrator=integ, dt=dt, dx=0.5)
            print(r, flush=True)
            out.append(r)
    if not quick:
        for key, ref_key in [("ref_spectral", ("spectral", "sbdf2", 0.01, 0.5)), ("ref_fd", ("fd", "rk4", 0.025, 0.5))]:
            ref = SNAPS[ref_key]
            for r in out:
                k = (r["scheme"], r["integrator"], r["dt"], r["dx"])
                if k in SNAPS and k != ref_key:
                    r[f"psi_error_vs_{key}"] = float(np.linalg.norm(SNAPS[k] - ref) / np.linalg.norm(ref))
        for r in out:
            print(r)
    with open("docs/figures/hydro_scheme_comparison.json", "w") as f:
        json.dump(out, f, indent=1)


if __name__ == "__main__":
    main("--quick" in sys.argv)
