"""The tissue-flow stage's share of ``analyze`` on the bench_t1 movie (1000 frames x 440 cells, periodic).

Alternates ``analyze`` with the flow stage on (default: velocities and the flow fields on the Gamma_p grid, in
the main process after the frames) and off (``FlowOptions(enabled=False)``, the CLI's ``--no-flow``), --pairs
times, in this one run: wall time and CPU time (this process and its workers); then the flow statistics
(``flow_summary``, what the report adds) and the stage alone (``cell_velocities`` + ``flow_fields``, CPU time in
this process) on the last run's tables.  The movie is bench_t1.py's (rendered there into --cache).  Writes
``results_flow_share.md`` beside this script.

    NUMBA_NUM_THREADS=1 python benchmarks/bench_flow_share.py [--cache /tmp/hexatissue_bench] [--pairs 2]
"""
import argparse
import datetime
import os
import platform
import resource
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_t1 import RawStack, render  # noqa: E402

from hexatissue import analyze  # noqa: E402
from hexatissue.box import Box  # noqa: E402
from hexatissue.errors import HexatissueWarning  # noqa: E402
from hexatissue.flow import cell_velocities, flow_fields, flow_summary  # noqa: E402
from hexatissue.options import FlowOptions  # noqa: E402

warnings.simplefilter("ignore", HexatissueWarning)


def cpu():
    s, c = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return s.ru_utime + s.ru_stime + c.ru_utime + c.ru_stime


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cache", default="/tmp/hexatissue_bench")
    ap.add_argument("--frames", type=int, default=1000)
    ap.add_argument("--pairs", type=int, default=2)
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args()
    shape = (384, 403)  # rows, columns: bench_t1.py's default
    path = Path(args.cache) / f"voronoi_{args.frames}x440_{shape[0]}x{shape[1]}.npy"
    render(path, args.frames, 440, shape)
    box = Box(shape[1], shape[0])
    analyze(RawStack(path, 3), box=box, workers=1, progress=False)  # numba caches warm, not timed
    modes = {"on": True, "off": False}
    times = {mode: [] for mode in modes}
    movie = None
    start = datetime.datetime.now(datetime.timezone.utc)
    load_before = os.getloadavg()[0]
    for _ in range(args.pairs):
        for mode, flow in modes.items():
            w0, c0 = time.perf_counter(), cpu()
            m = analyze(RawStack(path, args.frames), box=box, workers=args.workers, progress=False,
                        flow=FlowOptions(enabled=flow))
            times[mode].append((time.perf_counter() - w0, cpu() - c0))
            movie = m if flow else movie
            print(f"flow {mode}: wall {times[mode][-1][0]:.1f} s, CPU {times[mode][-1][1]:.1f} s", flush=True)
    t0 = time.process_time()
    flow_summary(movie.cells, box)
    stats = time.process_time() - t0
    # the stage alone, in this process (its kernel already loaded): what the alternated runs should differ by
    cells = movie.cells.drop(columns=["vx", "vy"])
    t0 = time.process_time()
    vx, vy = cell_velocities(cells, box)
    flow_fields(cells.assign(vx=vx, vy=vy), movie.grid, box)
    stage = time.process_time() - t0
    med = {mode: np.median(np.array(t), axis=0) for mode, t in times.items()}
    lines = [
        "# The flow stage's share of `analyze` (`bench_flow_share.py`)", "",
        (f"{start:%Y-%m-%d %H:%M} UTC, {platform.machine()} ({os.cpu_count()} cores), Python "
         f"{platform.python_version()}, `NUMBA_NUM_THREADS={os.environ.get('NUMBA_NUM_THREADS', 'unset')}`; "
         f"1-minute load before {load_before:.1f}, after {os.getloadavg()[0]:.1f}.  bench_t1's movie, "
         f"{args.frames} frames x 440 cells (periodic), {args.workers} workers; {args.pairs} rounds alternating "
         "on and off, medians.  CPU = this process and its workers."), "",
        "| flow stage | wall | CPU | wall / off | CPU / off |", "|---|---|---|---|---|"]
    for mode, text in (("on", "on (default)"), ("off", "off (`--no-flow`)")):
        lines.append(f"| {text} | {med[mode][0]:.1f} s | {med[mode][1]:.1f} s | {med[mode][0] / med['off'][0]:.3f} | "
                     f"**{med[mode][1] / med['off'][1]:.3f}** |")
    lines += ["", "Each run (wall s, CPU s): " + "; ".join(
        f"{mode} " + ", ".join(f"{w:.1f}/{c:.1f}" for w, c in times[mode]) for mode in modes), "",
        (f"The stage alone in this process (`cell_velocities` + one `flow_fields` call): {stage:.2f} s CPU = "
         f"{stage / med['off'][1]:.3f} of analyze's CPU without it; `flow_summary` {stats:.2f} s CPU "
         f"({len(movie.flow)} flow rows, {int(movie.flow['valid'].sum())} valid)."), ""]
    text = "\n".join(lines)
    print(text)
    (Path(__file__).resolve().parent / "results_flow_share.md").write_text(text)


if __name__ == "__main__":
    main()
