"""Timing of ``hexatissue analyze`` with and without its allocator settings, runs alternated.

The command line calls :func:`hexatissue._system.return_freed_memory_early`
(a fixed glibc mmap threshold, Arrow's system memory pool) before the
analysis.  This script runs the same command ``--repeats`` times each way in
fresh subprocesses, alternating (on, off, off, on, ...), "off" replacing that
function by a no-op, and prints the medians of wall time and of CPU time
(the process and its pool workers) and the ratios on / off.

Usage::

    PYTHONPATH=$PWD python benchmarks/bench_cli_allocator.py INPUT [--periodic] [--workers 2] [--repeats 4]

Results: ``benchmarks/README.md`` (memory section).
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

#: One CLI run; argv: report path, "on" / "off", then the CLI's arguments.
RUNNER = r"""
import json, resource, sys, time
import hexatissue._system as system
if sys.argv[2] == "off":
    system.return_freed_memory_early = lambda: None
from hexatissue.cli import main
t0, c0 = time.perf_counter(), time.process_time()
rc = main(sys.argv[3:])
wall, cpu = time.perf_counter() - t0, time.process_time() - c0
kids = resource.getrusage(resource.RUSAGE_CHILDREN)
with open(sys.argv[1], "w") as fh:
    json.dump({"rc": rc, "wall": wall, "cpu": cpu + kids.ru_utime + kids.ru_stime}, fh)
sys.exit(rc)
"""


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("input", type=Path)
    ap.add_argument("--periodic", action="store_true")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=4, help="runs each way (default 4)")
    args = ap.parse_args(argv)
    times = {"on": [], "off": []}
    with tempfile.TemporaryDirectory(prefix="bench-alloc-") as work:
        report = Path(work) / "report.json"
        for k in range(args.repeats):
            for mode in (("on", "off") if k % 2 == 0 else ("off", "on")):
                cmd = [sys.executable, "-c", RUNNER, str(report), mode, "analyze", str(args.input),
                       "--out", str(Path(work) / "out"), "--workers", str(args.workers)]
                cmd += ["--periodic"] if args.periodic else []
                subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
                rep = json.loads(report.read_text())
                times[mode].append((rep["wall"], rep["cpu"]))
                print(f"{mode:3s}: wall {rep['wall']:6.2f} s, CPU {rep['cpu']:6.2f} s; load {os.getloadavg()[0]:.2f}",
                      flush=True)
    med = {m: np.median(np.array(t), axis=0) for m, t in times.items()}
    print(f"median wall on / off: {med['on'][0]:.2f} / {med['off'][0]:.2f} s = {med['on'][0] / med['off'][0]:.3f}; "
          f"CPU {med['on'][1]:.2f} / {med['off'][1]:.2f} s = {med['on'][1] / med['off'][1]:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
