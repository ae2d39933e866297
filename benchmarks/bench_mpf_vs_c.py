"""Speed of hexatissue's MPF simulator against the published C code, on the same system, in one run.

The C code is https://github.com/mchchiang/phase_field_benjamin (Loewe et al., PRL 2020).  This script
does not contain it: ``--c-code DIR`` is a checkout or a bare git clone of it; ``src/`` is copied into a
temporary folder and built there with the repository's own ``make`` (``compare_c_code.build_c_code``).

Both codes get the same state and parameters as in ``compare_c_code.py``: 440 identical tanh discs on
hexatissue's jittered lattice in 384 x 403, P = 41 patches, the paper's functional with phi0 = 2, M = 0.1,
dt = 0.5, k_ad = 0 (the C code has no adhesion), v0 = 0.006, D_r = 1e-5.  Differences that remain:
the C code integrates with explicit Euler (one right-hand side per step) in float64; hexatissue with Heun
(two) or Euler (``--integrators``), in float32 by default (``--dtype``).

For every repeat and every thread count, the C code runs ``--steps`` steps (its own timer of the main
run, ``omp_get_wtime``, excludes start-up; CPU time is the child's rusage) and hexatissue runs the same
number of active steps in this process (after a short compiled warm-up), back to back, the order
alternating between repeats.  With ``--baseline DIR`` (a checkout of another hexatissue version, e.g.
``git worktree add /tmp/base main``) that version runs the same steps too, in a worker process started
once (compiled and warmed up before the timed runs; same state, same environment), in the same
rotation: its figures and ``ours / baseline`` come from the same repeat.  Thread counts: ``1``, ``2`` and ``auto`` (hexatissue's
``threads="auto"`` as in ``run_simulation``: the load-based count for the first chunk of 100 steps,
then a fresh ``ThreadTuner`` per timed run; compared with the C code at 2 OpenMP threads, its default
on this machine; the table lists the count used for each chunk).
The C code runs with the OpenMP environment the script was started with (libgomp's default spinning
waits unless ``OMP_WAIT_POLICY`` is set); hexatissue and the baseline with their own defaults (passive
waits, after a short spin).

Usage::

    PYTHONPATH=. python benchmarks/bench_mpf_vs_c.py --c-code /path/to/phase_field_benjamin \\
        [--steps 600] [--repeats 3] [--threads 1 2 auto] [--integrators heun euler] [--baseline DIR] [--out FILE]
"""
from __future__ import annotations

import argparse
import json
import os
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

START_ENV = dict(os.environ)  # before hexatissue sets its OpenMP waits: the C code's and the baseline's

from _timing import emit  # noqa: E402  (benchmarks/_timing.py)
from compare_c_code import build_c_code, common_params, hexatissue_sim, initial_fields, write_c_inputs  # noqa: E402
from hexatissue.simulate import set_threads  # noqa: E402
from hexatissue.simulate.model import ThreadTuner  # noqa: E402


def uptime() -> str:
    return "load %.2f %.2f %.2f" % os.getloadavg()


def run_c(exe: Path, run: Path, threads: int, steps: int):
    """(steps/s by the C code's own timer of the main run, steps per CPU-second of the child process)."""
    env = dict(START_ENV, OMP_NUM_THREADS=str(threads))
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    out = subprocess.run([str(exe), "params.txt"], cwd=run, env=env, capture_output=True, text=True, check=True).stdout
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    wall = float(re.findall(r"Time taken \(sec\): ([0-9.]+)", out)[-1])  # the last one is the main run
    return steps / wall, steps / cpu


def _describe(root: Path) -> str:
    """The commit of a checkout, for the report."""
    return subprocess.run(["git", "-C", str(root), "log", "-1", "--format=%h %s"], capture_output=True,
                          text=True).stdout.strip()[:60]


