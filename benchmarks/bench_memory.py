"""Memory acceptance benchmark: ``hexatissue analyze`` on a long label stack streams its frames.

Issue text: "the stack must not cost more than a few frames' worth plus its tables".

The script builds (once, cached) a T-frame S x S uint16 TIFF label stack of a slowly moving,
jittered Voronoi tissue (``hexatissue.synthetic.voronoi_movie``, open image) and a 1-frame TIFF of
its first frame; both are written page by page with ``tifffile.TiffWriter``, so building them does
not hold the stack in memory either.  It then runs, each in a fresh subprocess,

* ``hexatissue analyze STACK --out D --workers W`` for every W of ``--workers``,
* ``hexatissue analyze FIRST --out D1`` (one frame: always runs in the calling process),
* the same in a process that first analysed a small movie (``one frame, warm``: the scripted T1
  movie of :func:`hexatissue.synthetic.t1_movie`, 36 frames of 260 x 360 px), then reset its
  high-water mark (``/proc/self/clear_refs``): a movie loads code a single frame never runs
  (tracking, defect tracks, the T1 kernels: numba functions and modules, ~10-20 MB that do not
  grow with the movie), so this is the one frame with the movie's fixed cost paid; only its main
  peak is used (the polled tree figures include the warm-up),
* ``hexatissue analyze SHORT --out D2 --workers W``, SHORT = the first ``--ref-frames`` (10)
  frames: the same pool as the long run, so the difference of the two is what the movie's length
  costs, with the pool's fixed cost cancelled,
* the old CLI's way of reading: ``tifffile.imread(STACK)`` (the whole stack in memory),

and records for each

* wall time of the subprocess (imports included),
* main-process peak RSS: the kernel's high-water mark of the process, ``VmHWM`` of
  ``/proc/self/status`` read by the process itself at its end (not ``getrusage(RUSAGE_SELF)``:
  Python's subprocess starts children with vfork, and Linux carries the parent's high-water mark
  over ``exec`` into ``ru_maxrss``, so that would report this script's own size); the largest pool
  worker's peak is its polled ``VmHWM``,
* tree peak RSS: the largest *sum* of RSS over the process and all its descendants, polled every
  ``--poll`` s (50 ms) from ``/proc/PID/status`` -- what ``top`` would add up.  Forked pool
  workers share their parent's pages copy-on-write and RSS counts shared pages in every process,
  so the script also polls the tree's summed PSS (shared pages split between their users,
  ``/proc/PID/smaps_rollup``), which is what the machine really pays,
* the output tables: bytes on disk (every file in D) and in memory (``read_results(D)``, then
  ``sum(table.memory_usage(deep=True).sum())``), and bytes per cell-frame.

The criterion is checked as ``tree peak(stack) - tree peak(one frame) <= tables in memory +
a few frames``, a few frames = (2 x workers in flight + 2) raw frames of S x S x 2 bytes, and
again with the short stack as the reference (``tree peak(stack) - tree peak(short) <= tables(stack)
- tables(short) + a few frames``), for the polled RSS sum, the PSS sum and the main process, and
with the warm one frame as the reference (main process only).  The issue's criterion is the
first (a cold single frame); the other two separate what the movie's length costs from what
being a movie at all costs.

Usage::

    PYTHONPATH=$PWD python benchmarks/bench_memory.py                  # 200 x 1024^2, ~2,500 cells
    PYTHONPATH=$PWD python benchmarks/bench_memory.py --frames 20 --size 512   # quick check
    PYTHONPATH=$PWD python benchmarks/bench_memory.py --workers 1 --stages     # RSS per stage of each run

Default (200 frames, 1024^2, workers 2 and 1): 6.5 minutes on the shared 2-core machine at load
3-8, plus about 2 minutes the first time to build the 419 MB stack.  Under load the sampler
manages ~7 samples/s, not 20: the tree peak can miss a spike shorter than that; the main peak
(VmHWM) cannot.  Results: ``benchmarks/results_memory.md``.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from _timing import pss_kb, status_kb  # benchmarks/_timing.py

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
MB = 1e6

#: Runs the hexatissue CLI in this subprocess and reports its own and its children's peak RSS.
CLI_RUNNER = r"""
import json, resource, sys, time
from hexatissue.cli import main
if sys.argv[2] == "--warm-up":  # a small movie first, then the high-water mark reset to the RSS: see WARM_UP
    import gc
    from hexatissue._system import release_freed_memory
    main(["analyze", sys.argv[3], "--out", sys.argv[4], "--workers", "1"])  # its code in this process
    gc.collect()
    release_freed_memory()
    with open("/proc/self/clear_refs", "w") as fh:
        fh.write("5")
    del sys.argv[2:5]
    globals().get("STAGES", []).clear()  # with --stages: only the measured run's stages
