"""Speed of the benchmark renderer: frames per second for 512 x 512 frames with ~300 cells, one core.

    PYTHONPATH=$PWD python benchmarks/bench_render.py [--frames 20] [--repeats 5] [--cells 300] [--size 512]

The truth is a periodic moving Voronoi tissue (``truth_from_voronoi(cells, (size, size), frames)``;
its analysis is not timed).  Timed: ``Renderer(truth, options).frame(t)`` for every frame (drawing,
cytoplasm, PSF, drift, bleaching, noise, uint16), after one warm-up frame; OpenCV limited to one
thread (``cv2.setNumThreads(1)``).  Configurations: the default options (exact Poisson shot noise),
the normal approximation of the shot noise, and every feature on (curvature, Airy PSF, drift,
bleaching, nuclear channel).  Prints the median frames/s of the repeats (and the best) by wall time,
and by the process's CPU time (on a loaded machine the better estimate of a quiet core, since the
renderer is single-threaded), with the machine, date and ``uptime`` load; results go to
benchmarks/README.md by hand.  Timings are never asserted.
"""
from __future__ import annotations

import argparse
import datetime
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

import cv2  # noqa: E402

from hexatissue.benchmark import Renderer, RenderOptions, truth_from_voronoi  # noqa: E402

CONFIGS = {
    "default (Poisson)": RenderOptions(),
    "gaussian shot noise": RenderOptions(shot_noise="gaussian"),
    "all features (Poisson)": RenderOptions(curvature=0.05, psf="airy", drift=0.5, bleach_rate=0.01, nuclei=True),
    "all features (gaussian)": RenderOptions(curvature=0.05, psf="airy", drift=0.5, bleach_rate=0.01, nuclei=True,
                                             shot_noise="gaussian"),
}


def frames_per_second(renderer, repeats):
    """Median and best frames/s over ``repeats`` passes, by wall time and by this process's CPU time."""
    renderer.frame(0)  # warm-up
    wall, cpu = [], []
    for _ in range(repeats):
        start, start_cpu = time.perf_counter(), time.process_time()
        for t in range(len(renderer)):
            renderer.frame(t)
        wall.append(len(renderer) / (time.perf_counter() - start))
        cpu.append(len(renderer) / (time.process_time() - start_cpu))
    return float(np.median(wall)), float(np.max(wall)), float(np.median(cpu))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=20)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--cells", type=int, default=300)
    ap.add_argument("--size", type=int, default=512)
    args = ap.parse_args(argv)
    cv2.setNumThreads(1)
    truth = truth_from_voronoi(args.cells, (args.size, args.size), args.frames, seed=0, progress=False)
    edges = len(truth.movie.edges) / len(truth)
    print(f"## bench_render.py — {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC, "
          f"{platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, "
          f"numpy {np.__version__}, OpenCV {cv2.__version__}")
    print(f"\n{args.frames} frames of {args.size} x {args.size} px, {args.cells} cells ({edges:.0f} junctions per "
          f"frame), periodic; median (best) of {args.repeats} repeats, one thread\n")
    print("| options | frames/s, wall: median (best) | frames/s, CPU time: median | load before | load after |")
    print("|---|---|---|---|---|")
    for name, options in CONFIGS.items():
        before = os.getloadavg()[0]
        median, best, cpu = frames_per_second(Renderer(truth, options, seed=1), args.repeats)
        print(f"| {name} | {median:.1f} ({best:.1f}) | {cpu:.1f} | {before:.1f} | {os.getloadavg()[0]:.1f} |",
              flush=True)


if __name__ == "__main__":
    main()
