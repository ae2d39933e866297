"""Parameter sweeps of the MPF model: simulate and analyse several runs in parallel, resumably.

Layout of a sweep folder ``OUT``::

    OUT/D_r=1e-05/run.zarr        the MPF run (hexatissue.simulate.run_simulation)
    OUT/D_r=1e-05/results/        its analysis (hexatissue.analyze(...).write(...); read_results reads it)
    OUT/D_r=1e-05/analysis.log    the analysis' progress bar and warnings
    OUT/D_r=1e-05/done.json       written last: the run's settings and summary

**Resuming.** A run whose ``done.json`` matches the requested settings is not
redone.  A run store that exists but is unfinished continues from its last
checkpoint (``run_simulation(resume=True)``); a finished store is only
analysed.  A store created with other settings (parameters, seed, relax,
save_every) is an error rather than silently mixed.  So a sweep interrupted
at any point is completed by calling :func:`sweep` again with the same
arguments.

**Parallelism.** Every run is one job: simulation (single-threaded numba by
default; two single-thread runs use two cores better than one two-thread run)
then its analysis (in the same process).  Jobs go to a local process pool
(``spawn`` start method: numba's threading layer must not be forked) or, when
``client`` is given, to a dask.distributed cluster; the workers must then see
the sweep folder (shared file system).
"""
from __future__ import annotations

import contextlib
import dataclasses
import json
import os
import time
from pathlib import Path

import numpy as np
import pandas as pd

from ..errors import InputError
from ..io import atomic_path
from ..options import EventOptions, MeshOptions, OrderOptions, check_options

__all__ = ["sweep", "run_dir_name", "PARAM_ALIASES"]

#: Short names accepted for Params fields.
PARAM_ALIASES = {"dr": "D_r", "Dr": "D_r", "D_r": "D_r", "v0": "v0"}

_SETTINGS = ("param", "value", "params", "steps", "save_every", "relax", "seed")


def _param_name(param):
    from ..simulate import Params

    name = PARAM_ALIASES.get(param, param)
    fields = {f.name for f in dataclasses.fields(Params)}
    if name not in fields:
        raise InputError(f"param {param!r} is not a Params field; expected one of {sorted(fields)} or 'dr'")
    return name


def run_dir_name(name, value):
    """Folder name of one run, e.g. ``D_r=1e-05``."""
    return f"{name}={value:g}" if isinstance(value, (int, float, np.number)) else f"{name}={value}"


def _settings(name, value, params, steps, save_every, relax, seed):
    return {"param": name, "value": value, "params": params.to_dict(), "steps": int(steps),
            "save_every": int(save_every), "relax": int(relax), "seed": int(seed)}


def _store_state(path, settings):
    """State of the run store at ``path``: ``"absent"``, ``"broken"`` (created, never checkpointed),
    ``"partial"`` or ``"finished"``; raises on a settings mismatch or a foreign folder."""
    from ..simulate import read_run

    if not path.exists():
        return "absent"
    try:
        attrs = read_run(path).attrs
    except InputError as exc:  # never overwrite something that is not one of our run stores
        raise InputError(f"{path} exists but is not an MPF run store ({exc}); move it away or use another out "
                         f"folder") from exc
    stored = {"params": dict(attrs["params"]), "save_every": int(attrs["save_every"]), "relax": int(attrs["relax"]),
              "seed": int(attrs["seed"])}
    for key, have in stored.items():
        if have != settings[key]:
            raise InputError(f"{path}: existing run has {key} = {have!r}, the sweep asks for {settings[key]!r}; "
                             f"use another out folder or delete the run")
    if attrs.get("checkpoint") is None:
        return "broken"  # created but never checkpointed: start again
    n_final = settings["steps"] // settings["save_every"] + 1
    return "finished" if int(attrs["n_frames"]) >= n_final and int(attrs["steps"]) == settings["steps"] else "partial"