t0 = time.perf_counter()
rc = main(sys.argv[2:])
wall = time.perf_counter() - t0
hwm = [int(l.split()[1]) for l in open("/proc/self/status") if l.startswith("VmHWM:")][0]
with open(sys.argv[1], "w") as fh:
    json.dump({"rc": rc, "wall": wall, "self_hwm_kb": hwm,
               "children_maxrss_kb": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss}, fh)
sys.exit(rc)
"""

#: The CLI run of CLI_RUNNER with every stage of the analysis (and every table written) wrapped:
#: RSS at its start and end, and the high-water mark during it (reset by /proc/self/clear_refs
#: at its start; an enclosing stage keeps the larger of its own and its inner stages' marks).
STAGES_RUNNER = r"""
import json, sys
import hexatissue.cli as cli_mod
import hexatissue.io as io_mod
import hexatissue.pipeline as pipeline
import hexatissue.stages as stages

STAGES, OPEN = [], []

def _kb(key):
    return [int(l.split()[1]) for l in open("/proc/self/status") if l.startswith(key + ":")][0]

def _fold():
    hwm = _kb("VmHWM")
    for rec in OPEN:
        rec["hwm_kb"] = max(rec["hwm_kb"], hwm)

def wrapped(module, name, label=None):
    func = getattr(module, name)
    def call(*args, **kw):
        _fold()
        what = label(args) if label else name
        rec = {"stage": what, "rss_start_kb": _kb("VmRSS"), "hwm_kb": 0}
        OPEN.append(rec)
        with open("/proc/self/clear_refs", "w") as fh:
            fh.write("5")
        try:
            return func(*args, **kw)
        finally:
            _fold()
            OPEN.pop()
            rec["rss_end_kb"] = _kb("VmRSS")
            STAGES.append(rec)
    setattr(module, name, call)

for name in ("_extract", "release_freed_memory", "Movie"):
    wrapped(pipeline, name)
# the movie stages' functions, looked up by name in hexatissue.stages when the stages run
for name in ("cells_with_tracks", "lineage_table", "tracking_summary", "t1_tables", "cell_event_stats",
             "events_summary", "link_movie_defects"):
    wrapped(stages, name)
wrapped(pipeline.Rows, "table", label=lambda args: "table " + str(args[1]))
wrapped(cli_mod, "summary_line")
wrapped(io_mod, "write_table", label=lambda args: "write " + str(args[1]).rsplit("/", 1)[-1])
report = sys.argv[1]
sys.argv[1] = report + ".cli"
try:
    exec(CLI)
finally:
    rep = json.load(open(report + ".cli"))
    rep["stages"] = STAGES
    json.dump(rep, open(report, "w"))
"""

#: The old CLI's reading: the whole stack with tifffile.imread.
IMREAD_RUNNER = r"""
import json, resource, sys, time
t0 = time.perf_counter()
import tifffile
stack = tifffile.imread(sys.argv[2])
wall = time.perf_counter() - t0
hwm = [int(l.split()[1]) for l in open("/proc/self/status") if l.startswith("VmHWM:")][0]
with open(sys.argv[1], "w") as fh:
    json.dump({"rc": 0, "wall": wall, "nbytes": int(stack.nbytes), "shape": list(stack.shape),
               "self_hwm_kb": hwm, "children_maxrss_kb": 0}, fh)
