"""Report benchmark: peak memory of ``hexatissue report`` on a streamed results folder against the movie's length.

Goal: the report's peak does not grow with the movie (240 frames <= 1.25 x 40 frames), as for a
streamed ``analyze``.

The movie is ``bench_scale.py``'s: ``voronoi_movie(4800, (1024, 1024), F, periodic=False,
amplitude=0.3, seed=0)`` read from its cached zarr array (``--cache``; ``bench_scale.py`` renders it),
analysed with the default stages and ``workers=1`` into ``--work/results_F`` with ``out=`` (the tables
in Parquet parts), once per length.  Each report then runs in a fresh process, in one of two modes:

* ``lazy``: ``report(folder)``, which reads the folder with ``read_results(lazy=True)``: each section
  reads the columns it needs from the parts;
* ``whole``: ``report(read_results(folder, lazy=False))``: every table in memory first, as the report
  read its folder before it read columns.

Measured per section (and for the read): the process's resident memory at its start and its
high-water mark (``VmHWM``, reset at the section's start through ``/proc/self/clear_refs``), and
the wall time; the report's peak is the largest of them.  The machine's 1-minute load average is
recorded before the first run and after the last.

Usage::

    PYTHONPATH=$PWD python benchmarks/bench_report.py --frames 40 240 --modes lazy whole
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent


def _kb(key):
    return [int(line.split()[1]) for line in open("/proc/self/status") if line.startswith(key + ":")][0]


def _reset_peak():
    with open("/proc/self/clear_refs", "w") as fh:
        fh.write("5")


def _analyze(zarr_path, frames, folder):
    """The first ``frames`` frames of the cached movie, analysed into ``folder`` in parts."""
    import warnings

    import zarr

    from hexatissue import analyze

    array = zarr.open_array(str(zarr_path), mode="r")

    class Prefix:  # the first frames of the array, read one at a time
        shape, dtype, ndim = (frames,) + tuple(array.shape[1:]), array.dtype, 3

        def __getitem__(self, t):
            return array[int(t)]

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        analyze(Prefix(), out=folder, workers=1, progress=False)


def _run_one(folder, mode, out):
    """One report in this process; prints a JSON line per phase."""
    import importlib
    import warnings
    from dataclasses import replace

    report_module = importlib.import_module("hexatissue.workflows.report")
    from hexatissue import read_results

    rows = []

    def measured(name, run, *args, **kwargs):
        _reset_peak()
        start, t0 = _kb("VmRSS"), time.time()
        result = run(*args, **kwargs)
        rows.append({"phase": name, "rss_start_mb": start / 1e3, "hwm_mb": _kb("VmHWM") / 1e3,
                     "wall_s": time.time() - t0})
        return result

    sections = report_module.report_sections

    def timed_sections(extra=(), stages=None):
        return [replace(s, run=lambda movie, report, _s=s: measured(
            f"{_s.run.__module__.rsplit('.', 1)[-1]}.{_s.run.__name__}", _s.run, movie, report))
            for s in sections(extra, stages)]

    report_module.report_sections = timed_sections
    reader = report_module.read_results
    report_module.read_results = lambda *a, **k: measured("read_results", reader, *a, **k)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if mode == "lazy":
            report_module.report(folder, out)
        else:
            movie = measured("read_results", read_results, folder, lazy=False)
            report_module.report(movie, out)
    for row in rows:
        print(json.dumps(row))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--frames", type=int, nargs="+", default=[40, 240])
    ap.add_argument("--modes", nargs="+", default=["lazy", "whole"], choices=["lazy", "whole"])
    ap.add_argument("--cache", type=Path, default=Path("/tmp/hexatissue-bench-scale"))
    ap.add_argument("--work", type=Path, default=Path("/tmp/hexatissue-bench-report"))
    ap.add_argument("--md", type=Path, default=HERE / "results_report.md")
    ap.add_argument("--run-one", nargs=3, metavar=("FOLDER", "MODE", "OUT"), help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.run_one:
        _run_one(Path(args.run_one[0]), args.run_one[1], Path(args.run_one[2]))
        return
    sys.path.insert(0, str(HERE))
    from bench_scale import build_zarr  # the scale benchmark's movie, rendered once into the cache

    zarr_path = build_zarr(args.cache, max(args.frames), 1024, 4800, 0.3, 0)[0]
    load_before = os.getloadavg()[0]
    results = {}
    for frames in args.frames:
        folder = args.work / f"results_{frames}"
        if not (folder / "metadata.json").exists():
            _analyze(zarr_path, frames, folder)
        for mode in args.modes:
            done = subprocess.run([sys.executable, __file__, "--run-one", str(folder), mode,
                                   str(args.work / f"report_{frames}_{mode}")], check=True, capture_output=True,
                                  text=True, env={**os.environ, "HEXATISSUE_PROGRESS": "0"})
            results[(frames, mode)] = [json.loads(line) for line in done.stdout.splitlines() if line.startswith("{")]
            peak = max(r["hwm_mb"] for r in results[(frames, mode)])
            print(f"{frames} frames, {mode}: peak {peak:.0f} MB", flush=True)
    load_after = os.getloadavg()[0]
    _write_md(args, results, load_before, load_after)


def _write_md(args, results, load_before, load_after):
    import platform

    lines = ["# Report: peak memory against the movie's length (`bench_report.py`)", "",
             f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, {os.cpu_count()}-core {platform.machine()}, "
             f"Python {platform.python_version()}; 1-minute load {load_before:.2f} before the first run, "
             f"{load_after:.2f} after the last (other users' jobs share the machine: the wall times are "
             f"inflated by the load, the memory is not). Command: `python benchmarks/bench_report.py --frames "
             f"{' '.join(map(str, args.frames))} --modes {' '.join(args.modes)}`.", "",
             "Movie: `voronoi_movie(4800, (1024, 1024), F, periodic=False, amplitude=0.3, seed=0)`, analysed "
             "with the default stages, `workers=1`, `out=` (tables in Parquet parts). `lazy`: `report(folder)` "
             "(each section reads its columns from the parts); `whole`: `report(read_results(folder, "
             "lazy=False))` (every table in memory first). Per phase: resident memory at its start and the "
             "process's high-water mark (VmHWM, reset at the start) in MB, wall seconds.", "",
             "## Peak of the whole report", "", "| mode | " + " | ".join(f"{f} frames (MB)" for f in args.frames)
             + f" | {args.frames[-1]} / {args.frames[0]} frames (goal <= 1.25) |", "|---|" + "---|" * (len(args.frames) + 1)]
    for mode in args.modes:
        peaks = [max(r["hwm_mb"] for r in results[(f, mode)]) for f in args.frames]
        lines.append(f"| {mode} | " + " | ".join(f"{p:.0f}" for p in peaks) + f" | {peaks[-1] / peaks[0]:.2f} |")
    for mode in args.modes:
        lines += ["", f"## Per phase, {mode}", "", "| phase | " + " | ".join(
            f"{f} frames: start / peak MB, s" for f in args.frames) + " |", "|---|" + "---|" * len(args.frames)]
        phases = [r["phase"] for r in results[(args.frames[0], mode)]]
        for k, phase in enumerate(phases):
            cells = [results[(f, mode)][k] for f in args.frames]
            lines.append(f"| {phase} | " + " | ".join(
                f"{c['rss_start_mb']:.0f} / {c['hwm_mb']:.0f}, {c['wall_s']:.1f}" for c in cells) + " |")
    args.md.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
