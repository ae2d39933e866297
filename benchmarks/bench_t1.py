"""Benchmark: label movie -> junction networks -> tracks -> classified T1 events.

A smoothly moving periodic Voronoi movie (default 1000 frames x 440 cells in a
384 x 403 px box, ``hexatissue.synthetic.VoronoiMovie``) is rendered once to a
``.npy`` (uint16) in ``--cache`` and read lazily from there, one frame per read.

Stages, each in its own forked process so that its peak resident memory
(``ru_maxrss``) is its own:

- ``track``: overlap tracking of every frame (:class:`hexatissue.track.Tracker`);
- ``mesh``: ``mesh_from_labels`` of every frame, one process;
- ``events``: ``t1_tables`` (``detect_t1`` and ``neighbour_events`` in one pass, as ``analyze``)
  + lineage + per-cell statistics on the mesh tables;
- ``flow``: cell velocities, the flow fields on the Gamma_p grid (the grid itself, made by the order
  stage, not timed) and the flow statistics (``hexatissue.flow``) on the mesh tables;
- ``analyze``: everything end to end with ``--workers`` processes, for
  several movie lengths (cost per frame should not grow with length).

Times are medians over ``--repeats``; the machine load (``uptime``) is
printed with the results.  Usage::

    python benchmarks/bench_t1.py [--frames 1000] [--workers 2] [--repeats 3]
"""
from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import time
import warnings
from multiprocessing import get_context
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from hexatissue.box import Box  # noqa: E402
from hexatissue.errors import HexatissueWarning  # noqa: E402

warnings.simplefilter("ignore", HexatissueWarning)


def render(path: Path, n_frames, n_cells, shape, seed=0):
    """The benchmark movie as a uint16 .npy memmap (rendered once, then reused)."""
    from tqdm import tqdm

    from hexatissue.synthetic import voronoi_movie

    if path.exists():
        stack = np.load(path, mmap_mode="r")
        if stack.shape == (n_frames, *shape):
            return stack
    path.parent.mkdir(parents=True, exist_ok=True)
    movie = voronoi_movie(n_cells, shape, n_frames, periodic=True, amplitude=0.3, seed=seed)
    tmp = path.with_suffix(".tmp.npy")
    out = np.lib.format.open_memmap(tmp, mode="w+", dtype=np.uint16, shape=(n_frames, *shape))
    for t in tqdm(range(n_frames), desc="rendering benchmark movie"):
        out[t] = movie[t]
    out.flush()
    del out
    os.replace(tmp, path)
    return np.load(path, mmap_mode="r")


class RawStack:
    """A T x rows x cols ``.npy`` read frame by frame with plain file reads.

    Unlike a memory map, pages of frames already read do not count in the
    process's resident memory, so ``ru_maxrss`` measures the analysis only.
    """

    def __init__(self, path, n_frames=None):
        with open(path, "rb") as f:
            major, _ = np.lib.format.read_magic(f)
            read_header = np.lib.format.read_array_header_1_0 if major == 1 else np.lib.format.read_array_header_2_0
            shape, _, dtype = read_header(f)
            self.offset = f.tell()
        self.path, self.dtype = path, np.dtype(dtype)
        self.shape = (shape[0] if n_frames is None else min(n_frames, shape[0]), *shape[1:])
        self.ndim = 3
        self._size = int(np.prod(shape[1:]))

    def __len__(self):
        return self.shape[0]

    def __getitem__(self, t):
        with open(self.path, "rb") as f:
            f.seek(self.offset + int(t) * self._size * self.dtype.itemsize)
            return np.fromfile(f, dtype=self.dtype, count=self._size).reshape(self.shape[1:])


def _maxrss_mb(who=resource.RUSAGE_SELF):
    return resource.getrusage(who).ru_maxrss / 1024.0  # Linux: KiB


def _rss_mb():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def stage_track(path, n_frames):
    from hexatissue.track import Tracker

    stack = RawStack(path)
    tracker = Tracker()
    t0 = time.perf_counter()
    for t in range(n_frames):
        tracker.add(np.asarray(stack[t]), t)
    tracker.tracks()
    return time.perf_counter() - t0


def stage_mesh(path, n_frames, box, tables_dir):
    import pandas as pd

    from hexatissue.options import OrderOptions
    from hexatissue.stages import FrameData, frame_stages, run_frame, stage_options, worker_stages

    stack = RawStack(path)
    parts = {"cells": [], "edges": []}
    options = stage_options({"order": OrderOptions(fields=False)})  # mesh + gamma_p, as analyze does per frame
    stages = worker_stages(frame_stages(options), options)
    t0 = time.perf_counter()
    for t in range(n_frames):
        frame = FrameData(t=t, box=box, labels=np.asarray(stack[t]))
        run_frame(frame, stages)
        out = frame.tables  # network tables as numpy columns
        parts["cells"].append(pd.DataFrame(out["cells"]))
        parts["edges"].append(pd.DataFrame(out["edges"]))
    elapsed = time.perf_counter() - t0
    for name, p in parts.items():
        pd.concat(p, ignore_index=True).to_parquet(Path(tables_dir) / f"{name}.parquet")
    return elapsed


def stage_events(tables_dir, box):
    import pandas as pd

    from hexatissue.events import cell_event_stats, default_censor, t1_tables
    from hexatissue.track import lineage_table

    cells = pd.read_parquet(Path(tables_dir) / "cells.parquet")
    edges = pd.read_parquet(Path(tables_dir) / "edges.parquet")
    cells["track"] = cells["cell"]
    t0 = time.perf_counter()
    # both T1 tables, as analyze makes them (quartet T1s and the per-cell neighbour_events)
    events, _ = t1_tables(edges, cells, censor=default_censor(int(cells["frame"].max()) + 1), box=box)
    lineage_table(cells[["frame", "track"]], {}, cells["is_border"].to_numpy())
    cell_event_stats(events, cells)
    elapsed = time.perf_counter() - t0
    return elapsed, len(events), events["kind"].value_counts().to_dict()