"""


# ----------------------------------------------------------------------------------------------
# the input stacks
# ----------------------------------------------------------------------------------------------
def build_inputs(folder: Path, n_frames: int, size: int, n_cells: int, amplitude: float, seed: int,
                 ref_frames: int):
    """Paths of the cached stack, its first frame and its first ``ref_frames`` frames, built page by page."""
    import tifffile

    from hexatissue.synthetic import voronoi_movie

    folder.mkdir(parents=True, exist_ok=True)
    stem = f"voronoi_{n_frames}x{size}x{size}_{n_cells}cells_a{amplitude:g}_s{seed}"
    stack, first, short = folder / f"{stem}.tif", folder / f"{stem}_first.tif", folder / f"{stem}_first{ref_frames}.tif"
    if stack.exists() and first.exists() and short.exists():
        return stack, first, short, 0.0
    movie = voronoi_movie(n_cells, (size, size), n_frames, periodic=False, amplitude=amplitude, seed=seed)
    if movie.n_cells > np.iinfo(np.uint16).max:
        raise SystemExit(f"{movie.n_cells} cells do not fit uint16 labels")
    t0 = time.perf_counter()
    tmp, tmp_short = stack.with_suffix(".tif.part"), short.with_suffix(".tif.part")
    with tifffile.TiffWriter(tmp) as tw, tifffile.TiffWriter(tmp_short) as tw_short:
        for t in range(n_frames):
            frame = movie[t].astype(np.uint16)
            tw.write(frame, contiguous=True)  # one page per frame, one contiguous T x Y x X series
            if t < ref_frames:
                tw_short.write(frame, contiguous=True)
            if t == 0:
                with tifffile.TiffWriter(first) as one:
                    one.write(frame)
            if (t + 1) % 50 == 0:
                print(f"  built {t + 1}/{n_frames} frames ({time.perf_counter() - t0:.0f} s)", flush=True)
    tmp.replace(stack)
    tmp_short.replace(short)
    return stack, first, short, time.perf_counter() - t0


def build_warm_up(folder: Path) -> Path:
    """The cached warm-up movie of the ``one frame, warm`` case: :func:`hexatissue.synthetic.t1_movie`, open image.

    36 frames of 260 x 360 px with scripted T1s, divisions-free tracking,
    defects that move: every movie-level stage (tracking, defect tracks,
    the T1 kernels, the event statistics) runs on it, so its code is loaded.
    """
    import tifffile

    from hexatissue.synthetic import t1_movie

    path = folder / "warm_up_t1_movie.tif"
    if not path.exists():
        tmp = path.with_suffix(".tif.part")
        tifffile.imwrite(tmp, np.asarray(t1_movie(periodic=False).labels).astype(np.uint16))
        tmp.replace(path)
    return path


# ----------------------------------------------------------------------------------------------
# measuring a process tree
# ----------------------------------------------------------------------------------------------
class TreeSampler(threading.Thread):
    """Polls a process and its descendants; keeps the peaks of the main RSS and of the tree's sums."""

    def __init__(self, pid: int, interval: float):
        super().__init__(daemon=True)
        import psutil

        self.proc = psutil.Process(pid)
        self.interval = interval
        self.stop = threading.Event()
        self.peak = {"main_rss": 0, "main_anon": 0, "main_file": 0, "tree_rss": 0, "tree_anon": 0, "tree_pss": 0,
                     "max_procs": 0}
        self.hwm = {}  # pid -> largest VmHWM seen (the kernel's own high-water mark of that process)
        self.samples = 0

    def run(self):
        while not self.stop.is_set():
            self.sample()
            self.stop.wait(self.interval)

    def sample(self):
        import psutil

        try:
            procs = [self.proc] + self.proc.children(recursive=True)
        except psutil.Error:
            return
        rss = anon = pss = 0
        main = None
        for p in procs:
            try:
                s = status_kb(p.pid)
                pss += pss_kb(p.pid)
            except (OSError, ValueError):
                continue  # the process ended between listing and reading
            if "VmRSS" not in s:
                continue  # a zombie
            rss += s["VmRSS"]
            self.hwm[p.pid] = max(self.hwm.get(p.pid, 0), s.get("VmHWM", 0))
            anon += s.get("RssAnon", 0)
            if p.pid == self.proc.pid:
                main = s
        pk = self.peak
        if main is not None:
            pk["main_rss"] = max(pk["main_rss"], main["VmRSS"])
            if main["VmRSS"] >= pk["main_rss"]:
                pk["main_anon"], pk["main_file"] = main.get("RssAnon", 0), main.get("RssFile", 0)
        pk["tree_rss"] = max(pk["tree_rss"], rss)
        pk["tree_anon"] = max(pk["tree_anon"], anon)
        pk["tree_pss"] = max(pk["tree_pss"], pss)
        pk["max_procs"] = max(pk["max_procs"], len(procs))
        self.samples += 1


