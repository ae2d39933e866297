"""Scale benchmark: peak memory, time and throughput of ``analyze`` against the movie's length.

Goals: peak memory independent of the movie's length (240 frames <= 1.25x 40 frames); 10^7
cell-frames analysed on this 2-core, 24 GB machine within 8 GB; throughput per core within 10 % of
the in-memory path.

The movie is :func:`hexatissue.synthetic.voronoi_movie` (seeds on Lissajous orbits, open image, label
``k`` = seed ``k - 1`` in every frame: the exact tracking truth is one track per seed), at a fixed
frame size (default 1024 x 1024 px, 4,800 cells: a notum-sized field of view) and increasing length.  Two inputs:

* ``--input zarr`` (default): the frames are rendered once, one at a time, into a cached zarr array
  of one chunk per frame (``--cache``); each run reads the first ``F`` frames through a lazy
  array-like (``_Prefix``: ``shape``, ``dtype`` and ``[t]``, which :func:`hexatissue.open_source`
  reads frame by frame), so the run pays neither the rendering nor more than one frame of input;
* ``--input lazy``: the :class:`~hexatissue.synthetic.VoronoiMovie` itself, rendered frame by frame
  in the analysing process (what a user's lazy generator costs; the rendering's CPU is in the figures).

Each run is a fresh subprocess that calls ``analyze`` (default stages, or ``--deformation``) with
``workers=1``, ``workers=2`` or ``client=`` a ``dask.distributed.LocalCluster`` of 2 single-threaded
worker processes (started before the clock), then writes the results folder.  Measured:

* wall time of ``analyze`` and of the write;
* CPU time of the whole process tree in that window, from the polled per-process CPU times
  (``psutil``; a process that ended counts with its last sample, at most ``--poll`` s short);
* throughput: cell-frames per tree CPU-second, and per wall-second;
* peak memory of the process tree: the largest sum of RSS and of PSS (``/proc/PID/smaps_rollup``:
  shared pages split between their users, what the machine pays) over the process and all its
  descendants, polled every ``--poll`` s; and the main process's own ``VmHWM``;
* the same peaks per phase: ``frames`` (the frame loop and the tables' assembly), each movie stage
  (``tracks``, ``tissue flow``, ``T1 events``, ``cell events``, ``deformation budget``, ...),
  ``Movie`` (the result object) and ``write``; the runner logs each phase's start time and resets the
  main process's high-water mark there (``/proc/self/clear_refs``), so the main ``VmHWM`` per phase is
  exact and the tree peaks are the samples that fall in the phase's window;
* correctness against the truth: cells per frame (the seeds) and tracks (one per seed).

Memory is then fitted per configuration as ``peak = a + b * frames`` (least squares over the lengths
run) and extrapolated to 10^6, 10^7 and 10^8 cell-frames -- extrapolations, stated as such in
``results_scale.md``.

Usage::

    PYTHONPATH=$PWD python benchmarks/bench_scale.py --frames 5 10 --size 512 --cells 1200   # quick check
    # results_scale.md: five invocations (about 45 minutes at load 2-3, plus 11 minutes to render the
    # 2,083-frame input once), joined; --stream runs analyze(out=...), the tables streamed to disk
    PYTHONPATH=$PWD python benchmarks/bench_scale.py --frames 40 240 --configs 1 2 cluster --json A.json
    PYTHONPATH=$PWD python benchmarks/bench_scale.py --frames 40 240 --configs 1 2 cluster --stream --json B.json
    PYTHONPATH=$PWD python benchmarks/bench_scale.py --frames 2083 --configs 2 --stream --json C.json  # 10^7
    PYTHONPATH=$PWD python benchmarks/bench_scale.py --frames 40 240 --configs 2 --deformation --json D.json
    PYTHONPATH=$PWD python benchmarks/bench_scale.py --frames 40 240 --configs 2 --deformation --stream --json E.json
    PYTHONPATH=$PWD python benchmarks/bench_scale.py --from-json A.json B.json C.json D.json E.json

Results: ``benchmarks/results_scale.md`` (written by ``--from-json`` or ``--write-md``), with a section
comparing each streamed run with the in-memory run of the same movie, configuration and length.  10^7
cell-frames (2,083 frames) is run streamed; the in-memory path would need about 15 GB there (its fit).
"""
from __future__ import annotations

