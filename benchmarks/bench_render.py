"""Speed of the benchmark renderer: frames per second for 512 x 512 frames with ~300 cells, one core.

    PYTHONPATH=$PWD python benchmarks/bench_render.py [--frames 20] [--repeats 5] [--cells 300] [--size 512]
        [--against OTHER_CHECKOUT]

The truth is a periodic moving Voronoi tissue (``truth_from_voronoi(cells, (size, size), frames)``;
its analysis is not timed).  Timed: ``Renderer(truth, options).frame(t)`` for every frame (drawing,
cytoplasm, PSF, drift, bleaching, noise, uint16), after one warm-up frame; OpenCV limited to one
thread (``cv2.setNumThreads(1)``).  Configurations: the default options (exact Poisson shot noise),
the normal approximation of the shot noise, and every feature on (curvature, Airy PSF, drift,
bleaching, nuclear channel).  Prints the median frames/s of the repeats (and the best) by wall time,
and by the process's CPU time (on a loaded machine the better estimate of a quiet core, since the
renderer is single-threaded), with the machine, date and ``uptime`` load; results go to
benchmarks/results_render.md by hand.  Timings are never asserted.

``--against DIR`` times the hexatissue of another checkout (e.g. a worktree of main) in the same
process, pass for pass alternating with this one (the order swapped every repeat), so both see the
same load; it adds the median of the per-repeat CPU-time ratios (this / other).
"""
from __future__ import annotations

import argparse
import datetime
import importlib
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent

import cv2  # noqa: E402

CONFIGS = {
    "default (Poisson)": {},
    "gaussian shot noise": dict(shot_noise="gaussian"),
    "all features (Poisson)": dict(curvature=0.05, psf="airy", drift=0.5, bleach_rate=0.01, nuclei=True),
    "all features (gaussian)": dict(curvature=0.05, psf="airy", drift=0.5, bleach_rate=0.01, nuclei=True,
                                    shot_noise="gaussian"),
}


#: the roots of the Checkouts made
_ROOTS = set()


def _ours(name):
    return name == "hexatissue" or name.startswith("hexatissue.")


class Checkout:
    """``hexatissue.benchmark`` of the checkout at ``root`` (``.benchmark``), importable beside another one.

    Its modules are kept aside and put back into ``sys.modules`` by
    :meth:`use` (hexatissue imports some modules inside functions, at call
    time), so two checkouts can be timed in one process.
    """

    def __init__(self, root):
        for name in [m for m in sys.modules if _ours(m)]:
            del sys.modules[name]
        sys.path.insert(0, str(root))
        try:
            self.benchmark = importlib.import_module("hexatissue.benchmark")
            importlib.import_module("hexatissue.benchmark.render")
        finally:
            sys.path.remove(str(root))
        self.root = root
        _ROOTS.add(str(root))
        self._modules = {m: mod for m, mod in sys.modules.items() if _ours(m)}

    def use(self):
        for name in [m for m in sys.modules if _ours(m)]:
            del sys.modules[name]
        sys.modules.update(self._modules)
        sys.path[:] = [str(self.root)] + [p for p in sys.path if p not in _ROOTS]  # for modules imported now
        return self.benchmark


def one_pass(checkout, renderer):
    """Frames/s of one pass over every frame: (wall, CPU time)."""
    checkout.use()
    start, start_cpu = time.perf_counter(), time.process_time()
    for t in range(len(renderer)):
        renderer.frame(t)
    return len(renderer) / (time.perf_counter() - start), len(renderer) / (time.process_time() - start_cpu)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=20)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--cells", type=int, default=300)
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--against", type=Path, help="another checkout whose hexatissue is timed alternately")
    args = ap.parse_args(argv)
    cv2.setNumThreads(1)
    versions = {"this": Checkout(HERE.parent)}
    if args.against:
        versions["against"] = Checkout(args.against.resolve())
    truths = {name: c.use().truth_from_voronoi(args.cells, (args.size, args.size), args.frames, seed=0,
                                               progress=False) for name, c in versions.items()}
    truth = truths["this"]
    edges = len(truth.movie.edges) / len(truth)
    print(f"## bench_render.py — {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC, "
          f"{platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, "
          f"numpy {np.__version__}, OpenCV {cv2.__version__}")
    print(f"\n{args.frames} frames of {args.size} x {args.size} px, {args.cells} cells ({edges:.0f} junctions per "
          f"frame), periodic; median (best) of {args.repeats} repeats, one thread"
          + "".join(f"; {name}: {c.benchmark.__file__}" for name, c in versions.items()) + "\n")
    print("| options | version | frames/s, wall: median (best) | frames/s, CPU time: median | CPU-time ratio "
          "this / against | load before | load after |")
    print("|---|---|---|---|---|---|---|")
    for config, fields in CONFIGS.items():
        before = os.getloadavg()[0]
        renderers = {}
        for name, c in versions.items():
            b = c.use()
            renderers[name] = b.Renderer(truths[name], b.RenderOptions(**fields), seed=1)
            renderers[name].frame(0)  # warm-up
        rates = {name: [] for name in versions}
        for repeat in range(args.repeats):
            for name in (list(versions) if repeat % 2 == 0 else list(versions)[::-1]):
                rates[name].append(one_pass(versions[name], renderers[name]))
        cpu = {name: np.array(r)[:, 1] for name, r in rates.items()}
        ratio = f"{np.median(cpu['this'] / cpu['against']):.2f}" if args.against else ""
        for name, r in rates.items():
            wall = np.array(r)[:, 0]
            print(f"| {config} | {name} | {np.median(wall):.1f} ({wall.max():.1f}) | {np.median(cpu[name]):.1f} | "
                  f"{ratio if name == 'this' else ''} | {before:.1f} | {os.getloadavg()[0]:.1f} |", flush=True)


if __name__ == "__main__":
    main()