def stage_flow(tables_dir, box):
    import pandas as pd

    from hexatissue.flow import cell_velocities, flow_fields, flow_summary
    from hexatissue.order import coarse_grain

    cells = pd.read_parquet(Path(tables_dir) / "cells.parquet")
    cells["track"] = cells["cell"]  # the movie's ids are its tracks
    grid = coarse_grain(cells, p=(6, 2), box=box)  # the order stage's field: not the flow's cost
    t0 = time.perf_counter()
    cells["vx"], cells["vy"] = cell_velocities(cells, box)
    flow = flow_fields(cells, grid, box)
    fields = time.perf_counter() - t0
    summary = flow_summary(cells, box)
    return fields, time.perf_counter() - t0, float(flow["valid"].mean()), summary


def stage_analyze(path, n_frames, box, workers):
    from hexatissue import OrderOptions, analyze

    stack = RawStack(path, n_frames)
    t0 = time.perf_counter()
    # networks, tracks and T1s (no Gamma_p fields: those are timed by bench_order.py)
    movie = analyze(stack, box=box, order=OrderOptions(fields=False), workers=workers, progress=False)
    elapsed = time.perf_counter() - t0
    return elapsed, len(movie.events)


def _child(fn, args, conn):
    base = _rss_mb()
    result = fn(*args)
    conn.send((result, base, _maxrss_mb(), _maxrss_mb(resource.RUSAGE_CHILDREN)))
    conn.close()


def run_isolated(fn, *args):
    """Run ``fn(*args)`` in a forked process; returns (result, rss at start, peak rss, peak of its children) MB."""
    ctx = get_context("fork")
    parent, child = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=_child, args=(fn, args, child))
    proc.start()
    out = parent.recv()
    proc.join()
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=1000)
    ap.add_argument("--cells", type=int, default=440)
    ap.add_argument("--shape", type=int, nargs=2, default=(384, 403), metavar=("ROWS", "COLS"))
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--cache", default="/tmp/hexatissue_bench")
    args = ap.parse_args(argv)
    cache = Path(args.cache)
    path = cache / f"voronoi_{args.frames}x{args.cells}_{args.shape[0]}x{args.shape[1]}.npy"
    render(path, args.frames, args.cells, tuple(args.shape))
    box = Box(float(args.shape[1]), float(args.shape[0]))
    n = args.frames
    print(f"# bench_t1: {n} frames x {args.cells} cells, {args.shape[0]} x {args.shape[1]} px periodic")
    print(f"uptime before: {subprocess.run(['uptime'], capture_output=True, text=True).stdout.strip()}")
    print(f"cpus: {os.cpu_count()}, workers: {args.workers}")
    # warm the numba cache in this process's children (not timed)
    run_isolated(stage_analyze, path, 2, box, 1)

    rows = []
    med = lambda xs: float(np.median(xs))
    res = [run_isolated(stage_track, path, n) for _ in range(args.repeats)]
    rows.append(("track (1 process)", n, med([r[0] for r in res]), max(r[2] - r[1] for r in res), None))
    tables = cache / "tables"
    tables.mkdir(exist_ok=True)
    res = [run_isolated(stage_mesh, path, n, box, str(tables)) for _ in range(args.repeats)]
    rows.append(("mesh_from_labels (1 process)", n, med([r[0] for r in res]), max(r[2] - r[1] for r in res), None))
    res = [run_isolated(stage_events, str(tables), box) for _ in range(args.repeats)]
    rows.append(("events (both T1 tables) + lineage + stats", n, med([r[0][0] for r in res]), max(r[2] - r[1] for r in res), None))
    n_events, kinds = res[0][0][1], res[0][0][2]
    flow = None
    if Path(__file__).resolve().parents[1].joinpath("hexatissue", "flow").is_dir():  # trees without it: skipped
        res = [run_isolated(stage_flow, str(tables), box) for _ in range(args.repeats)]
        flow = res[0][0]
        rows.append(("flow: velocities + fields", n, med([r[0][0] for r in res]), max(r[2] - r[1] for r in res), None))
        rows.append(("flow: velocities + fields + statistics", n, med([r[0][1] for r in res]),
                     max(r[2] - r[1] for r in res), None))
    for frames in sorted({max(1, n // 4), max(1, n // 2), n}):
        reps = args.repeats if frames == n else 1
        res = [run_isolated(stage_analyze, path, frames, box, args.workers) for _ in range(reps)]
        rows.append((f"analyze ({args.workers} workers)", frames, med([r[0][0] for r in res]),
                     max(r[2] - r[1] for r in res), max(r[3] for r in res)))

    print()
    print("| stage | frames | time (s, median) | ms / frame | peak RSS increase, main (MB) | peak RSS, largest worker (MB) |")
    print("|---|---|---|---|---|---|")
    for name, frames, sec, mem, worker in rows:
        w = "" if worker is None else f"{worker:.0f}"
        print(f"| {name} | {frames} | {sec:.1f} | {1000 * sec / frames:.1f} | {mem:.0f} | {w} |")
    print(f"\nevents in the {n}-frame movie: {n_events} {kinds}")
    if flow is not None:
        print(f"flow: {100 * flow[2]:.1f} % of the grid nodes valid; {flow[3]}")
    print(f"uptime after: {subprocess.run(['uptime'], capture_output=True, text=True).stdout.strip()}")


if __name__ == "__main__":
    main()