import argparse
import json
import os
import platform
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

#: One run: analyze + write in this process, phases logged with their start times.
RUNNER = r"""
import json, sys, time, warnings
cfg = json.loads(sys.argv[1])

def kb(key):
    return [int(l.split()[1]) for l in open("/proc/self/status") if l.startswith(key + ":")][0]

PHASES = []
def phase(name):
    if PHASES:
        PHASES[-1]["main_hwm_kb"] = kb("VmHWM")
        PHASES[-1]["end"] = time.time()
    if name is not None:
        with open("/proc/self/clear_refs", "w") as fh:
            fh.write("5")  # the main process's high-water mark starts again at its RSS
        PHASES.append({"phase": name, "start": time.time(), "main_rss_start_kb": kb("VmRSS")})

import numpy as np
import hexatissue.stages as stages
from dataclasses import replace
from hexatissue import analyze, open_source
from hexatissue.synthetic import voronoi_movie

def tagged(stage):
    def run(data, options):
        phase(stage.name)
        return stage.run(data, options)
    return replace(stage, run=run)

stages.STAGES = tuple(tagged(s) if s.per == "movie" else s for s in stages.STAGES)

class _Prefix:
    # the first n frames of an on-disk array, read one frame at a time
    def __init__(self, arr, n):
        self.arr, self.shape, self.dtype, self.ndim = arr, (n,) + tuple(arr.shape[1:]), arr.dtype, 3
    def __getitem__(self, t):
        if not isinstance(t, (int, np.integer)) or not 0 <= t < self.shape[0]:
            raise IndexError(t)
        return self.arr[int(t)]

if cfg["input"] == "zarr":
    import zarr
    movie = _Prefix(zarr.open_array(cfg["zarr"], mode="r"), cfg["frames"])
else:
    movie = voronoi_movie(cfg["cells"], (cfg["size"], cfg["size"]), cfg["frames"], periodic=False,
                          amplitude=cfg["amplitude"], seed=cfg["seed"])
kw = {"workers": cfg["workers"]} if cfg["cluster"] is None else {}
client = cluster = None
if cfg["cluster"] is not None:
    from dask.distributed import Client, LocalCluster
    cluster = LocalCluster(n_workers=cfg["cluster"], threads_per_worker=1, processes=True, dashboard_address=None)
    client = Client(cluster)
    kw = {"client": client}
    client.run(lambda: None)  # the workers are up before the clock starts
opts = {}
if cfg["deformation"]:
    from hexatissue.options import DeformationOptions
    opts["deformation"] = DeformationOptions(enabled=True)
out = {}
t0 = time.time()
phase("frames")
with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    m = analyze(movie, progress=False, out=cfg["out"] if cfg["stream"] else None, **kw, **opts)
phase("Movie")
t1 = time.time()
phase("write")
if not cfg["stream"]:  # a streamed run wrote its folder itself, within analyze
    m.write(cfg["out"])
phase(None)
t2 = time.time()
cells = m.cells
per_frame = np.bincount(cells["frame"].to_numpy(), minlength=cfg["frames"])
truth = {"cells_per_frame_min": int(per_frame.min()), "cells_per_frame_max": int(per_frame.max()),
         "tracks": int(cells["track"].nunique()), "t1_events": int(len(m.tables.get("events", []))),
         "rows": {k: int(len(v)) for k, v in m.tables.items()},
         "tables_mb": float(sum(int(v.memory_usage(deep=True).sum()) for v in m.tables.values()
                                if hasattr(v, "memory_usage")) / 1e6)}
if client is not None:
    client.close()
    cluster.close()
json.dump({"t_analyze": [t0, t1], "t_write": [t1, t2], "phases": PHASES, "truth": truth,
           "main_hwm_kb": kb("VmHWM")}, open(cfg["report"], "w"))
"""


