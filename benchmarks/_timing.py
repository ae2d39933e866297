"""Timing and reporting helpers shared by the benchmark scripts."""
import time

import numpy as np


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