def _run_one(run_dir, settings, threads, options):
    """Simulate (or resume) and analyse one run; returns its summary dict.  Runs in a worker process."""
    from ..pipeline import analyze
    from ..simulate import Params, run_simulation

    run_dir = Path(run_dir)
    done = run_dir / "done.json"
    if done.exists():
        old = json.loads(done.read_text())
        if {k: old.get(k) for k in _SETTINGS} == settings:
            return dict(old, status="skipped")
    run_dir.mkdir(parents=True, exist_ok=True)
    store = run_dir / "run.zarr"
    state = _store_state(store, settings)
    t0 = time.perf_counter()
    common = dict(steps=settings["steps"], threads=threads, progress=False)
    if state == "partial":
        run_simulation(store, resume=True, **common)
    elif state in ("absent", "broken"):
        run_simulation(store, Params.from_dict(settings["params"]), save_every=settings["save_every"],
                       relax=settings["relax"], seed=settings["seed"], overwrite=state == "broken", **common)
    sim_seconds = time.perf_counter() - t0
    t0 = time.perf_counter()
    # the per-frame progress bar and warnings of a worker would garble the sweep's output: keep them per run
    with open(run_dir / "analysis.log", "a") as log, contextlib.redirect_stderr(log):
        movie = analyze(store, workers=1, **options)
        movie.write(run_dir / "results")
    defects = {} if movie.defects is None else {
        f"p={q}": {"+": int((g["charge"] > 0).sum()), "-": int((g["charge"] < 0).sum())}
        for q, g in movie.defects.groupby("p")}
    out = dict(settings, status={"absent": "new", "broken": "new", "partial": "resumed"}.get(state, "analysed"),
               path=str(store), results=str(run_dir / "results"), n_frames=len(movie),
               sim_seconds=round(sim_seconds, 2), analysis_seconds=round(time.perf_counter() - t0, 2),
               events={k: int(v) for k, v in movie.events["kind"].value_counts().items()}, defects=defects)
    with atomic_path(done) as tmp:
        tmp.write_text(json.dumps(out, indent=2, default=str))
    return out


class _LocalPool:
    def __init__(self, workers):
        import multiprocessing as mp
        from concurrent.futures import ProcessPoolExecutor

        self.pool = ProcessPoolExecutor(max_workers=workers, mp_context=mp.get_context("spawn"))

    def submit(self, *args):
        return self.pool.submit(_run_one, *args)

    def shutdown(self):
        self.pool.shutdown(wait=True, cancel_futures=True)


class _InProcess:
    """workers=1: run the jobs one after the other in this process."""

    class _Job:
        """Runs when first asked whether it is done (so the progress loop drives the jobs in order)."""

        def __init__(self, args):
            self.args, self.value = args, None

        def done(self):
            if self.value is None:
                self.value = _run_one(*self.args)
            return True

        def result(self):
            self.done()
            return self.value

    def submit(self, *args):
        return self._Job(args)

    def shutdown(self):
        pass


class _DaskPool:
    def __init__(self, client):
        self.client = client

    def submit(self, *args):
        return self.client.submit(_run_one, *args, pure=False)

    def shutdown(self):
        pass


def _final_frames(settings):
    return settings["steps"] // settings["save_every"] + 1


def _frames_written(run_dir):
    """Frames committed to a run's store so far (0 while it does not exist or is being created)."""
    from ..simulate import read_run

    try:
        return len(read_run(Path(run_dir) / "run.zarr"))
    except Exception:  # absent, or half-created by a worker right now
        return 0


def _watch(futures, jobs, pbar, poll=2.0):
    """Collect the jobs' results while a progress bar follows the frames simulated by all runs."""
    results, pending = {}, dict(futures)
    with pbar:
        while pending:
            finished = [f for f in list(pending) if f.done()]
            for f in finished:
                results[pending.pop(f)] = f.result()
            frames = sum(min(_frames_written(d), _final_frames(s)) for d, s in jobs)
            pbar.update(frames - pbar.n)
            pbar.set_postfix(runs=f"{len(results)}/{len(jobs)} done", refresh=False)
            if pending and not finished:
                time.sleep(poll)
    return results


