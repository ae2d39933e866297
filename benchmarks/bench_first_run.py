"""First ``hexatissue analyze`` on an empty numba cache against the same run with a warm cache.

Issue goal: the cold first analyze of the bundled sample takes <= 3 x the warm run's wall time on a
quiet machine and <= 15 CPU-seconds in all its processes, with nothing left running when it returns.

Each run is ``hexatissue analyze SAMPLE --out DIR`` in a fresh subprocess (imports included), in a new
session so that what it leaves running can be listed (``ps -s``) once it returns:

* ``cold``: an empty ``NUMBA_CACHE_DIR`` (the default: a small input runs the references of the
  kernels not yet compiled, :mod:`hexatissue._dispatch`),
* ``warm``: the same command again on the cache the cold runs left (the cold runs of the default
  compile only the kernels without a reference; ``warm`` first fills the cache with every kernel
  the sample needs, through one ``compiling`` run, so it times the fully compiled path),
* ``compiling``: an empty cache with ``pipeline.REFERENCE_PIXELS = 0``, so that the run compiles
  every kernel it needs, as every run did before the references (and as a large input does now).

Runs alternate (cold, warm, compiling, ...) ``--pairs`` times.  Then, for the size limit of the
references (``pipeline.REFERENCE_PIXELS``), one ``cold`` and one ``compiling`` run of a single
Voronoi label image of that many pixels (cells 16 px apart): the references must cost less than
compiling there.  CPU-seconds are user + system time
of the subprocess and of every descendant it waited for (``resource.getrusage(RUSAGE_CHILDREN)``
differences; a process still running when the run returns is listed as left over instead).
``--profile`` adds, in one more subprocess per mode on an empty cache, the numba kernels that
compile (numba's ``numba:compile`` events) and the seconds spent in them.

Usage: ``python benchmarks/bench_first_run.py [--pairs 2] [--profile] [--out benchmarks/results_first_run.md]``
"""
from __future__ import annotations

import argparse
import datetime
import os
import platform
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

COMPILING = ("import sys; import hexatissue.pipeline as p; p.REFERENCE_PIXELS = 0; "
             "from hexatissue.cli import main; sys.exit(main(sys.argv[1:]))")
PROFILE = r"""
import sys, time, warnings, collections
from numba.core import event
spent, started = collections.defaultdict(float), {}
class Listener(event.Listener):
    def on_start(self, e):
        started[id(e.data["dispatcher"]), str(e.data["args"])] = time.perf_counter()
    def on_end(self, e):
        d = e.data["dispatcher"]
        if d.py_func.__module__.startswith("hexatissue"):
            key = d.py_func.__module__.split(".")[-2] + "." + d.py_func.__name__
            spent[key] += time.perf_counter() - started[id(d), str(e.data["args"])]
event.register("numba:compile", Listener())
import hexatissue.pipeline as p
if sys.argv[1] == "compiling":
    p.REFERENCE_PIXELS = 0
from hexatissue.samples import sample_path
with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    p.analyze(sample_path("epicure_notum"), workers=1, progress=False)
top = sorted(spent.items(), key=lambda kv: -kv[1])
print(len(spent), round(sum(spent.values()), 1), ", ".join(f"{k} {v:.1f}" for k, v in top[:8]))
"""


def _left_over(pid):
    """The live processes of session ``pid`` (what the run left running)."""
    out = subprocess.run(["ps", "-o", "pid=,stat=,comm=", "-s", str(pid)], capture_output=True, text=True).stdout
    return [line.strip() for line in out.splitlines() if line.split() and not line.split()[1].startswith("Z")]