# ----------------------------------------------------------------------------------------------
# the input
# ----------------------------------------------------------------------------------------------
def build_zarr(folder: Path, n_frames: int, size: int, n_cells: int, amplitude: float, seed: int):
    """Path of the cached zarr array of the movie's first ``n_frames`` frames (int32, one chunk a frame).

    Rendered and written one frame at a time; a cached array with at least ``n_frames`` frames of the
    same movie is reused (runs read a prefix).
    """
    import zarr

    from hexatissue.synthetic import voronoi_movie

    folder.mkdir(parents=True, exist_ok=True)
    stem = f"voronoi_{size}x{size}_{n_cells}cells_a{amplitude:g}_s{seed}"
    for cached in sorted(folder.glob(stem + "_*f.zarr")):
        if int(cached.name[len(stem) + 1:-len("f.zarr")]) >= n_frames:
            return cached, 0.0
    path = folder / f"{stem}_{n_frames}f.zarr"
    movie = voronoi_movie(n_cells, (size, size), n_frames, periodic=False, amplitude=amplitude, seed=seed)
    t0 = time.perf_counter()
    tmp = path.with_suffix(".part")
    shutil.rmtree(tmp, ignore_errors=True)
    arr = zarr.open_array(str(tmp), mode="w", shape=(n_frames, size, size), chunks=(1, size, size), dtype="int32")
    for t in range(n_frames):
        arr[t] = movie[t]
        if (t + 1) % 20 == 0:
            print(f"  rendered {t + 1}/{n_frames} frames ({time.perf_counter() - t0:.0f} s)", flush=True)
    tmp.rename(path)
    return path, time.perf_counter() - t0


# ----------------------------------------------------------------------------------------------
# measuring a process tree
# ----------------------------------------------------------------------------------------------
class TreeSampler(threading.Thread):
    """Polls a process and its descendants: time, summed RSS and PSS, main RSS, and every process's CPU time."""

    def __init__(self, pid: int, interval: float):
        super().__init__(daemon=True)
        import psutil

        self.proc = psutil.Process(pid)
        self.interval = interval
        self.stop = threading.Event()
        self.samples = []  # (time, tree RSS kB, tree PSS kB, main RSS kB, {pid: cpu s})

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
        rss = pss = main = 0
        cpu = {}
        for p in procs:
            try:
                s = status_kb(p.pid)
                pss += pss_kb(p.pid)
                times = p.cpu_times()
            except (OSError, ValueError, psutil.Error):
                continue  # ended between listing and reading
            if "VmRSS" not in s:
                continue
            rss += s["VmRSS"]
            cpu[p.pid] = times.user + times.system
            if p.pid == self.proc.pid:
                main = s["VmRSS"]
        self.samples.append((time.time(), rss, pss, main, cpu))


def tree_cpu(samples, t0: float, t1: float) -> float:
    """CPU seconds of the tree between ``t0`` and ``t1``: per process, its last CPU time by ``t1`` minus by ``t0``."""
    start, end = {}, {}
    for t, *_, cpu in samples:
        for pid, c in cpu.items():
            if t <= t0:
                start[pid] = c
            if t <= t1:
                end[pid] = c
    return sum(c - start.get(pid, 0.0) for pid, c in end.items())


def window_peaks(samples, t0: float, t1: float) -> dict:
    """Largest tree RSS, tree PSS and main RSS (MB) among the samples in ``[t0, t1]``."""
    inside = [s for s in samples if t0 <= s[0] <= t1]
    kb = 1024 / MB
    if not inside:
        return {"tree_rss_mb": float("nan"), "tree_pss_mb": float("nan"), "main_rss_mb": float("nan"), "n": 0}
    return {"tree_rss_mb": max(s[1] for s in inside) * kb, "tree_pss_mb": max(s[2] for s in inside) * kb,
            "main_rss_mb": max(s[3] for s in inside) * kb, "n": len(inside)}


