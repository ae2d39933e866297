"""Timing, reporting and data-location helpers shared by the benchmark scripts."""
import os
import time
from pathlib import Path

import numpy as np

# the real third-party data sets the tests and benchmarks read: the folder named by HEXATISSUE_REAL_DATA (as in
# tests/conftest.py), else the folder of that name beside the checkout
REAL_DATA = Path(os.environ.get("HEXATISSUE_REAL_DATA",
                                Path(__file__).resolve().parents[2] / "shared" / "data" / "real"))


def median_time(fn, repeats=5):
    """Median wall time (s) of ``repeats`` calls of ``fn()``."""
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def emit(lines, load, out=None):
    """Print a Markdown result block (``lines`` plus the load after the run) and append it to ``out``."""
    text = "\n".join(list(lines) + ["", f"- load after: `{load}`", ""])
    print(text)
    if out:
        with open(out, "a") as fh:
            fh.write(text + "\n")


def status_kb(pid: int, keys=("VmRSS", "VmHWM", "RssAnon", "RssFile", "RssShmem")) -> dict:
    """The ``keys`` of ``/proc/PID/status`` (kB): resident memory, its high-water mark and its kinds (Linux)."""
    out = {}
    with open(f"/proc/{pid}/status") as fh:
        for line in fh:
            name, _, rest = line.partition(":")
            if name in keys:
                out[name] = int(rest.split()[0])
    return out


def pss_kb(pid: int) -> int:
    """Proportional set size of a process (kB): its pages, shared ones split between their users (Linux)."""
    with open(f"/proc/{pid}/smaps_rollup") as fh:
        for line in fh:
            if line.startswith("Pss:"):
                return int(line.split()[1])
    return 0