def run_ours(sim, threads, steps: int, chunk: int = 100):
    """(steps/s wall, steps per CPU-second, thread counts used) for ``steps`` active steps of ``sim``.

    ``threads="auto"`` does what ``run_simulation`` does: the load-based count for the first chunk of
    ``chunk`` steps, then a fresh :class:`ThreadTuner` (so every timed run pays for its probes).
    """
    t0, c0 = time.perf_counter(), time.process_time()
    if threads != "auto":
        used = [set_threads(threads)]
        sim.advance(steps)
    else:
        used = [set_threads("auto")]
        tuner = ThreadTuner.for_machine(used[0])
        sim.advance(chunk)
        for _ in range(chunk, steps, chunk):
            n = set_threads(tuner.choose(time.monotonic()))
            t = time.perf_counter()
            sim.advance(chunk)
            tuner.record(n, chunk / (time.perf_counter() - t), time.monotonic())
            used.append(n)
    return steps / (time.perf_counter() - t0), steps / (time.process_time() - c0), used


# The baseline's side: its own benchmarks/ and package first on the path, so that run_ours, the state
# and the simulator are all the baseline's.  Protocol: one JSON line per request on stdin, one reply each.
BASELINE_WORKER = r"""
import json, sys
sys.path[:0] = [sys.argv[1] + "/benchmarks", sys.argv[1]]
from bench_mpf_vs_c import run_ours
from compare_c_code import common_params, hexatissue_sim, initial_fields
cfg = json.loads(sys.stdin.readline())
base = common_params(dtype=cfg["dtype"])
template, ox, oy, theta = initial_fields(base, cfg["seed"])
sims = {}
for integ in cfg["integrators"]:
    sims[integ] = hexatissue_sim(base.replace(integrator=integ), template, ox, oy, theta, cfg["seed"])
    sims[integ].advance(4)
print(json.dumps("ready"), flush=True)
for line in sys.stdin:
    integ, threads, steps = json.loads(line)
    print(json.dumps(run_ours(sims[integ], threads, steps)), flush=True)
"""