def measure(cmd, report: Path, interval: float, env, cwd) -> dict:
    """Run ``cmd`` (which writes ``report``) in ``cwd``, sampling its process tree; peaks in MB.

    ``cwd`` is the checkout whose package is measured: ``python -c`` puts
    the working directory first on ``sys.path``, before ``PYTHONPATH``.
    """
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, env=env, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    sampler = TreeSampler(proc.pid, interval)
    sampler.start()
    output = proc.communicate()[0]
    wall = time.perf_counter() - t0
    sampler.stop.set()
    sampler.join()
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(map(str, cmd))} failed ({proc.returncode}):\n{output}")
    rep = json.loads(report.read_text())
    kb = 1024 / MB
    return {
        "wall_s": wall,
        "inner_wall_s": rep["wall"],
        # the main process's VmHWM, read by itself at its end: exact (with --stages: the largest stage's)
        "main_peak_mb": max([rep["self_hwm_kb"]] + [st["hwm_kb"] for st in rep.get("stages", [])]) * kb,
        # the largest pool worker's VmHWM as polled (0: no worker)
        "worker_peak_mb": max([v for pid, v in sampler.hwm.items() if pid != proc.pid], default=0) * kb,
        "polled_main_peak_mb": sampler.peak["main_rss"] * kb,
        "main_anon_at_peak_mb": sampler.peak["main_anon"] * kb,
        "main_file_at_peak_mb": sampler.peak["main_file"] * kb,
        "tree_peak_mb": sampler.peak["tree_rss"] * kb,
        "tree_anon_peak_mb": sampler.peak["tree_anon"] * kb,
        "tree_pss_peak_mb": sampler.peak["tree_pss"] * kb,
        "max_procs": sampler.peak["max_procs"],
        "samples": sampler.samples,
        "output": output.strip().splitlines()[-1] if output.strip() else "",
        **{k: v for k, v in rep.items() if k in ("nbytes", "shape", "stages")},
    }


def table_sizes(out: Path) -> dict:
    from hexatissue import read_results

    movie = read_results(out)
    tables = movie.tables
    mem = {name: int(t.memory_usage(deep=True).sum()) for name, t in tables.items()}
    disk = sum(p.stat().st_size for p in out.rglob("*") if p.is_file())
    n_cell_frames = len(movie.cells)
    return {"tables_mb": sum(mem.values()) / MB, "disk_mb": disk / MB, "cell_frames": n_cell_frames,
            "bytes_per_cell_frame": sum(mem.values()) / max(n_cell_frames, 1),
            "table_mb": {k: v / MB for k, v in mem.items()}, "rows": {k: len(t) for k, t in tables.items()}}


def _load():
    return os.getloadavg()


