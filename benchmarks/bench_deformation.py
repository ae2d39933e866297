"""Benchmark: the deformation budget against the rest of ``analyze`` on the same movie.

A smoothly moving periodic Voronoi movie of 1,500 cells (``VoronoiMovie``,
about 14 px per cell, 100 frames by default; its cells exchange neighbours
now and then) is analysed once without the deformation stage; the budget
(:func:`hexatissue.deformation.deformation_budget`, tissue and grid regions)
is then timed on its tables, ``--repeats`` times (median), in wall time and
in CPU time of this process (the budget runs on one core: its CPU time is
what it costs on an idle core, whatever else shares the machine).  Printed:
the analysis time, the budget time, the budget per frame pair, and the
machine's load.  Usage::

    python benchmarks/bench_deformation.py [--cells 1500] [--frames 100] [--repeats 3]
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import hexatissue as ht  # noqa: E402
from hexatissue.deformation import deformation_budget  # noqa: E402
from hexatissue.synthetic import voronoi_movie  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cells", type=int, default=1500)
    parser.add_argument("--frames", type=int, default=100)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    side = int(round(np.sqrt(args.cells) * 14))
    movie = voronoi_movie(args.cells, (side, side), args.frames, periodic=True, seed=0)
    frames = np.stack([movie[t] for t in range(args.frames)])
    start = time.perf_counter()
    result = ht.analyze(frames, box=movie.box, progress=False, workers=1)
    analyze = time.perf_counter() - start
    deformation_budget(result.cells[result.cells["frame"] < 3], result.vertices, result.cell_vertices,
                       result.lineage, result.events, box=movie.box)  # first call: imports
    pairs = args.frames - 1
    for label, grid in (("tissue only", None), ("tissue + grid regions", result.grid)):
        wall, cpu = [], []
        for _ in range(args.repeats):
            start, start_cpu = time.perf_counter(), time.process_time()
            table, _ = deformation_budget(result.cells, result.vertices, result.cell_vertices, result.lineage,
                                          result.events, box=movie.box, grid=grid)
            wall.append(time.perf_counter() - start)
            cpu.append(time.process_time() - start_cpu)
        if grid is None:
            tissue = table[table["region"] == "tissue"]
            print(f"{args.cells} cells ({side} x {side} px, periodic), {args.frames} frames; {len(result.events)} T1 "
                  f"events; {int(tissue['n_triangles'].mean())} triangles per frame")
            print(f"analyze (1 worker, no budget): {analyze:.2f} s wall")
        else:
            label += f" ({int((table['region'] == 'grid').sum() / pairs)} per pair)"
        w, c = float(np.median(wall)), float(np.median(cpu))
        print(f"deformation budget, {label}: {1000 * c / pairs:.1f} ms CPU per frame pair ({1000 * w / pairs:.1f} ms "
              f"wall; medians of {args.repeats}; {100 * w / analyze:.0f} % of analyze's wall time)")
    print(f"max |closure|: {tissue[['closure_xx', 'closure_xy', 'closure_iso']].abs().to_numpy().max():.2g}")
    print(f"load: {os.getloadavg()}")


if __name__ == "__main__":
    main()