def run_one(cfg: dict, poll: float, env, cwd) -> dict:
    report = Path(cfg["report"])
    proc = subprocess.Popen([sys.executable, "-c", RUNNER, json.dumps(cfg)], env=env, cwd=cwd,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    sampler = TreeSampler(proc.pid, poll)
    sampler.start()
    output = proc.communicate()[0]
    sampler.stop.set()
    sampler.join()
    if proc.returncode != 0:
        raise SystemExit(f"run {cfg} failed ({proc.returncode}):\n{output}")
    rep = json.loads(report.read_text())
    (a0, a1), (w0, w1) = rep["t_analyze"], rep["t_write"]
    samples = sampler.samples
    kb = 1024 / MB
    phases = []
    for ph in rep["phases"]:
        peaks = window_peaks(samples, ph["start"], ph["end"])
        phases.append({"phase": ph["phase"], "wall_s": ph["end"] - ph["start"],
                       "main_hwm_mb": ph["main_hwm_kb"] * kb, "main_rss_start_mb": ph["main_rss_start_kb"] * kb,
                       **peaks})
    whole = window_peaks(samples, a0, w1)
    cpu = tree_cpu(samples, a0, a1)
    cell_frames = cfg["frames"] * cfg["cells"]
    return {
        "frames": cfg["frames"], "cell_frames": cell_frames, "config": cfg["label"], "input": cfg["input"],
        "deformation": cfg["deformation"],
        "analyze_wall_s": a1 - a0, "write_wall_s": w1 - w0, "analyze_cpu_s": cpu,
        "write_cpu_s": tree_cpu(samples, w0, w1),
        "cell_frames_per_cpu_s": cell_frames / cpu if cpu > 0 else float("nan"),
        "cell_frames_per_wall_s": cell_frames / (a1 - a0),
        "peak_tree_rss_mb": whole["tree_rss_mb"], "peak_tree_pss_mb": whole["tree_pss_mb"],
        "peak_main_hwm_mb": max(p["main_hwm_mb"] for p in phases),
        "samples": len(samples), "phases": phases, "truth": rep["truth"],
    }


# ----------------------------------------------------------------------------------------------
# the report
# ----------------------------------------------------------------------------------------------
def fit_line(x, y):
    """Least-squares ``y = a + b x``; (a, b), or (y, nan) with one point."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    if len(set(x.tolist())) < 2:
        return float(y.mean()), float("nan")
    b, a = np.polyfit(x, y, 1)
    return float(a), float(b)


TITLE = "# Scale: memory, time and throughput of `analyze` against the movie's length (`bench_scale.py`)"


def merged(sets: list) -> list:
    """Result sets of the same movie and stages (several invocations) joined into one, in order of length."""
    out = {}
    for res in sets:
        c = res["config"]
        key = (c["size"], c["cells"], c["amplitude"], c["seed"], c["input"], c["deformation"], c.get("stream", False))
        if key not in out:
            out[key] = {"config": dict(c, command=[c["command"]]), "runs": []}
        else:
            mc = out[key]["config"]
            mc["command"].append(c["command"])
            mc["load_before"] = min(mc["load_before"], c["load_before"])
            mc["load_after"] = max(mc["load_after"], c["load_after"])
            mc["date"] = mc["date"] if mc["date"] <= c["date"] else c["date"]
        out[key]["runs"] += res["runs"]
    for res in out.values():
        order = {cfg: i for i, cfg in enumerate(dict.fromkeys(r["config"] for r in res["runs"]))}
        res["runs"].sort(key=lambda r: (r["frames"], order[r["config"]]))
    return list(out.values())


def markdown(results: dict, heading: str = "##") -> str:
    """One result set (one invocation) as markdown sections under ``heading``."""
    c = results["config"]
    runs = results["runs"]
    stages = "default stages + deformation budget" if c["deformation"] else "default stages"
    if c.get("stream"):
        stages += ", streamed (`analyze(out=...)`: tables written as the frames finish)"
    lines = [
        f"{heading} {stages}, {', '.join(dict.fromkeys(r['config'] for r in runs))}",
        "",
        f"{c['date']}, shared {c['cores']}-core {c['machine']} VM, {c['memory_gb']:.0f} GB, Python {c['python']}; "
        f"1-minute load {c['load_before']:.2f}-{c['load_after']:.2f} (before the first run, after the last; other "
        f"users' jobs ran throughout: wall times are inflated by the load, CPU times much less). Command"
        + (f": `{c['command']}`." if isinstance(c["command"], str) else
           "s: " + "; ".join(f"`{cmd}`" for cmd in c["command"]) + "."),
        "",
        f"Movie: `voronoi_movie({c['cells']}, ({c['size']}, {c['size']}), F, periodic=False, amplitude="
        f"{c['amplitude']:g}, seed={c['seed']})`, {c['cells']:,} cells a frame, read "
        + ("from a zarr array rendered beforehand, one frame at a time (the rendering is not in the figures)"
           if c["input"] == "zarr" else "lazily, each frame rendered in the analysing process (in the figures)")
        + f". Stages: {'default + deformation budget' if c['deformation'] else 'default'}. "
        "Configurations: `workers=1`, `workers=2` (process pool), `cluster` = `client=` a dask "
        "`LocalCluster` of 2 single-threaded worker processes (started before the clock). "
        "Peaks are of the whole process tree (sums over the process and its workers, polled every "
        f"{c['poll']} s), CPU is the tree's.",
        "",
        "| config | frames | cell-frames | analyze wall s | write s | tree CPU s | cell-frames / CPU s | "
        "write CPU s | cell-frames / CPU s, analyze + write | "
        "tree peak RSS MB | tree peak PSS MB | main VmHWM MB | tables MB | tracks (truth) | cells/frame (truth) |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in runs:
        t = r["truth"]
        lines.append(
            f"| {r['config']} | {r['frames']} | {r['cell_frames']:,} | {r['analyze_wall_s']:.1f} | "
            f"{r['write_wall_s']:.1f} | {r['analyze_cpu_s']:.1f} | {r['cell_frames_per_cpu_s']:.0f} | "
            f"{r['write_cpu_s']:.1f} | {r['cell_frames'] / (r['analyze_cpu_s'] + r['write_cpu_s']):.0f} | "
            f"{r['peak_tree_rss_mb']:.0f} | {r['peak_tree_pss_mb']:.0f} | {r['peak_main_hwm_mb']:.0f} | "
            f"{t['tables_mb']:.1f} | {t['tracks']} ({c['cells']}) | {t['cells_per_frame_min']}-"
            f"{t['cells_per_frame_max']} ({c['cells']}) |")
    lines += ["", f"{heading}# Memory against length: fit and extrapolation", "",
              "Per configuration, least squares `peak = a + b x frames` over the lengths run; the rows for "
              "10^6, 10^7 and 10^8 cell-frames are **extrapolated** from that line, not measured (a length "
              "that was run is marked measured).", "",
              "| config | measure | a (MB) | b (MB / frame) | b (bytes / cell-frame) | 10^6 cell-frames | "
              "10^7 cell-frames | 10^8 cell-frames | 240 / 40 frames (goal <= 1.25) | largest / smallest run |",
              "|---|---|---|---|---|---|---|---|---|---|"]
    fits = {}
    for cfg in dict.fromkeys(r["config"] for r in runs):
        mine = [r for r in runs if r["config"] == cfg]
        for key, name in (("peak_tree_pss_mb", "tree PSS"), ("peak_tree_rss_mb", "tree RSS"),
                          ("peak_main_hwm_mb", "main VmHWM")):
            a, b = fit_line([r["frames"] for r in mine], [r[key] for r in mine])
            fits[(cfg, key)] = (a, b)
            big, small = max(mine, key=lambda r: r["frames"]), min(mine, key=lambda r: r["frames"])
            ext = []
            for n in (1e6, 1e7, 1e8):
                frames = n / c["cells"]
                near = [r for r in mine if abs(r["cell_frames"] - n) / n < 0.01]
                if near:  # run at this size (to within 1 %): the measured peak, not the line's
                    ext.append(f"{near[0][key] / 1e3:.2f} GB (measured, {near[0]['frames']} frames)")
                else:
                    ext.append(f"{(a + b * frames) / 1e3:.2f} GB (extrapolated, {frames:,.0f} frames)")
            at = {r["frames"]: r[key] for r in mine}
            goal = f"{at[240] / at[40]:.2f}" if 40 in at and 240 in at else "-"
            lines.append(f"| {cfg} | {name} | {a:.0f} | {b:.2f} | {b * MB / c['cells']:.0f} | " + " | ".join(ext)
                         + f" | {goal} | {big[key] / small[key]:.2f} ({big['frames']} / {small['frames']} frames) |")
    results["fits"] = {f"{k[0]} {k[1]}": v for k, v in fits.items()}
    lines += ["", f"{heading}# Goals", ""]
    for cfg in dict.fromkeys(r["config"] for r in runs):
        at = {r["frames"]: r for r in runs if r["config"] == cfg}
        a, b = fits[(cfg, "peak_tree_pss_mb")]
        ratio = (f"peak tree PSS at 240 / 40 frames {at[240]['peak_tree_pss_mb'] / at[40]['peak_tree_pss_mb']:.2f} "
                 f"(goal <= 1.25: {'met' if at[240]['peak_tree_pss_mb'] <= 1.25 * at[40]['peak_tree_pss_mb'] else 'not met'})"
                 if 40 in at and 240 in at else "240 and 40 frames not both run")
        near = [r for r in at.values() if abs(r["cell_frames"] - 1e7) / 1e7 < 0.01]
        ten7, how = (near[0]["peak_tree_pss_mb"], "measured") if near else (a + b * 1e7 / c["cells"], "extrapolated")
        cpu = sum(r["analyze_cpu_s"] + r["write_cpu_s"] for r in at.values())
        lines.append(f"- {cfg}: {ratio}; 10^7 cell-frames {how}: {ten7 / 1e3:.1f} GB tree PSS (goal <= 8 GB: "
                     f"{'met' if ten7 <= 8e3 else 'not met'}, {how}); throughput over its runs "
                     f"{sum(r['cell_frames'] for r in at.values()) / cpu:,.0f} cell-frames per CPU-second, analyze "
                     f"and the results folder's write (a streamed run writes within analyze).")
    lines += ["", f"{heading}# Peak per phase (largest run of each configuration)", "",
              "Main VmHWM: the main process's own high-water mark, reset at the phase's start (exact). Tree "
              "peaks: the polled samples inside the phase (a phase shorter than the poll may have none: -).", "",
              "| config | frames | phase | wall s | main RSS at start MB | main VmHWM MB | tree peak RSS MB | "
              "tree peak PSS MB |", "|---|---|---|---|---|---|---|---|"]
    for cfg in dict.fromkeys(r["config"] for r in runs):
        r = max((r for r in runs if r["config"] == cfg), key=lambda r: r["frames"])
        for p in r["phases"]:
            tree = (f"{p['tree_rss_mb']:.0f} | {p['tree_pss_mb']:.0f}" if p["n"] else "- | -")
            lines.append(f"| {cfg} | {r['frames']} | {p['phase']} | {p['wall_s']:.1f} | {p['main_rss_start_mb']:.0f}"
                         f" | {p['main_hwm_mb']:.0f} | {tree} |")
    return "\n".join(lines) + "\n"


# ----------------------------------------------------------------------------------------------
def comparison(sets: list) -> str:
    """Streamed against in-memory runs of the same movie, configuration and length (joined sets): peak memory and
    CPU (analyze + write) ratios."""
    def key(c, r):
        return (c["size"], c["cells"], c["amplitude"], c["seed"], c["input"], c["deformation"], r["config"],
                r["frames"])

    memory = {key(s["config"], r): r for s in sets if not s["config"].get("stream") for r in s["runs"]}
    rows = []
    for res in sets:
        if not res["config"].get("stream"):
            continue
        for r in res["runs"]:
            m = memory.get(key(res["config"], r))
            if m is None:
                continue
            cpu_s = r["analyze_cpu_s"] + r["write_cpu_s"]
            cpu_m = m["analyze_cpu_s"] + m["write_cpu_s"]
            stages = "default + deformation budget" if res["config"]["deformation"] else "default"
            rows.append(f"| {stages} | {r['config']} | {r['frames']} | {m['peak_tree_pss_mb']:.0f} | {r['peak_tree_pss_mb']:.0f} "
                        f"| {r['peak_tree_pss_mb'] / m['peak_tree_pss_mb']:.2f} | {cpu_m:.1f} | {cpu_s:.1f} | "
                        f"{cpu_m / cpu_s:.2f} |")
    if not rows:
        return ""
    return "\n".join([
        "## Streamed against in-memory", "",
        "The same movie, configuration and length, from the sections above. CPU: the process tree's, analyze and "
        "the results folder's write (a streamed run writes within analyze; an in-memory run after it). "
        "Throughput ratio > 1: the streamed run is faster.", "",
        "| stages | config | frames | peak PSS MB, in memory | peak PSS MB, streamed | streamed / in memory | CPU s, "
        "in memory | CPU s, streamed | throughput streamed / in memory |", "|---|---|---|---|---|---|---|---|---|",
        *rows, ""])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", type=int, default=1024, help="frame rows = cols, px (default 1024)")
    ap.add_argument("--cells", type=int, default=4800, help="cells a frame (default 4800: the issue's tissue)")
    ap.add_argument("--frames", type=int, nargs="+", help="movie lengths to run (frames)")
    ap.add_argument("--cell-frames", type=float, nargs="+",
                    help="movie lengths to run as cell-frames (rounded to whole frames); default 1e5 1e6")
    ap.add_argument("--configs", nargs="+", default=["1", "2", "cluster"],
                    help="1 and 2: workers=1 / 2 (process pool); cluster: client= a 2-worker LocalCluster")
    ap.add_argument("--deformation", action="store_true", help="also run the deformation budget")
    ap.add_argument("--stream", action="store_true",
                    help="analyze(out=...): the tables streamed to the results folder as the frames finish")
    ap.add_argument("--input", choices=("zarr", "lazy"), default="zarr",
                    help="zarr: frames rendered beforehand into a cached zarr array; lazy: rendered in the run")
    ap.add_argument("--amplitude", type=float, default=0.3)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--cache", type=Path, help="folder of the zarr input (default TMPDIR/hexatissue-bench-scale)")
    ap.add_argument("--poll", type=float, default=0.1, help="sampling interval of the process tree, s (default 0.1)")
    ap.add_argument("--json", type=Path, help="also write every number to this JSON file")
    ap.add_argument("--write-md", action="store_true", help="write benchmarks/results_scale.md")
    ap.add_argument("--from-json", type=Path, nargs="+",
                    help="run nothing: write results_scale.md from these --json files (one section each)")
    args = ap.parse_args(argv)
    if args.from_json:
        sets = merged([json.loads(p.read_text()) for p in args.from_json])
        text = TITLE + "\n\n" + "\n".join(markdown(s) for s in sets) + comparison(sets)
        (HERE / "results_scale.md").write_text(text)
        print(text)
        return 0

    import hexatissue

    pkg = Path(hexatissue.__file__).resolve().parent
    if REPO not in pkg.parents:
        print(f"warning: hexatissue is imported from {pkg}, not from this checkout ({REPO})", file=sys.stderr)
    env = dict(os.environ, HEXATISSUE_PROGRESS="0",
               PYTHONPATH=os.pathsep.join([str(pkg.parent)] + [p for p in os.environ.get("PYTHONPATH", "").split(
                   os.pathsep) if p]))
    frames = args.frames or [max(1, round(n / args.cells)) for n in (args.cell_frames or [1e5, 1e6])]
    frames = sorted(set(frames))
    load_before = os.getloadavg()[0]
    print(f"hexatissue {hexatissue.__version__} from {pkg}; load {load_before:.2f}; frames {frames}", flush=True)
    zarr_path = None
    if args.input == "zarr":
        cache = args.cache or Path(tempfile.gettempdir()) / "hexatissue-bench-scale"
        zarr_path, build_s = build_zarr(cache, max(frames), args.size, args.cells, args.amplitude, args.seed)
        print(f"input {zarr_path} ({'rendered in %.0f s' % build_s if build_s else 'cached'})", flush=True)
    work = Path(tempfile.mkdtemp(prefix="bench-scale-"))
    runs = []
    try:
        for n in frames:
            for cfg in args.configs:
                label = f"workers={cfg}" if cfg != "cluster" else "cluster (2 workers)"
                out = work / "out"
                run_cfg = {"frames": n, "cells": args.cells, "size": args.size, "amplitude": args.amplitude,
                           "seed": args.seed, "input": args.input, "zarr": str(zarr_path) if zarr_path else None,
                           "workers": None if cfg == "cluster" else int(cfg), "cluster": 2 if cfg == "cluster" else None,
                           "deformation": args.deformation, "stream": args.stream, "out": str(out),
                           "report": str(work / "report.json"),
                           "label": label}
                load = os.getloadavg()[0]
                r = run_one(run_cfg, args.poll, env, pkg.parent)
                r["load_before"] = load
                runs.append(r)
                shutil.rmtree(out, ignore_errors=True)
                print(f"{label:20s} {n:5d} frames: analyze {r['analyze_wall_s']:6.1f} s wall, "
                      f"{r['analyze_cpu_s']:6.1f} s CPU ({r['cell_frames_per_cpu_s']:.0f} cell-frames/CPU s), write "
                      f"{r['write_wall_s']:.1f} s; peak tree PSS {r['peak_tree_pss_mb']:.0f} MB, RSS "
                      f"{r['peak_tree_rss_mb']:.0f} MB, main {r['peak_main_hwm_mb']:.0f} MB; tracks "
                      f"{r['truth']['tracks']}; load {load:.2f}", flush=True)
                for p in r["phases"]:
                    print(f"    {p['phase']:20s} {p['wall_s']:7.1f} s  main HWM {p['main_hwm_mb']:6.0f} MB  tree PSS "
                          f"{p['tree_pss_mb']:6.0f} MB", flush=True)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    import psutil

    results = {"config": {"size": args.size, "cells": args.cells, "amplitude": args.amplitude, "seed": args.seed,
                          "input": args.input, "deformation": args.deformation, "stream": args.stream,
                          "poll": args.poll,
                          "cores": os.cpu_count(), "machine": platform.machine(),
                          "memory_gb": psutil.virtual_memory().total / 1e9, "python": sys.version.split()[0],
                          "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "load_before": load_before,
                          "load_after": os.getloadavg()[0],
                          "command": "python benchmarks/bench_scale.py " + " ".join(argv if argv is not None
                                                                                      else sys.argv[1:])},
               "runs": runs}
    text = TITLE + "\n\n" + markdown(results)
    print(text)
    if args.write_md:
        (HERE / "results_scale.md").write_text(text)
    if args.json:
        args.json.write_text(json.dumps(results, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