# ----------------------------------------------------------------------------------------------
def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--frames", type=int, default=200, help="frames of the stack (default 200)")
    ap.add_argument("--size", type=int, default=1024, help="frame rows = cols (default 1024)")
    ap.add_argument("--cells", type=int, help="cells per frame (default 2500 x (size / 1024)^2)")
    ap.add_argument("--amplitude", type=float, default=0.3, help="seed motion, in cell spacings (default 0.3)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--workers", type=int, nargs="+", default=[2, 1], help="--workers values to run (default 2 1)")
    ap.add_argument("--ref-frames", type=int, default=10, help="frames of the short reference stack (default 10)")
    ap.add_argument("--cache", type=Path, help="folder for the input TIFFs (default: TMPDIR/hexatissue-bench-memory)")
    ap.add_argument("--poll", type=float, default=0.05, help="sampling interval of the process tree, s (default 0.05)")
    ap.add_argument("--no-baseline", action="store_true", help="skip the tifffile.imread baseline")
    ap.add_argument("--json", type=Path, help="also write every number to this JSON file")
    ap.add_argument("--stages", action="store_true",
                    help="also record RSS and high-water mark per stage of each run (the main peak is then the "
                         "largest stage mark: the kernel's own is reset at every stage)")
    args = ap.parse_args(argv)

    import hexatissue

    pkg = Path(hexatissue.__file__).resolve().parent
    if REPO not in pkg.parents:
        print(f"warning: hexatissue is imported from {pkg}, not from this checkout ({REPO}); "
              f"run with PYTHONPATH={REPO}", file=sys.stderr)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(pkg.parent)] + [p for p in
                                                       os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]))
    n_cells = args.cells or max(2, round(2500 * (args.size / 1024) ** 2))
    cache = args.cache or Path(tempfile.gettempdir()) / "hexatissue-bench-memory"
    print(f"hexatissue {hexatissue.__version__} from {pkg}; load {_load()[0]:.2f}, {os.cpu_count()} cores")
    ref_frames = max(1, min(args.ref_frames, args.frames))
    stack, first, short, build_s = build_inputs(cache, args.frames, args.size, n_cells, args.amplitude, args.seed,
                                                ref_frames)
    frame_mb = args.size * args.size * 2 / MB
    print(f"stack {stack} ({stack.stat().st_size / MB:.0f} MB on disk; "
          + (f"built in {build_s:.0f} s" if build_s else "cached") + f"), one frame = {frame_mb:.2f} MB")

    work = Path(tempfile.mkdtemp(prefix="bench-memory-"))
    results = {"config": {"frames": args.frames, "size": args.size, "cells": n_cells, "amplitude": args.amplitude,
                          "seed": args.seed, "frame_mb": frame_mb, "stack": str(stack),
                          "python": sys.version.split()[0], "cores": os.cpu_count(),
                          "date": time.strftime("%Y-%m-%d %H:%M %Z")},
               "runs": []}
    try:
        cases = [("one frame", first, None), ("one frame, warm", first, None)]
        for w in args.workers:
            cases += [(f"first {ref_frames}", short, w), ("stack", stack, w)]
        for name, path, workers in cases:
            out = work / f"out_{name.replace(' ', '_')}_{workers}"
            report = work / "report.json"
            runner = f"CLI = {CLI_RUNNER!r}\n" + STAGES_RUNNER if args.stages else CLI_RUNNER
            cmd = [sys.executable, "-c", runner, str(report)]
            if name == "one frame, warm":
                cmd += ["--warm-up", str(build_warm_up(cache)), str(work / "out_warm_up")]
            cmd += ["analyze", str(path), "--out", str(out)]
            if workers is not None:
                cmd += ["--workers", str(workers)]
            load_before = _load()[0]
            run = measure(cmd, report, args.poll, env, pkg.parent)
            run.update(table_sizes(out), case=name, workers=workers, load_before=load_before,
                       load_after=_load()[0])
            results["runs"].append(run)
            print(f"{name:9s} workers={workers}: {run['wall_s']:6.1f} s, main peak {run['main_peak_mb']:6.0f} MB "
                  f"(anon {run['main_anon_at_peak_mb']:.0f}, file {run['main_file_at_peak_mb']:.0f}), worker peak "
                  f"{run['worker_peak_mb']:.0f} MB, "
                  f"tree peak {run['tree_peak_mb']:6.0f} MB (PSS {run['tree_pss_peak_mb']:.0f} MB), "
                  f"tables {run['tables_mb']:.1f} MB in memory / {run['disk_mb']:.1f} MB on disk, "
                  f"{run['bytes_per_cell_frame']:.0f} B per cell-frame; load {load_before:.2f} -> "
                  f"{run['load_after']:.2f}", flush=True)
            for st in run.get("stages", []):
                start, end, hwm = (st[k] * 1024 / MB for k in ("rss_start_kb", "rss_end_kb", "hwm_kb"))
                print(f"    {st['stage']:28s} RSS {start:6.1f} -> {end:6.1f} MB, high-water mark {hwm:6.1f} MB",
                      flush=True)
            shutil.rmtree(out, ignore_errors=True)
        if not args.no_baseline:
            report = work / "report.json"
            load_before = _load()[0]
            run = measure([sys.executable, "-c", IMREAD_RUNNER, str(report), str(stack)], report, args.poll, env,
                          pkg.parent)
            run.update(case="tifffile.imread (old CLI)", workers=None, load_before=load_before,
                       load_after=_load()[0])
            results["runs"].append(run)
            print(f"baseline tifffile.imread: {run['wall_s']:.1f} s, peak {run['main_peak_mb']:.0f} MB "
                  f"(array {run['nbytes'] / MB:.0f} MB)", flush=True)
    finally:
        shutil.rmtree(work, ignore_errors=True)

    # the acceptance criterion
    runs = results["runs"]
    single = next(r for r in runs if r["case"] == "one frame")
    warm = next(r for r in runs if r["case"] == "one frame, warm")
    verdicts = []
    for r in runs:
        if r["case"] != "stack":
            continue
        few = 2 * r["workers"] + 2
        short_run = next(q for q in runs if q["case"] == f"first {ref_frames}" and q["workers"] == r["workers"])
        for ref in (single, warm, short_run):
            allowed = r["tables_mb"] - (ref["tables_mb"] if ref is short_run else 0) + few * frame_mb
            # the warm-up's own peak is in the polled tree figures of the warm case: only its main peak (VmHWM,
            # reset after the warm-up) is the one frame's
            for what in ("main_peak_mb",) if ref is warm else ("tree_peak_mb", "tree_pss_peak_mb", "main_peak_mb"):
                extra = r[what] - ref[what]
                ok = extra <= allowed
                verdicts.append({"workers": r["workers"], "reference": ref["case"], "measure": what,
                                 "extra_mb": extra, "allowed_mb": allowed, "ok": ok})
                print(f"criterion workers={r['workers']} {what:16s}: stack - {ref['case']:15s} = {extra:6.1f} MB vs "
                      f"tables {allowed - few * frame_mb:.1f} + {few} frames {few * frame_mb:.1f} = {allowed:.1f} MB:"
                      f" {'holds' if ok else 'FAILS'}")
    results["criterion"] = verdicts
    print(f"load {_load()[0]:.2f}")
    if args.json:
        args.json.write_text(json.dumps(results, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