class Baseline:
    """Another hexatissue checkout timing the same runs in a worker process (see ``BASELINE_WORKER``)."""

    def __init__(self, root: Path, dtype: str, seed: int, integrators):
        env = dict(START_ENV, PYTHONPATH=str(root))  # it sets its own OpenMP waits
        self.proc = subprocess.Popen([sys.executable, "-c", BASELINE_WORKER, str(root)], cwd=root, env=env,
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        self._ask({"dtype": dtype, "seed": seed, "integrators": list(integrators)})

    def _ask(self, request):
        self.proc.stdin.write(json.dumps(request) + "\n")
        self.proc.stdin.flush()
        reply = self.proc.stdout.readline()
        if not reply:
            raise SystemExit("the baseline worker stopped (its error is above)")
        return json.loads(reply)

    def run(self, integ: str, threads, steps: int):
        """(steps/s wall, steps per CPU-second, thread counts used), as :func:`run_ours`."""
        return tuple(self._ask([integ, threads, steps]))

    def close(self):
        self.proc.stdin.close()
        self.proc.wait()


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--c-code", required=True, type=Path,
                    help="checkout or bare clone of mchchiang/phase_field_benjamin")
    ap.add_argument("--steps", type=int, default=600, help="steps per timed run of each code (a multiple of 100)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--threads", nargs="+", default=["1", "2", "auto"], help="thread counts: integers or 'auto'")
    ap.add_argument("--integrators", nargs="+", default=["heun"], choices=["heun", "euler"])
    ap.add_argument("--dtype", default="float32", choices=["float32", "float64"])
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--baseline", type=Path, default=None,
                    help="checkout of another hexatissue version (e.g. main) to time in the same run")
    ap.add_argument("--out", type=Path, default=None, help="append the markdown report here")
    args = ap.parse_args(argv)
    threads = [t if t == "auto" else int(t) for t in args.threads]
    if args.steps % 100 or args.steps < 200:
        raise SystemExit("--steps must be a multiple of 100, at least 200 (the chunks of --threads auto)")

    work = Path(tempfile.mkdtemp(prefix="hexatissue-speed-vs-c-"))
    try:
        exe = build_c_code(args.c_code, work / "build")
        base = common_params(dtype=args.dtype)
        template, ox, oy, theta = initial_fields(base, args.seed)
        run = work / "run"
        write_c_inputs(run, base, template, ox, oy, theta, nequil=0, nsteps=args.steps, every=10**9,
                       field_every=10**9, seed=args.seed)
        # no output during the timed run: drop the dump lines
        text = (run / "params.txt").read_text()
        (run / "params.txt").write_text("\n".join(ln for ln in text.splitlines() if not ln.startswith("dump_")) + "\n")
        sims = {}
        for integ in args.integrators:
            sim = hexatissue_sim(base.replace(integrator=integ), template, ox, oy, theta, args.seed)
            sim.advance(4)  # compile (or load the cache) outside the timed runs
            sims[integ] = sim
        baseline = Baseline(args.baseline, args.dtype, args.seed, args.integrators) if args.baseline else None
        lines = [f"## hexatissue vs the C code, speed, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}", "",
                 f"- {base.n_cells} cells, {base.Lx} x {base.Ly}, patch {base.patch}, phi0 = {base.phi0:g}, "
                 f"dt = {base.dt:g}, k_ad = 0, active; hexatissue {args.dtype} upwind3, C code float64 Euler; "
                 f"{args.steps} steps per run, {args.repeats} repeats, back to back (order alternating)",
                 f"- C code OMP_WAIT_POLICY: {START_ENV.get('OMP_WAIT_POLICY', '(unset: libgomp default)')}; "
                 f"hexatissue: {os.environ.get('OMP_WAIT_POLICY')}, GOMP_SPINCOUNT "
                 f"{os.environ.get('GOMP_SPINCOUNT', '(unset)')}",
                 *([f"- baseline: {args.baseline} ({_describe(args.baseline)})"] if baseline else []),
                 f"- {uptime()} before", "",
                 "| repeat | threads (C / ours) | load | C steps/s (wall; per CPU-s) | "
                 + " | ".join(f"hexatissue {i} steps/s (wall; per CPU-s) | {i} / C (wall)"
                              + (f" | baseline {i} steps/s (wall; per CPU-s) | {i} ours / baseline" if baseline else "")
                              for i in args.integrators) + " |",
                 "|---|---|---|---|" + ("---|---|" * (2 if baseline else 1)) * len(args.integrators)]
        ratios = {(str(t), i, who): [] for t in threads for i in args.integrators for who in ("C", "baseline")}
        for rep in range(args.repeats):
            for t in threads:
                c_threads = 2 if t == "auto" else t
                got = {}
                runs = [("C", None, lambda: run_c(exe, run, c_threads, args.steps))]
                for integ in args.integrators:
                    runs.append(("ours", integ, lambda integ=integ: run_ours(sims[integ], t, args.steps)))
                    if baseline:
                        runs.append(("baseline", integ, lambda integ=integ: baseline.run(integ, t, args.steps)))
                for who, integ, fn in (runs if rep % 2 == 0 else runs[::-1]):
                    got[who, integ] = fn()
                c = got["C", None]
                used = got["ours", args.integrators[0]][2]
                shown = f"{t} ({'/'.join(str(n) for n in used)})" if t == "auto" else str(t)
                row = f"| {rep + 1} | {c_threads} / {shown} | {os.getloadavg()[0]:.1f} | {c[0]:.0f}; {c[1]:.0f} |"
                for integ in args.integrators:
                    w, cpu = got["ours", integ][:2]
                    ratios[str(t), integ, "C"].append(w / c[0])
                    row += f" {w:.0f}; {cpu:.0f} | {w / c[0]:.2f} |"
                    if baseline:
                        bw, bcpu = got["baseline", integ][:2]
                        ratios[str(t), integ, "baseline"].append(w / bw)
                        row += f" {bw:.0f}; {bcpu:.0f} | {w / bw:.2f} |"
                print(row, flush=True)
                lines.append(row)
        if baseline:
            baseline.close()
        lines += ["", "Median ratios (wall steps/s, same repeat):", ""]
        for (t, integ, who), r in ratios.items():
            if r:
                lines.append(f"- threads {t}, {integ}, ours / {who}: {np.median(r):.2f} ("
                             + ", ".join(f"{x:.2f}" for x in r) + ")")
        emit(lines, uptime(), args.out)
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
