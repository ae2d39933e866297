"""Throughput of the numba multiphase-field simulator (steps per second).

Measures the paper's system (440 cells, 384 x 403 px, P = 41) in float32 and
float64 with 1 and 2 threads, and N = 110, 440, 1760 cells at the paper's
density (the box scaled by sqrt(N / 440)), which must cost linearly in N.
Each figure is the median over repeats of an active (v0 > 0) stretch after a
warm-up (compilation excluded); patch re-centring is included, output is not.
"steps per CPU-second" divides by the process CPU time (all threads): with 1
thread it shows what an idle core would give even when the machine is busy.
The machine load (``uptime``) is recorded: on a shared machine, compare only
figures taken in one run.

``--schemes`` instead measures the cost of the advection stencil: the paper
system with ``advection="central"`` and ``"upwind3"`` side by side in one
process, their stretches interleaved so that both see the same machine load.

Usage::

    python benchmarks/bench_mpf.py [--repeats 5] [--out benchmarks/results_mpf.md]
    python benchmarks/bench_mpf.py --schemes [--repeats 9] [--threads 1] [--out benchmarks/results_mpf.md]
"""
from __future__ import annotations

import argparse
import math
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from _timing import emit  # noqa: E402  (benchmarks/_timing.py)
from hexatissue.simulate import Params, initial_state, set_threads  # noqa: E402


def uptime() -> str:
    try:
        return subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    except OSError:
        return "load %.2f %.2f %.2f" % os.getloadavg()


def steps_per_second(params: Params, threads: int, repeats: int, seconds: float = 1.0) -> list[float]:
    set_threads(threads)
    sim = initial_state(params, seed=0)
    sim.advance(30, active=False)  # compile and leave the initial transient
    t0 = time.perf_counter()
    sim.advance(10)
    n = max(10, int(seconds * 10 / max(time.perf_counter() - t0, 1e-6)))
    rates, cpu = [], []
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        sim.advance(n)
        rates.append(n / (time.perf_counter() - t0))
        cpu.append(n / (time.process_time() - c0))
    return rates, cpu


def scheme_rates(dtype: str, threads: int, repeats: int, n: int = 100):
    """Interleaved stretches of ``n`` active steps with central and upwind3 advection (paper system)."""
    set_threads(threads)
    sims = {}
    for adv in ("central", "upwind3"):
        sim = initial_state(Params(dtype=dtype, advection=adv), seed=0)
        sim.advance(30, active=False)  # compile and leave the initial transient
        sim.advance(10)
        sims[adv] = sim
    rates = {adv: [] for adv in sims}
    cpu = {adv: [] for adv in sims}
    for _ in range(repeats):
        for adv, sim in sims.items():
            t0, c0 = time.perf_counter(), time.process_time()
            sim.advance(n)
            rates[adv].append(n / (time.perf_counter() - t0))
            cpu[adv].append(n / (time.process_time() - c0))
    return rates, cpu


def schemes_main(args):
    import numba

    lines = [
        f"## Advection stencil cost, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}",
        "",
        f"- machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores; "
        f"python {platform.python_version()}, numba {numba.__version__}, numpy {np.__version__}",
        f"- paper system (440 cells, 384 x 403, P = 41), active; {args.repeats} interleaved stretches of 100 steps "
        "per scheme",
        f"- load before: `{uptime()}`",
        "",
        "| dtype | threads | central steps/s (median wall; per CPU-s) | upwind3 steps/s (median wall; per CPU-s) "
        "| upwind3 / central (per CPU-s) |",
        "|---|---|---|---|---|",
    ]
    for dtype in ("float32", "float64"):
        rates, cpu = scheme_rates(dtype, args.threads, args.repeats)
        c = {a: float(np.median(v)) for a, v in cpu.items()}
        w = {a: float(np.median(v)) for a, v in rates.items()}
        row = (f"| {dtype} | {args.threads} | {w['central']:.0f}; {c['central']:.0f} | {w['upwind3']:.0f}; "
               f"{c['upwind3']:.0f} | {c['upwind3'] / c['central']:.2f} |")
        print(row, flush=True)
        lines.append(row)
    emit(lines, uptime(), args.out)


def scaled(n_cells: int, **kw) -> Params:
    s = math.sqrt(n_cells / 440)
    return Params(n_cells=n_cells, Lx=int(round(384 * s)), Ly=int(round(403 * s)), **kw)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--out", type=Path, default=None, help="also write the markdown table here")
    ap.add_argument("--schemes", action="store_true", help="measure central vs upwind3 advection instead")
    ap.add_argument("--threads", type=int, default=1, help="threads for --schemes (default 1)")
    args = ap.parse_args(argv)
    if args.schemes:
        return schemes_main(args)

    import numba

    lines = [
        f"## MPF throughput, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}",
        "",
        f"- machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores; "
        f"python {platform.python_version()}, numba {numba.__version__}, numpy {np.__version__}",
        f"- OMP_WAIT_POLICY at start: {os.environ.get('OMP_WAIT_POLICY', '(unset: the simulator sets PASSIVE)')}",
        f"- load before: `{uptime()}`",
        "",
        "| system | box | dtype | threads | steps/s (median, wall) | min-max | steps per CPU-second | ns per cell-step (wall) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    configs = [(440, "float32", 1), (440, "float32", 2), (440, "float64", 1), (440, "float64", 2),
               (110, "float32", 1), (1760, "float32", 1), (110, "float32", 2), (1760, "float32", 2)]
    for n, dtype, threads in configs:
        p = scaled(n, dtype=dtype)
        rates, cpu = steps_per_second(p, threads, args.repeats)
        med = float(np.median(rates))
        row = (f"| N = {n} | {p.Lx} x {p.Ly} | {dtype} | {threads} | {med:.0f} | {min(rates):.0f}-{max(rates):.0f} "
               f"| {float(np.median(cpu)):.0f} | {1e9 / (med * n):.0f} |")
        print(row, flush=True)
        lines.append(row)
    import numba

    lines += ["", f"- threading layer used: {numba.threading_layer()}, OMP_WAIT_POLICY={os.environ.get('OMP_WAIT_POLICY')}",
              f"- load after: `{uptime()}`", ""]
    text = "\n".join(lines)
    print(text)
    if args.out:
        with open(args.out, "a") as fh:
            fh.write(text + "\n")


if __name__ == "__main__":
    main()