def sweep(param="dr", values=(), out="sweep", *, params=None, steps=20_000, save_every=500, relax=10_000, seed=0,
          client=None, workers=None, threads=1, mesh=MeshOptions(), order=OrderOptions(), events=EventOptions(),
          progress=True) -> pd.DataFrame:
    """Run the MPF model for several values of one parameter and analyse each run.

    Parameters
    ----------
    param : str
        A :class:`hexatissue.simulate.Params` field (``"dr"`` is short for ``"D_r"``).
    values : sequence
        Parameter values, one run each.
    out : path
        Sweep folder (see the module docstring for its layout).
    params : Params, optional
        Base parameters (default: the paper's); ``param`` is replaced per run.
    steps, save_every, relax, seed
        Passed to :func:`hexatissue.simulate.run_simulation`: active steps,
        steps per saved frame, passive relaxation steps, seed.  Every run
        uses the same seed (same initial tissue and noise stream), so runs
        differ only by the parameter.
    client : dask.distributed.Client, optional
        Run the jobs on this cluster instead of local processes.
    workers : int, optional
        Local processes (default: ``min(len(values), os.cpu_count())``); 1
        runs everything in this process.
    threads : int or "auto"
        numba threads per simulation.
    mesh, order, events : MeshOptions, OrderOptions, EventOptions
        Options of the analysis of every run (:func:`hexatissue.analyze`;
        MPF ids are consistent, so runs are not tracked).
    progress : bool
        A progress bar of the frames simulated by all runs (polled from
        their stores every 2 s), with the number of finished runs.

    Returns
    -------
    pandas.DataFrame
        One row per run, in the order of ``values``: ``param``, ``value``,
        ``status`` (``new``, ``resumed``, ``analysed`` (simulation was
        complete), ``skipped`` (already done)), ``path`` (run store),
        ``results`` (analysis folder), ``n_frames``, ``sim_seconds``,
        ``analysis_seconds`` (of the call that did the work), ``events``,
        ``defects`` (counts from the analysis summary).
    """
    from ..progress import progress as bar
    from ..simulate import Params

    name = _param_name(param)
    values = list(values)
    if not values:
        raise InputError("values must list at least one parameter value")
    if len({run_dir_name(name, v) for v in values}) != len(values):
        raise InputError(f"values {values} give duplicate run folders; expected distinct values")
    base = Params() if params is None else params
    if not isinstance(base, Params):
        raise InputError(f"params must be a hexatissue.simulate.Params; got {type(base).__name__}")
    options = {"mesh": check_options(mesh, "mesh"), "order": check_options(order, "order"),
               "events": check_options(events, "events")}
    jobs = []
    for v in values:
        p = base.replace(**{name: v})  # validates the value
        jobs.append((str(Path(out) / run_dir_name(name, v)), _settings(name, v, p, steps, save_every, relax, seed)))
    Path(out).mkdir(parents=True, exist_ok=True)
    if client is not None:
        pool = _DaskPool(client)
    else:
        n = min(len(jobs), os.cpu_count() or 1) if workers is None else int(workers)
        if n < 1:
            raise InputError(f"workers must be a positive integer; got {workers!r}")
        pool = _InProcess() if n == 1 else _LocalPool(n)
    try:
        futures = {pool.submit(run_dir, settings, threads, options): run_dir for run_dir, settings in jobs}
        results = _watch(futures, jobs, bar(total=sum(_final_frames(s) for _, s in jobs), unit="frame",
                                            desc=f"{name} sweep", **({} if progress else {"disable": True})))
    finally:
        pool.shutdown()
    rows = [results[run_dir] for run_dir, _ in jobs]
    cols = ["param", "value", "status", "path", "results", "n_frames", "sim_seconds", "analysis_seconds", "events",
            "defects"]
    return pd.DataFrame([{c: r.get(c) for c in cols} for r in rows], columns=cols)
