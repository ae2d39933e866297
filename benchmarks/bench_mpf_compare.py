"""Two checkouts of the simulator (e.g. a baseline commit and the working tree) under several OpenMP
wait policies, in interleaved processes, so that both see the same machine.

Paper system (440 cells, 384 x 403, P = 41), float32: 30 passive steps (compilation, transient),
then 7 stretches of 150 active steps; the median steps/s is printed per (checkout, policy, threads).

Usage::

    git worktree add /tmp/baseline <commit>
    python benchmarks/bench_mpf_compare.py /tmp/baseline . [--rounds 2]

Each measurement runs in its own process because the OpenMP wait policy is read once, when the
thread pool starts.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys

POLICIES = {  # name -> environment
    "PASSIVE": {"OMP_WAIT_POLICY": "PASSIVE"},
    "ACTIVE": {"OMP_WAIT_POLICY": "ACTIVE"},
    "SPIN20000": {"OMP_WAIT_POLICY": "", "GOMP_SPINCOUNT": "20000"},
}

CHILD = """
import sys, time, numpy as np
from hexatissue.simulate import Params, initial_state, set_threads
set_threads(int(sys.argv[1]))
sim = initial_state(Params(dtype=sys.argv[2]), seed=0)
sim.advance(30, active=False)
rates = []
for _ in range(7):
    t = time.perf_counter(); sim.advance(150); rates.append(150 / (time.perf_counter() - t))
print(' '.join(f'{r:.0f}' for r in rates))
"""


def measure(src, threads, dtype, env):
    full = dict(os.environ, PYTHONPATH=os.path.abspath(src), **env)
    out = subprocess.run([sys.executable, "-c", CHILD, str(threads), dtype], env=full, capture_output=True,
                         text=True, check=True, cwd=os.path.abspath(src)).stdout.split()
    return [float(x) for x in out]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("baseline", help="checkout of the baseline")
    ap.add_argument("candidate", help="checkout to compare")
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--dtype", default="float32")
    args = ap.parse_args(argv)
    print(f"load: {os.getloadavg()}")
    print("| round | policy | threads | baseline median (all) | candidate median (all) |")
    print("|---|---|---|---|---|")
    for rnd in range(1, args.rounds + 1):
        for threads in (2, 1):
            for name, env in POLICIES.items():
                cells = []
                for src in (args.baseline, args.candidate):
                    r = measure(src, threads, args.dtype, env)
                    cells.append(f"{sorted(r)[len(r) // 2]:.0f} ({', '.join(f'{x:.0f}' for x in r)})")
                print(f"| {rnd} | {name} | {threads} | {cells[0]} | {cells[1]} |", flush=True)
    print(f"load: {os.getloadavg()}")


if __name__ == "__main__":
    main()