def run(kind, sample, cache, work):
    """One ``analyze`` subprocess: (wall s, CPU s of it and its waited-for descendants, load before, left over, ok)."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), HEXATISSUE_PROGRESS="0",
               PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    out = Path(tempfile.mkdtemp(dir=work))
    shutil.rmtree(out)
    head = [sys.executable, "-c", COMPILING] if kind == "compiling" else [sys.executable, "-m", "hexatissue.cli"]
    load = os.getloadavg()[0]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    proc = subprocess.Popen(head + ["analyze", str(sample), "--out", str(out)], env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    err = proc.communicate()[1]
    wall = time.perf_counter() - start
    left = _left_over(proc.pid)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    announced = "compiling the kernels" in err
    return wall, cpu, load, left, proc.returncode == 0, announced


def limit_image(work):
    """A square Voronoi label image of about ``REFERENCE_PIXELS`` pixels (at most that many), saved as .npy."""
    import numpy as np

    from hexatissue.pipeline import REFERENCE_PIXELS
    from hexatissue.synthetic import jittered_seeds, voronoi_labels

    side = int(np.sqrt(REFERENCE_PIXELS))
    path = work / "limit.npy"
    np.save(path, voronoi_labels(jittered_seeds((side, side), 16, seed=1), (side, side)).astype(np.int32))
    return path, side


def profile(mode, work):
    cache = Path(tempfile.mkdtemp(dir=work))
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    out = subprocess.run([sys.executable, "-c", PROFILE, mode], env=env, capture_output=True, text=True, check=True)
    n, total, *top = out.stdout.strip().split(" ", 2)
    return int(n), float(total), top[0] if top else "none"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pairs", type=int, default=2)
    parser.add_argument("--profile", action="store_true")
    parser.add_argument("--out", default=str(ROOT / "benchmarks" / "results_first_run.md"))
    args = parser.parse_args()
    sys.path.insert(0, str(ROOT))
    from hexatissue.samples import sample_path

    sample = sample_path("epicure_notum")
    stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    rows = []
    with tempfile.TemporaryDirectory() as work:
        work = Path(work)
        warm_cache = work / "warm-cache"
        run("compiling", sample, warm_cache, work)  # fills the warm cache with every kernel the sample needs
        for pair in range(args.pairs):
            for kind in ("cold", "warm", "compiling"):
                cache = warm_cache if kind == "warm" else Path(tempfile.mkdtemp(dir=work))
                wall, cpu, load, left, ok, announced = run(kind, sample, cache, work)
                rows.append((pair + 1, kind, wall, cpu, load, left, ok, announced))
                print(f"pair {pair + 1} {kind}: {wall:.1f} s wall, {cpu:.1f} CPU-s, load {load:.2f}, "
                      f"left over {left or 'none'}, exit ok {ok}, compile announced {announced}", flush=True)
        limit, side = limit_image(work)
        at_limit = {kind: run(kind, limit, Path(tempfile.mkdtemp(dir=work)), work) for kind in ("cold", "compiling")}
        for kind, (wall, cpu, load, left, ok, announced) in at_limit.items():
            print(f"limit {kind}: {wall:.1f} s wall, {cpu:.1f} CPU-s, load {load:.2f}, exit ok {ok}", flush=True)
        profiles = {mode: profile(mode, work) for mode in ("default", "compiling")} if args.profile else {}
    end_load = os.getloadavg()[0]

    def stat(kind, i):
        values = [r[i] for r in rows if r[1] == kind]
        return min(values), max(values)

    cold, warm, comp = (stat(k, 2) for k in ("cold", "warm", "compiling"))
    cold_cpu, warm_cpu, comp_cpu = (stat(k, 3) for k in ("cold", "warm", "compiling"))
    ratios = [c[2] / w[2] for c, w in zip([r for r in rows if r[1] == "cold"], [r for r in rows if r[1] == "warm"])]
    lines = [
        "# First `analyze` on an empty numba cache (`benchmarks/bench_first_run.py`)",
        "",
        f"{stamp}, {platform.machine()} with {os.cpu_count()} cores (shared), Python {platform.python_version()}; "
        f"1-minute load before each run in the table, {end_load:.2f} after the last.",
        f"Command: `NUMBA_CACHE_DIR=<dir> hexatissue analyze <bundled epicure_notum> --out <dir>` in a fresh "
        f"subprocess (its own session), {args.pairs} alternated rounds of cold / warm / compiling (see the script's "
        f"docstring). CPU = user + system seconds of the run and every process it waited for.",
        "",
        "| round | run | wall s | CPU s | load before | left running after return | exit 0 | compile announced |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for pair, kind, wall, cpu, load, left, ok, announced in rows:
        lines.append(f"| {pair} | {kind} | {wall:.1f} | {cpu:.1f} | {load:.2f} | {', '.join(left) or 'nothing'} | "
                     f"{'yes' if ok else 'NO'} | {'yes' if announced else 'no'} |")
    lines += [
        "",
        f"- cold (references for what is not compiled): {cold[0]:.1f}-{cold[1]:.1f} s wall, "
        f"{cold_cpu[0]:.1f}-{cold_cpu[1]:.1f} CPU-s",
        f"- warm: {warm[0]:.1f}-{warm[1]:.1f} s wall, {warm_cpu[0]:.1f}-{warm_cpu[1]:.1f} CPU-s",
        f"- cold / warm (same round): {min(ratios):.1f}-{max(ratios):.1f} x (goal <= 3 x on a quiet machine)",
        f"- compiling every kernel in the run (a large input's first run; small ones did too before the references, "
        f"then with a second compiling process beside them): {comp[0]:.1f}-{comp[1]:.1f} s wall, "
        f"{comp_cpu[0]:.1f}-{comp_cpu[1]:.1f} CPU-s",
    ]
    lines += ["", f"At the references' size limit (one {side} x {side} px Voronoi image, {side * side:,} px, cells 16 px "
              f"apart), empty cache:", ""]
    for kind, (wall, cpu, load, left, ok, announced) in at_limit.items():
        lines.append(f"- {kind}: {wall:.1f} s wall, {cpu:.1f} CPU-s (load before {load:.2f}; left running: "
                     f"{', '.join(left) or 'nothing'}; exit 0: {'yes' if ok else 'NO'})")
    if profiles:
        lines += ["", "Kernels compiled in one process on an empty cache (numba's compile events; nested kernels "
                  "are counted in their callers too, so the seconds add up to more than the run's CPU time):", ""]
        for mode, (n, total, top) in profiles.items():
            lines.append(f"- {mode}: {n} kernels, {total:.1f} s; largest: {top}")
    text = "\n".join(lines) + "\n"
    print(text)
    Path(args.out).write_text(text)


if __name__ == "__main__":
    main()
