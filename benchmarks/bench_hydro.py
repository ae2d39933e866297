"""Steps per second of the hydro solver: production (spectral + SBDF2, dt 0.05) and the paper's FD + RK4 (dt 0.1).

Usage: python benchmarks/bench_hydro.py [--sizes 256 1024] [--repeats 3] [--steps 20]
Prints a markdown table (median of repeats) with the machine, date and load.
"""
import argparse
import datetime
import os
import platform
import subprocess
import time

import numpy as np

from hexatissue.hydro import HydroParams, Solver
from hexatissue.hydro.initial import core_profile


def field(n):
    x = np.arange(n)
    X, Y = np.meshgrid(x, x)
    z = X + 1j * Y
    zp, zm = n / 2 - 16.5 + 1j * (n / 2 - 0.5), n / 2 + 15.5 + 1j * (n / 2 - 0.5)
    p = HydroParams()
    return np.exp(1j * (np.angle(z - zp) - np.angle(z - zm))) * core_profile(abs(z - zp), p) * core_profile(abs(z - zm), p)


def bench(n, scheme, integrator, dtype, steps, repeats):
    params = HydroParams(scheme=scheme, integrator=integrator, dtype=dtype, alpha6=-0.1,
                         dt=0.05 if integrator == "sbdf2" else 0.1)
    solver = Solver(n, params)
    state = solver.state_from_fields(field(n))
    solver.step(state)  # compile / warm up
    rates = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(steps):
            solver.step(state)
        rates.append(steps / (time.perf_counter() - t0))
    assert np.all(np.isfinite(solver.psi(state)))
    return float(np.median(rates))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", type=int, nargs="+", default=[256, 1024])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--steps", type=int, default=20)
    a = ap.parse_args()
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores; "
          f"{datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC")
    print(f"load before: {subprocess.run(['uptime'], capture_output=True, text=True).stdout.strip()}\n")
    print("| n | scheme | integrator (dt) | dtype | steps/s | time units/s |")
    print("|---|---|---|---|---|---|")
    for n in a.sizes:
        steps = max(3, a.steps * (256 // n) ** 2) if n <= 256 else max(3, a.steps // 4)
        for scheme, integ in [("spectral", "sbdf2"), ("fd", "rk4")]:
            for dtype in ("float64", "float32"):
                r = bench(n, scheme, integ, dtype, steps, a.repeats)
                dt = 0.05 if integ == "sbdf2" else 0.1
                print(f"| {n} | {scheme} | {integ} ({dt}) | {dtype} | {r:.2f} | {r * dt:.2f} |", flush=True)
    print(f"\nload after: {subprocess.run(['uptime'], capture_output=True, text=True).stdout.strip()}")


if __name__ == "__main__":
    main()
